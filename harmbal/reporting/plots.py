"""Figures: crank stars and phasor diagrams of the free forces and moments,
order spectra, time traces and loci of the shaking loads, the phasing of the
balancer elements, the joint forces of a lever balancer, with gas, the
cylinder pressure, the torque over the cycle, its orders and the speed
fluctuation, and the polar diagrams of the crank pin, the big end and the
main bearings.

Every diagram is drawn in the plane normal to the crank axis, oriented like
the transverse vector w = v_z + i·v_t of :doc:`conventions`: +z points up and
angles grow clockwise on the page, in the direction of rotation, so t (90°
ahead of +z in the direction of rotation) points to the right. For a
clockwise engine t = +y and the page shows the engine seen from the front;
for a counterclockwise one t = −y (seen from the rear).

The figures use :class:`matplotlib.figure.Figure` directly, never pyplot, so
they work headless and leave no global state behind. matplotlib is imported
only when a function here is called: ``import harmbal`` stays light.

>>> import harmbal as hb
>>> from harmbal.reporting.plots import save_figure, stars_figure
>>> ds = hb.stars(hb.load_scene("datasets/engines/v-twin-90.toml"))  # doctest: +SKIP
>>> save_figure(stars_figure(ds, orders=[1, 2]), "v-twin-90.svg")   # doctest: +SKIP
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..io.files import atomic_path
from ..orders.spectrum import BALANCED_RTOL, is_balanced, phase_degrees
from ..orders.stars import star_arms
from ..scene.elements import TRANSMISSION_WARNING
from ..scene.requests import signed_ratio

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..scene import Scene

#: The Okabe–Ito colour-blind-safe palette.
OKABE_ITO = {
    "black": "#000000",
    "orange": "#E69F00",
    "sky_blue": "#56B4E9",
    "bluish_green": "#009E73",
    "yellow": "#F0E442",
    "blue": "#0072B2",
    "vermillion": "#D55E00",
    "reddish_purple": "#CC79A7",
}

#: Colours of the banks of a multi-bank crank star, in bank order.
BANK_COLOURS = ("blue", "vermillion", "bluish_green", "reddish_purple", "orange", "sky_blue", "black")

#: Colours of the per-cylinder arrows and of the resultant, per rotation.
ROTATION_COLOURS = {"co": ("sky_blue", "blue"), "counter": ("orange", "vermillion")}

#: Colours of the engine axes in the order spectrum and the time traces.
AXIS_COLOURS = {"x": "reddish_purple", "y": "bluish_green", "z": "orange"}

#: Colours of the co- and counter-rotating bars of the order spectrum.
SPECTRUM_ROTATION_COLOURS = {"co": "blue", "counter": "vermillion"}

#: The curves "before" and "after": colours of the loci, line styles and
#: widths of the loci and of the traces of :func:`time_traces_figure`.
RUN_COLOURS = {"before": "blue", "after": "vermillion"}
RUN_STYLES = {"before": "-", "after": "--"}
RUN_WIDTHS = {"before": 1.8, "after": 1.2}

#: Colours of the torques over the cycle and of their order bars.
TORQUE_COLOURS = {"gas": "vermillion", "mass": "sky_blue", "delivered": "blue", "mean": "black"}

#: Colours for series without a fixed meaning (joints, levers, balancer
#: elements), cycled; yellow is left out, it is hard to see on white.
SERIES_COLOURS = ("blue", "vermillion", "bluish_green", "orange", "reddish_purple", "sky_blue", "black")
SERIES_STYLES = ("-", "--", ":", "-.")

#: Step of the ticks of crank-angle axes [deg], over a revolution or a working cycle.
ANGLE_TICK_STEP = 90

#: At most about this many intervals between the ticks of a linear value axis (fewer texts to lay out).
TICKS = 4

#: Order axes with more orders than this label the whole orders only (half orders get minor ticks).
MAX_ORDER_LABELS = 16

#: File types :func:`save_figure` writes.
FIGURE_FORMATS = ("svg", "png")

#: Orders :func:`stars_figure` draws by default: 1, 2 and the free orders up to
#: ``DEFAULT_MAX_ORDER``, at most ``DEFAULT_MAX_ROWS`` of them.
DEFAULT_MAX_ORDER = 8
DEFAULT_MAX_ROWS = 6

#: Chains with more arrows than this are drawn without cylinder labels.
_MAX_ARROW_LABELS = 16

_QUANTITIES = {"force": ("Force", "F", "N"), "moment": ("Moment", "M", "N m")}
_PREFIXES = {-12: "p", -9: "n", -6: "µ", -3: "m", 0: "", 3: "k", 6: "M", 9: "G", 12: "T"}


def named_colour(name: str) -> str:
    """The hex colour of an Okabe–Ito colour's ``name`` (:data:`OKABE_ITO`)."""
    return OKABE_ITO[name]


#: Width of an average character of the figures' font (DejaVu Sans) in ems, with a margin.
_EM_PER_CHARACTER = 0.6


def fitted(text: str, width: float, fontsize: float) -> str:
    """``text`` wrapped at spaces into lines that fit ``width`` inches at
    ``fontsize`` points, its own line breaks kept.

    Parameters
    ----------
    text : str
    width : float
        Room for the text [in] (a figure's or an axes' width).
    fontsize : float
        Font size [pt].

    Returns
    -------
    str
    """
    import re
    import textwrap

    columns = max(int(width * 72 / (_EM_PER_CHARACTER * fontsize)), 12)
    kept = re.sub(r"(?<=\d) ", "\0", text)  # a number stays on the line of its unit ("3000 rpm")
    lines = (line for paragraph in kept.split("\n")
             for line in (textwrap.wrap(paragraph, columns, break_on_hyphens=False) or [""]))
    return "\n".join(lines).replace("\0", " ")


def suptitle(fig: Figure, text: str, fontsize: float, **style) -> None:
    """The figure's title, wrapped to its width (:func:`fitted`)."""
    fig.suptitle(fitted(text, 0.96 * fig.get_figwidth(), fontsize), fontsize=fontsize, **style)


def supxlabel(fig: Figure, text: str, fontsize: float, **style) -> None:
    """The figure's footnote, wrapped to its width (:func:`fitted`)."""
    fig.supxlabel(fitted(text, 0.96 * fig.get_figwidth(), fontsize), fontsize=fontsize, **style)


def page_coordinates(values) -> tuple[Any, Any]:
    """Page coordinates (horizontal, vertical) of transverse vectors
    w = z + i·t: t to the right, z up (arrays, or numbers for one vector)."""
    values = np.asarray(values)
    return values.imag, values.real


def _engineering(value: float) -> int:
    """Exponent (a multiple of 3) of the engineering prefix for ``value``."""
    if not np.isfinite(value) or value <= 0:
        return 0
    return int(np.clip(3 * np.floor(np.log10(value) / 3), -12, 12))


def _quantity(value: float, unit: str, digits: int = 4) -> str:
    """``value`` with an engineering prefix, e.g. ``34.61 kN``."""
    e = _engineering(abs(value))
    return f"{value / 10.0**e:.{digits}g} {_PREFIXES[e]}{unit}"


def _degrees(value: complex) -> str:
    """The phase of ``value`` in degrees in (−180, 180], one decimal."""
    return f"{phase_degrees(value, 1):.1f}°"


def t_label(rotation: str) -> str:
    """What t is in the engine frame for a sense of rotation."""
    return "+y" if rotation == "clockwise" else "−y"


def rotation_label(stars: xr.Dataset) -> str:
    """What t is in the engine frame, from the dataset's rotation."""
    return t_label(stars.attrs.get("rotation", "clockwise"))


def _check_order(stars: xr.Dataset, order: int) -> int:
    orders = [int(k) for k in stars["order"].values]
    if int(order) != order or int(order) not in orders:
        raise ValueError(f"order {order!r} is not in the dataset (orders {orders[0]} … {orders[-1]})")
    return int(order)


def select_speed(stars: xr.Dataset, speed: float | None = None) -> tuple[xr.Dataset, float]:
    """The dataset at one crank speed.

    Parameters
    ----------
    stars : xarray.Dataset
        From :func:`harmbal.stars`, with or without a ``speed`` dimension.
    speed : float, optional
        Crank speed in rpm; default the dataset's first speed.

    Returns
    -------
    tuple of (xarray.Dataset, float)
        The dataset without a ``speed`` dimension, and its speed in rpm.

    Raises
    ------
    ValueError
        If the dataset has no speed within 1e-9 (relative) of ``speed``.
    """
    rpm = np.atleast_1d(np.asarray(stars["rpm"].values, dtype=float))
    if speed is None:
        index = 0
    else:
        matches = np.flatnonzero(np.isclose(rpm, float(speed), rtol=1e-9, atol=0))
        if not len(matches):
            available = ", ".join(f"{v:g}" for v in rpm)
            raise ValueError(f"speed {speed:g} rpm is not in the dataset (speeds {available} rpm)")
        index = int(matches[0])
    selected = stars.isel(speed=index) if "speed" in stars.dims else stars
    return selected, float(rpm[index])


def _new_axes(ax: Axes | None) -> Axes:
    if ax is not None:
        return ax
    from matplotlib.figure import Figure

    return Figure(figsize=(4.2, 4.6), layout="constrained").add_subplot()


