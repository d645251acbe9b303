"""Time what gas costs: analyse() of the bundled gas scenes against the same
scenes without the gas effect.

Run from the repository root with harmbal installed:

    python benchmarks/bench_gas.py [--repeat 200]

Without gas a scene is sampled as finely as its inertia needs (48 samples per
revolution for the V8 at the default accuracy); with gas at least 720
(``GAS_SAMPLES_PER_REV``: a pressure trace's harmonics decay algebraically)
over the two revolutions of a four-stroke cycle. So two ratios are printed:
against the scene without gas at its own sampling, and at the gas scene's
sampling (what the gas itself adds: one trace per cylinder type, a shift per
cylinder, the /torque view). The four timings of a scene are taken in turn,
call by call, so that a shared machine's changing load does not skew the
ratios. With gas the inertia keeps a grid of its own
(``inertia_samples``) and is interpolated onto the gas grid where a
time-domain sum needs it. A second table measures what the 720 samples per
revolution buy: the gas torque's order phasors against 4× finer sampling,
and the tail estimate harmbal reports for them; a third, what the
interpolation costs in accuracy: the inertia's time-domain loads of the gas
scene against the inertia evaluated directly on the gas grid. Prints
Markdown tables; docs/performance.md records the figures and the machine.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from timing import interleaved_medians, machine

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
SCENES = ("single-gas", "inline-4-gas", "tractor-3cyl-measured-gas", "v8-cross-plane-gas")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=200, help="calls per timing")
    args = parser.parse_args()

    import harmbal as hb
    from harmbal.model.gas import gas_loads
    import numpy as np

    from harmbal.model.evaluate import evaluate
    from harmbal.model.sampling import choose_samples, inertia_samples
    from harmbal.orders.spectrum import aliasing_estimate, phasors

    print(machine(args.repeat).replace("min of", "median of").replace("timeit repeats", "calls"))
    print("| scene | samples/rev with gas (inertia) | analyse with gas | gas_loads | without gas (own sampling) | "
          "ratio | without gas (same sampling) | ratio |\n|---|---|---|---|---|---|---|---|")
    for name in SCENES:
        scene = hb.load_scene(ENGINES / f"{name}.toml")
        n = choose_samples(scene)
        inertia = scene.with_effects(scene.model.effects - {"gas"})
        same = dataclasses.replace(inertia, sampling=dataclasses.replace(inertia.sampling, samples_per_rev=n))
        gas, loads, own, at_n = interleaved_medians(
            [lambda: hb.analyse(scene), lambda: gas_loads(scene, n), lambda: hb.analyse(inertia),
             lambda: hb.analyse(same)], args.repeat)
        print(f"| {name} | {n} ({inertia_samples(scene)}) | {gas * 1e3:.2f} ms | {loads * 1e3:.2f} ms | "
              f"{own * 1e3:.2f} ms | {gas / own:.2f}× | "
              f"{at_n * 1e3:.2f} ms | {gas / at_n:.2f}× |")

    print("\n| scene | samples/rev | max order error of the gas torque vs 4× finer (/ largest order) | "
          "tail estimate (/ largest order) |\n|---|---|---|---|")
    for name in SCENES:
        scene = hb.load_scene(ENGINES / f"{name}.toml")
        n, kmax = choose_samples(scene), scene.sampling.max_order
        count = scene.cycle // 2 * kmax + 1  # orders 0, 1/2, … max_order of the four-stroke cycle
        coarse, fine = gas_loads(scene, n), gas_loads(scene, 4 * n)
        reference = phasors(fine.torque.sum(axis=0))[:count]
        error = np.abs(phasors(coarse.torque.sum(axis=0))[:count] - reference).max()
        tail = aliasing_estimate(np.abs(phasors(coarse.torque)), coarse.theta.size, count - 1).sum()
        largest = np.abs(reference[1:]).max()
        print(f"| {name} | {n} | {error / largest:.2g} | {tail / largest:.2g} |")

    print("\n| scene | inertia samples/rev → gas grid | force error (/ force_scale) | moment error (/ moment_scale) | "
          "mass torque error (/ its peak) |\n|---|---|---|---|---|")
    for name in SCENES:
        scene = hb.load_scene(ENGINES / f"{name}.toml")
        n, w2 = choose_samples(scene), np.square(scene.speeds)[:, None, None]
        tree = hb.analyse(scene)
        time, torque = tree["time"].ds, tree["torque"].ds
        inertia = scene.with_effects(scene.model.effects - {"gas"})
        direct = evaluate(inertia, n)
        force, moment = (w2 * np.tile(values, 2) for values in direct.total())
        moment[:, 0] -= scene.sense * torque.gas_torque.values.sum(axis=0)  # the gas moment: −sense·T
        drive = w2[:, 0] * np.tile(direct.drive_torque.sum(axis=0), 2)
        errors = [np.abs(time[key].values - want).max() / float(time[f"{key}_scale"].max())
                  for key, want in (("force", force), ("moment", moment))]
        errors.append(np.abs(torque.mass_torque.values - drive).max() / np.abs(drive).max())
        print(f"| {name} | {time.attrs['inertia_samples_per_rev']} → {n} | "
              + " | ".join(f"{e:.1g}" for e in errors) + " |")


if __name__ == "__main__":
    main()
