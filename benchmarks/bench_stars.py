"""Time the order-domain path against the time-domain path for V12 and W24.

Order domain: ``harmbal.orders.phasors.order_phasors(scene)`` (per-cylinder phasors by
the shift theorem, plain arrays) and ``harmbal.views.stars.stars(scene)`` (that plus
crank stars, firing and the xarray Dataset). Time domain:
``order_spectrum(simulate(scene))`` (exact loads of every cylinder at every
angle, FFT of the sums, two Datasets), and for reference the same arithmetic
without xarray (``evaluate`` + rFFT of the summed force and moment).
Each at the scene's default sampling and at a fixed 1024 samples/rev.

Run from the repository root with harmbal installed (or ``PYTHONPATH=.``):

    python benchmarks/bench_stars.py [--repeat 7]
    python -m pytest benchmarks/bench_stars.py --benchmark-only

The script prints a Markdown table; each figure is the minimum over
``--repeat`` repeats of ``timeit`` (loop count chosen by ``Timer.autorange``,
≥ 0.2 s per repeat) divided by the loop count, after one warm-up call.
docs/performance.md records the figures and the machine.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

from timing import machine, min_seconds

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"

#: Engine label -> scene file.
SCENES = {"V12": "v12.toml", "W24": "w24-broad-arrow.toml"}
#: Sampling label -> samples per revolution (None: the scene's default accuracy).
SAMPLINGS = {"default": None, "1024": 1024}


@functools.cache
def scene(engine: str):
    import harmbal as hb

    return hb.load_scene(ENGINES / SCENES[engine])


def _order_phasors(s, n):
    from harmbal.model.evaluate import evaluate
    from harmbal.orders.phasors import order_phasors

    return order_phasors(evaluate(s, n))


def _stars(s, n):
    from harmbal.views.stars import stars

    return stars(s, samples_per_rev=n)


def _time_domain(s, n):
    from harmbal.views.orders import order_spectrum
    from harmbal.views.time import simulate

    return order_spectrum(simulate(s, samples_per_rev=n))


def _time_domain_arrays(s, n):
    from harmbal.orders.spectrum import phasors
    from harmbal.model.sampling import choose_samples
    from harmbal.model.evaluate import evaluate

    unit = evaluate(s, n or choose_samples(s))
    kmax = s.sampling.max_order
    return (phasors(unit.force_cylinder.sum(axis=0) + unit.force_crankshaft)[..., : kmax + 1],
            phasors(unit.moment_cylinder.sum(axis=0) + unit.moment_crankshaft)[..., : kmax + 1])


#: Path label -> function(scene, samples_per_rev or None).
PATHS = {
    "order domain: `order_phasors`": _order_phasors,
    "order domain: `stars` (Dataset)": _stars,
    "time domain: `order_spectrum(simulate)`": _time_domain,
    "time domain, arrays only: `evaluate` + rFFT": _time_domain_arrays,
}


def samples_used(engine: str, samples: int | None) -> int:
    from harmbal.model.sampling import choose_samples

    return samples or choose_samples(scene(engine))


def check_agreement(engine: str, samples: int | None) -> float:
    """Largest difference between the two paths' free force phasors, relative
    to the force scale (a guard that both paths compute the same thing)."""
    import numpy as np

    s = scene(engine)
    order = _order_phasors(s, samples).force
    time = _time_domain_arrays(s, samples)[0]
    return float(np.abs(order - time).max() / _order_phasors(s, samples).peak_force.sum())


# -- pytest-benchmark ----------------------------------------------------------

try:
    import pytest
except ImportError:  # plain-script mode needs no pytest
    pytest = None

if pytest is not None:

    @pytest.mark.parametrize("path", list(PATHS), ids=["order_phasors", "stars", "time_domain", "time_domain_arrays"])
    @pytest.mark.parametrize("sampling", list(SAMPLINGS))
    @pytest.mark.parametrize("engine", list(SCENES))
    def test_path(benchmark, engine, sampling, path):
        samples = SAMPLINGS[sampling]
        s = scene(engine)
        function = PATHS[path]
        function(s, samples)  # warm-up: imports, FFT plans
        benchmark.group = f"{engine}, {sampling} sampling ({samples_used(engine, samples)} samples/rev)"
        benchmark(function, s, samples)


# -- plain script ---------------------------------------------------------------

def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7, help="timeit repeats (the minimum is reported)")
    args = parser.parse_args()

    columns = [(engine, sampling) for engine in SCENES for sampling in SAMPLINGS]
    times = {}
    for engine, sampling in columns:
        samples = SAMPLINGS[sampling]
        s = scene(engine)
        agreement = check_agreement(engine, samples)
        assert agreement < 1e-9, f"{engine} {sampling}: paths differ by {agreement:.1e} of the force scale"
        for path, function in PATHS.items():
            times[path, engine, sampling] = min_seconds(functools.partial(function, s, samples), args.repeat)

    print(machine(args.repeat))
    header = [f"{e} ({len(scene(e).cylinders)} cyl), {samples_used(e, SAMPLINGS[p])} samples/rev"
              for e, p in columns]
    print("| path | " + " | ".join(header) + " |")
    print("|---" * (len(columns) + 1) + "|")
    for path in PATHS:
        print(f"| {path} | " + " | ".join(f"{times[path, e, p] * 1e3:.3f} ms" for e, p in columns) + " |")
    reference = "time domain: `order_spectrum(simulate)`"
    for path in ("order domain: `order_phasors`", "order domain: `stars` (Dataset)"):
        print(f"| speed-up of {path.split(': ')[1]} over `order_spectrum(simulate)` | "
              + " | ".join(f"{times[reference, e, p] / times[path, e, p]:.1f}×" for e, p in columns) + " |")


if __name__ == "__main__":
    main()
