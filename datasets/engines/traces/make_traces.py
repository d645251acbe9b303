"""Write the bundled pressure-trace CSV files from harmbal's parametric model.

Run from the repository root:

    python datasets/engines/traces/make_traces.py

tractor-full-load.csv is the parametric full-load trace of
datasets/engines/tractor-3cyl-gas.toml (cylinder 1), sampled every 0.5° from
firing TDC over one four-stroke cycle (0 … 719.5°), in the two-column layout
indicating systems export: a header line naming the units, then one
"angle,pressure" line per sample. It is SYNTHETIC, not a measurement; the
file's comment lines say so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import harmbal as hb
from harmbal.model.pressure import cylinder_pressure

HERE = Path(__file__).resolve().parent
STEP_DEG = 0.5


def main() -> None:
    scene = hb.load_scene(HERE.parent / "tractor-3cyl-gas.toml")
    c = scene.cylinders[0]
    angle = np.arange(0.0, 720.0, STEP_DEG)
    pressure = cylinder_pressure(c.gas, c.crank_radius, c.rod_length, c.offset, scene.cycle, np.radians(angle))
    lines = [
        "# SYNTHETIC full-load cylinder pressure of reference engine A (tractor diesel, bore 105 mm),",
        "# not a measurement: harmbal's parametric trace of datasets/engines/tractor-3cyl-gas.toml",
        f"# (peak {pressure.max() / 1e5:.4g} bar), written by traces/make_traces.py every {STEP_DEG:g} deg.",
        "# Crank angle from the cylinder's firing TDC; absolute pressure.",
        "angle [deg],pressure [bar]",
    ]
    lines += [f"{a:g},{p / 1e5:.10g}" for a, p in zip(angle, pressure)]
    (HERE / "tractor-full-load.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
