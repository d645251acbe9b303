"""The /mounts view end to end: from a scene file to the transmitted forces,
checked by the rigid body's own equilibrium (Newton–Euler per order, from the
outputs alone), by the /orders phasors it is driven by, and through the CLI
and the archive."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.cli import main

ENGINES = Path(__file__).resolve().parents[1] / "datasets" / "engines"
TRACTOR = ENGINES / "tractor-3cyl-mounts.toml"
CAR = ENGINES / "inline-4-transverse-mounts.toml"


def _cross(a):
    """[a]x for a (..., 3): the matrix of a × ·."""
    z = np.zeros(a.shape[:-1])
    return np.stack([np.stack([z, -a[..., 2], a[..., 1]], -1), np.stack([a[..., 2], z, -a[..., 0]], -1),
                     np.stack([-a[..., 1], a[..., 0], z], -1)], -2)


@pytest.fixture(scope="module", params=[TRACTOR, CAR], ids=["tractor", "car"])
def analysed(request):
    scene = hb.load_scene(request.param)
    return scene, hb.analyse(scene)


def test_mounts_are_in_the_tree_only_when_asked():
    assert "mounts" not in hb.analyse(hb.load_scene(ENGINES / "tractor-3cyl-gas.toml")).children
    with pytest.raises(ValueError, match="no \\[powertrain\\]"):
        hb.mounts(hb.load_scene(ENGINES / "inline-4.toml"))


def test_every_order_satisfies_the_rigid_bodys_equilibrium(analysed):
    """−Ω² M q + iΩ θ × h = L − Σ f_i (forces and moments about the CG; h the
    spinning parts' momentum), with L built from /orders by hand: the solve, the
    transfer of the moment to the CG, the gyroscopic moment and the mount forces
    checked together, from the outputs."""
    scene, tree = analysed
    ds, orders = tree["mounts"].ds, tree["orders"].ds.sel(order=tree["mounts"].ds.order)
    pt = scene.powertrain
    cg, ref = np.array(pt.cg), np.array(scene.reference_point)
    force = orders.force.transpose("speed", "order", "axis").values
    moment = orders.moment.transpose("speed", "order", "axis").values + np.cross(ref - cg, force)
    load = np.concatenate([force, moment], axis=-1)
    omega = ds.speed.values[:, None] * ds.order.values[None, :]
    q = ds.response.transpose("speed", "order", "dof").values
    f = ds.transmitted_force.transpose("speed", "order", "mount", "component").values
    arms = np.array([m.position for m in scene.mounts]) - cg
    reaction = np.concatenate([f.sum(axis=-2), np.einsum("nab,sknb->ska", _cross(arms), f)], axis=-1)
    mass = np.zeros((6, 6))
    mass[:3, :3] = pt.mass * np.eye(3)
    mass[3:, 3:] = np.array(pt.inertia)
    inertial = -(omega**2)[..., None] * np.einsum("ab,skb->ska", mass, q)
    # The spinning parts' momentum h = sense·J·ω along x turns with the body: θ̇ × h e_x on pitch and yaw.
    h = scene.sense * pt.spinning_inertia * ds.speed.values[:, None]
    rate = 1j * omega[..., None] * q[..., 3:]
    inertial[..., 3:] += np.cross(rate, np.stack([h, 0 * h, 0 * h], axis=-1))
    scale = np.abs(load).max(axis=(-1, -2), keepdims=True)
    assert np.abs(inertial - (load - reaction)).max() <= 1e-11 * scale.max()


def test_statics_carry_the_weight_and_the_torque(analysed):
    scene, tree = analysed
    ds = tree["mounts"].ds
    pt = scene.powertrain
    weight = pt.mass * np.array(pt.gravity)
    total = ds.static_force.sum("mount").values  # into the frame: what the powertrain puts on its mounts
    for case in ds.case.values:
        assert np.allclose(total[list(ds.case.values).index(case)], weight, rtol=0, atol=1e-12 * abs(weight).max())
    roll = ds.static_roll.sel(case="weight+full_load").item() - ds.static_roll.sel(case="weight").item()
    assert roll != 0 and np.sign(roll) == -np.sign(scene.sense)  # the block turns against the crank's drive
    carrying = [m.name for m in scene.mounts if m.preload_axis == "w"]  # the mounts the weight stands on
    assert (ds.preload.sel(case="weight", mount=carrying).values > 0).all()


def test_modes_and_energy(analysed):
    _, tree = analysed
    ds = tree["mounts"].ds
    f = ds.natural_frequency.values
    assert (np.diff(f) >= 0).all() and f[0] > 0
    assert np.abs(ds.energy.sum("dof").values - 1.0).max() <= 1e-12  # shares of a whole: the scale is 1
    assert 0 <= ds.tra_roll_mode_angle.item() <= np.pi / 2
    assert np.isclose(np.linalg.norm(ds.torque_roll_axis.values), 1.0, rtol=1e-14)


def test_high_orders_tend_to_the_mass_line():
    """Far above the modes the block moves as a free body, q → −M⁻¹L/Ω²: at
    the tractor's rated speed the 12th order is at 490 Hz, 40× the highest mode."""
    scene = hb.load_scene(TRACTOR)
    tree = hb.analyse(scene.with_speeds([2460 * np.pi / 30]))
    ds, orders = tree["mounts"].ds, tree["orders"].ds
    k = 12.0
    pt = scene.powertrain
    force = orders.force.sel(order=k).values
    moment = orders.moment.sel(order=k).values + np.cross(np.array(scene.reference_point) - pt.cg, force)
    omega = 2460 * np.pi / 30 * k
    free = -np.concatenate([force / pt.mass, np.linalg.solve(np.array(pt.inertia), moment)]) / omega**2
    q = ds.response.sel(order=k).values
    ratio = (ds.natural_frequency.max().item() * 2 * np.pi / omega) ** 2
    assert np.abs(q - free).max() <= 3 * ratio * np.abs(free).max()


def test_cli_prints_and_writes(tmp_path, capsys):
    out = tmp_path / "tractor.nc"
    assert main(["mounts", str(TRACTOR), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    for words in ("Statics", "Rigid-body modes", "torque roll axis", "Transmitted force", "front left"):
        assert words in text
    back = hb.open_archive(out)
    assert "mounts" in back.children
    direct = hb.analyse(hb.load_scene(TRACTOR))["mounts"].ds
    np.testing.assert_array_equal(back["mounts"].ds.transmitted_force.values, direct.transmitted_force.values)


def test_cli_refuses_a_scene_without_mounts(capsys):
    assert main(["mounts", str(ENGINES / "inline-4.toml")]) == 2
    assert "[powertrain]" in capsys.readouterr().err


def test_the_spinning_inertia_defaults_to_the_flywheels():
    from harmbal.scene import scene_from_text
    from harmbal.views.mounts import operating

    text = TRACTOR.read_text(encoding="utf-8")
    given = scene_from_text(text, str(TRACTOR))
    assert operating(given).spinning_inertia == pytest.approx(1.6, rel=1e-15)
    lines = [line for line in text.splitlines() if not line.startswith("spinning_inertia")]
    without = scene_from_text("\n".join(lines), str(TRACTOR))
    assert without.powertrain.spinning_inertia is None and operating(without).spinning_inertia == 0.0
    flywheel = scene_from_text("\n".join(lines) + '\n[flywheel]\ninertia = "2.5 kg m^2"\n', str(TRACTOR))
    assert operating(flywheel).spinning_inertia == pytest.approx(2.5, rel=1e-15)
    with pytest.raises(hb.SceneError, match="spinning_inertia"):
        scene_from_text(text.replace('spinning_inertia = "1.6 kg m^2"', 'spinning_inertia = "-1 kg m^2"'),
                           str(TRACTOR))


def test_the_library_refuses_a_response_over_the_budget(monkeypatch):
    """20 000 speeds × 24 orders of response: refused under a 300 MiB budget, naming the speeds, before the
    evaluation (which alone fits) is even made."""
    from harmbal.model import budget
    from harmbal.scene import scene_from_text

    text = TRACTOR.read_text(encoding="utf-8").replace("points = 167", "points = 20000")
    scene = scene_from_text(text, str(TRACTOR))
    monkeypatch.setattr(budget, "memory_budget", lambda: 300 * 2**20)
    assert budget.estimate(scene, "evaluate", samples=4096).bytes < 300 * 2**20
    with pytest.raises(hb.SceneError, match="engine.speed.*mounts' response"):
        hb.mounts(scene)


def test_cli_monte_carlo_of_the_stiffness_tolerances(capsys):
    args = ["mounts", str(TRACTOR), "--monte-carlo", "40", "--tol", "mount[*].stiffness[3]=normal:10 %", "--seed", "3"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert text.count("Normal(sigma='10 %')") == 4 and "mount[4].stiffness[3]" in text and "P95" in text
    assert main(args) == 0 and capsys.readouterr().out == text  # the same seed, the same table
    assert main(["mounts", str(TRACTOR), "--monte-carlo", "40"]) == 2
    assert "--tol" in capsys.readouterr().err


def test_a_mount_monte_carlo_over_the_time_budget_is_refused(monkeypatch):
    from harmbal.model import budget

    scene = hb.load_scene(TRACTOR)
    monkeypatch.setattr(budget, "time_budget", lambda: 60.0)
    estimate = budget.estimate(scene, "mounts", mount_samples=100_000)
    assert estimate.seconds > 60 > budget.estimate(scene, "mounts", mount_samples=100).seconds
    with pytest.raises(hb.SceneError, match="100000 samples"):
        hb.mount_monte_carlo(scene, {"mount[1].stiffness[3]": hb.Normal("10 %")}, 100_000)


def test_the_tolerance_wildcards_name_every_mount_and_axis():
    from harmbal.cli import _mount_keys

    scene = hb.load_scene(TRACTOR)
    assert _mount_keys("mount[1].stiffness[*]", scene) == [f"mount[1].stiffness[{j}]" for j in (1, 2, 3)]
    assert _mount_keys("mount[*].stiffness[2]", scene) == [f"mount[{i}].stiffness[2]" for i in (1, 2, 3, 4)]
    assert len(_mount_keys("mount[*].stiffness[*]", scene)) == 12
