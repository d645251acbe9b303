"""Time balancer design and verification, and compare the peak objective's
linear programme with the thesis's sweep.

* ``harmbal.design`` (least squares, then the output scene written and loaded
  again) and ``harmbal.verify`` (exact time-domain model with and without the
  balancers) for each bundled engine with a ``[design]`` table;
* reference engine A (``tractor-3cyl-balanced.toml``): the crank
  counterweight couple that minimises max|M_y| + max|M_z| over the
  revolution, by the linear programme of ``harmbal.design`` (objective
  "peak") and by the thesis's method, a sweep of the couple's magnitude in
  1 N m steps and its phase in 1° steps, evaluated on the same
  ``PEAK_SAMPLES`` crank angles (vectorised over the magnitudes).

Run from the repository root with harmbal installed (or ``PYTHONPATH=.``):

    python benchmarks/bench_design.py [--repeat 5]
    python -m pytest benchmarks/bench_design.py --benchmark-only

Figures are the minimum over ``--repeat`` timeit repeats divided by the loop
count, after one warm-up call; docs/performance.md records them.
"""

from __future__ import annotations

import argparse
import functools
import math
import time
from pathlib import Path

from timing import machine, min_seconds

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
DESIGNS = ("test-single", "inline-3", "inline-4", "v6-90-split-pin", "tractor-3cyl-balanced")

#: The thesis's sweep: couple magnitudes 0 … SWEEP_MAX in 1 N m steps, phases in 1° steps.
SWEEP_MAX = 600.0


@functools.cache
def scene(stem: str):
    import harmbal as hb

    return hb.load_scene(ENGINES / f"{stem}.toml")


def _design(stem: str):
    import harmbal as hb

    return hb.design(scene(stem))


def _verify(stem: str):
    import harmbal as hb

    return hb.verify(_design(stem).scene)


def thesis_sweep(stem: str = "tractor-3cyl-balanced") -> tuple[float, float, float]:
    """Best (objective [N m], couple [N m], phase [deg]) of the sweep over the
    counterweight couple of the scene's [design] (two planes, no net force)."""
    import numpy as np

    from harmbal.balance.design import _element_loads
    from harmbal.scene.requests import PEAK_SAMPLES
    from harmbal.scene.requests import Placement
    from harmbal.model.evaluate import moment_about, evaluate

    s = scene(stem)
    x1, x2 = s.design.candidates[0].planes
    ref = np.asarray(s.reference_point)
    theta = 2 * np.pi * np.arange(PEAK_SAMPLES) / PEAK_SAMPLES
    w2 = s.speeds[0] ** 2
    unit = evaluate(s, PEAK_SAMPLES)
    base = w2 * (moment_about(ref, unit.force_cylinder, unit.moment_cylinder).sum(axis=0)
                 + moment_about(ref, unit.force_crankshaft, unit.moment_crankshaft))[1:]
    # Unit couple (1 N m at the scene's speed) pointing 0° and 90°: unbalance ±u at x1, x2.
    u = 1 / (w2 * abs(x2 - x1))
    couple = (Placement(1, 0.0, 0.0, x1, -u), Placement(1, 0.0, 0.0, x2, u))
    along = [w2 * _element_loads(couple, value, theta, s.sense, ref)[1][1:] for value in (1.0, 1j)]
    magnitudes = np.arange(0.0, SWEEP_MAX + 0.5, 1.0)[:, None, None]
    best = (math.inf, 0.0, 0.0)
    for degrees in range(360):
        phase = math.radians(degrees)
        unit_couple = math.cos(phase) * along[0] + math.sin(phase) * along[1]
        total = base[None] + magnitudes * unit_couple[None]
        objective = np.abs(total).max(axis=-1).sum(axis=-1)
        i = int(objective.argmin())
        if objective[i] < best[0]:
            best = (float(objective[i]), float(magnitudes[i, 0, 0]), float(degrees))
    return best


def linear_programme(stem: str = "tractor-3cyl-balanced") -> float:
    """The peak objective [N m] of harmbal's design, re-evaluated on the same angles."""
    import numpy as np

    from harmbal.scene.requests import PEAK_SAMPLES
    from harmbal.model.evaluate import moment_about, evaluate

    designed = _design(stem).scene
    unit = evaluate(designed, PEAK_SAMPLES)
    ref = np.asarray(designed.reference_point)
    moment = designed.speeds[0] ** 2 * (moment_about(ref, unit.force_cylinder, unit.moment_cylinder).sum(axis=0)
                                        + moment_about(ref, unit.force_crankshaft, unit.moment_crankshaft))
    return float(np.abs(moment[1:]).max(axis=-1).sum())


# -- pytest-benchmark ----------------------------------------------------------

try:
    import pytest
except ImportError:  # plain-script mode needs no pytest
    pytest = None

if pytest is not None:

    @pytest.mark.parametrize("stem", DESIGNS)
    def test_design(benchmark, stem):
        _design(stem)
        benchmark.group = "design"
        benchmark(_design, stem)

    @pytest.mark.parametrize("stem", DESIGNS)
    def test_verify(benchmark, stem):
        import harmbal as hb

        designed = _design(stem).scene
        hb.verify(designed)
        benchmark.group = "verify"
        benchmark(hb.verify, designed)


# -- plain script ---------------------------------------------------------------

def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="timeit repeats (the minimum is reported)")
    args = parser.parse_args()

    print(machine(args.repeat))
    print("| engine | objective | `design` | `verify` |")
    print("|---|---|---|---|")
    for stem in DESIGNS:
        request = scene(stem).design
        t_design = min_seconds(functools.partial(_design, stem), args.repeat)
        t_verify = min_seconds(functools.partial(_verify, stem), args.repeat) - t_design
        print(f"| {stem} | {request.objective} | {t_design * 1e3:.2f} ms | {t_verify * 1e3:.1f} ms |")

    start = time.perf_counter()
    best, magnitude, phase = thesis_sweep()
    t_sweep = time.perf_counter() - start
    t_lp = min_seconds(functools.partial(_design, "tractor-3cyl-balanced"), args.repeat)
    optimum = linear_programme()
    print()
    print("| method (reference engine A, 2460 rpm) | max\\|M_y\\| + max\\|M_z\\| | time |")
    print("|---|---|---|")
    print(f"| sweep, 1 N m × 1° ({int(SWEEP_MAX) + 1} × 360 candidates; best {magnitude:g} N m at {phase:g}°) "
          f"| {best:.4f} N m | {t_sweep:.2f} s |")
    print(f"| `harmbal.design`, linear programme (whole design) | {optimum:.4f} N m | {t_lp * 1e3:.1f} ms |")


if __name__ == "__main__":
    main()
