"""Keep xarray from importing dask, pint and the other duck-array libraries
when nothing uses them.

xarray checks data against the array types of the libraries it knows
(``array_type("dask")`` whenever a ``Variable`` is made, ``array_type("pint")``
whenever an index is, and cupy, sparse and cubed in places), and the check,
in ``xarray.namedarray.pycompat``, imports the library when it is installed.
For a ``harmbal report`` that is dask.array and pint (which imports dask in
turn, with yaml, jinja2 and psutil): about 0.5 s of CPU for checks that can
only say no, since an array of a library exists only once that library is
imported. :func:`defer_duck_array_imports` puts entries into the checks'
cache that answer "no such array type" until the library is imported by
someone, and xarray's own answer from then on; ``is_dask_collection``
likewise answers False until dask is imported. Chunked sweeps import dask
themselves (harmbal.studies.sweep) and then see the real types.

Only private xarray names are touched, each looked up defensively, and the
entries are checked once installed: xarray's check must answer from them
(``array_type`` gives no types, nothing imported) and xarray's entries must
have no attribute beyond the four the deferred ones answer. With an xarray
that lacks the names or fails the check, the entries are taken out again,
nothing is deferred and xarray behaves as it always did (only slower).
pyproject.toml pins the xarray releases this was tested with.

:func:`defer_when_xarray_is_imported` installs the deferral as soon as any
code imports xarray (``import harmbal`` calls it), so that no command imports
dask or pint through xarray unless they are used.
"""

from __future__ import annotations

import sys

#: The libraries deferred and the module whose import makes their arrays possible.
DEFERRED = {"dask": "dask.array", "pint": "pint", "cupy": "cupy", "sparse": "sparse", "cubed": "cubed"}


def defer_duck_array_imports() -> list[str]:
    """Install the deferred checks into xarray (at most once per library).

    Returns
    -------
    list of str
        The libraries whose check is deferred now (installed by this call or
        an earlier one); a library already imported, or already checked by
        xarray, is left as it is.
    """
    try:
        from xarray.namedarray import pycompat, utils
    except ImportError:
        return []
    cache = getattr(pycompat, "_cached_duck_array_modules", None)
    module_type = getattr(pycompat, "DuckArrayModule", None)
    if not isinstance(cache, dict) or module_type is None:
        return []
    deferred = []
    for name, arrays in DEFERRED.items():
        if isinstance(cache.get(name), _Deferred):
            deferred.append(name)
        elif name not in cache and name not in sys.modules:
            cache[name] = _deferred(module_type, cache, name, arrays)
            deferred.append(name)
    if not _answered_from_cache(pycompat, module_type, deferred):
        for name in deferred:
            if isinstance(cache.get(name), _Deferred):
                del cache[name]
        return []
    collection = getattr(utils, "is_dask_collection", None)
    if "dask" in deferred and collection is not None and not getattr(collection, "_harmbal_deferred", False):
        utils.is_dask_collection = _deferred_collection(collection)
    return deferred


#: The attributes of xarray's DuckArrayModule that the deferred entries answer.
ANSWERED = frozenset({"module", "version", "type", "available"})


def _answered_from_cache(pycompat, module_type, deferred: list[str]) -> bool:
    """Whether xarray answers its array-type checks from the deferred entries: no attribute of its
    entries is left unanswered, and ``array_type`` of each deferred library is empty without importing it."""
    attributes = set(getattr(module_type, "__annotations__", {}))
    if not attributes or not attributes <= ANSWERED:
        return False
    array_type = getattr(pycompat, "array_type", None)
    if array_type is None:
        return False
    for name in deferred:
        if name not in sys.modules and (array_type(name) != () or name in sys.modules):
            return False
    return True


class _Deferred:
    """Marker base of the deferred cache entries."""


def _deferred(module_type, cache: dict, name: str, arrays: str):
    """A cache entry for library ``name`` that imports nothing until module
    ``arrays`` is imported, then hands over to xarray's own entry."""

    class Deferred(module_type, _Deferred):
        def __init__(self):  # no import here: that is the point
            pass

        def _real(self):
            real = module_type(name)
            cache[name] = real
            return real

        @property
        def type(self):
            return self._real().type if arrays in sys.modules else ()

        @property
        def module(self):
            return self._real().module if name in sys.modules else None

        @property
        def available(self):
            return self._real().available if name in sys.modules else False

        @property
        def version(self):
            return self._real().version

    return Deferred()


def _deferred_collection(original):
    """``is_dask_collection`` that is False, without importing dask, until dask is imported."""

    def is_dask_collection(x) -> bool:
        return "dask" in sys.modules and original(x)

    is_dask_collection._harmbal_deferred = True
    return is_dask_collection


def defer_when_xarray_is_imported() -> None:
    """Call :func:`defer_duck_array_imports` right after xarray is imported,
    by whoever imports it, without importing xarray here (it costs a quarter
    second that a command printing tables need not pay).

    If xarray is imported already, the deferral is installed now. Otherwise a
    finder at the front of ``sys.meta_path`` waits for ``import xarray``: it
    leaves finding and loading to the other finders and only wraps the
    loader's ``exec_module`` so that the deferral follows the module's
    execution. The finder removes itself on first use; calling this again
    adds no second one.
    """
    if "xarray" in sys.modules:
        defer_duck_array_imports()
    elif not any(isinstance(finder, _XarrayFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, _XarrayFinder())


class _XarrayFinder:
    """A meta path finder (the protocol, not importlib.abc's class: importing that costs 15 ms) that finds nothing
    itself: it wraps the loader the other finders give xarray."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname != "xarray":
            return None
        import importlib.util

        sys.meta_path.remove(self)  # before find_spec, which would come back here
        spec = importlib.util.find_spec(fullname)
        loader = getattr(spec, "loader", None)
        if loader is None or not hasattr(loader, "exec_module"):
            return spec
        execute = loader.exec_module

        def exec_module(module):
            execute(module)
            defer_duck_array_imports()

        loader.exec_module = exec_module
        return spec
