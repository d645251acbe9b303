"""Designs that are physically sane, and a verify that cannot be fooled (issue 32, item 4).

Oracles: closed forms of what a request can do (a pair's roll moment is the height difference
times its lateral force, a couple is the plane spacing times the force), the engine's own load
scale computed here from the evaluation's bodies, and hb.verify (the exact time-domain model)
judging every design hb.design writes. Every tolerance is relative to the engine's load scale.
"""

import copy
import dataclasses
import math
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
import tomli_w

import harmbal as hb
from harmbal.balance.sanity import ELEMENT_LIMIT, LEVERAGE_MIN, engine_length
from harmbal.balance.solvers import DesignError
from harmbal.balance.variants import design_basis
from harmbal.balance.verify import VerifyError, engine_scales
from harmbal.cli import main
from harmbal.model.evaluate import evaluate
from harmbal.orders.linear import linear_phasors
from harmbal.orders.spectrum import ZERO, ZERO_RTOL
from harmbal.scene import scene_from_text

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
#: The bundled scenes with a [design] table designed by order (the lever's is an LP of its own).
DESIGNED = ("inline-3", "inline-4", "test-single", "tractor-3cyl-balanced", "v6-90-split-pin")


def raw(name: str) -> dict:
    return tomllib.loads((ENGINES / f"{name}.toml").read_text(encoding="utf-8"))


def scene_of(data: dict, name: str = "scene.toml"):
    return scene_from_text(tomli_w.dumps(data), name)


