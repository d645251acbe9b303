"""Exact design of a lever balancer's balance weight (harmbal.balance.lever).

The design is never judged by its own affine map or its own criterion code.
Oracles used here:

* A black box written here: the scene's coupler replaced by a trial weight
  (dataclasses.replace), simulated by ``hb.simulate`` at 2048 samples/rev, the
  signals picked by axis name and the criterion (peak-to-peak, peak, weighted
  squared order amplitudes by a DFT written here) computed here.
* The black box itself is checked against kinematics written here: the joint
  B by circle intersection, the weight's CG path differentiated spectrally,
  force = −m·ω²·a_G (and Newton on the coupler for the joint forces).
* Random and grid sampling of the feasible box, local perturbations around
  the optimum, and scipy Nelder–Mead from several starts on the black box:
  none beats the design.
* An LP (scipy HiGHS) and a convex least-squares solve (scipy lsq_linear plus
  a 1-D convex minimisation over the mass) assembled here from finite
  differences of the black box, which is affine in p = (m, m·x_G, m·y_G);
  the affinity itself is checked at a random point.
* Scaling laws: criterion ∝ ω² (ω⁴ for squared order amplitudes), optimum
  independent of speed and of the weight's moment of inertia.
* A simple quadratic for the compass search, with evaluations counted here.
* The input scene's text and TOML (comments kept, [design] dropped); the
  archive read back with xarray and with netCDF4 directly.

datasets/make_balanced.py's lever-single-optimised.toml is already compared
with the committed file by tests/test_design.py::test_generated_dataset_is_up_to_date.
"""

import copy
import dataclasses
import math
import re
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog, lsq_linear, minimize, minimize_scalar

import harmbal as hb
from harmbal.balance.lever import compass_search, design_lever
from harmbal.cli import main
from harmbal.scene import SceneError
from harmbal.scene.requests import LeverDesignRequest

ROOT = Path(__file__).resolve().parent.parent
LEVER = ROOT / "datasets" / "engines" / "lever-single.toml"
TEXT = LEVER.read_text(encoding="utf-8")
BASE = tomllib.loads(TEXT)

#: Samples per revolution of every criterion (harmbal.scene.requests.PEAK_SAMPLES).
N = 2048

#: The bounds of lever-single.toml's [design.lever] [kg, m].
BOX = ((0.5, 5.0), (0.0, 0.1), (-0.06, 0.06))

#: "Cannot beat" margin: relative.
RTOL = 1e-9


# --------------------------------------------------------------------------
# Helpers: scenes, the black box, criteria written here


def mapping(**lever_design):
    """lever-single as a mapping with [design.lever] keys replaced (None deletes)."""
    data = copy.deepcopy(BASE)
    for key, value in lever_design.items():
        if value is None:
            data["design"]["lever"].pop(key, None)
        else:
            data["design"]["lever"][key] = value
    return data


def moment_mapping():
    """lever-single with the lever off the reference plane, so that the
    transverse moments depend on the weight: lever at x = 25 mm, reference
    point at x = −10 mm, all four signals judged."""
    data = mapping(signals=["force_y", "force_z", "moment_y", "moment_z"])
    data["lever_balancer"][0]["axial_position"] = "25 mm"
    data["engine"]["reference_point"] = ["-10 mm", "0 mm", "0 mm"]
    return data


def with_weight(scene, weight, inertia=None):
    """The scene with the lever's coupler replaced by the weight (m, x_G, y_G)."""
    m, x, y = (float(v) for v in weight)
    lever = scene.levers[0]
    coupler = dataclasses.replace(lever.coupler, mass=m, cg=(x, y),
                                  inertia=lever.coupler.inertia if inertia is None else inertia)
    return dataclasses.replace(scene, levers=(dataclasses.replace(lever, coupler=coupler),) + scene.levers[1:])


def signals(scene, names):
    """The named signals at the scene's first speed, (signal, angle), from hb.simulate."""
    ds = hb.simulate(scene, samples_per_rev=N)
    if "speed" in ds.force.dims:
        ds = ds.isel(speed=0)
    assert ds.sizes["angle"] == N
    return np.array([(ds.force if n.startswith("force") else ds.moment).sel(axis=n[-1]).values for n in names])


def order_phasor(values, k):
    """One-sided order-k phasor (peak amplitude) of samples over one revolution."""
    n = values.shape[-1]
    return 2 * (values * np.exp(-2j * np.pi * k * np.arange(n) / n)).sum(axis=-1) / n


def criterion(values, objective, orders=(1,), weights=()):
    if objective == "peak_to_peak":
        return float((values.max(axis=-1) - values.min(axis=-1)).sum())
    if objective == "peak":
        return float(np.abs(values).max(axis=-1).sum())
    assert objective == "orders"
    weights = weights or (1.0,) * len(orders)
    return float(sum(w * (np.abs(order_phasor(values, k)) ** 2).sum() for k, w in zip(orders, weights)))


def black_box(scene, weight, request=None):
    """The criterion of the scene with this weight, from hb.simulate."""
    request = request or scene.design
    return criterion(signals(with_weight(scene, weight), request.signals), request.objective, request.orders,
                     request.weights)


def in_box(weight, request, slack=1e-12):
    m, x, y = weight
    checks = [m >= -slack]
    for value, bound in ((m, request.mass), (x, request.cg_x), (y, request.cg_y)):
        if bound:
            checks.append(bound[0] - slack * max(1, abs(bound[0])) <= value <= bound[1] + slack * max(1, abs(bound[1])))
    return all(checks)


def affine_map(scene, names):
    """Signals as s0 + S·p, p = (m, m·x_G, m·y_G), by finite differences of the
    black box (exact: the weight enters the loads linearly through p)."""
    h = 0.05
    s0 = signals(with_weight(scene, (0.0, 0.0, 0.0)), names)
    s1 = signals(with_weight(scene, (1.0, 0.0, 0.0)), names)
    s2 = signals(with_weight(scene, (1.0, h, 0.0)), names)
    s3 = signals(with_weight(scene, (1.0, 0.0, h)), names)
    columns = np.stack([s1 - s0, (s2 - s1) / h, (s3 - s1) / h], axis=-1)  # (signal, angle, 3)
    return s0, columns


