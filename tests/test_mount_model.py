"""Unit tests of harmbal.model.mounts: shapes and broadcasting, inertia from parts, the singular-stiffness
guard, mount tables, damped modes against single-DOF closed forms, and the model's own consistency
(the fast paths against the plain ones, statics against the response at Ω → 0, the elimination's
fallback). The independent oracles are in test_mount_oracles.py.

Matrices over the six DOF mix N/m, N and N m/rad: their entries are compared with the scale
√(Kᵢᵢ Kⱼⱼ) of each entry, and responses with ``ELL`` turning rotations into metres.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_close_to_scale

from harmbal.model import mounts

MASS, INERTIA = 150.0, np.array([[9.0, 0.0, -1.2], [0.0, 16.0, 0.3], [-1.2, 0.3, 14.0]])
CG = np.array([0.02, -0.01, 0.25])
ELL = 0.3
SPEEDS, ORDERS = 7, 5


def layout(seed=3, n=4):
    """A random asymmetric mount set: positions, axes (rows u, v, w), k, η, c."""
    rng = np.random.default_rng(seed)
    positions = CG + rng.uniform(-0.4, 0.4, (n, 3))
    axes = np.array([np.linalg.qr(rng.normal(size=(3, 3)))[0].T for _ in range(n)])
    axes[:, 2] *= np.linalg.det(axes)[:, None]  # right-handed
    k = rng.uniform(1e5, 8e5, (n, 3))
    return positions, axes, k, rng.uniform(0.05, 0.2, (n, 3)), rng.uniform(50, 500, (n, 3))


def entry_scale(k):
    d = np.sqrt(np.abs(np.diagonal(k, axis1=-2, axis2=-1)))
    return d[..., :, None] * d[..., None, :]


def response_scale(q):
    length = np.array([1, 1, 1, ELL, ELL, ELL])
    return np.max(np.abs(q) * length, axis=-1, keepdims=True) / length


def grid():
    rng = np.random.default_rng(7)
    omega = np.linspace(30.0, 400.0, SPEEDS)[:, None] * (np.arange(1, ORDERS + 1) / 2)
    loads = rng.normal(size=(SPEEDS, ORDERS, 6)) + 1j * rng.normal(size=(SPEEDS, ORDERS, 6))
    return omega, loads * [1e3, 1e3, 1e3, 1e2, 1e2, 1e2]


def test_shapes_broadcast_and_fast_paths_agree_with_the_plain_ones():
    positions, axes, k, eta, c = layout()
    omega, loads = grid()
    transforms = mounts.point_transforms(positions, CG)
    local = mounts.local_stiffness(k, eta, c, omega)
    assert local.shape == (SPEEDS, ORDERS, 4, 3) and transforms.shape == (4, 3, 6)
    matrices = mounts.global_stiffness(axes, local)
    assert matrices.shape == (SPEEDS, ORDERS, 4, 3, 3)
    i, j, n = 4, 2, 1
    assert_close_to_scale(matrices[i, j, n], axes[n].T @ np.diag(local[i, j, n]) @ axes[n], k.max())
    stiffness = mounts.system_matrix(transforms, matrices)
    plain = sum(transforms[m].T @ matrices[i, j, m] @ transforms[m] for m in range(4))
    assert_close_to_scale(stiffness[i, j], plain, entry_scale(plain))
    fast = mounts.system_matrix_from_local(mounts.projected_matrices(axes, transforms), local)
    assert_close_to_scale(fast, stiffness, entry_scale(stiffness))
    assert_close_to_scale(mounts.dynamic_matrix(transforms, axes, local), stiffness, entry_scale(stiffness))
    m = mounts.mass_matrix(MASS, INERTIA)
    q = mounts.forced_response(m, stiffness, omega, loads)
    expected = np.linalg.solve(np.ascontiguousarray(stiffness) - omega[..., None, None] ** 2 * m, loads[..., None])
    assert q.shape == (SPEEDS, ORDERS, 6)
    assert_close_to_scale(q, expected[..., 0], response_scale(expected[..., 0]), rtol=1e-10)
    forces = mounts.mount_forces(matrices, transforms, q)
    assert forces.shape == (SPEEDS, ORDERS, 4, 3)
    assert_close_to_scale(forces[i, j, n], matrices[i, j, n] @ transforms[n] @ q[i, j], np.abs(forces[i, j]).max())
    assert_close_to_scale(mounts.mount_forces_local(axes, local, transforms, q), forces, np.abs(forces).max())


def test_unequal_leading_dimensions_broadcast():
    positions, axes, k, _, _ = layout()
    omega, loads = grid()
    transforms = mounts.point_transforms(positions, CG)
    matrices = mounts.global_stiffness(axes, k)  # real, no leading dims
    stiffness = mounts.system_matrix(transforms, matrices)
    m = mounts.mass_matrix(MASS, INERTIA)
    q = mounts.forced_response(m, stiffness, omega, loads[0, 0])  # one load, K without leading dims
    assert q.shape == omega.shape + (6,)
    expected = np.linalg.solve(stiffness - omega[..., None, None] ** 2 * m, loads[0, 0])
    assert_close_to_scale(q, expected, response_scale(expected), rtol=1e-10)
    forces = mounts.mount_forces(matrices, transforms, q)
    assert forces.shape == omega.shape + (4, 3)
    assert_close_to_scale(forces, np.einsum("nab,nbj,...j->...na", matrices, transforms, q), np.abs(forces).max())
    assert_close_to_scale(mounts.mount_forces_local(axes, k, transforms, q), forces, np.abs(forces).max())


def test_inertia_from_parts_by_the_parallel_axis_theorem():
    # Two unit point masses at ±(1, 1, 0) about their CG, I = Σ m(|d|² I − d dᵀ), and a third part with its own
    # inertia at the common CG (which it does not move): I_xy = −∫xy dm = −2 in the tensor convention.
    own = np.array([np.zeros((3, 3)), np.zeros((3, 3)), np.diag([0.5, 0.25, 0.125])])
    mass, cg, inertia = mounts.inertia_from_parts([1.0, 1.0, 2.0], [[2, 1, 3], [0, -1, 3], [1, 0, 3]], own)
    assert mass == 4.0
    assert_close_to_scale(cg, [1.0, 0.0, 3.0], 3.0)
    assert_close_to_scale(inertia, [[2.5, -2.0, 0.0], [-2.0, 2.25, 0.0], [0.0, 0.0, 4.125]], 4.0)
    with pytest.raises(ValueError, match="total mass must be positive"):
        mounts.inertia_from_parts([0.0], [[0, 0, 0]], [np.eye(3)])


def test_singular_stiffness_names_the_free_directions():
    positions, axes, k, _, _ = layout()
    transforms = mounts.point_transforms(positions, CG)
    vertical_only = mounts.system_matrix(transforms, mounts.global_stiffness(np.broadcast_to(np.eye(3), (4, 3, 3)),
                                                                            k * [0, 0, 1]))
    with pytest.raises(ValueError, match="rank 3 < 6"):
        mounts.modes(mounts.mass_matrix(MASS, INERTIA), vertical_only)
    no_x = mounts.system_matrix(transforms, mounts.global_stiffness(np.broadcast_to(np.eye(3), (4, 3, 3)),
                                                                    k * [0, 1, 1]))
    for call in (lambda: mounts.statics(no_x, transforms, np.zeros((4, 3, 3)), axes, np.zeros((1, 6))),
                 lambda: mounts.elastic_centre(no_x)):
        with pytest.raises(ValueError, match=r"rank 5 < 6; free: x\."):
            call()
    mounts.require_constrained(mounts.system_matrix(transforms, mounts.global_stiffness(axes, k)))


def test_tables_interpolate_linearly_in_frequency_and_hold_beyond_the_ends():
    freq = np.array([5.0, 50.0, 200.0])
    stiffness = np.array([[1e5, 2e5, 3e5], [2e5, 4e5, 6e5], [4e5, 4e5, 4e5]])
    loss = np.array([[0.1, 0.1, 0.1], [0.2, 0.1, 0.3], [0.2, 0.2, 0.2]])
    hz = np.array([[1.0, 5.0, 27.5], [50.0, 125.0, 1e4]])
    k, eta = mounts.table_stiffness(freq, stiffness, loss, 2 * np.pi * hz)
    assert k.shape == eta.shape == (2, 3, 3)
    expected_k = [[stiffness[0], stiffness[0], (stiffness[0] + stiffness[1]) / 2],
                  [stiffness[1], (stiffness[1] + stiffness[2]) / 2, stiffness[2]]]
    expected_eta = [[loss[0], loss[0], (loss[0] + loss[1]) / 2], [loss[1], (loss[1] + loss[2]) / 2, loss[2]]]
    assert_close_to_scale(k, expected_k, 6e5)
    assert_close_to_scale(eta, expected_eta, 1.0)  # scale: a loss factor, of order 1
    single = mounts.table_stiffness([10.0], stiffness[:1], loss[:1], np.array([1.0, 1e3]))[0]
    assert_close_to_scale(single, np.broadcast_to(stiffness[0], (2, 3)), 3e5)
    with pytest.raises(ValueError, match="increase strictly"):
        mounts.table_stiffness(freq[::-1], stiffness, loss, 1.0)


def decoupled_system(damping=(0.0, 0.0, 0.0), loss=0.0):
    """Four identical mounts symmetric about a CG at their own height: bounce decoupled from the rest."""
    positions = CG + np.array([[0.3, 0.2, 0.0], [0.3, -0.2, 0.0], [-0.3, 0.2, 0.0], [-0.3, -0.2, 0.0]])
    axes = np.broadcast_to(np.eye(3), (4, 3, 3))
    k = np.broadcast_to([2e5, 2.5e5, 4e5], (4, 3))
    transforms = mounts.point_transforms(positions, CG)
    system = mounts.system_matrix(transforms, mounts.global_stiffness(axes, k))
    damper = mounts.system_matrix(transforms, mounts.global_stiffness(axes, np.broadcast_to(damping, (4, 3))))
    return mounts.mass_matrix(MASS, np.diag(np.diag(INERTIA))), system, damper, loss * system, k


def test_damped_modes_against_single_dof_closed_forms():
    m, k, c, _, local = decoupled_system(damping=(0.0, 0.0, 900.0))
    frequency, shapes = mounts.modes(m, k)
    bounce = int(np.argmax(mounts.energy_distribution(m, shapes)[2]))
    damped, zeta = mounts.damped_modes(m, k, c, None)
    k_z, c_z = local[:, 2].sum(), 4 * 900.0
    expected = c_z / (2 * np.sqrt(k_z * MASS))
    assert_close_to_scale(zeta[bounce], expected, expected)
    assert_close_to_scale(damped[bounce], frequency[bounce] * np.sqrt(1 - expected**2), frequency[bounce])
    # Uniform hysteretic damping: every mode gets ζ = η/2 (its viscous equivalent at its own frequency).
    m, k, _, h, _ = decoupled_system(loss=0.14)
    damped, zeta = mounts.damped_modes(m, k, None, h)
    assert_close_to_scale(zeta, np.full(6, 0.07), 0.07)
    assert_close_to_scale(damped, mounts.modes(m, k)[0] * np.sqrt(1 - 0.07**2), mounts.modes(m, k)[0])
    undamped = mounts.damped_modes(m, k)
    assert_close_to_scale(undamped[0], mounts.modes(m, k)[0], mounts.modes(m, k)[0])
    assert_close_to_scale(undamped[1], np.zeros(6), 1.0)  # scale: a damping ratio, of order 1


def test_modes_energy_and_elastic_centre_are_consistent():
    positions, axes, k, _, _ = layout(seed=11)
    transforms = mounts.point_transforms(positions, CG)
    stiffness = mounts.system_matrix(transforms, mounts.global_stiffness(axes, k))
    m = mounts.mass_matrix(MASS, INERTIA)
    frequency, shapes = mounts.modes(m, stiffness)
    assert np.all(np.diff(frequency) > 0)
    assert_close_to_scale(shapes.T @ m @ shapes, np.eye(6), 1.0)  # scale: mass-normalised shapes
    assert_close_to_scale(shapes.T @ stiffness @ shapes, np.diag((2 * np.pi * frequency) ** 2),
                          (2 * np.pi * frequency.max()) ** 2)
    assert np.all(shapes[np.argmax(np.abs(shapes), axis=0), range(6)] > 0)
    energy = mounts.energy_distribution(m, shapes)
    assert_close_to_scale(energy.sum(axis=0), np.ones(6), 1.0)  # scale: energy shares
    # Isotropic mounts: the elastic centre is the stiffness-weighted centroid, where K's coupling vanishes.
    iso = np.broadcast_to(k[:, :1], (4, 3))
    centre, elastic_axes, torsional = mounts.elastic_centre(
        mounts.system_matrix(transforms, mounts.global_stiffness(axes, iso)))
    assert_close_to_scale(centre, iso[:, 0] @ (positions - CG) / iso[:, 0].sum(), ELL)
    assert_close_to_scale(elastic_axes @ elastic_axes.T, np.eye(3), 1.0)  # scale: unit vectors
    assert np.all(torsional > 0)
    tra = mounts.torque_roll_axis(INERTIA)
    assert_close_to_scale(tra, np.linalg.solve(INERTIA, [1, 0, 0]) / np.linalg.norm(np.linalg.solve(
        INERTIA, [1, 0, 0])), 1.0)  # scale: unit vector
    assert 0 <= mounts.tra_angle(tra, shapes, energy) <= np.pi / 2


def test_response_tends_to_statics_and_the_gyroscopic_term():
    positions, axes, k, eta, _ = layout(seed=5)
    transforms = mounts.point_transforms(positions, CG)
    matrices = mounts.global_stiffness(axes, k)
    stiffness = mounts.system_matrix(transforms, matrices)
    m = mounts.mass_matrix(MASS, INERTIA)
    load = np.array([[0.0, 0.0, -MASS * 9.80665, 10.0, -20.0, 5.0]])
    static = mounts.statics(stiffness, transforms, matrices, axes, load)
    q = mounts.forced_response(m, stiffness, np.array([1e-6]), load)
    assert_close_to_scale(q, static["q"], response_scale(static["q"]), rtol=1e-10)
    assert_close_to_scale(static["force"].sum(axis=1), load[:, :3], MASS * 9.80665)  # the frame feels the weight
    assert_close_to_scale(static["local_force"], np.einsum("nab,cnb->cna", axes, static["force"]),
                          MASS * 9.80665)
    assert_close_to_scale(mounts.loads_about(CG + [1, 0, 0], CG, [0, 0, -10.0], [0, 0, 0]), [0, -10.0, 0], 10.0)
    # A gyroscopic term (spinning parts, momentum h along +x) couples pitch and yaw: D = K − Ω²M + iΩG.
    spin = mounts.gyroscopic_matrix(np.array([0.0, 3.0]))
    assert spin[1, 4, 5] == 3.0 and spin[1, 5, 4] == -3.0 and np.count_nonzero(spin[0]) == 0
    omega = np.array([20.0, 20.0])
    q = mounts.forced_response(m, stiffness, omega, load, spin)
    dynamic = stiffness - 400.0 * m + 20j * spin
    assert_close_to_scale(np.einsum("sab,sb->sa", dynamic, q), np.tile(load, (2, 1)), np.abs(load).max())


def test_order_response_is_the_direct_solve_with_the_gyroscopic_term():
    """The modal expansion per order (constant matrices) against one direct
    solve per system, with damping of both kinds and spinning parts, across
    the modes: the same to round-off of the response's scale."""
    positions, axes, k, eta, c = layout(seed=3)
    transforms = mounts.point_transforms(positions, CG)
    stiffness = mounts.system_matrix(transforms, mounts.global_stiffness(axes, k * (1 + 1j * eta)))
    damping = mounts.system_matrix(transforms, mounts.global_stiffness(axes, c))
    m = mounts.mass_matrix(MASS, INERTIA)
    omega, orders = np.linspace(20.0, 400.0, 37), np.arange(1, 13) / 2
    rng = np.random.default_rng(7)
    unit = rng.normal(size=(12, 6)) + 1j * rng.normal(size=(12, 6))  # inertia: times ω²
    constant = 1e4 * (rng.normal(size=(12, 6)) + 1j * rng.normal(size=(12, 6)))  # gas: speed-independent
    load = (omega**2)[:, None, None] * unit + constant
    spin = -1.6  # sense·J: clockwise, 1.6 kg m²
    q = mounts.order_response(m, stiffness, damping, spin, orders, omega, unit, constant)
    frequency = omega[:, None] * orders[None, :]
    dynamic = (stiffness + 1j * frequency[..., None, None] * damping - frequency[..., None, None] ** 2 * m
               + 1j * frequency[..., None, None] * mounts.gyroscopic_matrix(spin * omega[:, None]))
    expected = np.linalg.solve(dynamic, load[..., None])[..., 0]
    for s in range(37):
        for o in range(12):
            assert_close_to_scale(q[s, o], expected[s, o], response_scale(expected[s, o]), rtol=1e-13)


