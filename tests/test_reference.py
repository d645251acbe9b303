"""The mpmath reference of harmbal/reference.py: against harmbal's exact model, against the
classical series of the centric slider-crank, and against itself with twice the samples."""

from __future__ import annotations

import dataclasses

import mpmath as mp
import numpy as np
import pytest

import harmbal as hb
from harmbal.reference import reference_phasors, reference_samples

MAX_ORDER = 12
#: harmbal (float64, 256 samples per revolution) against the reference, relative to its scales.
RTOL_FLOAT = 1e-13


def _harmbal_phasors(scene, samples=256):
    ds = hb.simulate(scene, samples_per_rev=samples)
    if "speed" in ds.dims:
        ds = ds.isel(speed=0)
    orders = hb.order_spectrum(ds, max_order=MAX_ORDER)
    return orders.force.values, orders.moment.values


def _assert_agrees(scene):
    ref = reference_phasors(scene, MAX_ORDER)
    force, moment = _harmbal_phasors(scene)
    assert ref.force_scale > 0 and ref.moment_scale > 0
    np.testing.assert_allclose(force, ref.force, rtol=0, atol=RTOL_FLOAT * ref.force_scale)
    np.testing.assert_allclose(moment, ref.moment, rtol=0, atol=RTOL_FLOAT * ref.moment_scale)


# --------------------------------------------------------------------------
# 1. harmbal's exact model


@pytest.mark.parametrize("name", [
    "single", "test-single", "test-single-balanced", "inline-4", "inline-4-lanchester", "v8-cross-plane",
    "w24-broad-arrow", "tractor-3cyl-balanced", "inline-3-balanced", "v6-90-split-pin-balanced",
])
def test_bundled_scenes(name):
    _assert_agrees(hb.load_scene(f"datasets/engines/{name}.toml"))


def _random_v_engine(seed, rotation, *, effects=None, rod="rigid"):
    """A four-cylinder 'V' on two throws with λ up to 0.9, pin and cylinder offsets, off-axis
    piston and rod CGs, throw and crankshaft unbalances, a crankshaft with products of inertia,
    a balance shaft with a couple and a Lanchester pair, about a random reference point."""
    rng = np.random.default_rng(seed)
    u = rng.uniform
    gamma = u(0.5, 1.8)
    cylinders = []
    for j, throw in enumerate((0.0, u(0.5, 6.0))):
        for side in (-1, 1):
            r = u(0.03, 0.07)
            l = r / u(0.2, 0.9)
            slack = l - r  # the offsets must leave the crank train able to assemble: |e| < l − r
            cylinders.append({
                "throw": throw, "bank": side * gamma / 2 + u(-0.1, 0.1), "axial_position": 0.1 * j + 0.02 * side,
                "geometry": {"crank_radius": r, "rod_length": l, "pin_offset": u(-0.25, 0.25) * slack,
                             "cylinder_offset": u(-0.25, 0.25) * slack},
                "piston": {"mass": u(0.3, 2.0), "cg_offset": [u(-0.01, 0.02), u(-0.003, 0.003)]},
                "rod": {"mass": u(0.3, 1.5), "cg_from_big_end": u(0.2, 0.45) * l, "cg_offset": u(-0.004, 0.004),
                        "inertia": u(0.002, 0.02)},
                "throw_unbalance": [{"unbalance": u(0.005, 0.05), "angle": u(-3, 3), "axial_offset": u(-0.03, 0.03)}],
            })
    return hb.load_scene({
        "engine": {"name": "random-v", "speed": u(100, 700), "rotation": rotation,
                   "reference_point": list(u(-0.1, 0.1, 3))},
        "model": {"effects": effects or ["reciprocating", "rotating", "rod_inertia", "mass_torque", "balancers"],
                  "rod": rod},
        "cylinder": cylinders,
        "crankshaft_unbalance": [{"unbalance": u(0.01, 0.1), "angle": u(-3, 3), "axial_position": u(-0.05, 0.2)}],
        "crankshaft": {"mass": 20.0, "cg_offset": [u(-1e-3, 1e-3), u(-1e-3, 1e-3)], "axial_position": u(0, 0.1),
                       "products_of_inertia": {"xy": u(-0.03, 0.03), "xz": u(-0.03, 0.03), "convention": "tensor"}},
        "balance_shaft": [{"ratio": -1, "axis_position": [u(-0.1, 0.1), u(-0.2, 0.0)], "couple": u(0.001, 0.02),
                           "couple_angle": u(-3, 3),
                           "unbalance": [{"unbalance": u(0.005, 0.02), "angle": u(-3, 3),
                                          "axial_position": u(-0.1, 0.1)}]}],
        "lanchester_pair": [{"order": 2, "unbalance": u(0.001, 0.01), "angle": u(-3, 3), "phase": u(-1, 1),
                             "axial_position": u(-0.1, 0.1), "heights": [u(-0.2, 0), u(-0.2, 0)],
                             "lateral": [u(-0.1, 0), u(0, 0.1)]}],
    })


@pytest.mark.parametrize("seed,rotation", [(1, "clockwise"), (2, "counterclockwise"), (3, "clockwise"),
                                           (4, "counterclockwise")])
def test_random_v_engines(seed, rotation):
    _assert_agrees(_random_v_engine(seed, rotation))


@pytest.mark.parametrize("effects,rod", [
    (["reciprocating"], "rigid"),
    (["rotating", "balancers"], "rigid"),
    (["rod_inertia", "mass_torque"], "rigid"),
    (["reciprocating", "rotating", "mass_torque"], "two_point"),
    (["reciprocating", "rod_inertia", "mass_torque"], "two_point_couple"),
])
def test_effect_subsets_and_rod_models(effects, rod):
    _assert_agrees(_random_v_engine(5, "counterclockwise", effects=effects, rod=rod))


