"""Balance shafts, Lanchester pairs and crankshaft CAD data, judged by closed
forms written here and by the thesis's published moments."""

import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_close_to_scale
from hypothesis import given, settings
from hypothesis import strategies as st

import harmbal as hb

DATASETS = Path(__file__).resolve().parent.parent / "datasets" / "engines"

#: One small cylinder so that scenes load; its loads are subtracted or switched off.
BASE = {
    "engine": {"name": "shafts", "speed": "3000 rpm"},
    "model": {"effects": ["rotating", "balancers"], "rod": "two_point"},
    "geometry": {"crank_radius": "40 mm", "rod_length": "140 mm"},
    "piston": {"mass": "0.5 kg"},
    "rod": {"mass_big_end": "0.3 kg", "mass_small_end": "0.1 kg"},
    "cylinder": [{}],
}


def shaft_part(scene):
    """Time-domain force and moment of everything that is not a cylinder."""
    ds = hb.simulate(scene, per_cylinder=True)
    return ds.force - ds.force_cylinder.sum("cylinder"), ds.moment - ds.moment_cylinder.sum("cylinder"), ds


def test_tractor_thesis_moments_at_theta_zero():
    # reference-engines.md A: at θ = 0 and 2460 rpm the crankshaft exerts M_x = 2828.1,
    # M_y = 1759.1 N m and the balance shaft M_x = 1185.9, M_y = -684.5 N m in CAD axes
    # (CAD x, y = harmbal y, z).
    with open(DATASETS / "tractor-3cyl-balanced.toml", "rb") as fh:
        data = tomllib.load(fh)
    expected = {"crankshaft": (2828.1, 1759.1), "balance_shaft": (1185.9, -684.5)}
    for element, (m_y, m_z) in expected.items():
        only = copy.deepcopy(data)
        only.pop("balance_shaft" if element == "crankshaft" else "crankshaft")
        _, moment, _ = shaft_part(hb.load_scene(only))
        at_zero = moment.isel(angle=0).values
        assert abs(at_zero[0]) < 1e-9 * abs(m_y)
        np.testing.assert_allclose(at_zero[1:], [m_y, m_z], rtol=6e-4)


def test_tractor_balance_shaft_cancels_most_of_the_counter_rotating_moment():
    plain = hb.stars(hb.load_scene(DATASETS / "tractor-3cyl.toml"))
    balanced = hb.stars(hb.load_scene(DATASETS / "tractor-3cyl-balanced.toml"))
    before = abs(plain.moment_rotating.sel(order=1, rotation="counter").item())
    after = abs(balanced.moment_rotating.sel(order=1, rotation="counter").item())
    assert before > 1300 and after < 0.02 * before


@pytest.mark.parametrize("rotation, sense", [("clockwise", -1), ("counterclockwise", 1)])
@pytest.mark.parametrize("ratio", [1, -1, 2, -2, 3])
def test_static_unbalance_on_an_offset_shaft_closed_form(rotation, sense, ratio):
    u, alpha, x_u, y_a, z_a = 0.004, 0.7, 0.12, -0.05, -0.09
    data = copy.deepcopy(BASE)
    data["engine"]["rotation"] = rotation
    data["engine"]["reference_point"] = [0.01, 0.02, -0.03]
    data["balance_shaft"] = [{"ratio": ratio, "axis_position": [y_a, z_a],
                              "unbalance": [{"unbalance": u, "angle": alpha, "axial_position": x_u}]}]
    force, moment, ds = shaft_part(hb.load_scene(data))
    theta = ds.angle.values
    w2 = float(ds.speed) ** 2
    # The unbalance points at nθ + α from +z, turning in the crank's direction
    # for n > 0; y = -sense·(component 90° ahead of z).
    f_z = u * ratio**2 * w2 * np.cos(ratio * theta + alpha)
    f_y = -sense * u * ratio**2 * w2 * np.sin(ratio * theta + alpha)
    f = np.stack([np.zeros_like(f_z), f_y, f_z])
    r = np.array([x_u, y_a, z_a]) - np.array([0.01, 0.02, -0.03])
    m = np.cross(r, f.T).T
    scale = u * ratio**2 * w2
    np.testing.assert_allclose(force.values, f, atol=1e-13 * scale)
    np.testing.assert_allclose(moment.values, m, atol=1e-13 * scale)


