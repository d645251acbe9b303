"""Write the designed variants of bundled engines: run `harmbal design` on each
engine's [design] table. Run from the repository root:

    python datasets/make_balanced.py

tests/test_design.py fails if a written file is out of date.
"""

from __future__ import annotations

import sys
from pathlib import Path

import harmbal as hb
from harmbal.scene import scene_from_text

ENGINES = Path("datasets/engines")

#: Engine with a [design] table -> designed variant (name, description).
VARIANTS = {
    "test-single": ("test-single-balanced", "Reference engine B with its counterweights (100 % rotating, two "
                                            "planes) and two first-order balance shafts"),
    "inline-3": ("inline-3-balanced", "Inline three with counterweights and a -1x moment-balance shaft"),
    "inline-4": ("inline-4-lanchester", "Inline four with a second-order Lanchester pair"),
    "v6-90-split-pin": ("v6-90-split-pin-balanced", "90 deg V6, split pins, with counterweights and a -1x "
                                                    "moment-balance shaft"),
    "tractor-3cyl-balanced": ("tractor-3cyl-tuned", "Reference engine A with its balancers and counterweights "
                                                    "tuned to the smallest peak moments"),
    "lever-single": ("lever-single-optimised", "Reference engine C with the balance weight that minimises the "
                                               "peak-to-peak frame force (illustrative geometry)"),
}


def designed_text(stem: str) -> str:
    """The designed variant of ``stem`` as harmbal writes it."""
    source = ENGINES / f"{stem}.toml"
    name, description = VARIANTS[stem]
    scene = scene_from_text(source.read_text(encoding="utf-8"), source.as_posix())
    return hb.design(scene, name=name, description=description).text


def main() -> int:
    for stem, (name, _) in VARIANTS.items():
        path = ENGINES / f"{name}.toml"
        path.write_text(designed_text(stem), encoding="utf-8")
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
