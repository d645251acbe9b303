"""The rigid powertrain on its mounts, on plain arrays: inertia, stiffness,
statics, modes, the torque roll axis, the elastic centre and the forced
response per order.

Conventions (docs/mounts.md): SI; the engine frame of harmbal (x along the
crank axis, y transverse, z up); the six degrees of freedom are the small
displacement of the powertrain's CG and its small rotation,
q = [u_x, u_y, u_z, θ_x, θ_y, θ_z] (:data:`DOF_NAMES`). A point p moves by
d = u + θ × (p − c) = T(p) q, T = [I₃, −[p − c]ₓ]. Mount i has local axes R_i
(rows u, v, w in the engine frame), complex local stiffnesses
k*(Ω) = k(1 + iη) + iΩc, engine-frame matrix K_i = R_iᵀ diag(k*) R_i, and
transmits f_i = K_i T_i q into the frame. The system stiffness is
K = Σ T_iᵀ K_i T_i; the mass matrix M = diag(m, m, m, I) with I the inertia
tensor about the CG.

Every function broadcasts leading dimensions (speeds × orders × variants) and
works on all of them at once: stiffness matrices are contracted with one
matrix product each; the forced response is one batched LAPACK solve
(:func:`forced_response`). Arrays over many frequencies may be returned as
views of memory whose batch axis is the last one (their shapes are the
documented ones; ``np.ascontiguousarray`` gives the usual layout).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from scipy.optimize import linear_sum_assignment

from ..scene.mounts import inertia_from_parts  # noqa: F401  (the parts' totals: the scene reader's, re-exported)

#: The six degrees of freedom, in the order of every 6-vector and 6×6 matrix.
DOF_NAMES = ("x", "y", "z", "roll", "pitch", "yaw")

#: An eigenvalue of the diagonally scaled stiffness matrix (unit diagonal, eigenvalues at most 6) below this
#: share of the largest counts as zero: the mounts leave that direction free. Round-off of a singular sum of
#: mount matrices is ~1e-16 of the largest; a real but soft direction (a mount 1e6 times softer than the
#: others) is ~1e-6.
RANK_RTOL = 1e-10


def cross_matrix(vectors: np.ndarray) -> np.ndarray:
    """The cross-product matrices [a]ₓ ([a]ₓ b = a × b) of vectors (..., 3) -> (..., 3, 3)."""
    a = np.asarray(vectors, dtype=float)
    zero = np.zeros(a.shape[:-1])
    x, y, z = a[..., 0], a[..., 1], a[..., 2]
    return np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)


def mass_matrix(mass, inertia) -> np.ndarray:
    """The 6×6 mass matrix diag(m, m, m, I); mass (...) and inertia (..., 3, 3) broadcast."""
    m = np.asarray(mass, dtype=float)
    inertia = np.asarray(inertia, dtype=float)
    lead = np.broadcast_shapes(m.shape, inertia.shape[:-2])
    out = np.zeros(lead + (6, 6))
    out[..., range(3), range(3)] = m[..., None]
    out[..., 3:, 3:] = inertia
    return out


def point_transforms(points, cg) -> np.ndarray:
    """T(p) = [I₃, −[p − c]ₓ] of points (n, 3) about the CG (3,) -> (n, 3, 6): d = T q."""
    arm = np.asarray(points, dtype=float) - np.asarray(cg, dtype=float)
    eye = np.broadcast_to(np.eye(3), arm.shape[:-1] + (3, 3))
    return np.concatenate([eye, -cross_matrix(arm)], axis=-1)


def local_stiffness(stiffness, loss=None, damping=None, omega=None) -> np.ndarray:
    """Local stiffnesses of the mounts along their axes, k*(Ω) = k (1 + iη) + iΩc.

    Parameters
    ----------
    stiffness : array_like (..., n, 3)
        k along u, v, w [N/m].
    loss : array_like (..., n, 3), optional
        Hysteretic loss factors η.
    damping : array_like (..., n, 3), optional
        Viscous dampings c [N s/m]; needs ``omega``.
    omega : array_like (...), optional
        Circular frequencies Ω [rad/s], broadcast against the leading dimensions.

    Returns
    -------
    ndarray (..., n, 3)
        Real when neither ``loss`` nor ``damping`` is given, else complex.
    """
    k = np.asarray(stiffness, dtype=float)
    if damping is not None and omega is None:
        raise ValueError("viscous damping needs the circular frequency omega")
    w = None if omega is None else np.asarray(omega, dtype=float)
    lead = np.broadcast_shapes(k.shape[:-2], () if w is None else w.shape)
    for extra in (loss, damping):
        lead = lead if extra is None else np.broadcast_shapes(lead, np.shape(extra)[:-2])
    complex_ = loss is not None or damping is not None
    out = _batch_last_empty(lead, k.shape[-2:], complex if complex_ else float)
    out[...] = k
    if loss is not None:
        out.imag[...] = k * np.asarray(loss, dtype=float)
    if damping is not None and w is not None:
        out.imag[...] += w[..., None, None] * np.asarray(damping, dtype=float)
    return out


def table_stiffness(freq_hz, stiffness, loss, omega) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and loss factor of a mount's table at circular frequencies ``omega``.

    Linear interpolation in the frequency f = Ω/2π, held constant beyond the
    table's ends.

    Parameters
    ----------
    freq_hz : array_like (j,)
        Increasing frequencies of the table [Hz].
    stiffness, loss : array_like (j, 3)
        Stiffness [N/m] and loss factor along u, v, w at those frequencies.
    omega : array_like (...)
        Circular frequencies [rad/s].

    Returns
    -------
    k, eta : ndarray (..., 3)
    """
    f = np.asarray(freq_hz, dtype=float)
    k, eta = np.asarray(stiffness, dtype=float), np.asarray(loss, dtype=float)
    if f.ndim != 1 or k.shape != (f.size, 3) or eta.shape != (f.size, 3) or f.size == 0:
        raise ValueError(f"a table needs frequencies (j,) and values (j, 3), got {f.shape}, {k.shape}, {eta.shape}")
    if np.any(np.diff(f) <= 0):
        raise ValueError(f"the table's frequencies must increase strictly, got {f.tolist()} Hz")
    x = np.asarray(omega, dtype=float) / (2 * math.pi)
    if f.size == 1:
        shape = x.shape + (3,)
        return np.broadcast_to(k[0], shape).copy(), np.broadcast_to(eta[0], shape).copy()
    lower = np.clip(np.searchsorted(f, x, side="right") - 1, 0, f.size - 2)
    weight = np.clip((x - f[lower]) / (f[lower + 1] - f[lower]), 0.0, 1.0)[..., None]
    return (k[lower] * (1 - weight) + k[lower + 1] * weight,
            eta[lower] * (1 - weight) + eta[lower + 1] * weight)


