"""Timing of the crank and firing-order search (docs/search.md, issue 31's target: the inline-9
two-stroke, all 8! = 40 320 firing orders, ≤ 10 s).

    python benchmarks/bench_search.py
"""

from __future__ import annotations

import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASES = [
    ("inline-9 two-stroke, gas (40 320)", ROOT / "tests/fixtures/marine-2stroke-7.toml", {"cylinders": 9}),
    ("inline-9 two-stroke, gas, no symmetry", ROOT / "tests/fixtures/marine-2stroke-7.toml",
     {"cylinders": 9, "symmetry": False}),
    ("inline-6 four-stroke", ROOT / "datasets/engines/inline-6.toml", {}),
    ("V8 90 deg, gas", ROOT / "datasets/engines/v8-cross-plane-gas.toml",
     {"layout": "V", "bank": "90 deg", "stagger": 0.011}),
]


def main() -> None:
    import harmbal as hb

    hb.search(ROOT / "datasets/engines/inline-4.toml")  # imports and caches out of the timings
    for name, path, options in CASES:
        times = []
        for _ in range(3):
            start = time.perf_counter()
            ds = hb.search(path, **options)
            times.append(time.perf_counter() - start)
        print(f"{name}: {ds.attrs['candidates']} candidates, {ds.attrs['classes']} classes, best of 3 "
              f"{min(times):.2f} s (median {sorted(times)[1]:.2f} s)")


if __name__ == "__main__":
    main()
