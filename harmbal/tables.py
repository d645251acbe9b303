"""Plain-text tables of free forces and moments per order, for the CLI."""

from __future__ import annotations

import numpy as np

from .orders import is_balanced


def _cell(phasor: complex, scale: float, rtol: float) -> str:
    amplitude = abs(phasor)
    if is_balanced(amplitude, scale, rtol):
        return f" {'0':>10}{'':>8}"
    phase = round(float(np.degrees(np.angle(phasor))), 1) + 0.0  # no "-0.0"
    return f" {amplitude:>10.5g} {phase:>6.1f}°"


def order_table(orders) -> str:
    """Free force and free moment per order, one block per speed.

    Each cell is the peak amplitude and the phase (degrees, of
    Re(C·e^{ikθ}) at θ = 0); components at or below the balanced tolerance
    print as 0 without a phase.
    """
    attrs = orders.attrs
    rtol = float(attrs.get("balanced_rtol", 1e-10))
    ref = np.asarray(attrs.get("reference_point", [0.0, 0.0, 0.0]), dtype=float) * 1e3
    lines = [
        f"{attrs.get('engine', '')}: effects {attrs.get('effects', '')}; piston {attrs.get('piston_model')}, "
        f"rod {attrs.get('rod_model')}; {attrs.get('samples_per_rev')} samples/rev",
        f"Moments about ({ref[0]:g}, {ref[1]:g}, {ref[2]:g}) mm; amplitude (peak) and phase at θ = 0; "
        f"co/counter: rotating phasors of the transverse (y, z) vector.",
    ]
    speeds = np.atleast_1d(orders["rpm"].values)
    for i, rpm in enumerate(speeds):
        sel = orders.isel(speed=i) if "speed" in orders.dims else orders
        lines.append("")
        lines.append(f"Speed {rpm:.6g} rpm ({float(np.atleast_1d(sel['speed'].values)[0]):.6g} rad/s)")
        for name, units, label in (("force", "N", "Free force"), ("moment", "N m", "Free moment")):
            scale = float(sel[f"{name}_scale"])
            axes = "".join(f"{a + ' [' + units + ']':>19}" for a in ("x", "y", "z"))
            lines.append(f"{label}  {'order':>5}{axes}{'co [' + units + ']':>19}{'counter [' + units + ']':>19}")
            values = sel[name].values
            rotating = sel[f"{name}_rotating"].values
            for k in sel["order"].values:
                row = list(values[k]) + list(rotating[k])
                if k == 0 and all(is_balanced(abs(v), scale, rtol) for v in row):
                    continue
                lines.append(f"{'':{len(label) + 2}}{k:>5}" + "".join(_cell(v, scale, rtol) for v in row))
            tail = float(np.max(sel[f"aliasing_error_{name}"].values))
            lines.append(f"{'':{len(label) + 2}}aliasing estimate {tail:.2g} {units}")
    return "\n".join(lines)