def test_couple_given_as_moment_and_as_products_agree():
    # A couple of size C at angle γ (w-plane) equals products J_xy = C cos γ,
    # J_xz = sense·C sin γ (integral convention) = minus those in the tensor convention.
    c, gamma = 0.02, 0.9
    for rotation, sense in (("clockwise", -1), ("counterclockwise", 1)):
        results = []
        for shaft in ({"couple": c, "couple_angle": gamma},
                      {"products_of_inertia": {"xy": c * math.cos(gamma), "xz": sense * c * math.sin(gamma),
                                               "convention": "integral"}},
                      {"products_of_inertia": {"xy": -c * math.cos(gamma), "xz": -sense * c * math.sin(gamma),
                                               "convention": "tensor"}}):
            data = copy.deepcopy(BASE)
            data["engine"]["rotation"] = rotation
            data["balance_shaft"] = [{"ratio": -2, **shaft}]
            results.append(shaft_part(hb.load_scene(data))[1].values)
        np.testing.assert_allclose(results[1], results[0], atol=1e-12 * np.abs(results[0]).max())
        np.testing.assert_allclose(results[2], results[0], atol=1e-12 * np.abs(results[0]).max())


def test_two_point_masses_as_a_couple():
    # Masses m at (x = ±a, z = ±ρ) on a shaft turning at n×: J_xz = 2 m a ρ, so
    # the moment on the block at θ = 0 is M_y = -J_xz (nω)²; check it against the
    # same body written as two static unbalances.
    m, a, rho, n = 0.3, 0.08, 0.02, -1
    as_couple = copy.deepcopy(BASE)
    as_couple["balance_shaft"] = [{"ratio": n, "products_of_inertia": {"xz": 2 * m * a * rho,
                                                                       "convention": "integral"}}]
    as_masses = copy.deepcopy(BASE)
    as_masses["balance_shaft"] = [{"ratio": n, "unbalance": [
        {"unbalance": m * rho, "angle": 0.0, "axial_position": a},
        {"unbalance": m * rho, "angle": math.pi, "axial_position": -a}]}]
    f1, m1, ds = shaft_part(hb.load_scene(as_couple))
    f2, m2, _ = shaft_part(hb.load_scene(as_masses))
    w2 = float(ds.speed) ** 2
    assert float(m1.isel(angle=0).sel(axis="y")) == pytest.approx(-2 * m * a * rho * n**2 * w2, rel=1e-12)
    np.testing.assert_allclose(m1.values, m2.values, atol=1e-12 * float(np.abs(m2).max()))
    np.testing.assert_allclose(f2.values, 0, atol=1e-12 * m * rho * w2)


def test_lanchester_pair_makes_a_standing_vector_and_a_roll_moment():
    u, order, alpha, z1, z2 = 0.002, 2, 0.0, -0.10, -0.16
    data = copy.deepcopy(BASE)
    data["lanchester_pair"] = [{"order": order, "unbalance": u, "angle": alpha, "heights": [z1, z2]}]
    scene = hb.load_scene(data)
    assert [s.ratio for s in scene.shafts] == [2, -2]
    force, moment, ds = shaft_part(scene)
    theta, w2, sense = ds.angle.values, float(ds.speed) ** 2, -1
    amplitude = u * order**2 * w2
    np.testing.assert_allclose(force.sel(axis="z").values, 2 * amplitude * np.cos(order * theta),
                               atol=1e-12 * amplitude)
    np.testing.assert_allclose(force.sel(axis="y").values, 0, atol=1e-12 * amplitude)
    # roll M_x = -z1·F_y1 - z2·F_y2 with F_y of the ±n shafts = ∓(-sense)·A·sin(nθ)
    f_y1 = -sense * amplitude * np.sin(order * theta)
    np.testing.assert_allclose(moment.sel(axis="x").values, -z1 * f_y1 + z2 * f_y1, atol=1e-12 * amplitude)


