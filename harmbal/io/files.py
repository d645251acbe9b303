"""Writing result files atomically: a reader never sees half a file, a
failed job leaves nothing behind, and a killed one leaves nothing the next
write does not clean.

Temporaries are named after their target and their writer,
``.NAME.<pid>-<host>.<random>.tmp`` (``<host>``: 8 hex digits of a hash of
the machine's name), beside the target. A write first removes the
temporaries of that same target whose writer, on this machine, is no longer
running (``kill -9``, a power cut): nothing else, and never a file of
another name or of a running process or of another machine. A Zarr store
(a folder) is replaced by one atomic exchange of names where the system has
it (Linux ``renameat2(RENAME_EXCHANGE)``), else by two renames through
``.NAME.<pid>-<host>.<random>.old/NAME``, which the next write or
:func:`restore_interrupted` puts back if the writer was killed between them.
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import shutil
import socket
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

#: Errors that mean the device is full (or the user's quota).
_FULL = {errno.ENOSPC, errno.EDQUOT}
_MIB = 1 << 20


class WriteError(OSError):
    """A result file that could not be written: one line naming the file and
    why (its ``errno`` is the system's); nothing was left behind."""

    def __str__(self) -> str:
        return str(self.strerror)


@contextmanager
def atomic_path(path: Path, directory: bool = False, reserve: int = 0) -> Iterator[Path]:
    """Yield a temporary path next to ``path`` to write to.

    It replaces ``path`` when the block succeeds and is deleted when it
    fails. The file gets the permissions a plainly created file would
    (mkstemp's are private).

    Parameters
    ----------
    path : pathlib.Path
        The target.
    directory : bool, default False
        The temporary path is an empty folder (a Zarr store), and a folder
        already at ``path`` is replaced as a whole.
    reserve : int, default 0
        Bytes [B] of disk to reserve for the temporary file before the block
        runs (an upper bound of what it writes): a full disk is then refused
        before anything is written, and the writer, which must write into the
        file it is given without truncating it, cannot run out of space
        half-way (HDF5 does not recover from that). Reserved space beyond
        what is written is released when the file is truncated or closed.

    Raises
    ------
    WriteError
        For any system error while writing or moving the file into place
        (full disk, no permission …), with a one-line message.
    """
    path = Path(path)
    clean_orphans(path)
    try:
        tmp = _temporary(path, directory, reserve)
    except WriteError:
        raise
    except OSError as exc:
        raise _write_error(path, exc) from exc
    try:
        yield tmp
        if reserve > 0:
            os.truncate(tmp, os.path.getsize(tmp))  # releases what was reserved beyond the end written
        os.chmod(tmp, (0o777 if directory else 0o666) & ~_umask())
        if directory and os.path.lexists(path):
            _replace_folder(tmp, path)
        else:
            os.replace(tmp, path)
    except BaseException as exc:
        _remove(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, WriteError):
            raise _write_error(path, exc) from exc
        raise


def _temporary(path: Path, directory: bool, reserve: int) -> Path:
    prefix = f".{path.name}.{os.getpid()}-{_host()}."
    if directory:
        return Path(tempfile.mkdtemp(prefix=prefix, suffix=".tmp", dir=path.parent))
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=".tmp", dir=path.parent)
    try:
        if reserve > 0:
            _reserve(fd, reserve, path)
    except BaseException:
        os.close(fd)
        os.unlink(tmp)
        raise
    os.close(fd)
    return Path(tmp)


def _reserve(fd: int, nbytes: int, path: Path) -> None:
    """Reserve ``nbytes`` of disk for the file ``fd`` without changing its
    size (Linux ``fallocate(FALLOC_FL_KEEP_SIZE)``), or where the system
    cannot, check that the device has that much free."""
    result = _fallocate_keep_size(fd, nbytes)
    if result == 0:
        return
    if result in _FULL or shutil.disk_usage(path.parent).free < nbytes:
        raise WriteError(errno.ENOSPC, f"{path}: no space left on device for it (needs about "
                                       f"{_mib(nbytes)} MiB, {_mib(shutil.disk_usage(path.parent).free)} MiB free)")


def _fallocate_keep_size(fd: int, nbytes: int) -> int:
    """0 when reserved, else the errno (``ENOSYS`` where there is no ``fallocate``)."""
    libc = _libc()
    if libc is None or not hasattr(libc, "fallocate"):
        return errno.ENOSYS
    import ctypes

    libc.fallocate.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_longlong, ctypes.c_longlong]
    if libc.fallocate(fd, 1, 0, nbytes) == 0:  # 1: FALLOC_FL_KEEP_SIZE
        return 0
    return ctypes.get_errno()


