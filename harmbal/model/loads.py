"""Inertial loads of each body group on the block, one function per effect.

All loads are evaluated at unit crank speed (ω = 1 rad/s); the time-domain
assembly multiplies by ω². A load is what the moving body exerts on the block:
the force −m·a_G and, about the crank axis, the moment −(r_G × m·a_G + I·ϑ̈).

Planar loads are returned in the cylinder's local frame (see
:mod:`harmbal.model.kinematics`) as a :class:`PlanarLoad`; ``roll`` is the moment
about the crank axis, positive in the direction of rotation, ``energy`` the
kinetic energy of the bodies involved and ``power`` its derivative d/dθ, from
which the reaction of the torque that keeps the crank at constant speed
follows (``mass_torque``).

Which functions run is decided by the scene's effects in
:mod:`harmbal.model.evaluate`; an effect that is not asked for is never computed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kinematics import SliderCrank


@dataclass(frozen=True)
class PlanarLoad:
    """Force (c, n) on the block, roll moment about the crank axis, kinetic
    energy and power d(KE)/dθ at unit speed; arrays of shape (cylinder, angle)."""

    force_c: np.ndarray
    force_n: np.ndarray
    roll: np.ndarray
    power: np.ndarray
    energy: np.ndarray


def _cross(p, q):
    """z-component of the planar cross product p × q, (c, n) pairs."""
    return p[0] * q[1] - p[1] * q[0]


def _dot(p, q):
    return p[0] * q[0] + p[1] * q[1]


def reciprocating(kin: SliderCrank, piston_mass, piston_lateral, rod_small_end) -> PlanarLoad:
    """Piston group plus the con-rod's small-end share, moving with the pin.

    Both translate along the cylinder axis with acceleration c_B''; the piston
    CG may sit ``piston_lateral`` off the pin path, which changes only the
    roll moment.
    """
    mass = piston_mass + rod_small_end
    force_c = -mass * kin.ddb
    lever = kin.e + piston_lateral * piston_mass / mass
    return PlanarLoad(
        force_c=force_c,
        force_n=np.zeros_like(force_c),
        roll=-lever * force_c,
        power=mass * kin.db * kin.ddb,
        energy=mass * kin.db**2 / 2,
    )


def rotating_rod(a, rod_big_end) -> PlanarLoad:
    """The con-rod's big-end share, turning with the crank pin A (A'' = −A).

    The force is radial, so it has no roll moment and does no work.
    """
    force_c, force_n = rod_big_end * a[0], rod_big_end * a[1]
    zero = np.zeros(np.broadcast_shapes(np.shape(force_c), np.shape(force_n)))
    return PlanarLoad(force_c=force_c + zero, force_n=force_n + zero, roll=zero, power=zero,
                      energy=rod_big_end * (a[0] ** 2 + a[1] ** 2) / 2 + zero)


def rod_inertia(kin: SliderCrank, mass, cg_along, cg_lateral, inertia, length, off_axis: bool) -> PlanarLoad:
    """What a rigid rod has beyond its two-point split.

    The split keeps mass and the on-axis CG G₀, so it differs from the rigid
    body by (i) the couple −(I_G − m·a·(l − a))·ϑ̈ (the two point masses have
    inertia m·a·(l − a) about G₀) and, if ``off_axis``, (ii) the loads of the
    CG lying ``cg_lateral`` off the rod axis: force −m(G'' − G₀'') and roll
    −m(G × G'' − G₀ × G₀'').
    """
    deficit = inertia - mass * cg_along * (length - cg_along)
    roll = -deficit * kin.ddrod_angle
    power = deficit * kin.drod_angle * kin.ddrod_angle
    energy = deficit * kin.drod_angle**2 / 2
    force_c = np.zeros_like(roll)
    force_n = np.zeros_like(roll)
    if off_axis:
        g0, dg0, ddg0 = kin.rod_point(cg_along, 0.0, length)
        g, dg, ddg = kin.rod_point(cg_along, cg_lateral, length)
        force_c = -mass * (ddg[0] - ddg0[0])
        force_n = -mass * (ddg[1] - ddg0[1])
        roll = roll - mass * (_cross(g, ddg) - _cross(g0, ddg0))
        power = power + mass * (_dot(dg, ddg) - _dot(dg0, ddg0))
        energy = energy + mass * (_dot(dg, dg) - _dot(dg0, dg0)) / 2
    return PlanarLoad(force_c=force_c, force_n=force_n, roll=roll, power=power, energy=energy)


def rotating_unbalance(angle, unbalance, x, sense: int):
    """Centrifugal force of static unbalances turning with the crank.

    Parameters
    ----------
    angle : ndarray
        Direction of each unbalance [rad] from +z in the direction of
        rotation, shape (element, angle).
    unbalance : ndarray
        Mass × radius [kg m], shape (element, 1).
    x : ndarray
        Axial position [m], shape (element, 1).
    sense : int
        +1 if the crank turns about +x, −1 otherwise.

    Returns
    -------
    force, moment : ndarray
        Force [N] and moment about the origin [N m] at unit speed, shape
        (element, 3, angle). The force is radial, so its moment about the crank
        axis vanishes.
    """
    fz = unbalance * np.cos(angle)
    fy = -sense * unbalance * np.sin(angle)
    zero = np.zeros_like(fz)
    force = np.stack([zero, fy, fz], axis=1)
    moment = np.stack([zero, -x * fz, x * fy], axis=1)
    return force, moment
