"""What an archive may hold, and the checksums that show it is as written.

The whole file. :func:`~harmbal.io.archive.save` appends to a netCDF file
a trailer of :data:`TRAILER_SIZE` bytes, past the end HDF5 records (so that
every netCDF reader ignores it): a marker and the SHA-256 of every byte
before it. :func:`check_file_checksum` verifies it before HDF5 parses
anything: HDF5 does not checksum all its metadata, and a damaged file can
make it fail anywhere or loop (one flipped byte in the global heap made
h5netcdf spin for minutes).

Data. Every array goes through a checksum filter: HDF5's ``fletcher32`` in
a netCDF file (each chunk checked as it is read, by any HDF5 reader),
numcodecs' ``crc32`` in a Zarr store (every chunk written, even one of fill
values, so that a missing chunk shows too).

Metadata, and the values held in memory. The root attribute
:data:`CHECKSUM_ATTR` holds, for every group, a digest (SHA-256, first 128
bits) of its attributes and, for every variable, one of its name,
dimensions, shape, dtype and attributes and one of its values; values
computed chunk by chunk while writing (a dask sweep) have none (``null``:
never all in memory, they rely on the filter). :func:`verify` recomputes
them from what was read, so they hold when the trailer is gone (a tool
rewrote the file) and for Zarr stores. They are digests of the values as
xarray decodes them (strings and NaN in one canonical form).

Refused: anything that makes reading an archive read another file or run
other code: HDF5 external storage, virtual datasets, external and soft links,
filters that need a plugin; symbolic links, devices or pipes in a Zarr store;
and arrays that claim more bytes than the file could hold (a damaged shape
would otherwise allocate them).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import stat
from pathlib import Path

import numpy as np

#: Root attribute with the digests of every group and variable (JSON text).
CHECKSUM_ATTR = "harmbal_checksum"
_ALGORITHM = "sha256-128"
_FORMAT = 1
#: HDF5 filters built into the library (and h5py's lzf): anything else would load a plugin.
_BUILT_IN_FILTERS = {1: "deflate", 2: "shuffle", 3: "fletcher32", 4: "szip", 5: "nbit", 6: "scaleoffset",
                     32000: "lzf"}
_FLETCHER32 = 3
#: The netCDF file's trailer: this marker, the SHA-256 of every byte before it (64 hex digits), a newline.
_TRAILER_MARK = b"\nharmbal archive sha256 "
TRAILER_SIZE = len(_TRAILER_MARK) + 65
#: Deeper than any netCDF file nests; a crafted cycle of hard links ends here.
_MAX_DEPTH = 64
#: An array claiming more than this many times the file's size (plus a MiB) is damaged: harmbal
#: writes no compression, and deflate, the strongest of the others, cannot pack 1024 bytes into one.
_MAX_RATIO = 1024


class ArchiveError(ValueError):
    """A file that is not a readable harmbal archive, or one damaged or
    altered since it was written (one line naming the file and what is wrong)."""


# ---------------------------------------------------------------------------------------------------------------
# Checksums


def checksum_attribute(nodes: dict) -> str:
    """The value of :data:`CHECKSUM_ATTR` for the groups about to be written.

    Parameters
    ----------
    nodes : dict
        Group path -> :class:`xarray.Dataset` exactly as written (encoded).
        Values held as dask arrays get no data digest.

    Returns
    -------
    str
        JSON text: ``{"format", "algorithm", "groups": {path: {"attrs": digest,
        "variables": {name: [metadata digest, data digest or null]}}}}``.
    """
    groups = {path: _group_digests(path, ds, hash_data=lambda name, var: not _is_lazy(var))
              for path, ds in nodes.items()}
    return json.dumps({"format": _FORMAT, "algorithm": _ALGORITHM, "groups": groups}, sort_keys=True,
                      separators=(",", ":"))


def verify(nodes: dict, source, required: bool) -> bool:
    """Check the groups read from ``source`` against their stored digests.

    Parameters
    ----------
    nodes : dict
        Group path -> :class:`xarray.Dataset` as read (loaded).
    source : path-like
        The archive, for messages.
    required : bool
        Whether the file was written with checksums (its arrays have the
        checksum filter): then a missing :data:`CHECKSUM_ATTR` is damage.

    Returns
    -------
    bool
        True if verified; False for an archive written before checksums
        (no attribute, no filter), which is read unverified.

    Raises
    ------
    ArchiveError
        Naming the group and variable whose metadata or data changed, or
        the groups or variables missing or added.
    """
    raw = nodes["/"].attrs.get(CHECKSUM_ATTR) if "/" in nodes else None
    if raw is None:
        if required:
            raise ArchiveError(f"{source}: the {CHECKSUM_ATTR} attribute is missing from a file written with "
                               "checksums: damaged or altered")
        return False
    stored = _parse(raw, source)
    if set(stored) != set(nodes):
        missing, extra = sorted(set(stored) - set(nodes)), sorted(set(nodes) - set(stored))
        raise ArchiveError(f"{source}: groups changed since written" + _missing_and_extra(missing, extra))
    for path, ds in nodes.items():
        _verify_group(path, ds, stored[path], source)
    return True


def _missing_and_extra(missing: list[str], extra: list[str]) -> str:
    """The "; missing: …; not written by harmbal: …" tail of a changed-contents message."""
    return ((f"; missing: {', '.join(missing)}" if missing else "")
            + (f"; not written by harmbal: {', '.join(extra)}" if extra else ""))


def _parse(raw, source) -> dict:
    try:
        value = json.loads(str(raw))
        groups = value["groups"]
        if value.get("format") != _FORMAT or value.get("algorithm") != _ALGORITHM or not isinstance(groups, dict):
            raise ValueError(value.get("format"))
        for group in groups.values():
            if not isinstance(group.get("attrs"), str) or not isinstance(group.get("variables"), dict):
                raise ValueError(group)
            for digests in group["variables"].values():
                if not (isinstance(digests, list) and len(digests) == 2 and isinstance(digests[0], str)
                        and isinstance(digests[1], (str, type(None)))):
                    raise ValueError(digests)
        return groups
    except (ValueError, TypeError, KeyError, AttributeError):
        raise ArchiveError(f"{source}: the {CHECKSUM_ATTR} attribute is damaged (or of a newer harmbal)") from None


def _verify_group(path: str, ds, stored: dict, source) -> None:
    where = f"{source}: group {path}"
    variables = stored["variables"]
    if set(variables) != set(ds.variables):
        missing, extra = sorted(set(variables) - set(ds.variables)), sorted(set(ds.variables) - set(variables))
        raise ArchiveError(f"{where}: variables changed since written" + _missing_and_extra(missing, extra))
    digests = _group_digests(path, ds, hash_data=lambda name, var: variables[name][1] is not None)
    if digests["attrs"] != stored["attrs"]:
        raise ArchiveError(f"{where}: attributes changed since written (checksum mismatch)")
    for name, (meta, data) in digests["variables"].items():
        want = variables[name]
        if meta != want[0]:
            raise ArchiveError(f"{where}, variable {name}: metadata (dimensions, shape, dtype or attributes) changed "
                               "since written (checksum mismatch)")
        if data != want[1]:
            raise ArchiveError(f"{where}, variable {name}: data checksum mismatch (damaged or altered)")


def _group_digests(path: str, ds, hash_data) -> dict:
    attrs = {k: v for k, v in ds.attrs.items() if not (path == "/" and k == CHECKSUM_ATTR)}
    variables = {}
    for name, variable in ds.variables.items():
        meta = _digest(name, list(variable.dims), [int(n) for n in variable.shape], _dtype_name(variable.dtype),
                       _canonical_attrs(variable.attrs))
        variables[name] = [meta, _data_digest(variable.values) if hash_data(name, variable) else None]
    return {"attrs": _digest(_canonical_attrs(attrs)), "variables": variables}


def _is_lazy(var) -> bool:
    """Whether the values are computed while writing (a dask array), not held in memory."""
    return hasattr(var.data, "__dask_graph__")


def _digest(*parts) -> str:
    text = json.dumps(parts, ensure_ascii=False, allow_nan=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:32]


def _dtype_name(dtype) -> str:
    """The dtype as compared: strings of any storage as one kind (a reader
    gets variable-length strings back as objects)."""
    return "str" if dtype.kind in "USO" else dtype.str


def _canonical_attrs(attrs) -> list:
    """Attributes as compared: netCDF stores every attribute as a 1-D array,
    so a scalar and a list of one are the same; strings as text."""
    out = []
    for key in sorted(attrs, key=str):
        value = np.asarray(attrs[key])
        if value.dtype.kind in "USO":
            out.append([str(key), "str", [_text(v) for v in value.ravel().tolist()]])
        else:
            out.append([str(key), value.dtype.kind, value.ravel().tolist()])
    return out


def _text(value) -> str:
    return value.decode("utf-8", "surrogateescape") if isinstance(value, bytes) else str(value)


def _data_digest(values) -> str:
    h = hashlib.sha256()
    values = np.asarray(values)
    if values.dtype.kind in "USO":
        for item in values.ravel().tolist():
            text = _text(item).encode("utf-8", "surrogatepass")
            h.update(len(text).to_bytes(8, "little"))
            h.update(text)
        return h.hexdigest()[:32]
    if values.dtype.kind in "fc" and np.isnan(values).any():
        values = np.where(np.isnan(values), np.nan, values)  # one NaN, whatever payload a reader gives it
    if values.dtype.kind in "Mm":
        values = values.astype(f"{values.dtype.kind}8[ns]").view("i8")
    # numpy types ndarray as a Buffer only for Python >= 3.12 (PEP 688); it has the buffer protocol anyway.
    h.update(np.ascontiguousarray(values).view(np.uint8).ravel() if values.size else b"")  # type: ignore[arg-type]
    return h.hexdigest()[:32]


# ---------------------------------------------------------------------------------------------------------------
# The whole netCDF file


def append_file_checksum(path) -> None:
    """Append :data:`TRAILER_SIZE` bytes after the end of the HDF5 file at
    ``path``: a marker and the SHA-256 of every byte before it. HDF5 (and so
    netCDF-C, h5py, xarray) ignores bytes past the end it records."""
    digest = _file_digest(path, os.path.getsize(path))
    with open(path, "ab") as fh:
        fh.write(_TRAILER_MARK + digest.encode("ascii") + b"\n")


def check_file_checksum(path) -> bool:
    """Check the trailer :func:`append_file_checksum` wrote, before HDF5
    parses the file (HDF5 can hang or fail anywhere on damaged metadata
    that it does not checksum itself).

    Returns
    -------
    bool
        True if the file has the trailer and every byte matches; False if it
        has none (an earlier archive, one whose trailer a tool rewriting
        the file dropped, or the trailer itself damaged: the other checks
        still apply).

    Raises
    ------
    ArchiveError
        If the bytes changed since written.
    """
    size = os.path.getsize(path)
    if size < TRAILER_SIZE:
        return False
    with open(path, "rb") as fh:
        fh.seek(size - TRAILER_SIZE)
        trailer = fh.read(TRAILER_SIZE)
    digest = trailer[len(_TRAILER_MARK):-1]
    if not (trailer.startswith(_TRAILER_MARK) and trailer.endswith(b"\n") and re.fullmatch(rb"[0-9a-f]{64}", digest)):
        return False
    if _file_digest(path, size - TRAILER_SIZE) != digest.decode("ascii"):
        raise ArchiveError(f"{path}: file checksum mismatch: damaged or altered since written")
    return True


def _file_digest(path, nbytes: int) -> str:
    h = hashlib.sha256()
    block = bytearray(1 << 20)
    view = memoryview(block)
    with open(path, "rb", buffering=0) as fh:
        while nbytes > 0:
            got = fh.readinto(view[:min(nbytes, len(block))])
            if not got:
                break
            h.update(view[:got])
            nbytes -= got
    return h.hexdigest()


# ---------------------------------------------------------------------------------------------------------------
# What a file may contain


def scan_netcdf(path) -> bool:
    """Refuse an HDF5 file that would make a reader touch anything but itself.

    Parameters
    ----------
    path : path-like
        The netCDF-4 file.

    Returns
    -------
    bool
        Whether its arrays carry the ``fletcher32`` checksum (a file
        written by a harmbal with checksums).

    Raises
    ------
    ArchiveError
        For an external or soft link, external storage, a virtual dataset, a
        filter that needs a plugin, or an array larger than the file could
        hold; or a file HDF5 cannot open.
    """
    import h5py

    limit = _MAX_RATIO * os.path.getsize(path) + (1 << 20)
    with h5py.File(path, "r") as f:
        found: list = []
        _scan_group(f, "", path, limit, found, depth=0)
    return any(found)


def _scan_group(group, prefix: str, source, limit: int, found: list, depth: int) -> None:
    import h5py

    if depth > _MAX_DEPTH:
        raise ArchiveError(f"{source}: groups nested more than {_MAX_DEPTH} deep (a cycle of links?)")
    for name in group:
        where = f"{prefix}/{name}"
        link = group.get(name, getlink=True)
        if isinstance(link, h5py.ExternalLink):
            raise ArchiveError(f"{source}: {where} is an external link to {link.filename}:{link.path}; "
                               "an archive holds its data itself")
        if not isinstance(link, h5py.HardLink):
            raise ArchiveError(f"{source}: {where} is a {type(link).__name__}; an archive holds no links")
        obj = group[name]
        if isinstance(obj, h5py.Group):
            _scan_group(obj, where, source, limit, found, depth + 1)
        elif isinstance(obj, h5py.Dataset):
            found.append(_scan_dataset(obj, where, source, limit))


def _scan_dataset(dataset, where: str, source, limit: int) -> bool:
    if dataset.is_virtual:
        raise ArchiveError(f"{source}: {where} is a virtual dataset (data in other files); an archive holds its data "
                           "itself")
    if dataset.external:
        raise ArchiveError(f"{source}: {where} keeps its data in an external file ({dataset.external[0][0]!s}); "
                           "an archive holds its data itself")
    plist = dataset.id.get_create_plist()
    codes = [plist.get_filter(i)[0] for i in range(plist.get_nfilters())]
    unknown = [code for code in codes if code not in _BUILT_IN_FILTERS]
    if unknown:
        raise ArchiveError(f"{source}: {where} needs HDF5 filter {unknown[0]}, a plugin harmbal does not load")
    nbytes = math.prod(dataset.shape or ()) * dataset.dtype.itemsize
    if nbytes > limit:
        raise ArchiveError(f"{source}: {where} claims {nbytes / (1 << 20):.3g} MiB, more than the file can hold "
                           "(damaged)")
    return _FLETCHER32 in codes


def scan_zarr(path) -> bool:
    """Refuse a Zarr store holding anything but plain files and folders, or
    missing a chunk of a checksummed array.

    Parameters
    ----------
    path : path-like
        The store (a folder).

    Returns
    -------
    bool
        Whether its arrays carry the ``crc32`` filter (written with checksums).

    Raises
    ------
    ArchiveError
        For a symbolic link (which could point out of the store), a device,
        pipe or socket, a missing chunk, or a store that is not a folder.
    """
    root = Path(path)
    if not root.is_dir():
        raise ArchiveError(f"{path}: not a Zarr store (a folder)")
    checksummed = False
    for folder, dirs, files in os.walk(root, followlinks=False):
        for name in dirs + files:
            mode = os.lstat(os.path.join(folder, name)).st_mode
            if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
                kind = "a symbolic link" if stat.S_ISLNK(mode) else "not a plain file"
                where = Path(folder, name).relative_to(root)
                raise ArchiveError(f"{path}: {where} is {kind}; a store holds its data itself")
        if ".zarray" in files:
            checksummed = _check_chunks(Path(folder), root, path) or checksummed
    return checksummed


def _check_chunks(folder: Path, root: Path, source) -> bool:
    """Whether the array in ``folder`` has the crc32 filter; then all its chunks must be there."""
    meta = json.loads((folder / ".zarray").read_text(encoding="utf-8"))
    filters = meta.get("filters") or []
    if not any(isinstance(f, dict) and f.get("id") == "crc32" for f in filters):
        return False
    shape, chunks = meta["shape"], meta["chunks"]
    expected = math.prod(-(-int(n) // int(c)) for n, c in zip(shape, chunks)) if all(shape) else 0
    present = sum(1 for _, _, files in os.walk(folder) for name in files if not name.startswith("."))
    if present < expected:
        where = "/" + folder.relative_to(root).as_posix()
        raise ArchiveError(f"{source}: {where}: {expected - present} of {expected} chunks missing (damaged)")
    return True
