"""Write the figures of docs/lever.md: the lever balancer of reference engine C.

Run from anywhere:

    python docs/make_lever_figures.py

Writes into ``docs/figures/``, from ``datasets/engines/lever-single.toml`` and
harmbal itself (``harmbal.model.linkage.four_bar``, ``harmbal.joints``,
``harmbal.simulate``, ``harmbal.stars``, ``harmbal.balance.lever``):

* ``lever-sketch.svg``: the mechanism at four crank angles, with the paths of
  the joints and of the balance weight's CG (start and optimum);
* ``lever-joint-forces.svg``: joint-force magnitudes and the transmission
  angle over the revolution;
* ``lever-locus.svg``: the shaking force F_y against F_z over the revolution
  without the lever, with the scene's weight and with the optimal weight, and
  the boxes whose width + height is the peak-to-peak criterion;
* ``lever-orders.svg``: co- and counter-rotating force per order 1–4 for the
  same three cases;
* ``lever-mass.svg``: the criterion with the CG optimised for a prescribed
  mass, against that mass.

It also prints the numbers docs/lever.md quotes from these computations (the
design, the criteria, the order amplitudes, the table of optimal CGs for
prescribed masses, the toggle table, the sampling cap near toggle, the other
objectives and the compass search), so that the page can be checked against
the code. The SVGs are
deterministic (fixed hash salt, no date, text as text; written by
``harmbal.reporting.plots.save_figure``), so rerunning the script changes nothing
unless harmbal's numbers or drawing do.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ROOT / "docs" / "figures"
SCENE = ROOT / "datasets" / "engines" / "lever-single.toml"

#: Crank angles [deg] at which the sketch draws the mechanism.
SKETCH_ANGLES = (0, 90, 180, 270)

#: Prescribed masses [kg] of the table in docs/lever.md (bounds [m, m]),
#: on both sides of the free optimum (1.814 kg).
TABLE_MASSES = (0.6, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0, 2.2)

#: Masses [kg] of the curve in lever-mass.svg.
CURVE_MASSES = tuple(np.round(np.arange(0.5, 3.0001, 0.1), 10))

#: Orders in lever-orders.svg.
ORDERS = (1, 2, 3, 4)

#: Samples per revolution for the curves (as harmbal.joints and the design).
SAMPLES = 2048

#: Pivot positions y [mm] (z stays at −45 mm) of the toggle table in
#: docs/lever.md: the dataset's 115 mm, then closer and closer to toggle.
TOGGLE_PIVOTS = (115, 130, 140, 145, 148, 150, 152, 153)

#: Samples per revolution and lowest order of the fitted decay of the link
#: forces (toggle table): ln(|C_k|/k²) against k by least squares, over the
#: orders k ≥ FIT_FROM whose |C_k| is above FIT_FLOOR × the largest.
FIT_SAMPLES, FIT_FROM, FIT_FLOOR = 4096, 5, 1e-10

#: Pivot y [mm] so close to toggle (the largest |A→C| = |A| + r_C just below
#: a + b = 180 mm; the loop stops closing at y = 153.5415… mm) that the
#: default accuracy would need more than harmbal.model.sampling.MAX_SAMPLES
#: samples per revolution.
CAP_PIVOT = 153.54152

#: Crank counterweight [kg mm] at the second pin's angle for the comparison in
#: docs/lever.md (0.6 kg at the pin radius, 20 mm).
CRANK_UNBALANCE = 12


def _colours():
    from harmbal.reporting.plots import OKABE_ITO

    return OKABE_ITO


def _figure(**kwargs):
    from matplotlib.figure import Figure

    return Figure(layout="constrained", **kwargs)


def _engine(w, sense):
    """(y, z) in mm of w-plane points."""
    from harmbal.model.linkage import to_engine

    y, z = to_engine(np.asarray(w, dtype=complex), sense)
    return y * 1e3, z * 1e3


def cases(scene, design):
    """The three scenes compared: no lever, the scene's weight, the optimum."""
    return {
        "without lever": dataclasses.replace(scene, levers=()),
        f"start weight {design.start[0]:.5g} kg": scene,
        f"optimum {design.weight[0]:.4g} kg": design.scene,
    }


