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

Integrity (:mod:`harmbal.io.integrity`). Every array is written through a
checksum filter (HDF5 ``fletcher32``, Zarr ``crc32``), the root attribute
``harmbal_checksum`` holds digests of every group's and variable's metadata
and in-memory values, and a netCDF file ends with the SHA-256 of all its
bytes; :func:`open_archive` checks them all and refuses external storage
and links.

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

import errno
import os
from pathlib import Path

import numpy as np

from ..labelled import (
    CF_CONVENTIONS,
    SPEED_INDEPENDENT,
    SPEED_SCALING,
    Speeds,
    speed_independent_values,
    unit_speed_values,
    with_speed_indexes,
)
from .files import atomic_path, restore_interrupted
from .integrity import (
    CHECKSUM_ATTR,
    TRAILER_SIZE,
    ArchiveError,
    append_file_checksum,
    check_file_checksum,
    checksum_attribute,
    scan_netcdf,
    scan_zarr,
    verify,
)

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


class _Malformed(Exception):
    """A group that does not have the structure harmbal writes (found while decoding it)."""


def _complex_decoded(var):
    import xarray as xr

    attrs, variable = dict(var.attrs), var.variable
    if attrs.pop(_ENCODING_ATTR, None) != _ENCODING:
        return variable
    if variable.sizes.get(PART) != 2:
        raise _Malformed(f"variable {var.name}: {_ENCODING_ATTR} without a '{PART}' dimension of 2 (real, imag)")
    values = variable.transpose(..., PART).values
    return xr.Variable(variable.transpose(..., PART).dims[:-1], values[..., 0] + 1j * values[..., 1], attrs)


def _per_speed(ds, variable, constant) -> tuple:
    """The variable a ``<name>_per_speed_squared`` stores, over ``speed``."""
    attrs = dict(variable.attrs)
    _require_speeds(ds, variable.attrs[_NAME_ATTR] + PER_SPEED_SQUARED, attrs, _UNITS_ATTR)
    name = str(attrs.pop(_NAME_ATTR))
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
    _require_speeds(ds, name, attrs, "units_at_speed")
    del attrs[SPEED_SCALING]
    attrs["units"] = attrs.pop("units_at_speed")
    constant = plain.get(f"{name}{SPEED_INDEPENDENT}")
    return name, Speeds(ds["speed"].values).variable(variable.dims, variable.values, attrs,
                                                     constant=None if constant is None else constant.values)


def _require_speeds(ds, name: str, attrs: dict, units: str) -> None:
    """A variable stored without its speeds needs the group's (or the root's) speed coordinates and its units."""
    if "speed" not in ds.coords or ds["speed"].ndim != 1:
        raise _Malformed(f"variable {name}: stored without its speed dimension, but the archive has no speed "
                         "coordinate for it")
    if units not in attrs:
        raise _Malformed(f"variable {name}: stored without its speed dimension, but has no {units} attribute")


