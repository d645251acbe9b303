"""harmbal: harmonic-domain balancing analysis of reciprocating machines.

>>> import harmbal as hb
>>> tree = hb.analyse(hb.load_scene("datasets/engines/inline-3.toml"))  # doctest: +SKIP
>>> tree["orders"].ds.moment.sel(order=1)                               # doctest: +SKIP

The public names are loaded on first use, so ``import harmbal`` stays light
(no xarray, scipy or pint until a function needs them).
"""

from ._version import __version__
from .reporting.lazy_imports import defer_when_xarray_is_imported

# xarray, once something imports it, would import dask and pint (0.2-0.3 s) only to learn that no data is a dask
# array or a pint quantity: the checks answer "no" without importing them until they are imported for real.
defer_when_xarray_is_imported()

_EXPORTS = {
    "load_scene": "scene",
    "Scene": "scene",
    "SceneError": "scene",
    "simulate": "views.time",
    "order_spectrum": "views.orders",
    "stars": "views.stars",
    "verify_orders": "views.stars",
    "design": "balance.design",
    "Design": "balance.design",
    "DesignError": "balance.solvers",
    "DesignRequest": "scene.requests",
    "Candidate": "scene.requests",
    "verify": "balance.verify",
    "VerifyError": "balance.verify",
    "VerifyRequest": "scene.requests",
    "joints": "model.mechanism",
    "loads": "views.loads",
    "LeverDesignRequest": "scene.requests",
    "LeverDesign": "balance.lever",
    "LinkageWarning": "scene.elements",
    "AccuracyWarning": "model.sampling",
    "analyse": "analysis",
    "report": "reporting.html",
    "save": "io.archive",
    "open_archive": "io.archive",
    "ArchiveError": "io.archive",
    "Blank": "scene.shapes",
    "Sector": "scene.shapes",
    "Segment": "scene.shapes",
    "Strip": "scene.shapes",
    "Box": "scene.shapes",
    "Disc": "scene.shapes",
    "PointMass": "scene.shapes",
    "size_blank": "balance.counterweights",
    "unbalance_range": "balance.counterweights",
    "fastener_load": "balance.counterweights",
    "clearance": "model.clearance",
    "sweep": "studies.sweep",
    "monte_carlo": "studies.sweep",
    "search": "studies.search",
    "mounts": "views.mounts",
    "design_mounts": "balance.mount_design",
    "mount_monte_carlo": "studies.mount_tolerances",
    "Normal": "studies.sweep",
    "Uniform": "studies.sweep",
    "WeightClasses": "studies.sweep",
}

__all__ = ["__version__", *_EXPORTS]

#: The public names whose results are xarray objects: looking one up registers
#: the ``.harmbal`` accessor on Datasets and DataTrees (:mod:`harmbal.accessor`),
#: so that ``import harmbal`` alone does not import xarray.
_XARRAY_RESULTS = {"simulate", "order_spectrum", "stars", "verify_orders", "design", "Design", "verify", "joints",
                   "loads", "LeverDesign", "analyse", "report", "open_archive", "clearance", "sweep", "monte_carlo",
                   "search", "mounts", "design_mounts", "mount_monte_carlo"}


def __getattr__(name: str):
    if name in _EXPORTS:
        import importlib

        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
        if name in _XARRAY_RESULTS:
            from . import accessor  # noqa: F401  (registers ds.harmbal and tree.harmbal)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'harmbal' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