CASE_COLOURS = ("black", "sky_blue", "vermillion")
CASE_STYLES = ("--", "-", "-")


def sketch(scene, design) -> object:
    """The mechanism at SKETCH_ANGLES, seen from the front (y right, z up).
    Drawn for the dataset's single upright cylinder (bank 0)."""
    from matplotlib.patches import Rectangle

    from harmbal.model.kinematics import slider_crank
    from harmbal.model.linkage import four_bar

    c = _colours()
    sense = scene.sense
    lever = scene.levers[0]
    cyl = scene.cylinders[0]
    full = 2 * np.pi * np.arange(721) / 720
    path = four_bar(lever, full, sense)
    start_g = path.point("coupler", complex(*lever.coupler.cg))[0]
    best_g = path.point("coupler", complex(*design.weight[1:]))[0]
    bore = 94.0  # mm, as the dataset's header says
    fig = _figure(figsize=(11.5, 5.4))
    axes = fig.subplots(1, len(SKETCH_ANGLES), sharex=True, sharey=True)
    for ax, degrees in zip(axes, SKETCH_ANGLES):
        theta = np.radians([degrees])
        m = four_bar(lever, theta, sense)
        kin = slider_crank(theta + cyl.throw - cyl.bank, cyl.crank_radius, cyl.rod_length, cyl.offset)
        e_pin = complex(kin.a[0][0], kin.a[1][0])
        f_pin = complex(kin.b[0], kin.e[0])
        g = m.point("coupler", complex(*lever.coupler.cg))[0][0]
        g_best = m.point("coupler", complex(*design.weight[1:]))[0][0]
        a, b, cc = m.pivot, m.b[0], m.c[0]
        # paths over the revolution
        ax.plot(*_engine(path.c, sense), color="0.75", lw=0.8)
        ax.plot(*_engine(path.b, sense), color=c["blue"], lw=0.8, alpha=0.5)
        ax.plot(*_engine(start_g, sense), color=c["orange"], lw=1.0, ls=":",
                label="path of G, start weight")
        ax.plot(*_engine(best_g, sense), color=c["reddish_purple"], lw=1.0, ls="--",
                label="path of G, optimal weight")
        ax.plot(*_engine(cyl.crank_radius * np.exp(1j * full), sense), color="0.85", lw=0.8)
        # cylinder walls and piston (schematic)
        for side in (-1, 1):
            ax.plot([side * bore / 2] * 2, [70, 215], color="0.55", lw=1.0)
        _, fz = _engine(f_pin, sense)
        ax.add_patch(Rectangle((-bore / 2, fz - 15), bore, 45, facecolor="0.88", edgecolor="0.4", lw=0.8))
        # piston chain: crank D-E, rod E-F
        for p, q, colour, width in ((0, e_pin, "black", 2.2), (e_pin, f_pin, "0.35", 2.0),
                                    (0, cc, "black", 2.2),  # second crank arm D-C
                                    (a, b, c["blue"], 2.4), (b, cc, c["vermillion"], 2.8)):
            ax.plot(*_engine([p, q], sense), color=colour, lw=width, solid_capstyle="round")
        # the coupler as a body: triangle B-C-G
        ax.fill(*_engine([b, cc, g], sense), color=c["vermillion"], alpha=0.25, lw=0)
        y, z = _engine(g_best, sense)
        ax.plot(y, z, "o", ms=4, color=c["reddish_purple"], zorder=5)
        ax.text(y + 5, z - 12, "G*", fontsize=8, fontweight="bold", color=c["reddish_purple"], zorder=6)
        for point, name, dy in ((a, "A", -12), (b, "B", 8), (cc, "C", -12), (0, "D", -12), (e_pin, "E", 8),
                                (f_pin, "F", 8), (g, "G", 8)):
            y, z = _engine(point, sense)
            marker = "^" if name in ("A", "D") else "o"
            ax.plot(y, z, marker=marker, ms=6 if marker == "^" else 4, color="black",
                    mfc="white" if name in ("A", "D") else "black", zorder=5)
            ax.text(y + 5, z + dy, name, fontsize=8, fontweight="bold", zorder=6)
        ax.set_title(f"θ = {degrees}°", fontsize=9)
        ax.set_aspect("equal")
        ax.set_xlabel("y [mm]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, color="0.92", lw=0.5)
    axes[0].set_ylabel("z [mm]", fontsize=8)
    axes[0].set_xlim(-75, 140)
    axes[0].set_ylim(-135, 215)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    rotation = "clockwise" if sense < 0 else "counterclockwise"
    fig.suptitle(f"{scene.name}: the mechanism seen from the front ({rotation} rotation, θ from +z)\n"
                 "A rocker pivot, B rocker–coupler joint, C second crank pin, D crank axis, E crank pin, "
                 "F piston pin, G CG of the start weight, G* CG of the optimal weight", fontsize=9)
    return fig


def joint_forces(scene) -> object:
    """|joint force| over θ and the transmission angle."""
    import harmbal as hb

    c = _colours()
    ds = hb.joints(scene, samples_per_rev=SAMPLES)
    theta = np.degrees(ds["angle"].values)
    magnitude = np.hypot(ds["joint_force"].sel(axis="y"), ds["joint_force"].sel(axis="z"))
    rpm = float(ds["rpm"])
    fig = _figure(figsize=(8.0, 7.2))
    top, middle, bottom = fig.subplots(3, 1, sharex=True, height_ratios=(3, 2.2, 1.4))
    groups = ((top, (("lever: A", "blue", "-"), ("lever: B", "sky_blue", "--"), ("lever: C", "vermillion", "-"),
                     ("D", "black", "-"))),
              (middle, (("E1", "bluish_green", "-"), ("F1", "orange", "-"), ("W1", "reddish_purple", "-"))))
    for ax, joints in groups:
        for name, colour, style in joints:
            description = str(ds["joint_description"].sel(joint=name).values)
            ax.plot(theta, magnitude.sel(joint=name) / 1e3, color=c[colour], ls=style, lw=1.3,
                    label=f"{name}: {description}")
        ax.set_ylabel("|joint force| [kN]", fontsize=8)
        ax.legend(fontsize=7, frameon=False, loc="upper left", bbox_to_anchor=(1.0, 1.0))
        ax.set_ylim(bottom=0)
    gamma = np.degrees(ds["transmission_angle"].sel(lever=scene.levers[0].label))
    bottom.plot(theta, gamma, color=c["blue"], lw=1.3, label="transmission angle min(γ, 180° − γ)")
    bottom.axhline(float(ds.attrs["transmission_warning"]), color=c["vermillion"], ls=":", lw=1.0,
                   label="warning below 30°")
    bottom.set_ylim(0, 90)
    bottom.set_ylabel("γ [deg]", fontsize=8)
    bottom.legend(fontsize=7, frameon=False, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    bottom.set_xlabel("crank angle θ [deg]", fontsize=8)
    bottom.set_xlim(0, 360)
    bottom.set_xticks(range(0, 361, 45))
    for ax in (top, middle, bottom):
        ax.tick_params(labelsize=7)
        ax.grid(True, color="0.92", lw=0.5)
    top.set_title(f"{scene.name} at {rpm:.6g} rpm: joint forces (constant speed, no gas forces)", fontsize=9)
    return fig


def locus(scene, design) -> tuple[object, dict]:
    """F_y against F_z over the revolution, with the bounding boxes."""
    import harmbal as hb
    from matplotlib.patches import Rectangle

    c = _colours()
    fig = _figure(figsize=(6.4, 6.4))
    ax = fig.add_subplot()
    numbers = {}
    for (label, case), colour, style in zip(cases(scene, design).items(), CASE_COLOURS, CASE_STYLES):
        t = hb.simulate(case, samples_per_rev=SAMPLES)
        fy, fz = t.force.sel(axis="y").values, t.force.sel(axis="z").values
        ppy, ppz = np.ptp(fy), np.ptp(fz)
        numbers[label] = (ppy, ppz, float(np.hypot(fy, fz).max()))
        ax.plot(fy, fz, color=c[colour], ls=style, lw=1.4,
                label=f"{label}: {ppy:.5g} + {ppz:.5g} = {ppy + ppz:.5g} N")
        ax.plot(fy[0], fz[0], "o", color=c[colour], ms=4)
        ax.add_patch(Rectangle((fy.min(), fz.min()), ppy, ppz, fill=False, edgecolor=c[colour], lw=0.6,
                               ls=":"))
    ax.plot(0, 0, "+", color="0.4", ms=8)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("F_y [N] (to the right, seen from the front)", fontsize=8)
    ax.set_ylabel("F_z [N] (up)", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(True, color="0.92", lw=0.5)
    ax.set_title(f"{scene.name} at {design.speed * 30 / np.pi:.6g} rpm: shaking force over one revolution\n"
                 "(dot: θ = 0; box: peak-to-peak in y and z; legend: p-p F_y + p-p F_z)", fontsize=9)
    ax.legend(fontsize=7.5, frameon=False, loc="upper center", bbox_to_anchor=(0.5, -0.1))
    return fig, numbers


def orders(scene, design) -> tuple[object, dict]:
    """Co- and counter-rotating force per order, three cases."""
    import harmbal as hb

    c = _colours()
    values = {}
    for label, case in cases(scene, design).items():
        st = hb.stars(case)
        values[label] = np.abs(st["force_rotating"].sel(order=list(ORDERS)).values)  # (order, rotation)
    fig = _figure(figsize=(9.0, 4.2))
    axes = fig.subplots(1, 2, sharey=True)
    x = np.arange(len(ORDERS))
    width = 0.27
    for r, (ax, rotation) in enumerate(zip(axes, ("co-rotating", "counter-rotating"))):
        for j, ((label, v), colour) in enumerate(zip(values.items(), CASE_COLOURS)):
            bars = ax.bar(x + (j - 1) * width, v[:, r], width, color=c[colour], label=label,
                          edgecolor="black", lw=0.4, alpha=0.85 if colour != "black" else 0.55)
            for bar, value in zip(bars, v[:, r]):
                ax.text(bar.get_x() + bar.get_width() / 2, value + 15, f"{value:.4g}", ha="center",
                        va="bottom", fontsize=6.5, rotation=90)
        ax.set_xticks(x, [str(k) for k in ORDERS])
        ax.set_xlabel("order", fontsize=8)
        ax.set_title(f"{rotation} force", fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(True, axis="y", color="0.92", lw=0.5)
    axes[0].set_ylabel("peak amplitude [N]", fontsize=8)
    axes[0].set_ylim(0, 1.2 * max(v.max() for v in values.values()))
    axes[0].legend(fontsize=7.5, frameon=False)
    fig.suptitle(f"{scene.name} at {design.speed * 30 / np.pi:.6g} rpm: free force per order "
                 "(harmbal.stars)", fontsize=9)
    return fig, values


def mass_sweep(scene, design) -> tuple[object, list, list]:
    """The criterion with the CG optimised for each prescribed mass."""
    import harmbal as hb
    from harmbal.balance.lever import design_lever

    c = _colours()

    def at(mass):
        d = design_lever(scene, dataclasses.replace(design.request, mass=(mass, mass)))
        return (mass, d.weight[1], d.weight[2], d.criterion, *d.breakdown["criterion"].values[1], d.verified)

    table = [at(m) for m in TABLE_MASSES]
    curve = [at(float(m)) for m in sorted(CURVE_MASSES + (design.weight[0],))]
    fig = _figure(figsize=(7.0, 4.4))
    ax = fig.add_subplot()
    masses = [row[0] for row in curve]
    ax.plot(masses, [row[3] for row in curve], color=c["black"], lw=1.5, marker="o", ms=3,
            label="p-p F_y + p-p F_z (CG optimised in the envelope)")
    ax.plot(masses, [row[4] for row in curve], color=c["blue"], lw=1.1, ls="--", label="p-p F_y")
    ax.plot(masses, [row[5] for row in curve], color=c["orange"], lw=1.1, ls="--", label="p-p F_z")
    ax.plot(design.weight[0], design.criterion, "*", color=c["vermillion"], ms=11,
            label=f"optimum with free mass: {design.weight[0]:.4g} kg, {design.criterion:.5g} N")
    ax.plot(design.start[0], design.criterion_start, "s", color=c["sky_blue"], ms=6,
            label=f"start weight: {design.start[0]:.5g} kg, {design.criterion_start:.5g} N")
    bare = hb.simulate(dataclasses.replace(scene, levers=()), samples_per_rev=SAMPLES).force
    without = float(np.ptp(bare.sel(axis="y").values) + np.ptp(bare.sel(axis="z").values))
    ax.axhline(without, color=c["black"], ls=":", lw=1.0, label=f"without lever: {without:.5g} N")
    ax.set_xlabel("prescribed mass of the balance weight m [kg]", fontsize=8)
    ax.set_ylabel("criterion [N]", fontsize=8)
    ax.set_ylim(bottom=0)
    ax.tick_params(labelsize=7)
    ax.grid(True, color="0.92", lw=0.5)
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    ax.set_title(f"{scene.name} at {design.speed * 30 / np.pi:.6g} rpm: best CG for a prescribed mass "
                 "(one LP per mass)", fontsize=9)
    return fig, table, curve


def fitted_decay(scene) -> tuple[float, float]:
    """Smallest and largest decay rate, over the lever's joints A, B and C,
    of a fit |C_k| ≈ c·k²·ρᵏ to the FFT of the joint force (as a w-plane
    vector) over FIT_SAMPLES samples."""
    import harmbal as hb

    ds = hb.joints(scene, samples_per_rev=FIT_SAMPLES)
    label = scene.levers[0].label
    rates = []
    for joint in (f"{label}: A", f"{label}: B", f"{label}: C"):
        force = ds["joint_force"].sel(joint=joint)
        spectrum = np.fft.fft(force.sel(axis="y").values + 1j * force.sel(axis="z").values) / FIT_SAMPLES
        k = np.arange(1, FIT_SAMPLES // 8)
        amplitude = np.abs(spectrum[k]) + np.abs(spectrum[-k])
        use = (k >= FIT_FROM) & (amplitude > FIT_FLOOR * amplitude.max())
        slope = np.polyfit(k[use], np.log(amplitude[use] / k[use] ** 2), 1)[0]
        rates.append(float(np.exp(slope)))
    return min(rates), max(rates)


def toggle_table() -> list[tuple]:
    """The lever moved towards toggle: transmission angle, decay rate, default
    sampling, peak joint forces and the fitted decay, per pivot position."""
    import harmbal as hb
    from harmbal.scene.elements import closure
    from harmbal.model.linkage import decay_rate
    from harmbal.model.sampling import choose_samples

    rows = []
    for y in TOGGLE_PIVOTS:
        scene, caught = _variant(y)
        lever = scene.levers[0]
        check = closure(lever, scene.sense)
        ds = hb.joints(scene, samples_per_rev=SAMPLES)
        peak = dict(zip(ds["joint"].values, ds["joint_force_peak"].values))
        rows.append((y, abs(lever.pivot_w(scene.sense)), check.min_transmission_angle, check.min_transmission_theta,
                     check.margin, decay_rate(lever, scene.sense), choose_samples(scene), peak["lever: B"],
                     peak["D"], bool(caught), *fitted_decay(scene)))
    return rows


def _variant(y_mm: float):
    """The dataset with its pivot at (y_mm, −45) mm and without [design],
    loaded with every warning recorded: (scene, warnings)."""
    import copy
    import tomllib
    import warnings

    import harmbal as hb

    raw = tomllib.loads(SCENE.read_text(encoding="utf-8"))
    raw.pop("design")
    raw["lever_balancer"][0]["pivot"] = [f"{y_mm} mm", "-45 mm"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = hb.load_scene(copy.deepcopy(raw))
    return scene, caught


def accuracy_cap() -> tuple:
    """The lever at CAP_PIVOT: the warnings, the samples harmbal chooses and
    the peak force at B on them."""
    import warnings

    import harmbal as hb
    from harmbal.scene.elements import closure
    from harmbal.model.linkage import decay_rate
    from harmbal.model.sampling import choose_samples

    scene, caught = _variant(CAP_PIVOT)
    with warnings.catch_warnings(record=True) as more:
        warnings.simplefilter("always")
        samples = choose_samples(scene)
        ds = hb.joints(scene)
    lever = scene.levers[0]
    check = closure(lever, scene.sense)
    names = sorted({w.category.__name__ for w in [*caught, *more]})
    return (check.min_transmission_angle, check.margin, decay_rate(lever, scene.sense), samples,
            int(ds.attrs["samples_per_rev"]), float(ds["joint_force_peak"].sel(joint=f"{lever.label}: B")), names)


def crank_counterweight(scene, design) -> tuple:
    """The dataset with a crank counterweight of CRANK_UNBALANCE [kg mm] at
    the second pin's angle: its optimal weight and criterion, and the peak
    force at C with each optimum."""
    import tomllib

    import harmbal as hb
    from harmbal.balance.lever import design_lever

    raw = tomllib.loads(SCENE.read_text(encoding="utf-8"))
    lever = raw["lever_balancer"][0]
    raw["crankshaft_unbalance"] = [{"unbalance": f"{CRANK_UNBALANCE} kg mm", "angle": lever["pin_angle"],
                                    "axial_position": lever["axial_position"]}]
    other = design_lever(hb.load_scene(raw))
    label = f"{scene.levers[0].label}: C"

    def peak_c(s) -> float:
        return float(hb.joints(s, samples_per_rev=SAMPLES)["joint_force_peak"].sel(joint=label))

    return other, peak_c(other.scene), peak_c(design.scene)


def main() -> list[Path]:
    """Write every figure and print the numbers docs/lever.md quotes."""
    import warnings

    import harmbal as hb
    from harmbal.balance.lever import design_lever
    from harmbal.reporting.plots import save_figure

    FIGURES.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error", hb.LinkageWarning)  # the bundled lever must not be near toggle
        scene = hb.load_scene(SCENE)
    design = design_lever(scene)
    written = []

    def save(fig, name):
        path = save_figure(fig, FIGURES / name)
        written.append(path)
        print(f"wrote {path.relative_to(ROOT)} ({path.stat().st_size / 1000:.0f} kB)")

    save(sketch(scene, design), "lever-sketch.svg")
    save(joint_forces(scene), "lever-joint-forces.svg")
    fig, pp = locus(scene, design)
    save(fig, "lever-locus.svg")
    fig, spectrum = orders(scene, design)
    save(fig, "lever-orders.svg")
    fig, table, _ = mass_sweep(scene, design)
    save(fig, "lever-mass.svg")

    print(f"\ndesign: start {design.start[0]:.6g} kg at ({design.start[1] * 1e3:.6g}, {design.start[2] * 1e3:.6g}) mm"
          f" -> {design.weight[0]:.6g} kg at ({design.weight[1] * 1e3:.6g}, {design.weight[2] * 1e3:.6g}) mm; "
          f"criterion {design.criterion_start:.8g} -> {design.criterion:.8g} N")
    print("\npeak-to-peak F_y, F_z, their sum and the largest |F| over the revolution [N]:")
    for label, (ppy, ppz, largest) in pp.items():
        print(f"  {label:<24}{ppy:>10.6g}{ppz:>10.6g}{ppy + ppz:>12.8g}{largest:>10.6g}")
    print("\nforce per order, co / counter [N]:")
    for label, v in spectrum.items():
        print(f"  {label:<24}" + "  ".join(f"{k}: {co:.5g} / {counter:.5g}" for k, (co, counter) in zip(ORDERS, v)))
    print("\nprescribed mass: m [kg], x_G [mm], y_G [mm], criterion [N] (p-p F_y + p-p F_z), verified")
    for m, x, y, value, ppy, ppz, ok in table:
        print(f"  {m:4.2f}  {x * 1e3:8.3f}  {y * 1e3:8.3f}  {value:9.2f} ({ppy:.2f} + {ppz:.2f})  {ok}")
    print("\ntoggle: pivot y [mm], |A| [mm], min γ [deg] at θ [deg], margin, ρ, N, peak B [N], peak D [N], warning, "
          "fitted decay of A, B, C (min–max)")
    for y, dist, gamma, theta, margin, rho, n, b, d, warned, low, high in toggle_table():
        print(f"  {y:4d} {dist * 1e3:7.2f} {np.degrees(gamma):7.4g} {np.degrees(theta):8.5g} {margin:7.4g} "
              f"{rho:7.4g} {n:4d} {b:9.5g} {d:9.5g}  {warned!s:<5} {low:.3g}–{high:.3g}")
    print("\nother objectives:")
    for objective, extra in (("peak", {}), ("orders", {"orders": (1, 2)})):
        other = design_lever(scene, dataclasses.replace(design.request, objective=objective, **extra))
        print(f"  {objective:<7}{other.weight[0]:.6g} kg at ({other.weight[1] * 1e3:.6g}, {other.weight[2] * 1e3:.6g}) mm;"
              f" criterion {other.criterion_start:.6g} -> {other.criterion:.6g}; verified {other.verified}")
    other, peak_other, peak_here = crank_counterweight(scene, design)
    print(f"\nwith a {CRANK_UNBALANCE} kg mm crank counterweight at the pin's angle: start {other.criterion_start:.8g} N, "
          f"optimum {other.weight[0]:.6g} kg at ({other.weight[1] * 1e3:.6g}, {other.weight[2] * 1e3:.6g}) mm, "
          f"{other.criterion:.8g} N; peak force at C {peak_other:.5g} N (without it: {peak_here:.5g} N)")
    gamma, margin, rho, samples, joint_samples, peak_b, names = accuracy_cap()
    print(f"\naccuracy cap: pivot y {CAP_PIVOT} mm: min γ {np.degrees(gamma):.4g}°, margin {margin:.4g}, ρ {rho:.6g}, "
          f"{samples} samples/rev ({joint_samples} for the joints), peak B {peak_b:.5g} N; warnings {', '.join(names)}")
    compass = design_lever(scene, method="compass")
    print(f"\ncompass search: {compass.cycles} cycles, {compass.evaluations} evaluations, "
          f"{compass.weight[0]:.6g} kg at ({compass.weight[1] * 1e3:.6g}, {compass.weight[2] * 1e3:.6g}) mm, "
          f"criterion {compass.criterion:.8g} N ({compass.criterion - design.criterion:.4g} N above the LP)")
    return written


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    main()
