"""Exact time-domain shaking force and moment on the block.

The model is evaluated once at unit crank speed, vectorised over angles and
cylinders, and scaled by ω² for every speed (exact for inertial loads at
constant speed). Only the effects listed in the scene are computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import loads
from .balancers import shaft_loads
from ._version import __version__
from .kinematics import crank_pin, decay_rate, slider_crank
from .linkage import decay_rate as linkage_decay_rate
from .linkage import lever_loads
from .orders import ALIAS_SAFETY
from .scene import EFFECTS, Scene

AXES = ("x", "y", "z")

CONVENTIONS = (
    "Engine frame: x along the crank axis towards the front (pulley end), y to the right seen from the "
    "front, z up; right-handed. Crank angle theta in the direction of rotation, 0 when throw 1 points along +z. "
    "force, moment: exerted by the moving parts on the block; moment about the scene's reference point. "
    "See docs/conventions.md."
)


@dataclass(frozen=True)
class UnitSpeedLoads:
    """Loads at ω = 1 rad/s about the origin: per cylinder (cylinder, axis,
    angle) and from crankshaft unbalances and balancer elements (axis, angle)."""

    theta: np.ndarray
    force_cylinder: np.ndarray
    moment_cylinder: np.ndarray
    force_crankshaft: np.ndarray
    moment_crankshaft: np.ndarray

    def total(self, point) -> tuple[np.ndarray, np.ndarray]:
        """Summed force and moment about ``point`` (axis, angle)."""
        point = np.asarray(point, dtype=float)
        force = self.force_cylinder.sum(axis=0) + self.force_crankshaft
        moment = self.moment_cylinder.sum(axis=0) + self.moment_crankshaft
        return force, moment_about(point, force, moment)


#: Most samples per revolution the accuracy setting chooses.
MAX_SAMPLES = 1 << 16


class AccuracyWarning(UserWarning):
    """The requested accuracy needs more samples than harmbal will choose."""


def choose_samples(scene: Scene) -> int:
    """Samples per revolution: the scene's fixed count, or the smallest count
    whose aliasing error meets the scene's target accuracy.

    The slider-crank harmonics decay geometrically, |C_n| ≲ n²ρⁿ relative to
    the first order for accelerations (ρ from
    :func:`harmbal.kinematics.decay_rate`); order k ≤ K is contaminated by
    orders ≥ N − K. The count is also at least 4K so that the spectral-tail
    estimate in :func:`harmbal.order_spectrum` covers the orders of interest,
    and above |n| + K for a balancer element turning at n× (a single harmonic
    that would otherwise alias onto an order kept).
    """
    sampling = scene.sampling
    if sampling.samples_per_rev is not None:
        return sampling.samples_per_rev
    k = sampling.max_order
    rho = float(body_decay_rates(scene).max())
    n = 4 * k
    if "balancers" in scene.model.effects:
        # A shaft at n× is one harmonic: it must not alias onto the orders kept (N − |n| > K).
        n = max([n] + [abs(shaft.ratio) + k + 1 for shaft in scene.shafts])
    if rho > 0:
        m = k + 1
        target = sampling.accuracy / ALIAS_SAFETY  # so that the estimate reported meets the target too
        while m * m * rho**m > target and m < MAX_SAMPLES:
            m += 1
        n = max(n, m + k)
        if m * m * rho**m > target:
            import warnings

            warnings.warn(f"{scene.source}: sampling.accuracy = {sampling.accuracy:g} needs more than {MAX_SAMPLES} "
                          f"samples per revolution (harmonics decay only like {rho:.6g}^k: a slider-crank with "
                          f"λ close to 1 or a linkage close to its toggle position); using {8 * math.ceil(n / 8)}, the "
                          "results may be less accurate than asked: compare with a larger sampling.samples_per_rev",
                          AccuracyWarning, stacklevel=2)
    return 8 * math.ceil(n / 8)


def _column(values) -> np.ndarray:
    return np.asarray(values, dtype=float)[:, None]


def planar_loads(scene: Scene, cylinders, psi: np.ndarray):
    """Load of one cylinder's moving parts in its local plane frame at unit
    speed, summed over the scene's effects.

    Parameters
    ----------
    scene : Scene
        Gives the effects and model options.
    cylinders : sequence of Cylinder
        Geometry and masses, one row of ``psi`` each.
    psi : ndarray
        Local crank angles ψ [rad], shape (cylinder, angle).

    Returns
    -------
    (force_c, force_n, roll) or None
        Force along and across the cylinder axis [N] and moment about the
        crank axis in the direction of rotation [N m] (including the drive
        torque's reaction if ``mass_torque`` is simulated), shape of ``psi``;
        None if no planar effect is simulated.
    """
    effects = scene.model.effects
    r = _column([c.crank_radius for c in cylinders])
    l = _column([c.rod_length for c in cylinders])
    rod_mass = _column([c.rod.mass for c in cylinders])
    rod_cg = _column([c.rod.cg_from_big_end for c in cylinders])
    small_end = rod_mass * rod_cg / l
    big_end = rod_mass - small_end

    kin = None
    if effects & {"reciprocating", "rod_inertia"}:
        series = scene.model.series_harmonics if scene.model.piston == "series" else None
        kin = slider_crank(psi, r, l, _column([c.offset for c in cylinders]), series)

    planar: list[loads.PlanarLoad] = []
    if "reciprocating" in effects:
        planar.append(loads.reciprocating(
            kin, _column([c.piston.mass for c in cylinders]), _column([c.piston.cg_lateral for c in cylinders]),
            small_end))
    if "rotating" in effects:
        planar.append(loads.rotating_rod(crank_pin(psi, r)[0], big_end))
    if "rod_inertia" in effects and scene.model.rod != "two_point":
        lateral = _column([c.rod.cg_lateral for c in cylinders])
        off_axis = scene.model.rod == "rigid" and bool(np.any(lateral))
        planar.append(loads.rod_inertia(kin, rod_mass, rod_cg, lateral,
                                        _column([c.rod.inertia for c in cylinders]), l, off_axis))
    if not planar:
        return None
    shape = np.shape(psi)
    force_c = sum(p.force_c for p in planar) + np.zeros(shape)
    force_n = sum(p.force_n for p in planar) + np.zeros(shape)
    roll = sum(p.roll for p in planar) + np.zeros(shape)
    if "mass_torque" in effects:
        # The drive keeps ω constant with torque T = d(KE)/dθ·ω²; the block
        # receives its reaction about the crank axis in the sense of rotation.
        roll = roll + sum(p.power for p in planar)
    return force_c, force_n, roll


def unit_speed_loads(scene: Scene, samples_per_rev: int) -> UnitSpeedLoads:
    """Force and moment about the origin at ω = 1 rad/s, per cylinder and for
    the crankshaft unbalances, computing only the scene's effects."""
    sense = scene.sense
    theta = 2 * np.pi * np.arange(samples_per_rev) / samples_per_rev
    cyls = scene.cylinders
    bank = _column([c.bank for c in cyls])
    x = _column([c.x for c in cyls])
    psi = theta[None, :] + _column([c.throw for c in cyls]) - bank

    shape = (len(cyls), 3, samples_per_rev)
    force = np.zeros(shape)
    moment = np.zeros(shape)
    planar = planar_loads(scene, cyls, psi)
    if planar is not None:
        force_c, force_n, roll = planar
        # Local (c, n) -> transverse complex w = z + i·t, t 90° ahead of +z in
        # the direction of rotation (t = −sense·y); e_c ↔ e^{iβ}.
        w = (force_c + 1j * force_n) * np.exp(1j * bank)
        force[:, 1] = -sense * w.imag
        force[:, 2] = w.real
        moment[:, 0] = sense * roll
        moment[:, 1] = -x * force[:, 2]
        moment[:, 2] = x * force[:, 1]

    crank_force = np.zeros((3, samples_per_rev))
    crank_moment = np.zeros((3, samples_per_rev))
    if "rotating" in scene.model.effects:
        index = [i for i, c in enumerate(cyls) for _ in c.throw_unbalances]
        if index:
            ub = [u for c in cyls for u in c.throw_unbalances]
            f, m = loads.rotating_unbalance(
                theta[None, :] + _column([cyls[i].throw + u.angle for i, u in zip(index, ub)]),
                _column([u.unbalance for u in ub]), _column([u.x for u in ub]), sense)
            np.add.at(force, index, f)
            np.add.at(moment, index, m)
        if scene.crankshaft_unbalances:
            ub = scene.crankshaft_unbalances
            f, m = loads.rotating_unbalance(theta[None, :] + _column([u.angle for u in ub]),
                                            _column([u.unbalance for u in ub]), _column([u.x for u in ub]), sense)
            crank_force, crank_moment = f.sum(axis=0), m.sum(axis=0)
    if "balancers" in scene.model.effects and scene.shafts:
        f, m = shaft_loads(scene.shafts, theta, sense)
        crank_force, crank_moment = crank_force + f, crank_moment + m
    if "balancers" in scene.model.effects and scene.levers:
        f, m = lever_loads(scene.levers, theta, sense, "mass_torque" in scene.model.effects)
        crank_force, crank_moment = crank_force + f, crank_moment + m
    return UnitSpeedLoads(theta, force, moment, crank_force, crank_moment)


def moment_about(point: np.ndarray, force: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """Moment about ``point`` from the moment about the origin: M − p × F
    (axis is the second-to-last dimension)."""
    px, py, pz = point
    fx, fy, fz = force[..., 0, :], force[..., 1, :], force[..., 2, :]
    shift = np.stack([py * fz - pz * fy, pz * fx - px * fz, px * fy - py * fx], axis=-2)
    return moment - shift


def simulate(scene: Scene, *, per_cylinder: bool = False, samples_per_rev: int | None = None):
    """Exact shaking force and moment on the block over one crank revolution.

    Parameters
    ----------
    scene : Scene
        A scene from :func:`harmbal.load_scene`.
    per_cylinder : bool, default False
        Also return each cylinder's contribution (``force_cylinder``,
        ``moment_cylinder``, dim ``cylinder``); crankshaft unbalances belong to
        no cylinder and are in the totals only.
    samples_per_rev : int, optional
        Override the scene's sampling.

    Returns
    -------
    xarray.Dataset
        Dims ``angle`` (crank angle θ [rad]), ``axis`` (x, y, z) and, when the
        scene has several speeds, ``speed`` [rad/s] (with an ``rpm``
        coordinate). Variables ``force`` [N] and ``moment`` [N m] about the
        scene's reference point, and ``force_scale``/``moment_scale``, the sums
        of bounds on the single bodies' peak loads (the same as
        :func:`harmbal.stars`'), used to judge what is "zero", and
        ``aliasing_error_force``/``aliasing_error_moment`` (per axis), the
        aliasing estimate of the order phasors summed body by body
        (:func:`body_aliasing`).
    """
    import xarray as xr

    n = samples_per_rev or choose_samples(scene)
    unit = unit_speed_loads(scene, n)
    ref = np.asarray(scene.reference_point)
    moment_cyl = moment_about(ref, unit.force_cylinder, unit.moment_cylinder)
    moment_crank = moment_about(ref, unit.force_crankshaft, unit.moment_crankshaft)
    force = unit.force_cylinder.sum(axis=0) + unit.force_crankshaft
    moment = moment_cyl.sum(axis=0) + moment_crank

    # One definition of the load scale for both paths (the order domain's bound on each body's
    # peak), so that a component is "balanced" in harmbal run exactly when it is in harmbal stars.
    from .crank_stars import order_phasors

    bounds = order_phasors(scene, samples_per_rev=n)
    force_scale = float(bounds.peak_force.sum() + bounds.crankshaft_peak_force)
    moment_scale = float(bounds.peak_moment.sum() + bounds.crankshaft_peak_moment)
    rates = body_decay_rates(scene)
    alias_force = body_aliasing(unit.force_cylinder, unit.force_crankshaft, scene.sampling.max_order, rates)
    alias_moment = body_aliasing(moment_cyl, moment_crank, scene.sampling.max_order, rates)

    lead, w2, coords = speed_axis(scene)

    def scaled(values):
        """Unit-speed values times ω², with a leading speed dim if several."""
        return np.multiply.outer(w2, values) if lead else w2 * values

    coords.update({
        "angle": ("angle", unit.theta, {"units": "rad", "long_name": "crank angle θ",
                                        "description": "angle of throw 1 from +z, in the direction of rotation"}),
        "axis": ("axis", list(AXES), {"long_name": "engine axis"}),
    })
    data = {
        "force": (lead + ("axis", "angle"), scaled(force), {"units": "N", "long_name": "shaking force on the block"}),
        "moment": (lead + ("axis", "angle"), scaled(moment),
                   {"units": "N m", "long_name": "shaking moment on the block about the reference point"}),
        "force_scale": (lead, w2 * force_scale, {"units": "N", "long_name": "sum of single-body peak forces"}),
        "moment_scale": (lead, w2 * moment_scale, {"units": "N m", "long_name": "sum of single-body peak moments"}),
        "aliasing_error_force": (lead + ("axis",), scaled(alias_force), {
            "units": "N", "long_name": "estimated aliasing error of the force phasors, body by body"}),
        "aliasing_error_moment": (lead + ("axis",), scaled(alias_moment), {
            "units": "N m", "long_name": "estimated aliasing error of the moment phasors, body by body"}),
    }
    if per_cylinder:
        coords["cylinder"] = ("cylinder", [c.label for c in scene.cylinders], {"long_name": "cylinder label"})
        dims = lead + ("cylinder", "axis", "angle")
        data["force_cylinder"] = (dims, scaled(unit.force_cylinder), {"units": "N", "long_name": "force of one cylinder"})
        data["moment_cylinder"] = (dims, scaled(moment_cyl), {"units": "N m", "long_name": "moment of one cylinder"})
    return xr.Dataset(data, coords, attrs=attributes(scene, n))


def body_decay_rates(scene: Scene) -> np.ndarray:
    """Decay rate ρ of the harmonics of each cylinder and of the crankshaft's
    elements (pure harmonics, or a lever balancer's linkage), in the order of
    :func:`body_aliasing`'s bodies."""
    cyls = scene.cylinders
    rho = decay_rate(np.array([c.crank_radius for c in cyls]), np.array([c.rod_length for c in cyls]),
                     np.array([c.offset for c in cyls]))
    levers = [linkage_decay_rate(lever, scene.sense) for lever in scene.levers] if "balancers" in scene.model.effects else []
    return np.append(rho, max(levers, default=0.0))


def body_aliasing(per_cylinder: np.ndarray, crankshaft: np.ndarray, max_order: int,
                  rates: np.ndarray | float = 0.0) -> np.ndarray:
    """Aliasing estimate per axis of the orders ≤ ``max_order``, summed over
    the cylinders (and the crankshaft's elements) without cancellation.

    The tail of the *total* spectrum can mislead: an engine whose cylinders
    cancel every order in the sampled tail band (a W24 keeps only multiples
    of 12 in its moment) hides the orders beyond it that fold back onto the
    orders kept. Each body's own spectrum decays smoothly, so the sum of their
    tail estimates (:func:`harmbal.orders.aliasing_estimate`) bounds the
    total's aliasing whatever cancels. ``rates`` (per body, from
    :func:`body_decay_rates`) keeps each fit from decaying faster than the
    geometry allows.
    """
    from .orders import aliasing_estimate, phasors

    n = per_cylinder.shape[-1]
    bodies = np.concatenate([per_cylinder, crankshaft[None]])  # (body, axis, angle)
    slowest = np.broadcast_to(np.asarray(rates, dtype=float), bodies.shape[:1])[:, None]
    return aliasing_estimate(np.abs(phasors(bodies)), n, max_order, slowest).sum(axis=0)


def speed_axis(scene: Scene):
    """The scene's speeds as a leading dimension.

    Returns ``(lead, w2, coords)``: ``("speed",)`` and the array of ω² if the
    scene has several speeds, else ``()`` and the scalar ω²; and the
    ``speed`` [rad/s] and ``rpm`` coordinates.
    """
    speeds = np.asarray(scene.speeds, dtype=float)
    if len(speeds) > 1:
        lead, values = ("speed",), speeds
    else:
        lead, values = (), speeds[0]
    coords = {
        "speed": (lead, values, {"units": "rad/s", "long_name": "crank speed ω"}),
        "rpm": (lead, values * 30 / np.pi, {"units": "rpm", "long_name": "crank speed"}),
    }
    return lead, values**2, coords


def attributes(scene: Scene, samples: int) -> dict:
    model = scene.model
    return {
        "title": f"harmbal time-domain shaking loads: {scene.name}",
        "engine": scene.name,
        "harmbal_version": __version__,
        "conventions": CONVENTIONS,
        "rotation": scene.rotation,
        "cycle_strokes": scene.cycle,
        "reference_point": np.asarray(scene.reference_point, dtype=float),
        "reference_point_units": "m",
        "effects": " ".join(e for e in EFFECTS if e in model.effects),
        "piston_model": model.piston if model.piston == "exact" else f"series-{model.series_harmonics}",
        "rod_model": model.rod,
        "samples_per_rev": samples,
        "max_order": scene.sampling.max_order,
        # The relative accuracy asked for; 0 when the scene fixes samples_per_rev instead.
        "accuracy_target": float(scene.sampling.accuracy) if scene.sampling.samples_per_rev is None else 0.0,
    }