def global_stiffness(axes, local) -> np.ndarray:
    """The mounts' 3×3 matrices in the engine frame, K_i = R_iᵀ diag(k*_i) R_i.

    Parameters
    ----------
    axes : array_like (n, 3, 3)
        R_i, rows the unit vectors u, v, w in the engine frame.
    local : array_like (..., n, 3)
        Local stiffnesses (real or complex), e.g. from :func:`local_stiffness`.

    Returns
    -------
    ndarray (..., n, 3, 3)
    """
    r = np.asarray(axes, dtype=float)
    weights = np.einsum("nca,ncb->nabc", r, r).reshape(r.shape[0], 9, 3)
    columns, lead = _batch_last(np.asarray(local), 2)
    return _batch_first(_matmul_real(weights, columns).reshape((r.shape[0], 3, 3) + lead), 3)


def system_matrix(transforms, mount_matrices) -> np.ndarray:
    """The 6×6 stiffness K = Σ T_iᵀ K_i T_i of mount matrices (..., n, 3, 3) -> (..., 6, 6)."""
    t = np.asarray(transforms, dtype=float)
    weights = np.einsum("nai,nbj->ijnab", t, t).reshape(36, -1)
    columns, lead = _batch_last(np.asarray(mount_matrices), 3)
    return _batch_first(_matmul_real(weights, columns.reshape((-1,) + columns.shape[3:])).reshape((6, 6) + lead), 2)


def projected_matrices(axes, transforms) -> np.ndarray:
    """P_{i,a} = T_iᵀ r_a r_aᵀ T_i (n, 3, 6, 6): K = Σ_i Σ_a k*_{i,a} P_{i,a}.

    Computed once per mount set, they turn the stiffness at every frequency
    into one matrix product (:func:`system_matrix_from_local`).
    """
    g = np.einsum("nac,ncj->naj", np.asarray(axes, dtype=float), np.asarray(transforms, dtype=float))
    return g[..., :, None] * g[..., None, :]


