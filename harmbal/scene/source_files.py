"""Reading the files a scene names, safely: the scene file itself and its
measured pressure traces (``[gas.trace] file``).

A file is read only if it is a regular file (a FIFO would block the open, a
device such as ``/dev/zero`` never ends, a directory is no file) of at most a
size limit, decoded as UTF-8 with or without a byte-order mark. The check is
made before the file is opened, and again on the open file (opened without
blocking), so that a FIFO put in its place in between cannot block either.

Trace files are resolved relative to the scene's folder, symbolic links and
``..`` followed, and must lie inside that folder's tree or inside a folder
the user allows: :data:`TRACE_ROOTS_VARIABLE` in the environment, or the
``trace_roots`` argument of :func:`harmbal.load_scene`. The rules are in
docs/scenes.md, "Validation".
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable
from pathlib import Path

#: Largest trace file read [bytes]: 200 000 rows of angle and pressure fit many times over.
MAX_TRACE_BYTES = 16 << 20
#: The environment variable naming further folders trace files may lie in (separated by ``os.pathsep``).
TRACE_ROOTS_VARIABLE = "HARMBAL_TRACE_ROOTS"


class FileRefused(ValueError):
    """A file that is not read; the message says why and what to do (it never holds the file's content)."""


def read_regular(path: Path, limit: int, what: str) -> str:
    """The text of the regular file ``path``, at most ``limit`` bytes, in UTF-8
    (a leading byte-order mark dropped); ``what`` names the kind of file in
    messages ("a scene file (.toml)").

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    FileRefused
        If it is not a regular file, is larger than ``limit``, is not UTF-8 or cannot be read.
    """
    status = os.stat(path)  # FileNotFoundError as documented
    _check_regular(status.st_mode, what)
    if status.st_size > limit:
        raise FileRefused(f"is larger than {_size(limit)}: not {what}")
    try:
        # O_NONBLOCK: should a FIFO have taken the file's place since the check, opening it does not block.
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except OSError as exc:
        raise FileRefused(f"cannot be opened ({exc.strerror or exc})") from None
    with os.fdopen(descriptor, "rb") as file:
        _check_regular(os.fstat(file.fileno()).st_mode, what)
        try:
            raw = file.read(limit + 1)
        except OSError as exc:
            raise FileRefused(f"cannot be read ({exc.strerror or exc})") from None
    if len(raw) > limit:
        raise FileRefused(f"is larger than {_size(limit)}: not {what}")
    try:
        return raw.decode("utf-8-sig")  # a byte-order mark, as some editors write, is not part of the text
    except UnicodeDecodeError as exc:
        raise FileRefused(f"is not UTF-8 text (byte {exc.start + 1} cannot be decoded): save it as UTF-8") from None


def _check_regular(mode: int, what: str) -> None:
    if not stat.S_ISREG(mode):
        kind = "a directory" if stat.S_ISDIR(mode) else "not a regular file (a FIFO, device or socket)"
        raise FileRefused(f"is {kind}: give the path of {what}")


def _size(limit: int) -> str:
    return f"{limit >> 20} MiB" if limit >= 1 << 20 else f"{limit >> 10} KiB"


def trace_roots(extra: Iterable[str | os.PathLike] | None = None) -> tuple[Path, ...]:
    """The folders, besides the scene's own, that trace files may lie in:
    those of :data:`TRACE_ROOTS_VARIABLE` and ``extra``, resolved."""
    listed = [p for p in os.environ.get(TRACE_ROOTS_VARIABLE, "").split(os.pathsep) if p.strip()]
    return tuple(Path(p).expanduser().resolve() for p in [*listed, *(extra or ())])


def resolve_trace(name: str, base: Path, roots: tuple[Path, ...]) -> Path:
    """The path of the trace file written ``name`` in a scene whose folder is
    ``base``: relative to ``base``, links and ``..`` followed, inside
    ``base`` or one of ``roots``.

    Raises
    ------
    FileNotFoundError
        If it does not exist.
    FileRefused
        If it lies outside those folders (it is then not opened) or cannot
        be resolved; the message follows the path ("lies outside ...").
    """
    written = Path(name).expanduser()
    path = written if written.is_absolute() else base / written
    try:
        resolved = path.resolve(strict=True)  # follows links without opening anything
    except FileNotFoundError:
        raise
    except (OSError, RuntimeError) as exc:  # a loop of links, a component that is no folder
        raise FileRefused(f"cannot be resolved ({getattr(exc, 'strerror', None) or exc})") from None
    folder = base.resolve()
    if any(resolved.is_relative_to(root) for root in (folder, *roots)):
        return resolved
    shown = f"(which is {resolved}) " if resolved != path.absolute() else ""
    raise FileRefused(
        f"{shown}lies outside the scene's folder {folder}: a trace file must be in the scene's folder or below "
        f"it. Copy it there, or allow its folder: set the environment variable {TRACE_ROOTS_VARIABLE} to it "
        f"(folders separated by {os.pathsep!r}) or pass trace_roots=[...] to harmbal.load_scene")