def _frame(ax: Axes, centre: tuple[float, float], half: float) -> None:
    """Equal aspect showing at least the square of half-width ``half`` about
    ``centre``; the limits grow along one axis to fill the axes' box, so the
    layout engine can place the axes and their legend."""
    ax.update_datalim([(centre[0] - half, centre[1] - half), (centre[0] + half, centre[1] + half)])
    ax.margins(0)
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()


def bank_colours(stars: xr.Dataset) -> list[str]:
    """The colour of each bank's arms: by bank for a multi-bank engine, else black."""
    banks = np.asarray(stars["bank"].values, dtype=float)
    if len(banks) == 1:
        return [named_colour("black")]
    return [named_colour(BANK_COLOURS[j % len(BANK_COLOURS)]) for j in range(len(banks))]


def star_arms_drawn(ax: Axes, stars: xr.Dataset, order: int, centre: tuple[float, float] = (0.0, 0.0),
                    labelled: bool = True) -> tuple[list[str], bool]:
    """Draw the unit circle, θ = 0 mark and arms of one crank star around
    ``centre`` (page coordinates), as :func:`crank_star` does.

    Returns
    -------
    (list of str, bool)
        The bank colours and whether the engine has several banks.
    """
    from matplotlib.lines import Line2D

    k = int(order)
    cx, cy = centre
    angles = np.asarray(stars["star_angle"].sel(order=k).values, dtype=float)
    labels = [str(c) for c in stars["cylinder"].values]
    banks = np.asarray(stars["bank"].values, dtype=float)
    cylinder_bank = np.asarray(stars["cylinder_bank"].values, dtype=float)
    bank_of = np.array([int(np.argmin(np.abs(np.remainder(b - banks + np.pi, 2 * np.pi) - np.pi)))
                        for b in cylinder_bank])
    colours = bank_colours(stars)
    circle = np.linspace(0, 2 * np.pi, 181)
    ax.plot(cx + np.sin(circle), cy + np.cos(circle), color="0.75", lw=0.8, zorder=1)
    ax.plot([cx, cx], [cy + 1.0, cy + 1.08], color="0.45", lw=0.8, zorder=1)
    for angle, members in star_arms(angles):
        direction = np.array([np.sin(angle), np.cos(angle)])
        normal = np.array([direction[1], -direction[0]])
        by_bank = [[i for i in members if bank_of[i] == j] for j in range(len(banks))]
        groups = [(j, g) for j, g in enumerate(by_bank) if g]
        for n, (j, group) in enumerate(groups):
            shift = (n - (len(groups) - 1) / 2) * 0.05 * normal
            text = ",".join(labels[i] for i in group)
            end = direction + shift
            ax.add_line(Line2D([cx + shift[0], cx + end[0]], [cy + shift[1], cy + end[1]], color=colours[j], lw=2.2,
                               solid_capstyle="round", marker="o", markevery=[1], markersize=4.5,
                               gid=f"order{k}-star-arm-{text}", zorder=3))
            if not labelled:
                continue
            # Labels of coincident arms stack vertically on the page, away
            # from the circle at the top and bottom, centred at the sides.
            if direction[1] > 0.5:
                dy = 0.15 * n
            elif direction[1] < -0.5:
                dy = -0.15 * n
            else:
                dy = 0.15 * ((len(groups) - 1) / 2 - n)
            ha = "left" if direction[0] > 0.3 else ("right" if direction[0] < -0.3 else "center")
            ax.text(cx + 1.14 * direction[0], cy + 1.14 * direction[1] + dy, text, color=colours[j], ha=ha,
                    va="center", fontsize=8, fontweight="bold", zorder=4)
    ax.plot([cx], [cy], "o", color="0.2", markersize=3, zorder=4)
    return colours, len(banks) > 1


