"""The CLI's tables of a powertrain on its mounts (``/mounts``, :func:`harmbal.mounts`)."""

from __future__ import annotations

import numpy as np

#: A transmitted force at or below this share of the largest one in the table is round-off of an order the
#: engine does not excite (its shaking loads cancel): shown as 0, never as a number.
ZERO_SHARE = 1e-9
#: Orders listed per mount in the transmitted-force table, the largest first.
TOP_ORDERS = 4


def mounts_table(ds, title: str = "") -> str:
    """Statics, modes (energy distribution), the torque roll axis and the
    largest transmitted forces of a ``/mounts`` Dataset, as text."""
    lines = [title or f"{ds.attrs.get('engine', '')}: powertrain on {ds.sizes['mount']} mounts "
             f"(mass {ds.attrs['powertrain_mass']:.5g} kg; idle firing {ds.attrs['idle_firing_frequency']:.4g} Hz "
             f"= {ds.attrs['idle_speed'] * 30 / np.pi:.5g} rpm × order {ds.attrs['firing_order']:g})"]
    lines += ["", *statics_lines(ds), "", *modes_lines(ds), "", *force_lines(ds)]
    return "\n".join(lines)


def statics_lines(ds) -> list[str]:
    """Roll angle and each mount's preload, deflection and force per static case."""
    lines = ["Statics (force into the frame; preload along the mount's preload axis, compression positive)"]
    for case in ds["case"].values:
        sel = ds.sel(case=case)
        lines.append(f"  {case}: roll {np.degrees(float(sel['static_roll'])):+.3f}°")
        lines.append(f"    {'mount':<16}{'preload [N]':>12}{'δu [mm]':>9}{'δv [mm]':>9}{'δw [mm]':>9}"
                     f"{'Fx [N]':>10}{'Fy [N]':>10}{'Fz [N]':>10}")
        for name in ds["mount"].values:
            row = sel.sel(mount=name)
            deflection = row["static_deflection"].values * 1e3
            force = row["static_force"].values
            lines.append(f"    {str(name):<16}{float(row['preload']):>12.5g}"
                         + "".join(f"{_zero_small(d, deflection):>9.3f}" for d in deflection)
                         + "".join(f"{_zero_small(f, force):>10.5g}" for f in force))
    return lines


def modes_lines(ds) -> list[str]:
    """Frequencies, damping, dominant DOF and the kinetic-energy distribution [%]."""
    damped = "damped_frequency" in ds
    head = f"  {'mode':<5}{'f [Hz]':>8}" + (f"{'f_d [Hz]':>9}{'ζ':>7}" if damped else "")
    head += f"{'f/f_idle':>9}  {'dominant':<9}" + "".join(f"{d:>7}" for d in ds["dof"].values)
    lines = ["Rigid-body modes and kinetic-energy distribution [%] (share of each mode's energy per DOF)", head]
    for j, mode in enumerate(ds["mode"].values):
        row = f"  {int(mode):<5}{float(ds['natural_frequency'][j]):>8.3f}"
        if damped:
            row += f"{float(ds['damped_frequency'][j]):>9.3f}{float(ds['damping_ratio'][j]):>7.3f}"
        row += f"{float(ds['frequency_ratio_idle_firing'][j]):>9.3f}  {str(ds['dominant_dof'].values[j]):<9}"
        row += "".join(f"{100 * max(float(e), 0.0) + 0.0:>7.1f}" for e in ds["energy"].values[:, j])  # no "-0.0"
        lines.append(row)
    tra = ds["torque_roll_axis"].values
    lines.append(f"  torque roll axis ({tra[0]:.4f}, {tra[1]:.4f}, {tra[2]:.4f}); angle to the roll-dominant mode "
                 f"{np.degrees(float(ds['tra_roll_mode_angle'])):.2f}°")
    return lines


def force_lines(ds) -> list[str]:
    """Per mount, the orders with the largest transmitted force over the speeds,
    and the total into the frame."""
    amplitude = ds["transmitted_force_amplitude"]
    if "speed" not in amplitude.dims:
        amplitude = amplitude.expand_dims("speed")
    rpm = np.atleast_1d(ds["rpm"].values)
    values = amplitude.transpose("speed", "order", "mount").values
    largest = float(values.max(initial=0.0))
    span = f"{rpm.min():.5g}–{rpm.max():.5g} rpm" if rpm.size > 1 else f"{rpm[0]:.5g} rpm"
    lines = [f"Transmitted force into the frame over {span}: the {TOP_ORDERS} largest orders per mount "
             "(peak amplitude |f|, crank speed of the peak)",
             f"  {'mount':<16}" + "".join(f"{'order':>7}{'|f| [N]':>11}{'at rpm':>8}" for _ in range(TOP_ORDERS))]
    orders = ds["order"].values
    for m, name in enumerate(ds["mount"].values):
        peak = values[:, :, m].max(axis=0)
        at = rpm[values[:, :, m].argmax(axis=0)]
        cells = ""
        for k in np.argsort(-peak)[:TOP_ORDERS]:
            shown = "0" if peak[k] <= ZERO_SHARE * largest else f"{peak[k]:.5g}"
            cells += f"{orders[k]:>7g}{shown:>11}{at[k]:>8.5g}"
        lines.append(f"  {str(name):<16}{cells}")
    total = np.sqrt((np.abs(np.atleast_1d(ds["total_force"].values).reshape(rpm.size, orders.size, 3)) ** 2)
                    .sum(axis=-1)).max(axis=0)
    top = np.argsort(-total)[:TOP_ORDERS]
    lines.append(f"  {'total':<16}" + "".join(
        f"{orders[k]:>7g}{('0' if total[k] <= ZERO_SHARE * largest else f'{total[k]:.5g}'):>11}{'':>8}" for k in top))
    return lines


