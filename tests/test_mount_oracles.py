"""Oracles for the rigid powertrain on its mounts (issue 30), sharing no code with the model.

Every expected value is computed here from closed forms or plain numpy written out in the test:

* the 6×6 stiffness of four identical orthogonal mounts at (±a, ±b, h) about a powertrain with
  two planes of symmetry, entry by entry; its vertical and yaw modes alone and the x–pitch and
  y–roll pairs from their own 2×2 quadratics (Harris, Shock and Vibration Handbook, ch. 3);
* a random asymmetric system (inertia with products, mounts at random positions and angles)
  assembled here as Σ Tᵢᵀ Rᵢᵀ diag(k) Rᵢ Tᵢ, for orthogonality, statics and the response limits;
* the torque roll axis from the cofactors of the inertia tensor, moved by the parallel axis
  theorem and rotated as R I Rᵀ by hand.

Conventions (docs: the mount model's specification): q = [u_x, u_y, u_z, θ_x, θ_y, θ_z] of the
CG; a point p moves by T(p) q = u + θ × (p − c); mount i's force into the frame is Kᵢ Tᵢ q; the
inertia is the tensor (I_xy = −∫xy dm). Matrices over the six DOF mix units (N/m, N, N m/rad), so
their round-off is compared with the scale √(Kᵢᵢ Kⱼⱼ) of each entry, and displacements with the
length ``ELL`` converting rotations to metres.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_close_to_scale

from harmbal.model import mounts

G = 9.80665
#: Powertrain with two planes of symmetry (x–z and y–z through the CG): no products of inertia.
MASS = 180.0
PRINCIPAL = (8.0, 14.0, 12.0)  # I_xx, I_yy, I_zz [kg m^2]
CG = np.array([0.05, -0.02, 0.30])  # anywhere: the model works relative to it
A, B, H = 0.30, 0.22, -0.12  # mounts at CG + (±A, ±B, H) [m]
KX, KY, KZ = 1.1e5, 1.6e5, 3.0e5  # [N/m] along the engine axes
#: Length turning rotations into displacements when comparing q's components with one scale.
ELL = 0.3


# --------------------------------------------------------------------------
# Independent helpers


def skew(a):
    """[a]ₓ, with [a]ₓ b = a × b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def hand_transform(point, cg):
    """T(p) = [I₃, −[p − c]ₓ]: the motion of ``point`` for the CG's six DOF."""
    return np.hstack([np.eye(3), -skew(np.asarray(point) - cg)])


def hand_stiffness(positions, axes, local, cg):
    """Σ Tᵢᵀ Rᵢᵀ diag(kᵢ) Rᵢ Tᵢ (complex ``local`` allowed)."""
    total = np.zeros((6, 6), dtype=np.result_type(local, float))
    for p, r, k in zip(positions, axes, local):
        t = hand_transform(p, cg)
        total += t.T @ (r.T @ np.diag(k) @ r) @ t
    return total


def hand_mass(mass, inertia):
    out = np.zeros((6, 6))
    out[:3, :3] = mass * np.eye(3)
    out[3:, 3:] = inertia
    return out


def entry_scale(matrix):
    """√(|Mᵢᵢ| |Mⱼⱼ|): the unit-consistent scale of each entry of a 6×6 matrix over the DOF."""
    d = np.sqrt(np.abs(np.diag(matrix)))
    return np.outer(d, d)


def dof_scale(q):
    """One scale per DOF for displacement vectors (..., 6): translations in m, rotations in rad."""
    q = np.asarray(q)
    size = np.maximum(np.abs(q[..., :3]).max(-1), ELL * np.abs(q[..., 3:]).max(-1))
    return np.concatenate([np.repeat(size[..., None], 3, -1), np.repeat(size[..., None] / ELL, 3, -1)], -1)