def crank_star(stars: xr.Dataset, order: int, ax: Axes | None = None) -> Axes:
    """Draw the crank star of one order.

    One unit arm per cylinder at the angle k·φ_i, drawn in the w-plane
    orientation (+z up, angles growing clockwise on the page, in the
    direction of rotation). Coincident arms share one line and one label
    (e.g. ``1,4``). For a multi-bank engine the arms are coloured by bank
    (coincident arms of different banks side by side) and the legend gives
    each bank's angle and whether its own star is regular.

    Parameters
    ----------
    stars : xarray.Dataset
        From :func:`harmbal.stars`.
    order : int
        The order k.
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure's single axes.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on. Each arm is a ``Line2D`` with gid
        ``order<k>-star-arm-<labels>`` from the origin to (sin a, cos a).

    Raises
    ------
    ValueError
        If the order is not in the dataset.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import FancyArrowPatch

    k = _check_order(stars, order)
    ax = _new_axes(ax)
    colours, multibank = star_arms_drawn(ax, stars, k)
    ax.text(0.02, 0.98, "arms at k·φ from +z", transform=ax.transAxes, ha="left", va="top", fontsize=7,
            color="0.35")
    a0, a1 = np.radians(110), np.radians(150)
    ax.add_patch(FancyArrowPatch((1.42 * np.sin(a0), 1.42 * np.cos(a0)), (1.42 * np.sin(a1), 1.42 * np.cos(a1)),
                                 connectionstyle="arc3,rad=-0.2", arrowstyle="-|>", mutation_scale=8,
                                 color="0.45", lw=0.8, zorder=1))
    ax.text(1.5 * np.sin(np.radians(130)), 1.5 * np.cos(np.radians(130)), "rotation", rotation=-40,
            ha="left", va="top", fontsize=7, color="0.35")
    banks = np.asarray(stars["bank"].values, dtype=float)

    if multibank:
        regular = np.asarray(stars["bank_star_regular"].sel(order=k).values, dtype=bool)
        handles = [Line2D([], [], color=colours[j], lw=2.2,
                          label=f"bank {np.degrees(b):+.4g}°" + (" (regular)" if regular[j] else ""))
                   for j, b in enumerate(banks)]
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.2), fontsize=7,
                  frameon=False, ncols=min(len(handles), 2))
    is_regular = bool(stars["star_regular"].sel(order=k))
    resultant = abs(complex(stars["star_resultant"].sel(order=k)))
    detail = "regular" if is_regular else f"not regular, |Σ| = {resultant:.3g}"
    ax.set_title(f"Order {k} crank star: {detail}", fontsize=9)
    _frame(ax, (0.0, 0.0), 1.7)
    ax.set_xticks([-1, 0, 1])
    ax.set_yticks([-1, 0, 1])
    ax.tick_params(labelsize=7)
    ax.set_xlabel(f"t = {rotation_label(stars)} [unit arm]", fontsize=8)
    ax.set_ylabel("z [unit arm]", fontsize=8)
    return ax


def phasor_chain(stars: xr.Dataset, order: int, quantity: str = "force",
                 rotation: str = "co") -> tuple[list[str], np.ndarray, complex]:
    """The arrows of one phasor chain, as drawn by :func:`phasor_diagram`.

    Parameters
    ----------
    stars : xarray.Dataset
        From :func:`harmbal.stars` at one speed (see :func:`select_speed`).
    order : int
        The order k.
    quantity : {"force", "moment"}
    rotation : {"co", "counter"}

    Returns
    -------
    labels : list of str
        Cylinder labels, plus ``"crankshaft"`` if the crankshaft
        unbalances contribute more than the balanced tolerance.
    phasors : numpy.ndarray
        Complex phasors of the arrows, head to tail from the origin.
    resultant : complex
        The dataset's resultant (exactly 0 if balanced).
    """
    k = _check_order(stars, order)
    if "speed" in stars.dims:
        raise ValueError("select one speed first (harmbal.reporting.plots.select_speed)")
    per_cylinder = np.asarray(stars[f"{quantity}_cylinder"].sel(order=k, rotation=rotation).values, dtype=complex)
    resultant = complex(stars[f"{quantity}_rotating"].sel(order=k, rotation=rotation))
    labels = [str(c) for c in stars["cylinder"].values]
    crankshaft = resultant - per_cylinder.sum()
    tol = float(stars.attrs.get("balanced_rtol", 1e-10)) * float(stars[f"{quantity}_scale"])
    if abs(crankshaft) > tol:
        labels.append("crankshaft")
        per_cylinder = np.append(per_cylinder, crankshaft)
    return labels, per_cylinder, resultant


def phasor_diagram(stars: xr.Dataset, order: int, quantity: str = "force", ax: Axes | None = None,
                   speed: float | None = None) -> Axes:
    """Draw the co- and counter-rotating phasors of one order, cylinder by
    cylinder.

    Each cylinder's phasor (at θ = 0) is an arrow; the arrows of one sense of
    rotation are placed head to tail from the origin, so the chain ends at
    the resultant, drawn bold from the origin with its amplitude and phase in
    the legend. Co-rotating phasors are blue, counter-rotating ones orange
    (thinner, on top). A balanced resultant is a dot at the origin marked
    "balanced". Crankshaft unbalances, if any, add one arrow at the end of
    the chain. Orientation as :func:`crank_star`.

    Parameters
    ----------
    stars : xarray.Dataset
        From :func:`harmbal.stars`.
    order : int
        The order k.
    quantity : {"force", "moment"}
        Free force [N] or free moment about the reference point [N m].
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure's single axes.
    speed : float, optional
        Crank speed in rpm if the dataset has several; default the first.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on. The chains are ``Quiver`` collections with gid
        ``order<k>-<quantity>-<rotation>-cylinders`` (arrows from ``(X, Y)``
        by ``(U, V)`` in page coordinates: horizontal t, vertical z), the
        resultants ``order<k>-<quantity>-<rotation>-resultant`` (a
        ``Quiver``, or a ``Line2D`` dot at the origin if balanced).

    Raises
    ------
    ValueError
        If the quantity, order or speed is not in the dataset.
    """
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter

    if quantity not in _QUANTITIES:
        raise ValueError(f"quantity must be 'force' or 'moment', not {quantity!r}")
    k = _check_order(stars, order)
    sel, rpm = select_speed(stars, speed)
    ax = _new_axes(ax)
    name, symbol, unit = _QUANTITIES[quantity]

    points = [0j]
    handles = []
    chains = {}
    for rotation in ("co", "counter"):
        labels, arrows, resultant = phasor_chain(sel, k, quantity, rotation)
        heads = np.cumsum(arrows)
        tails = heads - arrows
        chains[rotation] = (labels, arrows, tails, resultant)
        points.extend(heads)
        points.append(resultant)
    x, y = page_coordinates(points)
    half = max(np.ptp(x), np.ptp(y), np.abs(x).max(), np.abs(y).max()) * 0.55
    if not half > 0:
        half = 1.0
    centre = ((x.max() + x.min()) / 2, (y.max() + y.min()) / 2)
    span = 2 * half
    exponent = _engineering(half)
    factor = 10.0**exponent
    free = {r: bool(sel[f"{quantity}_free"].sel(order=k, rotation=r)) for r in ("co", "counter")}

    for rotation, width, z in (("co", 0.014, 3), ("counter", 0.008, 4)):
        labels, arrows, tails, resultant = chains[rotation]
        light, dark = (named_colour(c) for c in ROTATION_COLOURS[rotation])
        tx, ty = page_coordinates(tails)
        u, v = page_coordinates(arrows)
        ax.quiver(tx, ty, u, v, angles="xy", scale_units="xy", scale=1, units="width", width=width,
                  headwidth=3.2, headlength=4.5, headaxislength=4, minlength=0, color=light, zorder=z,
                  gid=f"order{k}-{quantity}-{rotation}-cylinders")
        for place, text in _arrow_labels(labels, tails, arrows, span, 1 if rotation == "co" else -1):
            px, py = page_coordinates(place)
            ax.text(px, py, text, fontsize=6.5, color=dark, ha="center", va="center", zorder=6)
        if free[rotation] and resultant != 0:
            rx, ry = page_coordinates(resultant)
            ax.quiver([0], [0], [rx], [ry], angles="xy", scale_units="xy", scale=1, units="width",
                      width=0.028, headwidth=2.6, headlength=3.2, headaxislength=2.9, minlength=0,
                      color=dark, alpha=0.55, zorder=2, gid=f"order{k}-{quantity}-{rotation}-resultant")
            text = f"{rotation} Σ: {_quantity(abs(resultant), unit)} at {_degrees(resultant)}"
            handles.append(Line2D([], [], color=dark, lw=4, alpha=0.7, label=text))
        else:
            ax.plot([0], [0], "o", color=dark, markersize=7 if rotation == "co" else 4, zorder=5,
                    gid=f"order{k}-{quantity}-{rotation}-resultant")
            handles.append(Line2D([], [], color=dark, marker="o", ls="none", label=f"{rotation}: balanced"))

    ax.axhline(0, color="0.85", lw=0.6, zorder=0)
    ax.axvline(0, color="0.85", lw=0.6, zorder=0)
    _frame(ax, centre, 1.1 * half)
    scaled = FuncFormatter(lambda value, _: f"{value / factor:.4g}")
    ax.xaxis.set_major_formatter(scaled)
    ax.yaxis.set_major_formatter(scaled)
    ax.locator_params(nbins=TICKS)
    ax.tick_params(labelsize=7)
    prefixed = f"{_PREFIXES[exponent]}{unit}"
    ax.set_xlabel(f"{symbol} t = {rotation_label(sel)} [{prefixed}]", fontsize=8)
    ax.set_ylabel(f"{symbol} z [{prefixed}]", fontsize=8)
    speed_text = f" at {rpm:.6g} rpm" if "speed" in stars.dims else ""
    ax.set_title(f"{name}, order {k}{speed_text}: phasors at θ = 0", fontsize=9)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.2), fontsize=7, frameon=False)
    return ax


def _arrow_labels(labels: list[str], tails: np.ndarray, arrows: np.ndarray, span: float,
                  side: int) -> list[tuple[complex, str]]:
    """Where to write the cylinder labels of a chain: beside the middle of
    each arrow long enough to see (co- and counter-rotating labels on
    opposite sides, whichever way the arrows point), labels that would
    overlap joined as ``1,4``; none for more than ``_MAX_ARROW_LABELS``
    arrows."""
    if len(arrows) > _MAX_ARROW_LABELS:
        return []
    places: list[tuple[complex, list[str]]] = []
    for label, tail, arrow in zip(labels, tails, arrows):
        if abs(arrow) < 0.06 * span:
            continue
        normal = 1j * arrow / abs(arrow)
        if (normal * np.exp(-0.3j)).real < 0:  # one fixed side whichever way the arrow points
            normal = -normal
        place = tail + arrow / 2 + side * 0.035 * span * normal
        text = "cs" if label == "crankshaft" else label
        for other, texts in places:
            if abs(other - place) < 0.04 * span:
                texts.append(text)
                break
        else:
            places.append((place, [text]))
    return [(place, ",".join(texts)) for place, texts in places]


def default_orders(stars: xr.Dataset) -> list[int]:
    """Orders :func:`stars_figure` draws by default: 1, 2 and every order up
    to ``DEFAULT_MAX_ORDER`` with a free co- or counter-rotating force or
    moment, at most ``DEFAULT_MAX_ROWS``."""
    available = {int(k) for k in stars["order"].values}
    free = (stars["force_free"] | stars["moment_free"]).any("rotation")
    orders = {1, 2} | {int(k) for k in stars["order"].values[free.values] if 1 <= k <= DEFAULT_MAX_ORDER}
    return sorted(orders & available)[:DEFAULT_MAX_ROWS]


def stars_figure(stars: xr.Dataset, orders: Sequence[int] | None = None, speed: float | None = None) -> Figure:
    """Crank star, force and moment phasor diagrams, one row per order.

    Parameters
    ----------
    stars : xarray.Dataset
        From :func:`harmbal.stars`.
    orders : sequence of int, optional
        Orders to draw (≥ 1, each once, in the order given); default
        :func:`default_orders`.
    speed : float, optional
        Crank speed in rpm if the dataset has several; default the first.

    Returns
    -------
    matplotlib.figure.Figure
        Three axes per order (crank star, force, moment); not attached to
        pyplot.

    Raises
    ------
    ValueError
        If an order or the speed is not in the dataset, or no order is given.
    """
    from matplotlib.figure import Figure

    if orders is None:
        orders = default_orders(stars)
    if not len(orders):
        raise ValueError("no orders to draw")
    for k in orders:
        if not k >= 1:
            raise ValueError(f"orders must be positive, not {k!r}")
    orders = list(dict.fromkeys(_check_order(stars, k) for k in orders))
    sel, rpm = select_speed(stars, speed)
    rows = len(orders)
    fig = Figure(figsize=(11.5, 4.1 * rows + 0.9), layout="constrained")
    axes = fig.subplots(rows, 3, squeeze=False)
    for row, k in zip(axes, orders):
        crank_star(sel, k, row[0])
        phasor_diagram(sel, k, "force", row[1])
        phasor_diagram(sel, k, "moment", row[2])
    engine = stars.attrs.get("engine", "")
    view = "front" if rotation_label(stars) == "+y" else "rear"
    suptitle(fig, f"{engine} at {rpm:.6g} rpm: crank stars and free force and moment phasors", fontsize=12)
    supxlabel(fig, f"+z up, angles clockwise in the direction of rotation, t = {rotation_label(stars)} to the "
                 f"right (the engine seen from the {view}; {stars.attrs.get('rotation', 'clockwise')} "
                 "rotation); moments about the reference point; cs = crankshaft unbalances\n"
                 f"firing order {stars.attrs.get('firing_order', '?')}", fontsize=7, color="0.3")
    return fig


def at_speed(ds: xr.Dataset, speed: int) -> tuple[xr.Dataset, float]:
    """The dataset at speed index ``speed`` and that speed in rpm.

    Raises
    ------
    ValueError
        If the dataset has one speed and ``speed`` is not 0.
    IndexError
        If the index is out of range.
    """
    if "speed" in ds.dims:
        ds = ds.isel(speed=speed)
    elif speed != 0:
        raise ValueError(f"speed index {speed} but the dataset has a single speed (index 0)")
    return ds, float(ds["rpm"])


def _runs(time: xr.Dataset, after: xr.Dataset | None, speed: int) -> tuple[dict[str, xr.Dataset], float]:
    """The datasets ``before`` (and ``after``, if given) at one speed index,
    and that speed in rpm.

    Raises
    ------
    ValueError
        If ``after`` is at another speed.
    """
    before, rpm = at_speed(time, speed)
    runs = {"before": before}
    if after is not None:
        runs["after"], other = at_speed(after, speed)
        if not np.isclose(other, rpm, rtol=1e-9, atol=0):
            raise ValueError(f"'after' is at {other:.6g} rpm, not {rpm:.6g} rpm (speed index {speed})")
    return runs, rpm


def _span(ds: xr.Dataset) -> float:
    """The crank angle [deg] that ``ds``'s angle axis spans: one revolution,
    or the working cycle with gas (attribute ``revolutions``, 720° for a
    four-stroke)."""
    return 360.0 * int(ds.attrs.get("revolutions", 1))


def _closed(angle, values, span: float = 360.0) -> tuple[np.ndarray, np.ndarray]:
    """Crank angles in degrees and ``values`` (angle last) over one closed
    period: the first sample repeated at ``span`` degrees."""
    values = np.asarray(values)
    return np.append(np.degrees(np.asarray(angle, dtype=float)), span), np.concatenate(
        [values, values[..., :1]], axis=-1)


def _angle_axis(ax: Axes, span: float = 360.0) -> None:
    """A crank-angle x axis from 0 to ``span`` degrees in steps of 90°."""
    ax.set_xlim(0, span)
    ax.set_xticks(np.arange(0, span + 1, ANGLE_TICK_STEP))
    ax.set_xlabel("crank angle θ [deg]", fontsize=8)


def _order_label(order: float) -> str:
    """An order as printed: ``2``, ``1.5``."""
    return f"{order:g}"


def _order_step(order: np.ndarray) -> float:
    """Spacing of an order axis: 1, or ½ for the half orders of a four-stroke with gas."""
    return float(np.min(np.diff(order))) if order.size > 1 else 1.0


def _order_axis(ax: Axes, order, max_labels: int = MAX_ORDER_LABELS) -> None:
    """Ticks at every order of ``order`` (whole or half orders), labelled
    ``1.5`` rather than ``1.50``; with more than ``max_labels`` orders only
    the whole ones are labelled and the others get minor ticks, so the labels
    never run into each other."""
    order = np.asarray(order, dtype=float)
    labelled = order if order.size <= max_labels else order[order == np.round(order)]
    ax.set_xticks(labelled, [_order_label(k) for k in labelled])
    ax.set_xticks(np.setdiff1d(order, labelled), minor=True)
    step = _order_step(order)
    ax.set_xlim(order[0] - 0.6 * step, order[-1] + 0.6 * step)
    ax.set_xlabel("order k [cycles/rev]", fontsize=8)


def _period_name(ds: xr.Dataset) -> str:
    """What ``ds``'s angle axis spans, in words."""
    revolutions = int(ds.attrs.get("revolutions", 1))
    return "one revolution" if revolutions == 1 else f"the working cycle ({revolutions} revolutions)"


