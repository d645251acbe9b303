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
import io
import math
import os
from pathlib import Path

import numpy as np

from .._version import __version__
from ..orders.spectrum import is_balanced

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
pre { background: #f6f6f6; padding: 0.8rem; overflow-x: auto; font-size: 0.8rem; }
.verdict-balanced { color: #006d4f; } .verdict-free { color: #a33b00; }
.note { font-size: 0.85rem; color: #444; }
@media print {
  body { max-width: none; margin: 0; }
  figure, table, pre { break-inside: avoid; page-break-inside: avoid; }
  figure svg { max-height: 23cm; }  /* a tall figure shrinks to one A4 page, caption included */
  h2 { break-after: avoid; page-break-after: avoid; }
  pre { white-space: pre-wrap; }
}
"""


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _svg(fig, number: int) -> str:
    """A figure as an inline ``<svg>`` element: deterministic, text as text,
    ids unique on the page (one hash salt per figure)."""
    import matplotlib

    buffer = io.StringIO()
    with matplotlib.rc_context({"svg.hashsalt": f"harmbal-{number}", "svg.fonttype": "none"}):
        fig.savefig(buffer, format="svg", metadata={"Date": None})
    text = buffer.getvalue()
    return text[text.index("<svg"):]


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
    """Collects sections and numbers the figures."""

    def __init__(self):
        self.parts: list[str] = []
        self.figures = 0

    def add(self, text: str) -> None:
        self.parts.append(text)

    def figure(self, fig, caption: str, name: str) -> None:
        self.figures += 1
        self.add(f'<figure id="figure-{name}" data-figure="{_e(name)}">{_svg(fig, self.figures)}'
                 f"<figcaption>Figure {self.figures}. {_e(caption)}</figcaption></figure>")


def _free_vector_stars(tree):
    """The tree's crank stars with its free vectors (kept in /orders)."""
    from ..views.stars import with_free_vectors

    return with_free_vectors(tree["stars"].ds, tree["orders"].ds)


#: Speeds from which the spectrum section adds Campbell maps (order against speed).
CAMPBELL_SPEEDS = 3


def _first_speed(ds):
    return ds.isel(speed=0) if "speed" in ds.dims else ds


def _phasor(value: complex, scale: float, rtol: float) -> tuple[str, str]:
    if is_balanced(abs(value), scale, rtol):
        return "0", "—"
    return f"{abs(value):.5g}", f"{round(math.degrees(np.angle(value)), 1) + 0.0:.1f}°"


def _summary(page: _Page, scene, tree) -> None:
    from .tables import verdict

    time, stars = tree["time"].ds, _first_speed(_free_vector_stars(tree))
    orders = tree["orders"].ds
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
        ["harmbal version", __version__],
    ]
    page.add('<section id="summary"><h2>Summary</h2>' + _table(["item", "value"], rows, 2))
    verdict_rows = []
    for k in stars["order"].values[1:]:
        text = verdict(stars, int(k))
        verdict_rows.append(f'<tr><td>{int(k)}</td><td class="text verdict-{"balanced" if text == "balanced" else "free"}">'
                            f"{_e(text)}</td></tr>")
    page.add(f'<h3>Verdict per order at {float(np.atleast_1d(stars["rpm"].values)[0]):.6g} rpm</h3>'
             '<table><thead><tr><th>order</th><th class="text">verdict</th></tr></thead><tbody>'
             + "".join(verdict_rows) + "</tbody></table></section>")


def _spectrum(page: _Page, tree, log: bool) -> None:
    from .plots import order_spectrum_figure

    orders = _first_speed(tree["orders"].ds)
    rtol = float(orders.attrs.get("balanced_rtol", 1e-10))
    half = tree["time"].ds.attrs.get("revolutions", 1) > 1
    page.add('<section id="spectrum"><h2>Order spectrum</h2>')
    page.figure(order_spectrum_figure(tree["orders"].ds, log=log),
                f"Free force and moment per order and axis, and their co- and counter-rotating parts"
                f"{' (log scale)' if log else ''}.", "spectrum")
    for name, units in (("force", "N"), ("moment", "N m")):
        scale = float(orders[f"{name}_scale"])
        rows = []
        for i, k in enumerate(orders["order"].values):
            if i == 0:
                continue
            row = [f"{k:g}"]
            for value in list(orders[name].values[i]) + list(orders[f"{name}_rotating"].values[i]):
                row += _phasor(complex(value), scale, rtol)
            rows.append(row)
        header = ["order"] + [f"{c} {part}" for c in ("x", "y", "z", "co", "counter") for part in ("amplitude", "phase")]
        page.add(f"<h3>Free {name} [{units}]</h3>" + _table(header, rows, 0))
    page.add('<p class="note">Amplitudes are peak values of Re(C·e^{ikθ}); phases at θ = 0. Components within '
             f"{rtol:g} of the single-body load scale are balanced and shown as 0."
             + (" Orders are per crank revolution: over the four-stroke cycle of two revolutions they run in halves;"
                " the inertial loads have whole orders only and the gas adds only the roll moment M_x (at whole and"
                " half orders)." if half else "") + "</p>")
    if tree["orders"].ds.sizes.get("speed", 1) >= CAMPBELL_SPEEDS:
        from .sweep_plots import campbell_figure

        rpm = tree["orders"].ds["rpm"].values
        page.add(f'<p class="note">The tables are at {float(rpm[0]):.6g} rpm, the first of {rpm.size} speeds; every '
                 "speed is in the maps below and in the Datasets.</p>")
        for name in ("force", "moment"):
            page.figure(campbell_figure(tree["orders"].ds, name=name),
                        f"Campbell map: the peak of each order's {name} vector over a revolution against crank speed, "
                        f"{float(rpm.min()):.6g} to {float(rpm.max()):.6g} rpm.", f"campbell-{name}")
    page.add("</section>")


def _stars(page: _Page, tree) -> None:
    from .plots import stars_figure

    page.add('<section id="stars"><h2>Crank stars and phasor diagrams</h2>')
    page.figure(stars_figure(_free_vector_stars(tree)), "Crank stars and the free force and moment phasors per order "
                "(each cylinder's arrow head to tail, co- and counter-rotating).", "stars")
    page.add("</section>")


def _traces(page: _Page, scene, tree) -> None:
    from .plots import locus_figure, time_traces_figure
    from ..views.time import simulate

    # Smooth curves need more angles than the spectra: the traces are simulated again from the scene
    # at TRACE_SAMPLES or more (the same from a scene and from its archive).
    samples = max(int(tree["time"].ds.attrs["samples_per_rev"]), TRACE_SAMPLES)
    after = simulate(scene, samples_per_rev=samples)
    before = None
    if (scene.shafts or scene.levers) and "balancers" in scene.model.effects:
        before = simulate(scene.with_effects(scene.model.effects - {"balancers"}), samples_per_rev=samples)
    revolutions = int(after.attrs.get("revolutions", 1))
    heading = "Over one revolution" if revolutions == 1 else f"Over the working cycle ({revolutions} revolutions)"
    page.add(f'<section id="time"><h2>{heading}</h2>')
    if before is None:
        page.figure(time_traces_figure(after), "Shaking force and moment per axis over the crank angle.", "traces")
        page.figure(locus_figure(after), "Locus of the transverse force and moment over the revolution.", "locus")
    else:
        page.figure(time_traces_figure(before, after=after), "Shaking force and moment per axis over the crank "
                    "angle, without the balancer elements (solid) and with them (dashed).", "traces")
        page.figure(locus_figure(before, after=after), "Locus of the transverse force and moment, without and "
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
        page.figure(phasing_figure(scene), "Phasing of the balancer elements at θ = 0: each unbalance as n²·U in "
                    "its direction (+z up, the direction of rotation to the right).", "phasing")
    if "verify" in tree.children:
        check = _first_speed(tree["verify"].ds)
        vrows = [[f"order {k} {name.replace('_', ' ')}", f"{abs(complex(row['before'])):.5g} {units}",
                  f"{abs(complex(row['predicted'])):.3g} {units}", f"{abs(complex(row['exact'])):.3g} {units}",
                  f"{float(row['tolerance']):.2g} {units}", "pass" if bool(row["passed"]) else "FAIL"]
                 for k, name, row, units in targeted_rows(check)]
        page.add(f"<h3>Verification by the exact model: {'passed' if check.attrs['passed'] == 'yes' else 'FAILED'}"
                 "</h3>" + _table(["target", "before", "predicted", "exact residual", "tolerance", "result"], vrows, 1))
    page.add("</section>")


def _lever(page: _Page, tree) -> None:
    from .plots import lever_figure

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
    page.figure(lever_figure(joints), "Joint force magnitudes and the transmission angle over the crank angle.",
                "lever")
    page.add("</section>")


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
    from .tables import _printed_speeds

    rpm = np.atleast_1d(rpm)
    shown = list(_printed_speeds(rpm, []))
    if len(shown) == rpm.size:
        return shown, ""
    return shown, (f'<p class="note">{rpm.size} speeds from {rpm.min():.6g} to {rpm.max():.6g} rpm: the lowest and '
                   "the highest are shown; every speed is in the Datasets.</p>")


def _torque(page: _Page, scene, tree) -> None:
    from ..orders.spectrum import BALANCED_RTOL
    from .plots import (pressure_figure, speed_fluctuation_figure, torque_figure, torque_scale,
                        torque_spectrum_figure)

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
    page.figure(pressure_figure(torque, cylinders=drawn), f"Cylinder pressure (absolute){which} over the "
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
    page.figure(torque_figure(torque), f"Torque on the crankshaft in the direction of rotation over the working "
                f"cycle at {rpm:.6g} rpm (constant speed): the gas torque of all cylinders, the mass torque the "
                "moving parts take from the crank, the torque the crank delivers (gas − mass) and its mean.",
                "torque")
    page.add(f"<h3>Torque orders at {rpm:.6g} rpm</h3>")
    page.figure(torque_spectrum_figure(torque), f"Orders of the delivered and of the gas torque at {rpm:.6g} rpm "
                "(peak amplitudes); major orders shaded.", "torque-spectrum")
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
             "crank speed: amplitudes are peak values, phases at θ = 0 (throw 1 along +z). A major order is one where every cylinder's gas "
             f"harmonic is in phase. Components within {BALANCED_RTOL:g} of the largest order amplitude cancel "
             "and are shown as 0.</p>")
    if "omega" in torque:
        page.add("<h3>Speed fluctuation</h3>")
        page.figure(speed_fluctuation_figure(torque), f"Crank speed over the working cycle at a mean of "
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
    several = "speed" in loads.dims
    page.add('<section id="loads"><h2>Bearing and interface loads</h2>'
             f'<p class="note">At {rpm:.6g} rpm{" (the first speed of the sweep; every speed is in the Datasets)" if several else ""}, '
             f"constant speed, over {span}°{' with the cylinder pressure' if loads.attrs['gas'] == 'yes' else ''}. "
             "Peaks and means are of the magnitude; see docs/loads.md for the frames and the method.</p>"
             "<h3>Crank train</h3>")
    rows = []
    for label in at["cylinder"].values:
        row = at.sel(cylinder=label)
        for name, meaning in CRANK_TRAIN_LOADS:
            rows.append([str(label), meaning, f"{float(row[name + '_peak']):.5g} N",
                         f"{math.degrees(float(row[name + '_peak_angle'])):.1f}°", f"{float(row[name + '_mean']):.5g} N"])
    page.add(_table(["cylinder", "joint", "peak", "at θ", "mean"], rows, 2))
    drawn = _distinct_cylinders(scene)
    which = "" if len(drawn) == len(scene.cylinders) else (
        f" of cylinder{'s' if len(drawn) > 1 else ''} {', '.join(drawn)} (the others' diagrams are the same)")
    page.figure(crank_pin_figure(loads, cylinders=drawn), f"Polar diagrams{which} at {rpm:.6g} rpm: the con-rod's "
                "force on the crank pin in the crank frame (radial outwards up, tangential in the direction of "
                "rotation to the right; the dot is the peak), and the crank pin's force on the big-end bearing in "
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
        page.figure(main_bearing_figure(loads), f"Main-bearing loads at {rpm:.6g} rpm: the crankshaft's force on "
                    "each bearing over the angle in the block frame (+z up, t to the right); the dot is the peak.",
                    "main-bearings")
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


def _provenance(page: _Page, scene, source: str) -> None:
    page.add('<section id="provenance"><h2>Provenance</h2>'
             f"<p>Made by harmbal {_e(__version__)} from <code>{_e(source)}</code>. To reproduce:</p>"
             f"<pre>pip install harmbal=={_e(__version__)}\nharmbal report {_e(source)} -o report.html</pre>"
             f"<h3>Scene</h3><pre>{_e(scene.source_text)}</pre></section>")


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
    from ..scene import scene_from_text

    attrs = tree["scene"].ds.attrs
    scene = scene_from_text(attrs["scene_toml"], attrs.get("source", "<scene>"))
    page = _Page()
    _summary(page, scene, tree)
    _spectrum(page, tree, log)
    _stars(page, tree)
    _traces(page, scene, tree)
    _balancers(page, scene, tree)
    _lever(page, tree)
    _torque(page, scene, tree)
    _loads(page, scene, tree)
    _clearance(page, tree)
    _provenance(page, scene, source or scene.source)
    title = f"harmbal report: {scene.name}"
    text = ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>{_e(title)}</title>"
            f"<style>{_STYLE}{css}</style></head><body><h1>{_e(title)}</h1>"
            f"<p class=\"note\">{_e(scene.description)}</p>" + "\n".join(page.parts) + "</body></html>\n")
    if path is not None:
        from ..io.files import atomic_path

        with atomic_path(Path(path)) as tmp:
            tmp.write_text(text, encoding="utf-8")
    return text