def rotation(rng):
    """A random proper rotation (rows orthonormal, det +1)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def symmetric_layout(h=H):
    positions = CG + np.array([[sx * A, sy * B, h] for sx in (1, -1) for sy in (1, -1)])
    axes = np.repeat(np.eye(3)[None], 4, 0)
    local = np.repeat(np.array([[KX, KY, KZ]]), 4, 0)
    return positions, axes, local


def closed_form_stiffness(h=H):
    """The 6×6 stiffness of the symmetric layout, entry by entry (mounts at (±a, ±b, h) from the CG)."""
    k = np.zeros((6, 6))
    k[0, 0], k[1, 1], k[2, 2] = 4 * KX, 4 * KY, 4 * KZ
    k[3, 3] = 4 * (KY * h**2 + KZ * B**2)  # roll: θ e_x × r = (0, −h, b) θ
    k[4, 4] = 4 * (KX * h**2 + KZ * A**2)  # pitch: (h, 0, −a) θ
    k[5, 5] = 4 * (KX * B**2 + KY * A**2)  # yaw: (−b, a, 0) θ
    k[0, 4] = k[4, 0] = 4 * KX * h
    k[1, 3] = k[3, 1] = -4 * KY * h
    return k


def pair_roots(k11, k12, k22, m, inertia):
    """ω² of the 2×2 pair [[k11, k12], [k12, k22]] on diag(m, I): m I ω⁴ − (k11 I + k22 m) ω² + det = 0."""
    b = k11 * inertia + k22 * m
    disc = np.sqrt(b * b - 4 * m * inertia * (k11 * k22 - k12 * k12))
    return (b - disc) / (2 * m * inertia), (b + disc) / (2 * m * inertia)


def closed_form_squares(h=H):
    """{dof pair or dof: ω²} of the symmetric layout."""
    ixx, iyy, izz = PRINCIPAL
    k = closed_form_stiffness(h)
    return {
        "z": k[2, 2] / MASS,
        "yaw": k[5, 5] / izz,
        "x-pitch": pair_roots(k[0, 0], k[0, 4], k[4, 4], MASS, iyy),
        "y-roll": pair_roots(k[1, 1], k[1, 3], k[3, 3], MASS, ixx),
    }


def model_stiffness(positions, axes, local, cg=CG):
    """K through the public functions of the model."""
    transforms = mounts.point_transforms(positions, cg)
    return mounts.system_matrix(transforms, mounts.global_stiffness(axes, local))


def random_system(seed=3):
    """An asymmetric powertrain: inertia with products, five mounts at random places and angles."""
    rng = np.random.default_rng(seed)
    axes_body = rotation(rng)
    principal = np.array([9.0, 15.0, 13.0]) * rng.uniform(0.9, 1.1, 3)
    inertia = axes_body.T @ np.diag(principal) @ axes_body
    cg = rng.normal(scale=0.1, size=3)
    positions = cg + rng.uniform(-0.35, 0.35, size=(5, 3))
    axes = np.array([rotation(rng) for _ in range(5)])
    local = rng.uniform(0.8e5, 4e5, size=(5, 3))
    damping = rng.uniform(100.0, 600.0, size=(5, 3))
    return dict(mass=210.0, inertia=inertia, cg=cg, positions=positions, axes=axes, local=local,
                damping=damping)


def omega_squares(mass_matrix, stiffness):
    return np.sort(np.linalg.eigvals(np.linalg.solve(mass_matrix, stiffness)).real)


# --------------------------------------------------------------------------
# Assembly


def test_transforms_mount_matrices_and_system_matrix_match_the_hand_assembly():
    positions, axes, local = symmetric_layout()
    transforms = mounts.point_transforms(positions, CG)
    assert_close_to_scale(transforms, np.array([hand_transform(p, CG) for p in positions]), 1.0,
                          err_msg="T(p) = [I, -[p - c]x]")  # scale: unit and lever arms below 1 m
    # A mount turned 90 deg about z (u along y, v along -x) with (k_y, k_x, k_z) is the same mount.
    turned = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    global_ = mounts.global_stiffness(np.array([np.eye(3), turned]), np.array([[KX, KY, KZ], [KY, KX, KZ]]))
    assert_close_to_scale(global_, np.repeat(np.diag([KX, KY, KZ])[None], 2, 0), KZ)
    expected = closed_form_stiffness()
    assert_close_to_scale(model_stiffness(positions, axes, local), expected, entry_scale(expected))
    assert_close_to_scale(mounts.mass_matrix(MASS, np.diag(PRINCIPAL)), hand_mass(MASS, np.diag(PRINCIPAL)),
                          entry_scale(hand_mass(MASS, np.diag(PRINCIPAL))))


def test_random_system_matrix_matches_the_hand_assembly():
    s = random_system()
    expected = hand_stiffness(s["positions"], s["axes"], s["local"], s["cg"])
    actual = model_stiffness(s["positions"], s["axes"], s["local"], s["cg"])
    assert_close_to_scale(actual, expected, entry_scale(expected))


# --------------------------------------------------------------------------
# Modes of the symmetric powertrain (closed forms)


def symmetric_modes(h=H):
    m = hand_mass(MASS, np.diag(PRINCIPAL))
    k = model_stiffness(*symmetric_layout(h))
    frequency, shapes = mounts.modes(m, k)
    return m, k, np.asarray(frequency), np.asarray(shapes)


@pytest.mark.parametrize("h", [H, 0.0, 0.17])
def test_symmetric_frequencies_are_the_closed_forms(h):
    _, _, frequency, _ = symmetric_modes(h)
    squares = closed_form_squares(h)
    expected = np.sort([squares["z"], squares["yaw"], *squares["x-pitch"], *squares["y-roll"]])
    assert np.all(np.diff(frequency) >= 0), "modes ascending"
    assert_close_to_scale((2 * np.pi * frequency) ** 2, expected, expected.max(),
                          err_msg=f"omega^2 at h = {h}")
    # The vertical mode alone: f = (1/2 pi) sqrt(sum k_z / m), to the round-off of that frequency.
    f_vertical = np.sqrt(4 * KZ / MASS) / (2 * np.pi)
    assert np.min(np.abs(frequency - f_vertical)) <= 1e-12 * f_vertical * 10


def find_mode(shapes, dofs):
    """The mode (column) whose motion is in ``dofs`` only."""
    others = [i for i in range(6) if i not in dofs]
    weight = np.abs(shapes[others]).sum(0) / np.abs(shapes).sum(0)
    return int(np.argmin(weight)), weight


def test_symmetric_mode_shapes_are_the_closed_forms():
    m, _, frequency, shapes = symmetric_modes()
    izz = PRINCIPAL[2]
    # Mass-normalised, largest component positive: the single-DOF modes are e_k / sqrt(m_k).
    for dof, modal_mass in ((2, MASS), (5, izz)):
        j, _ = find_mode(shapes, [dof])
        expected = np.zeros(6)
        expected[dof] = 1 / np.sqrt(modal_mass)
        assert_close_to_scale(shapes[:, j], expected, 1 / np.sqrt(modal_mass))
    k = closed_form_stiffness()
    for (t, r), roots in zip(((0, 4), (1, 3)), (closed_form_squares()["x-pitch"], closed_form_squares()["y-roll"])):
        for w2 in roots:
            j = int(np.argmin(np.abs((2 * np.pi * frequency) ** 2 - w2)))
            # (k11 - w2 m) phi_t + k12 phi_r = 0: phi proportional to (k12, w2 m - k11).
            phi = np.zeros(6)
            phi[t], phi[r] = k[t, r], w2 * MASS - k[t, t]
            phi /= np.sqrt(phi @ m @ phi)
            phi *= np.sign(phi @ m @ shapes[:, j])  # the sign is checked on its own below
            assert_close_to_scale(shapes[:, j], phi, dof_scale(phi), rtol=1e-10,
                                  err_msg=f"pair ({t}, {r}) mode at omega^2 = {w2}")
    largest = shapes[np.argmax(np.abs(shapes), axis=0), np.arange(6)]
    assert np.all(largest > 0), "sign: largest |component| positive"


def hand_energy(m, shapes):
    return shapes * (m @ shapes) / np.einsum("kj,kl,lj->j", shapes, m, shapes)


def test_energy_of_the_decoupled_system_is_the_identity():
    m, _, _, shapes = symmetric_modes(0.0)  # mounts in the CG plane: six single-DOF modes
    energy = np.asarray(mounts.energy_distribution(m, shapes))
    order = np.argmax(energy, axis=0)
    assert sorted(order) == list(range(6)), f"one mode per DOF: {order}"
    assert_close_to_scale(energy, np.eye(6)[:, order], 1.0)  # scale: a share of 1


def test_energy_of_the_coupled_pairs_is_the_closed_form_split():
    m, _, frequency, shapes = symmetric_modes()
    energy = np.asarray(mounts.energy_distribution(m, shapes))
    assert_close_to_scale(energy.sum(0), np.ones(6), 1.0)  # scale: a share of 1
    assert_close_to_scale(energy, hand_energy(m, shapes), 1.0)  # scale: a share of 1
    k = closed_form_stiffness()
    for t, r, inertia, roots in ((0, 4, PRINCIPAL[1], closed_form_squares()["x-pitch"]),
                                 (1, 3, PRINCIPAL[0], closed_form_squares()["y-roll"])):
        for w2 in roots:
            j = int(np.argmin(np.abs((2 * np.pi * frequency) ** 2 - w2)))
            phi_t, phi_r = k[t, r], w2 * MASS - k[t, t]
            share = MASS * phi_t**2 / (MASS * phi_t**2 + inertia * phi_r**2)
            assert_close_to_scale(energy[[t, r], j], [share, 1 - share], 1.0, rtol=1e-10)  # scale: a share of 1


# --------------------------------------------------------------------------
# Orthogonality of an asymmetric system


def test_modes_of_a_random_system_are_mass_and_stiffness_orthogonal():
    s = random_system()
    m = hand_mass(s["mass"], s["inertia"])
    k = hand_stiffness(s["positions"], s["axes"], s["local"], s["cg"])
    frequency, shapes = (np.asarray(a) for a in mounts.modes(m, k))
    w2 = (2 * np.pi * frequency) ** 2
    assert_close_to_scale(w2, omega_squares(m, k), w2.max())
    # Mass-normalised modes: Phi^T M Phi = 1 and Phi^T K Phi = diag(omega^2).
    assert_close_to_scale(shapes.T @ m @ shapes, np.eye(6), 1.0)  # scale: mass-normalised, the unit
    assert_close_to_scale(shapes.T @ k @ shapes, np.diag(w2), w2.max())
    residual = k @ shapes - m @ shapes * w2
    assert_close_to_scale(residual, np.zeros_like(residual), np.abs(k).max() * np.abs(shapes).max())
    energy = np.asarray(mounts.energy_distribution(m, shapes))
    assert_close_to_scale(energy, hand_energy(m, shapes), 1.0)  # scale: a share of 1
    assert_close_to_scale(energy.sum(0), np.ones(6), 1.0)  # scale: a share of 1
    # A share does not depend on how the shapes are scaled.
    rescaled = np.asarray(mounts.energy_distribution(m, shapes * [3.0, -0.5, 2.0, 1.0, 7.0, -1.5]))
    assert_close_to_scale(rescaled, energy, 1.0)  # scale: a share of 1


# --------------------------------------------------------------------------
# Statics


def test_statics_under_weight_balance_forces_and_moments():
    s = random_system()
    transforms = mounts.point_transforms(s["positions"], s["cg"])
    matrices = mounts.global_stiffness(s["axes"], s["local"])
    k = hand_stiffness(s["positions"], s["axes"], s["local"], s["cg"])
    weight = np.array([0.0, 0.0, -s["mass"] * G, 0.0, 0.0, 0.0])
    general = np.array([310.0, -120.0, -s["mass"] * G, 45.0, -80.0, 25.0])  # with a couple about the CG
    loads = np.array([weight, general])
    result = mounts.statics(mounts.system_matrix(transforms, matrices), transforms, matrices, s["axes"], loads)
    q, force, deflection = (np.asarray(result[name]) for name in ("q", "force", "deflection"))
    scale = s["mass"] * G
    arms = s["positions"] - s["cg"]
    for case, load in enumerate(loads):
        # Into the frame: the mounts carry the load, sum f = F, sum (p - c) x f = M_c.
        assert_close_to_scale(force[case].sum(0), load[:3], scale, err_msg=f"case {case} forces")
        assert_close_to_scale(np.cross(arms, force[case]).sum(0), load[3:], scale * ELL,
                              err_msg=f"case {case} moments about the CG")
        hand_q = np.linalg.solve(k, load)
        condition = np.linalg.cond(k)
        assert_close_to_scale(q[case], hand_q, dof_scale(hand_q), rtol=1e-15 * condition * 10)
        hand_deflection = np.array([r @ hand_transform(p, s["cg"]) @ hand_q for p, r in zip(s["positions"], s["axes"])])
        assert_close_to_scale(deflection[case], hand_deflection, np.abs(hand_deflection).max(),
                              rtol=1e-15 * condition * 10)
        hand_force = np.array([r.T @ np.diag(kl) @ d for r, kl, d in zip(s["axes"], s["local"], hand_deflection)])
        assert_close_to_scale(force[case], hand_force, scale, rtol=1e-15 * condition * 10)


def test_symmetric_statics_sink_straight_down():
    # Mounts symmetric about the CG's vertical: weight only compresses them, by m g / (4 k_z).
    positions, axes, local = symmetric_layout()
    transforms = mounts.point_transforms(positions, CG)
    matrices = mounts.global_stiffness(axes, local)
    weight = np.array([[0.0, 0.0, -MASS * G, 0.0, 0.0, 0.0]])
    result = mounts.statics(mounts.system_matrix(transforms, matrices), transforms, matrices, axes, weight)
    sink = -MASS * G / (4 * KZ)
    assert_close_to_scale(np.asarray(result["q"])[0], [0, 0, sink, 0, 0, 0], abs(sink) * np.array([1, 1, 1, 1 / ELL,
                                                                                                  1 / ELL, 1 / ELL]))
    assert_close_to_scale(np.asarray(result["force"])[0], np.tile([0.0, 0.0, -MASS * G / 4], (4, 1)), MASS * G)
    assert_close_to_scale(np.asarray(result["deflection"])[0], np.tile([0.0, 0.0, sink], (4, 1)), abs(sink))


# --------------------------------------------------------------------------
# Inertia from parts and the torque roll axis


def cofactor_tra(inertia):
    """I⁻¹ e_x from the first row of cofactors (I symmetric, det > 0), normalised."""
    (ixx, ixy, ixz), (_, iyy, iyz), (_, _, izz) = inertia
    v = np.array([iyy * izz - iyz**2, iyz * ixz - ixy * izz, ixy * iyz - iyy * ixz])
    return v / np.sqrt(v @ v)


def hand_parts(seed=5):
    rng = np.random.default_rng(seed)
    masses = np.array([120.0, 45.0, 30.0])
    cgs = rng.uniform(-0.3, 0.3, size=(3, 3))
    own = []
    for _ in masses:
        r = rotation(rng)
        own.append(r.T @ np.diag(rng.uniform(0.5, 1.0, 3) + 0.5) @ r)
    return masses, cgs, np.array(own)


def inertia_about(point, masses, cgs, own):
    """Σ [I_i + m_i (|d|² I₃ − d dᵀ)], d = c_i − point: the tensor about any ``point`` (parallel axes)."""
    total = np.zeros((3, 3))
    for m, c, inertia in zip(masses, cgs, own):
        d = c - point
        total += inertia + m * ((d @ d) * np.eye(3) - np.outer(d, d))
    return total


def test_inertia_from_parts_is_the_parallel_axis_sum():
    masses, cgs, own = hand_parts()
    mass, cg, inertia = mounts.inertia_from_parts(masses, cgs, own)
    hand_cg = (masses[:, None] * cgs).sum(0) / masses.sum()
    assert mass == pytest.approx(masses.sum(), rel=1e-15, abs=0)
    assert_close_to_scale(cg, hand_cg, 0.3)
    # About the origin, then back to the CG by the parallel axis theorem the other way.
    about_origin = inertia_about(np.zeros(3), masses, cgs, own)
    back = about_origin - masses.sum() * ((hand_cg @ hand_cg) * np.eye(3) - np.outer(hand_cg, hand_cg))
    assert_close_to_scale(inertia, back, np.abs(about_origin).max())
    assert_close_to_scale(inertia, inertia_about(hand_cg, masses, cgs, own), np.abs(about_origin).max())


def test_torque_roll_axis_of_a_tensor_with_products_is_the_cofactor_direction():
    assert_close_to_scale(mounts.torque_roll_axis(np.diag(PRINCIPAL)), [1.0, 0.0, 0.0], 1.0)  # scale: unit vector
    inertia = np.array([[18.0, -0.9, -2.1], [-0.9, 42.0, 0.4], [-2.1, 0.4, 38.0]])
    tra = np.asarray(mounts.torque_roll_axis(inertia))
    assert_close_to_scale(tra, cofactor_tra(inertia), 1.0)  # scale: unit vector
    assert tra[0] > 0


def test_torque_roll_axis_is_invariant_under_a_shift_of_the_reference_point():
    masses, cgs, own = hand_parts()
    _, cg, inertia = mounts.inertia_from_parts(masses, cgs, own)
    shift = np.array([0.7, -1.3, 0.45])  # the same body described from another origin
    _, cg_shifted, inertia_shifted = mounts.inertia_from_parts(masses, cgs + shift, own)
    assert_close_to_scale(cg_shifted, np.asarray(cg) + shift, 1.0)
    assert_close_to_scale(inertia_shifted, inertia, np.abs(inertia).max())
    tra = np.asarray(mounts.torque_roll_axis(inertia))
    assert_close_to_scale(mounts.torque_roll_axis(inertia_shifted), tra, 1.0)  # scale: unit vector
    assert_close_to_scale(tra, cofactor_tra(np.asarray(inertia)), 1.0)  # scale: unit vector
    # The tensor about another point is not the CG's: its "TRA" differs, so the model must use the CG's.
    about_origin = inertia_about(np.zeros(3), masses, cgs, own)
    assert np.abs(cofactor_tra(about_origin) - tra).max() > 1e-3


def test_torque_roll_axis_turns_with_the_frame():
    masses, cgs, own = hand_parts()
    r = rotation(np.random.default_rng(11))
    _, cg, inertia = mounts.inertia_from_parts(masses, cgs, own)
    _, cg_r, inertia_r = mounts.inertia_from_parts(masses, cgs @ r.T, np.einsum("ij,njk,lk->nil", r, own, r))
    assert_close_to_scale(cg_r, r @ np.asarray(cg), 1.0)
    assert_close_to_scale(inertia_r, r @ np.asarray(inertia) @ r.T, np.abs(inertia).max())
    tra = np.asarray(mounts.torque_roll_axis(inertia))
    turned = np.asarray(mounts.torque_roll_axis(r @ np.asarray(inertia) @ r.T, axis=r @ [1.0, 0.0, 0.0]))
    expected = r @ tra
    # The sign convention is "positive along the crank axis": a⋅I⁻¹a > 0, so it holds in both frames.
    assert turned @ (r @ [1.0, 0.0, 0.0]) > 0, "TRA points along the (turned) crank axis"
    assert_close_to_scale(turned, expected, 1.0)  # scale: unit vector


@pytest.mark.parametrize("flip", [1.0, -1.0])
def test_tra_angle_is_the_acute_angle_to_the_roll_mode(flip):
    beta, alpha = 0.12, 0.42  # TRA and roll-mode rotation tilted in the x-z plane
    m = hand_mass(MASS, np.diag(PRINCIPAL))
    shapes = np.diag(1 / np.sqrt(np.diag(m)))
    shapes[3:, 3] = flip * np.array([np.cos(alpha), 0.0, np.sin(alpha)]) / np.sqrt(PRINCIPAL[0])
    shapes[0, 3] = 0.01  # a little x in the roll mode: its rotation part is what counts
    shapes[3, 5] = 0.2 * shapes[5, 5]  # the yaw mode carries some roll, less than the roll mode
    energy = hand_energy(m, shapes)
    assert np.argmax(energy[3]) == 3
    angle = mounts.tra_angle(np.array([np.cos(beta), 0.0, np.sin(beta)]), shapes, energy)
    assert angle == pytest.approx(alpha - beta, rel=0, abs=1e-12)  # scale: angles in rad


# --------------------------------------------------------------------------
# Forced response


def dynamic_stiffness(transforms, axes, local, omegas, loss=None, damping=None):
    """K(Ω) for each Ω through the public functions (one Ω at a time: no assumption on broadcasting)."""
    return np.array([mounts.system_matrix(transforms, mounts.global_stiffness(
        axes, mounts.local_stiffness(local, loss=loss, damping=damping, omega=w))) for w in omegas])


def random_forced(omegas, loss=None, damping=None, load=None):
    s = random_system()
    m = hand_mass(s["mass"], s["inertia"])
    transforms = mounts.point_transforms(s["positions"], s["cg"])
    k_of_omega = dynamic_stiffness(transforms, s["axes"], s["local"], omegas, loss, damping)
    load = np.array([400.0, -250.0, 900.0, 60.0, -35.0, 20.0]) if load is None else load
    loads = np.broadcast_to(load.astype(complex), (len(omegas), 6)).copy()
    q = np.asarray(mounts.forced_response(m, k_of_omega, np.asarray(omegas, dtype=float), loads))
    return s, m, transforms, k_of_omega, loads, q


def test_local_stiffness_is_k_one_plus_i_eta_plus_i_omega_c():
    k = np.array([[3e5, 2e5, 5e5], [1e5, 1.5e5, 2.5e5]])
    eta = np.array([[0.1, 0.12, 0.08], [0.2, 0.0, 0.05]])
    c = np.array([[200.0, 0.0, 450.0], [30.0, 60.0, 90.0]])
    w = 2 * np.pi * 37.0
    expected = k * (1 + 1j * eta) + 1j * w * c
    assert_close_to_scale(mounts.local_stiffness(k, loss=eta, damping=c, omega=w), expected, k)
    assert_close_to_scale(np.real(mounts.local_stiffness(k)), k, k)


def test_response_at_zero_frequency_is_the_static_solution():
    s = random_system()
    w_min = np.sqrt(omega_squares(hand_mass(s["mass"], s["inertia"]),
                                  hand_stiffness(s["positions"], s["axes"], s["local"], s["cg"]))[0])
    _, m, transforms, k_of_omega, loads, q = random_forced([0.0, 1e-10 * w_min], damping=s["damping"])
    matrices = mounts.global_stiffness(s["axes"], s["local"])
    static = np.asarray(mounts.statics(mounts.system_matrix(transforms, matrices), transforms, matrices, s["axes"],
                                       loads[:1].real)["q"])[0]
    assert_close_to_scale(q[0], static, dof_scale(static), err_msg="omega = 0")
    assert_close_to_scale(q[1], static, dof_scale(static), rtol=1e-9, err_msg="omega -> 0")
    # Quasi-statically the mounts pass the whole load into the frame.
    force = np.asarray(mounts.mount_forces(np.array([mounts.global_stiffness(s["axes"], mounts.local_stiffness(
        s["local"], damping=s["damping"], omega=w)) for w in (0.0, 1e-10 * w_min)]), transforms, q))
    assert_close_to_scale(force.sum(1), loads[:, :3], np.abs(loads[0, :3]).max(), rtol=1e-9)


def test_response_matches_a_hand_solve_and_mount_forces_the_hand_product():
    s = random_system()
    w2 = omega_squares(hand_mass(s["mass"], s["inertia"]),
                       hand_stiffness(s["positions"], s["axes"], s["local"], s["cg"]))
    omegas = np.array([0.5 * np.sqrt(w2[0]), 1.7 * np.sqrt(w2[-1])])
    loss = np.full_like(s["local"], 0.1)
    _, m, transforms, k_of_omega, loads, q = random_forced(omegas, loss=loss, damping=s["damping"])
    for i, w in enumerate(omegas):
        local = s["local"] * (1 + 1j * loss) + 1j * w * s["damping"]
        k = hand_stiffness(s["positions"], s["axes"], local, s["cg"])
        hand_q = np.linalg.solve(k - w**2 * m, loads[i])
        assert_close_to_scale(q[i], hand_q, dof_scale(hand_q), rtol=1e-10)
        matrices = mounts.global_stiffness(s["axes"], mounts.local_stiffness(s["local"], loss=loss,
                                                                             damping=s["damping"], omega=w))
        hand_f = np.array([r.T @ np.diag(kl) @ r @ hand_transform(p, s["cg"]) @ q[i]
                           for p, r, kl in zip(s["positions"], s["axes"], local)])
        force = np.asarray(mounts.mount_forces(matrices, transforms, q[i]))
        assert_close_to_scale(force, hand_f, np.abs(hand_f).max())


def test_far_above_the_modes_the_block_follows_the_mass_line():
    s = random_system()
    m = hand_mass(s["mass"], s["inertia"])
    w_max = np.sqrt(omega_squares(m, hand_stiffness(s["positions"], s["axes"], s["local"], s["cg"]))[-1])
    ratios = np.array([1e3, 1e4])
    loss = np.full_like(s["local"], 0.1)  # hysteretic: K(1 + i eta) stays O(K), so the error is O((w/W)^2)
    _, m, transforms, k_of_omega, loads, q = random_forced(ratios * w_max, loss=loss)
    mass_line = -np.linalg.solve(m, loads[0])
    errors = []
    for i, omega in enumerate(ratios * w_max):
        deviation = omega**2 * q[i] - mass_line
        errors.append(np.max(np.abs(deviation) / dof_scale(mass_line)))
        # The next term of (M - K/W^2)^-1 = M^-1 + M^-1 K M^-1 / W^2 + ...: Omega^2 (Omega^2 Q - mass line).
        # Its truncation is (w_max/W)^2 <= 1e-6, the round-off of the cancelling difference ~1e-16 (W/w_max)^2.
        next_term = -np.linalg.solve(m, k_of_omega[i] @ np.linalg.solve(m, loads[0]))
        assert_close_to_scale(omega**2 * deviation, next_term, dof_scale(next_term), rtol=1e-5)
        matrices = mounts.global_stiffness(s["axes"], mounts.local_stiffness(s["local"], loss=loss, omega=omega))
        force = np.asarray(mounts.mount_forces(matrices, transforms, q[i]))
        transmitted = np.abs(force.sum(0)).max() / np.abs(loads[0, :3]).max()
        assert transmitted < 10 / ratios[i] ** 2, f"transmitted/|F| = {transmitted} at {ratios[i]} x w_max"
        assert np.abs(force).max() / np.abs(loads[0, :3]).max() < 10 / ratios[i] ** 2
    assert errors[0] < 10 / ratios[0] ** 2
    assert errors[0] / errors[1] == pytest.approx((ratios[1] / ratios[0]) ** 2, rel=0.02), errors


def test_pure_roll_torque_on_a_decoupled_system_moves_only_roll():
    positions, axes, local = symmetric_layout(0.0)
    m = hand_mass(MASS, np.diag(PRINCIPAL))
    transforms = mounts.point_transforms(positions, CG)
    w_roll = np.sqrt(closed_form_stiffness(0.0)[3, 3] / PRINCIPAL[0])
    omegas = np.array([0.3, 0.97, 1.0, 1.04, 3.0, 40.0]) * w_roll
    loss, damping = np.full_like(local, 0.15), np.full_like(local, 250.0)
    k_of_omega = dynamic_stiffness(transforms, axes, local, omegas, loss, damping)
    torque = np.array([0, 0, 0, 120.0 - 35.0j, 0, 0])
    q = np.asarray(mounts.forced_response(m, k_of_omega, omegas, np.tile(torque, (len(omegas), 1))))
    roll = q[:, 3]
    k_roll = 4 * (KZ * B**2) * (1 + 0.15j) + 1j * omegas * 4 * 250.0 * B**2
    assert_close_to_scale(roll, torque[3] / (k_roll - omegas**2 * PRINCIPAL[0]), np.abs(roll))
    scale = np.abs(roll)[:, None] * np.array([ELL, ELL, ELL, 1, 1, 1])
    others = q.copy()
    others[:, 3] = 0
    assert_close_to_scale(others, np.zeros_like(others), scale)


def test_vertical_transmissibility_is_the_single_dof_closed_form():
    positions, axes, local = symmetric_layout(0.0)
    m = hand_mass(MASS, np.diag(PRINCIPAL))
    transforms = mounts.point_transforms(positions, CG)
    eta = 0.12
    w_z = np.sqrt(4 * KZ / MASS)
    omegas = np.linspace(0.2, 5.0, 41) * w_z
    k_of_omega = dynamic_stiffness(transforms, axes, local, omegas, loss=np.full_like(local, eta))
    force = np.array([0, 0, 1500.0, 0, 0, 0], dtype=complex)
    q = np.asarray(mounts.forced_response(m, k_of_omega, omegas, np.tile(force, (len(omegas), 1))))
    transmitted = np.array([np.asarray(mounts.mount_forces(mounts.global_stiffness(axes, mounts.local_stiffness(
        local, loss=np.full_like(local, eta), omega=w)), transforms, qi)).sum(0) for w, qi in zip(omegas, q)])
    k_star = 4 * KZ * (1 + 1j * eta)
    ratio = k_star / (k_star - MASS * omegas**2)
    assert_close_to_scale(transmitted[:, 2] / force[2], ratio, np.abs(ratio))
    closed = np.abs(4 * KZ * (1 + 1j * eta)) / np.abs(4 * KZ * (1 + 1j * eta) - MASS * omegas**2)
    assert_close_to_scale(np.abs(transmitted[:, 2]) / abs(force[2]), closed, closed)
    assert_close_to_scale(transmitted[:, :2], np.zeros((len(omegas), 2)), np.abs(transmitted[:, 2:]))


# --------------------------------------------------------------------------
# Tables, elastic centre, damped modes


def test_table_stiffness_interpolates_linearly_in_hertz_and_holds_the_ends():
    freq = np.array([5.0, 50.0, 200.0])
    stiffness = np.array([[3e5, 3e5, 9e5], [3.6e5, 3.3e5, 1.1e6], [5e5, 4e5, 1.4e6]])
    loss = np.array([[0.10, 0.10, 0.10], [0.14, 0.12, 0.11], [0.20, 0.15, 0.13]])
    hz = np.array([1.0, 5.0, 20.0, 50.0, 120.0, 200.0, 900.0])
    k, eta = (np.asarray(a) for a in mounts.table_stiffness(freq, stiffness, loss, 2 * np.pi * hz))
    expected_k, expected_eta = [], []
    for f in hz:
        j = min(max(np.searchsorted(freq, f) - 1, 0), len(freq) - 2)
        t = min(max((f - freq[j]) / (freq[j + 1] - freq[j]), 0.0), 1.0)
        expected_k.append((1 - t) * stiffness[j] + t * stiffness[j + 1])
        expected_eta.append((1 - t) * loss[j] + t * loss[j + 1])
    assert_close_to_scale(k, np.array(expected_k), stiffness.max())
    assert_close_to_scale(eta, np.array(expected_eta), 1.0)  # scale: loss factors below 1


def test_elastic_centre_of_the_symmetric_layout_is_the_mount_plane_centre():
    centre, axes, torsional = (np.asarray(a) for a in mounts.elastic_centre(model_stiffness(*symmetric_layout())))
    assert_close_to_scale(centre, [0.0, 0.0, H], ELL)
    expected = {0: 4 * KZ * B**2, 1: 4 * KZ * A**2, 2: 4 * (KX * B**2 + KY * A**2)}
    found = {int(np.argmax(np.abs(axis))): (axis, stiffness) for axis, stiffness in zip(axes, torsional)}
    assert sorted(found) == [0, 1, 2], axes
    for dof, (axis, stiffness) in found.items():
        assert_close_to_scale(np.abs(axis), np.eye(3)[dof], 1.0)  # scale: unit vector
        assert stiffness == pytest.approx(expected[dof], rel=1e-12, abs=0)


def test_elastic_centre_turns_and_moves_with_the_layout():
    rng = np.random.default_rng(17)
    r = rotation(rng)
    positions, axes, local = symmetric_layout()
    turned = CG + (positions - CG) @ r.T  # the whole layout turned about the CG
    centre, _, torsional = (np.asarray(a) for a in mounts.elastic_centre(model_stiffness(turned, axes @ r.T, local)))
    assert_close_to_scale(centre, r @ [0.0, 0.0, H], ELL)
    reference = np.sort(np.asarray(mounts.elastic_centre(model_stiffness(positions, axes, local))[2]))
    assert_close_to_scale(np.sort(torsional), reference, reference.max())


def test_damped_modes_with_stiffness_proportional_damping():
    m = hand_mass(MASS, np.diag(PRINCIPAL))
    k = model_stiffness(*symmetric_layout())
    beta = 2e-3  # C = beta K: zeta_j = beta omega_j / 2, omega_d = omega_j sqrt(1 - zeta_j^2)
    frequency, zeta = (np.asarray(a) for a in mounts.damped_modes(m, k, beta * k, np.zeros((6, 6))))
    omega = np.sqrt(np.sort(omega_squares(m, k)))
    order = np.argsort(frequency)
    expected_zeta = beta * omega / 2
    assert_close_to_scale(zeta[order], expected_zeta, 1.0, rtol=1e-10)  # scale: damping ratios below 1
    assert_close_to_scale(frequency[order], omega * np.sqrt(1 - expected_zeta**2) / (2 * np.pi), omega.max(),
                          rtol=1e-10)
