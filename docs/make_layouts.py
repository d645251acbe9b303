"""Write docs/layouts.md: a worked crank-star example for every classic layout.

Run from the repository root:

    python docs/make_layouts.py

Every number on the page comes from ``harmbal.stars`` on the bundled dataset;
tests/test_docs.py checks that the committed page is what this script writes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
ORDERS = (1, 2, 3, 4)

#: Dataset and what to look for, derived by hand from the phasor sums
#: Σ e^{ikφ_i} (forces) and Σ x_i e^{ikφ_i} (moments).
LAYOUTS = {
    "inline-twin-360": "Both throws together: the forces of every order add, Σ e^{ikφ} = 2. The first-order "
                       "force is co-rotating (rotating masses) plus a standing vector (reciprocating masses); "
                       "the cylinders sit symmetrically about x = 0, so there are no moments.",
    "inline-twin-180": "Star of order 1 is regular (0, 180°): first-order forces cancel, leaving a "
                       "first-order rocking moment; even orders add (Σ e^{2iφ} = 2).",
    "inline-twin-270": "Order-1 star 0/270°: |Σ e^{iφ}| = √2, so a first-order force of √2 times one "
                       "cylinder's, plus moments; order 2 star 0/180° is regular and cancels the force.",
    "inline-3": "Stars of orders 1, 2, 4, 5 are regular (120° apart): those forces cancel. The first-order "
                "moment is √3·m·r·ω²·a for the reciprocating mass (half co-, half counter-rotating) plus the "
                "co-rotating moment of the rotating masses; order 3 stars collapse to one arm.",
    "inline-4": "Orders 1 and 3: star 0/180° ×2, regular; mirror-symmetric crank, so no moments. "
                "Orders 2 and 4: all arms at 0°, the forces add: 4·A₂·m·r·ω² of order 2, a standing vector.",
    "inline-5": "Forces of orders 1–4 cancel (regular five-arm stars); a first- and a second-order moment "
                "remain.",
    "inline-6": "Mirror-symmetric crank of two I3 halves: forces of orders 1, 2, 4, 5 and all moments "
                "cancel; order 6 (not shown) adds.",
    "v-twin-45": "Common pin, γ = 45°: order k co-rotating ∝ |cos((k−1)γ/2)|, counter-rotating "
                 "∝ |cos((k+1)γ/2)| times one cylinder's reciprocating amplitude.",
    "v-twin-60": "Common pin, γ = 60°: as above; the first-order counter-rotating force is cos 60° = ½ of "
                 "one cylinder's reciprocating half-amplitude.",
    "v-twin-90": "Common pin, γ = 90°: the first-order counter-rotating force vanishes (cos 90° = 0), so a "
                 "crank counterweight balances the first order completely; a small counter-rotating moment "
                 "remains from the rods' axial offset.",
    "boxer-twin": "Opposed cylinders on 180° throws: forces of every order cancel except for the axial "
                  "stagger, which leaves small moments of every order.",
    "flat-4": "Forces and moments of orders 1 cancel; order 2 forces cancel across the banks; small "
              "moments remain from the axial stagger.",
    "v6-60": "60° V6 with split pins: free first- and second-order moments, no free forces.",
    "v6-90-common-pin": "90° V6 on a 120° crank with common pins: uneven firing (90/150°) and free moments.",
    "v6-90-split-pin": "Split pins (30° offset) restore even firing; the balance changes accordingly.",
    "v8-cross-plane": "Forces of all orders up to 3 cancel; the first-order moment √10·m·r·ω²·a (for the "
                      "equivalent masses) is purely co-rotating, so crank counterweights balance it.",
    "v8-flat-plane": "Two I4 banks at 90°: no first-order force or moment; the banks' second-order forces "
                     "are in antiphase and add to a horizontal standing vector of 4√2·A₂·m·r·ω².",
    "v12": "Two I6 banks: every force and moment of orders 1–4 cancels.",
}


def _amplitude(value: complex, code: int) -> str:
    """The amplitude of a free component; 0 (zero to round-off) or ~0 (negligible) otherwise."""
    return f"{abs(value):.4g}" if code == 2 else ("~0" if code == 1 else "0")


def layout_section(name: str, note: str) -> str:
    import harmbal as hb
    from harmbal.reporting.tables import _arms, verdict

    scene = hb.load_scene(ROOT / "datasets" / "engines" / f"{name}.toml")
    ds = hb.stars(scene)
    if "speed" in ds.dims:
        ds = ds.isel(speed=0)
    intervals = ", ".join(f"{d:g}" for d in np.round(np.degrees(ds["firing_interval"].values), 2))
    lines = [
        f"## {scene.description or name}",
        "",
        note,
        "",
        f"`datasets/engines/{name}.toml`, {float(ds['rpm']):.0f} rpm, effects: {ds.attrs['effects']}. "
        f"Firing {ds.attrs['firing_order']}, intervals {intervals}°.",
        "",
        "| order | star arms k·φ [°] | regular | F co [N] | F counter [N] | M co [N m] | M counter [N m] | verdict |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for k in ORDERS:
        force = ds["force_rotating"].values[k]
        moment = ds["moment_rotating"].values[k]
        cells = [_amplitude(v, c) for v, c in zip(force, ds["force_class"].values[k])]
        cells += [_amplitude(v, c) for v, c in zip(moment, ds["moment_class"].values[k])]
        regular = "yes" if bool(ds["star_regular"].values[k]) else "no"
        lines.append(f"| {k} | {_arms(ds['star_angle'].values[k])} | {regular} | " + " | ".join(cells)
                     + f" | {verdict(ds, k)} |")
    return "\n".join(lines)


def page() -> str:
    header = (
        "# Worked examples: the classic layouts\n\n"
        "Generated by `python docs/make_layouts.py` from the bundled datasets with `harmbal.stars`; see\n"
        "[Crank stars and free vectors](stars.md) for what the columns mean. Amplitudes are peak values of\n"
        "the co- and counter-rotating phasors of the transverse free force F and free moment M (about the\n"
        "scene's reference point) at the dataset's first speed, with all of the dataset's effects\n"
        "(so the rotating masses and, where present, counterweights are included). `0` means zero to\n"
        "round-off (1e-10 of the load scale), `~0` negligible (at most 1e-3 of one cylinder's share of the\n"
        "load scale: [conventions](conventions.md#zero-negligible-free)). The note under each title is the hand derivation the numbers\n"
        "confirm; tests/test_stars_oracles.py checks them against independent closed forms.\n"
    )
    return header + "\n" + "\n\n".join(layout_section(name, note) for name, note in LAYOUTS.items()) + "\n"


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    (ROOT / "docs" / "layouts.md").write_text(page(), encoding="utf-8")
    print("wrote docs/layouts.md")
