"""Only the effects a scene asks for are computed, and they add up."""

import numpy as np
import pytest

import harmbal as hb
from harmbal.model import evaluate as core
from harmbal.model import kinematics, loads

EFFECTS = ["reciprocating", "rotating", "rod_inertia", "mass_torque"]


def _forbid(monkeypatch, module, name):
    def refuse(*args, **kwargs):
        raise AssertionError(f"{name} was computed although its effect is disabled")

    monkeypatch.setattr(module, name, refuse)


@pytest.mark.parametrize("effect, module, function", [
    ("rod_inertia", loads, "rod_inertia"),
    ("reciprocating", loads, "reciprocating"),
    ("rotating", loads, "rotating_rod"),
    ("rotating", loads, "rotating_unbalance"),
])
def test_disabled_effect_is_never_evaluated(monkeypatch, base_scene, effect, module, function):
    base_scene["throw_unbalance"] = {"unbalance": "0.01 kg m", "angle": "180 deg"}
    base_scene["crankshaft_unbalance"] = {"unbalance": "0.002 kg m"}
    base_scene["model"] = {"effects": [e for e in EFFECTS if e != effect]}
    _forbid(monkeypatch, module, function)
    hb.simulate(hb.load_scene(base_scene))


def test_rotating_only_needs_no_slider_crank(monkeypatch, base_scene):
    base_scene["model"] = {"effects": ["rotating"]}
    _forbid(monkeypatch, core, "slider_crank")
    _forbid(monkeypatch, kinematics, "slider_crank")
    ds = hb.simulate(hb.load_scene(base_scene))
    assert np.abs(ds.force).max() > 0


def test_effects_superpose(base_scene):
    base_scene["throw_unbalance"] = {"unbalance": "0.01 kg m", "angle": "180 deg"}
    base_scene["rod"]["cg_offset"] = "2 mm"
    total = hb.simulate(hb.load_scene(base_scene))
    parts = []
    for effect in ["reciprocating", "rotating", "rod_inertia"]:
        base_scene["model"] = {"effects": [effect]}
        parts.append(hb.simulate(hb.load_scene(base_scene)))
    # mass_torque depends on which bodies are simulated, so it is checked
    # against the sum of the three with mass_torque enabled in each.
    scale = float(total.moment_scale)
    base_scene["model"] = {"effects": ["reciprocating", "rotating", "rod_inertia"]}
    no_torque = hb.simulate(hb.load_scene(base_scene))
    np.testing.assert_allclose(sum(p.force for p in parts), no_torque.force, rtol=0,
                               atol=1e-12 * float(total.force_scale))
    np.testing.assert_allclose(sum(p.moment for p in parts), no_torque.moment, rtol=0, atol=1e-12 * scale)
    # The drive-torque reaction acts about the crank axis only.
    diff = (total.moment - no_torque.moment).values
    assert np.abs(diff[1:]).max() <= 1e-12 * scale and np.abs(diff[0]).max() > 1e-3 * scale


def test_two_point_rod_has_no_rod_inertia_term(monkeypatch, base_scene):
    base_scene["model"] = {"rod": "two_point"}
    _forbid(monkeypatch, loads, "rod_inertia")
    hb.simulate(hb.load_scene(base_scene))


def test_each_derived_quantity_of_an_evaluation_is_computed_once(monkeypatch, base_scene):
    # analyse builds every view from one Evaluation: a derived quantity several views read (the bodies'
    # aliasing: /time and /orders; the order phasors: /stars) is computed on first use and then read.
    from harmbal.views import evaluation as module

    scene = hb.load_scene(base_scene)
    calls = {"body_aliasing": 0, "order_phasors": 0}
    for name in calls:
        original = getattr(module, name)

        def counted(*args, _original=original, _name=name, **kwargs):
            calls[_name] += 1
            return _original(*args, **kwargs)

        monkeypatch.setattr(module, name, counted)
    hb.analyse(scene)
    assert calls == {"body_aliasing": 1, "order_phasors": 1}
    ev = module.evaluation(scene)
    assert ev.aliasing is ev.aliasing and ev.phasors is ev.phasors and ev.gas is None
    with pytest.raises(ValueError, match="no gas"):
        _ = ev.cycle