def system_matrix_from_local(projections, local) -> np.ndarray:
    """K = Σ_i Σ_a k*_{i,a} P_{i,a} -> (..., 6, 6) from :func:`projected_matrices` and local stiffnesses (..., n, 3)."""
    p = np.asarray(projections, dtype=float)
    columns, lead = _batch_last(np.asarray(local), 2)
    weights = p.reshape(-1, 36).T
    return _batch_first(_matmul_real(weights, columns.reshape((-1,) + columns.shape[2:])).reshape((6, 6) + lead), 2)


def dynamic_matrix(transforms, axes, local) -> np.ndarray:
    """K(Ω) (..., 6, 6) of local stiffnesses (..., n, 3) at mounts of ``transforms`` (n, 3, 6) and ``axes``
    (n, 3, 3): :func:`system_matrix_from_local` of :func:`projected_matrices`, in one call."""
    return system_matrix_from_local(projected_matrices(axes, transforms), local)


def direct_response(M, axes, transforms, local, Omega, loads, gyroscopic=None) -> tuple[np.ndarray, np.ndarray]:
    """Q (..., 6) and the mounts' forces into the frame (..., n, 3) of local
    stiffnesses (..., n, 3) at frequencies ``Omega`` (...) under ``loads``
    (..., 6): the system matrix from :func:`projected_matrices`, one
    :func:`forced_response` per system (the path of any mount set, tables
    included), :func:`mount_forces_local`."""
    stiffness = system_matrix_from_local(projected_matrices(axes, transforms), local)
    q = forced_response(M, stiffness, Omega, loads, gyroscopic)
    return q, mount_forces_local(axes, local, transforms, q)


def require_constrained(K) -> None:
    """Raise ValueError when the stiffness (6, 6) leaves a direction free or is not positive semi-definite.

    The rank is read from the eigenvalues of the matrix scaled to a unit
    diagonal (so that N/m and N m/rad compare); the message names the free
    directions in :data:`DOF_NAMES`.
    """
    k = np.asarray(K, dtype=float)
    diagonal = np.diag(k)
    scale = np.where(diagonal > 0, 1 / np.sqrt(np.where(diagonal > 0, diagonal, 1.0)), 1.0)
    values, vectors = np.linalg.eigh(k * scale[:, None] * scale[None, :])
    tolerance = RANK_RTOL * max(float(np.abs(values).max()), np.finfo(float).tiny)
    if values[0] < -tolerance:
        raise ValueError("the mount stiffness matrix is not positive semi-definite (a negative stiffness?): "
                         f"scaled eigenvalue {values[0]:.3g}")
    free = vectors[:, values <= tolerance] * scale[:, None]
    if free.shape[1]:
        names = "; ".join(_direction_name(v) for v in free.T)
        raise ValueError(f"the mounts do not constrain all six degrees of freedom: the stiffness matrix has rank "
                         f"{6 - free.shape[1]} < 6; free: {names}. Add a mount or a stiffness along it")


def _direction_name(vector: np.ndarray) -> str:
    """A null direction in dof names, e.g. 'x' or '0.707 roll - 0.707 yaw'."""
    v = vector / np.abs(vector).max()
    v = v * np.sign(v[np.argmax(np.abs(v))]) / np.linalg.norm(v)
    terms = [(c, name) for c, name in zip(v, DOF_NAMES) if abs(c) > 1e-3]
    if len(terms) == 1:
        return terms[0][1]
    return " ".join(f"{'-' if c < 0 else '+'} {abs(c):.3g} {name}" for c, name in terms).lstrip("+ ")


