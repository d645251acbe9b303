"""Lever (linkage) balancers: a four-bar driven by a second crank pin.

A :class:`LeverBalancer` lies in a plane normal to the crank axis at axial
position ``x``. A second crank pin C on the crankshaft (radius ``pin_radius``,
at ``pin_angle`` from throw 1 in the direction of rotation) drives a coupler
body (the balance weight) from C to B; a rocker pivoted in the crankcase at A
holds B. D, the crank axis, is the origin, so A–B–C–D is a four-bar with one
degree of freedom, the crank angle θ.

Planar coordinates are the w-plane of :mod:`harmbal.orders`: a point is the
complex number w = z + i·t, t = −sense·y pointing 90° ahead of +z in the
direction of rotation, so angles count like crank angles and the kinematics
of a mirrored engine are the same numbers. A body's local frame has its
x axis along the link (rocker: origin A, x along A→B; coupler: origin B,
x along B→C) and its y axis 90° ahead of it in the direction of rotation.

Closure in closed form (never two independent sign choices): with
D = C − A, q = |D|², a = |AB| (rocker) and b = |BC| (coupler),

    B = A + D·κ,   κ = (a² − b² + q)/(2q) + i·s·sqrt(Δ)/(2q),
    Δ = 4a²q − (a² − b² + q)² = ((a + b)² − q)(q − (a − b)²) = 4a²b²·sin²γ,

where γ is the transmission angle (between rocker and coupler at B) and
s = ±1 the assembly mode: s = +1 (``"ahead"``) puts B ahead of the directed
line A→C in the direction of rotation, s = −1 (``"behind"``) behind it. The
loop closes at every angle exactly when Δ > 0 over the whole revolution, i.e.
(a − b)² < q < (a + b)² for q between (|A| − r_C)² and (|A| + r_C)²; at
Δ = 0 the rocker and coupler are in line (toggle) and the mode is ambiguous,
so harmbal refuses that too.

All derivatives are with respect to θ (transfer functions μ = dq/dθ,
ν = d²q/dθ²); a point's acceleration is ν·ω² + μ·α.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene.elements import ASSEMBLY_MODES, LeverBalancer


def decay_rate(lever: LeverBalancer, sense: int) -> float:
    """Geometric decay rate ρ of the linkage's harmonics.

    The motion is analytic in θ except where q(θ) = (a ± b)² (Δ = 0) or
    q = 0; with q = |A|² + r² − 2|A|r·cos φ (φ the angle between C and A)
    these sit at cos φ = σ, |σ| > 1, a distance arccosh|σ| from the real axis,
    so the Fourier coefficients decay like ρⁿ, ρ = |σ| − sqrt(σ² − 1).
    """
    a, b, r = lever.rocker_length, lever.coupler_length, lever.pin_radius
    dist = abs(lever.pivot_w(sense))
    if dist == 0:  # pivot on the crank axis: q = r² is constant, the links turn rigidly with the crank
        return 0.0
    rho = 0.0
    for target in ((a + b) ** 2, (a - b) ** 2, 0.0):
        sigma = abs((dist * dist + r * r - target) / (2 * dist * r))
        if sigma > 1:
            rho = max(rho, sigma - math.sqrt(sigma * sigma - 1))
        else:
            rho = 1.0  # only reached by a linkage that the scene validation refuses
    return rho


@dataclass(frozen=True)
class FourBarMotion:
    """Positions in the w-plane (complex) and their θ-derivatives.

    ``c``, ``b``: the crank pin C and the joint B with first and second
    derivatives (``dc``, ``ddc``, ``db``, ``ddb``); ``rocker`` and
    ``coupler``: the link angles (from +z, in the direction of rotation) with
    their derivatives; ``sin_gamma``: sine of the transmission angle.
    """

    pivot: complex
    c: np.ndarray
    dc: np.ndarray
    ddc: np.ndarray
    b: np.ndarray
    db: np.ndarray
    ddb: np.ndarray
    rocker: np.ndarray
    drocker: np.ndarray
    ddrocker: np.ndarray
    coupler: np.ndarray
    dcoupler: np.ndarray
    ddcoupler: np.ndarray
    sin_gamma: np.ndarray

    def point(self, body: str, local: complex):
        """A point fixed in the rocker or the coupler, given in the body's
        local frame: (position, first, second derivative), complex arrays."""
        origin: complex | np.ndarray
        d_origin: float | np.ndarray
        dd_origin: float | np.ndarray
        if body == "rocker":
            origin, d_origin, dd_origin = self.pivot, 0.0, 0.0
            angle, d_angle, dd_angle = self.rocker, self.drocker, self.ddrocker
        elif body == "coupler":
            origin, d_origin, dd_origin = self.b, self.db, self.ddb
            angle, d_angle, dd_angle = self.coupler, self.dcoupler, self.ddcoupler
        else:
            raise ValueError(f"unknown link {body!r}: 'rocker' or 'coupler'")
        arm = local * np.exp(1j * angle)
        return origin + arm, d_origin + 1j * d_angle * arm, dd_origin + (1j * dd_angle - d_angle**2) * arm


def four_bar(lever: LeverBalancer, theta: np.ndarray, sense: int) -> FourBarMotion:
    """Closed-form position, μ and ν of the lever balancer at crank angles θ."""
    s = ASSEMBLY_MODES[lever.assembly]
    a2, b2 = lever.rocker_length**2, lever.coupler_length**2
    pivot = lever.pivot_w(sense)
    c = lever.pin_radius * np.exp(1j * (np.asarray(theta, dtype=float) + lever.pin_angle))
    dc, ddc = 1j * c, -c
    d = c - pivot  # D = C − A; D' = C', D'' = C''
    q = d.real**2 + d.imag**2
    dq = 2 * (d.real * dc.real + d.imag * dc.imag)
    ddq = 2 * (dc.real**2 + dc.imag**2 + d.real * ddc.real + d.imag * ddc.imag)
    # κ = κ_r + i·s·R/(2q), κ_r = 1/2 + (a² − b²)/(2q), R = sqrt(Δ).
    k = a2 - b2
    kr, dkr, ddkr = 0.5 + k / (2 * q), -k * dq / (2 * q**2), -k * (ddq / (2 * q**2) - dq**2 / q**3)
    disc = 4 * a2 * q - (k + q) ** 2
    ddisc = (4 * a2 - 2 * (k + q)) * dq
    dddisc = -2 * dq**2 + (4 * a2 - 2 * (k + q)) * ddq
    root = np.sqrt(disc)
    droot = ddisc / (2 * root)
    ddroot = dddisc / (2 * root) - ddisc**2 / (4 * root**3)
    ki = s * root / (2 * q)
    dki = s * (droot / (2 * q) - root * dq / (2 * q**2))
    ddki = s * (ddroot / (2 * q) - droot * dq / q**2 - root * ddq / (2 * q**2) + root * dq**2 / q**3)
    kappa, dkappa, ddkappa = kr + 1j * ki, dkr + 1j * dki, ddkr + 1j * ddki
    b = pivot + d * kappa
    db = dc * kappa + d * dkappa
    ddb = ddc * kappa + 2 * dc * dkappa + d * ddkappa

    def angle(v, dv, ddv, length2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Angle of a vector of constant length and its derivatives:
        ϑ' = Im(v̄·v')/|v|², ϑ'' = Im(v̄·v'')/|v|²."""
        return np.angle(v), (np.conj(v) * dv).imag / length2, (np.conj(v) * ddv).imag / length2

    rocker = angle(b - pivot, db, ddb, a2)
    coupler = angle(c - b, dc - db, ddc - ddb, b2)
    sin_gamma = root / (2 * lever.rocker_length * lever.coupler_length)
    return FourBarMotion(pivot, c, dc, ddc, b, db, ddb, *rocker, *coupler, sin_gamma)


