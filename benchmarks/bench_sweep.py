"""Variants per second of a design sweep against looping the public API.

The V-twin (datasets/engines/v-twin-90.toml) over 4 parameters, a grid of
10 rod lengths × 10 crank radii × 100 piston masses × 100 rod masses = 10⁶
variants (100 geometries), free force and moment phasors of orders 1 and 2
with the co/counter split and order amplitudes: ``hb.sweep`` end to end (keys
read and validated, each geometry evaluated once, the Dataset built), on one
core (BLAS and FFT threads limited to 1 before numpy is imported). Also a
pure mass sweep (one geometry), the same sweep with all orders 0–12, and
with the peaks over a revolution (10⁵ variants); Monte Carlo of the masses
(10⁶ samples, with the percentiles and the sensitivity ranking) and of the
masses and the rod length (every sample its own geometry).

First, 10⁷ variants (1 000 rod masses) with ``phasors=False``, reduced to
the best variant and the percentiles, with the process's peak memory.

Baselines, same run, on the first variants of the same grid: per variant,
``load_scene`` of the modified mapping then ``hb.analyse`` (the public
Dataset path), and ``load_scene`` then ``order_phasors`` (plain arrays).

Run from the repository root with harmbal installed:

    python benchmarks/bench_sweep.py [--repeat 3]

Each figure is the minimum over ``--repeat`` timed calls after one warm-up
call. docs/performance.md records the figures and the machine.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # one core: set before numpy loads its BLAS

import argparse
import copy
import resource
import time
import tomllib
from pathlib import Path

import numpy as np
from timing import best_seconds, machine

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "datasets" / "engines" / "v-twin-90.toml"

GRID = {
    "geometry.rod_length": np.linspace(0.120, 0.140, 10),
    "geometry.crank_radius": np.linspace(0.035, 0.039, 10),
    "piston.mass": np.linspace(0.36, 0.44, 100),
    "rod.mass": np.linspace(0.34, 0.42, 100),
}


def baseline(count: int, analyse: bool) -> float:
    """Seconds per variant of the public loop over the first ``count`` grid variants."""
    import harmbal as hb
    from harmbal.model.evaluate import evaluate
    from harmbal.orders.phasors import order_phasors

    raw = tomllib.loads(SCENE.read_text(encoding="utf-8"))
    index = np.indices([len(v) for v in GRID.values()]).reshape(len(GRID), -1).T[:count]
    start = time.perf_counter()
    for row in index:
        variant = copy.deepcopy(raw)
        (variant["geometry"]["rod_length"], variant["geometry"]["crank_radius"], variant["piston"]["mass"],
         variant["rod"]["mass"]) = (float(values[i]) for values, i in zip(GRID.values(), row))
        scene = hb.load_scene(variant)
        hb.analyse(scene) if analyse else order_phasors(evaluate(scene))
    return (time.perf_counter() - start) / count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed calls per figure (the minimum is kept)")
    args = parser.parse_args()

    import harmbal as hb

    scene = hb.load_scene(SCENE)
    size = int(np.prod([len(v) for v in GRID.values()]))
    masses = {"piston.mass": GRID["piston.mass"], "rod.mass": np.linspace(0.34, 0.42, 10_000)}
    small = {**GRID, "piston.mass": GRID["piston.mass"][::10]}  # 10⁵ variants
    small_size = int(np.prod([len(v) for v in small.values()]))
    cases = [
        ("4 parameters (100 geometries), orders 1-2", size, lambda: hb.sweep(scene, GRID, orders=[1, 2])),
        ("2 masses (1 geometry), orders 1-2", 100 * 10_000, lambda: hb.sweep(scene, masses, orders=[1, 2])),
        ("4 parameters, orders 0-12", small_size, lambda: hb.sweep(scene, small)),
        ("4 parameters, orders 1-2 + peaks (360 angles)", small_size,
         lambda: hb.sweep(scene, small, orders=[1, 2], peaks=True)),
    ]
    mc_masses = {"piston.mass": hb.Normal("2 g"), "rod.mass": hb.Normal("1 g")}
    mc_geometry = {**mc_masses, "geometry.rod_length": hb.Normal("0.02 mm")}
    monte_carlo = [
        ("piston and rod mass (normal)", 1_000_000, lambda: hb.monte_carlo(scene, mc_masses, 1_000_000, seed=1,
                                                                          orders=[1, 2])),
        ("the masses and the rod length (every sample a geometry)", 2_000,
         lambda: hb.monte_carlo(scene, mc_geometry, 2_000, seed=1, orders=[1, 2])),
    ]
    print(machine(args.repeat))
    print()
    print("| case | variants | time | variants/s |")
    print("|---|---:|---:|---:|")
    # First, so that the process's peak memory is this case's: 10⁷ variants reduced to the best one and
    # percentiles, the phasors evaluated in blocks and dropped (phasors=False). One timed call.
    big = {**GRID, "rod.mass": np.linspace(0.34, 0.42, 1000)}

    def reduced():
        ds = hb.sweep(scene, big, orders=[1, 2], phasors=False)
        best = int(np.argmin(ds.force_amplitude.sum("order").values))
        return best, ds.force_amplitude.quantile([0.05, 0.5, 0.95], dim="variant")

    start = time.perf_counter()
    reduced()
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # kB -> GB on Linux
    print(f"| hb.sweep, 4 parameters (10 × 10 × 100 × 1000), amplitudes only, reduced to the best variant and "
          f"percentiles (peak RSS {peak:.2f} GB) | 10,000,000 | {seconds:.3g} s | {1e7 / seconds:,.0f} |", flush=True)
    for label, count, function in cases:
        seconds = best_seconds(function, args.repeat)
        print(f"| hb.sweep, {label} | {count:,} | {seconds:.3g} s | {count / seconds:,.0f} |", flush=True)
    for label, count, function in monte_carlo:
        seconds = best_seconds(function, args.repeat)
        print(f"| hb.monte_carlo, {label}, orders 1-2 | {count:,} | {seconds:.3g} s | {count / seconds:,.0f} |",
              flush=True)
    for label, count, analyse in (("load_scene + hb.analyse per variant", 200, True),
                                  ("load_scene + order_phasors per variant", 1000, False)):
        baseline(5, analyse)  # warm-up
        seconds = min(baseline(count, analyse) for _ in range(args.repeat))
        print(f"| public loop: {label} | {count:,} | {seconds * count:.3g} s | {1 / seconds:,.0f} |", flush=True)


if __name__ == "__main__":
    main()