def test_order_response_solves_directly_what_misses_its_residual(monkeypatch):
    """With no residual accepted, every system takes the direct solve: the fallback gives the same."""
    positions, axes, k, eta, c = layout(seed=4)
    transforms = mounts.point_transforms(positions, CG)
    stiffness = mounts.system_matrix(transforms, mounts.global_stiffness(axes, k * (1 + 1j * eta)))
    damping = mounts.system_matrix(transforms, mounts.global_stiffness(axes, c))
    m = mounts.mass_matrix(MASS, INERTIA)
    omega, orders = np.array([50.0, 90.0]), np.array([1.0, 2.5])
    unit = np.arange(12.0).reshape(2, 6) + 1j
    modal = mounts.order_response(m, stiffness, damping, 0.7, orders, omega, unit)
    monkeypatch.setattr(mounts, "RESIDUAL_RTOL", -1.0)
    direct = mounts.order_response(m, stiffness, damping, 0.7, orders, omega, unit)
    for s in range(2):
        for o in range(2):
            assert_close_to_scale(modal[s, o], direct[s, o], response_scale(direct[s, o]), rtol=1e-13)


def test_constant_mount_forces_are_the_general_ones():
    positions, axes, k, eta, c = layout(seed=6)
    transforms = mounts.point_transforms(positions, CG)
    omega = np.array([[10.0, 35.0], [80.0, 200.0]])
    rng = np.random.default_rng(2)
    q = rng.normal(size=(2, 2, 6)) + 1j * rng.normal(size=(2, 2, 6))
    local = mounts.local_stiffness(k, eta, c, omega)
    general = mounts.mount_forces_local(axes, local, transforms, q)
    fast = mounts.constant_mount_forces(axes, transforms, k * (1 + 1j * eta), c, omega, q)
    assert_close_to_scale(fast, general, np.abs(general).max())