def save(tree, path: str | os.PathLike, *, per_speed_limit: int | None = None) -> Path:
    """Write an analysis tree to a netCDF-4 file (or a Zarr store), atomically.

    The file is first written next to its destination and moved into place
    only when complete, so a failed write leaves no file behind (and a
    killed one a temporary that the next write there removes,
    :mod:`harmbal.io.files`). A netCDF file's disk space is reserved before
    HDF5 writes a byte, so a full disk is refused up front. Every array is
    checksummed, and so is the whole file (:mod:`harmbal.io.integrity`).
    Variables held as dask arrays (a chunked sweep) are evaluated and
    written chunk by chunk, never all in memory.

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

    Raises
    ------
    harmbal.io.files.WriteError
        An ``OSError`` with a one-line message naming ``path`` when it
        cannot be written (full disk, with the size it needs; no permission).
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
    nodes["/"] = nodes["/"].assign_attrs({CHECKSUM_ATTR: checksum_attribute(nodes)})
    encoded = xr.DataTree.from_dict(nodes)
    encoding = {group: {name: _checksum_encoding(var, zarr) for name, var in ds.variables.items()}
                for group, ds in nodes.items()}
    lazy = bool(collections)
    with atomic_path(path, directory=zarr, reserve=0 if zarr else netcdf_size(nodes) + TRAILER_SIZE) as tmp:
        if zarr:
            # Zarr format 2: its fixed-length strings and consolidated metadata are specified (format 3: not yet).
            # Every chunk is written, even one of fill values, so that a missing chunk file shows (integrity).
            # DataTree.to_zarr's overloads take compute only as a literal True or False, not a bool known at run time.
            write = encoded.to_zarr(tmp, mode="w", compute=not lazy, consolidated=True, zarr_format=2,  # type: ignore[call-overload]
                                    encoding=encoding, write_empty_chunks=True)
            computed = _compute(write, collections) if lazy else ()
        else:
            import h5py

            # HDF5 writes into the file atomic_path reserved (a file object: it must not truncate it), so a full
            # disk is refused before it starts: HDF5 cannot recover from running out of space half-way. The
            # HDF5 1.10 format (readable by HDF5 >= 1.10, 2016) indexes a one-chunk array without a B-tree node:
            # checksummed (chunked) small arrays then cost bytes, not kilobytes. Creation order kept for netCDF-C.
            with open(tmp, "r+b") as fh, h5py.File(fh, "w", libver=("v110", "v110"), track_order=True) as h5:
                write = encoded.to_netcdf(h5, engine="h5netcdf", compute=not lazy, encoding=encoding)
                computed = _compute(write, collections) if lazy else ()
            append_file_checksum(tmp)
    return (path, *computed)


def _compute(write, collections) -> tuple:
    import dask

    return dask.compute(write, *collections)[1:]


def _checksum_encoding(variable, zarr: bool) -> dict:
    """Each array through a checksum filter (fletcher32 in HDF5, which needs a
    chunked array of at least one element; crc32 in Zarr); every other
    encoding dropped, so that the file holds exactly the values digested."""
    kind = variable.dtype.kind
    if zarr:
        from numcodecs import CRC32

        return {"filters": [CRC32()]} if kind in "biufcmMUS" else {}
    chunks = _hdf5_chunks(variable)
    return {} if chunks is None else {"fletcher32": True, "chunksizes": chunks}


#: Largest HDF5 chunk [B] of an array held in memory: one chunk up to it (no B-tree, no padding), else slabs.
_CHUNK_BYTES = 1 << 22


def _hdf5_chunks(variable) -> tuple | None:
    """The chunk shape of a checksummed array in HDF5 (None: stored whole,
    unfiltered: strings, scalars, empty arrays). A dask array keeps its
    blocks (each written once, whole); another is one chunk up to 4 MiB,
    else slabs along its leading dimensions."""
    if variable.dtype.kind not in "biufcmM" or not variable.ndim or not variable.size:
        return None
    itemsize = variable.dtype.itemsize
    blocks = getattr(variable, "chunks", None)
    if blocks and np.prod([b[0] for b in blocks]) * itemsize <= 1 << 30:
        return tuple(int(b[0]) for b in blocks)
    chunks, inner = list(variable.shape), itemsize
    for axis in reversed(range(variable.ndim)):  # the trailing dimensions whole as long as they fit
        if inner * variable.shape[axis] > _CHUNK_BYTES:
            count = -(-variable.shape[axis] // max(1, _CHUNK_BYTES // inner))
            chunks[axis] = -(-variable.shape[axis] // count)  # equal slabs: the last one padded by < count rows
            chunks[:axis] = [1] * axis
            break
        inner *= variable.shape[axis]
    return tuple(int(c) for c in chunks)


def netcdf_size(nodes: dict) -> int:
    """An upper bound of the size [B] of the netCDF file of ``nodes`` (group
    path -> encoded Dataset), the space :func:`save` reserves: the values
    with their chunks' padding and 64 B per chunk for its index entry,
    strings at 32 B each beyond their text, the attributes twice, 2 KiB of
    headers per variable (0.3 to 0.9 KiB measured), 64 KiB, and 1/32 of all
    that for free space (the file of a 10⁴-speed V8 is 0.97 of the bound)."""
    total = 1 << 16
    for ds in nodes.values():
        total += 4096 + 2 * _attrs_bytes(ds.attrs)
        for variable in ds.variables.values():
            total += (2 << 10) + 2 * _attrs_bytes(variable.attrs)
            chunks = _hdf5_chunks(variable)
            if variable.dtype.kind == "O":
                total += sum(32 + 4 * len(str(item)) for item in np.ravel(variable.values))
            elif variable.dtype.kind in "US":
                total += variable.size * (32 + variable.dtype.itemsize)
            elif chunks is None:
                total += variable.size * variable.dtype.itemsize
            else:  # whole chunks are stored, the last of each dimension padded, and each has an index entry
                counts = [-(-n // c) for n, c in zip(variable.shape, chunks)]
                total += int(np.prod(counts)) * (int(np.prod(chunks)) * variable.dtype.itemsize + 64)
    return total + total // 32


def _attrs_bytes(attrs) -> int:
    return sum(64 + 4 * len(str(key)) + (4 * len(value) if isinstance(value, str) else np.asarray(value).nbytes)
               for key, value in attrs.items())


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


def _unshare_speeds(nodes: dict, source) -> dict:
    """The groups as :func:`harmbal.analyse` makes them: each with its speed
    coordinates, none in the root."""
    root = nodes["/"]
    root.attrs.pop(_STORAGE_ATTR, None)
    having = root.attrs.pop(_SHARED_ATTR, None)
    if having is None:
        return nodes
    having = set(str(having).split())
    if not having <= set(nodes) or any(name not in root.coords for name in _SPEED_COORDS):
        absent = sorted(having - set(nodes)) or [f"root coordinate {n}" for n in _SPEED_COORDS if n not in root.coords]
        raise ArchiveError(f"{source}: {_SHARED_ATTR} names {', '.join(absent)}, which the archive lacks")
    shared = {name: root[name].variable for name in _SPEED_COORDS}
    root = root.drop_vars(_SPEED_COORDS)
    return {path: root if path == "/" else ds.assign_coords(shared) if path in having else ds
            for path, ds in nodes.items()}


def open_archive(path: str | os.PathLike):
    """Read an archive written by :func:`save` (netCDF, or Zarr if the path
    ends in ``.zarr``): complex values restored, the unit-speed form rebuilt
    over ``speed``, ``rpm`` indexed along ``speed`` (``ds.sel(rpm=3000)``).

    The file is checked before and while it is read: it may not make HDF5
    or Zarr read anything but itself (external storage, virtual datasets,
    links, plugin filters, symbolic links in a store), every array's
    checksum filter and the digests of the root attribute ``harmbal_checksum``
    must match (:mod:`harmbal.io.integrity`). An archive written before
    checksums (no such attribute, no filter) is read unverified: damage to
    its values can go unnoticed. A Zarr store that a killed write left
    beside its path (between the two renames of systems without an atomic
    exchange) is put back first.

    Returns
    -------
    xarray.DataTree
        Loaded into memory (the file is closed).

    Raises
    ------
    FileNotFoundError
        If nothing is at ``path``.
    ArchiveError
        For anything else that keeps it from being read as written: not a
        netCDF-4/HDF5 file (or Zarr store), damaged (naming the group and
        variable where it can), altered, or refused; one line, naming the file.
    """
    path = Path(path)
    zarr = path.suffix == ".zarr"
    if zarr:
        restore_interrupted(path)
    if not os.path.lexists(path):
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), os.fspath(path))
    try:
        return _read(path, zarr)
    except (ArchiveError, MemoryError):
        raise
    except Exception as exc:  # whatever h5py, HDF5, zarr or xarray make of a damaged file: one line, the file named
        raise ArchiveError(f"{path}: not a readable harmbal archive ({_one_line(exc)})") from None


def _read(path: Path, zarr: bool):
    import xarray as xr

    if not zarr:
        check_file_checksum(path)  # every byte, before HDF5 parses any
    checksummed = scan_zarr(path) if zarr else scan_netcdf(path)
    with xr.open_datatree(path, engine="zarr" if zarr else "h5netcdf") as stored:
        groups = {node.path: _loaded(node.to_dataset(inherit=False), node.path, path) for node in stored.subtree}
    verify(groups, path, required=checksummed)
    groups["/"].attrs.pop(CHECKSUM_ATTR, None)
    groups = _unshare_speeds(groups, path)
    nodes = {}
    for group, ds in groups.items():
        try:
            nodes[group] = _decode(ds)
        except _Malformed as exc:
            raise ArchiveError(f"{path}: group {group}: {exc}") from None
    return xr.DataTree.from_dict(nodes)


def _loaded(ds, group: str, source):
    """The group's values read, one variable at a time, so that a checksum
    failure names the variable."""
    for name, variable in ds.variables.items():
        try:
            variable.load()
        except MemoryError:
            raise
        except Exception as exc:
            text = _one_line(exc)
            reason = ("data checksum mismatch (damaged)" if "checksum" in text.lower() or "filter" in text.lower()
                      else f"cannot be read ({text})")
            raise ArchiveError(f"{source}: group {group}, variable {name}: {reason}") from None
    return ds


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 300 else text[:297] + "..."