def p_of(weight):
    m, x, y = weight
    return np.array([m, m * x, m * y])


def weight_of(p):
    return (p[0], p[1] / p[0], p[2] / p[0])


def p_constraints(request):
    """Bounds on the weight as rows G·p ≤ h written here (m ≥ 0 always)."""
    rows, rhs = [[-1, 0, 0]], [0.0]
    if request.mass:
        rows += [[-1, 0, 0], [1, 0, 0]]
        rhs += [-request.mass[0], request.mass[1]]
    for j, bound in ((1, request.cg_x), (2, request.cg_y)):
        if bound:
            low, high = [0.0] * 3, [0.0] * 3
            low[0], low[j] = bound[0], -1.0
            high[0], high[j] = -bound[1], 1.0
            rows += [low, high]
            rhs += [0.0, 0.0]
    return np.array(rows, float), np.array(rhs, float)


def own_lp(s0, columns, objective, request):
    """min Σ_s (max − min) or Σ_s max|·| of s0 + S·p under the bounds, by HiGHS
    on an LP assembled here. Returns p."""
    nsig = s0.shape[0]
    size = np.abs(s0).max(axis=-1)
    pscale = np.array([1.0, 0.05, 0.05])
    a = columns * pscale / size[:, None, None]
    b = s0 / size[:, None]
    extra = 2 if objective == "peak_to_peak" else 1
    nvar = 3 + extra * nsig
    c = np.zeros(nvar)
    rows, rhs = [], []
    for s in range(nsig):
        up = np.zeros((N, nvar))
        up[:, :3], up[:, 3 + extra * s] = a[s], -1.0
        down = np.zeros((N, nvar))
        down[:, :3] = -a[s]
        if objective == "peak_to_peak":
            down[:, 4 + 2 * s] = 1.0
            c[3 + 2 * s], c[4 + 2 * s] = size[s], -size[s]
        else:
            down[:, 3 + s] = -1.0
            c[3 + s] = size[s]
        rows += [up, down]
        rhs += [-b[s], b[s]]
    g, h = p_constraints(request)
    bound_rows = np.zeros((len(h), nvar))
    bound_rows[:, :3] = g * pscale
    result = linprog(c / size.max(), A_ub=np.vstack(rows + [bound_rows]), b_ub=np.concatenate(rhs + [h]),
                     bounds=[(None, None)] * nvar, method="highs",
                     options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10})
    assert result.success, result.message
    return result.x[:3] * pscale


def own_orders_solve(s0, columns, request):
    """min Σ_k w_k Σ_s |C_k|² of s0 + S·p under the bounds: for a fixed mass a
    box-constrained linear least squares in (m·x_G, m·y_G) (lsq_linear, BVLS),
    then a bounded 1-D minimisation over the mass (the partial minimum of a
    jointly convex function is convex). Returns (p, value)."""
    weights = request.weights or (1.0,) * len(request.orders)
    rest, cols = [], []
    for k, w in zip(request.orders, weights):
        r = np.sqrt(w) * order_phasor(s0, k)  # (signal,)
        c = np.sqrt(w) * np.stack([order_phasor(columns[..., j], k) for j in range(3)], axis=-1)  # (signal, 3)
        rest += [r.real, r.imag]
        cols += [c.real, c.imag]
    b = np.concatenate(rest)
    a = np.vstack(cols)

    def inner(m):
        xb = request.cg_x or (-np.inf, np.inf)
        yb = request.cg_y or (-np.inf, np.inf)
        lo = [m * xb[0], m * yb[0]]
        hi = [m * xb[1], m * yb[1]]
        fit = lsq_linear(a[:, 1:], -(b + a[:, 0] * m), bounds=(lo, hi), method="bvls", tol=1e-14)
        p = np.array([m, *fit.x])
        return float(np.sum((a @ p + b) ** 2)), p

    lo, hi = request.mass or (0.0, 20.0)
    best = minimize_scalar(lambda m: inner(m)[0], bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-11 * max(1.0, hi)})
    value, p = inner(best.x)
    for m in (lo, hi):  # the bounded Brent search never evaluates the ends themselves
        v, q = inner(m)
        if v < value:
            value, p = v, q
    return p, value


def box_sample(rng, count, box=BOX):
    return np.column_stack([rng.uniform(lo, hi, count) for lo, hi in box])


def nelder_mead_best(function, box, starts):
    """Best value of Nelder–Mead runs on the box (normalised coordinates,
    projected onto the box)."""
    lo = np.array([b[0] for b in box])
    span = np.array([b[1] - b[0] for b in box])

    def f(u):
        return function(lo + np.clip(u, 0, 1) * span)

    best = math.inf
    for start in starts:
        u0 = (np.asarray(start) - lo) / np.where(span > 0, span, 1)
        simplex = np.vstack([u0] + [u0 + 0.15 * e * (1 if u0[i] < 0.5 else -1) for i, e in enumerate(np.eye(len(u0)))])
        result = minimize(f, u0, method="Nelder-Mead", options={"initial_simplex": simplex, "maxfev": 250,
                                                                 "xatol": 1e-9, "fatol": 1e-9})
        best = min(best, result.fun)
    return best