def acceleration(mu: np.ndarray, nu: np.ndarray, omega: float, alpha: float = 0.0) -> np.ndarray:
    """Acceleration from the transfer functions: ν·ω² + μ·α."""
    return nu * omega**2 + mu * alpha


@dataclass(frozen=True)
class LinkLoads:
    """Unit-speed loads of one lever balancer's moving links (rocker and
    coupler) on the block, in the w-plane: ``force`` (complex), ``roll``
    (moment about the crank axis, in the direction of rotation) and ``power``
    d(KE)/dθ; arrays over θ."""

    force: np.ndarray
    roll: np.ndarray
    power: np.ndarray


def _cross(p, q):
    """Planar cross product p × q of complex numbers (positive: q ahead of p)."""
    return (np.conj(p) * q).imag


def link_loads(lever: LeverBalancer, motion: FourBarMotion) -> LinkLoads:
    """−Σ m·a_G and −Σ (r_G × m·a_G + I·ϑ'') of rocker and coupler, and the
    power Σ (m·v_G·a_G + I·ϑ'·ϑ'') at unit crank speed."""
    force = np.zeros_like(motion.c)
    roll = np.zeros(np.shape(motion.c))
    power = np.zeros(np.shape(motion.c))
    for name, body, dangle, ddangle in (("rocker", lever.rocker, motion.drocker, motion.ddrocker),
                                        ("coupler", lever.coupler, motion.dcoupler, motion.ddcoupler)):
        g, dg, ddg = motion.point(name, complex(*body.cg))
        force = force - body.mass * ddg
        roll = roll - body.mass * _cross(g, ddg) - body.inertia * ddangle
        power = power + body.mass * (np.conj(dg) * ddg).real + body.inertia * dangle * ddangle
    return LinkLoads(force, roll, power)


def weight_basis(motion: FourBarMotion) -> np.ndarray:
    """The coupler's m·a_G as a linear map of p = (m, m·x_G, m·y_G).

    a_G = B'' + (x_G + i·y_G)·E with E = (i·ϑ'' − ϑ'²)·e^{iϑ}, so
    m·a_G = m·B'' + (m·x_G)·E + (m·y_G)·i·E: returns the complex columns
    (B'', E, i·E), shape (3, angle). The moment of inertia does not appear.
    """
    e = (1j * motion.ddcoupler - motion.dcoupler**2) * np.exp(1j * motion.coupler)
    return np.stack([motion.ddb, e, 1j * e])


def to_engine(w: np.ndarray, sense: int) -> tuple[np.ndarray, np.ndarray]:
    """A w-plane vector as engine components (y, z): z = Re w, y = −sense·Im w."""
    return -sense * w.imag, w.real


def lever_loads(levers: tuple[LeverBalancer, ...], theta: np.ndarray, sense: int,
                mass_torque: bool) -> tuple[np.ndarray, np.ndarray]:
    """Force and moment about the origin of the lever balancers' links at
    unit crank speed, summed: arrays (axis, angle). The moment about the crank
    axis includes the drive torque's reaction if ``mass_torque``."""
    force = np.zeros((3, len(theta)))
    moment = np.zeros((3, len(theta)))
    for lever in levers:
        loads = link_loads(lever, four_bar(lever, theta, sense))
        fy, fz = to_engine(loads.force, sense)
        roll = loads.roll + loads.power if mass_torque else loads.roll
        force[1] += fy
        force[2] += fz
        moment[0] += sense * roll
        moment[1] -= lever.x * fz
        moment[2] += lever.x * fy
    return force, moment
