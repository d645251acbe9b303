"""High-precision reference order phasors of the exact model, for accuracy benchmarks.

Written from the physics with mpmath (50 significant digits by default), independently of
harmbal's model code: only the scene dataclasses are read. The loads the moving parts exert on
the block at constant crank speed ω are (docs/conventions.md, "What is reported")

    F = −Σ m·a_G,
    M_p = −Σ ((r_G − p) × m·a_G + I_G·ϑ̈·e_ω) + T·e_ω,   T = ω²·d(KE)/dθ (effect ``mass_torque``),

summed over the bodies the scene's effects simulate. Everything below is at unit crank speed,
where positions, velocities and accelerations are the crank-angle derivatives q, q', q'', and is
multiplied by ω² at the end.

Method. A cylinder lies in its own plane (c along its axis, n 90° ahead in the direction of
rotation) at its local crank angle ψ = θ + φ − β (throw φ, bank β). Cylinders with the same
geometry and masses share one *type*: its planar load (force along c and n, roll moment about the
crank axis) is evaluated once, with hand-written first and second ψ-derivatives, at M equally
spaced ψ, and its Fourier coefficients of orders 0 … K are the trapezoid sums (exact up to
aliasing). A cylinder of that type then has the order-k phasors of its type times e^{ik(φ − β)};
its bank turns the in-plane vector by β, and its axial position x adds the moments x·e_x × F.
Unbalances turning with the crank and balance shafts are rigid rotors whose loads are pure single
orders; their phasors are found from four angles of the rotor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .scene import Cylinder, Model, Scene

DEFAULT_DPS = 50


@dataclass(frozen=True)
class ReferencePhasors:
    """Reference order phasors of a scene's shaking force and moment.

    Attributes
    ----------
    force, moment : ndarray of complex128, shape (max_order + 1, 3)
        Phasors C_k (s(θ) = Σ Re(C_k e^{ikθ})) per order and axis (x, y, z) in the engine frame
        [N] and [N m]; the moment is about the scene's ``reference_point``.
    force_mp, moment_mp : tuple of tuple of mpmath.mpc
        The same values at full working precision, indexed [order][axis].
    force_scale, moment_scale : float
        A size for relative errors: the largest single-element load, i.e. the largest
        ‖C_k‖ = sqrt(Σ_axis |C_k,axis|²) over the orders 0 … max_order and over the single
        elements (each cylinder's moving parts with its throw unbalances, each crankshaft
        unbalance, each balancer shaft) taken on their own; the moment about the reference point.
    omega : float
        Crank speed [rad/s].
    samples : int
        Number M of crank angles of the trapezoid sums.
    dps : int
        Working precision in significant decimal digits.
    """

    force: np.ndarray
    moment: np.ndarray
    force_mp: tuple[tuple[Any, ...], ...]
    moment_mp: tuple[tuple[Any, ...], ...]
    force_scale: float
    moment_scale: float
    omega: float
    samples: int
    dps: int


def reference_phasors(scene: Scene, max_order: int, *, omega: float | None = None, dps: int = DEFAULT_DPS,
                      samples: int | None = None) -> ReferencePhasors:
    """Order phasors of the shaking force and moment of ``scene``, to ``dps`` digits.

    Supported: the exact piston model (``model.piston = "exact"``), every rod model and any
    subset of the effects, honoured as docs/conventions.md defines them: ``reciprocating`` (piston
    group and the rod's small-end share at the piston pin), ``rotating`` (the rod's big-end share
    at the crank pin, throw and crankshaft unbalances), ``rod_inertia`` (the rigid rod minus its
    two-point split; with ``rod = "two_point_couple"`` the rod's CG is taken on its axis, with
    ``"two_point"`` the effect adds nothing), ``mass_torque`` (T = ω²·d(KE)/dθ of the bodies
    simulated) and ``balancers`` (counterweights, balance shafts, Lanchester pairs, crankshaft
    mass data). With reciprocating, rotating and rod_inertia the rod is the rigid body itself.

    Parameters
    ----------
    scene : Scene
        The engine (see :func:`harmbal.load_scene`).
    max_order : int
        Highest order K returned.
    omega : float, optional
        Crank speed [rad/s]; default the scene's first speed.
    dps : int, default 50
        Working precision (significant decimal digits); mpmath's global precision is untouched.
    samples : int, optional
        Number M of crank angles; default :func:`reference_samples` (for convergence checks).

    Returns
    -------
    ReferencePhasors

    Raises
    ------
    ValueError
        For lever balancers, the series piston model, a crank train that cannot assemble, or
        fewer than 2K + 2 samples.
    """
    import mpmath

    if scene.levers:
        raise ValueError("reference: lever balancers are not supported")
    if scene.model.piston != "exact":
        raise ValueError(f"reference: only the exact piston model is supported, not {scene.model.piston!r}")
    if max_order < 0:
        raise ValueError(f"reference: max_order must not be negative, got {max_order}")
    chosen = reference_samples(scene, max_order, dps=dps)  # also checks that every crank train assembles
    n = chosen if samples is None else samples
    if n < 2 * max_order + 2:
        raise ValueError(f"reference: {n} samples cannot resolve order {max_order} (need at least {2 * max_order + 2})")
    omega = scene.speeds[0] if omega is None else omega
    effects = scene.model.effects
    sense = scene.sense

    with mpmath.mp.workdps(dps):
        mp = mpmath.mp
        grid = [(mp.cospi(mp.mpf(2 * j) / n), mp.sinpi(mp.mpf(2 * j) / n)) for j in range(n)]
        types: dict[tuple, list] = {}
        elements = []  # (force, moment about the origin) per order, unit speed
        for cyl in scene.cylinders:
            key = _type_key(cyl)
            if key not in types:
                types[key] = _type_phasors(cyl, scene.model, grid, max_order)
            force, moment = _place(types[key], cyl, sense)
            if "rotating" in effects:
                for u in cyl.throw_unbalances:
                    _accumulate(force, moment, *_rotor(1, 0, 0, [(u.unbalance, mp.mpf(cyl.throw) + u.angle, u.x)],
                                                       0j, sense, max_order))
            elements.append((force, moment))
        if "rotating" in effects:
            elements += [_rotor(1, 0, 0, [(u.unbalance, u.angle, u.x)], 0j, sense, max_order)
                         for u in scene.crankshaft_unbalances]
        if "balancers" in effects:
            elements += [_rotor(s.ratio, s.y, s.z, [(u.unbalance, u.angle, u.x) for u in s.unbalances], s.couple,
                                sense, max_order) for s in scene.shafts]

        p = [mp.mpf(c) for c in scene.reference_point]
        w2 = mp.mpf(omega) ** 2
        total_force = [[mp.mpc(0)] * 3 for _ in range(max_order + 1)]
        total_moment = [[mp.mpc(0)] * 3 for _ in range(max_order + 1)]
        force_scale = moment_scale = mp.mpf(0)
        for force, moment in elements:
            moment = [[m - q for m, q in zip(mk, _cross(p, fk))] for fk, mk in zip(force, moment)]
            force_scale = max([force_scale] + [_norm(fk) for fk in force])
            moment_scale = max([moment_scale] + [_norm(mk) for mk in moment])
            _accumulate(total_force, total_moment, force, moment)
        force_mp = tuple(tuple(w2 * v for v in fk) for fk in total_force)
        moment_mp = tuple(tuple(w2 * v for v in mk) for mk in total_moment)
        return ReferencePhasors(
            force=np.array([[complex(v) for v in fk] for fk in force_mp], dtype=np.complex128),
            moment=np.array([[complex(v) for v in mk] for mk in moment_mp], dtype=np.complex128),
            force_mp=force_mp, moment_mp=moment_mp,
            force_scale=float(w2 * force_scale), moment_scale=float(w2 * moment_scale),
            omega=float(omega), samples=n, dps=dps,
        )


def reference_samples(scene: Scene, max_order: int, *, dps: int = DEFAULT_DPS) -> int:
    """Number of crank angles M that keeps aliasing far below the working precision.

    The slider-crank harmonics decay like n²ρⁿ relative to the first order, with
    ρ = σ − sqrt(σ² − 1) = 1/(σ + sqrt(σ² − 1)), σ = (l − |e|)/r (the nearest complex angle at which
    the rod stands across the pin path; for e = 0, ρ = λ/(1 + sqrt(1 − λ²))). Order k ≤ K is
    contaminated first by order M − k ≥ M − K, so M is the smallest multiple of 8 with
    M ≥ K + m and M ≥ 2K + 2, where m is the smallest integer with m²ρ^m < 10^(5 − dps)
    (1e-45 at 50 digits), ρ the slowest decay of the scene's cylinders.

    Parameters
    ----------
    scene : Scene
        The engine.
    max_order : int
        Highest order K wanted.
    dps : int, default 50
        Working precision (significant decimal digits).

    Returns
    -------
    int

    Raises
    ------
    ValueError
        If a crank train cannot assemble (l ≤ r + |e|).
    """
    rho = 0.0
    for cyl in scene.cylinders:
        sigma = (cyl.rod_length - abs(cyl.pin_offset + cyl.cylinder_offset)) / cyl.crank_radius
        if not sigma > 1:
            raise ValueError(f"reference: cylinder {cyl.label} cannot assemble (needs rod length > crank radius "
                             "+ |pin offset + cylinder offset|)")
        rho = max(rho, 1 / (sigma + math.sqrt(sigma * sigma - 1)))
    log_target = (5 - dps) * math.log(10)
    m = 1
    while 2 * math.log(m) + m * math.log(rho) >= log_target:
        m += 1
    return 8 * math.ceil(max(max_order + m, 2 * max_order + 2) / 8)


# --------------------------------------------------------------------------
# One cylinder type in its own plane


def _type_key(cyl: Cylinder) -> tuple:
    """What the planar load of a cylinder depends on (everything but its placement)."""
    return (cyl.crank_radius, cyl.rod_length, cyl.pin_offset, cyl.cylinder_offset, cyl.piston, cyl.rod)


def _type_phasors(cyl: Cylinder, model: Model, grid: list, max_order: int) -> list:
    """Order phasors (in ψ) of one cylinder type's planar load at unit speed: three lists
    (force along c, force along n, roll moment about the crank axis in the direction of
    rotation, with the mass torque's reaction if simulated) of K + 1 mpc each."""
    import mpmath

    mp = mpmath.mp
    mpf = mp.mpf
    effects = model.effects
    r, l = mpf(cyl.crank_radius), mpf(cyl.rod_length)
    e = mpf(cyl.pin_offset) + mpf(cyl.cylinder_offset)
    reciprocating = "reciprocating" in effects
    rotating = "rotating" in effects
    rigid_rod = "rod_inertia" in effects and model.rod != "two_point"

    # Point masses: the rod's two-point split (small end at the piston pin B for
    # 'reciprocating', big end at the crank pin A for 'rotating'); 'rod_inertia' is the rigid
    # rod minus that split, so with all three effects only the rigid rod remains.
    rod_mass, along = mpf(cyl.rod.mass), mpf(cyl.rod.cg_from_big_end)
    small = rod_mass * along / l
    big = rod_mass - small
    m_pin_b = small * (int(reciprocating) - int(rigid_rod))
    m_pin_a = big * (int(rotating) - int(rigid_rod))
    m_piston = mpf(cyl.piston.mass) if reciprocating else mpf(0)
    piston_offset = (mpf(cyl.piston.cg_axial), mpf(cyl.piston.cg_lateral))
    if rigid_rod:
        f = along / l
        q = (mpf(cyl.rod.cg_lateral) if model.rod == "rigid" else mpf(0)) / l  # two_point_couple: CG on the axis
        inertia = mpf(cyl.rod.inertia)

    signals: tuple[list, list, list] = ([], [], [])
    for cos, sin in grid:
        # Crank pin A = r(cos ψ, sin ψ); piston pin B = (r cos ψ + S, e) with S = sqrt(l² − g²),
        # g = e − r sin ψ the rod's rise across the cylinder axis (sin ϑ = g/l, cos ϑ = S/l).
        pin_a = ((r * cos, r * sin), (-r * sin, r * cos), (-r * cos, -r * sin))
        g, dg, ddg = e - r * sin, -r * cos, r * sin
        s = mp.sqrt(l * l - g * g)
        ds = -g * dg / s
        dds = -(dg * dg + g * ddg) / s - (g * dg) ** 2 / s**3
        pin_b = ((r * cos + s, e), (-r * sin + ds, mpf(0)), (-r * cos + dds, mpf(0)))
        bodies: list[tuple[Any, tuple]] = [  # (mass, (position, first, second derivative))
            (m_piston, ((pin_b[0][0] + piston_offset[0], e + piston_offset[1]), pin_b[1], pin_b[2])),
            (m_pin_b, pin_b),
            (m_pin_a, pin_a),
        ]
        if rigid_rod:
            # G = A + f·(B − A) + q·R90(B − A), R90(c, n) = (−n, c): affine in A and B, so its
            # derivatives are the same combination of theirs.
            rod_point = []
            for (ac, an), (bc, bn) in zip(pin_a, pin_b):
                dc, dn = bc - ac, bn - an
                rod_point.append((ac + f * dc - q * dn, an + f * dn + q * dc))
            bodies.append((rod_mass, tuple(rod_point)))
        force_c = force_n = roll = power = mpf(0)
        for mass, ((pc, pn), (vc, vn), (ac, an)) in bodies:
            if mass:
                force_c -= mass * ac
                force_n -= mass * an
                roll -= mass * (pc * an - pn * ac)
                power += mass * (vc * ac + vn * an)
        if rigid_rod:
            dtheta = dg / s  # rod angle ϑ from the cylinder axis towards n
            ddtheta = (ddg * s - dg * ds) / (s * s)
            roll -= inertia * ddtheta
            power += inertia * dtheta * ddtheta
        if "mass_torque" in effects:
            roll += power  # reaction of the drive torque d(KE)/dθ (unit speed)
        for signal, value in zip(signals, (force_c, force_n, roll)):
            signal.append(value)
    return [_fourier(signal, grid, max_order) for signal in signals]


def _fourier(values: list, grid: list, max_order: int) -> list:
    """Phasors C_0 … C_K of samples at ψ_j = 2πj/M by the trapezoid rule:
    C_k = (2/M)·Σ_j s_j e^{−ikψ_j} (1/M for k = 0)."""
    import mpmath

    mp = mpmath.mp
    n = len(values)
    out = []
    for k in range(max_order + 1):
        turns = [grid[(k * j) % n] for j in range(n)]
        re = mp.fdot(values, [c for c, _ in turns])
        im = -mp.fdot(values, [s for _, s in turns])
        out.append(mp.mpc(re, im) * (1 if k == 0 else 2) / n)
    return out


def _place(planar: list, cyl: Cylinder, sense: int) -> tuple[list, list]:
    """Engine-frame force and moment about the origin, per order, of one cylinder from its
    type's planar phasors.

    ψ = θ + φ − β, so order k picks up e^{ik(φ − β)}. The in-plane vector (c, n) becomes
    w = z + i·t = (c + i·n)·e^{iβ}, t = −sense·y; all bodies lie in the plane x = x_i, so the
    moment about the origin is (sense·roll, −x·F_z, x·F_y).
    """
    import mpmath

    mp = mpmath.mp
    delta = mp.mpf(cyl.throw) - mp.mpf(cyl.bank)
    cb, sb = mp.cos(cyl.bank), mp.sin(cyl.bank)
    x = mp.mpf(cyl.x)
    force, moment = [], []
    for k, (fc, fn, roll) in enumerate(zip(*planar)):
        shift = mp.expj(k * delta)
        fc, fn, roll = fc * shift, fn * shift, roll * shift
        fz = cb * fc - sb * fn
        fy = -sense * (sb * fc + cb * fn)
        force.append([mp.mpc(0), fy, fz])
        moment.append([sense * roll, -x * fz, x * fy])
    return force, moment


# --------------------------------------------------------------------------
# Rotors: unbalances on the crank and balance shafts

#: (cos φ, sin φ) at the rotor angles 0, 90°, 180°, 270°, exactly.
_QUARTERS = ((1, 0), (0, 1), (-1, 0), (0, -1))


def _rotor(ratio: int, y: float, z: float, unbalances: list, couple: complex, sense: int,
           max_order: int) -> tuple[list, list]:
    """Force and moment about the origin, per order, of a rigid rotor turning at ratio·θ about
    the axis through (y, z) parallel to x, at unit crank speed.

    A static unbalance U (mass × radius) at angle α + φ (φ = ratio·θ, the rotor angle; from +z in
    the direction of rotation) and axial position x pulls the axis with U·ratio² along its
    direction d = cos(α + φ)·e_z + sin(α + φ)·e_t, e_t = −sense·e_y; the mass point's offset from
    the axis is parallel to the force, so the moment is (x, y, z) × F. A couple unbalance: at
    constant spin Ω about x the angular momentum H = I·Ω turns, dH/dt = Ω × H, and the block gets
    −Ω × (I·Ω) = Ω²·(0, −J_xz, J_xy), J = ∫x·(y, z) dm; ∫x·(z + i·t) dm = −i·sense·couple at
    φ = 0 (``couple`` as :class:`harmbal.model.balancers.Shaft` stores it) and turns with the rotor as
    e^{iφ}. The loads are pure first harmonics of φ, so four rotor angles give their phasor
    P = ½·Σ L(φ_j)·e^{−iφ_j} exactly; as order |ratio| of θ that is P, or conj(P) for ratio < 0.
    """
    import mpmath

    mp = mpmath.mp
    order = abs(ratio)
    force = [[mp.mpc(0)] * 3 for _ in range(max_order + 1)]
    moment = [[mp.mpc(0)] * 3 for _ in range(max_order + 1)]
    if order > max_order:
        return force, moment
    n2 = ratio * ratio
    axis = (mp.mpf(y), mp.mpf(z))
    spin_products = -1j * sense * mp.mpc(couple.real, couple.imag)
    unbalances = [(mp.mpf(u), mp.cos(alpha), mp.sin(alpha), mp.mpf(x)) for u, alpha, x in unbalances]
    p_force, p_moment = [mp.mpc(0)] * 3, [mp.mpc(0)] * 3
    for cos, sin in _QUARTERS:
        f_total, m_total = [mp.mpf(0)] * 3, [mp.mpf(0)] * 3
        for u, ca, sa, x in unbalances:
            d_z, d_t = ca * cos - sa * sin, sa * cos + ca * sin
            f = (mp.mpf(0), -sense * n2 * u * d_t, n2 * u * d_z)
            f_total = [a + b for a, b in zip(f_total, f)]
            m_total = [a + b for a, b in zip(m_total, _cross((x, *axis), f))]
        products = spin_products * mp.mpc(cos, sin)
        j_xz, j_xy = products.real, -sense * products.imag
        m_total = [m_total[0], m_total[1] - n2 * j_xz, m_total[2] + n2 * j_xy]
        turn = mp.mpc(cos, -sin) / 2
        p_force = [p + v * turn for p, v in zip(p_force, f_total)]
        p_moment = [p + v * turn for p, v in zip(p_moment, m_total)]
    if ratio < 0:
        p_force, p_moment = [mp.conj(v) for v in p_force], [mp.conj(v) for v in p_moment]
    force[order], moment[order] = p_force, p_moment
    return force, moment


# --------------------------------------------------------------------------
# Small vector helpers (mpmath values)


def _cross(u, v) -> list:
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


def _norm(v):
    import mpmath

    return mpmath.mp.sqrt(sum(abs(c) ** 2 for c in v))


def _accumulate(force: list, moment: list, more_force: list, more_moment: list) -> None:
    """Add per-order loads in place."""
    for total, more in ((force, more_force), (moment, more_moment)):
        for k, values in enumerate(more):
            total[k] = [a + b for a, b in zip(total[k], values)]