# --------------------------------------------------------------------------
# 2. Closed form: centric single cylinder, piston mass only


def _series_force_z(m, r, l, omega, orders):
    """Order phasors of F_z = −m ω² x'' for x(θ) = r cos θ + l·sqrt(1 − λ² sin²θ), from the binomial
    series sqrt(1 − u) = Σ_j b_j u^j and sin^{2j}θ = 4^{−j}(C(2j, j) + 2 Σ_i (−1)^i C(2j, j − i) cos 2iθ):
    X_1 = r, X_{2i} = l Σ_{j≥i} b_j λ^{2j} 4^{−j} 2 (−1)^i C(2j, j − i), and C_k(F_z) = m ω² k² X_k."""
    lam2 = (r / l) ** 2
    out = {}
    for k in orders:
        if k == 1:
            x = r
        elif k % 2:
            x = mp.mpf(0)
        else:
            i, x, b, j = k // 2, mp.mpf(0), mp.mpf(1), 0
            while True:
                if j >= i:
                    term = l * b * (lam2 / 4) ** j * 2 * (-1) ** i * mp.binomial(2 * j, j - i)
                    x += term
                    if abs(term) < mp.mpf("1e-60") * r:
                        break
                j += 1
                b *= (j - mp.mpf(3) / 2) / j  # b_j = (−1)^j·C(1/2, j)
        out[k] = m * omega**2 * k * k * x
    return out


@pytest.mark.parametrize("lam", ["0.3", "0.6", "0.9"])
def test_centric_piston_series(lam):
    r, omega, m = 0.05, 300.0, 1.3
    l = r / float(lam)
    scene = hb.load_scene({
        "engine": {"name": "series", "speed": omega},
        "model": {"effects": ["reciprocating"]},
        "geometry": {"crank_radius": r, "rod_length": l},
        "piston": {"mass": m},
        "rod": {"mass": 0.5, "cg_from_big_end": 0.0, "inertia": 0.001},  # small-end share m·a/l = 0
        "cylinder": [{}],
    })
    ref = reference_phasors(scene, 6)
    with mp.workdps(60):
        expected = _series_force_z(mp.mpf(m), mp.mpf(r), mp.mpf(l), mp.mpf(omega), range(1, 7))
        scale = mp.mpf(m) * r * mp.mpf(omega) ** 2
        for k, value in expected.items():
            assert abs(ref.force_mp[k][2] - value) < mp.mpf("1e-40") * scale, k
            assert abs(ref.force_mp[k][0]) + abs(ref.force_mp[k][1]) < mp.mpf("1e-40") * scale
        assert abs(expected[2]) > mp.mpf("0.2") * scale  # the second order really is there
        assert abs(ref.force_mp[0][2]) < mp.mpf("1e-40") * scale


# --------------------------------------------------------------------------
# 3. Convergence in the number of samples


@pytest.mark.parametrize("lam", [0.5, 0.9, 0.95])
def test_samples_converged(lam):
    """Doubling M changes nothing at 1e-40 (λ of every cylinder set to ``lam``, offsets 0.3 (l − r))."""
    scene = _random_v_engine(6, "clockwise")
    cylinders = tuple(dataclasses.replace(c, rod_length=c.crank_radius / lam, cylinder_offset=0.0,
                                          pin_offset=0.3 * (c.crank_radius / lam - c.crank_radius))
                      for c in scene.cylinders)
    scene = dataclasses.replace(scene, cylinders=cylinders)
    n = reference_samples(scene, MAX_ORDER)
    assert n % 8 == 0
    one = reference_phasors(scene, MAX_ORDER)
    two = reference_phasors(scene, MAX_ORDER, samples=2 * n)
    assert one.samples == n and two.samples == 2 * n
    for mine, theirs, scale in ((one.force_mp, two.force_mp, one.force_scale),
                                (one.moment_mp, two.moment_mp, one.moment_scale)):
        worst = max(abs(a - b) for ka, kb in zip(mine, theirs) for a, b in zip(ka, kb))
        assert worst < 1e-40 * scale


def test_samples_grow_with_lambda():
    single = hb.load_scene("datasets/engines/single.toml")

    def samples(lam):
        cyl = single.cylinders[0]
        return reference_samples(dataclasses.replace(single, cylinders=(
            dataclasses.replace(cyl, rod_length=cyl.crank_radius / lam),)), MAX_ORDER)

    counts = [samples(lam) for lam in (0.25, 0.45, 0.7, 0.9, 0.95)]
    assert counts == sorted(counts) and counts[0] >= 2 * MAX_ORDER + 2


# --------------------------------------------------------------------------
# 4. What is refused; precision left alone


def test_lever_scenes_refused():
    scene = hb.load_scene("datasets/engines/lever-single.toml")
    with pytest.raises(ValueError, match="lever balancers are not supported"):
        reference_phasors(scene, MAX_ORDER)


def test_series_piston_refused():
    scene = hb.load_scene("datasets/engines/single.toml")
    scene = dataclasses.replace(scene, model=dataclasses.replace(scene.model, piston="series"))
    with pytest.raises(ValueError, match="exact piston model"):
        reference_phasors(scene, MAX_ORDER)


def test_global_precision_untouched():
    before = mp.mp.dps
    ref = reference_phasors(hb.load_scene("datasets/engines/single.toml"), 4, dps=40)
    assert mp.mp.dps == before
    assert ref.dps == 40 and ref.force.shape == (5, 3) and ref.force.dtype == np.complex128
