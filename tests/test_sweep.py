"""Speed sweeps: many operating points from one evaluation of the model.

Oracles: each speed of a sweep equals a scene run at that speed alone
(independent loads, no ω² scaling shared), and the (ω/ω₀)² law itself.
"""

import math
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.cli import main
from harmbal.scene import MAX_SPEEDS, SceneError

ROOT = Path(__file__).resolve().parent.parent
SWEEP = {"from": "600 rpm", "to": "8000 rpm", "points": 10_000}


def _problems(mapping):
    with pytest.raises(SceneError) as info:
        hb.load_scene(mapping)
    return [(p.key, p.rule) for p in info.value.problems]


def test_sweep_table_gives_evenly_spaced_speeds(base_scene):
    base_scene["engine"]["speed"] = dict(SWEEP)
    scene = hb.load_scene(base_scene)
    rpm = np.asarray(scene.speeds) * 30 / math.pi
    assert rpm.size == 10_000
    np.testing.assert_allclose(rpm, np.linspace(600, 8000, 10_000), rtol=1e-15)


def test_every_speed_of_a_sweep_equals_a_run_at_that_speed_alone(base_scene):
    base_scene["engine"]["speed"] = dict(SWEEP)
    tree = hb.analyse(hb.load_scene(base_scene))
    for i in (0, 1234, 9999):
        rpm = float(tree["orders"]["rpm"].values[i])
        alone = dict(base_scene, engine=dict(base_scene["engine"], speed=f"{rpm!r} rpm"))
        single = hb.analyse(hb.load_scene(alone))
        for group, names in (("orders", ("force", "moment", "force_rotating")),
                             ("stars", ("force_cylinder", "moment_cylinder")), ("time", ("force", "moment"))):
            for name in names:
                got = tree[group][name].isel(speed=i).values
                want = single[group][name].values
                np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13 * np.abs(want).max())


def test_sweep_loads_follow_omega_squared(base_scene):
    base_scene["engine"]["speed"] = dict(SWEEP)
    orders = hb.order_spectrum(hb.simulate(hb.load_scene(base_scene)))
    w = orders["speed"].values
    force = orders["force"].values
    expected = (w[:, None, None] / w[0]) ** 2 * force[0]
    scale = np.abs(expected).max(axis=(1, 2), keepdims=True)
    assert np.all(np.abs(force - expected) <= 1e-14 * scale)


@pytest.mark.parametrize("speed, key, rule", [
    ({"from": "600 rpm", "to": "8000 rpm"}, "engine.speed.points", "missing required key"),
    ({"from": "600 rpm", "to": "8000 rpm", "points": 1}, "engine.speed.points", "at least 2"),
    ({"from": "600 rpm", "to": "8000 rpm", "points": 2.5}, "engine.speed.points", "must be an integer"),
    ({"from": "600 rpm", "to": "8000 rpm", "points": MAX_SPEEDS + 1}, "engine.speed.points", "at most"),
    ({"from": "8000 rpm", "to": "600 rpm", "points": 10}, "engine.speed.to", "above engine.speed.from"),
    ({"from": "600 rpm", "to": "50 Hz", "points": 10}, "engine.speed.to", "ambiguous"),
    ({"to": "8000 rpm", "points": 10}, "engine.speed.from", "missing required key"),
    ({"from": "600 rpm", "to": "8000 rpm", "points": 10, "step": 1}, "engine.speed.step", "unknown key"),
])
def test_bad_sweeps_are_refused_with_the_key(base_scene, speed, key, rule):
    base_scene["engine"]["speed"] = speed
    found = _problems(base_scene)
    assert any(k == key and rule in r for k, r in found), found


def test_with_speeds(base_scene):
    scene = hb.load_scene(base_scene)
    other = scene.with_speeds([100.0, 200.0])
    assert other.speeds == (100.0, 200.0) and other.cylinders == scene.cylinders
    for bad in ([], [100.0, 100.0], [100.0, -1.0], [np.nan], [[100.0, 200.0]]):
        with pytest.raises(ValueError, match="speeds"):
            scene.with_speeds(bad)


def test_cli_prints_the_ends_of_a_long_sweep(tmp_path, capsys):
    path = tmp_path / "sweep.toml"
    path.write_text('[engine]\nname = "s"\nspeed = { from = "600 rpm", to = "8000 rpm", points = 100 }\n'
                    '[geometry]\ncrank_radius = "40 mm"\nrod_length = "140 mm"\n[piston]\nmass = "0.45 kg"\n'
                    '[rod]\nmass = "0.5 kg"\ncg_from_big_end = "40 mm"\ninertia = "0.0012 kg m^2"\n'
                    '[[cylinder]]\nthrow = "0 deg"\naxial_position = "0 mm"\n', encoding="utf-8")
    assert main(["run", str(path)]) == 0
    out = capsys.readouterr().out
    assert "100 speeds from 600 to 8000 rpm" in out
    assert [line.split(" rpm")[0] for line in out.splitlines() if line.startswith("Speed ")] == \
        ["Speed 600", "Speed 8000"]


def test_a_million_speeds_hold_no_per_speed_array():
    """A 10⁶-speed sweep keeps the unit-speed arrays and multiplies out only
    what is read; the value read equals an analysis at that speed alone."""
    import gc
    import tracemalloc

    scene = hb.load_scene(ROOT / "datasets" / "engines" / "v8-cross-plane.toml")
    speeds = np.linspace(50.0, 800.0, 1_000_000)
    hb.analyse(scene)  # caches and imports out of the measurement
    tracemalloc.start()
    tree = hb.analyse(scene.with_speeds(speeds))
    _, peak = tracemalloc.get_traced_memory()
    got = tree["orders"].ds.moment.isel(speed=123_456).values
    time_got = tree["time"].ds.force.isel(speed=-1).values
    del tree
    gc.collect()
    left, _ = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    # Per group a few copies of the speed coordinates (8 MB each); one (speed, order, axis) array alone is 624 MB.
    assert peak < 200e6, peak
    assert left < 5e6, left  # nothing stays alive after the tree is gone
    alone = hb.analyse(scene.with_speeds([speeds[123_456]]))
    want = alone["orders"].ds.moment.values
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-14 * np.abs(want).max())
    want = hb.analyse(scene.with_speeds([speeds[-1]]))["time"].ds.force.values
    np.testing.assert_allclose(time_got, want, rtol=0, atol=1e-14 * np.abs(want).max())