def _write_error(path: Path, exc: OSError) -> WriteError:
    """One line: the target, what went wrong (the system's words), nothing of the temporary's name."""
    if exc.errno in _FULL:
        reason = "no space left on device while writing it"
    else:
        reason = exc.strerror or str(exc) or type(exc).__name__
    return WriteError(exc.errno, f"{path}: {' '.join(str(reason).split())}")


def _mib(nbytes: int) -> str:
    return f"{nbytes / _MIB:.3g}"


def _replace_folder(tmp: Path, path: Path) -> None:
    """Put the folder ``tmp`` at ``path`` in place of what is there, with no
    moment when nothing is at ``path`` where the system can swap two names."""
    if _exchange(tmp, path):
        _remove(tmp)  # now the old store, under the temporary's name
        return
    old = Path(tempfile.mkdtemp(prefix=f".{path.name}.{os.getpid()}-{_host()}.", suffix=".old", dir=path.parent))
    os.replace(path, old / path.name)
    os.replace(tmp, path)
    shutil.rmtree(old, ignore_errors=True)


def _exchange(a: Path, b: Path) -> bool:
    """Swap the names ``a`` and ``b`` atomically (Linux ``renameat2`` with
    ``RENAME_EXCHANGE``); False where the system or the file system cannot."""
    libc = _libc()
    if libc is None or not hasattr(libc, "renameat2"):
        return False
    import ctypes

    libc.renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    at_fdcwd, rename_exchange = -100, 2
    if libc.renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.EPERM):
        return False  # not supported here: two renames instead
    raise OSError(code, os.strerror(code), os.fspath(b))


def _libc():
    if not sys.platform.startswith("linux"):
        return None
    import ctypes

    try:
        return ctypes.CDLL(None, use_errno=True)
    except OSError:
        return None


def clean_orphans(path: Path) -> list[Path]:
    """Remove what killed writes of ``path`` left beside it.

    Only harmbal's temporaries of that target (``.NAME.<pid>-<host>.<random>.tmp``
    or ``.old``) whose writer ran on this machine and is no longer running
    are removed; a store a writer killed between its two renames is first
    put back at ``path`` (:func:`restore_interrupted`).

    Parameters
    ----------
    path : pathlib.Path
        The target whose temporaries to look for.

    Returns
    -------
    list of pathlib.Path
        What was removed.
    """
    path = Path(path)
    restore_interrupted(path)
    removed = []
    for entry in _orphans(path):
        _remove(entry)
        removed.append(entry)
    return removed


def restore_interrupted(path: Path) -> bool:
    """Put back a store that a write killed between its two renames left in
    ``.NAME.<pid>-<host>.<random>.old/NAME`` (only when nothing is at
    ``path`` and that writer is gone).

    Returns
    -------
    bool
        Whether a store was put back.
    """
    path = Path(path)
    if os.path.lexists(path):
        return False
    for entry in _orphans(path):
        kept = entry / path.name
        if entry.name.endswith(".old") and os.path.lexists(kept):
            try:
                os.rename(kept, path)
            except OSError:
                continue  # another process restored it first, or the folder is read-only
            return True
    return False


def _orphans(path: Path) -> list[Path]:
    """harmbal's temporaries of ``path`` whose writer on this machine is gone."""
    pattern = re.compile(rf"\.{re.escape(path.name)}\.(\d+)-{_host()}\.[A-Za-z0-9_]+\.(tmp|old)")
    try:
        names = os.listdir(path.parent)
    except OSError:
        return []
    found = []
    for name in names:
        match = pattern.fullmatch(name)
        if match and not _alive(int(match.group(1))):
            found.append(path.parent / name)
    return sorted(found)


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` runs on this machine (one of another user counts)."""
    if pid == os.getpid() or os.name == "nt":  # Windows' os.kill would end the process, not ask about it
        return True
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True  # someone else's process, or a pid we cannot ask about: keep its files
    return True


def _host() -> str:
    """8 hex digits naming this machine, so that writers on another machine
    sharing the folder are never taken for dead ones of this one."""
    return hashlib.blake2b(socket.gethostname().encode("utf-8", "surrogateescape"), digest_size=4).hexdigest()


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def _umask() -> int:
    mask = os.umask(0o022)  # reading the umask means setting it
    os.umask(mask)
    return mask
