"""netCDF archives of analysis trees.

A :class:`xarray.DataTree` is written with h5netcdf as one netCDF-4 file, one
group per node (``/scene``, ``/time``, ``/orders`` …), readable as it is by
any netCDF tool: the root group carries the CF ``Conventions`` attribute
(:data:`~harmbal.labelled.CF_CONVENTIONS`), harmbal's own conventions in
prose as ``harmbal_conventions``, and every ``units`` attribute is a string
that both UDUNITS-2 and pint parse.

Complex values. netCDF has no complex type that every reader understands, so
each complex variable is stored as a real variable with a trailing dimension
``part`` = (``real``, ``imag``) and the attribute ``complex_encoding``;
:func:`open_archive` restores it.

Speeds. A variable over several speeds is stored as it is, per speed, with
the ``speed`` [rad/s] and ``rpm`` coordinates in its group, whenever the
ω²-scaled variables of the whole tree total at most :data:`PER_SPEED_LIMIT`
bytes (256 MiB: about 23 000 speeds of the bundled cross-plane V8, 2 400 of
its gas version). A larger sweep (10⁶ speeds) is stored in the unit-speed
form instead: each ω²-scaled variable ``<name>`` is replaced by
``<name>_per_speed_squared`` (its value at 1 rad/s, units × s²/rad²) and,
when the gas adds a part that does not scale with ω², by
``<name>_speed_independent_part``; the attribute ``formula`` of the first
says how to rebuild the per-speed values (``moment = moment_per_speed_squared
* speed**2 + moment_speed_independent_part``), ``per_speed_name`` and
``per_speed_units`` name the variable and its units; the root attribute
``speed_storage`` says which form the file uses. In that form the ``speed``
and ``rpm`` coordinates, the same in every group, are stored once, in the
root group (netCDF-4 groups see their parents' dimensions; the root's
``speed_coordinates_of`` attribute names the groups they belong to).
:func:`open_archive` reads both forms (and the ``speed_scaling`` form of
earlier archives) to the same objects :func:`harmbal.analyse` returns, lazy
ω² products for large sweeps, with ``rpm`` indexed along ``speed``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .files import atomic_path
from ..labelled import (CF_CONVENTIONS, SPEED_INDEPENDENT, SPEED_SCALING, Speeds, speed_independent_values,
                        unit_speed_values, with_speed_indexes)

PART = "part"
_ENCODING_ATTR = "complex_encoding"
_ENCODING = "real and imaginary parts along the last dimension 'part'"
_SPEED_COORDS = ("speed", "rpm")
#: Root attribute naming the groups whose speed coordinates the root holds.
_SHARED_ATTR = "speed_coordinates_of"

#: Largest size [bytes] of the ω²-scaled variables of a tree, multiplied out over its speeds, that an archive
#: stores per speed (2**28 = 256 MiB; a complex value counts 16 bytes); beyond it, the unit-speed form.
PER_SPEED_LIMIT = 1 << 28
#: Suffix of a variable stored in the unit-speed form: its values per squared crank speed (at 1 rad/s).
PER_SPEED_SQUARED = "_per_speed_squared"
#: Suffix of the part of such a variable that does not scale with ω² (the gas loads).
SPEED_INDEPENDENT_PART = "_speed_independent_part"
#: Attributes of the unit-speed form: the name and units of the per-speed variable stored.
_NAME_ATTR, _UNITS_ATTR = "per_speed_name", "per_speed_units"
_LONG_NAME_SUFFIX = ", per squared crank speed (the value at 1 rad/s)"
#: Root attribute of an archive in the unit-speed form.
_STORAGE_ATTR = "speed_storage"
_UNIT_SPEED_STORAGE = ("unit speed: every variable that scales with the squared crank speed is stored as "
                       "<name>_per_speed_squared (see its formula attribute); the speed [rad/s] and rpm coordinates "
                       "are the root group's (see speed_coordinates_of)")


class ArchiveError(ValueError):
    """A file that is not a readable harmbal archive."""


def per_speed_bytes(tree) -> int:
    """What the per-speed form of a tree's archive stores for its ω²-scaled variables.

    Parameters
    ----------
    tree : xarray.DataTree
        From :func:`harmbal.analyse` (or any tree of such Datasets).

    Returns
    -------
    int
        The size [bytes] of the variables that scale with ω², multiplied
        out over the speeds (a complex value counts 16 bytes): :func:`save`
        writes them per speed up to :data:`PER_SPEED_LIMIT`. 0 for one speed.
    """
    return sum(_scaled_bytes(node.to_dataset(inherit=False)) for node in tree.subtree)


def _scaled_bytes(ds) -> int:
    return sum(var.size * var.dtype.itemsize for var in ds.data_vars.values()
               if unit_speed_values(var.variable) is not None)


def _encode(ds, unit_speed: bool):
    """The Dataset as stored: ω²-scaled variables multiplied out (or, with
    ``unit_speed``, replaced by :func:`_unit_speed_form`), complex variables
    as (..., part)."""
    import xarray as xr

    out, changed = {}, False
    for name, var in ds.data_vars.items():
        stored = _unit_speed_form(name, var.variable) if unit_speed else None
        if stored is None:
            stored = {name: _per_speed_values(var.variable)}
        for key, variable in stored.items():
            out[key] = _complex_encoded(variable)
            changed = changed or key != name or out[key] is not var.variable
    if not changed:
        return ds
    coords = {name: ds[name].variable for name in ds.coords}
    if any(v.attrs.get(_ENCODING_ATTR) == _ENCODING for v in out.values()):
        coords[PART] = xr.Variable(PART, ["real", "imag"])
    return xr.Dataset(out, coords, ds.attrs)


def _per_speed_values(variable):
    """An ω²-scaled variable as the values it stands for (at most
    :data:`PER_SPEED_LIMIT` bytes in all; a lazy product multiplied out);
    any other as it is (a dask array stays lazy: a chunked sweep is written
    chunk by chunk)."""
    import xarray as xr

    if unit_speed_values(variable) is None:
        return variable
    return xr.Variable(variable.dims, variable.values, variable.attrs)


def _complex_encoded(variable):
    import xarray as xr

    if not np.iscomplexobj(variable.dtype.type()):
        return variable
    # Variable.concat and .real/.imag keep a dask array lazy.
    encoded = xr.Variable.concat([variable.real, variable.imag], dim=PART).transpose(..., PART)
    return xr.Variable(encoded.dims, encoded.data, {**variable.attrs, _ENCODING_ATTR: _ENCODING})


def _unit_speed_form(name: str, variable) -> dict | None:
    """``<name>_per_speed_squared`` (and ``<name>_speed_independent_part``)
    that store an ω²-scaled variable without its ``speed`` dimension (None
    for any other variable)."""
    import xarray as xr

    unit = unit_speed_values(variable)
    if unit is None:
        return None
    constant = speed_independent_values(variable)
    attrs, units = dict(variable.attrs), variable.attrs.get("units", "1")
    scaled, part = f"{name}{PER_SPEED_SQUARED}", f"{name}{SPEED_INDEPENDENT_PART}"
    attrs.update({"units": per_speed_squared_units(units), _NAME_ATTR: name, _UNITS_ATTR: units,
                  "formula": f"{name} = {scaled} * speed**2" + ("" if constant is None else f" + {part}")})
    if "long_name" in attrs:
        attrs["long_name"] += _LONG_NAME_SUFFIX
    if constant is not None:
        attrs["ancillary_variables"] = part  # CF: the variable that goes with this one
    out = {scaled: xr.Variable(variable.dims[1:], unit, attrs)}
    if constant is not None:
        out[part] = xr.Variable(variable.dims[1:], np.asarray(constant), {
            "units": units, "long_name": f"part of {name} that does not scale with the squared crank speed (gas loads)",
            _NAME_ATTR: name})
    return out


def per_speed_squared_units(units: str) -> str:
    """The units of a value per squared crank speed.

    Parameters
    ----------
    units : str
        The value's units (``"N m"``).

    Returns
    -------
    str
        Those units per (rad/s)² (``"N m s^2/rad^2"``), a string UDUNITS-2
        and pint both parse.
    """
    if units in ("", "1"):
        return "s^2/rad^2"
    return f"({units}) s^2/rad^2" if "/" in units else f"{units} s^2/rad^2"


def _decode(ds):
    """A stored group as :func:`harmbal.analyse` made it: complex values,
    ω²-scaled variables of the unit-speed (or earlier ``speed_scaling``)
    form rebuilt over ``speed``, ``rpm`` indexed."""
    import xarray as xr

    plain = {name: _complex_decoded(var) for name, var in ds.data_vars.items()}
    out = {}
    for name, variable in plain.items():
        if _is_part(name, variable, plain):
            continue  # read with the variable it belongs to
        if name.endswith(PER_SPEED_SQUARED) and _NAME_ATTR in variable.attrs:
            name, variable = _per_speed(ds, variable, plain.get(
                f"{variable.attrs[_NAME_ATTR]}{SPEED_INDEPENDENT_PART}"))
        elif SPEED_SCALING in variable.attrs:
            name, variable = _legacy_per_speed(ds, name, variable, plain)
        out[name] = variable
    coords = {name: ds[name].variable for name in ds.coords if name != PART}
    return with_speed_indexes(xr.Dataset(out, coords, ds.attrs))


def _is_part(name: str, variable, plain: dict) -> bool:
    """Whether ``name`` is the speed-independent part of another variable."""
    if name.endswith(SPEED_INDEPENDENT_PART) and _NAME_ATTR in variable.attrs:
        return True
    base = plain.get(name.removesuffix(SPEED_INDEPENDENT))
    return name.endswith(SPEED_INDEPENDENT) and base is not None and SPEED_SCALING in base.attrs


def _complex_decoded(var):
    import xarray as xr

    attrs, variable = dict(var.attrs), var.variable
    if attrs.pop(_ENCODING_ATTR, None) != _ENCODING:
        return variable
    values = variable.transpose(..., PART).values
    return xr.Variable(variable.transpose(..., PART).dims[:-1], values[..., 0] + 1j * values[..., 1], attrs)


def _per_speed(ds, variable, constant) -> tuple:
    """The variable a ``<name>_per_speed_squared`` stores, over ``speed``."""
    attrs = dict(variable.attrs)
    name = attrs.pop(_NAME_ATTR)
    attrs["units"] = attrs.pop(_UNITS_ATTR)
    for key in ("formula", "ancillary_variables"):
        attrs.pop(key, None)
    if "long_name" in attrs:
        attrs["long_name"] = attrs["long_name"].removesuffix(_LONG_NAME_SUFFIX)
    return name, Speeds(ds["speed"].values).variable(variable.dims, variable.values, attrs,
                                                     constant=None if constant is None else constant.values)


def _legacy_per_speed(ds, name: str, variable, plain: dict) -> tuple:
    """A variable of an archive written before issue 33 (attributes
    ``speed_scaling``, ``units_at_speed``; gas part ``<name>_speed_independent``)."""
    attrs = dict(variable.attrs)
    del attrs[SPEED_SCALING]
    attrs["units"] = attrs.pop("units_at_speed")
    constant = plain.get(f"{name}{SPEED_INDEPENDENT}")
    return name, Speeds(ds["speed"].values).variable(variable.dims, variable.values, attrs,
                                                     constant=None if constant is None else constant.values)


def save(tree, path: str | os.PathLike, *, per_speed_limit: int | None = None) -> Path:
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
    per_speed_limit : int, optional
        Largest size [bytes] of the ω²-scaled variables, multiplied out over
        the speeds, stored per speed (default :data:`PER_SPEED_LIMIT`,
        256 MiB); beyond it the unit-speed form (module docstring). 0 asks
        for the unit-speed form whenever the tree has several speeds.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    return save_and_compute(tree, path, per_speed_limit=per_speed_limit)[0]


def save_and_compute(tree, path: str | os.PathLike, *collections, per_speed_limit: int | None = None) -> tuple:
    """:func:`save`, computing the dask ``collections`` in the same pass as
    the write: what they share with the tree (a chunked sweep's summary and
    its archive) is evaluated once. ``tree``, ``path`` and
    ``per_speed_limit`` as for :func:`save`.

    Returns
    -------
    tuple
        The path written, then each of ``collections`` computed.
    """
    import xarray as xr

    path = Path(path)
    zarr = path.suffix == ".zarr"
    limit = PER_SPEED_LIMIT if per_speed_limit is None else per_speed_limit
    nodes = {node.path: node.to_dataset(inherit=False) for node in tree.subtree}
    unit_speed = sum(map(_scaled_bytes, nodes.values())) > limit
    nodes = {path: _encode(ds, unit_speed) for path, ds in nodes.items()}
    nodes["/"] = nodes["/"].assign_attrs({"Conventions": nodes["/"].attrs.get("Conventions", CF_CONVENTIONS)})
    if unit_speed:
        nodes = _share_speeds(nodes)
    encoded = xr.DataTree.from_dict(nodes)
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
    into the root (a 10⁶-speed sweep's are 16 MB per group), and say in the
    root that the file is in the unit-speed form."""
    having = {path: ds for path, ds in nodes.items() if path != "/" and "speed" in ds.dims}
    root = nodes["/"].assign_attrs({_STORAGE_ATTR: _UNIT_SPEED_STORAGE})
    nodes = {**nodes, "/": root}
    if not having or "speed" in root.variables:
        return nodes
    first = next(iter(having.values()))
    if any(name not in ds.coords or not ds[name].variable.identical(first[name].variable)
           for ds in having.values() for name in _SPEED_COORDS):
        return nodes
    root = root.assign_coords({name: first[name].variable.to_base_variable() for name in _SPEED_COORDS})
    root.attrs[_SHARED_ATTR] = " ".join(having)
    return {path: root if path == "/" else ds.drop_vars(_SPEED_COORDS) if path in having else ds
            for path, ds in nodes.items()}


def _unshare_speeds(nodes: dict) -> dict:
    """The groups as :func:`harmbal.analyse` makes them: each with its speed
    coordinates, none in the root."""
    root = nodes["/"]
    root.attrs.pop(_STORAGE_ATTR, None)
    having = root.attrs.pop(_SHARED_ATTR, None)
    if having is None:
        return nodes
    shared = {name: root[name].variable for name in _SPEED_COORDS}
    root = root.drop_vars(_SPEED_COORDS)
    having = set(having.split())
    return {path: root if path == "/" else ds.assign_coords(shared) if path in having else ds
            for path, ds in nodes.items()}


def open_archive(path: str | os.PathLike):
    """Read an archive written by :func:`save` (netCDF, or Zarr if the path
    ends in ``.zarr``): complex values restored, the unit-speed form rebuilt
    over ``speed``, ``rpm`` indexed along ``speed`` (``ds.sel(rpm=3000)``).

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
