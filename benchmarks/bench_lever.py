"""Time the lever balancer: kinematics, joint forces, the whole analysis, and
the balance weight's design by the linear programme against the thesis's
compass search.

* ``four_bar`` (closed-form position, μ and ν of the four-bar) and
  ``link_loads`` at 2048 crank angles;
* ``harmbal.joints`` (Newton–Euler of the whole mechanism, Dataset) and
  ``harmbal.analyse`` on ``lever-single.toml``;
* the balance weight that minimises the peak-to-peak frame force in y plus
  that in z at 3000 rpm: ``design_lever(method="exact")`` (the linear
  programme; the figure is the solver alone and the whole design with the
  output scene written, loaded and checked by the exact model) against
  ``design_lever(method="compass")``, the coordinate search with step halving
  that the source thesis used (216 cycles, 4 min 35 s in its run), with the
  lever's exact loads recomputed for every trial weight.

Run from the repository root with harmbal installed (or ``PYTHONPATH=.``):

    python benchmarks/bench_lever.py [--repeat 5]
    python -m pytest benchmarks/bench_lever.py --benchmark-only

Figures are the minimum over ``--repeat`` timeit repeats divided by the loop
count, after one warm-up call; docs/performance.md records them.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

from timing import machine, min_seconds

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "datasets" / "engines" / "lever-single.toml"
SAMPLES = 2048


@functools.cache
def scene():
    import harmbal as hb

    return hb.load_scene(SCENE)


def _kinematics():
    import numpy as np

    from harmbal.model.linkage import four_bar, link_loads

    s = scene()
    lever = s.levers[0]
    theta = 2 * np.pi * np.arange(SAMPLES) / SAMPLES
    return link_loads(lever, four_bar(lever, theta, s.sense))


def _joints():
    import harmbal as hb

    return hb.joints(scene())


def _analyse():
    import harmbal as hb

    return hb.analyse(scene())


def _design(method: str):
    from harmbal.balance.lever import design_lever

    return design_lever(scene(), method=method)


# -- pytest-benchmark ----------------------------------------------------------

try:
    import pytest
except ImportError:  # plain-script mode needs no pytest
    pytest = None

if pytest is not None:

    @pytest.mark.parametrize("function", [_kinematics, _joints, _analyse], ids=["four_bar", "joints", "analyse"])
    def test_lever_model(benchmark, function):
        benchmark.group = "lever model"
        benchmark(function)

    @pytest.mark.parametrize("method", ["exact", "compass"])
    def test_lever_design(benchmark, method):
        benchmark.group = "lever design"
        benchmark(_design, method)


# -- plain script ---------------------------------------------------------------

def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="timeit repeats (the minimum is reported)")
    args = parser.parse_args()

    print(machine(args.repeat))
    print("| lever-single | time |")
    print("|---|---|")
    for label, function in ((f"`four_bar` + `link_loads`, {SAMPLES} angles", _kinematics),
                            (f"`harmbal.joints` ({SAMPLES} angles, Dataset)", _joints),
                            ("`harmbal.analyse` (time, orders, stars, joints)", _analyse)):
        print(f"| {label} | {min_seconds(function, args.repeat) * 1e3:.2f} ms |")

    print()
    print("| method (lever-single, 3000 rpm, peak-to-peak F_y + F_z) | weight | criterion | cycles / evaluations "
          "| solver | whole design |")
    print("|---|---|---|---|---|---|")
    for method in ("exact", "compass"):
        result = _design(method)
        solver = min(_design(method).seconds for _ in range(args.repeat))
        whole = min_seconds(functools.partial(_design, method), args.repeat)
        m, x, y = result.weight
        work = f"{result.cycles} / {result.evaluations}" if method == "compass" else "—"
        name = "linear programme (HiGHS)" if method == "exact" else "compass search, step halving"
        print(f"| {name} | {m:.5f} kg at ({x * 1e3:.3f}, {y * 1e3:.3f}) mm | {result.criterion:.4f} N | {work} "
              f"| {solver * 1e3:.1f} ms | {whole * 1e3:.0f} ms |")
    start = _design("exact")
    print(f"\nstart weight {start.start[0]} kg at ({start.start[1] * 1e3:g}, {start.start[2] * 1e3:g}) mm: "
          f"{start.criterion_start:.4f} N")


if __name__ == "__main__":
    main()