def _zero_small(value: float, among: np.ndarray) -> float:
    """``value``, or 0 if it is round-off next to the largest of ``among``."""
    return 0.0 if abs(value) <= 1e-12 * float(np.abs(among).max(initial=0.0)) else float(value)


def mount_design_table(result) -> str:
    """The variables and constraints of a mount design (:func:`harmbal.design_mounts`) before and after,
    in the units mount engineers read (N/mm, mm, deg), and the verdict."""
    verdict = ("feasible" if result.feasible else "misses a constraint") + ", " + (
        "verified by recomputing the designed scene" if result.verified else "NOT confirmed by the recomputation")
    what = ("RMS over speeds and orders of the mounts' force into the frame [N]"
            if result.objective == "transmitted_force" else "the weakest mode's decoupling")
    lines = [f"Mount design: {what} {result.objective_before:.5g} → {result.objective_after:.5g} ({verdict})",
             f"  {'mount':<16}{'variable':<14}{'before':>10}{'after':>10}{'bounds':>22}  {'unit':<6}group"]
    for v in result.variables:
        factor, unit = _SHOWN.get(v.units, (1.0, v.units))
        bounds = f"[{v.lower * factor:.5g}, {v.upper * factor:.5g}]"
        lines.append(f"  {v.mount:<16}{v.kind + ' ' + v.axis:<14}{v.before * factor:>10.5g}{v.after * factor:>10.5g}"
                     f"{bounds:>22}  {unit:<6}{v.group or ''}")
    lines += ["", f"  {'constraint':<22}{'limit':>14}{'before':>10}{'after':>10}"]
    for c in result.constraints:
        factor, unit = _SHOWN.get(c.units, (1.0, c.units))
        limit = f"{c.sense} {c.limit * factor:.5g} {unit}".rstrip()
        lines.append(f"  {c.name:<22}{limit:>14}{c.before * factor:>10.5g}{c.after * factor:>10.5g}"
                     + ("" if c.satisfied else "  missed"))
    return "\n".join(lines + [f"  {m}" for m in (*result.messages, *result.mismatches)])


#: SI units of design variables and constraints -> (factor, the unit shown).
_SHOWN = {"N/m": (1e-3, "N/mm"), "m": (1e3, "mm"), "rad": (180 / np.pi, "deg"), "1": (1.0, "")}


def mount_monte_carlo_table(mc) -> str:
    """Percentiles of the modes, their decoupling, the TRA angle and the peak transmitted force per mount of a
    mount Monte Carlo run (:func:`harmbal.mount_monte_carlo`)."""
    p = [f"P{v:g}" for v in mc["percentile"].values]
    lines = [f"{mc.attrs.get('title', 'mount Monte Carlo')}: {mc.attrs['samples']} samples, seed {mc.attrs['seed']}",
             *(f"  {t}" for t in mc.attrs["tolerances"]), "",
             f"  {'mode':<6}" + "".join(f"{'f ' + q + ' [Hz]':>14}" for q in p)
             + "".join(f"{'decoupl. ' + q:>14}" for q in p)]
    frequency, share = mc["natural_frequency_percentile"].values, mc["decoupling_percentile"].values
    for j, mode in enumerate(mc["mode"].values):
        lines.append(f"  {int(mode):<6}" + "".join(f"{f:>14.4g}" for f in frequency[:, j])
                     + "".join(f"{d:>14.3f}" for d in share[:, j]))
    angle = np.degrees(mc["tra_roll_mode_angle_percentile"].values)
    lines += ["", "  angle between the TRA and the roll mode [deg]: " + ", ".join(
        f"{q} {a:.3g}" for q, a in zip(p, angle)), "",
        f"  {'mount':<16}" + "".join(f"{'peak |f| ' + q + ' [N]':>18}" for q in p)]
    force = mc["peak_transmitted_force_percentile"].values
    for m, name in enumerate(mc["mount"].values):
        lines.append(f"  {str(name):<16}" + "".join(f"{v:>18.5g}" for v in force[:, m]))
    return "\n".join(lines)
