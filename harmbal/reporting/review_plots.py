"""The report's own figures: the crank stars and phasor diagrams of the free
orders with every repeated star drawn once, and a sketch of the mechanism
(crank trains, balance shafts and lever balancers) at a few crank angles.

Oriented like every diagram of :mod:`harmbal.reporting.plots`: the plane
normal to the crank axis, +z up, angles growing clockwise on the page in the
direction of rotation (t, 90° ahead of +z, to the right).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..orders.spectrum import ZERO
from .plots import (
    AXIS_COLOURS,
    SPECTRUM_ROTATION_COLOURS,
    at_speed,
    bank_colours,
    fitted,
    named_colour,
    page_coordinates,
    phasor_bars,
    phasor_diagram,
    rotation_label,
    select_speed,
    series_style,
    star_arms_drawn,
    suptitle,
    supxlabel,
    t_label,
)

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..scene import Scene

#: Columns of panels in :func:`review_stars_figure`.
COLUMNS = 3

#: Crank angles [deg] :func:`mechanism_figure` draws by default.
MECHANISM_ANGLES = (0.0, 90.0, 180.0, 270.0)


#: Colours and legend labels of the bars of :func:`review_spectrum_figure`.
SPECTRUM_COLOURS = {**SPECTRUM_ROTATION_COLOURS, "roll": AXIS_COLOURS["x"]}
SPECTRUM_LABELS = {"co": "co-rotating", "counter": "counter-rotating", "roll": "roll (about the crank axis)"}


def review_spectrum_figure(orders: xr.Dataset, *, log: bool = False, max_order: float | None = None,
                           quantities: Sequence[str] = ("force", "moment"), speed: int = 0) -> Figure:
    """The order spectrum as a balancer sees it: per order the co- and
    counter-rotating phasors of the transverse force and moment, and the roll.

    One axes per quantity, side by side: the force's co- and
    counter-rotating amplitudes [N]; the moment's [N m] and the roll (the
    moment about the crank axis). Components zero to round-off or at most
    their negligible level are drawn as 0 (no bar on a log scale), as in
    :func:`harmbal.reporting.plots.order_spectrum_figure`, whose per-axis
    charts the report's tables replace.

    Parameters
    ----------
    orders : xarray.Dataset
        From :func:`harmbal.order_spectrum` (an analysis tree's ``/orders``).
    log : bool, default False
        Logarithmic amplitude axes.
    max_order : float, optional
        Highest order drawn; default every order above 0 (order 0, the
        mean, is not a rotating load).
    quantities : sequence of {"force", "moment"}, default both
    speed : int, default 0
        Index of the crank speed if the dataset has several.

    Returns
    -------
    matplotlib.figure.Figure
        One axes per quantity; on a linear scale the bars of each component
        one ``PolyCollection`` with gid ``<quantity>-<co|counter|roll>``, a
        rectangle per order drawn (heights in N or N m); on a log scale each
        bar a ``Rectangle`` with gid ``<quantity>-<co|counter|roll>-order<k>``.
    """
    import xarray as xr
    from matplotlib.figure import Figure

    from ..orders.spectrum import BALANCED_RTOL

    sel, rpm = at_speed(orders, speed)
    sel = sel.sel(order=(sel["order"] > 0) & (sel["order"] <= (np.inf if max_order is None else max_order)))
    rtol = float(orders.attrs.get("balanced_rtol", BALANCED_RTOL))
    quantities = list(quantities)
    fig = Figure(figsize=(11.0, 4.0), layout="constrained")
    for ax, quantity in zip(fig.subplots(1, len(quantities), squeeze=False)[0], quantities):
        phasors = sel[f"{quantity}_rotating"]
        level = float(sel[f"{quantity}_negligible_level"])
        levels = [level, level]
        if quantity == "moment":
            roll = sel["moment"].sel(axis="x", drop=True).expand_dims(rotation=["roll"])
            phasors = xr.concat([phasors, roll.transpose(*phasors.dims)], "rotation")
            levels.append(float(sel["roll_negligible_level"]))
        phasor_bars(ax, phasors, "rotation", SPECTRUM_COLOURS, SPECTRUM_LABELS, float(sel[f"{quantity}_scale"]), rtol,
                    log, quantity, np.array(levels), collected=True)
        unit = "N" if quantity == "force" else "N m"
        ax.set_ylabel(f"amplitude |P| [{unit}]", fontsize=8)
        ax.set_title("Force: co- and counter-rotating" if quantity == "force"
                     else "Moment: co- and counter-rotating, and roll", fontsize=9)
    suptitle(fig, f"{orders.attrs.get('engine', '')} at {rpm:.6g} rpm: order spectrum of the free force and moment",
             11)
    supxlabel(fig, "peak amplitudes of the rotating phasors of the transverse vectors; moments about the reference "
              "point; zero and negligible components drawn as 0" + (" (omitted: log scale)" if log else ""),
              7, color="0.3")
    return fig


def free_phasor_orders(stars: xr.Dataset) -> list[int]:
    """Orders above 0 with a free (class 2) co- or counter-rotating force or
    moment, of ``stars`` at one speed."""
    free = (stars["force_free"] | stars["moment_free"]).any("rotation").values
    return [int(k) for k, f in zip(stars["order"].values, free) if f and k > 0]


def star_groups(stars: xr.Dataset, orders: Sequence[int]) -> list[list[int]]:
    """``orders`` grouped by their crank star: the same arm angle for every
    cylinder (and the same regular banks), in the order first seen."""
    groups: dict[tuple, list[int]] = {}
    for k in orders:
        angles = np.degrees(np.asarray(stars["star_angle"].sel(order=k).values, dtype=float)) % 360
        key = tuple(np.round(angles, 6) % 360) + tuple(bool(b) for b in stars["bank_star_regular"].sel(order=k).values)
        groups.setdefault(key, []).append(int(k))
    return list(groups.values())


def _diagrams(stars: xr.Dataset, orders: Sequence[int]) -> list[tuple[str, int]]:
    """The phasor diagrams :func:`review_stars_figure` draws: (quantity, k)
    for each quantity of each order with a free component."""
    return [(quantity, k) for k in orders for quantity in ("force", "moment")
            if bool(stars[f"{quantity}_free"].sel(order=k).any())]


def review_stars_note(stars: xr.Dataset, orders: Sequence[int] | None = None) -> str:
    """What :func:`review_stars_figure` leaves out or draws once, in words."""
    from .review import order_ranges

    sel, _ = select_speed(stars)
    orders = free_phasor_orders(sel) if orders is None else list(orders)
    notes = [f"orders {order_ranges(g)} have the same crank star, drawn once" for g in star_groups(sel, orders)
             if len(g) > 1]
    for quantity in ("force", "moment"):
        quiet = [k for k in orders if not bool(sel[f"{quantity}_free"].sel(order=k).any())]
        if quiet:
            zero = all(int(c) == ZERO for k in quiet for c in sel[f"{quantity}_class"].sel(order=k).values)
            notes.append(f"the {quantity} of order{'s' if len(quiet) > 1 else ''} {order_ranges(quiet)} is "
                         f"{'zero' if zero else 'negligible'}, not drawn")
    return (notes[0][0].upper() + "; ".join(notes)[1:] + ".") if notes else ""


def review_stars_figure(stars: xr.Dataset, orders: Sequence[int] | None = None,
                        speed: float | None = None) -> Figure:
    """Crank stars and free phasor diagrams, each drawn once.

    A strip of the distinct crank stars on top (orders with the same arms
    share one star, named above it), then one panel per free force or moment
    phasor diagram (:func:`harmbal.reporting.plots.phasor_diagram`) in rows of
    :data:`COLUMNS`, order by order; components that are zero or negligible
    get no diagram (:func:`review_stars_note` says so).

    Parameters
    ----------
    stars : xarray.Dataset
        From :func:`harmbal.stars` (or an analysis tree's ``/stars`` with its
        free vectors).
    orders : sequence of int, optional
        Orders to draw; default those with a free force or moment
        (:func:`free_phasor_orders`).
    speed : float, optional
        Crank speed in rpm if the dataset has several; default the first.

    Returns
    -------
    matplotlib.figure.Figure
        The first axes holds the stars (no axis: arms of unit length, star j
        centred at (:data:`STAR_PITCH` · j, 0) in its row, arms with gids
        ``order<k>-star-arm-<labels>`` for the first order k of each group),
        then one axes per phasor diagram.

    Raises
    ------
    ValueError
        If there is nothing to draw.
    """
    from matplotlib.figure import Figure

    sel, rpm = select_speed(stars, speed)
    orders = free_phasor_orders(sel) if orders is None else [int(k) for k in orders]
    diagrams = _diagrams(sel, orders)
    groups = star_groups(sel, orders)
    if not groups:
        raise ValueError("no order to draw")
    strip_rows = -(-len(groups) // STARS_PER_ROW)
    rows = -(-len(diagrams) // COLUMNS)
    strip = 3.4 * strip_rows
    fig = Figure(figsize=(11.5, strip + 4.1 * rows + 0.9), layout="constrained")
    grid = fig.add_gridspec(1 + rows, COLUMNS, height_ratios=[strip] + [4.1] * rows)
    _star_strip(fig.add_subplot(grid[0, :]), sel, groups)
    for i, (quantity, k) in enumerate(diagrams):
        phasor_diagram(sel, k, quantity, fig.add_subplot(grid[1 + i // COLUMNS, i % COLUMNS]))
    engine = stars.attrs.get("engine", "")
    view = "front" if rotation_label(stars) == "+y" else "rear"
    suptitle(fig, f"{engine} at {rpm:.6g} rpm: crank stars and free force and moment phasors", 12)
    supxlabel(fig, f"+z up, angles clockwise in the direction of rotation, t = {rotation_label(stars)} to the right "
              f"(the engine seen from the {view}; {stars.attrs.get('rotation', 'clockwise')} rotation); moments about "
              "the reference point; cs = crankshaft unbalances; firing order "
              f"{stars.attrs.get('firing_order', '?')}", 7, color="0.3")
    return fig


#: Distance between the centres of neighbouring stars in the strip [unit arms], and stars per row.
STAR_PITCH = 3.6
STARS_PER_ROW = 5


def _star_strip(ax: Axes, stars: xr.Dataset, groups: list[list[int]]) -> None:
    """The distinct crank stars side by side in one axes without axis lines:
    each named by its orders above and its regularity below."""
    from matplotlib.lines import Line2D

    from .review import order_ranges

    colours, multibank = bank_colours(stars), stars.sizes.get("bank", 1) > 1
    for j, group in enumerate(groups):
        centre = (STAR_PITCH * (j % STARS_PER_ROW), -3.8 * (j // STARS_PER_ROW))
        star_arms_drawn(ax, stars, group[0], centre)
        k = group[0]
        name = f"order{'s' if len(group) > 1 else ''} {order_ranges(group)}"
        detail = ("regular" if bool(stars["star_regular"].sel(order=k))
                  else f"not regular, |Σ| = {abs(complex(stars['star_resultant'].sel(order=k))):.3g}")
        ax.text(centre[0], centre[1] + 1.6, fitted(name, 1.6, 9), ha="center", va="bottom", fontsize=9)
        ax.text(centre[0], centre[1] - 1.55, detail, ha="center", va="top", fontsize=7, color="0.35")
    ax.set_aspect("equal")
    count = min(len(groups), STARS_PER_ROW)
    rows = -(-len(groups) // STARS_PER_ROW)
    ax.set_xlim(-1.8, STAR_PITCH * (count - 1) + 1.8)
    ax.set_ylim(-3.8 * (rows - 1) - 2.0, 2.3)
    ax.axis("off")
    ax.set_title(f"Crank stars (arms at k·φ from +z, t = {rotation_label(stars)} to the right)", fontsize=9)
    if multibank:
        handles = [Line2D([], [], color=colours[j], lw=2.2, label=f"bank {np.degrees(b):+.4g}°")
                   for j, b in enumerate(np.asarray(stars["bank"].values, dtype=float))]
        ax.legend(handles=handles, loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=7, frameon=False)


def mechanism_figure(scene: Scene, angles: Sequence[float] = MECHANISM_ANGLES) -> Figure:
    """A sketch of the mechanism at a few crank angles.

    Per crank angle θ one panel in the plane normal to the crank axis (+z
    up, t to the right, millimetres): each cylinder's crank (crank axis to
    crank pin), con-rod (crank pin to piston pin) and piston (a square at
    the piston pin) with its cylinder axis dashed; each balance shaft's axis
    and unbalance direction; and each lever balancer's second crank pin C,
    coupler (the balance weight, B–C, with its centre of gravity), rocker
    (pivot A to B) and the fixed pivot.

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`.
    angles : sequence of float, default (0, 90, 180, 270)
        Crank angles θ [deg] (θ = 0: throw 1 up).

    Returns
    -------
    matplotlib.figure.Figure
        One axes per angle, equal aspect, sharing one scale. Lines have gids
        ``crank-<label>``, ``rod-<label>``, ``lever-<label>-crank``,
        ``lever-<label>-coupler``, ``lever-<label>-rocker`` and
        ``shaft-<label>``, the suffix ``-<i>`` numbering the angle; their
        data are page coordinates (t, z) in mm.
    """
    from matplotlib.figure import Figure

    theta = np.radians(np.asarray(angles, dtype=float))
    fig = Figure(figsize=(11.5, 0.9 + 10.6 / len(theta)), layout="constrained")
    axes = fig.subplots(1, len(theta), squeeze=False)[0]
    points = [np.zeros(1, dtype=complex)]
    for i, (ax, angle) in enumerate(zip(axes, theta)):
        points += _draw_crank_trains(ax, scene, angle, i)
        points += _draw_shafts(ax, scene, angle, i)
        points += _draw_levers(ax, scene, angle, i)
        ax.plot([0], [0], "o", color="0.2", markersize=4, zorder=6)
        ax.set_title(f"θ = {np.degrees(angle):g}°", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.set_xlabel(f"t = {t_label(scene.rotation)} [mm]", fontsize=8)
    axes[0].set_ylabel("z [mm]", fontsize=8)
    x, y = page_coordinates(np.concatenate(points) * 1e3)
    half = 0.55 * max(np.ptp(x), np.ptp(y), 1.0)
    for ax in axes:
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlim((x.max() + x.min()) / 2 - half, (x.max() + x.min()) / 2 + half)
        ax.set_ylim((y.max() + y.min()) / 2 - half, (y.max() + y.min()) / 2 + half)
    suptitle(fig, f"{scene.name}: the mechanism at {len(theta)} crank angles (+z up, the direction of rotation to "
             "the right)", 11)
    return fig


def _line(ax: Axes, a: complex, b: complex, gid: str, **style) -> None:
    """A segment between two points of the w-plane [m], drawn in mm."""
    x, y = page_coordinates(np.array([a, b]) * 1e3)
    ax.plot(x, y, gid=gid, solid_capstyle="round", **style)


def _draw_crank_trains(ax: Axes, scene: Scene, theta: float, i: int) -> list[np.ndarray]:
    """Crank, con-rod, piston and cylinder axis of every cylinder at θ."""
    from ..model.clearance import body_motion

    points = []
    for n, cyl in enumerate(scene.cylinders):
        big, along = (v[0] for v in body_motion(scene, "rod", n, np.array([theta])))
        small = big + cyl.rod_length * along
        axis = np.exp(1j * cyl.bank)
        reach = cyl.crank_radius + cyl.rod_length * 1.25
        _line(ax, 0j, reach * axis, f"axis-{cyl.label}-{i}", color="0.8", lw=0.8, ls="--", zorder=1)
        _line(ax, 0j, big, f"crank-{cyl.label}-{i}", color="0.25", lw=2.6, zorder=4)
        _line(ax, big, small, f"rod-{cyl.label}-{i}", color=named_colour("blue"), lw=1.8, zorder=3)
        px, py = page_coordinates(np.array([small]) * 1e3)
        ax.plot(px, py, "s", color=named_colour("sky_blue"), markersize=9, markeredgecolor=named_colour("blue"),
                zorder=5)
        points.append(np.array([big, small, reach * axis]))
    return points


def _draw_shafts(ax: Axes, scene: Scene, theta: float, i: int) -> list[np.ndarray]:
    """Each balance shaft off the crank axis: its axis and unbalance direction at θ."""
    points = []
    for n, shaft in enumerate(s for s in scene.shafts if not s.on_crank and s.unbalances):
        centre = complex(shaft.z, -scene.sense * shaft.y)
        size = max(u.unbalance for u in shaft.unbalances)
        angle = shaft.unbalances[0].angle + shaft.ratio * theta
        arm = 0.02 * np.exp(1j * angle)
        style = series_style(n + 1)
        _line(ax, centre, centre + arm, f"shaft-{shaft.label}-{i}", color=style["color"], lw=2.0, zorder=4)
        cx, cy = page_coordinates(np.array([centre]) * 1e3)
        ax.plot(cx, cy, "o", color=style["color"], markersize=4 + 4 * (size > 0), zorder=5)
        points.append(np.array([centre + arm, centre - arm]))
    return points


def _draw_levers(ax: Axes, scene: Scene, theta: float, i: int) -> list[np.ndarray]:
    """Each lever balancer at θ: pin C, coupler B–C with the weight's CG, rocker A–B, pivot A."""
    from ..model.linkage import four_bar

    points = []
    for lever in scene.levers:
        motion = four_bar(lever, np.array([theta]), scene.sense)
        c, b, pivot = complex(motion.c[0]), complex(motion.b[0]), complex(motion.pivot)
        along = (c - b) / abs(c - b)
        cg = b + complex(*lever.coupler.cg) * along  # the weight's frame: x along B→C, y 90° ahead
        _line(ax, 0j, c, f"lever-{lever.label}-crank-{i}", color="0.45", lw=2.0, zorder=4)
        _line(ax, b, c, f"lever-{lever.label}-coupler-{i}", color=named_colour("vermillion"), lw=2.4, zorder=4)
        _line(ax, pivot, b, f"lever-{lever.label}-rocker-{i}", color=named_colour("bluish_green"), lw=2.0, zorder=4)
        for point, marker, colour, size in ((pivot, "^", "0.2", 8), (cg, "o", named_colour("vermillion"), 9)):
            px, py = page_coordinates(np.array([point]) * 1e3)
            ax.plot(px, py, marker, color=colour, markersize=size, zorder=6)
        if i == 0:  # name the joints once, as docs/lever.md does
            for point, name in ((pivot, "A"), (b, "B"), (c, "C")):
                px, py = page_coordinates(np.array([point]) * 1e3)
                ax.annotate(name, (px[0], py[0]), xytext=(4, 4), textcoords="offset points", fontsize=8,
                            color="0.2", zorder=7)
        points.append(np.array([c, b, pivot, cg]))
    return points