def statics(K, transforms, mount_matrices, axes, loads) -> dict[str, np.ndarray]:
    """Static displacement and mount loads, K q = load.

    Parameters
    ----------
    K : array_like (6, 6)
        Real system stiffness (nominal mount stiffnesses).
    transforms : array_like (n, 3, 6)
        T of the mount positions.
    mount_matrices : array_like (n, 3, 3)
        K_i of the mounts, engine frame.
    axes : array_like (n, 3, 3)
        R_i of the mounts.
    loads : array_like (case, 6)
        Force and moment about the CG on the powertrain.

    Returns
    -------
    dict
        ``q`` (case, 6); ``force`` (case, n, 3) into the frame, engine axes;
        ``deflection`` (case, n, 3) δ = R T q in local axes; ``local_force``
        (case, n, 3) the force into the frame in local axes (R f).
    """
    require_constrained(K)
    q = np.linalg.solve(np.asarray(K, dtype=float), np.asarray(loads, dtype=float)[..., None])[..., 0]
    motion = np.einsum("naj,...j->...na", np.asarray(transforms, dtype=float), q)
    force = np.einsum("nab,...nb->...na", np.asarray(mount_matrices), motion)
    r = np.asarray(axes, dtype=float)
    return {"q": q, "force": force, "deflection": np.einsum("nab,...nb->...na", r, motion),
            "local_force": np.einsum("nab,...nb->...na", r, force)}


def modes(M, K) -> tuple[np.ndarray, np.ndarray]:
    """Undamped natural frequencies and mode shapes, K φ = ω² M φ.

    Returns
    -------
    frequency_hz : ndarray (6,)
        Ascending [Hz].
    shapes : ndarray (6, 6)
        Columns the modes, mass-normalised (φᵀ M φ = 1), each signed so that its
        largest component (in absolute value) is positive.
    """
    require_constrained(K)
    values, shapes = scipy.linalg.eigh(np.asarray(K, dtype=float), np.asarray(M, dtype=float))
    largest = shapes[np.argmax(np.abs(shapes), axis=0), range(shapes.shape[1])]
    return np.sqrt(np.clip(values, 0, None)) / (2 * math.pi), shapes * np.where(largest < 0, -1.0, 1.0)


def energy_distribution(M, shapes) -> np.ndarray:
    """Kinetic-energy shares E[k, j] = φ_kj (M φ_j)_k / (φ_jᵀ M φ_j): (6 dof, 6 modes), columns sum to 1."""
    phi = np.asarray(shapes, dtype=float)
    weighted = phi * (np.asarray(M, dtype=float) @ phi)
    return weighted / weighted.sum(axis=-2, keepdims=True)


def damped_modes(M, K, C=None, eta_matrix=None) -> tuple[np.ndarray, np.ndarray]:
    """Damped natural frequencies and damping ratios of the six modes.

    The viscous part is exact: the eigenvalues s of the 12×12 state space
    [[0, I], [−M⁻¹K, −M⁻¹C]]. The hysteretic part (stiffness K + i·H, with
    ``eta_matrix`` H = Σ T_iᵀ R_iᵀ diag(k_i η_i) R_i T_i) has no time-domain
    form: it enters as the viscous damping that dissipates as much at the
    mode's undamped frequency ω_j, H/ω_j, so the state space of mode j has
    C + H/ω_j (a single mode of loss factor η gets ζ = η/2). Each undamped
    mode j is matched to its eigenvalue pair of its state space by the
    largest modal assurance criterion (one assignment over all modes, so that
    modes of equal frequency get distinct eigenvalues).

    Returns
    -------
    frequency_hz : ndarray (6,)
        Damped natural frequency |Im s|/2π [Hz] (0 for an overdamped mode).
    damping_ratio : ndarray (6,)
        ζ = −(s₁ + s₂) / (2 √(s₁ s₂)) of the mode's pair (−Re s/|s| when
        underdamped).
    """
    m, k = np.asarray(M, dtype=float), np.asarray(K, dtype=float)
    frequency, shapes = modes(m, k)
    omega = 2 * math.pi * frequency
    c = np.zeros((6, 6)) if C is None else np.asarray(C, dtype=float)
    h = np.zeros((6, 6)) if eta_matrix is None else np.asarray(eta_matrix, dtype=float)
    state = np.zeros((6, 12, 12))
    state[:, :6, 6:] = np.eye(6)
    state[:, 6:, :6] = -np.linalg.solve(m, k)
    state[:, 6:, 6:] = -np.linalg.solve(m, c + h / omega[:, None, None])
    values, vectors = np.linalg.eig(state)
    pairs = np.array([_mode_pair(m, shapes, values[j], vectors[j, :6], j) for j in range(6)])
    natural = np.sqrt((pairs[:, 0] * pairs[:, 1]).real)
    return np.abs(pairs[:, 0].imag) / (2 * math.pi), -(pairs[:, 0] + pairs[:, 1]).real / (2 * natural)