def _note(ax: Axes, text: str) -> None:
    """A note centred in the axes."""
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", fontsize=9, color="0.35")


def series_style(index: int) -> dict:
    """Colour and line style of the ``index``-th series without a fixed
    colour: the colours cycle first, then the line styles."""
    return {"color": named_colour(SERIES_COLOURS[index % len(SERIES_COLOURS)]),
            "ls": SERIES_STYLES[(index // len(SERIES_COLOURS)) % len(SERIES_STYLES)]}


def phasor_bars(ax: Axes, phasors: xr.DataArray, dim: str, colours: dict[str, str], labels: dict[str, str],
          scale: float, rtol: float, log: bool, gid: str, level=0.0, collected: bool = False) -> None:
    """Grouped bars of |phasor| per order, one bar per entry of ``dim``.

    Components balanced at ``rtol`` × ``scale``, or at most the negligible
    ``level`` (a number, or one per entry of ``dim``), are drawn as bars of
    height 0, or not at all on a log scale. The orders may be whole or half orders (a
    four-stroke cycle with gas). Each bar has gid ``<gid>-<entry>-order<k>``,
    k printed as ``2`` or ``1.5``; with ``collected`` (linear scale only) the
    bars of each entry are instead one ``PolyCollection`` with gid
    ``<gid>-<entry>``, a rectangle per order in order (a tenth of the cost
    of one artist per bar).
    """
    from matplotlib.patches import Patch

    order = np.asarray(phasors["order"].values, dtype=float)
    amplitude = np.abs(phasors.transpose("order", dim).values)
    heights = np.where(is_balanced(amplitude, scale, rtol) | (amplitude <= np.asarray(level)), 0.0, amplitude)
    entries = [str(e) for e in phasors[dim].values]
    width = 0.8 * _order_step(order) / len(entries)
    for j, entry in enumerate(entries):
        centre = order + (j - (len(entries) - 1) / 2) * width
        if collected and not log:
            _bar_collection(ax, centre, heights[:, j], width, named_colour(colours[entry]), f"{gid}-{entry}")
            continue
        keep = heights[:, j] > 0 if log else np.ones(len(order), dtype=bool)
        bars = ax.bar(centre[keep], heights[keep, j], width, color=named_colour(colours[entry]), log=log)
        for bar, k in zip(bars, order[keep]):
            bar.set_gid(f"{gid}-{entry}-order{_order_label(k)}")
    if not heights.any():
        _note(ax, "all components balanced" if not (amplitude > rtol * scale).any() else "all components negligible")
    elif log:  # at least three decades, so that nearly equal bars do not fill a sliver of a decade
        top = heights.max()
        ax.set_ylim(min(heights[heights > 0].min(), 1e-3 * top) / 2, 2 * top)
    _order_axis(ax, order)
    ax.tick_params(labelsize=7)
    if not log:
        ax.locator_params(axis="y", nbins=TICKS)
    ax.legend(handles=[Patch(color=named_colour(colours[e]), label=labels[e]) for e in entries], fontsize=7,
              frameon=False)


def _bar_collection(ax: Axes, centre: np.ndarray, height: np.ndarray, width: float, colour: str, gid: str) -> None:
    """Bars from 0 to ``height`` at ``centre`` as one PolyCollection (autoscaled like ``ax.bar``'s)."""
    from matplotlib.collections import PolyCollection

    left, right = centre - width / 2, centre + width / 2
    zero = np.zeros_like(height)
    verts = np.stack([np.stack([left, zero], -1), np.stack([left, height], -1), np.stack([right, height], -1),
                      np.stack([right, zero], -1)], axis=1)
    # matplotlib's stubs ask for a sequence of polygons; a (polygon, vertex, 2) array is one.
    bars = PolyCollection(verts, facecolors=colour, edgecolors="none", gid=gid)  # type: ignore[arg-type]
    bars.sticky_edges.y.append(0)
    ax.add_collection(bars, autolim=True)
    ax.autoscale_view()


def order_spectrum_figure(orders: xr.Dataset, *, log: bool = False, max_order: int | None = None,
                          speed: int = 0, quantities: Sequence[str] = ("force", "moment")) -> Figure:
    """Bar charts of the order spectrum of the free force and moment.

    Top row the force, bottom row the moment about the reference point;
    left the peak amplitude |C_k| of each engine axis (x, y, z) per order,
    right the magnitudes of the co- and counter-rotating phasors of the
    transverse vector per order. Components zero to round-off or at most the
    dataset's negligible levels (``force_negligible_level``, …: classes
    zero and negligible, docs/conventions.md) are drawn as 0: bars of height
    0, or no bar on a log scale.

    Parameters
    ----------
    orders : xarray.Dataset
        From :func:`harmbal.order_spectrum`.
    log : bool, default False
        Logarithmic amplitude axis.
    max_order : int, optional
        Highest order drawn; default every order of the dataset.
    speed : int, default 0
        Index of the crank speed if the dataset has several.
    quantities : sequence of {"force", "moment"}, default both
        The rows to draw (the report leaves out a quantity with nothing free).

    Returns
    -------
    matplotlib.figure.Figure
        Two axes per quantity, in rows (by default four: force per axis,
        force rotating, moment per axis, moment rotating). Each bar is a ``Rectangle`` with gid
        ``<quantity>-<axis or rotation>-order<k>`` (k as ``2`` or, for the
        half orders of a four-stroke with gas, ``1.5``), its height in N or
        N m.
    """
    from matplotlib.figure import Figure

    sel, rpm = at_speed(orders, speed)
    if max_order is not None:
        sel = sel.sel(order=sel["order"] <= max_order)
    rtol = float(orders.attrs.get("balanced_rtol", BALANCED_RTOL))
    quantities = list(quantities)
    if not quantities or set(quantities) - set(_QUANTITIES):
        raise ValueError(f"quantities must be some of 'force', 'moment', not {quantities!r}")
    fig = Figure(figsize=(11.0, 3.3 * len(quantities) + 0.4), layout="constrained")
    axes = fig.subplots(len(quantities), 2, squeeze=False)
    axis_labels = {a: a for a in AXIS_COLOURS}
    rotation_labels = {"co": "co-rotating", "counter": "counter-rotating"}
    for row, quantity in zip(axes, quantities):
        name, symbol, unit = _QUANTITIES[quantity]
        scale = float(sel[f"{quantity}_scale"])
        level = _negligible_levels(sel, quantity)
        phasor_bars(row[0], sel[quantity], "axis", AXIS_COLOURS, axis_labels, scale, rtol, log, quantity, level)
        phasor_bars(row[1], sel[f"{quantity}_rotating"], "rotation", SPECTRUM_ROTATION_COLOURS, rotation_labels,
                    scale, rtol, log, quantity, level[1])
        row[0].set_ylabel(f"|{symbol}_k| per axis [{unit}]", fontsize=8)
        row[1].set_ylabel(f"|P| [{unit}]", fontsize=8)
        row[0].set_title(f"{name} per engine axis (peak)", fontsize=9)
        row[1].set_title(f"{name}: co- and counter-rotating phasors", fontsize=9)
    zero = "omitted (log scale)" if log else "drawn as 0"
    suptitle(fig, f"{orders.attrs.get('engine', '')} at {rpm:.6g} rpm: order spectrum of the shaking loads",
                fontsize=11)
    supxlabel(fig, f"peak amplitudes; moments about the reference point; components zero to round-off or at most the "
                 f"negligible level ({orders.attrs.get('negligible', 0.0):g} of one cylinder's share of the load "
                 f"scale) are {zero}", fontsize=7, color="0.3")
    return fig


def _negligible_levels(sel: xr.Dataset, quantity: str) -> np.ndarray:
    """The negligible level of each engine axis (x, y, z) of ``quantity`` at
    one speed: the roll's for the moment about x; 0 in datasets without levels."""
    level = float(sel[f"{quantity}_negligible_level"]) if f"{quantity}_negligible_level" in sel else 0.0
    levels = np.full(3, level)
    if quantity == "moment" and "roll_negligible_level" in sel:
        levels[0] = float(sel["roll_negligible_level"])
    return levels


def time_traces_figure(time: xr.Dataset, *, after: xr.Dataset | None = None, speed: int = 0,
                       hide_negligible: bool = True) -> Figure:
    """The shaking force and moment over one crank revolution, or over the
    working cycle with gas (two revolutions for a four-stroke, 0–720°).

    Parameters
    ----------
    time : xarray.Dataset
        From :func:`harmbal.simulate`.
    after : xarray.Dataset, optional
        A second simulation at the same speeds (e.g. with balancers), drawn
        dashed in the same colours.
    speed : int, default 0
        Index of the crank speed if the datasets have several.
    hide_negligible : bool, default True
        A quantity whose every axis stays at or below its negligible level
        (:func:`negligible_peak`) in both runs is not drawn: its axes say
        "negligible" or "zero to round-off" instead of showing round-off
        magnified.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes: force [N] (top) and moment [N m] (bottom) against the crank
        angle [deg], one colour per engine axis. Each trace is a ``Line2D``
        with gid ``<quantity>-<axis>-<before|after>`` closed at the end of
        the period, 360° or 720° (the first sample repeated).

    Raises
    ------
    ValueError
        If ``after`` is at another speed.
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    runs, rpm = _runs(time, after, speed)
    span = _span(time)
    hidden = {q: hide_negligible and negligible_peak(runs, q, ("x", "y", "z")) for q in _QUANTITIES}
    heights = [0.25 if hidden[q] else 1.0 for q in _QUANTITIES]
    fig = Figure(figsize=(9.0, 0.9 + 2.8 * sum(heights)), layout="constrained")
    axes = fig.subplots(2, 1, height_ratios=heights)
    for ax, quantity in zip(axes, ("force", "moment")):
        name, symbol, unit = _QUANTITIES[quantity]
        quiet = hidden[quantity]
        if quiet:
            _quiet(ax, name, quiet, unit)
            ax.axis("off")
        for run, ds in ({} if quiet else runs).items():
            angle, values = _closed(ds["angle"].values, ds[quantity].transpose("axis", "angle").values, span)
            for axis, trace in zip(ds["axis"].values, values):
                ax.plot(angle, trace, color=named_colour(AXIS_COLOURS[str(axis)]), ls=RUN_STYLES[run],
                        lw=RUN_WIDTHS[run], gid=f"{quantity}-{axis}-{run}")
        handles = [Line2D([], [], color=named_colour(c), label=f"{symbol}_{a}") for a, c in AXIS_COLOURS.items()]
        if after is not None:
            handles += [Line2D([], [], color="0.3", ls=RUN_STYLES[r], label=r) for r in runs]
        if not quiet:
            ax.axhline(0, color="0.85", lw=0.6, zorder=0)
        _angle_axis(ax, span)
        ax.set_ylabel(f"{name} {symbol} [{unit}]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.locator_params(axis="y", nbins=TICKS)
        if not quiet:
            ax.legend(handles=handles, fontsize=7, frameon=False, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    axes[0].set_title("Shaking force on the block", fontsize=9)
    axes[1].set_title("Shaking moment on the block about the reference point", fontsize=9)
    suptitle(fig, f"{time.attrs.get('engine', '')} at {rpm:.6g} rpm: loads over {_period_name(time)}", fontsize=11)
    return fig


def locus_figure(time: xr.Dataset, *, after: xr.Dataset | None = None, speed: int = 0,
                 hide_negligible: bool = True) -> Figure:
    """The loci of the transverse force and moment over one revolution (the
    working cycle with gas).

    The tip of (F_y, F_z) and of (M_y, M_z) over the period, seen from
    the front of the engine (y to the right, z up), with equal aspect and
    the origin marked.

    Parameters
    ----------
    time : xarray.Dataset
        From :func:`harmbal.simulate`.
    after : xarray.Dataset, optional
        A second simulation at the same speeds (e.g. with balancers), drawn
        as a second, dashed curve.
    speed : int, default 0
        Index of the crank speed if the datasets have several.
    hide_negligible : bool, default True
        A locus that stays within its negligible level (:func:`negligible_peak`)
        in both runs is not drawn (a circle of round-off would fill the
        axes): its axes say "negligible" or "zero to round-off" instead.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes, force [N] and moment [N m]. Each curve is a ``Line2D`` with
        gid ``<quantity>-locus-<before|after>``: x data the y component, y data
        the z component, closed (the first sample repeated).

    Raises
    ------
    ValueError
        If ``after`` is at another speed.
    """
    from matplotlib.figure import Figure

    runs, rpm = _runs(time, after, speed)
    hidden = {q: hide_negligible and negligible_peak(runs, q, ("y", "z")) for q in _QUANTITIES}
    widths = [0.45 if hidden[q] else 1.0 for q in _QUANTITIES]
    fig = Figure(figsize=(10.0, 5.4), layout="constrained")
    for ax, quantity in zip(fig.subplots(1, 2, width_ratios=widths), ("force", "moment")):
        name, symbol, unit = _QUANTITIES[quantity]
        quiet = hidden[quantity]
        ax.set_xlabel(f"{symbol}_y [{unit}]", fontsize=8)
        ax.set_ylabel(f"{symbol}_z [{unit}]", fontsize=8)
        if quiet:
            _quiet(ax, f"{name} locus", quiet, unit)
            ax.axis("off")
            continue
        for run, ds in runs.items():
            values = ds[quantity].sel(axis=["y", "z"]).transpose("axis", "angle").values
            _, (y, z) = _closed(ds["angle"].values, values)
            ax.plot(y, z, color=named_colour(RUN_COLOURS[run]), ls=RUN_STYLES[run], lw=RUN_WIDTHS[run], label=run,
                    gid=f"{quantity}-locus-{run}")
        ax.plot([0], [0], "+", color="black", markersize=10, mew=1.2, gid=f"{quantity}-origin")
        ax.axhline(0, color="0.85", lw=0.6, zorder=0)
        ax.axvline(0, color="0.85", lw=0.6, zorder=0)
        ax.set_aspect("equal", adjustable="datalim")
        ax.locator_params(nbins=TICKS)
        ax.tick_params(labelsize=7)
        ax.set_title(f"{name} locus" + (" about the reference point" if quantity == "moment" else ""), fontsize=9)
        if after is not None:
            ax.legend(fontsize=7, frameon=False)
    suptitle(fig, f"{time.attrs.get('engine', '')} at {rpm:.6g} rpm: transverse loads over {_period_name(time)}, "
                "seen from the front (y right, z up; + the origin)", fontsize=11)
    return fig


def negligible_peak(runs: dict, quantity: str, axes: Sequence[str]) -> tuple[str, float, float] | None:
    """Whether ``quantity`` is negligible over the whole period in every run
    (time-domain Datasets at one speed): its peak over ``axes`` at most
    ``negligible`` × the load scale / the number of cylinders (the level of
    one order component, docs/conventions.md).

    Returns
    -------
    tuple of (str, float, float) or None
        ("zero" or "negligible", the peak, the level) [N or N m], or None if
        the quantity is not negligible somewhere (or the Datasets carry no
        negligible fraction).
    """
    from ..orders.spectrum import ZERO_RTOL

    first = next(iter(runs.values()))
    fraction = float(first.attrs.get("negligible", 0.0))
    if fraction <= 0:
        return None
    scale = max(float(ds[f"{quantity}_scale"]) for ds in runs.values())
    level = fraction * scale / max(int(first.attrs.get("cylinders", 1)), 1)
    peak = max(float(np.abs(ds[quantity].sel(axis=list(axes)).values).max()) for ds in runs.values())
    if peak > level:
        return None
    return ("zero" if peak <= ZERO_RTOL * scale else "negligible"), peak, level


def _quiet(ax: Axes, what: str, quiet: tuple[str, float, float], unit: str) -> None:
    """Say in ``ax`` that ``what`` is not drawn: zero or negligible, with its peak and level."""
    kind, peak, level = quiet
    text = (f"{what}: zero to round-off" if kind == "zero"
            else f"{what}: negligible\n(peak {peak:.2g} {unit}, level {level:.2g} {unit})")
    _note(ax, text)


def phasing_figure(scene: Scene) -> Figure:
    """The static unbalances of the balancer elements at θ = 0.

    One arrow per static unbalance of every element of ``scene.shafts``
    (counterweights, balance shafts, Lanchester pairs, crankshaft mass data),
    from the origin in the direction of its angle at θ = 0 in the w-plane
    orientation (+z up, angles from +z in the direction of rotation, which is
    to the right), of length n²·U [kg m]: times ω² it is the force of the
    unbalance at crank speed ω, so arrows compare forces. Each element turns
    at its ratio n × crank speed from there. Couple unbalances are not drawn.

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`.

    Returns
    -------
    matplotlib.figure.Figure
        One axes with equal aspect; the arrows of element i (numbered among
        the elements with static unbalances) form a ``Quiver`` with gid
        ``phasing-<i>`` (arrows from (0, 0) by (U, V) in page coordinates:
        horizontal t, vertical z). A scene without such elements gives the
        note "no balancer elements".
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    t = t_label(scene.rotation)
    fig = Figure(figsize=(6.4, 6.4), layout="constrained")
    ax = fig.add_subplot()
    ax.set_xlabel(f"t = {t}, direction of rotation: n²·U [kg m]", fontsize=8)
    ax.set_ylabel("z: n²·U [kg m]", fontsize=8)
    ax.set_title(f"{scene.name}: balancer unbalances at θ = 0\n+z up, direction of rotation to the right "
                 f"(t = {t}); arrow length n²·U", fontsize=9)
    ax.tick_params(labelsize=7)
    elements = [shaft for shaft in scene.shafts if shaft.unbalances]
    if not elements:
        _note(ax, "no balancer elements")
        return fig
    handles = []
    for i, shaft in enumerate(elements):
        w = shaft.ratio**2 * np.array([u.unbalance * np.exp(1j * u.angle) for u in shaft.unbalances])
        u, v = page_coordinates(w)
        style = series_style(i)
        # Later elements are drawn thinner on top, so coincident arrows stay visible.
        ax.quiver(np.zeros(len(w)), np.zeros(len(w)), u, v, angles="xy", scale_units="xy", scale=1,
                  units="width", width=0.014 * max(0.3, 1 - 0.15 * i), headwidth=3.2, headlength=4.5,
                  headaxislength=4, minlength=0, color=style["color"], zorder=3 + i, gid=f"phasing-{i}")
        tag = signed_ratio(shaft.ratio)
        label = shaft.label if tag in shaft.label else f"{shaft.label} {tag}"
        handles.append(Line2D([], [], color=style["color"], lw=2.5, label=label))
    reach = max(max(u.unbalance for u in s.unbalances) * s.ratio**2 for s in elements) or 1.0
    circle = np.linspace(0, 2 * np.pi, 181)
    ax.plot(reach * np.sin(circle), reach * np.cos(circle), color="0.8", lw=0.8, zorder=1)
    for degrees in (0, 90, 180, 270):
        a = np.radians(degrees)
        ax.text(1.1 * reach * np.sin(a), 1.1 * reach * np.cos(a), f"{degrees}°", ha="center", va="center",
                fontsize=7, color="0.4")
    ax.axhline(0, color="0.85", lw=0.6, zorder=0)
    ax.axvline(0, color="0.85", lw=0.6, zorder=0)
    ax.plot([0], [0], "o", color="0.2", markersize=3, zorder=20)
    _frame(ax, (0.0, 0.0), 1.2 * reach)
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=7, frameon=False,
              ncols=2 if len(handles) > 3 else 1)
    return fig


def lever_figure(joints: xr.Dataset, *, speed: int = 0) -> Figure:
    """Joint forces over the revolution and the lever balancers' transmission
    angles.

    Parameters
    ----------
    joints : xarray.Dataset
        From :func:`harmbal.joints`.
    speed : int, default 0
        Index of the crank speed if the dataset has several.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes. Left, |F| [N] of every joint against the crank angle
        [deg], one ``Line2D`` per joint labelled with its name (gid
        ``joint-<i>``). Right, the transmission angle γ [deg] of each lever
        (gid ``transmission-<i>``), the warning level
        :data:`harmbal.scene.elements.TRANSMISSION_WARNING` as a horizontal line
        (gid ``transmission-warning``) and
        the dataset's minimum as a marker (gid ``min-transmission-<i>``, at
        (θ, γ) in degrees); the note "no lever balancer" if there is none.
    """
    from matplotlib.figure import Figure

    sel, rpm = at_speed(joints, speed)
    fig = Figure(figsize=(12.0, 5.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    force = sel["joint_force"]
    # np.hypot of two DataArrays is a DataArray (numpy's stubs say ndarray).
    angle, magnitude = _closed(sel["angle"].values, np.hypot(force.sel(axis="y"), force.sel(axis="z"))
                               .transpose("joint", "angle").values)  # type: ignore[call-overload]
    for i, (name, values) in enumerate(zip(sel["joint"].values, magnitude)):
        left.plot(angle, values, lw=1.1, label=str(name), gid=f"joint-{i}", **series_style(i))
    _angle_axis(left)
    left.set_ylabel("joint force |F| [N]", fontsize=8)
    left.set_title("Joint forces (first-named body on the second)", fontsize=9)
    left.tick_params(labelsize=7)
    left.legend(fontsize=7, frameon=False, loc="upper left", bbox_to_anchor=(1.0, 1.0),
                ncols=1 + len(magnitude) // 16)
    _angle_axis(right)
    right.set_ylim(0, 90)
    right.set_yticks(range(0, 91, 15))
    right.set_ylabel("transmission angle γ [deg]", fontsize=8)
    right.set_title("Lever balancers: transmission angle", fontsize=9)
    right.tick_params(labelsize=7)
    if "lever" not in sel.dims:
        _note(right, "no lever balancer")
    else:
        _transmission(right, sel)
    suptitle(fig, f"{joints.attrs.get('engine', '')} at {rpm:.6g} rpm: joint forces and transmission angle",
                fontsize=11)
    return fig


def _transmission(ax: Axes, joints: xr.Dataset) -> None:
    """Draw each lever's transmission angle over θ, its minimum and the
    warning level (all in degrees)."""
    warning = np.degrees(TRANSMISSION_WARNING)
    angle, gamma = _closed(joints["angle"].values, joints["transmission_angle"].transpose("lever", "angle").values)
    for i, lever in enumerate(joints["lever"].values):
        style = series_style(i)
        low = float(np.degrees(joints["min_transmission_angle"].sel(lever=lever)))
        where = float(np.degrees(joints["min_transmission_theta"].sel(lever=lever)))
        ax.plot(angle, np.degrees(gamma[i]), lw=1.3, label=str(lever), gid=f"transmission-{i}", **style)
        ax.plot([where], [low], "v", color=style["color"], markersize=7, ls="none",
                label=f"{lever}: min {low:.1f}° at θ = {where:.1f}°", gid=f"min-transmission-{i}")
    ax.axhline(warning, color=named_colour("vermillion"), lw=1.0, ls="--", label=f"warning below {warning:.0f}°",
               gid="transmission-warning")
    ax.legend(fontsize=7, frameon=False, loc="lower right")


def pressure_figure(torque: xr.Dataset, *, cylinders: Sequence[str] | None = None) -> Figure:
    """Cylinder pressure over the working cycle and the p–V diagram.

    Parameters
    ----------
    torque : xarray.Dataset
        ``/torque`` of :func:`harmbal.analyse` with gas.
    cylinders : sequence of str, optional
        Labels of the cylinders to draw; default all.

    Returns
    -------
    matplotlib.figure.Figure
        Left, the absolute pressure [bar] against the crank angle θ [deg]
        over the cycle (0–720° for a four-stroke), one ``Line2D`` per
        cylinder drawn (gid ``pressure-<label>``, closed at the end of the
        cycle) and a dotted line at every cylinder's firing TDC (gid
        ``firing-<label>``). Right, pressure against the
        displaced volume V − V_TDC [cm³], one closed loop per cylinder drawn
        (gid ``pv-<label>``), whose area is the indicated work, and the swept
        volume as a dashed line (gid ``swept-<label>``).

    Raises
    ------
    ValueError
        If a label is not a cylinder of the dataset.
    """
    from matplotlib.figure import Figure

    labels = [str(c) for c in torque["cylinder"].values]
    chosen = labels if cylinders is None else [str(c) for c in cylinders]
    unknown = sorted(set(chosen) - set(labels))
    if unknown:
        raise ValueError(f"no cylinder {', '.join(unknown)} in the dataset (cylinders {', '.join(labels)})")
    span = _span(torque)
    fig = Figure(figsize=(11.0, 4.6), layout="constrained")
    left, right = fig.subplots(1, 2)
    angle, pressure = _closed(torque["angle"].values, torque["pressure"].transpose("cylinder", "angle").values, span)
    styles = {label: series_style(i) for i, label in enumerate(chosen)}
    for label in chosen:
        left.plot(angle, pressure[labels.index(label)] / 1e5, lw=1.3, label=f"cylinder {label}",
                  gid=f"pressure-{label}", **styles[label])
    for label, fire in zip(labels, np.degrees(torque["firing_angle"].values) % span):
        left.axvline(fire, color="0.6", lw=0.7, ls=":", zorder=0, gid=f"firing-{label}")
        left.text(fire, 1.0, label, transform=left.get_xaxis_transform(), ha="center", va="bottom", fontsize=7,
                  color="0.35")
    _angle_axis(left, span)
    left.set_ylabel("cylinder pressure p [bar]", fontsize=8)
    left.set_title("Pressure over the cycle (dotted: firing TDC of each cylinder)", fontsize=9, pad=14)
    left.tick_params(labelsize=7)
    left.legend(fontsize=7, frameon=False, loc="upper right")
    volume = torque["volume"].transpose("cylinder", "angle").values
    swept = torque["swept_volume"].values
    for label in chosen:
        i = labels.index(label)
        right.plot(np.append(volume[i], volume[i][:1]) * 1e6, pressure[i] / 1e5, lw=1.3, gid=f"pv-{label}",
                   label=f"cylinder {label}", **styles[label])
        right.axvline(swept[i] * 1e6, color=styles[label]["color"], lw=0.8, ls="--", zorder=0,
                      gid=f"swept-{label}", label=f"swept volume {swept[i] * 1e6:.4g} cm³")
    right.set_xlabel("displaced volume V − V_TDC [cm³]", fontsize=8)
    right.set_ylabel("cylinder pressure p [bar]", fontsize=8)
    right.set_title("p–V diagram (loop area: indicated work)", fontsize=9, pad=14)
    right.tick_params(labelsize=7)
    right.legend(fontsize=7, frameon=False, loc="upper right")
    suptitle(fig, f"{torque.attrs.get('engine', '')}: cylinder pressure (absolute)", fontsize=11)
    return fig


def torque_figure(torque: xr.Dataset, *, speed: int = 0) -> Figure:
    """The torques on the crankshaft over the working cycle.

    Parameters
    ----------
    torque : xarray.Dataset
        ``/torque`` of :func:`harmbal.analyse` with gas.
    speed : int, default 0
        Index of the crank speed if the dataset has several.

    Returns
    -------
    matplotlib.figure.Figure
        One axes against the crank angle θ [deg] over the cycle, ``Line2D``
        closed at the end of the cycle: the gas torque of all cylinders (gid
        ``torque-gas``), the mass torque the moving parts take from the crank
        (gid ``torque-mass``), the torque the crank delivers, gas − mass
        (gid ``torque-delivered``), and the mean torque (gid ``torque-mean``);
        positive in the direction of rotation.
    """
    from matplotlib.figure import Figure

    sel, rpm = at_speed(torque, speed)
    span = _span(torque)
    fig = Figure(figsize=(9.0, 4.6), layout="constrained")
    ax = fig.add_subplot()
    mean = float(sel["mean_torque"])
    for name, values, lw, label in (
            ("gas", sel["gas_torque"].sum("cylinder").values, 1.1, "gas torque, all cylinders"),
            ("mass", sel["mass_torque"].values, 1.1, "mass torque (taken by the moving parts)"),
            ("delivered", sel["torque"].values, 1.8, "delivered torque = gas − mass")):
        angle, closed = _closed(sel["angle"].values, values, span)
        ax.plot(angle, closed, color=named_colour(TORQUE_COLOURS[name]), lw=lw, label=label, gid=f"torque-{name}")
    ax.axhline(mean, color=named_colour(TORQUE_COLOURS["mean"]), lw=1.0, ls="--", label=f"mean {mean:.4g} N m",
               gid="torque-mean")
    ax.axhline(0, color="0.85", lw=0.6, zorder=0)
    _angle_axis(ax, span)
    ax.set_ylabel("torque on the crankshaft T [N m]", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=7, frameon=False, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    suptitle(fig, f"{torque.attrs.get('engine', '')} at {rpm:.6g} rpm (constant speed): torque over "
                f"{_period_name(torque)}", fontsize=11)
    return fig


def torque_scale(torque: xr.Dataset) -> float:
    """The largest order amplitude of the gas torque and of the delivered
    torque at any speed [N m]: order components at most
    :data:`~harmbal.orders.spectrum.BALANCED_RTOL` times it cancel (e.g. the
    half orders of an evenly firing inline four)."""
    gas = np.abs(torque["gas_torque_order"].sum("cylinder").values)
    return float(max(gas.max(initial=0.0), np.abs(torque["torque_order"].values).max(initial=0.0)))


def torque_spectrum_figure(torque: xr.Dataset, *, speed: int = 0) -> Figure:
    """Bar chart of the orders of the torque on the crankshaft.

    Parameters
    ----------
    torque : xarray.Dataset
        ``/torque`` of :func:`harmbal.analyse` with gas.
    speed : int, default 0
        Index of the crank speed if the dataset has several.

    Returns
    -------
    matplotlib.figure.Figure
        One axes: per order k > 0 (half orders for a four-stroke) the peak
        amplitudes of the delivered torque (gas − mass, gid
        ``torque-delivered-order<k>``) and of the gas torque of all cylinders
        (gid ``torque-gas-order<k>``), k printed as ``2`` or ``1.5``;
        components cancelling to within :func:`torque_scale` are drawn as 0.
        Major orders (every cylinder's gas harmonic in phase) are shaded
        (gid ``major-order<k>``).
    """
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    sel, rpm = at_speed(torque, speed)
    sel = sel.isel(order=slice(1, None))  # the mean is the mean torque, drawn in torque_figure
    order = np.asarray(sel["order"].values, dtype=float)
    scale = torque_scale(torque)
    step = _order_step(order)
    width = 0.4 * step
    fig = Figure(figsize=(10.0, 4.4), layout="constrained")
    ax = fig.add_subplot()
    handles = []
    for j, (name, phasors, label) in enumerate((
            ("delivered", sel["torque_order"].values, "delivered torque (gas − mass)"),
            ("gas", sel["gas_torque_order"].sum("cylinder").values, "gas torque, all cylinders"))):
        amplitude = np.abs(phasors)
        heights = np.where(is_balanced(amplitude, scale, BALANCED_RTOL), 0.0, amplitude)
        bars = ax.bar(order + (j - 0.5) * width, heights, width, color=named_colour(TORQUE_COLOURS[name]))
        for bar, k in zip(bars, order):
            bar.set_gid(f"torque-{name}-order{_order_label(k)}")
        handles.append(Patch(color=named_colour(TORQUE_COLOURS[name]), label=label))
    for k in order[np.asarray(sel["major_order"].values, dtype=bool)]:
        ax.axvspan(k - step / 2, k + step / 2, color="0.9", zorder=0, lw=0, gid=f"major-order{_order_label(k)}")
    handles.append(Patch(color="0.9", label="major order (all cylinders in phase)"))
    _order_axis(ax, order, max_labels=2 * MAX_ORDER_LABELS)
    ax.set_ylabel("torque amplitude |T_k| (peak) [N m]", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(handles=handles, fontsize=7, frameon=False, loc="upper right")
    suptitle(fig, f"{torque.attrs.get('engine', '')} at {rpm:.6g} rpm: orders of the torque on the crankshaft "
                f"(mean {float(sel['mean_torque']):.4g} N m not drawn)", fontsize=11)
    return fig


def speed_fluctuation_figure(torque: xr.Dataset, *, speed: int = 0) -> Figure:
    """The crank speed over the working cycle of an engine with a flywheel.

    Parameters
    ----------
    torque : xarray.Dataset
        ``/torque`` of :func:`harmbal.analyse` for a scene with ``[gas]`` and
        ``[flywheel]`` (variables ``omega`` and ``fluctuation_coefficient``).
    speed : int, default 0
        Index of the mean crank speed if the dataset has several.

    Returns
    -------
    matplotlib.figure.Figure
        One axes: the crank speed [rpm] against the crank angle θ [deg]
        (gid ``speed``, closed at the end of the cycle) and the scene's mean
        speed (gid ``speed-mean``); the coefficient of fluctuation δ in the
        title.

    Raises
    ------
    ValueError
        If the dataset has no speed fluctuation (no ``[flywheel]``).
    """
    from matplotlib.figure import Figure

    if "omega" not in torque:
        raise ValueError("the dataset has no speed fluctuation: the scene needs a [flywheel] table")
    sel, rpm = at_speed(torque, speed)
    span = _span(torque)
    angle, omega = _closed(sel["angle"].values, sel["omega"].values, span)
    fig = Figure(figsize=(9.0, 3.8), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(angle, omega * 30 / np.pi, color=named_colour("blue"), lw=1.5, label="crank speed", gid="speed")
    ax.axhline(rpm, color="black", lw=1.0, ls="--", label=f"mean {rpm:.6g} rpm (the scene's speed)",
               gid="speed-mean")
    _angle_axis(ax, span)
    ax.set_ylabel("crank speed n [rpm]", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(fontsize=7, frameon=False, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    delta = float(sel["fluctuation_coefficient"])
    suptitle(fig, f"{torque.attrs.get('engine', '')} at {rpm:.6g} rpm: speed fluctuation, δ = (ω_max − ω_min)/ω_mean "
                f"= {delta:.4g}, J₀ = {float(sel['flywheel_inertia']):.4g} kg m²", fontsize=11)
    return fig


def accuracy_figure(rows: list[dict]) -> Figure:
    """Error against time per operating point from :func:`harmbal.bench.run`,
    one panel per engine; colour = what is varied, marker = λ; the sampling
    family joined by lines."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    engines = list(dict.fromkeys(r["engine"] for r in rows))
    lambdas = list(dict.fromkeys(r["lambda"] for r in rows))
    markers = dict(zip(lambdas, "os^Dvp"))
    families = list(dict.fromkeys(r["family"] for r in rows))  # in the order harmbal.bench.run measured them
    colours = {family: OKABE_ITO[c] for family, c in zip(families, SERIES_COLOURS)}
    fig = Figure(figsize=(4.2 * len(engines), 4.8))
    axes = fig.subplots(1, len(engines), squeeze=False, sharey=True)
    floor = 1e-17
    for ax, name in zip(axes[0], engines):
        mine = [r for r in rows if r["engine"] == name]
        for lam in lambdas:
            line = [r for r in mine if r["family"] == "samples" and r["lambda"] == lam]
            if line:
                ax.plot([r["seconds"] * 1e3 for r in line], [max(r["error"], floor) for r in line], "-",
                        color=colours["samples"], lw=0.8, alpha=0.6)
        for family in families:
            for lam in lambdas:
                pts = [r for r in mine if r["family"] == family and r["lambda"] == lam]
                if pts:
                    ax.plot([r["seconds"] * 1e3 for r in pts], [max(r["error"], floor) for r in pts], markers[lam],
                            color=colours[family], ms=4.5, mec="none", alpha=0.85,
                            label=family if lam == lambdas[0] else None)
        ax.set(xscale="log", yscale="log", title=f"{name} ({mine[0]['cylinders']} cyl.)",
               xlabel="time per operating point [ms]")
        ax.grid(True, which="major", lw=0.4, alpha=0.5)
    axes[0][0].set_ylabel("largest relative error of the order phasors (orders 0–12)")
    handles = [Line2D([], [], ls="none", marker=markers[lam], color="0.3", label=f"λ = {lam:g}") for lam in lambdas]
    fam_handles, fam_labels = axes[0][0].get_legend_handles_labels()
    fig.legend(fam_handles + handles, fam_labels + [h.get_label() for h in handles], loc="lower center",
               ncol=len(fam_handles) + len(handles), fontsize=8, frameon=False)
    fig.suptitle("harmbal: accuracy against cost (reference: mpmath at 50 digits; errors below 1e-17 drawn at 1e-17)",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 0.95))
    return fig


def save_figure(fig: Figure, path: str | os.PathLike) -> Path:
    """Write a figure as SVG or PNG (by extension), atomically.

    The file is written next to its destination and moved into place only
    when complete, so a failed write leaves no file behind. SVG output keeps
    text as text and is deterministic (fixed hash salt, no date).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : path-like
        Destination ending in ``.svg`` or ``.png``.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ValueError
        If the extension is neither ``.svg`` nor ``.png``.
    """
    import matplotlib

    path = Path(path)
    fmt = path.suffix.lower().lstrip(".")
    if fmt not in FIGURE_FORMATS:
        raise ValueError(f"{path}: figures are written as .svg or .png, not {path.suffix or 'no extension'!r}")
    by_format: dict[str, dict[str, Any]] = {"svg": {"metadata": {"Date": None}}, "png": {"dpi": 150}}
    options = by_format[fmt]
    with atomic_path(path) as tmp, matplotlib.rc_context({"svg.hashsalt": "harmbal", "svg.fonttype": "none"}):
        fig.savefig(tmp, format=fmt, **options)
    return path


def _polar_axes(ax: Axes, x, y, xlabel: str, ylabel: str, title: str) -> None:
    """Equal axes through the origin sized to the loci ``x``, ``y`` [kN]."""
    reach = max(float(np.abs(x).max(initial=0.0)), float(np.abs(y).max(initial=0.0)), 1e-9)
    ax.axhline(0, color="0.85", lw=0.6, zorder=0)
    ax.axvline(0, color="0.85", lw=0.6, zorder=0)
    ax.plot([0], [0], "o", color="0.2", markersize=3, zorder=20)
    _frame(ax, (0.0, 0.0), 1.1 * reach)
    ax.set_xlabel(xlabel, fontsize=8)
    ax.set_ylabel(ylabel, fontsize=8)
    ax.set_title(title, fontsize=9)
    ax.tick_params(labelsize=7)


def crank_pin_figure(loads: xr.Dataset, *, cylinders: Sequence[str] | None = None, speed: int = 0) -> Figure:
    """Polar diagrams of the crank pin and of the big-end bearing.

    Parameters
    ----------
    loads : xarray.Dataset
        From :func:`harmbal.loads` (``/loads``).
    cylinders : sequence of str, optional
        Labels of the cylinders to draw; default all.
    speed : int, default 0
        Index of the crank speed if the dataset has several.

    Returns
    -------
    matplotlib.figure.Figure
        Left, the con-rod's force on the crank pin in the crank frame
        (tangential [kN] to the right, radial [kN] up: outwards from the
        crank axis through the pin), one closed ``Line2D`` per cylinder over
        the angle (gid ``crank-pin-<label>``) and its peak as a marker (gid
        ``crank-pin-peak-<label>``). Right, the crank pin's force on the
        con-rod in the rod frame (across to the right, along the rod up:
        from the big end to the small end), the big-end bearing's polar
        diagram (gid ``big-end-<label>``).
    """
    from matplotlib.figure import Figure

    sel, rpm = at_speed(loads, speed)
    labels = list(cylinders) if cylinders is not None else [str(c) for c in sel["cylinder"].values]
    fig = Figure(figsize=(11.0, 5.6), layout="constrained")
    left, right = fig.subplots(1, 2)
    xs, ys = [], []
    for i, label in enumerate(labels):
        style = series_style(i)
        pin = sel["crank_pin_force"].sel(cylinder=label).values / 1e3
        end = sel["big_end_force"].sel(cylinder=label).values / 1e3
        (radial, tangential), (along, across) = pin, end
        left.plot(np.append(tangential, tangential[0]), np.append(radial, radial[0]), lw=1.1,
                  label=f"cylinder {label}", gid=f"crank-pin-{label}", **style)
        k = int(np.argmax(np.hypot(radial, tangential)))
        left.plot([tangential[k]], [radial[k]], "o", color=style["color"], markersize=5,
                  gid=f"crank-pin-peak-{label}")
        right.plot(np.append(across, across[0]), np.append(along, along[0]), lw=1.1, label=f"cylinder {label}",
                   gid=f"big-end-{label}", **style)
        xs += [tangential, across]
        ys += [radial, along]
    everything = np.concatenate(xs + ys) if xs else np.zeros(1)  # one scale for both diagrams
    _polar_axes(left, everything, everything, "tangential (direction of rotation) [kN]", "radial (outwards) [kN]",
                "Crank pin: force of the con-rod, crank frame")
    _polar_axes(right, everything, everything, "across the rod [kN]", "along the rod (big end → small end) [kN]",
                "Big-end bearing: force of the crank pin, rod frame")
    left.legend(fontsize=7, frameon=False, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    suptitle(fig, f"{loads.attrs.get('engine', '')} at {rpm:.6g} rpm: crank-pin and big-end polar diagrams over "
                f"{_period_name(loads)}", fontsize=11)
    return fig


def main_bearing_figure(loads: xr.Dataset, *, speed: int = 0) -> Figure:
    """Polar diagrams of the main-bearing loads, one axes per bearing.

    Parameters
    ----------
    loads : xarray.Dataset
        From :func:`harmbal.loads` with main bearings (``[loads]
        main_bearings``).
    speed : int, default 0
        Index of the crank speed if the dataset has several.

    Returns
    -------
    matplotlib.figure.Figure
        Per bearing, the crankshaft's force on the bearing in the block
        frame, oriented like every diagram here (+z up, t to the right),
        [kN], one closed ``Line2D`` (gid ``main-bearing-<label>``) and its
        peak as a marker (gid ``main-bearing-peak-<label>``); all axes share
        one scale.
    """
    from matplotlib.figure import Figure

    sel, rpm = at_speed(loads, speed)
    labels = [str(b) for b in sel["bearing"].values]
    sense = 1 if loads.attrs.get("rotation") == "counterclockwise" else -1
    force = sel["main_bearing_force"].transpose("bearing", "axis", "angle").values / 1e3
    t = -sense * force[:, 0]  # t = −sense·y points to the right
    z = force[:, 1]
    columns = min(len(labels), 4)
    rows = -(-len(labels) // columns)
    fig = Figure(figsize=(3.2 * columns + 0.6, 3.4 * rows + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, columns)).ravel()
    for i, label in enumerate(labels):
        ax = axes[i]
        ax.plot(np.append(t[i], t[i][0]), np.append(z[i], z[i][0]), lw=1.1, color=named_colour("blue"),
                gid=f"main-bearing-{label}")
        k = int(np.argmax(np.hypot(t[i], z[i])))
        ax.plot([t[i][k]], [z[i][k]], "o", color=named_colour("vermillion"), markersize=5,
                gid=f"main-bearing-peak-{label}")
        x = float(sel["bearing_position"].sel(bearing=label)) * 1e3
        _polar_axes(ax, t, z, f"F_t [kN] (t = {t_label(loads.attrs.get('rotation', 'clockwise'))})", "F_z [kN]",
                    f"bearing {label} (x = {x:.6g} mm): peak {np.hypot(t[i], z[i])[k]:.4g} kN")
    for ax in axes[len(labels):]:
        ax.set_visible(False)
    suptitle(fig, f"{loads.attrs.get('engine', '')} at {rpm:.6g} rpm: main-bearing loads\nover {_period_name(loads)} "
                "(statically determinate split)", fontsize=10)
    return fig
