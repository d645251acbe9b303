"""The one evaluation of the exact model that every view derives from.

:func:`evaluate` computes, at unit crank speed (ω = 1 rad/s) and on one grid
of crank angles, the loads of every body the scene's effects ask for: the
planar loads of each cylinder *type* (cylinders differing only in throw, bank
and axial position share one), every cylinder's loads in the engine frame
(the type's samples shifted by its phase: a roll of the grid when the phase
falls on it, else one more row of the same vectorised evaluation), the
crankshaft's static unbalances and the balancer elements, and the bounds on
each body's peak load that judge what is "zero". Time-domain totals, order
phasors, crank stars, aliasing estimates and verification are derived from
this without evaluating the kinematics again; inertial loads at constant
speed scale exactly with ω², so one evaluation serves every speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene import Model, Scene
from . import loads
from .balancers import shaft_loads, shaft_phasors, unbalance_phasors
from .budget import check_budget
from .kinematics import SliderCrank, crank_pin, slider_crank
from .linkage import lever_loads
from .sampling import body_decay_rates, choose_samples, inertia_samples, interpolate

#: A cylinder's phase within this many rounding units (relative, of its phase in grid steps) of a grid
#: point is on the grid (a roll of its type's samples). Only round-off may be rolled away: a phase off
#: the grid by 1e-10 rad, rolled, put an error of 1e-10 of the load on every phasor.
ON_GRID = 16 * np.finfo(float).eps


@dataclass(frozen=True, eq=False)
class UnitLoads:
    """The exact model at ω = 1 rad/s on ``theta`` (N angles of one revolution).

    Loads are what the moving parts exert on the block, about the origin of
    the engine frame, shape (..., axis, angle) with axis = (x, y, z):

    * ``type_planar`` (type, 3, N): force along and across the cylinder axis
      [N] and roll moment [N m] of each cylinder type at ψ = θ (None if no
      planar effect is simulated); ``cylinder_type`` (cylinder,) its index.
    * ``force_cylinder``, ``moment_cylinder`` (cylinder, 3, N), with the
      cylinder's throw unbalances.
    * ``force_crankshaft``, ``moment_crankshaft`` (3, N): the crankshaft's own
      static unbalances.
    * ``force_elements``, ``moment_elements`` (3, N): balancer elements
      (shafts, counterweights, levers) when ``balancers`` is simulated;
      ``force_levers``, ``moment_levers`` the levers' part of them.
    * ``peak_force``, ``peak_moment`` (cylinder,) and ``crankshaft_peak_force``,
      ``crankshaft_peak_moment``: bounds on each body's peak load, moments
      about ``reference_point``; their sums are the load scales.
    * ``lever_arm`` (cylinder,): farthest distance of a cylinder's loads from
      the reference point [m], ``crankshaft_lever_arm`` that of the
      crankshaft's own unbalances; ``decay_rates`` (cylinder + 1,): decay rate of
      each body's harmonics (cylinders, then the crankshaft's elements).
    * ``drive_torque`` (cylinder, N): d(KE)/dθ of each cylinder's moving
      parts [N m], the torque on the crank that keeps ω constant (the mass
      torque), whether or not ``mass_torque`` puts its reaction on the block;
      ``kinetic_energy`` (cylinder, N) [J] its kinetic energy.
    * ``harmonic_orders``: the orders of the crankshaft's single-harmonic
      loads (static unbalances: 1, balance shafts: their |ratio|).
    * ``phase``, ``bank``, ``x`` (cylinder,): each cylinder's local crank
      angle offset φ − β and bank angle β [rad] and axial position [m], for
      the order domain's shift theorem.
    * ``unbalance_phasors``: the closed-form first-order force and moment
      phasors (about the origin) of each cylinder's throw unbalances,
      (cylinder, axis) each; ``crankshaft_phasors``: those of the
      crankshaft's own unbalances and the balance shafts, (axis, order 0 …
      max_order) each; None for a ``tangential`` evaluation.
    """

    theta: np.ndarray
    reference_point: np.ndarray
    sense: int
    max_order: int
    cylinder_type: np.ndarray
    type_planar: np.ndarray | None
    force_cylinder: np.ndarray
    moment_cylinder: np.ndarray
    force_crankshaft: np.ndarray
    moment_crankshaft: np.ndarray
    force_elements: np.ndarray
    moment_elements: np.ndarray
    force_levers: np.ndarray | None
    moment_levers: np.ndarray | None
    peak_force: np.ndarray
    peak_moment: np.ndarray
    crankshaft_peak_force: float
    crankshaft_peak_moment: float
    lever_arm: np.ndarray
    crankshaft_lever_arm: float
    decay_rates: np.ndarray
    drive_torque: np.ndarray
    kinetic_energy: np.ndarray
    phase: np.ndarray
    bank: np.ndarray
    x: np.ndarray
    unbalance_phasors: tuple[np.ndarray, np.ndarray] | None
    crankshaft_phasors: tuple[np.ndarray, np.ndarray] | None
    harmonic_orders: tuple[int, ...] = ()

    @property
    def samples_per_rev(self) -> int:
        return self.theta.size

    @property
    def force_scale(self) -> float:
        """Sum of the single bodies' peak forces [N] at unit speed."""
        return float(self.peak_force.sum() + self.crankshaft_peak_force)

    @property
    def moment_scale(self) -> float:
        """Sum of the single bodies' peak moments [N m] at unit speed."""
        return float(self.peak_moment.sum() + self.crankshaft_peak_moment)

    def crankshaft(self, elements: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Force and moment about the origin of the crankshaft body: its
        unbalances and, if ``elements``, the balancer elements."""
        if not elements:
            return self.force_crankshaft, self.moment_crankshaft
        return self.force_crankshaft + self.force_elements, self.moment_crankshaft + self.moment_elements

    def total(self, point=None, elements: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Summed force and moment about ``point`` (default the reference
        point), shape (axis, angle); without the balancer elements if not
        ``elements``."""
        point = self.reference_point if point is None else np.asarray(point, dtype=float)
        crank_force, crank_moment = self.crankshaft(elements)
        force = self.force_cylinder.sum(axis=0) + crank_force
        moment = self.moment_cylinder.sum(axis=0) + crank_moment
        return force, moment_about(point, force, moment)


def _column(values) -> np.ndarray:
    return np.asarray(values, dtype=float)[:, None]


def _per_unit_acceleration(kin: SliderCrank) -> SliderCrank:
    """The kinematics with every second ψ-derivative replaced by the first:
    loads are linear in the accelerations a = ν·ω² + μ·α, so the loads of
    these are the loads per unit crank acceleration α at rest (ω = 0)."""
    return SliderCrank(a=kin.a, da=kin.da, dda=kin.da, b=kin.b, db=kin.db, ddb=kin.db, e=kin.e,
                       drod_angle=kin.drod_angle, ddrod_angle=kin.drod_angle)


def planar_loads(model: Model, cylinders, psi: np.ndarray, tangential: bool = False):
    """Load of one cylinder's moving parts in its local plane frame at unit
    speed, summed over the scene's effects.

    Parameters
    ----------
    model : Model
        The scene's effects and model options.
    cylinders : sequence of Cylinder
        Geometry and masses, one row of ``psi`` each.
    psi : ndarray
        Local crank angles ψ [rad], shape (cylinder, angle).
    tangential : bool
        The loads per unit crank acceleration α (at ω = 0) instead of per
        unit ω² (at α = 0); their roll has no drive-torque term.

    Returns
    -------
    (force_c, force_n, roll, power, energy) or None
        Force along and across the cylinder axis [N] and moment about the
        crank axis in the direction of rotation [N m] (including the drive
        torque's reaction if ``mass_torque`` is simulated), the drive
        torque d(KE)/dψ [N m] that keeps ω constant and the kinetic energy
        [J], shape of ``psi``; None if no planar effect is simulated.
    """
    effects = model.effects
    r = _column([c.crank_radius for c in cylinders])
    l = _column([c.rod_length for c in cylinders])
    rod_mass = _column([c.rod.mass for c in cylinders])
    rod_cg = _column([c.rod.cg_from_big_end for c in cylinders])
    small_end = rod_mass * rod_cg / l
    big_end = rod_mass - small_end

    kin = None
    if effects & {"reciprocating", "rod_inertia"}:
        series = model.series_harmonics if model.piston == "series" else None
        kin = slider_crank(psi, r, l, _column([c.offset for c in cylinders]), series)
        if tangential:
            kin = _per_unit_acceleration(kin)

    planar: list[loads.PlanarLoad] = []
    if "reciprocating" in effects:
        assert kin is not None  # made for these effects
        planar.append(loads.reciprocating(
            kin, _column([c.piston.mass for c in cylinders]), _column([c.piston.cg_lateral for c in cylinders]),
            small_end))
    if "rotating" in effects:
        # rotating_rod's load is m·A (= −m·A'', A'' = −A); per unit α it is −m·A'. The slider-crank has the
        # crank pin already (the same products: its sines and cosines are the dearest part on a fine grid).
        pin, dpin = (kin.a, kin.da) if kin is not None else crank_pin(psi, r)[:2]
        planar.append(loads.rotating_rod((-dpin[0], -dpin[1]) if tangential else pin, big_end))
    if "rod_inertia" in effects and model.rod != "two_point":
        lateral = _column([c.rod.cg_lateral for c in cylinders])
        off_axis = model.rod == "rigid" and any(c.rod.cg_lateral for c in cylinders)
        assert kin is not None
        planar.append(loads.rod_inertia(kin, rod_mass, rod_cg, lateral,
                                        _column([c.rod.inertia for c in cylinders]), l, off_axis))
    if not planar:
        return None
    shape = np.shape(psi)
    force_c = sum(p.force_c for p in planar) + np.zeros(shape)
    force_n = sum(p.force_n for p in planar) + np.zeros(shape)
    roll = sum(p.roll for p in planar) + np.zeros(shape)
    power = sum(p.power for p in planar) + np.zeros(shape)
    energy = sum(p.energy for p in planar) + np.zeros(shape)
    if "mass_torque" in effects and not tangential:
        # The drive keeps ω constant with torque T = d(KE)/dθ·ω²; the block
        # receives its reaction about the crank axis in the sense of rotation.
        roll = roll + power
    return force_c, force_n, roll, power, energy


def _phase_rows(delta: np.ndarray, kind: np.ndarray, samples: int):
    """Rows to evaluate and how each cylinder reads them.

    Cylinder i runs at ψ = θ + δ_i. With δ_i = 2π(m_i + f_i)/N, f_i in [0, 1),
    its samples are the row of (type, f_i) at ψ = θ + 2πf_i/N rolled by m_i.
    Returns the rows' (type, offset [rad]) and, per cylinder, its row and m_i.
    Every type has its row at offset 0 (the type's own spectrum).
    """
    # In Python floats: a handful of cylinders, where numpy's per-call cost is most of the work. The
    # operations are numpy's elementwise ones in the same order (Python's round and % are numpy's too).
    keys: dict[tuple[int, float], int] = {(t, 0.0): t for t in sorted(set(kind.tolist()))}
    row = np.empty(len(kind), dtype=int)
    shift = np.empty(len(kind), dtype=int)
    for i, (d, t) in enumerate(zip(np.asarray(delta, dtype=float).tolist(), kind.tolist())):
        steps = d * samples / (2 * math.pi)
        nearest = round(steps)
        on = abs(steps - nearest) <= ON_GRID * max(abs(steps), 1.0)
        whole = nearest if on else math.floor(steps)
        row[i] = keys.setdefault((t, 0.0 if on else d - 2 * math.pi * whole / samples), len(keys))
        shift[i] = whole % samples
    return list(keys), row, shift  # keys in the order of their row indices


def cylinder_types(cylinders) -> tuple[list, np.ndarray]:
    """Cylinders that differ only in placement (throw, bank, axial position,
    label, throw unbalances) share a type: one representative per type and each cylinder's
    type index."""
    groups: dict[tuple, int] = {}
    representatives: list = []
    index = np.empty(len(cylinders), dtype=int)
    for i, c in enumerate(cylinders):
        key = tuple(getattr(c, name) for name in TYPE_FIELDS)
        if key not in groups:
            groups[key] = len(representatives)
            representatives.append(c)
        index[i] = groups[key]
    return representatives, index


#: Cylinder fields that place a cylinder in the engine; all other fields
#: (geometry and masses) define its type. A meta-test checks that the two sets
#: cover every field of :class:`harmbal.scene.Cylinder`.
PLACEMENT_FIELDS = ("label", "throw", "bank", "x", "throw_unbalances")
TYPE_FIELDS = ("crank_radius", "rod_length", "pin_offset", "cylinder_offset", "piston", "rod", "gas")


def evaluate(scene: Scene, samples_per_rev: int | None = None, *, tangential: bool = False,
             peak_samples: int | None = None, decay_rates: np.ndarray | None = None) -> UnitLoads:
    """Evaluate the exact model once at ω = 1 rad/s, only the scene's effects.

    With ``tangential``, the loads per unit crank acceleration α = 1 rad/s²
    at rest instead (the part μ·α of a = ν·ω² + μ·α, for a fluctuating
    speed); lever balancers have no such evaluation yet (ValueError).

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`.
    samples_per_rev : int, optional
        Samples per revolution; default the scene's sampling
        (:func:`harmbal.model.sampling.choose_samples`).
    peak_samples : int, optional
        Samples per revolution (at least the evaluation's) over which the
        peak loads are taken, by trigonometric interpolation of the loads; default the
        evaluation's own: with gas, the gas grid's, so that the load scales
        are those of the time domain the inertia is interpolated onto.
    decay_rates : ndarray, optional
        :func:`harmbal.model.sampling.body_decay_rates`, if already computed.

    Returns
    -------
    UnitLoads
    """
    decay_rates = body_decay_rates(scene) if decay_rates is None else decay_rates
    n = samples_per_rev or choose_samples(scene, decay_rates)
    check_budget(scene, "evaluate", samples=n)  # every entry point's last guard before the arrays of C × n samples
    theta = 2 * np.pi * np.arange(n) / n
    cyls = scene.cylinders
    ref = np.asarray(scene.reference_point, dtype=float)
    throw = np.array([c.throw for c in cyls])
    bank = np.array([c.bank for c in cyls])
    x = np.array([c.x for c in cyls])
    cyl = _cylinder_loads(scene, theta, (throw, bank, x), tangential, peak_samples)
    crank_force, crank_moment, crank_peak = _unbalance_loads(scene, theta, throw, cyl, tangential)
    el = _element_loads(scene, theta, ref, tangential, peak_samples)
    arm, crank_arm = _lever_arms(scene, ref)
    effects = scene.model.effects
    harmonic = [1] if "rotating" in effects and scene.crankshaft_unbalances else []
    if "balancers" in effects:
        harmonic += [abs(shaft.ratio) for shaft in scene.shafts]
    unbalances, crankshaft = (None, None) if tangential else _element_phasors(scene, throw)
    return UnitLoads(
        theta=theta, reference_point=ref, sense=scene.sense, max_order=scene.sampling.max_order,
        cylinder_type=cyl.kind, type_planar=cyl.type_planar,
        force_cylinder=cyl.force, moment_cylinder=cyl.moment,
        force_crankshaft=crank_force, moment_crankshaft=crank_moment,
        force_elements=el.force, moment_elements=el.moment,
        force_levers=el.lever_force, moment_levers=el.lever_moment,
        peak_force=cyl.peak_force, peak_moment=cyl.peak_roll + arm * cyl.peak_force,
        crankshaft_peak_force=crank_peak + el.shaft_peak_force + el.lever_peak_force,
        crankshaft_peak_moment=crank_arm * crank_peak + el.shaft_peak_moment + el.lever_peak_moment,
        lever_arm=arm, crankshaft_lever_arm=crank_arm, decay_rates=decay_rates, drive_torque=cyl.drive_torque,
        kinetic_energy=cyl.kinetic_energy, phase=throw - bank, bank=bank, x=x, unbalance_phasors=unbalances,
        crankshaft_phasors=crankshaft, harmonic_orders=tuple(harmonic),
    )


@dataclass(eq=False)
class _CylinderLoads:
    """Per cylinder, the loads of :func:`evaluate` in the engine frame
    (cylinder, axis, angle), the drive torque and kinetic energy (cylinder,
    angle) and the peak force and roll; per type, the planar samples and each
    cylinder's type (``kind``). Mutable: the throw unbalances are added in."""

    force: np.ndarray
    moment: np.ndarray
    drive_torque: np.ndarray
    kinetic_energy: np.ndarray
    type_planar: np.ndarray | None
    peak_force: np.ndarray
    peak_roll: np.ndarray
    kind: np.ndarray


def _cylinder_loads(scene: Scene, theta: np.ndarray, placement, tangential: bool,
                    peak_samples: int | None) -> _CylinderLoads:
    """The cylinders' planar loads, one vectorised evaluation per type and
    phase row, placed in the engine frame; ``placement`` is (throw, bank, x)."""
    throw, bank, x = placement
    n, ncyl, sense = theta.size, len(scene.cylinders), scene.sense
    representatives, kind = cylinder_types(scene.cylinders)
    rows, row, shift = _phase_rows(throw - bank, kind, n)
    psi = theta[None, :] + np.array([f for _, f in rows])[:, None]
    planar = planar_loads(scene.model, [representatives[t] for t, _ in rows], psi, tangential)
    out = _CylinderLoads(force=np.zeros((ncyl, 3, n)), moment=np.zeros((ncyl, 3, n)),
                         drive_torque=np.zeros((ncyl, n)), kinetic_energy=np.zeros((ncyl, n)), type_planar=None,
                         peak_force=np.zeros(ncyl), peak_roll=np.zeros(ncyl), kind=kind)
    if planar is None:
        return out
    samples = np.stack(planar, axis=1)  # (row, c/n/roll/drive torque/energy, angle)
    out.type_planar = samples[: len(representatives), :3]
    # Cylinder i's samples: its row rolled by its whole grid steps (index j + m_i).
    index = (np.arange(n)[None, :] + shift[:, None]) % n
    local = samples[row[:, None], :, index].transpose(0, 2, 1)  # (cylinder, c/n/roll/drive torque/energy, angle)
    out.drive_torque, out.kinetic_energy = local[:, 3], local[:, 4]
    # Local (c, n) -> transverse complex w = z + i·t, t 90° ahead of +z in
    # the direction of rotation (t = −sense·y); e_c ↔ e^{iβ}.
    w = (local[:, 0] + 1j * local[:, 1]) * np.exp(1j * bank)[:, None]
    out.force[:, 1] = -sense * w.imag
    out.force[:, 2] = w.real
    out.moment[:, 0] = sense * local[:, 2]
    out.moment[:, 1] = -x[:, None] * out.force[:, 2]
    out.moment[:, 2] = x[:, None] * out.force[:, 1]
    fine = out.type_planar if peak_samples is None else interpolate(out.type_planar, peak_samples)
    out.peak_force += np.hypot(fine[:, 0], fine[:, 1]).max(axis=-1)[kind]
    out.peak_roll += np.abs(fine[:, 2]).max(axis=-1)[kind]
    return out


def _unbalance_loads(scene: Scene, theta: np.ndarray, throw: np.ndarray, cyl: _CylinderLoads, tangential: bool):
    """Add the throw unbalances' loads and peaks to their cylinders' (``cyl``),
    and return the crankshaft's unbalances' force and moment (axis, angle)
    and peak force."""
    n, sense = theta.size, scene.sense
    crank_force = np.zeros((3, n))
    crank_moment = np.zeros((3, n))
    crank_peak = 0.0
    if "rotating" not in scene.model.effects:
        return crank_force, crank_moment, crank_peak
    # A static unbalance's load per unit α (−m·A') points 90° behind it, against the rotation.
    lag = np.pi / 2 if tangential else 0.0
    cyls = scene.cylinders
    owner = [i for i, c in enumerate(cyls) for _ in c.throw_unbalances]
    if owner:
        ub = [u for c in cyls for u in c.throw_unbalances]
        angles = np.array([throw[i] + u.angle for i, u in zip(owner, ub)])[:, None]
        f, m = loads.rotating_unbalance(theta[None, :] - lag + angles,
                                        np.array([u.unbalance for u in ub])[:, None],
                                        np.array([u.x for u in ub])[:, None], sense)
        np.add.at(cyl.force, owner, f)
        np.add.at(cyl.moment, owner, m)
        np.add.at(cyl.peak_force, owner, [u.unbalance for u in ub])
    if scene.crankshaft_unbalances:
        crank_ub = scene.crankshaft_unbalances
        f, m = loads.rotating_unbalance(theta[None, :] - lag + np.array([u.angle for u in crank_ub])[:, None],
                                        np.array([u.unbalance for u in crank_ub])[:, None],
                                        np.array([u.x for u in crank_ub])[:, None], sense)
        crank_force, crank_moment = f.sum(axis=0), m.sum(axis=0)
        crank_peak = sum(u.unbalance for u in crank_ub)
    return crank_force, crank_moment, crank_peak


@dataclass(frozen=True, eq=False)
class _ElementLoads:
    """The balancer elements' loads of :func:`evaluate` (axis, angle), the
    levers' alone (None without levers), and the peak force and moment of the
    shafts and of the levers (kept apart: :func:`evaluate` sums them in this order)."""

    force: np.ndarray
    moment: np.ndarray
    lever_force: np.ndarray | None = None
    lever_moment: np.ndarray | None = None
    shaft_peak_force: float = 0.0
    shaft_peak_moment: float = 0.0
    lever_peak_force: float = 0.0
    lever_peak_moment: float = 0.0


def _element_loads(scene: Scene, theta: np.ndarray, ref: np.ndarray, tangential: bool,
                   peak_samples: int | None) -> _ElementLoads:
    """The balance shafts' and lever balancers' loads (if the scene's effects
    include balancers) and their peaks."""
    n, sense, effects = theta.size, scene.sense, scene.model.effects
    element_force = np.zeros((3, n))
    element_moment = np.zeros((3, n))
    lever_force = lever_moment = None
    shaft_peak_force = shaft_peak_moment = lever_peak_force = lever_peak_moment = 0.0
    if "balancers" in effects and scene.shafts:
        element_force, element_moment = shaft_loads(scene.shafts, theta, sense, tangential)
        for shaft in scene.shafts:
            n2 = shaft.ratio**2
            shaft_peak_force += n2 * sum(u.unbalance for u in shaft.unbalances)
            shaft_peak_moment += n2 * (abs(shaft.couple) + sum(
                u.unbalance * float(np.linalg.norm(np.array([u.x, shaft.y, shaft.z]) - ref)) for u in shaft.unbalances))
    if "balancers" in effects and scene.levers:
        if tangential:
            raise ValueError("lever balancers have no loads per unit crank acceleration yet")
        lever_force, lever_moment = lever_loads(scene.levers, theta, sense, "mass_torque" in effects)
        element_force, element_moment = element_force + lever_force, element_moment + lever_moment
        fine = np.stack([lever_force, moment_about(ref, lever_force, lever_moment)])
        fine = fine if peak_samples is None else interpolate(fine, peak_samples)
        lever_peak_force, lever_peak_moment = (float(v) for v in np.linalg.norm(fine, axis=1).max(axis=-1))
    return _ElementLoads(force=element_force, moment=element_moment, lever_force=lever_force,
                         lever_moment=lever_moment, shaft_peak_force=shaft_peak_force,
                         shaft_peak_moment=shaft_peak_moment, lever_peak_force=lever_peak_force,
                         lever_peak_moment=lever_peak_moment)


def _lever_arms(scene: Scene, ref: np.ndarray) -> tuple[np.ndarray, float]:
    """The lever arms that bound each cylinder's and the crankshaft's peak
    moment about ``ref``: |M_i| ≤ |roll| + |r − ref|·|F| with r the farthest
    point of cylinder i's loads."""
    arm = np.array([max([abs(c.x - ref[0])] + [abs(u.x - ref[0]) for u in c.throw_unbalances])
                    for c in scene.cylinders])
    arm = np.hypot(arm, np.hypot(ref[1], ref[2]))
    crank_arm = max([0.0] + [float(np.hypot(u.x - ref[0], np.hypot(ref[1], ref[2])))
                             for u in scene.crankshaft_unbalances])
    return arm, crank_arm


def time_domain_evaluation(scene: Scene, samples_per_rev: int | None = None) -> tuple[UnitLoads, int]:
    """The evaluation the time-domain views derive from, and the samples per
    revolution of their grid (the gas grid's with gas: the scene's sampling,
    :func:`harmbal.model.sampling.choose_samples`, or ``samples_per_rev``).

    With gas the inertia keeps a grid of its own, coarser than the gas's
    (:func:`harmbal.model.sampling.inertia_samples` says why that is exact
    enough), and is interpolated onto the gas grid where a view needs it
    there; its peak loads, which judge what is "zero", are taken over that
    grid. A given ``samples_per_rev`` is used for both."""
    rates = body_decay_rates(scene)
    samples = samples_per_rev or choose_samples(scene, rates)
    inertia = samples_per_rev or inertia_samples(scene, rates, samples)
    return evaluate(scene, inertia, peak_samples=samples, decay_rates=rates), samples


def _element_phasors(scene: Scene, throw: np.ndarray):
    """The closed-form order phasors at unit speed, about the origin, of the
    throw unbalances (cylinder, axis) and of the crankshaft's unbalances and
    balance shafts (axis, order): see :class:`UnitLoads`."""
    sense, effects, kmax = scene.sense, scene.model.effects, scene.sampling.max_order
    cyls = scene.cylinders
    throw_force = np.zeros((len(cyls), 3), dtype=complex)
    throw_moment = np.zeros((len(cyls), 3), dtype=complex)
    crank_force = np.zeros((3, kmax + 1), dtype=complex)
    crank_moment = np.zeros((3, kmax + 1), dtype=complex)
    if "rotating" in effects:
        for i, c in enumerate(cyls):
            for u in c.throw_unbalances:
                f, m = unbalance_phasors(throw[i] + u.angle, u.unbalance, u.x, sense)
                throw_force[i] += f
                throw_moment[i] += m
        for u in scene.crankshaft_unbalances:
            f, m = unbalance_phasors(u.angle, u.unbalance, u.x, sense)
            crank_force[:, 1] += f
            crank_moment[:, 1] += m
    if "balancers" in effects and scene.shafts:
        shaft_force, shaft_moment = shaft_phasors(scene.shafts, kmax, sense)
        crank_force += shaft_force
        crank_moment += shaft_moment
    return (throw_force, throw_moment), (crank_force, crank_moment)


def moment_about(point: np.ndarray, force: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """Moment about ``point`` from the moment about the origin: M − p × F
    (axis is the second-to-last dimension)."""
    px, py, pz = point
    fx, fy, fz = force[..., 0, :], force[..., 1, :], force[..., 2, :]
    shift = np.stack([py * fz - pz * fy, pz * fx - px * fz, px * fy - py * fx], axis=-2)
    return moment - shift