def _mode_pair(m: np.ndarray, shapes: np.ndarray, values: np.ndarray, motions: np.ndarray, mode: int) -> np.ndarray:
    """The two eigenvalues of one state space that belong to undamped mode ``mode``."""
    projected = np.abs(shapes.T @ m @ motions) ** 2  # (mode, eigenvalue); φᵀMφ = 1
    mac = projected / np.einsum("ir,ij,jr->r", motions.conj(), m, motions).real
    oscillating = np.abs(values.imag) > 1e-9 * np.abs(values)
    candidates = np.flatnonzero(~oscillating | (values.imag > 0))
    rows, picked = linear_sum_assignment(-mac[:, candidates])
    first = candidates[picked[list(rows).index(mode)]]
    if oscillating[first]:
        return np.array([values[first], values[first].conjugate()])
    others = [r for r in np.flatnonzero(~oscillating) if r != first and r not in candidates[picked]]
    second = max(others, key=lambda r: mac[mode, r]) if others else first
    return np.array([values[first], values[second]])


def torque_roll_axis(inertia, axis=(1.0, 0.0, 0.0)) -> np.ndarray:
    """The torque roll axis: the unit vector along I⁻¹ a (a the crank axis), signed along a (3,)."""
    a = np.asarray(axis, dtype=float)
    v = np.linalg.solve(np.asarray(inertia, dtype=float), a)
    v = v / np.linalg.norm(v)
    return -v if v @ a < 0 else v


def tra_angle(tra, shapes, energy) -> float:
    """Acute angle [rad] between the torque roll axis and the rotation φ[3:6] of the roll-dominant mode.

    The roll-dominant mode is the one whose roll energy share E[3, j] is largest.
    """
    roll_mode = int(np.argmax(np.asarray(energy)[3]))
    rotation = np.asarray(shapes, dtype=float)[3:6, roll_mode]
    t = np.asarray(tra, dtype=float)
    return float(np.arctan2(np.linalg.norm(np.cross(t, rotation)), abs(t @ rotation)))


