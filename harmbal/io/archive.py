"""netCDF archives of analysis trees.

A :class:`xarray.DataTree` is written with h5netcdf as one netCDF-4 file, one
group per node (``/scene``, ``/time``, ``/orders`` …). netCDF has no complex
type that every reader understands, so each complex variable is stored as a
real variable with a trailing dimension ``part`` = (``real``, ``imag``) and
the attribute ``complex_encoding``; :func:`open_archive` restores it. A
variable of a speed sweep is the unit-speed array times ω² (see
:mod:`harmbal.labelled`): it is stored once, at 1 rad/s, without the
``speed`` dimension, with units multiplied by s² and the attributes
``speed_scaling`` (how to get the value at a speed: times speed², the
``speed`` coordinate in rad/s) and ``units_at_speed``; :func:`open_archive`
restores the lazy per-speed variable. The ``speed`` and ``rpm`` coordinates
of a sweep, the same in every group, are stored once, in the root group
(netCDF-4 groups see their parents' dimensions and xarray's DataTree
inherits the root's coordinates; the root's ``speed_coordinates_of``
attribute names the groups they belong to). Any netCDF tool can read the file as it is.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .files import atomic_path
from ..labelled import (SPEED_INDEPENDENT, SPEED_SCALING, SPEED_SCALING_RULE, Speeds, speed_independent_values,
                        unit_speed_values)

PART = "part"
_ENCODING_ATTR = "complex_encoding"
_ENCODING = "real and imaginary parts along the last dimension 'part'"
_UNITS_AT_SPEED = "units_at_speed"
_SPEED_COORDS = ("speed", "rpm")
#: Root attribute naming the groups whose speed coordinates the root holds.
_SHARED_ATTR = "speed_coordinates_of"


class ArchiveError(ValueError):
    """A file that is not a readable harmbal archive."""


def _encode(ds):
    """Complex variables as (..., part); lazily speed-scaled variables as
    their unit-speed array, without the ``speed`` dimension (and their
    speed-independent part, if any, beside them)."""
    import xarray as xr

    out = {}
    for name, var in ds.data_vars.items():
        for stored, variable, attrs in _unscaled(name, var.variable, dict(var.attrs)):
            if np.iscomplexobj(variable.dtype.type()):
                # Variable.concat and .real/.imag keep a dask array lazy: a chunked sweep is written chunk by chunk.
                variable = xr.Variable.concat([variable.real, variable.imag], dim=PART).transpose(..., PART)
                attrs[_ENCODING_ATTR] = _ENCODING
            if variable is not var.variable:
                out[stored] = xr.Variable(variable.dims, variable.data, attrs)
    if not out:
        return ds
    encoded = ds.assign(out)
    return encoded.assign_coords({PART: (PART, ["real", "imag"])}) if any(
        v.attrs.get(_ENCODING_ATTR) == _ENCODING for v in out.values()) else encoded


def _unscaled(name: str, variable, attrs: dict):
    """The variables that store ``variable``: itself, or its unit-speed array
    with units × s² and the rule to scale it, plus its speed-independent part."""
    import xarray as xr

    unit = unit_speed_values(variable)
    if unit is None:
        return [(name, variable, attrs)]
    units = attrs.get("units", "1")
    constant = speed_independent_values(variable)
    rule = SPEED_SCALING_RULE if constant is None else f"{SPEED_SCALING_RULE} plus {name}{SPEED_INDEPENDENT}"
    scaled = (name, xr.Variable(variable.dims[1:], unit),
              {**attrs, "units": f"{units} s2" if units != "1" else "s2", SPEED_SCALING: rule, _UNITS_AT_SPEED: units})
    if constant is None:
        return [scaled]
    return [scaled, (f"{name}{SPEED_INDEPENDENT}", xr.Variable(variable.dims[1:], np.array(constant)),
                     {"units": units, "long_name": f"speed-independent part (gas loads) of {name}"})]


def _decode(ds):
    import xarray as xr

    plain = {}
    for name, var in ds.data_vars.items():
        attrs, variable = dict(var.attrs), var.variable
        if attrs.pop(_ENCODING_ATTR, None) == _ENCODING:
            variable = variable.transpose(..., PART)
            variable = xr.Variable(variable.dims[:-1], variable.values[..., 0] + 1j * variable.values[..., 1])
        plain[name] = (variable, attrs)
    companions = {n for n in plain if n.endswith(SPEED_INDEPENDENT) and n[: -len(SPEED_INDEPENDENT)] in plain}
    out = {}
    for name, (variable, attrs) in plain.items():
        if name in companions:
            continue
        if attrs.pop(SPEED_SCALING, None) is not None:
            attrs["units"] = attrs.pop(_UNITS_AT_SPEED)
            constant = plain.get(f"{name}{SPEED_INDEPENDENT}")
            variable = Speeds(ds["speed"].values).variable(
                variable.dims, variable.values, attrs, constant=None if constant is None else constant[0].values)
        if variable is not ds[name].variable:
            out[name] = xr.Variable(variable.dims, variable._data, attrs)
    if not out and not companions:
        return ds
    decoded = ds.drop_vars(list(out) + sorted(companions)).assign(out)
    decoded = decoded[[n for n in ds.data_vars if n not in companions]]  # keep the stored order of variables
    return decoded.drop_vars(PART) if PART in decoded.coords else decoded


def save(tree, path: str | os.PathLike) -> Path:
    """Write an analysis tree to a netCDF-4 file (or a Zarr store), atomically.

    The file is first written next to its destination and moved into place
    only when complete, so a failed write leaves no file behind. Variables
    held as dask arrays (a chunked sweep) are evaluated and written chunk by
    chunk, never all in memory.

    Parameters
    ----------
    tree : xarray.DataTree
        From :func:`harmbal.analyse`.
    path : path-like
        Destination: ``*.nc`` for netCDF-4, ``*.zarr`` for a Zarr store (a
        folder; needs the ``zarr`` package, in the ``dask`` extra).

    Returns
    -------
    pathlib.Path
        The path written.
    """
    return save_and_compute(tree, path)[0]


def save_and_compute(tree, path: str | os.PathLike, *collections) -> tuple:
    """:func:`save`, computing the dask ``collections`` in the same pass as
    the write: what they share with the tree (a chunked sweep's summary and
    its archive) is evaluated once.

    Returns
    -------
    tuple
        The path written, then each of ``collections`` computed.
    """
    import xarray as xr

    path = Path(path)
    zarr = path.suffix == ".zarr"
    encoded = xr.DataTree.from_dict(_share_speeds({node.path: _encode(node.to_dataset(inherit=False))
                                                   for node in tree.subtree}))
    with atomic_path(path, directory=zarr) as tmp:
        lazy = bool(collections)
        if zarr:
            # Zarr format 2: its fixed-length strings and consolidated metadata are specified (format 3: not yet).
            write = encoded.to_zarr(tmp, mode="w", compute=not lazy, consolidated=True, zarr_format=2)
        else:
            write = encoded.to_netcdf(tmp, engine="h5netcdf", compute=not lazy)
        computed = ()
        if lazy:
            import dask

            computed = dask.compute(write, *collections)[1:]
    return (path, *computed)


def _share_speeds(nodes: dict) -> dict:
    """Move the sweep's speed coordinates, equal in every group that has them,
    into the root (a 10⁶-speed sweep's are 16 MB per group)."""
    having = {path: ds for path, ds in nodes.items() if path != "/" and "speed" in ds.dims}
    if not having or "speed" in nodes["/"].variables:
        return nodes
    first = next(iter(having.values()))
    if any(name not in ds.coords or not ds[name].variable.identical(first[name].variable)
           for ds in having.values() for name in _SPEED_COORDS):
        return nodes
    root = nodes["/"].assign_coords({name: first[name].variable for name in _SPEED_COORDS})
    root.attrs[_SHARED_ATTR] = " ".join(having)
    return {path: root if path == "/" else ds.drop_vars(_SPEED_COORDS) if path in having else ds
            for path, ds in nodes.items()}


def _unshare_speeds(nodes: dict) -> dict:
    """The groups as :func:`harmbal.analyse` makes them: each with its speed
    coordinates, none in the root."""
    root = nodes["/"]
    having = root.attrs.get(_SHARED_ATTR)
    if having is None:
        return nodes
    shared = {name: root[name].variable for name in _SPEED_COORDS}
    root = root.drop_vars(_SPEED_COORDS)
    del root.attrs[_SHARED_ATTR]
    having = set(having.split())
    return {path: root if path == "/" else ds.assign_coords(shared) if path in having else ds
            for path, ds in nodes.items()}


def open_archive(path: str | os.PathLike):
    """Read an archive written by :func:`save` (netCDF, or Zarr if the path
    ends in ``.zarr``), complex values restored.

    Returns
    -------
    xarray.DataTree
        Loaded into memory (the file is closed).

    Raises
    ------
    ArchiveError
        If the file is not a netCDF-4/HDF5 file (or a Zarr store).
    """
    import xarray as xr

    engine = "zarr" if Path(path).suffix == ".zarr" else "h5netcdf"
    try:
        with xr.open_datatree(path, engine=engine) as stored:
            stored.load()
            groups = _unshare_speeds({node.path: node.to_dataset(inherit=False) for node in stored.subtree})
            nodes = {path: _decode(ds) for path, ds in groups.items()}
    except (OSError, ValueError) as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise ArchiveError(f"{path}: not a harmbal netCDF archive ({exc})") from None
    return xr.DataTree.from_dict(nodes)
