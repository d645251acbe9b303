"""harmbal: harmonic-domain balancing analysis of reciprocating machines.

>>> import harmbal as hb
>>> tree = hb.analyse(hb.load_scene("datasets/engines/inline-3.toml"))  # doctest: +SKIP
>>> tree["orders"].ds.moment.sel(order=1)                               # doctest: +SKIP

The public names are loaded on first use, so ``import harmbal`` stays light
(no xarray, scipy or pint until a function needs them).
"""

from ._version import __version__

_EXPORTS = {
    "load_scene": "scene",
    "Scene": "scene",
    "SceneError": "scene",
    "simulate": "timedomain",
    "order_spectrum": "orders",
    "stars": "crank_stars",
    "verify_orders": "crank_stars",
    "design": "balance_design",
    "Design": "balance_design",
    "DesignError": "balance_design",
    "DesignRequest": "design_spec",
    "Candidate": "design_spec",
    "verify": "balance_verify",
    "VerifyError": "balance_verify",
    "VerifyRequest": "design_spec",
    "joints": "mechanism",
    "LeverDesignRequest": "design_spec",
    "LeverDesign": "lever_design",
    "LinkageWarning": "linkage",
    "AccuracyWarning": "timedomain",
    "analyse": "analysis",
    "report": "html_report",
    "save": "archive",
    "open_archive": "archive",
    "ArchiveError": "archive",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str):
    if name in _EXPORTS:
        import importlib

        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'harmbal' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
