"""Figures of design sweeps and Monte Carlo runs: an order's residual against a
swept key (a line, or a map over two keys), the distribution of the residual
under production tolerances with the tolerances ranked by how much of its
variance they explain, and the order-against-speed (Campbell) map of a speed
sweep.

Like :mod:`harmbal.reporting.plots`, the figures use
:class:`matplotlib.figure.Figure` directly (never pyplot), and matplotlib is
imported only when a function here is called; write them with
:func:`harmbal.reporting.plots.save_figure`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .plots import OKABE_ITO, fitted, suptitle
from .sweeps import at_top_speed, rounded, shown_units

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

_UNITS = {"force": "N", "moment": "N m"}
#: What a sweep figure can draw: the loads as given, and with ``design=True`` the loads after the design.
_NAMES = {"force": "free force", "moment": "free moment", "residual_force": "free force after the design",
          "residual_moment": "free moment after the design"}


def _label(ds, key: str) -> str:
    units, _ = shown_units(ds, key)
    return f"{key} [{units}]" if units else key


def _shown(ds, key: str, values=None) -> np.ndarray:
    """A key's values (default its coordinate in ``ds``) in the units they
    were typed in (``display_units`` of the key in ``ds``)."""
    return (ds[key].values if values is None else np.asarray(values)) / shown_units(ds, key)[1]


def _group(name: str) -> str:
    return "force" if name.endswith("force") else "moment"


def _amplitude(ds, name: str):
    """``{name}_amplitude`` with its round-off (zero class) drawn as 0."""
    amplitude = ds[f"{name}_amplitude"]
    return amplitude.copy(data=rounded(ds, amplitude.values, _group(name)))


def sweep_figure(ds: xr.Dataset, x: str | None = None, y: str | None = None, *, order: int = 1,
                 name: str = "force") -> Figure:
    """An order's residual over one or two swept keys.

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`harmbal.sweep`.
    x, y : str, optional
        Swept keys on the axes (default the first key; with ``y``, a map over
        both, which needs a grid sweep). Keys not on an axis are reduced to
        the best (smallest) residual over their values: the figure shows
        what the best choice of the other keys reaches.
    order : int
        The order whose amplitude (peak of its vector over a revolution) is
        drawn; for a line, every order of ``ds`` is drawn and ``order`` is
        ignored.
    name : {"force", "moment", "residual_force", "residual_moment"}
        The loads as given, or (``residual_*``, a sweep with ``design=True``)
        with the balancers designed per variant. Round-off (the zero class)
        is drawn as 0.

    Returns
    -------
    matplotlib.figure.Figure
        Keys on the axes in the units their values were typed in.
    """
    from matplotlib.figure import Figure

    keys = [str(k) for k in np.atleast_1d(ds.attrs["parameters"])]
    x = x or keys[0]
    for key in (x, y):
        if key is not None and key not in keys:
            raise ValueError(f"{key!r} is not a swept key; the keys are {', '.join(keys)}")
    if name not in _NAMES or f"{name}_amplitude" not in ds:
        raise ValueError(f"name must be one of {', '.join(n for n in _NAMES if f'{n}_amplitude' in ds)}, "
                         f"not {name!r}")
    ds, rpm = at_top_speed(ds)
    amplitude = _amplitude(ds, name)
    units, what = _UNITS[_group(name)], _NAMES[name]
    if name in _UNITS and f"residual_{name}_amplitude" in ds:
        what = f"free {name} before the design"
    grid = ds.attrs.get("grid_shape") is not None
    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    ax = fig.add_subplot()
    others = [k for k in keys if k not in (x, y)]
    note = f"; best over {', '.join(others)}" if others else ""
    if y is not None:
        if not grid:
            raise ValueError("a map over two keys needs a grid sweep (mode='grid')")
        table = amplitude.sel(order=order).set_index(variant=keys).unstack("variant")
        if others:
            table = table.min(others)
        table = table.transpose(y, x)
        mesh = ax.pcolormesh(_shown(ds, x, table[x]), _shown(ds, y, table[y]), table.values,
                             shading="nearest", cmap="viridis")
        fig.colorbar(mesh, ax=ax, label=fitted(f"order {order} {what} amplitude [{units}]", 3.6, 10))
        ax.set_ylabel(_label(ds, y))
    elif grid and len(keys) > 1:
        table = amplitude.set_index(variant=keys).unstack("variant")
        if others:
            table = table.min(others)
        colours = list(OKABE_ITO.values())[1:]
        for i, k in enumerate(table["order"].values):
            ax.plot(_shown(ds, x, table[x]), table.sel(order=k).values, marker="o", ms=3,
                    color=colours[i % len(colours)], label=f"order {int(k)}")
        ax.legend()
        ax.set_ylabel(f"{what} amplitude [{units}]")
    else:
        colours = list(OKABE_ITO.values())[1:]
        for i, k in enumerate(amplitude["order"].values):
            ax.plot(_shown(ds, x), amplitude.sel(order=k).values, "o", ms=3, color=colours[i % len(colours)],
                    label=f"order {int(k)}")
        ax.legend()
        ax.set_ylabel(f"{what} amplitude [{units}]")
    ax.set_xlabel(_label(ds, x))
    ax.set_title(fitted(f"{ds.attrs.get('engine', '')}: {what} at {rpm:.6g} rpm{note}", 5.0, 10), fontsize=10)
    return fig


def monte_carlo_figure(mc: xr.Dataset, *, order: int = 1, name: str = "force") -> Figure:
    """Distribution of an order's residual under the tolerances, and which tolerance drives it.

    Parameters
    ----------
    mc : xarray.Dataset
        From :func:`harmbal.monte_carlo`.
    order : int
        The order whose amplitude is drawn.
    name : {"force", "moment"}

    Returns
    -------
    matplotlib.figure.Figure
        Histogram, empirical CDF (with the limit, if the run had one, and the
        share above it) and the tolerances ranked by their share of the
        variance (``*_sensitivity``).
    """
    from matplotlib.figure import Figure

    if name not in _UNITS:
        raise ValueError(f"name must be 'force' or 'moment', not {name!r}")
    mc, rpm = at_top_speed(mc)
    values = np.sort(_amplitude(mc, name).sel(order=order).values)  # round-off drawn as 0
    units = _UNITS[name]
    fig = Figure(figsize=(11, 3.8), layout="constrained")
    hist, cdf, bars = fig.subplots(1, 3)
    hist.hist(values, bins=min(60, max(10, values.size // 50)), color=OKABE_ITO["blue"])
    hist.set_xlabel(f"order {order} {name} amplitude [{units}]")
    hist.set_ylabel("samples")
    cdf.step(values, np.arange(1, values.size + 1) / values.size, where="post", color=OKABE_ITO["blue"])
    cdf.set_xlabel(f"order {order} {name} amplitude [{units}]")
    cdf.set_ylabel("share of samples at or below")
    limit = mc.get(f"p_exceed_{name}")
    if limit is not None:
        cdf.axvline(limit.attrs["limit"], color=OKABE_ITO["vermillion"], ls="--",
                    label=f"limit {limit.attrs['limit']:g} {units}: {float(limit.sel(order=order)):.3g} above")
        cdf.legend(loc="lower right")
    share = mc[f"{name}_sensitivity"].sel(order=order)
    ranked = sorted(zip(share.values, [str(p) for p in share["parameter"].values]))
    bars.barh([p for _, p in ranked], [v for v, _ in ranked], color=OKABE_ITO["bluish_green"])
    bars.set_xlim(0, 1)
    bars.set_xlabel(f"share of the variance (R² {float(mc[f'{name}_sensitivity_r2'].sel(order=order)):.3g})")
    suptitle(fig, f"{mc.attrs.get('engine', '')}: order {order} {name} residual over {values.size} samples at "
             f"{rpm:.6g} rpm", 10)
    return fig


def campbell_figure(orders: xr.Dataset, *, name: str = "force") -> Figure:
    """Order against crank speed: the amplitude of each order's vector over a speed sweep.

    Parameters
    ----------
    orders : xarray.Dataset
        ``/orders`` of :func:`harmbal.analyse` (or :func:`harmbal.order_spectrum`)
        of a scene with several speeds (half orders too, with gas).
    name : {"force", "moment"}

    Returns
    -------
    matplotlib.figure.Figure
        A map over (rpm, order) of the peak over a revolution of each order's
        vector, √((Σ|C_a|² + |Σ C_a²|)/2), on a logarithmic colour scale
        (inertial orders grow as ω², gas orders do not).
    """
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    from ..studies.sweep import order_amplitude

    if name not in _UNITS:
        raise ValueError(f"name must be 'force' or 'moment', not {name!r}")
    if "speed" not in orders.dims or orders.sizes["speed"] < 2:
        raise ValueError("a Campbell map needs a scene with several speeds (engine.speed as a list or a sweep)")
    phasor = orders[name].transpose("speed", "order", "axis").values
    amplitude = order_amplitude(phasor)
    rpm, order = orders["rpm"].values, orders["order"].values
    positive = amplitude[amplitude > 0]
    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    ax = fig.add_subplot()
    floor = positive.max() * 1e-6 if positive.size else 1.0
    mesh = ax.pcolormesh(rpm, order, np.maximum(amplitude, floor).T, shading="nearest", cmap="viridis",
                         norm=LogNorm(vmin=floor, vmax=max(floor, float(amplitude.max()))))
    fig.colorbar(mesh, ax=ax, label=f"{name} amplitude [{_UNITS[name]}]")
    ax.set_xlabel("crank speed [rpm]")
    ax.set_ylabel("order")
    ax.set_title(fitted(f"{orders.attrs.get('engine', '')}: {name} per order and speed (log colours from 1e-6 of "
                        "the largest)", 5.0, 10), fontsize=10)
    return fig
