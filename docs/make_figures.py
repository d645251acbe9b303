"""Write the figures of the docs: crank stars and phasor diagrams per order.

Run from anywhere:

    python docs/make_figures.py

Writes ``docs/figures/stars-<dataset>.svg`` for the bundled datasets below,
with harmbal itself (``harmbal.stars`` and ``harmbal.reporting.plots``), exactly what
``harmbal stars datasets/engines/<dataset>.toml --plot FILE [--orders ...]``
draws. The SVGs are deterministic (fixed hash salt, no date, text as text),
so rerunning the script changes nothing unless harmbal's numbers or drawing
do. Multi-speed datasets are drawn at their first speed.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FIGURES = ROOT / "docs" / "figures"
ENGINES = ROOT / "datasets" / "engines"

#: Dataset and the orders to draw (None: the default of ``harmbal stars
#: --plot``, 1, 2 and the free orders up to 8).
DATASETS: dict[str, tuple[int, ...] | None] = {
    # Regular stars of orders 1, 2, 4 and 8 (no force, free moments); order 6
    # collapses to one arm and the forces add. Default orders, as docs/stars.md
    # says (``harmbal stars datasets/engines/inline-3.toml --plot ...``).
    "inline-3": None,
    # Orders 1 cancel by symmetry; orders 2 and 4 add to standing forces.
    "inline-4": (1, 2, 4),
    # Common pin: the first-order counter-rotating force cancels across the
    # banks; order 2 is a standing lateral vector.
    "v-twin-90": (1, 2),
    # Regular stars of orders 1 and 2 in both banks; the first-order moment
    # is purely co-rotating.
    "v8-cross-plane": (1, 2),
}


def main() -> list[Path]:
    """Write every figure; returns the paths written."""
    import harmbal as hb
    from harmbal.reporting.plots import save_figure, stars_figure

    FIGURES.mkdir(parents=True, exist_ok=True)
    written = []
    for name, orders in DATASETS.items():
        ds = hb.stars(hb.load_scene(ENGINES / f"{name}.toml"))
        path = save_figure(stars_figure(ds, orders=orders), FIGURES / f"stars-{name}.svg")
        written.append(path)
        print(f"wrote {path.relative_to(ROOT)} ({path.stat().st_size / 1000:.0f} kB)")
    return written


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    main()
