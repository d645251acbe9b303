"""Mount design (scipy.optimize over the [mount_design] variables) and the
mount-stiffness Monte Carlo: the designed tractor checked on its re-read,
recomputed /mounts, never on the optimiser's own numbers."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.balance.mount_design import DesignError, design_mounts
from harmbal.scene import SceneError, scene_from_text
from harmbal.scene.mounts import MountVariable
from harmbal.studies.mount_tolerances import mount_monte_carlo
from harmbal.views.mounts import mounts

ENGINES = Path(__file__).resolve().parents[1] / "datasets" / "engines"
TRACTOR = ENGINES / "tractor-3cyl-mounts.toml"


@pytest.fixture(scope="module")
def tractor():
    return hb.load_scene(TRACTOR)


@pytest.fixture(scope="module")
def designed(tractor):
    return design_mounts(tractor)


def _rms_mount_force(ds) -> float:
    """J of the module docstring, from a /mounts Dataset by hand."""
    f = ds.transmitted_force.transpose("speed", "order", "mount", "component").values
    return math.sqrt((np.abs(f) ** 2).sum(axis=(-1, -2)).mean())


def test_the_designed_tractor_meets_every_constraint_when_recomputed(tractor, designed):
    request, after = tractor.mount_design, designed.after
    assert designed.feasible and designed.verified and not designed.messages and not designed.mismatches
    assert np.all(after.decoupling.values >= request.decoupling)
    low, high = request.frequency_band
    assert np.all((after.natural_frequency.values >= low) & (after.natural_frequency.values <= high))
    assert abs(float(after.static_roll.sel(case="weight+full_load"))) <= request.max_static_roll
    # The nominal mounts violate the band (the highest mode above 14 Hz): the design had work to do.
    assert designed.before.natural_frequency.values.max() > high
    assert {c.name for c in designed.constraints} == {"decoupling", "lowest frequency", "highest frequency",
                                                      "static roll"}


def test_the_rms_mount_force_decreases(designed):
    before, after = _rms_mount_force(designed.before), _rms_mount_force(designed.after)
    assert after < 0.5 * before
    assert designed.objective_before == pytest.approx(before, rel=1e-12)
    assert designed.objective_after == pytest.approx(after, rel=1e-12)


def test_bounds_are_respected_and_groups_share_one_value(tractor, designed):
    by_group: dict = {}
    written = {m.name: m for m in designed.scene.mounts}
    for v in designed.variables:
        assert v.lower <= v.after <= v.upper
        by_group.setdefault(v.group, set()).add(v.after)
        mount = written[v.mount]
        value = mount.stiffness["uvw".index(v.axis)] if v.kind == "stiffness" else mount.position["xyz".index(v.axis)]
        assert value == pytest.approx(v.after, rel=1e-12, abs=1e-12 * (v.upper - v.lower))
    assert len(designed.variables) == 12
    assert all(len(values) == 1 for values in by_group.values())
    assert len(by_group) == 5


def test_the_text_reads_back_to_the_designed_scene(tractor, designed):
    again = scene_from_text(designed.text, "<designed>")
    assert again.mount_design is None  # a designed scene, as harmbal design writes one
    assert again.mounts == designed.scene.mounts
    assert [m.name for m in again.mounts] == [m.name for m in tractor.mounts]
    assert again.cylinders == tractor.cylinders


def test_an_infeasible_request_is_reported_not_raised(tractor):
    # One shared vertical rate cannot put all six modes between 5 and 6 Hz.
    variables = tuple(v for v in tractor.mount_design.variables if v.kind == "stiffness" and v.axis == 2)
    request = dataclasses.replace(tractor.mount_design, variables=tuple(
        dataclasses.replace(v, group="w") for v in variables), frequency_band=(5.0, 6.0))
    design = design_mounts(tractor, request=request, starts=0)
    assert not design.feasible
    violated = {c.name for c in design.constraints if not c.satisfied}
    assert "highest frequency" in violated
    assert any("above the frequency band's 6 Hz" in m for m in design.messages)
    assert design.after.natural_frequency.values.max() > 6.0


def test_an_angle_turns_the_mounts_axes_about_the_engine_axis(tractor):
    """An inclined mount (its axes rotated about x, the crank axis): the axes written are the rows u, v, w
    as given turned by the designed angle, right-handed, and the other mounts are unchanged."""
    variable = MountVariable("front left", "angle", 0, math.radians(-40), math.radians(40))
    request = dataclasses.replace(tractor.mount_design, variables=(variable,), max_static_roll=None)
    design = design_mounts(tractor, request=request, starts=0)
    angle = design.variables[0].after
    assert design.verified and design.variables[0].before == 0.0
    c, s = math.cos(angle), math.sin(angle)
    turn = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    given = np.array(tractor.mounts[0].axes)
    written = np.array(design.scene.mounts[0].axes)
    np.testing.assert_allclose(written, (turn @ given.T).T, atol=1e-12)  # scale: unit vectors
    assert design.scene.mounts[1:] == tractor.mounts[1:]


def test_requests_that_cannot_be_set_up_are_refused(tractor):
    with pytest.raises(DesignError, match="mount_design"):
        design_mounts(tractor, request=dataclasses.replace(tractor.mount_design, variables=()))
    with pytest.raises(DesignError, match="no \\[powertrain\\]"):
        design_mounts(hb.load_scene(ENGINES / "inline-4.toml"))


def test_zero_tolerance_gives_the_nominal_values(tractor):
    ds = mount_monte_carlo(tractor, {"mount[2].stiffness[3]": hb.Normal(0.0)}, 3, seed=1)
    nominal = mounts(tractor)
    for name in ("natural_frequency", "decoupling", "static_roll"):
        scale = np.abs(nominal[name].values).max()
        np.testing.assert_allclose(ds[name].values, np.broadcast_to(nominal[name].values, ds[name].shape),
                                   rtol=0, atol=1e-12 * scale)
    assert (ds.dominant_dof.values == nominal.dominant_dof.values).all()
    assert ds.tra_roll_mode_angle.values == pytest.approx(float(nominal.tra_roll_mode_angle), rel=1e-12)
    peak = nominal.transmitted_force_amplitude.max("speed").transpose("order", "mount").values
    np.testing.assert_allclose(ds.peak_transmitted_force_order.values, np.broadcast_to(peak, (3,) + peak.shape),
                               rtol=0, atol=1e-12 * peak.max())


@pytest.fixture(scope="module")
def scatter(tractor):
    tolerances = {"mount[1].stiffness[3]": hb.Normal("10 %"),
                  "mount[3].stiffness[2]": hb.Uniform("-20 N/mm", "20 N/mm")}
    return tolerances, mount_monte_carlo(tractor, tolerances, 40, seed=7)


def test_percentiles_are_ordered_and_the_seed_reproduces(tractor, scatter):
    tolerances, ds = scatter
    for name in ("natural_frequency", "decoupling", "peak_transmitted_force", "static_roll"):
        p = ds[f"{name}_percentile"].transpose("percentile", ...).values
        assert np.all(np.diff(p, axis=0) >= 0)
        assert np.all(p[0] < p[-1]) if name != "decoupling" else np.any(p[0] < p[-1])
    again = mount_monte_carlo(tractor, tolerances, 40, seed=7)
    assert again.identical(ds)
    other = mount_monte_carlo(tractor, tolerances, 40, seed=8)
    assert not np.array_equal(other.natural_frequency.values, ds.natural_frequency.values)


def test_relative_and_absolute_tolerances_draw_alike(tractor, scatter):
    _, ds = scatter
    nominal = tractor.mounts[0].stiffness[2]
    drawn = ds["mount[1].stiffness[3]"].values
    assert drawn.std() == pytest.approx(0.1 * nominal, rel=0.4)
    uniform = ds["mount[3].stiffness[2]"].values - tractor.mounts[2].stiffness[1]
    assert np.all(np.abs(uniform) <= 20e3) and uniform.std() > 5e3
    absolute = mount_monte_carlo(tractor, {"mount[1].stiffness[3]": hb.Normal(0.1 * nominal),
                                           "mount[3].stiffness[2]": hb.Uniform(-20e3, 20e3)}, 40, seed=7)
    np.testing.assert_allclose(absolute["mount[1].stiffness[3]"].values, drawn, rtol=1e-12)


@pytest.mark.parametrize("key, dist, match", [
    ("mount[9].stiffness[1]", hb.Normal("1 %"), "4 mounts"),
    ("mount[1].position[1]", hb.Normal("1 %"), "mount\\[i\\].stiffness\\[j\\]"),
    ("mount[1].stiffness[1]", hb.Normal("2 mm"), "a stiffness"),
    ("mount[1].stiffness[1]", hb.Normal("90 %"), "≤ 0"),
])
def test_bad_tolerances_are_refused(tractor, key, dist, match):
    with pytest.raises(SceneError, match=match):
        mount_monte_carlo(tractor, {key: dist}, 200, seed=0)