def test_lanchester_pair_cancels_the_inline_four_second_order_force():
    with open(DATASETS / "inline-4.toml", "rb") as fh:
        data = tomllib.load(fh)
    data["model"] = {"effects": ["reciprocating", "balancers"]}
    plain = hb.stars(hb.load_scene(data))
    # Size and phase of the pair from the free force: a vertical standing vector
    # F_z = Re(C e^{2iθ}) with C real (θ = 0 at TDC of cylinders 1 and 4).
    c = plain.force.isel(speed=0).sel(order=2, axis="z").item()
    w = float(plain.speed.isel(speed=0))
    assert abs(c.imag) < 1e-9 * abs(c)
    u = abs(c) / (2 * 4 * w**2)
    data["lanchester_pair"] = [{"order": 2, "unbalance": u, "angle": 0.0 if c.real < 0 else math.pi,
                                "heights": ["-120 mm", "-120 mm"]}]
    scene = hb.load_scene(data)
    orders = hb.order_spectrum(hb.simulate(scene))
    residual = np.abs(orders.force.sel(order=2)).max()
    assert float(residual) < 1e-9 * abs(c)
    assert hb.verify_orders(scene).attrs["passed"] == "yes"


def _signed(lo, hi):
    # Within the documented ranges (docs/scenes.md, "Ranges"): hypothesis's 1e-300 near 0 is refused, so 0.
    return st.floats(lo, hi).map(lambda v: 0.0 if abs(v) < 1e-12 else v)


@settings(max_examples=25, deadline=None)
@given(ratio=st.sampled_from([-3, -2, -1, 1, 2, 3]), u=st.floats(1e-4, 0.05), angle=_signed(-3, 3),
       x=_signed(-0.3, 0.3), y=_signed(-0.2, 0.2), z=_signed(-0.2, 0.2), couple=_signed(0, 0.05),
       couple_angle=_signed(-3, 3), clockwise=st.booleans())
def test_order_domain_agrees_with_time_domain(ratio, u, angle, x, y, z, couple, couple_angle, clockwise):
    data = copy.deepcopy(BASE)
    data["engine"]["rotation"] = "clockwise" if clockwise else "counterclockwise"
    data["engine"]["reference_point"] = [0.05, -0.01, 0.02]
    data["model"] = {"effects": ["reciprocating", "rotating", "balancers"], "rod": "two_point"}
    data["balance_shaft"] = [{"ratio": ratio, "axis_position": [y, z], "couple": couple, "couple_angle": couple_angle,
                              "unbalance": [{"unbalance": u, "angle": angle, "axial_position": x}]}]
    data["crankshaft"] = {"mass": 20.0, "cg_offset": [1e-4, -2e-4], "axial_position": 0.03,
                          "products_of_inertia": {"xy": 0.01, "xz": -0.02, "convention": "tensor"}}
    assert hb.verify_orders(hb.load_scene(data)).attrs["passed"] == "yes"


def test_crankshaft_cad_static_unbalance_is_its_mass_times_cg_offset():
    data = copy.deepcopy(BASE)
    data["crankshaft"] = {"mass": 50.0, "cg_offset": ["0.3 mm", "-0.4 mm"], "axial_position": "20 mm"}
    force, moment, ds = shaft_part(hb.load_scene(data))
    w2 = float(ds.speed) ** 2
    # At θ = 0 the CG offset is as given: the force points along it.
    np.testing.assert_allclose(force.isel(angle=0).values, [0, 50 * 3e-4 * w2, -50 * 4e-4 * w2], rtol=1e-12)
    np.testing.assert_allclose(np.hypot(force.sel(axis="y"), force.sel(axis="z")), 50 * 5e-4 * w2, rtol=1e-12)


