"""harmbal's version and, when it runs from a git checkout, the commit of its sources.

``__version__`` stays a literal: the build reads it without importing the package.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

__version__ = "0.1.0"

#: A full git object name: SHA-1 (40 hex digits) or SHA-256 (64).
_OBJECT_NAME = re.compile(r"[0-9a-f]{40}(?:[0-9a-f]{24})?")

#: The project table of harmbal's own pyproject.toml.
_HARMBAL_PROJECT = re.compile(r'^name\s*=\s*"harmbal"', re.M)

#: What archives and reports say when the source revision is not known.
UNKNOWN_REVISION = "unknown"


def source_revision(root: str | Path | None = None) -> str:
    """The git commit of the source tree harmbal runs from, read from the
    files of its ``.git`` folder (git itself is not needed).

    Parameters
    ----------
    root : path-like, optional
        The folder holding ``.git`` and harmbal's ``pyproject.toml``; default
        the one above the ``harmbal`` package (the repository root of a
        checkout or an editable install).

    Returns
    -------
    str
        The full commit name (hex) of HEAD, or :data:`UNKNOWN_REVISION` when
        harmbal does not run from a git checkout of its sources (an installed
        wheel, a copy inside another project) or the checkout cannot be read.
        Uncommitted changes are not detected.
    """
    root = Path(__file__).resolve().parent.parent if root is None else Path(root)
    return _revision(str(root))


@functools.lru_cache(maxsize=8)
def _revision(root: str) -> str:
    try:
        # The checkout must be harmbal's own, not a project that happens to hold a copy of the package.
        if not _HARMBAL_PROJECT.search((Path(root) / "pyproject.toml").read_text(encoding="utf-8")):
            return UNKNOWN_REVISION
        git = _git_dir(Path(root) / ".git")
        if git is None:
            return UNKNOWN_REVISION
        return _resolve(git, (git / "HEAD").read_text(encoding="utf-8").strip()) or UNKNOWN_REVISION
    except (OSError, UnicodeDecodeError):
        return UNKNOWN_REVISION


def _git_dir(dot_git: Path) -> Path | None:
    """The git folder of a checkout: ``.git`` itself, or the folder a
    ``.git`` file names (``gitdir: …``, in worktrees and submodules)."""
    if dot_git.is_dir():
        return dot_git
    if dot_git.is_file():
        text = dot_git.read_text(encoding="utf-8").strip()
        if text.startswith("gitdir:"):
            return (dot_git.parent / text.removeprefix("gitdir:").strip()).resolve()
    return None


def _resolve(git: Path, head: str) -> str | None:
    """The commit ``head`` (the text of HEAD) names: a detached commit, or a
    branch's ref file, or its line in ``packed-refs`` (looked up in the
    common folder of a worktree too)."""
    if _OBJECT_NAME.fullmatch(head):
        return head
    if not head.startswith("ref:"):
        return None
    ref = head.removeprefix("ref:").strip()
    common = git
    if (git / "commondir").is_file():
        common = (git / (git / "commondir").read_text(encoding="utf-8").strip()).resolve()
    for folder in dict.fromkeys((git, common)):
        if (folder / ref).is_file():
            name = (folder / ref).read_text(encoding="utf-8").strip()
            return name if _OBJECT_NAME.fullmatch(name) else None
    packed = common / "packed-refs"
    if packed.is_file():
        for line in packed.read_text(encoding="utf-8").splitlines():
            name, _, label = line.partition(" ")
            if label.strip() == ref and _OBJECT_NAME.fullmatch(name):
                return name
    return None
