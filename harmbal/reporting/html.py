"""One self-contained HTML report per scene or archive.

The page holds everything inline: styles in a ``<style>`` element and every
figure as an ``<svg>`` element (text kept as text), so it opens offline in any
browser and prints to PDF without cut figures (each figure and table is kept
on one page). The report is built from an analysis tree (:func:`harmbal.analyse`
or :func:`harmbal.open_archive`) and the scene text stored in it, so a report
from an archive equals the report from the scene it came from.
"""

from __future__ import annotations

import html
import math
import os
import shlex
from functools import partial
from pathlib import Path

import numpy as np

from .._version import __version__
from ..orders.spectrum import FREE, ZERO, is_balanced, phase_degrees
from .lazy_imports import defer_duck_array_imports

# Before the analysis that a report follows makes its first xarray Variable: xarray would import dask.array
# and pint (0.5 s) only to learn that no data is a dask array or a pint quantity (see lazy_imports).
defer_duck_array_imports()

#: Crank angles per revolution of the traces and loci (one every 0.5°).
TRACE_SAMPLES = 720

#: Highest order of the main-bearing force in the report's order table.
MAIN_BEARING_ORDERS = 3

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color: #1a1a1a;
       max-width: 62rem; margin: 2rem auto; padding: 0 1rem; line-height: 1.45; }
