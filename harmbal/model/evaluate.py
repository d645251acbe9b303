"""Exact time-domain shaking force and moment on the block.

The model is evaluated once at unit crank speed, vectorised over angles and
cylinders, and scaled by ω² for every speed (exact for inertial loads at
constant speed). Only the effects listed in the scene are computed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import loads
from .balancers import shaft_loads
from .kinematics import crank_pin, slider_crank
from .linkage import lever_loads
from ..scene import Scene


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


