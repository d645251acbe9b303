"""Rotating balancer elements: balance shafts and the crankshaft's own mass data.

A :class:`Shaft` turns at ``ratio`` × crank speed (n, a non-zero integer;
negative turns against the crank) about an axis parallel to the crank axis
at (y, z). It carries static unbalances (mass × radius at an angle and an
axial position) and a couple unbalance. Its loads on the block at constant
speed are pure order-|n| rotating vectors: co-rotating for n > 0,
counter-rotating for n < 0.

Angles are measured at θ = 0 from +z in the crank's direction of rotation,
like crank angles; transverse vectors are written w = v_z + i·v_t with
t 90° ahead of +z in the direction of rotation (t = −sense·y), see
docs/conventions.md.

Couple unbalance. A body spinning about the x axis at Ω with its CG on the
axis exerts on its bearings the moment M = Ω²·(0, −J_xz, J_xy), with the
products of inertia J_xy = ∫x·y dm and J_xz = ∫x·z dm about the body's
reference point, taken in the engine frame at θ = 0 (the moment turns with
the body). In the w-plane that is w_M(θ = 0) = Ω²·(J_xy + i·sense·J_xz): the
complex ``couple`` [kg m²] stored here. CAD and multibody tools differ in the
sign of products of inertia (the inertia tensor holds D = −∫x·y dm), so scene
input names its convention.
"""

from __future__ import annotations

import cmath

import numpy as np

from ..scene.elements import Shaft, ShaftUnbalance


def shaft_amplitudes(shaft: Shaft, sense: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis complex amplitudes P at unit crank speed of one shaft's force
    and moment about the origin: each load is Re(P·e^{inθ}), n the ratio.

    The static unbalances make the transverse force w_F = n²·Σ U·e^{iα}
    (w-plane, at θ = 0), acting on the shaft axis (y_a, z_a) at their axial
    positions: its moment is i·sense·x·w per unbalance, and the roll moment
    M_x = y_a·F_z − z_a·F_y = Re(w_F·(y_a − i·sense·z_a)). The couple adds
    n²·couple to the transverse moment. In the engine frame F_z = Re(w),
    F_y = −sense·Im(w) = Re(i·sense·w).
    """
    n2 = shaft.ratio**2
    w_force = sum((n2 * cmath.rect(u.unbalance, u.angle) for u in shaft.unbalances), 0j)
    w_moment = n2 * shaft.couple + sum((1j * sense * u.x * n2 * cmath.rect(u.unbalance, u.angle)
                                        for u in shaft.unbalances), 0j)
    roll = w_force * (shaft.y - 1j * sense * shaft.z)
    force = np.array([0j, 1j * sense * w_force, w_force])
    moment = np.array([roll, 1j * sense * w_moment, w_moment])
    return force, moment


def unbalance_phasors(angle: float, unbalance: float, x: float, sense: int) -> tuple[np.ndarray, np.ndarray]:
    """First-order force and moment (about the origin) phasors per axis of a
    static unbalance [kg m] at axial position ``x`` [m] turning with the
    crank, pointing at ``angle`` [rad]: a shaft at ratio 1 (:func:`shaft_amplitudes`)."""
    return shaft_amplitudes(Shaft("", 1, 0.0, 0.0, (ShaftUnbalance(unbalance, angle, x),)), sense)


def shaft_loads(shafts: tuple[Shaft, ...], theta: np.ndarray, sense: int,
                tangential: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Force and moment about the origin of the shafts at unit crank speed over
    the crank angles ``theta``, summed: arrays (axis, angle). ``tangential``:
    the loads per unit crank acceleration instead (a point at phase nθ has
    d²q/dθ² = −n²·q and dq/dθ = n·i·q, so Re(P e^{inθ}) becomes Re(−i·P/n e^{inθ}))."""
    # The loads are linear in the amplitudes and Re(P e^{−inθ}) = Re(P̄ e^{inθ}): the shafts at ±n (a crank's
    # counterweights and a −1× moment shaft, say) share one e^{inθ}, the dearest part on a fine grid.
    amplitudes: dict[int, np.ndarray] = {}
    for shaft in shafts:
        p = np.concatenate(shaft_amplitudes(shaft, sense))  # force then moment, (6,)
        if tangential:
            p = -1j * p / shaft.ratio
        n = abs(shaft.ratio)
        amplitudes[n] = amplitudes.get(n, 0) + (p if shaft.ratio > 0 else np.conj(p))
    total = np.zeros((6, len(theta)))
    for n, p in amplitudes.items():
        total += (p[:, None] * np.exp(1j * n * theta)).real
    return total[:3], total[3:]


def shaft_phasors(shafts: tuple[Shaft, ...], max_order: int, sense: int) -> tuple[np.ndarray, np.ndarray]:
    """Order phasors C_k (s = Σ Re(C_k e^{ikθ})) of the shafts' force and
    moment about the origin at unit crank speed, summed: arrays (axis, order).
    Re(P·e^{inθ}) is order |n| with phasor P for n > 0 and conj(P) for n < 0."""
    force = np.zeros((3, max_order + 1), dtype=complex)
    moment = np.zeros((3, max_order + 1), dtype=complex)
    for shaft in shafts:
        k = abs(shaft.ratio)
        if k > max_order:
            continue
        p_force, p_moment = shaft_amplitudes(shaft, sense)
        if shaft.ratio < 0:
            p_force, p_moment = np.conj(p_force), np.conj(p_moment)
        force[:, k] += p_force
        moment[:, k] += p_moment
    return force, moment