def run_cli(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def base():
    return hb.load_scene(LEVER)


@pytest.fixture(scope="module")
def optimum(base):
    return hb.design(base)


# --------------------------------------------------------------------------
# 0. The black box against kinematics written here


def coupler_cg_path(lever, sense, cg):
    """The weight's CG in the w-plane (w = z + i·t, t = −sense·y, angles in the
    direction of rotation) over one revolution, by circle intersection."""
    theta = 2 * np.pi * np.arange(N) / N
    y, z = lever.pivot
    pivot = complex(z, -sense * y)
    c = lever.pin_radius * np.exp(1j * (theta + lever.pin_angle))
    a, b = lever.rocker_length, lever.coupler_length
    d = np.abs(c - pivot)
    u = (c - pivot) / d
    along = (a * a - b * b + d * d) / (2 * d)
    across = np.sqrt(a * a - along**2)
    side = 1 if lever.assembly == "ahead" else -1  # ahead: left of A→C, +i·u
    joint_b = pivot + along * u + side * across * 1j * u
    assert np.allclose(np.abs(joint_b - pivot), a) and np.allclose(np.abs(c - joint_b), b)
    return joint_b + complex(*cg) * (c - joint_b) / b


def second_derivative(path):
    """Spectral d²/dθ²; harmonics above 128 (decayed below round-off for
    this linkage, checked) are dropped, they would only amplify round-off."""
    k = np.fft.fftfreq(N, 1.0 / N)
    spectrum = np.fft.fft(path)
    assert np.abs(spectrum[np.abs(k) > 128]).max() <= 1e-13 * np.abs(spectrum).max()
    return np.fft.ifft(np.where(np.abs(k) <= 128, -(k**2) * spectrum, 0))


def test_black_box_weight_force_is_minus_m_omega2_a_G_from_own_kinematics():
    """Oracle: circle intersection and spectral differentiation written here.
    The weight's share of the shaking force is −m·ω²·G''(θ), and (lever at
    x = 25 mm, reference at −10 mm) its transverse moments are the force at
    the arm 35 mm: M_y = −arm·F_z, M_z = arm·F_y."""
    scene = hb.load_scene(moment_mapping())
    lever, sense, w2 = scene.levers[0], scene.sense, scene.speeds[0] ** 2
    weight = (1.7, 0.03, -0.02)
    names = ("force_y", "force_z", "moment_y", "moment_z")
    share = signals(with_weight(scene, weight), names) - signals(with_weight(scene, (0.0, 0.03, -0.02)), names)
    force_w = -weight[0] * w2 * second_derivative(coupler_cg_path(lever, sense, weight[1:]))
    fy, fz = -sense * force_w.imag, force_w.real
    arm = 0.025 - (-0.010)
    expected = np.array([fy, fz, -arm * fz, arm * fy])
    scale = np.abs(expected).max()
    assert scale > 100  # a real load
    np.testing.assert_allclose(share, expected, rtol=0, atol=1e-9 * scale)


def test_a_weight_at_the_second_crank_pin_is_a_pure_first_order_unbalance(base):
    """Oracle: closed form. A mass at C (x_G = coupler_length, y_G = 0) turns
    with the crank on the circle of radius pin_radius at pin_angle: its share
    of the force is m·ω²·r_C·e^{i(θ + pin_angle)} in the w-plane, first order
    only (so the squared amplitudes of orders ≥ 2 do not see it)."""
    lever, sense, w2 = base.levers[0], base.sense, base.speeds[0] ** 2
    m, b = 2.2, lever.coupler_length
    names = ("force_y", "force_z")
    share = signals(with_weight(base, (m, b, 0.0)), names) - signals(with_weight(base, (0.0, b, 0.0)), names)
    theta = 2 * np.pi * np.arange(N) / N
    w = m * w2 * lever.pin_radius * np.exp(1j * (theta + lever.pin_angle))
    np.testing.assert_allclose(share, [-sense * w.imag, w.real], atol=1e-9 * np.abs(w).max())


def test_joint_forces_obey_newton_on_the_coupler_and_the_frame(base):
    """Oracle: Newton, with the coupler's acceleration from the kinematics
    written here. Rocker on coupler (B) + crankshaft on coupler (C) = m·a_G of
    the coupler; the frame's forces on the moving parts (main bearing D, pivot
    A, cylinder wall W1) are minus the shaking force of hb.simulate."""
    joints = hb.joints(base)
    lever, sense, w2 = base.levers[0], base.sense, base.speeds[0] ** 2
    force = joints["joint_force"]
    m_a = lever.coupler.mass * w2 * second_derivative(coupler_cg_path(lever, sense, lever.coupler.cg))
    on_coupler = force.sel(joint="lever: B") + force.sel(joint="lever: C")
    scale = np.abs(force).max().item()
    np.testing.assert_allclose(on_coupler.sel(axis="y"), -sense * m_a.imag, atol=1e-9 * scale)
    np.testing.assert_allclose(on_coupler.sel(axis="z"), m_a.real, atol=1e-9 * scale)
    frame = force.sel(joint="D") + force.sel(joint="lever: A") + force.sel(joint="W1")
    shaking = signals(base, ("force_y", "force_z"))
    np.testing.assert_allclose(-frame.values, shaking, atol=1e-9 * scale)
    # The peaks of the table are the peaks of |joint force|.
    magnitude = np.hypot(force.sel(axis="y"), force.sel(axis="z"))
    np.testing.assert_allclose(joints["joint_force_peak"], magnitude.max("angle"), rtol=1e-12)


# --------------------------------------------------------------------------
# 1. Optimality of the linear programme (peak-to-peak, the thesis's criterion)


def test_lp_optimum_is_what_the_black_box_measures(base, optimum):
    assert optimum.method == "lp"
    assert optimum.lever == "lever"
    assert optimum.speed == pytest.approx(3000 * math.pi / 30, rel=1e-14)
    assert in_box(optimum.weight, base.design)
    assert optimum.start == pytest.approx((1.3987, 0.04829, 0.02279), rel=1e-12)
    assert black_box(base, optimum.weight) == pytest.approx(optimum.criterion, rel=1e-10)
    assert black_box(base, optimum.start) == pytest.approx(optimum.criterion_start, rel=1e-10)
    assert optimum.criterion < 0.6 * optimum.criterion_start  # the design does something


def test_no_sampled_feasible_weight_beats_the_lp(base, optimum):
    """Oracle: 5³ grid (corners included) and 300 random weights in the box."""
    rng = np.random.default_rng(1)
    grid = np.array(np.meshgrid(*[np.linspace(lo, hi, 5) for lo, hi in BOX])).reshape(3, -1).T
    values = [black_box(base, w) for w in np.vstack([grid, box_sample(rng, 300)])]
    assert min(values) >= optimum.criterion * (1 - RTOL)


def test_no_nearby_weight_beats_the_lp(base, optimum):
    """Oracle: local perturbations of p in random directions at several
    sizes, kept feasible. The criterion is convex in p, so a local minimum
    over the box is the global one."""
    rng = np.random.default_rng(2)
    p0 = p_of(optimum.weight)
    count = 0
    for size in (1e-2, 1e-3, 1e-4, 1e-6):
        for direction in rng.normal(size=(40, 3)):
            p = p0 * (1 + size * direction / np.linalg.norm(direction))
            weight = weight_of(p)
            if in_box(weight, base.design, slack=0):
                count += 1
                assert black_box(base, weight) >= optimum.criterion * (1 - RTOL)
    assert count > 100


def test_nelder_mead_on_the_black_box_cannot_beat_the_lp(base, optimum):
    rng = np.random.default_rng(3)
    starts = [optimum.start, (2.75, 0.05, 0.0), *box_sample(rng, 1)]
    best = nelder_mead_best(lambda w: black_box(base, w), BOX, starts)
    assert best >= optimum.criterion * (1 - RTOL)
    assert best <= 1.2 * optimum.criterion  # the search itself works


def test_own_lp_on_the_black_box_affine_map_agrees(base, optimum):
    """Oracle: an LP assembled here from finite differences of the black box.
    Its optimum, re-measured by the black box, is not below the design's, and
    the design is not above it beyond the solvers' tolerance."""
    names = base.design.signals
    s0, columns = affine_map(base, names)
    # The affinity in p, at a random weight.
    weight = (2.3, 0.071, -0.033)
    np.testing.assert_allclose(signals(with_weight(base, weight), names), s0 + columns @ p_of(weight),
                               atol=1e-9 * np.abs(s0).max())
    p = own_lp(s0, columns, "peak_to_peak", base.design)
    mine = black_box(base, weight_of(p))
    assert optimum.criterion <= mine * (1 + RTOL)
    assert mine <= optimum.criterion * (1 + 1e-7)


# --------------------------------------------------------------------------
# 2. Speed


@pytest.mark.parametrize("objective, power", [("peak_to_peak", 2), ("orders", 4)])
def test_optimum_does_not_depend_on_speed_and_criterion_scales(objective, power):
    results = {}
    for rpm in (3000, 7000):
        data = mapping()
        data["engine"]["speed"] = f"{rpm} rpm"
        data["design"]["objective"] = objective
        results[rpm] = hb.design(hb.load_scene(data))
    slow, fast = results[3000], results[7000]
    np.testing.assert_allclose(fast.weight, slow.weight, rtol=1e-9, atol=1e-12)  # scale: ~1 (kg, m)
    assert fast.criterion == pytest.approx(slow.criterion * (7 / 3) ** power, rel=1e-10)
    assert fast.criterion_start == pytest.approx(slow.criterion_start * (7 / 3) ** power, rel=1e-10)
    # And by the black box at 7000 rpm with the 3000 rpm optimum.
    assert black_box(fast.scene, slow.weight, fast.request) == pytest.approx(fast.criterion, rel=1e-9)
    assert slow.verified and fast.verified


@pytest.mark.parametrize("speeds", [["7000 rpm", "3000 rpm"], ["3000 rpm", "5000 rpm", "7000 rpm"]])
def test_several_speeds_design_at_the_first_and_verify(optimum, speeds):
    """A scene may list several speeds; the criterion is the first speed's
    (the exact check must take the first speed of the simulated
    (speed, axis, angle) force)."""
    data = mapping()
    data["engine"]["speed"] = speeds
    scene = hb.load_scene(data)
    result = hb.design(scene)
    first = float(speeds[0].split()[0])
    np.testing.assert_allclose(result.weight, optimum.weight, rtol=1e-9, atol=1e-12)  # scale: ~1 (kg, m)
    assert result.criterion == pytest.approx(optimum.criterion * (first / 3000) ** 2, rel=1e-10)
    assert black_box(scene, result.weight) == pytest.approx(result.criterion, rel=1e-9)
    assert abs(result.exact_criterion - result.criterion) <= result.tolerance
    assert result.verified


# --------------------------------------------------------------------------
# 3. The weight's moment of inertia


def test_moment_of_inertia_changes_neither_optimum_nor_criterion():
    """Four signals with the lever off the reference plane, so that the
    transverse moments are judged too. The roll moment (not a signal) does
    see the inertia: the black box is sensitive to it."""
    results, rolls = [], []
    for inertia in ("0 kg mm^2", "1800 kg mm^2", "50000 kg mm^2"):
        data = moment_mapping()
        data["lever_balancer"][0]["coupler"]["inertia"] = inertia
        scene = hb.load_scene(data)
        result = hb.design(scene)
        assert result.verified
        results.append(result)
        rolls.append(signals(scene, ("moment_x",))[0])
        assert black_box(scene, result.weight) == pytest.approx(result.criterion, rel=1e-9)
    for other in results[1:]:
        np.testing.assert_allclose(other.weight, results[0].weight, rtol=1e-9, atol=1e-13)  # scale: ~1 (kg, m)
        assert other.criterion == pytest.approx(results[0].criterion, rel=1e-12)
        assert other.criterion_start == pytest.approx(results[0].criterion_start, rel=1e-12)
    assert np.abs(rolls[2] - rolls[0]).max() > 1.0  # [N m]
    # The moments do depend on the weight here (not a trivial design).
    start = results[0].breakdown["criterion"].sel(weight="start")
    end = results[0].breakdown["criterion"].sel(weight="optimum")
    assert not np.allclose(start.sel(signal=["moment_y", "moment_z"]), end.sel(signal=["moment_y", "moment_z"]))


def test_moment_signals_design_is_optimal_by_own_lp():
    scene = hb.load_scene(moment_mapping())
    result = hb.design(scene)
    s0, columns = affine_map(scene, scene.design.signals)
    mine = black_box(scene, weight_of(own_lp(s0, columns, "peak_to_peak", scene.design)))
    assert result.criterion <= mine * (1 + RTOL)
    assert mine <= result.criterion * (1 + 1e-7)
    assert in_box(result.weight, scene.design)


# --------------------------------------------------------------------------
# 4. Bounds


TIGHT = dict(mass=["1.0 kg", "1.0 kg"], cg_y=["-20 mm", "-10 mm"])


def test_tight_bounds_are_respected_and_optimal_in_the_box(optimum):
    """Mass fixed at 1 kg and y_G in [−20, −10] mm (the free optimum is at
    −51 mm): the 2-D problem over (x_G, y_G), checked on a 21 × 11 grid, by
    Nelder–Mead from its best point and by the own LP."""
    scene = hb.load_scene(mapping(**TIGHT))
    result = hb.design(scene)
    m, x, y = result.weight
    assert m == pytest.approx(1.0, rel=1e-12)
    assert 0.0 - 1e-12 <= x <= 0.1 + 1e-12
    assert -0.02 - 1e-12 <= y <= -0.01 + 1e-12
    assert result.criterion > optimum.criterion  # the bounds cost something
    values = {(gx, gy): black_box(scene, (1.0, gx, gy))
              for gx in np.linspace(0, 0.1, 21) for gy in np.linspace(-0.02, -0.01, 11)}
    assert min(values.values()) >= result.criterion * (1 - RTOL)
    best = min(values, key=values.get)
    nm = nelder_mead_best(lambda w: black_box(scene, (1.0, *w)), ((0.0, 0.1), (-0.02, -0.01)), [best])
    assert nm >= result.criterion * (1 - RTOL)
    s0, columns = affine_map(scene, scene.design.signals)
    mine = black_box(scene, weight_of(own_lp(s0, columns, "peak_to_peak", scene.design)))
    assert result.criterion <= mine * (1 + RTOL) and mine <= result.criterion * (1 + 1e-7)


@pytest.mark.parametrize("objective", ["peak_to_peak", "peak", "orders"])
def test_tight_bounds_every_objective(objective):
    data = mapping(**TIGHT)
    data["design"]["objective"] = objective
    scene = hb.load_scene(data)
    result = hb.design(scene)
    assert in_box(result.weight, scene.design)
    assert result.weight[0] == pytest.approx(1.0, rel=1e-12)
    assert result.verified
    assert black_box(scene, result.weight) == pytest.approx(result.criterion, rel=1e-9)


@pytest.mark.parametrize("objective", ["peak_to_peak", "orders"])
@pytest.mark.parametrize("mass", [(2.0, 1.0), (-1.0, -0.5)])
def test_contradictory_mass_bounds_raise_design_error(base, objective, mass):
    """The scene reader refuses low > high and negative masses (see the
    validation tests); a request built in Python is refused by the designer,
    naming the key."""
    with pytest.raises(hb.DesignError, match="design.lever.mass"):
        design_lever(base, LeverDesignRequest(objective=objective, mass=mass))


@pytest.mark.parametrize("objective", ["peak_to_peak", "orders"])
def test_contradictory_cg_bounds_leave_only_no_weight(base, objective):
    """x_lo > x_hi is satisfiable by m = 0 alone. Either the design says so
    (DesignError) or it returns no weight with the criterion of no weight,
    never a "massless" p = (0, 0, m·y_G ≠ 0) that no weight achieves."""
    request = LeverDesignRequest(objective=objective, cg_x=(0.05, 0.01))
    try:
        result = design_lever(base, request)
    except hb.DesignError:
        return
    assert result.weight[0] == 0.0
    assert result.criterion == pytest.approx(black_box(base, (0.0, 0.0, 0.0), request), rel=1e-9)
    assert result.verified


def test_zero_mass_bounds_without_cg_bounds_give_the_criterion_without_weight(tmp_path, capsys):
    """Reachable from a scene file: [design.lever] mass = ["0 kg", "0 kg"]
    and no CG bounds. Oracle: the black box with m = 0 (without the default
    CG envelope, p = (0, m·x_G ≠ 0, m·y_G ≠ 0) once passed for a design
    whose criterion no weight achieves)."""
    data = mapping(mass=["0 kg", "0 kg"], cg_x=None, cg_y=None)
    scene = hb.load_scene(data)
    result = hb.design(scene)
    assert result.weight[0] == 0.0
    no_weight = black_box(scene, (0.0, 0.0, 0.0))
    assert result.criterion == pytest.approx(no_weight, rel=1e-9)
    assert result.criterion_start < no_weight  # the thesis's weight does help
    assert result.verified


# --------------------------------------------------------------------------
# 5. The "peak" and "orders" objectives


def test_peak_objective_is_optimal(base):
    data = mapping()
    data["design"]["objective"] = "peak"
    scene = hb.load_scene(data)
    result = hb.design(scene)
    assert result.method == "lp" and result.verified and in_box(result.weight, scene.design)
    assert black_box(scene, result.weight) == pytest.approx(result.criterion, rel=1e-10)
    rng = np.random.default_rng(4)
    assert min(black_box(scene, w) for w in box_sample(rng, 100)) >= result.criterion * (1 - RTOL)
    best = nelder_mead_best(lambda w: black_box(scene, w), BOX, [result.start, (2.75, 0.05, 0.0)])
    assert best >= result.criterion * (1 - RTOL)
    s0, columns = affine_map(scene, scene.design.signals)
    mine = black_box(scene, weight_of(own_lp(s0, columns, "peak", scene.design)))
    assert result.criterion <= mine * (1 + RTOL) and mine <= result.criterion * (1 + 1e-7)


ORDER_CASES = [dict(orders=[1]), dict(orders=[1, 2], weights=[1.0, 0.3]), dict(orders=[2, 3], weights=[2.0, 1.0])]


@pytest.mark.parametrize("case", ORDER_CASES)
def test_orders_objective_is_optimal(case):
    data = mapping(weights=case.get("weights"))
    data["design"].update(objective="orders", orders=case["orders"])
    scene = hb.load_scene(data)
    result = hb.design(scene)
    request = scene.design
    assert result.method == "qp" and result.verified and in_box(result.weight, request)
    assert black_box(scene, result.weight) == pytest.approx(result.criterion, rel=1e-10)
    s0, columns = affine_map(scene, request.signals)
    p, value = own_orders_solve(s0, columns, request)
    mine = black_box(scene, weight_of(p))
    assert mine == pytest.approx(value, rel=1e-9)  # the finite-difference map is exact
    assert result.criterion <= mine * (1 + RTOL)
    assert mine <= result.criterion * (1 + 1e-8)
    if 1 in request.orders:  # strictly convex: one minimiser
        np.testing.assert_allclose(p_of(result.weight), p, rtol=1e-4, atol=1e-7)
    best = nelder_mead_best(lambda w: black_box(scene, w, request), BOX, [result.start])
    assert best >= result.criterion * (1 - RTOL)


def test_orders_objective_unconstrained_is_the_least_squares_solution_and_bounds_bind(base):
    """Oracle: numpy lstsq on the order phasors of the black box's affine map.
    Without bounds (or with loose ones) the design is the unconstrained
    minimiser; in a box that stops short of its y_G the design sits on the
    box's edge and costs more."""
    s0, columns = affine_map(base, ("force_y", "force_z"))
    r, c = order_phasor(s0, 1), np.stack([order_phasor(columns[..., j], 1) for j in range(3)], axis=-1)
    a, b = np.vstack([c.real, c.imag]), np.concatenate([r.real, r.imag])
    p_free, *_ = np.linalg.lstsq(a, -b, rcond=None)
    free_value = float(np.sum((a @ p_free + b) ** 2))
    free_weight = weight_of(p_free)
    # A box whose y_G range stops 10 mm short of the free minimiser's y_G.
    box = dataclasses.replace(base.design, objective="orders", cg_y=(free_weight[2] + 0.01, 0.06))
    assert not in_box(free_weight, box)
    for bounds in (dict(mass=None, cg_x=None, cg_y=None), dict(mass=(0.0, 100.0), cg_x=(-1.0, 1.0), cg_y=(-1.0, 1.0))):
        request = dataclasses.replace(base.design, objective="orders", **bounds)
        result = design_lever(base, request)
        np.testing.assert_allclose(p_of(result.weight), p_free, rtol=1e-8, atol=1e-12)  # scale: ~1 (kg, kg m)
        assert result.criterion == pytest.approx(free_value, rel=1e-9)
    bounded = design_lever(base, box)
    assert bounded.weight[2] == pytest.approx(box.cg_y[0], rel=1e-9)
    assert bounded.criterion > free_value * (1 + 1e-6)
    assert in_box(bounded.weight, box)


def test_orders_weight_zero_drops_the_order(base):
    """Oracle: orders [1, 2] with weights [1, 0] is orders [1]."""
    one = design_lever(base, dataclasses.replace(base.design, objective="orders", orders=(1,)))
    two = design_lever(base, dataclasses.replace(base.design, objective="orders", orders=(1, 2), weights=(1.0, 0.0)))
    np.testing.assert_allclose(two.weight, one.weight, rtol=1e-9)
    assert two.criterion == pytest.approx(one.criterion, rel=1e-10)


# --------------------------------------------------------------------------
# 6. The compass search


def test_compass_design_approaches_the_lp_from_above(base, optimum):
    result = design_lever(base, method="compass")
    assert result.method == "compass"
    assert result.start == optimum.start
    assert result.criterion >= optimum.criterion - optimum.tolerance
    assert result.criterion <= optimum.criterion * (1 + 1e-3)
    assert result.cycles > 0 and result.evaluations > result.cycles
    assert result.evaluations <= 1 + 6 * result.cycles  # at most ±step on three coordinates per cycle
    assert in_box(result.weight, base.design)
    assert result.verified
    assert black_box(base, result.weight) == pytest.approx(result.criterion, rel=1e-9)


@settings(max_examples=25, deadline=None)
@given(center=st.lists(st.floats(-3, 3), min_size=2, max_size=3),
       scales=st.lists(st.floats(0.2, 5), min_size=3, max_size=3), angle=st.floats(0, math.pi))
def test_compass_search_finds_the_minimum_of_a_quadratic(center, scales, angle):
    n = len(center)
    rotation = np.eye(n)
    c, s = math.cos(angle), math.sin(angle)
    rotation[:2, :2] = [[c, -s], [s, c]]
    hessian = rotation @ np.diag(scales[:n]) @ rotation.T
    target = np.array(center)
    calls = []

    def f(x):
        calls.append(1)
        d = np.asarray(x) - target
        return float(d @ hessian @ d) + 7.0

    x, value, cycles, evaluations = compass_search(f, np.zeros(n), np.ones(n))
    assert evaluations == len(calls)
    assert cycles > 0
    assert value == f(x) and value >= 7.0
    np.testing.assert_allclose(x, target, atol=1e-4)
    assert value - 7.0 <= 1e-8


def test_compass_search_stops_after_max_cycles_and_never_leaves_a_feasible_region():
    calls = []

    def f(x):
        calls.append(np.array(x))
        return math.inf if x[0] < 1 else (x[0] - 0.0) ** 2 + (x[1] - 2.0) ** 2

    x, value, cycles, evaluations = compass_search(f, (3.0, 0.0), (0.5, 0.5), max_cycles=5)
    assert cycles == 5 and evaluations == len(calls)
    x, value, cycles, evaluations = compass_search(f, (3.0, 0.0), (0.5, 0.5))
    assert x[0] >= 1 and x[0] == pytest.approx(1.0, abs=1e-5) and x[1] == pytest.approx(2.0, abs=1e-5)


# --------------------------------------------------------------------------
# 7. The output scene


def test_output_scene_text_keeps_comments_drops_design_and_holds_the_weight(base, optimum):
    text = optimum.text
    parsed = tomllib.loads(text)
    assert "design" not in parsed and not re.search(r"(?m)^\s*\[design", text)
    # Every comment of the input before its [design] table survives verbatim.
    head = TEXT[: re.search(r"(?m)^\[design\]", TEXT).start()]
    for line in head.splitlines():
        if "#" in line and not line.lstrip().startswith(("mass", "cg")):
            assert line in text.splitlines(), line
    assert "# was \"1.3987 kg\"" in text and "was [\"48.29 mm\", \"22.79 mm\"]" in text
    # Apart from the weight and the [design] table the TOML is the input's.
    expected = {k: v for k, v in copy.deepcopy(BASE).items() if k != "design"}
    coupler = parsed["lever_balancer"][0]["coupler"]
    expected["lever_balancer"][0]["coupler"].update(mass=coupler["mass"], cg=coupler["cg"])
    assert parsed == expected
    loaded = optimum.scene.levers[0].coupler
    np.testing.assert_allclose((loaded.mass, *loaded.cg), optimum.weight, rtol=1e-12)
    assert loaded.inertia == base.levers[0].coupler.inertia
    assert optimum.scene.design is None
    assert hb.load_scene(mapping()).levers[0] == base.levers[0]  # sanity: same scene by mapping


def test_output_scene_name_and_description():
    scene = hb.load_scene(LEVER)
    result = hb.design(scene, name="opt", description="designed here")
    assert result.scene.name == "opt" and result.scene.description == "designed here"
    assert tomllib.loads(result.text)["engine"]["name"] == "opt"


def test_exact_criterion_of_the_output_and_its_tolerance(optimum):
    assert optimum.verified
    assert abs(optimum.exact_criterion - optimum.criterion) <= optimum.tolerance
    assert 0 < optimum.tolerance < 1e-8 * optimum.criterion
    assert black_box(optimum.scene, optimum.weight, optimum.request) == pytest.approx(optimum.exact_criterion,
                                                                                        rel=1e-12)
    assert criterion(signals(optimum.scene, optimum.request.signals), "peak_to_peak") == pytest.approx(
        optimum.criterion, rel=1e-10)


def test_designing_the_output_again_gives_the_same_weight(base, optimum):
    again = design_lever(optimum.scene, base.design)
    np.testing.assert_allclose(again.weight, optimum.weight, rtol=1e-9)
    assert again.criterion == pytest.approx(optimum.criterion, rel=1e-10)
    assert again.criterion_start == pytest.approx(optimum.criterion, rel=1e-10)


def test_breakdown_matches_the_black_box(base, optimum):
    """Per-signal criteria and the co-/counter-rotating force per order, before
    and after, by the DFT written here (|co| = |Z + i·T|/2, |counter| =
    |Z − i·T|/2, t = −sense·y)."""
    b = optimum.breakdown
    np.testing.assert_allclose(b["total"].values, [optimum.criterion_start, optimum.criterion], rtol=1e-12)
    for label, weight in (("start", optimum.start), ("optimum", optimum.weight)):
        values = signals(with_weight(base, weight), ("force_y", "force_z"))
        per_signal = [criterion(v[None], "peak_to_peak") for v in values]
        np.testing.assert_allclose(b["criterion"].sel(weight=label).values, per_signal, rtol=1e-9)
        np.testing.assert_allclose(b["criterion"].sel(weight=label).sum().item(), b["total"].sel(weight=label).item(),
                                   rtol=1e-12)
        fy, fz = values
        t = -base.sense * fy
        for k in range(1, b.sizes["order"]):
            z_k, t_k = order_phasor(fz, k), order_phasor(t, k)
            got = b["force"].sel(weight=label, order=k).values
            np.testing.assert_allclose(got, [abs(z_k + 1j * t_k) / 2, abs(z_k - 1j * t_k) / 2], rtol=1e-9,
                                       atol=1e-9 * abs(z_k) + 1e-9)


# --------------------------------------------------------------------------
# 9. The command line


def test_cli_design_writes_the_optimum(tmp_path, capsys, optimum):
    out = tmp_path / "out.toml"
    code, stdout, stderr = run_cli(capsys, "design", LEVER, "-o", out)
    assert code == 0, stderr
    assert "balance weight of lever balancer 'lever'" in stdout and "PASSED" in stdout
    assert f"wrote {out}" in stdout
    loaded = hb.load_scene(out)
    coupler = loaded.levers[0].coupler
    np.testing.assert_allclose((coupler.mass, *coupler.cg), optimum.weight, rtol=1e-12)
    assert out.read_text(encoding="utf-8") == optimum.text
    mine = black_box(loaded, optimum.weight, optimum.request)
    row = next(line for line in stdout.splitlines() if line.startswith("optimum"))
    assert float(row.split()[-1]) == pytest.approx(mine, rel=1e-7)
    assert float(row.split()[1]) == pytest.approx(optimum.weight[0], rel=1e-5)
    assert float(row.split()[3]) == pytest.approx(optimum.weight[2] * 1e3, rel=1e-5)


@pytest.mark.parametrize("where", ["missing_dir/out.toml", "out.txt", "input"])
def test_cli_design_bad_output_exits_2_and_writes_nothing(tmp_path, capsys, where):
    scene = tmp_path / "lever.toml"
    shutil.copy(LEVER, scene)
    out = scene if where == "input" else tmp_path / where
    code, stdout, stderr = run_cli(capsys, "design", scene, "-o", out)
    assert code == 2 and "harmbal: error:" in stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lever.toml"]
    assert scene.read_text(encoding="utf-8") == TEXT


def test_cli_design_exits_1_and_writes_nothing_when_the_exact_model_disagrees(tmp_path, capsys, monkeypatch):
    import harmbal.views.time as timedomain

    real = timedomain.simulate

    def off_by_one_newton(*args, **kwargs):
        ds = real(*args, **kwargs)
        return ds.assign(force=ds.force + 1.0 * (ds.angle < 1.0))

    monkeypatch.setattr(timedomain, "simulate", off_by_one_newton)
    out = tmp_path / "out.toml"
    code, stdout, stderr = run_cli(capsys, "design", LEVER, "-o", out)
    assert code == 1 and "FAILED" in stdout and "nothing written" in stderr
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_cli_design_with_several_speeds_exits_0(tmp_path, capsys):
    """The command works with several speeds (see
    test_several_speeds_design_at_the_first_and_verify)."""
    scene = tmp_path / "lever.toml"
    scene.write_text(TEXT.replace('speed = "3000 rpm"', 'speed = ["3000 rpm", "5000 rpm", "7000 rpm"]'),
                     encoding="utf-8")
    out = tmp_path / "out.toml"
    code, stdout, stderr = run_cli(capsys, "design", scene, "-o", out)
    assert code == 0, stderr
    assert out.is_file()


def test_cli_run_prints_lever_and_joint_tables_and_archives_joints(tmp_path, capsys, base):
    import netCDF4

    out = tmp_path / "lever.nc"
    code, stdout, stderr = run_cli(capsys, "run", LEVER, "-o", out)
    assert code == 0, stderr
    assert "Free force per order without and with the lever balancers at 3000 rpm" in stdout
    assert "joint forces over the revolution" in stdout and "minimum transmission angle" in stdout
    for joint in ("lever: A", "lever: B", "lever: C", "D ", "E1", "F1", "W1"):
        assert f"\n{joint}" in stdout, joint
    # The lever table's order-1 row against the DFT of hb.simulate, with and without the lever.
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Free force per order without and with"))
    row = lines[start + 2].split()
    assert row[0] == "1"
    expected = []
    for scene in (dataclasses.replace(base, levers=()), base):
        fy, fz = signals(scene, ("force_y", "force_z"))
        z1, t1 = order_phasor(fz, 1), order_phasor(-base.sense * fy, 1)
        expected += [abs(z1 + 1j * t1) / 2, abs(z1 - 1j * t1) / 2]
    np.testing.assert_allclose([float(v) for v in row[1:]], expected, rtol=1e-4)
    # The archive's /joints group round-trips, and netCDF4 reads it.
    tree = hb.open_archive(out)
    assert "joints" in tree.children
    reference = hb.analyse(base)["joints"].to_dataset()
    xr.testing.assert_identical(tree["joints"].to_dataset(), reference)
    with netCDF4.Dataset(out) as nc:
        assert "joints" in nc.groups
        group = nc.groups["joints"]
        np.testing.assert_array_equal(group.variables["joint_force"][:], reference["joint_force"].values)
        assert group.variables["joint_force"].dimensions == ("joint", "axis", "angle")


# --------------------------------------------------------------------------
# 10. Validation of [design.lever]


def _bad(edit):
    data = mapping()
    edit(data)
    return data


BAD = [
    (lambda d: d["design"]["lever"].update(signal=["force_y"]), "design.lever.signal", "did you mean 'signals'"),
    (lambda d: d["design"]["lever"].update(weights=[1.0]), "design.lever.weights", "orders"),
    (lambda d: d["design"].update(objective="orders", orders=[1, 2]) or d["design"]["lever"].update(weights=[1.0]),
     "design.lever.weights", "number in [0, 1e6] per order"),
    (lambda d: d["design"].update(orders=[1]), "design.orders", 'objective = "orders"'),
    (lambda d: d["design"]["lever"].update(cg_x=["50 mm", "10 mm"]), "design.lever.cg_x", "low <= high"),
    (lambda d: d["design"]["lever"].update(mass=["3 kg", "1 kg"]), "design.lever.mass", "low <= high"),
    (lambda d: d["design"]["lever"].update(mass=["-1 kg", "2 kg"]), "design.lever.mass", "negative"),
    (lambda d: d["design"]["lever"].update(mass=["1 kg"]), "design.lever.mass", ""),
    (lambda d: d["design"]["lever"].update(cg_y=["1 kg", "2 kg"]), "design.lever.cg_y", ""),
    (lambda d: d["design"]["lever"].update(signals=["moment_x"]), "design.lever.signals", ""),
    (lambda d: d["design"].update(objective="least_squares"), "design.objective", ""),
    (lambda d: d["design"].update(counterweights=[{"label": "cw", "planes": ["-50 mm", "50 mm"]}]), "design",
     "counterweights"),
]


@pytest.mark.parametrize("edit, key, words", BAD)
def test_bad_lever_design_table_is_refused_naming_the_key(edit, key, words):
    with pytest.raises(SceneError) as info:
        hb.load_scene(_bad(edit))
    assert any(p.key == key or p.key.startswith(key + "[") for p in info.value.problems), str(info.value)
    assert words in str(info.value)


@pytest.mark.parametrize("edit, key, words", [BAD[0], BAD[2], BAD[5], BAD[11]])
def test_cli_design_on_a_bad_lever_design_table_exits_2(tmp_path, capsys, edit, key, words):
    import tomli_w

    scene = tmp_path / "bad.toml"
    scene.write_text(tomli_w.dumps(_bad(edit)), encoding="utf-8")
    out = tmp_path / "out.toml"
    code, stdout, stderr = run_cli(capsys, "design", scene, "-o", out)
    assert code == 2
    assert str(scene) in stderr and key in stderr
    assert not out.exists()


def test_unknown_lever_label_is_a_design_error_and_exit_2(tmp_path, capsys):
    import tomli_w

    data = mapping(label="levr")
    scene = hb.load_scene(data)  # the label is checked against the levers when designing
    with pytest.raises(hb.DesignError, match="design.lever.label"):
        hb.design(scene)
    path = tmp_path / "bad.toml"
    path.write_text(tomli_w.dumps(data), encoding="utf-8")
    code, _, stderr = run_cli(capsys, "design", path, "-o", tmp_path / "out.toml")
    assert code == 2 and "design.lever.label" in stderr and "'levr'" in stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_valid_lever_design_tables_load():
    scene = hb.load_scene(mapping(label="lever"))
    assert scene.design == LeverDesignRequest("lever", "peak_to_peak", ("force_y", "force_z"), (1,), (),
                                              (0.5, 5.0), (0.0, 0.1), (-0.06, 0.06))
    data = mapping(weights=[1, 0.5], mass=None, cg_x=None, cg_y=None)
    data["design"].update(objective="orders", orders=[1, 2])
    request = hb.load_scene(data).design
    assert (request.objective, request.orders, request.weights) == ("orders", (1, 2), (1.0, 0.5))
    assert request.mass is None and request.cg_x is None and request.cg_y is None
