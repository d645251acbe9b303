"""Accuracy against cost: the full matrix behind docs/accuracy.md.

Run from the repository root with harmbal installed:

    python benchmarks/bench_accuracy.py [--budget 0.02] [--repeat 3]

Measures every case of :mod:`harmbal.bench` (samples per revolution 8–4096,
accuracy targets, piston series with 2/4/8 harmonics vs exact, con-rod
models, order- vs time-domain path, FFT backends) on the single, I4, V8 and
W24 at λ = 0.25, 0.45, 0.7, 0.9 against the 50-digit mpmath reference, and
writes docs/accuracy-results.md (the tables), docs/figures/accuracy.svg (error
against time) and benchmarks/results/accuracy.csv. ``harmbal bench -o DIR``
runs the same measurement with its own choice of engines and λ.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=float, default=0.02, help="seconds of calls per timing repeat")
    parser.add_argument("--repeat", type=int, default=3, help="timing repeats (the minimum is kept)")
    args = parser.parse_args()

    from harmbal import bench
    from harmbal.io.files import atomic_path
    from harmbal.reporting.plots import accuracy_figure, save_figure

    rows = bench.run(budget=args.budget, repeat=args.repeat, engines_dir=ROOT / "datasets" / "engines",
                     progress=lambda message: print(message, file=sys.stderr, flush=True))
    results = ROOT / "benchmarks" / "results"
    results.mkdir(exist_ok=True)
    outputs = {
        results / "accuracy.csv": bench.to_csv(rows),
        ROOT / "docs" / "accuracy-results.md": (
            "# Accuracy against cost: measured tables\n\n"
            f"Written by `python benchmarks/bench_accuracy.py` on {bench.machine()}; "
            "see [accuracy.md](accuracy.md) for what the columns mean and what they imply. Each cell is the "
            "largest error of the order phasors (orders 0–12, force and moment, relative to the largest "
            "single-body load) against the 50-digit reference, and the time per operating point.\n\n"
            + bench.to_markdown(rows)),
    }
    for path, text in outputs.items():
        with atomic_path(path) as tmp:
            tmp.write_text(text, encoding="utf-8")
        print(f"wrote {path}")
    print(f"wrote {save_figure(accuracy_figure(rows), ROOT / 'docs' / 'figures' / 'accuracy.svg')}")


if __name__ == "__main__":
    main()
