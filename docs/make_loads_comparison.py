"""The main-bearing loads of the tractor (datasets/engines/tractor-3cyl-loads-gas.toml) by the
statically determinate split that harmbal uses, against a continuous beam on rigid, aligned
supports (the statically indeterminate textbook alternative): the table of docs/loads.md and its
figures docs/figures/loads-crank-pin.svg and docs/figures/loads-main-bearings.svg.

The continuous beam: a uniform Euler–Bernoulli beam (its bending stiffness cancels out on rigid
supports) through every main bearing, loaded by the crank-pin forces, the flywheel's weight and
nothing else, solved by finite elements with a node at every bearing and load (cubic Hermite
elements are exact for point loads). Run: python docs/make_loads_comparison.py
"""

from pathlib import Path

import numpy as np

import harmbal as hb
from harmbal.model.bearings import crank_train, to_w
from harmbal.model.gas import gas_loads

ROOT = Path(__file__).resolve().parent.parent


def continuous_beam(supports, x, loads):
    """Reactions on rigid supports (support, ...) of a uniform beam carrying the forces ``loads``
    (load, ...) at ``x``; the loads on the supports are minus the reactions."""
    nodes = np.unique(np.concatenate([supports, x]))
    n = nodes.size
    k = np.zeros((2 * n, 2 * n))
    for i, length in enumerate(np.diff(nodes)):
        a = np.array([[12, 6 * length, -12, 6 * length], [6 * length, 4 * length**2, -6 * length, 2 * length**2],
                      [-12, -6 * length, 12, -6 * length], [6 * length, 2 * length**2, -6 * length, 4 * length**2]])
        k[2 * i:2 * i + 4, 2 * i:2 * i + 4] += a / length**3
    f = np.zeros((2 * n,) + loads.shape[1:], dtype=complex)
    for j, xj in enumerate(x):
        f[2 * int(np.searchsorted(nodes, xj))] += loads[j]
    fixed = [2 * int(np.searchsorted(nodes, s)) for s in supports]
    free = np.setdiff1d(np.arange(2 * n), fixed)
    u = np.zeros_like(f)
    u[free] = np.linalg.solve(k[np.ix_(free, free)], f[free].reshape(free.size, -1)).reshape(f[free].shape)
    return (k @ u.reshape(2 * n, -1)).reshape(f.shape)[fixed] - f[fixed]


def main():
    scene = hb.load_scene(ROOT / "datasets" / "engines" / "tractor-3cyl-loads-gas.toml")
    n = 2048  # samples per revolution, as hb.loads takes them for its peaks
    gas = gas_loads(scene, n)
    train = crank_train(scene, gas.theta, gas.force)
    w2 = scene.speeds[0] ** 2
    on_pins = -(w2 * train.big_end_unit + train.big_end_gas)  # rods on the crank pins, w-plane
    flywheel = scene.loads.static_loads[0]
    x = np.array([c.x for c in scene.cylinders] + [flywheel.x])
    loads = np.concatenate([on_pins, np.full((1, on_pins.shape[1]), to_w(flywheel.force, scene.sense))])
    bearings = np.array(scene.loads.main_bearings)
    beam = -continuous_beam(bearings, x, loads)
    ds = hb.loads(scene, samples_per_rev=n)
    determinate = ds.main_bearing_force.transpose("bearing", "axis", "angle").values
    determinate = determinate[:, 1] - 1j * scene.sense * determinate[:, 0]
    print("| bearing | x [mm] | peak, determinate [kN] | peak, continuous beam [kN] | mean, determinate [kN] | "
          "mean, continuous beam [kN] |")
    print("|---|---|---|---|---|---|")
    for j, xb in enumerate(bearings):
        print(f"| {j + 1} | {xb * 1e3:g} | {np.abs(determinate[j]).max() / 1e3:.1f} | {np.abs(beam[j]).max() / 1e3:.1f} "
              f"| {np.abs(determinate[j]).mean() / 1e3:.2f} | {np.abs(beam[j]).mean() / 1e3:.2f} |")
    total = np.abs(determinate.sum(axis=0) - beam.sum(axis=0)).max()
    print(f"\nLargest difference of the totals: {total:.2g} N (both carry the same loads)")
    figures(scene, ds, determinate, beam)


def figures(scene, ds, determinate, beam):
    """The crank-pin polar diagram of cylinder 1 and the main bearings' polar diagrams by both methods."""
    import matplotlib

    from matplotlib.figure import Figure

    from harmbal.reporting.plots import crank_pin_figure, save_figure

    out = ROOT / "docs" / "figures"
    with matplotlib.rc_context({"svg.hashsalt": "harmbal-loads", "svg.fonttype": "none"}):
        # every 4th angle: smooth curves, a smaller file
        save_figure(crank_pin_figure(ds.isel(angle=slice(None, None, 4)), cylinders=["1"]), out / "loads-crank-pin.svg")
        fig = Figure(figsize=(12.0, 3.6), layout="constrained")
        axes = fig.subplots(1, determinate.shape[0])
        reach = 1.1 * max(np.abs(determinate).max(), np.abs(beam).max()) / 1e3
        for j, ax in enumerate(axes):
            for values, label, style in ((determinate[j, ::4], "statically determinate", "-"),
                                         (beam[j, ::4], "continuous beam", "--")):
                # w = F_z + i·F_t: t to the right, z up, as every harmbal diagram
                ax.plot(np.append(values.imag, values.imag[0]) / 1e3, np.append(values.real, values.real[0]) / 1e3,
                        ls=style, lw=1.0, label=label)
            ax.set_xlim(-reach, reach)
            ax.set_ylim(-reach, reach)
            ax.set_aspect("equal")
            ax.axhline(0, color="0.85", lw=0.6, zorder=0)
            ax.axvline(0, color="0.85", lw=0.6, zorder=0)
            ax.set_title(f"bearing {j + 1} (x = {scene.loads.main_bearings[j] * 1e3:g} mm)", fontsize=9)
            ax.set_xlabel("F_t [kN] (t = +y)", fontsize=8)
            ax.tick_params(labelsize=7)
        axes[0].set_ylabel("F_z [kN]", fontsize=8)
        axes[-1].legend(fontsize=7, frameon=False, loc="lower right")
        fig.suptitle("tractor-3cyl-loads-gas at 2460 rpm, full load: main-bearing loads over the working cycle",
                     fontsize=10)
        save_figure(fig, out / "loads-main-bearings.svg")


if __name__ == "__main__":
    main()