h1 { font-size: 1.7rem; margin-bottom: 0.2rem; } h2 { font-size: 1.3rem; margin-top: 2.2rem;
       border-bottom: 1px solid #ccc; padding-bottom: 0.2rem; } h3 { font-size: 1.05rem; }
table { border-collapse: collapse; margin: 0.6rem 0; font-size: 0.88rem; }
th, td { border: 1px solid #d0d0d0; padding: 0.2rem 0.5rem; text-align: right; }
th { background: #f2f2f2; } td.text, th.text { text-align: left; }
figure { margin: 1rem 0; } figure svg { width: 100%; height: auto; display: block; }
figcaption { font-size: 0.85rem; color: #444; }
pre { background: #f6f6f6; padding: 0.8rem; overflow-x: auto; font-size: 0.8rem; white-space: pre-wrap;
      overflow-wrap: anywhere; }
p.engine { font-size: 1.05rem; margin: 0.4rem 0 0.8rem; }
table.headline th { white-space: nowrap; vertical-align: bottom; }
table.headline td { vertical-align: top; } table.headline td.free { color: #a33b00; font-weight: 600; }
table.headline td.remedy { font-size: 0.8rem; min-width: 20rem; } td.remedy div.element { padding-left: 0.8rem; }
.verdict-balanced { color: #006d4f; } .verdict-negligible { color: #55606e; } .verdict-free { color: #a33b00; }
.note { font-size: 0.85rem; color: #444; }
@media print {
  body { max-width: none; margin: 0; }
  figure, table, pre { break-inside: avoid; page-break-inside: avoid; }
  figure svg { max-height: 23cm; }  /* a tall figure shrinks to one A4 page, caption included */
  h2 { break-after: avoid; page-break-after: avoid; }
  pre { white-space: pre-wrap; }
}
"""


#: Class attributes of table cells: text (left-aligned) and a free component (coloured).
_TEXT, _FREE, _ELEMENT = ' class="text"', ' class="free"', ' class="element"'


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _table(header: list[str], rows: list[list], text_columns: int = 1) -> str:
    def cells(values, tag):
        out = []
        for i, value in enumerate(values):
            css = ' class="text"' if i < text_columns else ""
            out.append(f"<{tag}{css}>{_e(value)}</{tag}>")
        return "".join(out)

    body = "".join(f"<tr>{cells(r, 'td')}</tr>" for r in rows)
    return f"<table><thead><tr>{cells(header, 'th')}</tr></thead><tbody>{body}</tbody></table>"


class _Page:
    """Collects sections and numbers the figures; the figures are made and
    rendered at the end, by :func:`harmbal.reporting.svg.figures_svg` (two at
    a time where the machine allows)."""

    def __init__(self) -> None:
        self.parts: list[str] = []
        self.figures: list[tuple] = []

    def add(self, text: str) -> None:
        self.parts.append(text)

    def figure(self, make, caption: str, name: str) -> None:
        """A figure: ``make()`` returns it (a matplotlib Figure), ``caption``
        and ``name`` (its ``data-figure``) go with it."""
        number = len(self.figures) + 1
        self.figures.append((len(self.parts), make, number, name))
        self.add(f'<figure id="figure-{name}" data-figure="{_e(name)}">\0'
                 f"<figcaption>Figure {number}. {_e(caption)}</figcaption></figure>")

    def text(self) -> str:
        """The sections with every figure's SVG in its place."""
        from .svg import figures_svg

        svgs = figures_svg([(make, number, name) for _, make, number, name in self.figures])
        parts = list(self.parts)
        for (index, _, _, _), svg in zip(self.figures, svgs):
            parts[index] = parts[index].replace("\0", svg, 1)
        return "\n".join(parts)


def _free_vector_stars(tree):
    """The tree's crank stars with its free vectors (kept in /orders)."""
    from ..views.stars import with_free_vectors

    return with_free_vectors(tree["stars"].ds, tree["orders"].ds)


#: Speeds from which the spectrum section adds Campbell maps (order against speed).
CAMPBELL_SPEEDS = 3


def _first_speed(ds):
    return ds.isel(speed=0) if "speed" in ds.dims else ds


def _phasor(value: complex, scale: float, rtol: float) -> tuple[str, str]:
    return _class_phasor(value, ZERO if is_balanced(abs(value), scale, rtol) else FREE)


def _class_phasor(value: complex, code: int) -> tuple[str, str]:
    """Amplitude and phase cells by class: 0 (round-off) and ~0 (negligible) without a phase."""
    if code != FREE:
        return ("0" if code == ZERO else "~0"), "—"
    return f"{abs(value):.5g}", f"{phase_degrees(value, 1):.1f}°"


class _Runs:
    """The scene simulated again for the traces and the headline: ``after``
    (as the scene is) and, when it has balancer elements, ``before`` (without
    them) with its order spectrum at the first speed. The same from a scene
    and from its archive (both rebuild the scene from its text)."""

    def __init__(self, scene, tree):
        from ..views.orders import order_spectrum
        from ..views.time import simulate

        # Smooth curves need more angles than the spectra: at TRACE_SAMPLES or more.
        samples = max(int(tree["time"].ds.attrs["samples_per_rev"]), TRACE_SAMPLES)
        self.after = simulate(scene, samples_per_rev=samples)
        self.before = self.before_orders = None
        if (scene.shafts or scene.levers) and "balancers" in scene.model.effects:
            self.before = simulate(scene.with_effects(scene.model.effects - {"balancers"}), samples_per_rev=samples)
            self.before_orders = _first_speed(order_spectrum(self.before))


def _summary(page: _Page, scene, tree, runs: _Runs) -> None:
    """The top of the page: the engine in one line, the headline table of the
    orders that are not negligible (before and after the balancers, with
    what would remove what remains) and one line for the others."""
    from . import review

    orders = _first_speed(tree["orders"].ds)
    after = review.order_loads(orders)
    before = None if runs.before_orders is None else review.judged_like(runs.before_orders, orders)
    shown = review.headline_orders(after, before)
    page.add(f'<section id="summary"><h2>Summary</h2><p class="engine">{_e(review.engine_line(scene))}</p>')
    if shown:
        page.add(_headline_table(scene, orders, after, before, shown))
    else:
        page.add("<p><strong>Nothing is free:</strong> every order is negligible or zero.</p>")
    page.add(f'<p class="note">{_e(_headline_note(orders, before is not None))}</p>'
             f"<p>{_e(_quiet_line(orders, after, before))}</p></section>")


def _headline_table(scene, orders, after, before, shown) -> str:
    """Rows per order shown: without and with the balancers (or as built),
    free components coloured, and what would remove what remains."""
    from . import review

    speed = float(np.atleast_1d(orders["speed"].values)[0])
    spacing = review.couple_spacing(scene)
    header = "<th>order</th>" + ("<th class=\"text\">balancers</th>" if before else "")
    header += "".join(f"<th>{_e(h)}<br>[{_e(u)}]</th>" for _, h, u in review.COMPONENTS)
    header += '<th class="text">to remove what remains</th>'
    now, was = {o.order: o for o in after}, {o.order: o for o in before or ()}
    body = []
    for k in shown:
        fix = review.remedy_text(now[k], review.removals(now[k], speed, scene.sense, scene.reference_point[0], spacing))
        remedy = "".join(f"<div{_ELEMENT if line.startswith('– ') else ''}>{_e(line)}</div>" for line in fix)
        runs = [("without", was[k]), ("with", now[k])] if before else [(None, now[k])]
        for j, (label, loads) in enumerate(runs):
            first = f'<td rowspan="{len(runs)}">{_e(f"{k:g}")}</td>' if j == 0 else ""
            which = f'<td class="text">{label}</td>' if label else ""
            cells = "".join(f'<td{_FREE if loads.classes[key] == FREE else ""}>'
                            f"{_e(review.cell(loads.values[key], loads.classes[key]))}</td>"
                            for key, _, _ in review.COMPONENTS)
            last = f'<td class="text remedy">{remedy}</td>' if j == len(runs) - 1 else '<td class="text"></td>'
            body.append(f"<tr>{first}{which}{cells}{last}</tr>")
    rpm = float(np.atleast_1d(orders["rpm"].values)[0])
    return (f"<h3>Free forces and moments per order at {rpm:.6g} rpm</h3>"
            f'<table class="headline"><thead><tr>{header}</tr></thead><tbody>{"".join(body)}</tbody></table>')


def _headline_note(orders, balancers: bool) -> str:
    """What the headline's columns mean and how the sizes are computed."""
    several = orders.sizes.get("speed", 1) > 1 or np.atleast_1d(orders["rpm"].values).size > 1
    return ("F: the transverse force, M: the transverse moment about the reference point, as co- and counter-rotating "
            "phasors (peak amplitudes); roll: the moment about the crank axis. 0: zero to round-off; ~0: negligible "
            f"(at most {float(orders['force_negligible_level']):.2g} N, {float(orders['moment_negligible_level']):.2g} "
            f"N m, roll {float(orders['roll_negligible_level']):.2g} N m). "
            + ("without / with: the engine without its balancer elements and as the scene has them. " if balancers
               else "")
            + "To remove what remains: for a force, an unbalance U = |P|/(k²ω²) turning at +k× (co) or −k× "
            "(counter) crank speed, at θ = 0 opposite the phasor P (angles from +z in the direction of rotation), "
            "in the plane x of the reference point; for a moment, two opposite unbalances U = |P|/(s·k²ω²) in planes "
            "s apart around it (s: the cylinders' axial span, or 100 mm when they share one plane). Each is a first "
            "size that cancels that component alone (docs/report.md); harmbal design places real elements. The "
            "roll is left to the mounts: no unbalance on the crank axis changes it."
            + (" The inertial loads go with ω², so these unbalances hold at every speed." if several else ""))


def _quiet_line(orders, after, before) -> str:
    """The orders not in the headline, in one line."""
    from . import review

    negligible, zero = review.quiet_orders(after, before)
    parts = []
    if negligible:
        word = "Order" if len(negligible) == 1 else "Orders"
        parts.append(f"{word} {review.order_ranges(negligible)}: negligible (every component at most "
                     f"{float(orders['force_negligible_level']):.2g} N, {float(orders['moment_negligible_level']):.2g} "
                     f"N m, roll {float(orders['roll_negligible_level']):.2g} N m).")
    if zero:
        word = "Order" if len(zero) == 1 else "Orders"
        parts.append(f"{word} {review.order_ranges(zero)}: zero to round-off.")
    return " ".join(parts) or "Every order is in the table."


def _settings(page: _Page, scene, tree) -> None:
    """What was simulated and how: the analysis settings."""
    time, orders = tree["time"].ds, tree["orders"].ds
    rpm = ", ".join(f"{v:.6g}" for v in np.atleast_1d(time["rpm"].values))
    alias_f = float(np.max(orders["aliasing_error_force"].values))
    alias_m = float(np.max(orders["aliasing_error_moment"].values))
    ref = np.asarray(scene.reference_point) * 1e3
    rows = [
        ["engine", scene.name], ["description", scene.description or "—"],
        ["speed(s)", f"{rpm} rpm"], ["rotation (seen from the front)", scene.rotation],
        ["cycle", f"{scene.cycle}-stroke"], ["cylinders", str(len(scene.cylinders))],
        ["effects simulated", time.attrs["effects"]],
        ["model", f"piston {time.attrs['piston_model']}, rod {time.attrs['rod_model']}"],
        ["sampling", f"{time.attrs['samples_per_rev']} samples per revolution, orders up to "
                     f"{time.attrs['max_order']}"],
        ["estimated accuracy (aliasing)", f"force {alias_f:.2g} N, moment {alias_m:.2g} N m"],
        ["moments about", f"({ref[0]:g}, {ref[1]:g}, {ref[2]:g}) mm"],
        ["zero, negligible", _levels(_first_speed(orders))],
        ["harmbal version", __version__],
    ]
    page.add('<section id="settings"><h2>Settings</h2>' + _table(["item", "value"], rows, 2) + "</section>")


def _levels(orders) -> str:
    """The classes' thresholds of ``orders`` at one speed, in words."""
    zero = f"zero: at most {orders.attrs.get('zero_rtol', 1e-10):g} of the load scale (round-off)"
    if "force_negligible_level" not in orders:
        return zero
    return (f"{zero}; negligible: at most {orders.attrs.get('negligible', 0.0):g} of one cylinder's share of it, "
            f"{float(orders['force_negligible_level']):.2g} N, {float(orders['moment_negligible_level']):.2g} N m")


def _spectrum(page: _Page, tree, log: bool) -> None:
    from .review_plots import review_spectrum_figure
    from .tables import ORDER_VALUES, cell_classes, negligible_note

    orders = _first_speed(tree["orders"].ds)
    half = tree["time"].ds.attrs.get("revolutions", 1) > 1
    values = {name: orders[name].values for name in ORDER_VALUES if name in orders}
    classes = cell_classes(values, orders.attrs)
    k = orders["order"].values
    free = {name: (np.asarray(classes[name]) == FREE).any(axis=-1) & (k > 0) for name in ("force", "moment")}
    page.add('<section id="spectrum"><h2>Order spectrum</h2>')
    if (free["force"] | free["moment"]).any():
        top = float(k[free["force"] | free["moment"]].max())
        beyond = f" Orders above {top:g} are negligible and not drawn." if top < k.max() else ""
        drawn = [name for name in ("force", "moment") if free[name].any()]
        page.figure(partial(review_spectrum_figure, tree["orders"].ds, log=log, max_order=top, quantities=drawn),
                    f"Free {' and '.join(drawn)} per order: the co- and counter-rotating phasors"
                    f"{' and the roll' if 'moment' in drawn else ''}; the tables below give each engine axis"
                    f"{' (log scale)' if log else ''}.{beyond}{_undrawn(free)}", "spectrum")
    for name, units in (("force", "N"), ("moment", "N m")):
        cells = np.concatenate([values[name], values[f"{name}_rotating"]], axis=-1)
        rows = [[f"{k[i]:g}"] + [part for value, code in zip(cells[i], classes[name][i])
                                 for part in _class_phasor(complex(value), int(code))] for i in np.flatnonzero(k > 0)]
        header = ["order"] + [f"{c} {part}" for c in ("x", "y", "z", "co", "counter")
                              for part in ("amplitude", "phase")]
        page.add(f"<h3>Free {name} [{units}]</h3>" + _table(header, rows, 0))
    page.add('<p class="note">Amplitudes are peak values of Re(C·e^{ikθ}); phases at θ = 0. '
             + _e(negligible_note(classes["levels"], float(orders.attrs.get("negligible", 0.0)))) + "."
             + (" Orders are per crank revolution: over the four-stroke cycle of two revolutions they run in halves;"
                " the inertial loads have whole orders only and the gas adds only the roll moment M_x (at whole and"
                " half orders)." if half else "") + "</p>")
    if tree["orders"].ds.sizes.get("speed", 1) >= CAMPBELL_SPEEDS:
        from .sweep_plots import campbell_figure

        rpm = tree["orders"].ds["rpm"].values
        page.add(f'<p class="note">The tables are at {float(rpm[0]):.6g} rpm, the first of {rpm.size} speeds; every '
                 "speed is in the maps below and in the Datasets.</p>")
        for name in ("force", "moment"):
            page.figure(partial(campbell_figure, tree["orders"].ds, name=name),
                        f"Campbell map: the peak of each order's {name} vector over a revolution against crank speed, "
                        f"{float(rpm.min()):.6g} to {float(rpm.max()):.6g} rpm.", f"campbell-{name}")
    page.add("</section>")


def _undrawn(free: dict) -> str:
    """The caption's note on a quantity with nothing free (not drawn)."""
    quiet = [name for name in ("force", "moment") if not free[name].any()]
    return f" The {quiet[0]} is zero or negligible at every order and not drawn." if quiet else ""


def _stars(page: _Page, tree) -> None:
    from .review_plots import free_phasor_orders, review_stars_figure, review_stars_note

    stars = _free_vector_stars(tree)
    page.add('<section id="stars"><h2>Crank stars and phasor diagrams</h2>')
    if free_phasor_orders(_first_speed(stars)):
        note = review_stars_note(stars)
        page.figure(partial(review_stars_figure, stars),
                    "Crank stars and the free force and moment phasors of the orders with a free force or moment "
                    f"(each cylinder's arrow head to tail, co- and counter-rotating). {note}", "stars")
    else:
        page.add("<p>No order has a free force or moment: nothing to draw.</p>")
    page.add("</section>")


def _traces(page: _Page, runs: _Runs) -> None:
    from .plots import locus_figure, time_traces_figure

    after, before = runs.after, runs.before
    revolutions = int(after.attrs.get("revolutions", 1))
    heading = "Over one revolution" if revolutions == 1 else f"Over the working cycle ({revolutions} revolutions)"
    page.add(f'<section id="time"><h2>{heading}</h2>')
    period = "the revolution" if revolutions == 1 else "the working cycle"
    if before is None:
        page.figure(partial(time_traces_figure, after), "Shaking force and moment per axis over the crank angle.",
                    "traces")
        page.figure(partial(locus_figure, after), f"Locus of the transverse force and moment over {period}.", "locus")
    else:
        page.figure(partial(time_traces_figure, before, after=after),
                    "Shaking force and moment per axis over the crank angle, without the balancer elements (solid) "
                    "and with them (dashed).", "traces")
        page.figure(partial(locus_figure, before, after=after), "Locus of the transverse force and moment, without and "
                    "with the balancer elements.", "locus")
    page.add("</section>")


def _balancers(page: _Page, scene, tree) -> None:
    from ..scene.requests import signed_ratio
    from .plots import phasing_figure
    from .tables import targeted_rows

    if not scene.shafts and "verify" not in tree.children:
        return
    page.add('<section id="balancers"><h2>Balancers</h2>')
    rows = []
    for shaft in scene.shafts:
        kind = "crank counterweight" if shaft.on_crank else "balance shaft"
        for u in shaft.unbalances:
            rows.append([shaft.label, kind, signed_ratio(shaft.ratio), f"{u.unbalance * 1e3:.5g} kg mm",
                         f"{math.degrees(u.angle) % 360:.2f}°", f"{u.x * 1e3:.6g} mm",
                         f"({shaft.y * 1e3:g}, {shaft.z * 1e3:g}) mm"])
        if shaft.couple:
            rows.append([shaft.label, "couple unbalance", signed_ratio(shaft.ratio),
                         f"{abs(shaft.couple) * 1e6:.5g} kg mm²", f"{math.degrees(np.angle(shaft.couple)) % 360:.2f}°",
                         "—", f"({shaft.y * 1e3:g}, {shaft.z * 1e3:g}) mm"])
    if rows:
        page.add(_table(["element", "type", "speed ratio", "unbalance", "angle at θ = 0", "axial position",
                         "axis (y, z)"], rows, 2))
        page.figure(partial(phasing_figure, scene),
                    "Phasing of the balancer elements at θ = 0: each unbalance as n²·U in its direction "
                    "(+z up, the direction of rotation to the right).", "phasing")
    if "verify" in tree.children:
        check = _first_speed(tree["verify"].ds)
        vrows = [[f"order {k} {name.replace('_', ' ')}", f"{abs(complex(row['before'])):.5g} {units}",
                  f"{abs(complex(row['predicted'])):.3g} {units}", f"{abs(complex(row['exact'])):.3g} {units}",
                  f"{float(row['tolerance']):.2g} {units}", "pass" if bool(row["passed"]) else "FAIL"]
                 for k, name, row, units in targeted_rows(check)]
        page.add(f"<h3>Verification by the exact model: {'passed' if check.attrs['passed'] == 'yes' else 'FAILED'}"
                 "</h3>" + _table(["target", "before", "predicted", "exact residual", "tolerance", "result"], vrows, 1))
        worsened = str(check.attrs.get("worsened", "")).strip()
        if worsened:
            page.add('<p class="verdict-free"><strong>Warning:</strong> '
                     + "; ".join(_e(line) for line in worsened.splitlines()) + ".</p>")
    page.add("</section>")


def _lever(page: _Page, scene, tree, runs: _Runs) -> None:
    from .plots import lever_figure
    from .review_plots import mechanism_figure

    if "joints" not in tree.children:
        return
    joints = tree["joints"].ds
    sel = _first_speed(joints)
    page.add('<section id="lever"><h2>Lever balancers and joint forces</h2>')
    rows = [[str(name), str(sel["joint_description"].values[j]), f"{float(sel['joint_force_peak'].values[j]):.5g} N",
             f"{math.degrees(float(sel['joint_force_peak_angle'].values[j])):.1f}°"]
            for j, name in enumerate(sel["joint"].values)]
    page.add(_table(["joint", "acting", "peak", "at θ"], rows, 2))
    if "lever" in joints.dims:
        drows = [[str(label), f"{math.degrees(float(joints['min_transmission_angle'].sel(lever=label))):.4g}°",
                  f"{math.degrees(float(joints['min_transmission_theta'].sel(lever=label))):.5g}°",
                  f"{float(joints['discriminant_margin'].sel(lever=label)):.4g}"] for label in joints["lever"].values]
        page.add(_table(["lever", "minimum transmission angle", "at θ", "closure margin min sin²γ"], drows, 1))
    if scene.levers:
        page.figure(partial(mechanism_figure, scene),
                    "The mechanism at four crank angles: cranks (dark), con-rods (blue) and "
                    "pistons (squares) on their cylinder axes (dashed); each lever balancer's second crank pin (grey), "
                    "the balance weight B–C (vermillion, the dot its centre of gravity), the rocker (green) "
                    "and its fixed pivot (triangle).", "mechanism")
    page.figure(partial(lever_figure, joints),
                "Joint force magnitudes and the transmission angle over the crank angle.", "lever")
    _lever_weight(page, scene, runs)
    page.add("</section>")


def _lever_weight(page: _Page, scene, runs: _Runs) -> None:
    """The frame force without the lever balancers, with the scene's balance
    weight and with the optimal one (:func:`harmbal.balance.lever.design_lever`
    on the scene's ``[design.lever]`` request), when the scene asks for one."""
    from ..scene.requests import LeverDesignRequest

    if not isinstance(scene.design, LeverDesignRequest):
        page.add('<p class="note">The scene has no [design.lever] table, so the report does not look for a better '
                 "balance weight (docs/lever.md).</p>")
        return
    from ..balance.lever import design_lever
    from ..balance.solvers import DesignError

    try:
        result = design_lever(scene)
    except DesignError as exc:
        page.add(f'<p class="note">No balance weight designed: {_e(exc)}</p>')
        return
    page.add(f"<h3>Frame force with the scene's and the optimal balance weight of {_e(result.lever)!s}</h3>"
             + _lever_weight_table(result, runs))


def _criterion_without(before, request) -> float:
    """The lever design's criterion of the loads without the balancer
    elements (``before``, simulated at the first speed's samples)."""
    from ..balance.lever import criterion

    ds = _first_speed(before)
    values = np.stack([ds[name.split("_")[0]].sel(axis=name.split("_")[1]).values for name in request.signals])
    return criterion(values, request.objective, request.orders, request.weights)


def _lever_weight_table(result, runs: _Runs) -> str:
    """The weight, the criterion per signal and the frame force per order
    with the scene's weight and the optimal one, and without the lever."""
    b, request = result.breakdown, result.request
    rpm = result.speed * 30 / math.pi
    found = "optimal" if result.method != "compass" else "end point"
    unit = str(b["signal_units"].values[0]) + ("²" if request.objective == "orders" else "")
    rows = [[label, f"{m:.4g} kg", f"({x * 1e3:.4g}, {y * 1e3:.4g}) mm", f"{value:.5g} {unit}"]
            for label, (m, x, y), value in (("the scene's weight", result.start, result.criterion_start),
                                            (f"{found} weight", result.weight, result.criterion))]
    if runs.before is not None:
        without = _criterion_without(runs.before, request)
        rows.insert(0, ["without the lever balancers", "—", "—", f"{without:.5g} {unit}"])
    text = _table(["", "mass", "CG (x along B→C, y ahead)", f"{request.objective.replace('_', ' ')} of "
                   f"{' + '.join(request.signals)}"], rows, 1)
    signals = [[str(name).replace("_", " "), f"{float(b['criterion'].values[0, j]):.5g} {unit}",
                f"{float(b['criterion'].values[1, j]):.5g} {unit}"] for j, name in enumerate(b["signal"].values)]
    text += _table(["signal", "the scene's weight", f"{found} weight"], signals, 1)
    orders = [[f"{k:g}"] + [f"{float(v):.5g}" for v in (*b["force"].values[0, i], *b["force"].values[1, i])]
              for i, k in enumerate(b["order"].values) if k > 0]
    text += _table(["order", "scene's: co [N]", "counter [N]", f"{found}: co [N]", "counter [N]"], orders, 1)
    check = "verified" if result.verified else "NOT verified"
    return text + (f'<p class="note">At {rpm:.6g} rpm ({result.method}); the exact model of the scene with the '
                   f"{found} weight gives {result.exact_criterion:.6g} {unit} ({check}). <code>harmbal design</code> "
                   "writes that scene.</p>")


def _distinct_cylinders(scene) -> list[str]:
    """The first cylinder of each group with the same pressure trace and
    slider-crank: the others' pressure is the same curve shifted to their
    firing TDC, so drawing it again adds nothing."""
    seen, labels = set(), []
    for c in scene.cylinders:
        key = (c.gas, c.crank_radius, c.rod_length, c.offset)
        if key not in seen:
            seen.add(key)
            labels.append(c.label)
    return labels


def _shown_speeds(rpm) -> tuple[list[int], str]:
    """Indices of the speeds given a row in the per-speed tables (those the
    CLI prints), and a note naming those left out; every speed is in the
    Datasets."""
    from .tables import printed_speeds

    rpm = np.atleast_1d(rpm)
    shown = list(printed_speeds(rpm, []))
    if len(shown) == rpm.size:
        return shown, ""
    return shown, (f'<p class="note">{rpm.size} speeds from {rpm.min():.6g} to {rpm.max():.6g} rpm: the lowest and '
                   "the highest are shown; every speed is in the Datasets.</p>")


def _torque(page: _Page, scene, tree) -> None:
    from ..orders.spectrum import BALANCED_RTOL
    from .plots import pressure_figure, speed_fluctuation_figure, torque_figure, torque_scale, torque_spectrum_figure

    if "torque" not in tree.children:
        return
    torque = tree["torque"].ds
    at = _first_speed(torque)
    rpm = float(at["rpm"])
    span = 360 * int(torque.attrs.get("revolutions", 1))
    page.add('<section id="torque"><h2>Torque</h2><h3>Cylinder pressure and indicated work</h3>')

    drawn = _distinct_cylinders(scene)
    if len(scene.cylinders) == 1:
        which = ""
    elif len(drawn) == 1:
        which = f" of cylinder {drawn[0]} (every cylinder has the same trace, shifted to its firing TDC)"
    else:
        which = f" of cylinders {', '.join(drawn)} (the others repeat one of these, shifted to their firing TDC)"
    page.figure(partial(pressure_figure, torque, cylinders=drawn), f"Cylinder pressure (absolute){which} over the "
                "crank angle θ of throw 1, and the p–V diagram against the displaced volume above TDC.", "pressure")
    rows = [[str(label), f"{math.degrees(float(fire)) % span:.1f}°", f"{float(volume) * 1e6:.5g} cm³",
             f"{float(imep) / 1e5:.4g} bar"]
            for label, fire, volume, imep in zip(torque["cylinder"].values, torque["firing_angle"].values,
                                                 torque["swept_volume"].values, torque["imep"].values)]
    page.add(_table(["cylinder", "firing TDC at θ", "swept volume", "IMEP"], rows, 1))
    mean = float(torque["mean_torque"])
    rpms, speeds = np.atleast_1d(torque["rpm"].values), np.atleast_1d(torque["speed"].values)
    shown, note = _shown_speeds(rpms)
    rows = [["mean torque", f"{mean:.5g} N m"]]
    rows += [[f"indicated power at {rpms[i]:.6g} rpm", f"{mean * speeds[i] / 1e3:.4g} kW"] for i in shown]
    page.add(_table(["quantity", "value"], rows, 1) + note)

    page.add("<h3>Torque over the working cycle</h3>")
    page.figure(partial(torque_figure, torque), "Torque on the crankshaft in the direction of rotation over the "
                f"working cycle at {rpm:.6g} rpm (constant speed): the gas torque of all cylinders, the mass torque "
                "the moving parts take from the crank, the torque the crank delivers (gas − mass) and its mean.",
                "torque")
    page.add(f"<h3>Torque orders at {rpm:.6g} rpm</h3>")
    page.figure(partial(torque_spectrum_figure, torque), f"Orders of the delivered and of the gas torque at {rpm:.6g} "
                "rpm (peak amplitudes); major orders shaded.", "torque-spectrum")
    scale = torque_scale(torque)
    gas = torque["gas_torque_order"].sum("cylinder").values
    total = at["torque_order"].values
    rows = []
    for i, (k, major) in enumerate(zip(torque["order"].values, torque["major_order"].values)):
        if i == 0:
            continue
        rows.append([f"{k:g}", "major" if major else "", *_phasor(complex(total[i]), scale, BALANCED_RTOL),
                     *_phasor(complex(gas[i]), scale, BALANCED_RTOL)])
    page.add(_table(["order", "major", "delivered amplitude [N m]", "delivered phase", "gas amplitude [N m]",
                     "gas phase"], rows, 2)
             + f'<p class="note">T(θ) = Σ Re(C_k·e^{{ikθ}}) with k in {"half " if span > 360 else ""}orders of the '
             "crank speed: amplitudes are peak values, phases at θ = 0 (throw 1 along +z). A major order is one "
             f"where every cylinder's gas harmonic is in phase. Components within {BALANCED_RTOL:g} of the largest "
             "order amplitude cancel and are shown as 0.</p>")
    if "omega" in torque:
        page.add("<h3>Speed fluctuation</h3>")
        page.figure(partial(speed_fluctuation_figure, torque), f"Crank speed over the working cycle at a mean of "
                    f"{rpm:.6g} rpm, driven by the gas torque against a constant load with the rotating inertia "
                    "of the flywheel and the moving parts.", "speed-fluctuation")
        rows = [["constant inertia J₀ (flywheel, crankshaft …)", f"{float(torque['flywheel_inertia']):.5g} kg m²"]]
        if "load_torque" in torque:
            rows.append(["load torque", f"{float(torque['load_torque']):.5g} N m"])
        needed = torque.get("flywheel_inertia_needed")
        if needed is not None:
            rows.append(["target coefficient δ", f"{float(needed.attrs['fluctuation_target']):.4g}"])
        page.add(_table(["quantity", "value"], rows, 1))
        header = ["speed", "coefficient δ = (ω_max − ω_min)/ω_mean"]
        if needed is not None:
            header.append("J₀ needed for the target")
        delta = np.atleast_1d(torque["fluctuation_coefficient"].values)
        rows = []
        for i in shown:
            row = [f"{rpms[i]:.6g} rpm", f"{delta[i]:.4g}"]
            if needed is not None:
                row.append(f"{np.atleast_1d(needed.values)[i]:.5g} kg m²")
            rows.append(row)
        page.add(_table(header, rows, 1) + note)
    page.add("</section>")


def _loads(page: _Page, scene, tree) -> None:
    from .plots import crank_pin_figure, main_bearing_figure
    from .tables import CRANK_TRAIN_LOADS

    if "loads" not in tree.children:
        return
    loads = tree["loads"].ds
    at = _first_speed(loads)
    rpm = float(at["rpm"])
    span = 360 * int(loads.attrs["revolutions"])
    sweep_note = " (the first speed of the sweep; every speed is in the Datasets)" if "speed" in loads.dims else ""
    page.add('<section id="loads"><h2>Bearing and interface loads</h2>'
             f'<p class="note">At {rpm:.6g} rpm{sweep_note}, '
             f"constant speed, over {span}°{' with the cylinder pressure' if loads.attrs['gas'] == 'yes' else ''}. "
             "Peaks and means are of the magnitude; see docs/loads.md for the frames and the method.</p>"
             "<h3>Crank train</h3>")
    rows = []
    for label in at["cylinder"].values:
        row = at.sel(cylinder=label)
        for name, meaning in CRANK_TRAIN_LOADS:
            rows.append([str(label), meaning, f"{float(row[name + '_peak']):.5g} N",
                         f"{math.degrees(float(row[name + '_peak_angle'])):.1f}°",
                         f"{float(row[name + '_mean']):.5g} N"])
    page.add(_table(["cylinder", "joint", "peak", "at θ", "mean"], rows, 2))
    drawn = _distinct_cylinders(scene)
    which = "" if len(drawn) == len(scene.cylinders) else (
        f" of cylinder{'s' if len(drawn) > 1 else ''} {', '.join(drawn)} (the others' diagrams are the same)")
    page.figure(partial(crank_pin_figure, loads, cylinders=drawn), f"Polar diagrams{which} at {rpm:.6g} rpm: the "
                "con-rod's force on the crank pin in the crank frame (radial outwards up, tangential in the direction "
                "of rotation to the right; the dot is the peak), and the crank pin's force on the big-end bearing in "
                "the rod frame.", "crank-pin")
    if "bearing" in loads.dims:
        page.add("<h3>Main bearings</h3>")
        rows = [[str(label), f"{float(at['bearing_position'].sel(bearing=label)) * 1e3:.6g} mm",
                 f"{float(at['main_bearing_force_peak'].sel(bearing=label)):.5g} N",
                 f"{math.degrees(float(at['main_bearing_force_peak_angle'].sel(bearing=label))):.1f}°",
                 f"{float(at['main_bearing_force_mean'].sel(bearing=label)):.5g} N",
                 f"{abs(complex(at['main_bearing_order'].sel(bearing=label, rotation='co', order=0))):.5g} N"]
                for label in at["bearing"].values]
        page.add(_table(["bearing", "axial position", "peak", "at θ", "mean magnitude", "mean force"], rows, 1)
                 + '<p class="note">Statically determinate split: each load on the crankshaft is carried by the two '
                 "main bearings around it by the lever rule (overhung loads by the last two). A continuous-beam "
                 "solution shares the loads differently (docs/loads.md).</p>")
        page.figure(partial(main_bearing_figure, loads), f"Main-bearing loads at {rpm:.6g} rpm: the crankshaft's "
                    "force on each bearing over the angle in the block frame (+z up, t to the right); the dot is the "
                    "peak.", "main-bearings")
        orders = [k for k in at["order"].values if 0 < k <= MAIN_BEARING_ORDERS]
        phasors = at["main_bearing_order"].sel(order=orders)
        rows = [[str(label)] + [f"{abs(complex(phasors.sel(bearing=label, rotation=r, order=k))):.4g}"
                                for k in orders for r in ("co", "counter")] for label in at["bearing"].values]
        page.add(_table(["bearing"] + [f"{k:g} {r}" for k in orders for r in ("co", "counter")], rows, 1)
                 + '<p class="note">Orders of the main-bearing force [N]: amplitudes of the co- and counter-rotating '
                 "phasors (w = F_z + i·F_t, as in the order spectrum); the mean force is in the table above.</p>")
    if "shaft" in loads.dims:
        page.add("<h3>Balance-shaft bearings</h3>")
        rows = []
        for label in at["shaft"].values:
            for end in at["shaft_bearing"].values:
                row = at.sel(shaft=label, shaft_bearing=end)
                rows.append([str(label), str(end), f"{float(row['shaft_bearing_position']) * 1e3:.6g} mm",
                             f"{float(row['shaft_bearing_rotating']):.5g} N",
                             f"{float(np.hypot(*row['shaft_bearing_static'].values)):.5g} N",
                             f"{float(row['shaft_bearing_peak']):.5g} N"])
        page.add(_table(["shaft", "bearing", "axial position", "rotating amplitude", "static load", "peak"], rows, 2))
    if "element" in loads.dims:
        top = float(loads["fastener_speed"]) * 30 / math.pi
        rows = [[str(label), str(int(count)), f"{float(value):.5g} N"] for label, count, value in
                zip(loads["element"].values, loads["fasteners"].values, loads["fastener_load"].values) if count]
        if rows:
            page.add(f"<h3>Fastener loads at {top:.6g} rpm</h3>"
                     + _table(["element", "fasteners", "load per fastener"], rows, 1))
        if "ramp_torque" in loads:
            rows = [[str(label), f"{inertia:.5g} kg m²", f"{torque:.4g} N m", f"{power:.4g} W"]
                    for label, inertia, torque, power in zip(loads["element"].values, loads["inertia"].values,
                                                             loads["ramp_torque"].values, loads["ramp_power"].values)
                    if np.isfinite(inertia)]
            page.add(f"<h3>Drive torque of the speed ramp {_e(loads['ramp_torque'].attrs['ramp'])}</h3>"
                     + _table(["element", "moment of inertia", "torque I·α", "power at the end speed"], rows, 1))
    page.add("</section>")


def _clearance(page: _Page, tree) -> None:
    if "clearance" not in tree.children:
        return
    from .tables import collisions_first

    ds = tree["clearance"].ds
    distance, collision = ds["min_distance"].values, ds["collision"].values
    rows = [[str(ds["pair"].values[i]), f"{ds['body_a'].values[i]} / {ds['body_b'].values[i]}",
             f"{distance[i] * 1e3:.4f} mm", f"{math.degrees(float(ds['angle'].values[i])):.1f}°",
             "COLLISION" if collision[i] else "clear"] for i in collisions_first(ds)]
    verdict = (f"<strong>{int(collision.sum())} of {distance.size} pairs collide.</strong>" if collision.any()
               else f"No collision: the closest of {distance.size} pairs are {distance.min() * 1e3:.4g} mm apart."
               if distance.size else "No two outlines can meet (different bodies, overlapping axial ranges).")
    page.add('<section id="clearance"><h2>Clearance between moving parts</h2>'
             f"<p>{verdict}</p>" + _table(["parts", "bodies", "smallest distance", "at θ", "result"], rows, 2)
             + '<p class="note">Over one revolution: each sampled minimum refined to 1e-13 rad; negative distances '
             "are overlaps. Outlines are 2-D and convex, in each cylinder's plane (docs/shapes.md).</p></section>")


def _provenance(page: _Page, scene, source: str, made_by: dict) -> None:
    """How to make the page again: the harmbal version and source revision
    that computed the numbers (``made_by``, the analysis tree's root
    attributes; this harmbal's if absent), the commands, and the scene text."""
    from .._version import UNKNOWN_REVISION, source_revision

    here = (__version__, source_revision())
    version = str(made_by.get("harmbal_version", here[0]))
    revision = str(made_by.get("source_revision", UNKNOWN_REVISION if "harmbal_version" in made_by else here[1]))
    text = _reproduce(version, revision, source)
    if (version, revision) != here:
        text += (f'<p class="note">The numbers come from an analysis by harmbal {_e(version)} (revision '
                 f"{_e(revision)}); this page was laid out by harmbal {_e(here[0])} (revision {_e(here[1])}).</p>")
    page.add(f'<section id="provenance"><h2>Provenance</h2>{text}'
             f"<h3>Scene</h3><pre>{_e(scene.source_text)}</pre></section>")


def _reproduce(version: str, revision: str, source: str) -> str:
    """The paragraphs that say which harmbal made the numbers and how to
    install it and run the report again (harmbal is on no package index)."""
    from .._version import UNKNOWN_REVISION

    command = f"harmbal report {shlex.quote(source)} -o report.html"
    if revision != UNKNOWN_REVISION:
        made = (f"Made by harmbal {_e(version)} at source revision <code>{_e(revision)}</code> (the git commit of "
                "the harmbal sources it ran from; uncommitted changes are not recorded)")
        commands = f"git checkout {revision}\npip install .\n{command}"
        how = "install that revision from a clone of the harmbal sources, then run the command"
    else:
        made = (f"Made by harmbal {_e(version)}, source revision unknown (it did not run from a git checkout of "
                "the harmbal sources)")
        commands = command
        how = f"install harmbal {_e(version)} from its sources (<code>pip install .</code> in a copy of them), then run"
    return (f"<p>{made}, from <code>{_e(source)}</code>. harmbal is not published on a package index: to reproduce, "
            f"{how} from the folder the scene's path is relative to:</p><pre>{_e(commands)}</pre>"
            "<p>The scene text below is the whole input: save it under that name if the file has changed.</p>")


def _sections(page: _Page, scene, tree, log: bool, source: str | None) -> None:
    """Every section of the page, in order (figures rendered later, by ``page.text``)."""
    runs = _Runs(scene, tree)
    _summary(page, scene, tree, runs)
    _settings(page, scene, tree)
    _spectrum(page, tree, log)
    _stars(page, tree)
    _traces(page, runs)
    _balancers(page, scene, tree)
    _lever(page, scene, tree, runs)
    _torque(page, scene, tree)
    _loads(page, scene, tree)
    if "mounts" in tree.children:
        from .mount_report import mounts_section

        mounts_section(page, scene, tree)
    _clearance(page, tree)
    _provenance(page, scene, source or scene.source, dict(tree.attrs))


def _stored_scene(attrs):
    """The scene an analysis stored in its /scene attributes, re-read from its
    text and the trace files stored with it, without opening a file. An
    archive written before the files were stored (no ``scene_files``) reads
    them from the file system, within the reader's rules."""
    import json

    from ..scene import SceneError, scene_from_text
    from ..scene.schema import MISSING, Problem

    source = attrs.get("source", "<scene>")
    files = None
    if "scene_files" in attrs:
        try:
            files = json.loads(attrs["scene_files"])
        except (TypeError, ValueError):
            files = None
        if not (isinstance(files, dict) and all(isinstance(v, str) for v in files.values())):
            raise SceneError([Problem(source, "(stored trace files)", MISSING, "the archive's /scene attribute "
                                      "scene_files is not a JSON table of file texts: the archive is damaged")])
    return scene_from_text(attrs["scene_toml"], source, files=files)


def report(tree, path: str | os.PathLike | None = None, *, log: bool = False, source: str | None = None,
           css: str = "") -> str:
    """The HTML report of an analysis.

    Parameters
    ----------
    tree : xarray.DataTree
        From :func:`harmbal.analyse` or :func:`harmbal.open_archive` (its
        ``/scene`` group holds the scene text the report rebuilds from).
    path : path-like, optional
        Write the page there (atomically).
    log : bool, default False
        Draw the order spectrum on a log scale.
    source : str, optional
        The file named under "provenance"; default the scene's source.
    css : str, optional
        Style rules added after the built-in ones (so they take precedence),
        e.g. a house font or wider pages; see docs/report.md.

    Returns
    -------
    str
        The HTML text.
    """
    scene = _stored_scene(tree["scene"].ds.attrs)
    from ..model.budget import check_budget

    check_budget(scene, "report", analysed=True)  # its figures and tables per speed, before any is drawn
    page = _Page()
    _sections(page, scene, tree, log, source)
    body = page.text()
    title = f"harmbal report: {scene.name}"
    text = ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>{_e(title)}</title>"
            f"<style>{_STYLE}{css}</style></head><body><h1>{_e(title)}</h1>"
            f"<p class=\"note\">{_e(scene.description)}</p>" + body + "</body></html>\n")
    if path is not None:
        from ..io.files import atomic_path

        with atomic_path(Path(path)) as tmp:
            tmp.write_text(text, encoding="utf-8")
    return text
