"""What the top of the report says: the engine in one line, and per order
that is not negligible the free force, moment and roll before and after the
scene's balancers, with what would remove what remains.

"What would remove it" is sized from the remaining rotating phasor P of
order k (a co- or counter-rotating phasor of the transverse vector
w = v_z + i·v_t at θ = 0, docs/conventions.md) at crank speed ω:

* a force: one static unbalance U·e^{iα} on an element turning at +k×
  (co-rotating) or −k× (counter-rotating) crank speed makes the phasor
  k²ω²·U·e^{iα} (:func:`harmbal.model.balancers.shaft_amplitudes`, either
  sense of turning), so it cancels P with U = |P|/(k²ω²) at α = arg P + 180°,
  placed in the plane of the reference point (x = x_ref: it adds no moment
  about it);
* a moment: a couple, two opposite unbalances U in planes a distance s apart
  around the reference point. The one at x_ref + s/2 makes the moment
  i·σ·(s/2)·k²ω²·U·e^{iα} about it (σ = the scene's ``sense``), the one at
  x_ref − s/2, at α + 180°, as much again, so the pair cancels P with
  U = |P|/(s·k²ω²) at α = arg(i·σ·P) (the front plane; the rear one
  opposite). s is the axial span of the cylinders, or
  :data:`DEFAULT_SPACING` for a single plane of cylinders;
* the roll (the moment about the crank axis) is left to the mounts: no
  unbalance on the crank axis changes it (shafts off the axis can, as a
  Lanchester pair at two heights does, but that is a design, not a size).

The inertial loads go with ω², so these unbalances are the same at every
speed. They are first sizes that cancel the component on its own, not a
design: ``harmbal design`` places elements where the scene says and checks
what else they change.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np

from ..orders.spectrum import FREE, NEGLIGIBLE, ZERO, classify

#: Plane spacing [m] of a couple when the cylinders lie in one plane (a single, a V-twin on one pin).
DEFAULT_SPACING = 0.1

#: The components of an order, as (key, heading, units) in the order the headline shows them.
COMPONENTS = (("force_co", "F co", "N"), ("force_counter", "F counter", "N"), ("moment_co", "M co", "N m"),
              ("moment_counter", "M counter", "N m"), ("roll", "roll", "N m"))


@dataclass(frozen=True)
class OrderLoads:
    """The components of one order at one speed: complex phasors and class
    codes per key of :data:`COMPONENTS`."""

    order: float
    values: dict
    classes: dict

    @property
    def free(self) -> bool:
        return any(c == FREE for c in self.classes.values())


@dataclass(frozen=True)
class Removal:
    """What cancels one free rotating component: ``kind`` of element, the
    ``unbalance`` [kg m] and its ``angle`` [rad] at θ = 0 (from +z in the
    direction of rotation), in the plane ``x`` [m] for a force, or in each
    of two planes ``spacing`` [m] apart around ``x`` for a moment (``angle``
    the front plane's, at x + spacing/2)."""

    order: int
    quantity: str
    rotation: str
    amplitude: float
    unbalance: float
    angle: float
    x: float
    spacing: float | None


def engine_line(scene) -> str:
    """The engine in one line: cylinders and layout, cycle, speeds, rotation,
    e.g. ``8 cylinders in a 90° V, four-stroke, 3000 and 6000 rpm, turning
    clockwise seen from the front.``"""
    rpm = np.asarray(scene.speeds) * 30 / math.pi
    speeds = (" and ".join(f"{v:.6g}" for v in rpm) if rpm.size <= 3
              else f"{rpm.min():.6g}–{rpm.max():.6g} ({rpm.size} speeds)")
    gas = ", with gas pressure" if "gas" in scene.model.effects and any(c.gas for c in scene.cylinders) else ""
    words = layout_words(scene)
    return (f"{words[0].upper()}{words[1:]}, {'four' if scene.cycle == 4 else 'two'}-stroke, {speeds} rpm, turning "
            f"{scene.rotation} seen from the front{gas}.")


def layout_words(scene) -> str:
    """The cylinders and how they are laid out, e.g. ``8 cylinders in a 90° V``."""
    n = len(scene.cylinders)
    banks = sorted({round(math.degrees(c.bank) % 360, 6) for c in scene.cylinders})
    if n == 1:
        return "a single cylinder"
    if len(banks) == 1:
        return f"{n} cylinders inline"
    if len(banks) == 2:
        angle = round(min((banks[1] - banks[0]) % 360, (banks[0] - banks[1]) % 360), 4)
        return f"{n} cylinders opposed (180°)" if angle == 180 else f"{n} cylinders in a {angle:g}° V"
    signed = sorted((b + 180) % 360 - 180 for b in banks)
    return f"{n} cylinders in {len(banks)} banks at " + ", ".join(f"{b:g}°".replace("-", "−") for b in signed)


def order_loads(orders) -> list[OrderLoads]:
    """Every order above 0 of an ``/orders`` Dataset at one speed, with the
    Dataset's own classes."""
    roll = orders["moment"].values[:, 0]
    out = []
    for i, k in enumerate(orders["order"].values):
        if i == 0:
            continue
        values, classes = {}, {}
        for name in ("force", "moment"):
            for j, rotation in enumerate(("co", "counter")):
                values[f"{name}_{rotation}"] = complex(orders[f"{name}_rotating"].values[i, j])
                classes[f"{name}_{rotation}"] = int(orders[f"{name}_class"].values[i, j])
        values["roll"], classes["roll"] = complex(roll[i]), int(np.atleast_1d(orders["roll_class"].values)[i])
        out.append(OrderLoads(float(k), values, classes))
    return out


def judged_like(before, after) -> list[OrderLoads]:
    """The orders of ``before`` (an ``/orders`` Dataset at one speed, the
    engine without its balancer elements) classed by the scales and
    negligible levels of ``after`` (the scene's), so that both rows of the
    headline use one rule."""
    scales, levels = _scales_and_levels(after)
    out = []
    for loads in order_loads(before):
        classes = {key: int(classify(value, scales[key], levels[key])) for key, value in loads.values.items()}
        out.append(OrderLoads(loads.order, loads.values, classes))
    return out


def _scales_and_levels(orders) -> tuple[dict, dict]:
    """Per key of :data:`COMPONENTS`, the load scale and the negligible level
    [N or N m] of an ``/orders`` Dataset at one speed. The roll's scale is
    recovered from its level (with gas it includes the gas torque's)."""
    fraction = float(orders.attrs.get("negligible", 0.0))
    cylinders = int(orders.attrs.get("cylinders", 1))
    scales, levels = {}, {}
    for name in ("force", "moment"):
        for rotation in ("co", "counter"):
            scales[f"{name}_{rotation}"] = float(orders[f"{name}_scale"])
            levels[f"{name}_{rotation}"] = float(orders[f"{name}_negligible_level"])
    levels["roll"] = float(orders["roll_negligible_level"])
    scales["roll"] = levels["roll"] * cylinders / fraction if fraction > 0 else float(orders["moment_scale"])
    return scales, levels


def removals(loads: OrderLoads, speed: float, sense: int, x: float, spacing: float) -> list[Removal]:
    """What cancels each free rotating component of one whole order (see the
    module docstring): a static unbalance for a force, a couple for a moment.

    Parameters
    ----------
    loads : OrderLoads
        The order after the scene's balancers.
    speed : float
        Crank speed ω [rad/s] of ``loads``.
    sense : int
        The scene's ``sense`` (+1 counterclockwise, −1 clockwise seen from the front).
    x : float
        Axial position [m] of the reference point of the moments.
    spacing : float
        Distance [m] between the two planes of a couple.
    """
    k = loads.order
    if k != int(k):
        return []
    k = int(k)
    out = []
    for quantity in ("force", "moment"):
        for rotation in ("co", "counter"):
            key = f"{quantity}_{rotation}"
            if loads.classes[key] != FREE:
                continue
            p = loads.values[key]
            if quantity == "force":
                u = -p / (k * k * speed * speed)
                out.append(Removal(k, quantity, rotation, abs(p), abs(u), cmath.phase(u), x, None))
            else:
                u = 1j * sense * p / (spacing * k * k * speed * speed)
                out.append(Removal(k, quantity, rotation, abs(p), abs(u), cmath.phase(u), x, spacing))
    return out


def couple_spacing(scene) -> float:
    """The plane spacing [m] of a couple: the axial span of the cylinders, or
    :data:`DEFAULT_SPACING` if they lie in one plane."""
    xs = [c.x for c in scene.cylinders]
    span = max(xs) - min(xs)
    return span if span > 0 else DEFAULT_SPACING


def remedy_text(loads: OrderLoads, found: list[Removal]) -> list[str]:
    """What removes what remains of an order (from :func:`removals`): per
    quantity a line with the kind of element (as the verdicts name it), then
    one line per element starting with "– ": its speed, unbalance and
    angle at θ = 0 and plane(s); a free roll gets the line "roll: the mounts"."""
    from .tables import balancer_remedy

    lines = []
    for quantity in ("force", "moment"):
        mine = {r.rotation: r for r in found if r.quantity == quantity}
        if not mine:
            continue
        co = loads.values[f"{quantity}_co"] if "co" in mine else 0
        counter = loads.values[f"{quantity}_counter"] if "counter" in mine else 0
        kind = balancer_remedy(int(loads.order), co, counter)
        lines.append(f"{quantity}: {kind}" + ("" if quantity == "force" else ", as couples"))
        lines += [f"– {_size(mine[r])}" for r in ("co", "counter") if r in mine]
    if loads.classes["roll"] == FREE:
        lines.append("roll: the mounts")
    return lines


def _size(r: Removal) -> str:
    """One removal in words: element speed, unbalance [kg mm], angle at θ = 0, plane(s)."""
    ratio = f"{'+' if r.rotation == 'co' else '−'}{r.order}×"
    angle = round(math.degrees(r.angle), 1) % 360
    if r.spacing is None:
        return f"{ratio}: {r.unbalance * 1e3:.4g} kg mm at {angle:.1f}° (x = {_mm(r.x)})"
    return (f"{ratio}: {r.unbalance * 1e3:.4g} kg mm at {angle:.1f}° (x = {_mm(r.x + r.spacing / 2)}) and at "
            f"{(angle + 180) % 360:.1f}° (x = {_mm(r.x - r.spacing / 2)})")


def _mm(x: float) -> str:
    """A length [m] in mm with a true minus sign."""
    return f"{x * 1e3:.4g} mm".replace("-", "−")


def cell(value: complex, code: int) -> str:
    """A headline cell: ``0`` (round-off), ``~0`` (negligible) or the amplitude."""
    if code == ZERO:
        return "0"
    if code == NEGLIGIBLE:
        return "~0"
    return f"{abs(value):.4g}"


def order_ranges(orders) -> str:
    """Orders as ranges of consecutive ones, e.g. ``5–8, 10`` (whole orders)
    or ``0.5–2`` (half orders, steps of ½)."""
    values = sorted(float(k) for k in orders)
    if not values:
        return ""
    step = min(np.diff(values)) if len(values) > 1 else 1.0
    step = 0.5 if step < 1 else 1.0
    runs, start, last = [], values[0], values[0]
    for k in values[1:]:
        if abs(k - last - step) < 1e-9:
            last = k
            continue
        runs.append((start, last))
        start = last = k
    runs.append((start, last))
    def text(a: float, b: float) -> str:
        if a == b:
            return f"{a:g}"
        return f"{a:g}, {b:g}" if abs(b - a - step) < 1e-9 else f"{a:g}–{b:g}"

    return ", ".join(text(a, b) for a, b in runs)


def quiet_orders(after: list[OrderLoads], before: list[OrderLoads] | None) -> tuple[list[float], list[float]]:
    """The orders left out of the headline: (negligible, zero): nothing
    free before or after, and something negligible, or everything zero."""
    shown = {o.order for o in after if o.free} | {o.order for o in before or () if o.free}
    negligible: list[float] = []
    zero: list[float] = []
    for o in after:
        if o.order in shown:
            continue
        codes = list(o.classes.values()) + (list(_by_order(before)[o.order].classes.values()) if before else [])
        (negligible if NEGLIGIBLE in codes else zero).append(o.order)
    return negligible, zero


def _by_order(loads: list[OrderLoads] | None) -> dict:
    return {o.order: o for o in loads or ()}


def headline_orders(after: list[OrderLoads], before: list[OrderLoads] | None) -> list[float]:
    """The orders the headline shows: any component free before or after."""
    shown = {o.order for o in after if o.free} | {o.order for o in before or () if o.free}
    return sorted(shown)