def design_and_verify(scene):
    """hb.design and hb.verify of its scene, failing on any warning numpy or harmbal raises."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        designed = hb.design(scene)
        return designed, hb.verify(designed.scene)


def assert_agree(designed, check):
    """What design calls cancelled verifies as zero (class and verdict), what it predicts the exact model
    confirms, and verify's tolerance is the engine's own zero level (plus aliasing), nothing larger."""
    ds = designed.dataset
    targeted, cancelled = ds.targeted.values, ds.cancelled.values
    shape = (-1,) + targeted.shape  # verify has a speed dimension for several speeds
    exact_class = check.exact_class.values.reshape(shape)
    passed = check.passed.values.reshape(shape)
    assert check.attrs["passed"] == "yes", (check.difference.values, check.tolerance.values)
    assert passed.all()
    assert (exact_class[:, cancelled & targeted] == ZERO).all(), (cancelled, exact_class)
    # The tolerance: the share of "before" the request allows (0 for a design by harmbal), ZERO_RTOL of the
    # engine's scale without any balancer element, and the aliasing estimate (far below it at 2048 samples).
    force, moment = engine_scales(designed.scene)
    w2 = np.asarray(designed.scene.speeds) ** 2
    scale = np.where(check.component_units.values == "N", force, moment)[None, None, :] * w2[:, None, None]
    tolerance = check.tolerance.values.reshape((len(w2),) + targeted.shape)
    assert (tolerance >= ZERO_RTOL * scale * (1 - 1e-12)).all()
    assert (tolerance <= 1.01 * ZERO_RTOL * scale).all()


# --------------------------------------------------------------------------
# 1. Ill-conditioned requests are refused, naming the keys to change


def test_pair_at_nearly_one_height_cannot_make_a_roll_moment():
    # Closed form: the pair's roll moment is (z₊ − z₋) × its lateral force. With the shafts 1 µm apart,
    # the 15.4 N m roll of reference engine B would take a force of 15.4 N m / 1 µm = 1.5e7 N, 600 times
    # the engine's 26 kN peak force.
    data = raw("test-single")
    data["design"]["cancel"] = ["roll"]
    data["design"]["lanchester_pair"][0].update(heights=["0.001 mm", "0 mm"], lateral=["0 mm", "0 mm"])
    with pytest.raises(DesignError) as info:
        hb.design(scene_of(data))
    message = str(info.value)
    assert "scene.toml" in message and "ill-conditioned" in message
    assert "design.lanchester_pair 'first-order balance shafts'" in message and "heights" in message
    # The leverage: roll per unit of gross force, per the engine's length (the farthest cylinder or
    # crank radius + rod length: 275 mm here).
    scene = scene_of(data)
    assert engine_length(scene) == pytest.approx(0.060 + 0.215, rel=1e-15)
    leverage = float(re.search(r"leverage ([0-9.e+-]+)", message).group(1))
    assert leverage == pytest.approx(1e-6 / engine_length(scene), rel=1e-2)
    # The same pair 100 mm apart is well-posed and cancels it.
    data["design"]["lanchester_pair"][0]["heights"] = ["100 mm", "0 mm"]
    designed, check = design_and_verify(scene_of(data))
    assert designed.feasible and bool(designed.dataset.cancelled.sel(order=1, component="roll"))
    assert_agree(designed, check)


def test_the_design_refuses_below_the_reader_too():
    # A request built in Python skips the reader's ranges: a pair 1e-300 mm apart (the 1.5e303 kg mm
    # design) is refused by the design itself.
    scene = hb.load_scene(ENGINES / "test-single.toml")
    pair = dataclasses.replace(scene.design.candidates[1], heights=(1e-303, 0.0), lateral=(0.0, 0.0))
    request = dataclasses.replace(scene.design, cancel=("roll",), candidates=(scene.design.candidates[0], pair))
    with pytest.raises(DesignError, match=r"ill-conditioned.*design\.lanchester_pair.*heights"):
        hb.design(scene, request)


@pytest.mark.parametrize("mass_factor", [1.0, 1e-6])
def test_counterweight_planes_a_micrometre_apart_are_refused_whatever_the_engine(mass_factor):
    # Two counterweight planes 1 µm apart make a couple only as ±P × 1 µm. The leverage does not depend on
    # the engine's loads: with the masses ×1e-6 (a couple a million times smaller to cancel) it is the same
    # request, refused alike.
    data = raw("test-single")
    data["piston"]["mass"] = f"{2.229 * mass_factor!r} kg"
    data["rod"]["mass"] = f"{2.726 * mass_factor!r} kg"
    data["rod"]["inertia"] = f"{26131 * mass_factor!r} kg mm^2"
    data["crankshaft_unbalance"][0]["mass"] = f"{12.782 * mass_factor!r} kg"
    data["design"] = {"orders": [1], "counterweights": [{"label": "cw", "planes": ["55 mm", "55.001 mm"]}]}
    with pytest.raises(DesignError) as info:
        hb.design(scene_of(data))
    message = str(info.value)
    assert "design.counterweights 'cw'" in message and "planes (now [55 mm, 55.001 mm]) apart" in message
    assert "order 1 moment" in message


def test_moment_shaft_with_nearly_coincident_planes_is_refused():
    data = raw("inline-3")
    data["design"]["moment_shaft"][0]["planes"] = ["0 mm", "0.001 mm"]
    with pytest.raises(DesignError, match=r"design\.moment_shaft 'balance shaft'.*planes"):
        hb.design(scene_of(data))


def test_balance_factor_counterweights_beyond_the_size_limit_are_refused():
    # The balance-factor rule is not solved by the least squares the leverage judges: its couple over planes
    # 1 µm apart is caught by the size check, against the engine's own unbalance (force scale / ω²).
    data = raw("test-single")
    data["design"]["counterweights"][0]["planes"] = ["55 mm", "55.001 mm"]
    scene = scene_of(data)
    with pytest.raises(DesignError) as info:
        hb.design(scene)
    message = str(info.value)
    assert "design.counterweights 'counterweight'" in message and "planes" in message
    times = float(re.search(r"kg mm, ([0-9.e+]+) times the engine's own unbalance", message).group(1))
    assert times > ELEMENT_LIMIT
    # The engine's own unbalance the message names: the sum of the bodies' peak forces at 1 rad/s.
    unit = evaluate(scene)
    own = unit.peak_force.sum() + 12.782 * 0.008047
    assert f"{own * 1e3:.4g} kg mm" in message


def test_cli_refuses_an_ill_conditioned_request_with_exit_2_and_writes_nothing(tmp_path, capsys):
    data = raw("test-single")
    data["design"]["cancel"] = ["roll"]
    data["design"]["lanchester_pair"][0].update(heights=["0.001 mm", "0 mm"], lateral=["0 mm", "0 mm"])
    path = tmp_path / "pair.toml"
    path.write_text(tomli_w.dumps(data), encoding="utf-8")
    out = tmp_path / "out.toml"
    assert main(["design", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and str(path) in err and "design.lanchester_pair" in err
    assert all(line.startswith("harmbal: error: ") for line in err.strip().splitlines())
    assert not out.exists()


def test_ill_conditioned_geometry_is_refused_for_every_mass_variant():
    data = raw("test-single")
    data["design"] = {"orders": [1], "counterweights": [{"label": "cw", "planes": ["55 mm", "55.001 mm"]}]}
    scene = scene_of(data)
    with pytest.raises(DesignError, match=r"ill-conditioned.*design\.counterweights 'cw'"):
        design_basis(scene, linear_phasors(scene))


def test_bundled_requests_are_far_from_the_thresholds():
    # The documented margins: elements at most 0.6 of the engine's own unbalance (1e3 is refused), and no
    # refusal of any bundled request.
    for name in DESIGNED:
        scene = hb.load_scene(ENGINES / f"{name}.toml")
        designed = hb.design(scene)
        own = engine_scales(scene)[0]
        gross = [sum(p.ratio**2 * abs(p.coefficient) for p in u) for c in scene.design.candidates
                 for u in c.unknowns()]
        assert (np.array(gross) * designed.dataset.unbalance.values <= 0.6 * own).all(), name
    assert LEVERAGE_MIN == 1e-3 and ELEMENT_LIMIT == 1e3


# --------------------------------------------------------------------------
# 2. verify cannot be fooled by the elements' own loads


def absurd(extra: float):
    """test-single-balanced with two counterweights of 1e6 × the engine's own unbalance at one plane,
    opposite, the second larger by the share ``extra``: their residual force is ``extra`` × 1e6 of it."""
    scene = hb.load_scene(ENGINES / "test-single-balanced.toml")
    own = engine_scales(scene)[0]
    text = (ENGINES / "test-single-balanced.toml").read_text(encoding="utf-8")
    big = 1e6 * own
    for label, size, angle in (("big", big, "0 deg"), ("bigger", big * (1 + extra), "180 deg")):
        text += (f'\n[[counterweight]]\nlabel = "{label}"\nunbalance = "{size!r} kg m"\nangle = "{angle}"\n'
                 'axial_position = "86 mm"\n')
    return scene_from_text(text, "absurd.toml"), own


def test_verify_of_elements_a_million_times_the_engine_fails():
    # A residual of 1e-13 of the absurd elements is 1e-7 of the engine's scale: far above its zero level
    # (1e-10), though within 1e-12 of the elements' own loads (the tolerance verify had).
    scene, own = absurd(1e-13)
    check = hb.verify(scene)
    assert check.attrs["passed"] == "no"
    force_co = check.sel(order=1, component="force_co")
    w2 = scene.speeds[0] ** 2
    assert float(force_co.difference) == pytest.approx(1e-13 * 1e6 * own * w2, rel=1e-2)
    # The tolerance and every level are the engine's, as if the elements were not there.
    plain = hb.verify(hb.load_scene(ENGINES / "test-single-balanced.toml"))
    np.testing.assert_allclose(check.tolerance.values, plain.tolerance.values, rtol=1e-6)
    assert float(check.force_scale) == float(plain.force_scale) == pytest.approx(own * w2, rel=1e-15)
    assert plain.attrs["passed"] == "yes"


def test_cli_verify_of_the_absurd_design_exits_1(tmp_path, capsys):
    scene, _ = absurd(1e-13)
    path = tmp_path / "absurd.toml"
    path.write_text(scene.source_text, encoding="utf-8")
    assert main(["verify", str(path)]) == 1
    assert "FAIL" in capsys.readouterr().out


def test_verify_refuses_loads_that_are_not_finite():
    scene = hb.load_scene(ENGINES / "test-single-balanced.toml")
    shaft = scene.shafts[0]
    huge = dataclasses.replace(shaft, unbalances=(dataclasses.replace(shaft.unbalances[0], unbalance=1e305),))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy warning as the only sign: a refusal
        with pytest.raises(VerifyError, match="not finite"):
            hb.verify(dataclasses.replace(scene, shafts=(huge,) + scene.shafts[1:]))


def test_design_refuses_an_engine_whose_loads_are_not_finite():
    scene = hb.load_scene(ENGINES / "test-single.toml")
    cylinder = scene.cylinders[0]
    broken = dataclasses.replace(cylinder, piston=dataclasses.replace(cylinder.piston, mass=math.nan))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(DesignError, match="not finite"):
            hb.design(dataclasses.replace(scene, cylinders=(broken,)))


# --------------------------------------------------------------------------
# 3. design and verify agree about "cancelled"


def scaled(data: dict, factor: float) -> dict:
    """Every quantity in kg (masses, inertias, unbalances, products of inertia) times ``factor``, the
    [design] bounds too: the same engine, its loads ``factor`` times larger."""
    def walk(node):
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for key, value in items:
            if isinstance(value, str) and re.fullmatch(r"-?[0-9.eE+-]+ .*kg.*", value):
                number, units = value.split(" ", 1)
                node[key] = f"{float(number) * factor!r} {units}"
            else:
                walk(value)

    data = copy.deepcopy(data)
    walk(data)
    return data


#: Masses ×1e6 and ×1e-6 (×1e5 where a mass would exceed the 1e7 kg the reader accepts: the tractor's 76 kg
#: crankshaft, reference engine B's 12.8 kg one).
SCALED = [(name, factor) for name in DESIGNED
          for factor in (1e-6, 1e5 if name in ("tractor-3cyl-balanced", "test-single") else 1e6)]


@pytest.mark.parametrize("name", DESIGNED)
def test_bundled_designs_verify_as_designed(name):
    designed, check = design_and_verify(hb.load_scene(ENGINES / f"{name}.toml"))
    assert_agree(designed, check)


@pytest.mark.parametrize("name, factor", SCALED)
def test_scaled_designs_verify_as_designed(name, factor):
    designed, check = design_and_verify(scene_of(scaled(raw(name), factor), f"{name}.toml"))
    assert_agree(designed, check)
    # The design scales with the masses: the same cancellations, unbalances × factor (least squares; the peak
    # objective's optimum is flat: other couples within its LP tolerance).
    nominal = hb.design(hb.load_scene(ENGINES / f"{name}.toml")).dataset
    np.testing.assert_array_equal(designed.dataset.cancelled.values, nominal.cancelled.values)
    if nominal.attrs["objective"] == "least_squares":
        np.testing.assert_allclose(designed.dataset.unbalance.values, factor * nominal.unbalance.values, rtol=1e-9)


@pytest.mark.parametrize("name", DESIGNED)
@pytest.mark.parametrize("offset", ["6e-8 mm", "1e-5 mm"])
def test_designs_about_an_offset_reference_point_verify_as_designed(name, offset):
    data = raw(name)
    data["engine"]["reference_point"] = [offset, offset, offset]
    assert_agree(*design_and_verify(scene_of(data, f"{name}.toml")))


def test_random_designs_from_the_bundled_scenes_verify_as_designed():
    rng = np.random.default_rng(32)
    for i in range(15):
        name = DESIGNED[i % len(DESIGNED)]
        data = scaled(raw(name), float(10 ** rng.uniform(-3, 3)))
        for table in ("piston", "rod"):  # the parts apart: other shares of rotating and reciprocating masses
            data[table] = scaled(data[table], float(rng.uniform(0.3, 3)))
        if rng.random() < 0.5:
            data["design"]["cancel"] = sorted(set(data["design"].get("cancel", ["force", "moment"])) | {"roll"})
        data["engine"]["reference_point"] = [f"{float(rng.normal() * 10 ** rng.uniform(-8, 1))!r} mm"
                                             for _ in range(3)]
        assert_agree(*design_and_verify(scene_of(data, f"{name}#{i}.toml")))


@pytest.mark.parametrize("throw", ["120.00000002 deg", "120.00000004 deg", "120.00000006 deg", "120.0000001 deg"])
def test_a_residual_near_the_zero_level_is_judged_alike(throw):
    # Throw 3 of the inline three a few 1e-8° off its regular star leaves an order-2 roll moment of
    # 0.3 to 1.7 × the zero level that no counterweight acts on. Design calls it cancelled below the level
    # and verify finds it zero, or design leaves it (predicting it) and verify confirms the prediction.
    # (Verify's tolerance was 1e-12 of the scale: the residuals design called cancelled failed.)
    data = raw("inline-3")
    data["cylinder"][2]["throw"] = throw
    data["design"] = {"orders": [2], "cancel": ["roll"], "counterweights": [{"planes": ["-120 mm", "120 mm"]}]}
    designed, check = design_and_verify(scene_of(data))
    assert_agree(designed, check)
    roll = abs(complex(check.exact.sel(order=2, component="roll")))
    level = ZERO_RTOL * float(check.moment_scale)
    assert bool(designed.dataset.cancelled.sel(order=2, component="roll")) == (roll <= level)
    assert designed.feasible == (roll <= level)


def test_a_design_the_written_scene_does_not_confirm_is_not_called_cancelled():
    # 16 samples per revolution of a short rod (λ = 0.6): the order domain's phasors carry the aliasing of
    # orders 15 and 17 (3.7e-4 N at order 1), so its design cancels what the exact model of the scene as
    # written leaves. Design judges the written scene as verify does: it reports the order-1 targets as left,
    # with the exact residual as the prediction and the fix, and verify confirms it (it used to fail).
    data = raw("test-single")
    data["geometry"]["rod_length"] = "100 mm"
    data["rod"]["cg_from_big_end"] = "30 mm"
    data["sampling"] = {"samples_per_rev": 16, "max_order": 2}
    designed, check = design_and_verify(scene_of(data))
    assert not designed.feasible and not designed.dataset.cancelled.values.any()
    assert sum("in the exact model of the scene as written" in m and "refine [sampling]" in m
               for m in designed.messages) == 4
    # The targets (force and moment; the roll is not one) against the engine's zero level of each component.
    predicted, exact = (ds.sel(order=1).values[:4] for ds in (designed.dataset.predicted, check.exact))
    units = check.component_units.values[:4]
    scale = np.where(units == "N", *engine_scales(designed.scene)) * designed.scene.speeds[0] ** 2
    assert (np.abs(predicted) > ZERO_RTOL * scale).all()
    assert (np.abs(predicted - exact) <= ZERO_RTOL * scale).all()
    assert_agree(designed, check)