@pytest.mark.parametrize("key, value, rule", [
    ("balance_shaft", [{"ratio": 0}], "non-zero integer"),
    ("balance_shaft", [{"axis_position": [0, 0]}], "missing: the speed ratio"),
    ("balance_shaft", [{"ratio": -1, "products_of_inertia": {"xy": 0.01}}], "name the sign convention"),
    ("balance_shaft", [{"ratio": -1, "products_of_inertia": {"xy": 0.01, "convention": "cad"}}], "must be one of"),
    ("balance_shaft", [{"ratio": 1, "couple": 0.01, "products_of_inertia": {"xy": 0.0, "convention": "tensor"}}],
     "not both"),
    ("balance_shaft", [{"ratio": 1, "couple_angle": "10 deg"}], "only with couple"),
    ("balance_shaft", {"ratio": 1}, "array of tables"),
    ("lanchester_pair", [{"unbalance": 0.01}], "missing: the order"),
    ("lanchester_pair", [{"order": 2, "unbalance": 0.01, "heights": [0.1]}], "list of 2"),
    ("crankshaft", {"cg_offset": [0, 0]}, "missing required key"),
])
def test_bad_balancers_are_refused_with_the_key_named(key, value, rule):
    data = copy.deepcopy(BASE)
    data[key] = value
    with pytest.raises(hb.SceneError) as info:
        hb.load_scene(data)
    assert rule in str(info.value)
    assert key in str(info.value)


def test_balancers_effect_switches_every_element_off(monkeypatch):
    import harmbal.model.evaluate

    def fail(*args, **kwargs):
        raise AssertionError("shaft loads computed although 'balancers' is not simulated")

    monkeypatch.setattr(harmbal.model.evaluate, "shaft_loads", fail)
    data = copy.deepcopy(BASE)
    data["model"]["effects"] = ["rotating"]
    data["lanchester_pair"] = [{"order": 2, "unbalance": 0.01}]
    scene = hb.load_scene(data)
    force, moment, _ = shaft_part(scene)
    assert float(np.abs(force).max()) < 1e-9 and float(np.abs(moment).max()) < 1e-9
    assert hb.stars(scene).force.sel(order=2).values.tolist() == [0, 0, 0]


def test_a_fast_shaft_does_not_alias_onto_the_orders_kept():
    """A shaft at 47× is one harmonic above every order kept (K = 12): orders
    0 … 12 are those of the engine without it. With 48 samples per
    revolution it would fold onto order 1, so the automatic sampling takes
    more and a fixed count that low is refused."""
    data = {"engine": {"name": "a", "speed": 100.0}, "geometry": {"crank_radius": 0.05, "rod_length": 0.2},
            "piston": {"mass": 1.0}, "rod": {"mass": 0.5, "cg_from_big_end": 0.05, "inertia": 0.002},
            "cylinder": [{}]}
    bare = hb.order_spectrum(hb.simulate(hb.load_scene(data)))
    fast = dict(data, balance_shaft=[{"ratio": 47, "unbalance": [{"unbalance": 1e-4, "angle": 0.0}]}])
    with_shaft = hb.order_spectrum(hb.simulate(hb.load_scene(fast)))
    assert with_shaft.attrs["samples_per_rev"] > 47 + 12
    scale = float(np.abs(bare.force).max())
    assert_close_to_scale(with_shaft.force.values, bare.force.values, scale)
    with pytest.raises(hb.SceneError, match="sampling.samples_per_rev.*alias"):
        hb.load_scene(dict(fast, sampling={"samples_per_rev": 48}))