def elastic_centre(K) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Elastic centre and elastic axes of the mount system.

    The stiffness referred to a point e (relative to the CG) is SᵀKS with
    S = [[I, [e]ₓ], [0, I]] (q = S q_e, q_e the displacement of e and the
    rotation); its coupling block A[e]ₓ + B (A, B the translational and
    coupling blocks of K) is made symmetric in the least-squares sense (a
    9×3 linear system in e; exactly solvable when A is positive definite).

    Returns
    -------
    centre : ndarray (3,)
        e relative to the CG [m].
    axes : ndarray (3, 3)
        Rows the eigenvectors of the rotational block referred to e, ascending
        stiffness, each signed so that its largest component is positive.
    torsional_stiffness : ndarray (3,)
        Their eigenvalues [N m/rad].
    """
    require_constrained(K)
    k = np.asarray(K, dtype=float)
    a, b = k[:3, :3], k[:3, 3:]
    basis = cross_matrix(np.eye(3))  # [e_k]ₓ
    columns = a @ basis + basis @ a  # antisymmetric part contributed by each component of e
    system = columns.reshape(3, 9).T
    centre = np.linalg.lstsq(system, -(b - b.T).reshape(9), rcond=None)[0]
    shift = np.eye(6)
    shift[:3, 3:] = cross_matrix(centre)
    rotational = (shift.T @ k @ shift)[3:, 3:]
    stiffness, vectors = np.linalg.eigh((rotational + rotational.T) / 2)
    largest = vectors[np.argmax(np.abs(vectors), axis=0), range(3)]
    return centre, (vectors * np.where(largest < 0, -1.0, 1.0)).T, stiffness


def forced_response(M, K_of_omega, Omega, loads, gyroscopic=None) -> np.ndarray:
    """Complex response Q of (−Ω² M + iΩ G + K(Ω)) Q = L for every leading index.

    Parameters
    ----------
    M : array_like (6, 6)
    K_of_omega : array_like (..., 6, 6)
        Complex (or real) stiffness at each Ω.
    Omega : array_like (...)
        Circular frequencies [rad/s].
    loads : array_like (..., 6)
        Load phasors [F; M about the CG].
    gyroscopic : array_like (..., 6, 6), optional
        G: the spinning parts' gyroscopic matrix at each crank speed
        (:func:`gyroscopic_matrix`).

    Returns
    -------
    ndarray (..., 6) complex

    Raises
    ------
    ValueError
        If a dynamic stiffness is singular (an undamped system exactly at a resonance).
    """
    k, om, load = np.asarray(K_of_omega), np.asarray(Omega, dtype=float), np.asarray(loads)
    dynamic = k - (om**2)[..., None, None] * np.asarray(M, dtype=float)
    if gyroscopic is not None:
        dynamic = dynamic + 1j * om[..., None, None] * np.asarray(gyroscopic, dtype=float)
    lead = np.broadcast_shapes(dynamic.shape[:-2], load.shape[:-1])
    dynamic = np.broadcast_to(dynamic, lead + (6, 6))
    try:
        return np.linalg.solve(dynamic, np.broadcast_to(load, lead + (6,))[..., None])[..., 0]
    except np.linalg.LinAlgError as error:
        raise ValueError("the dynamic stiffness K(Ω) − Ω²M is singular (an undamped system exactly at a "
                         "resonance): give the mounts some damping") from error


def gyroscopic_matrix(spin) -> np.ndarray:
    """G (..., 6, 6) of parts spinning about the crank axis with angular momentum
    ``spin`` = sense·J·ω [N m s] (...) along +x: a rotation rate θ̇ of the
    powertrain turns that momentum, which takes the moment θ̇ × H, so the
    equations of pitch and yaw gain G θ̇ with G[pitch, yaw] = h, G[yaw, pitch] = −h."""
    h = np.asarray(spin, dtype=float)
    g = np.zeros(h.shape + (6, 6))
    g[..., 4, 5], g[..., 5, 4] = h, -h
    return g


def order_response(M, K, C, spin_per_speed, orders, omega, unit, constant=None) -> np.ndarray:
    """Response Q (speed, order, 6) of mounts whose complex stiffness ``K``
    and viscous damping ``C`` do not depend on frequency, at crank speeds
    ``omega`` (S,) and ``orders`` (O,), to loads ω²·``unit`` + ``constant``
    (inertia and gas): the systems of :func:`forced_response` with the
    gyroscopic matrix of ``spin_per_speed`` × ω, several times faster.

    At order k, Ω = kω and the spinning parts' momentum is ω·``spin_per_speed``,
    so with s = iΩ the dynamic stiffness K + sC + s²(M − (i/k)G₁) has constant
    matrices (G₁ = :func:`gyroscopic_matrix` of ``spin_per_speed``): its 12×12
    linearisation A − sB, diagonalised once per order (in coordinates scaled
    by diag(M)^-½), gives Q = W η with modal coordinates
    η = (ω² U·unit + U·constant)/(λ − s), two vectors per order and a division
    per speed. The eigenbasis's round-off (~1e-12 relative) is removed by one
    step of iterative refinement with the exact residual L − D Q; a system
    whose residual then still exceeds :data:`RESIDUAL_RTOL` of |D||Q| (a nearly
    defective eigenbasis) is solved directly.

    Parameters
    ----------
    M, K, C : array_like (6, 6)
        Mass, complex stiffness K + iK_η and viscous damping.
    spin_per_speed : float
        sense·J [N m s per rad/s]: the spinning parts' momentum along +x per unit crank speed.
    orders : array_like (O,)
        Orders > 0.
    omega : array_like (S,)
        Crank speeds [rad/s].
    unit, constant : array_like (O, 6)
        The loads' phasors at unit speed (scaled by ω²) and their
        speed-independent part (None: none).

    Returns
    -------
    ndarray (S, O, 6) complex
    """
    m = np.asarray(M, dtype=float)
    scale = 1 / np.sqrt(np.diag(m))
    outer = scale[:, None] * scale[None, :]
    g1 = gyroscopic_matrix(spin_per_speed) * outer
    k, c, m = np.asarray(K) * outer, np.asarray(C) * outer, m * outer
    orders, omega = np.asarray(orders, dtype=float), np.asarray(omega, dtype=float)
    unit = np.asarray(unit) * scale
    constant = np.zeros_like(unit) if constant is None else np.asarray(constant) * scale
    w2 = (omega**2)[:, None]
    q = np.empty((omega.size, orders.size, 6), dtype=complex)
    bad = np.zeros(q.shape[:2], dtype=bool)
    for j, order in enumerate(orders):
        s = 1j * order * omega
        basis = _ModalBasis(k, c, m - (1j / order) * g1)
        load = w2 * unit[j] + constant[j]
        modal = (w2 * (basis.right @ unit[j]) + basis.right @ constant[j]) / basis.denominator(s)
        modal += (load - basis.apply(modal, s)) @ basis.right.T / basis.denominator(s)  # one refinement step
        residual = np.abs(load - basis.apply(modal, s)).max(axis=-1)
        size = np.abs(k).max() + np.abs(s) * np.abs(c).max() + np.abs(s) ** 2 * np.abs(basis.mass).max()
        q[:, j] = modal @ basis.top.T
        bad[:, j] = residual > RESIDUAL_RTOL * size * np.abs(q[:, j]).max(axis=-1)
    q *= scale
    if bad.any():
        speed, order = np.nonzero(bad)
        frequency = omega[speed] * orders[order]
        stiffness = np.asarray(K) + 1j * frequency[:, None, None] * np.asarray(C)
        load = ((omega[speed] ** 2)[:, None] * unit[order] + constant[order]) / scale
        q[speed, order] = forced_response(M, stiffness, frequency, load,
                                          gyroscopic_matrix(spin_per_speed * omega[speed]))
    return q


#: :func:`order_response` solves a system directly whose refined residual exceeds this share of |D||Q|.
RESIDUAL_RTOL = 1e-14


class _ModalBasis:
    """The eigenvectors of the companion pencil A − sB of (k + s c + s² mass) Q = L,
    A = [[0, I], [−k, −c]], B = [[I, 0], [0, mass]]: (A − sB) [Q; sQ] = [0; −L], so
    [Q; sQ] = V (Λ − s)⁻¹ V⁻¹ B⁻¹ [0; −L]. ``right`` (12, 6) takes L to the modal
    coordinates (before the division by λ − s), ``top`` (6, 12) takes them to Q,
    and ``stiffness`` (18, 12) stacks k·top, c·top and mass·top for the residual."""

    def __init__(self, k: np.ndarray, c: np.ndarray, mass: np.ndarray):
        eye, zero = np.eye(6), np.zeros((6, 6))
        a = np.block([[zero, eye], [-k, -c]]).astype(complex)
        b = np.block([[eye, zero], [zero, mass]])
        self.values, vectors = scipy.linalg.eig(a, b)
        self.right = np.linalg.solve(vectors, np.linalg.solve(b, np.vstack([zero, -eye])))
        self.top, self.mass = vectors[:6], mass
        self.stiffness = np.vstack([k @ self.top, c @ self.top, mass @ self.top])

    def denominator(self, s: np.ndarray) -> np.ndarray:
        """λ − s (S, 12)."""
        return self.values[None, :] - s[:, None]

    def apply(self, modal: np.ndarray, s: np.ndarray) -> np.ndarray:
        """D(s) Q of Q = top · modal (S, 12) -> (S, 6): one product for the three matrices."""
        parts = modal @ self.stiffness.T
        return parts[:, :6] + s[:, None] * parts[:, 6:12] + (s**2)[:, None] * parts[:, 12:]


def mount_forces(mount_matrices, transforms, Q) -> np.ndarray:
    """Forces into the frame f_i = K_i T_i Q of mount matrices (..., n, 3, 3) and responses (..., 6) -> (..., n, 3)."""
    t = np.asarray(transforms, dtype=float)
    q, lead_q = _batch_last(np.asarray(Q), 1)
    k, lead_k = _batch_last(np.asarray(mount_matrices), 3)
    lead = np.broadcast_shapes(lead_q, lead_k)
    motion = _with_lead(_matmul_real(t.reshape(-1, 6), q).reshape(t.shape[0], 3, -1), lead_q, lead)
    k = _with_lead(k, lead_k, lead)
    force = k[:, :, 0] * motion[:, None, 0]
    force = force + k[:, :, 1] * motion[:, None, 1]
    force += k[:, :, 2] * motion[:, None, 2]
    return _batch_first(np.broadcast_to(force, force.shape[:2] + lead), 2)


def mount_forces_local(axes, local, transforms, Q) -> np.ndarray:
    """f_i = R_iᵀ (k*_i ⊙ R_i T_i Q) from local stiffnesses (..., n, 3): :func:`mount_forces` without
    forming the 3×3 matrices (the fast path for many frequencies) -> (..., n, 3)."""
    r, t = np.asarray(axes, dtype=float), np.asarray(transforms, dtype=float)
    n = r.shape[0]
    q, lead_q = _batch_last(np.asarray(Q), 1)
    stiffness, lead_k = _batch_last(np.asarray(local), 2)
    lead = np.broadcast_shapes(lead_q, lead_k)
    deflection = _matmul_real(np.einsum("nac,ncj->naj", r, t).reshape(3 * n, 6), q).reshape(n, 3, -1)
    local_force = np.broadcast_to(_with_lead(stiffness, lead_k, lead) * _with_lead(deflection, lead_q, lead),
                                  (n, 3) + lead)
    flat = np.ascontiguousarray(local_force).reshape(n, 3, -1)
    return _batch_first(_matmul_real(r.transpose(0, 2, 1), flat).reshape((n, 3) + lead), 2)


def constant_mount_forces(axes, transforms, stiffness, damping, Omega, Q) -> np.ndarray:
    """f_i = R_iᵀ diag(k*_i + iΩc_i) R_i T_i Q (..., n, 3) of mounts whose complex stiffness
    ``stiffness`` (n, 3) and viscous damping ``damping`` (n, 3) do not depend on frequency, at
    circular frequencies ``Omega`` (...): two matrix products for every frequency at once."""
    r, t = np.asarray(axes, dtype=float), np.asarray(transforms, dtype=float)
    to_local = np.einsum("nac,ncj->naj", r, t)  # R_i T_i (n, 3, 6)
    elastic = np.einsum("nac,na,naj->ncj", r, np.asarray(stiffness), to_local).reshape(-1, 6)
    q = np.asarray(Q)
    force = q @ elastic.T
    if np.any(damping):
        viscous = np.einsum("nac,na,naj->ncj", r, np.asarray(damping, dtype=float), to_local).reshape(-1, 6)
        force += (1j * np.asarray(Omega, dtype=float))[..., None] * (q @ viscous.T)
    return force.reshape(q.shape[:-1] + (r.shape[0], 3))


def loads_about(point, reference, force, moment) -> np.ndarray:
    """The moment about ``point`` of a force and moment given about ``reference``: M + (r − p) × F (..., 3)."""
    arm = np.asarray(reference, dtype=float) - np.asarray(point, dtype=float)
    return np.asarray(moment) + np.cross(np.broadcast_to(arm, np.shape(force)), force)


def _with_lead(array: np.ndarray, own: tuple[int, ...], lead: tuple[int, ...]) -> np.ndarray:
    """(core..., B) of leading shape ``own`` as (core..., 1..., own...) that broadcasts against ``lead``."""
    core = array.shape[:-1]
    return array.reshape(core + (1,) * (len(lead) - len(own)) + own)


def _batch_last_empty(lead: tuple[int, ...], core: tuple[int, ...], dtype) -> np.ndarray:
    """An empty array of shape lead + core whose memory has the core axes first."""
    return _batch_first(np.empty(tuple(core) + tuple(lead), dtype=dtype), len(core))


def _batch_first(array: np.ndarray, core: int) -> np.ndarray:
    """View (core..., lead...) as (lead..., core...)."""
    return np.moveaxis(array, tuple(range(core)), tuple(range(-core, 0)))


def _batch_last(array: np.ndarray, core: int) -> tuple[np.ndarray, tuple[int, ...]]:
    """(lead..., core...) as a C-contiguous (core..., B) array (a view when the memory is already so) and lead."""
    lead = array.shape[: array.ndim - core]
    moved = np.moveaxis(array, tuple(range(-core, 0)), tuple(range(core)))
    return np.ascontiguousarray(moved.reshape(moved.shape[:core] + (-1,))), lead


def _matmul_real(weights: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """weights (..., p, q) real @ columns (..., q, B) real or complex, in real arithmetic.

    A complex C-contiguous (q, B) array is the real (q, 2B) array of its
    interleaved parts, so one real matrix product handles both.
    """
    if not np.iscomplexobj(columns):
        return weights @ columns
    product = weights @ np.ascontiguousarray(columns, dtype=np.complex128).view(np.float64)
    return np.ascontiguousarray(product).view(np.complex128)
