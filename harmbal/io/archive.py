"""netCDF archives of analysis trees.

A :class:`xarray.DataTree` is written with h5netcdf as one netCDF-4 file, one
group per node (``/scene``, ``/time``, ``/orders`` …). netCDF has no complex
type that every reader understands, so each complex variable is stored as a
real variable with a trailing dimension ``part`` = (``real``, ``imag``) and
the attribute ``complex_encoding``; :func:`open_archive` restores it. Any
netCDF tool can read the file as it is.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .files import atomic_path

PART = "part"
_ENCODING_ATTR = "complex_encoding"
_ENCODING = "real and imaginary parts along the last dimension 'part'"


class ArchiveError(ValueError):
    """A file that is not a readable harmbal archive."""


def _encode(ds):
    import xarray as xr

    if not any(np.iscomplexobj(v) for v in ds.data_vars.values()):
        return ds
    out = ds.copy()
    for name, var in ds.data_vars.items():
        if np.iscomplexobj(var):
            stacked = np.stack([var.values.real, var.values.imag], axis=-1)
            out[name] = xr.Variable(var.dims + (PART,), stacked, {**var.attrs, _ENCODING_ATTR: _ENCODING})
    return out.assign_coords({PART: (PART, ["real", "imag"])})


def _decode(ds):
    import xarray as xr

    encoded = [name for name, var in ds.data_vars.items() if var.attrs.get(_ENCODING_ATTR) == _ENCODING]
    if not encoded:
        return ds
    out = ds.copy()
    for name in encoded:
        var = ds[name].variable.transpose(..., PART)
        attrs = {k: v for k, v in var.attrs.items() if k != _ENCODING_ATTR}
        values = var.values[..., 0] + 1j * var.values[..., 1]
        out[name] = xr.Variable(var.dims[:-1], values, attrs)
    return out.drop_vars(PART)


def save(tree, path: str | os.PathLike) -> Path:
    """Write an analysis tree to a netCDF-4 file, atomically.

    The file is first written next to its destination and moved into place
    only when complete, so a failed write leaves no file behind.

    Parameters
    ----------
    tree : xarray.DataTree
        From :func:`harmbal.analyse`.
    path : path-like
        Destination, conventionally ``*.nc``.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    import xarray as xr

    path = Path(path)
    encoded = xr.DataTree.from_dict({node.path: _encode(node.to_dataset(inherit=False))
                                     for node in tree.subtree})
    with atomic_path(path) as tmp:
        encoded.to_netcdf(tmp, engine="h5netcdf")
    return path


def open_archive(path: str | os.PathLike):
    """Read an archive written by :func:`save`, complex values restored.

    Returns
    -------
    xarray.DataTree
        Loaded into memory (the file is closed).

    Raises
    ------
    ArchiveError
        If the file is not a netCDF-4/HDF5 file.
    """
    import xarray as xr

    try:
        with xr.open_datatree(path, engine="h5netcdf") as stored:
            stored.load()
            nodes = {node.path: _decode(node.to_dataset(inherit=False)) for node in stored.subtree}
    except (OSError, ValueError) as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise ArchiveError(f"{path}: not a harmbal netCDF archive ({exc})") from None
    return xr.DataTree.from_dict(nodes)
