"""Designs and verification name what they make worse (issue 28).

Oracles: the exact time-domain model (hb.simulate + hb.order_spectrum, not the
order-domain path the design uses) for the amplitudes before and after, and the
closed form of a balance shaft's roll couple: a shaft turning at n × crank
speed with the static unbalance U pulls on the block with n²ω²U, so set at
(y, z) off the crank axis its roll moment M_x = y·F_z − z·F_y has the peak
n²ω²U·√(y² + z²) (a rotating vector's two components, 90° apart).
"""

import re
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.balance.verify import made_worse_variables
from harmbal.cli import main
from harmbal.orders.spectrum import FREE, NEGLIGIBLE, ZERO
from harmbal.reporting.tables import verify_table
from harmbal.scene import scene_from_text

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
#: A two-stroke single balanced by counterweights (balance factor 0.5) and a −1× shaft 65 mm below the
#: crank; the design cancels the first-order force only, so the shaft's roll couple is not targeted.
FIXTURE = Path(__file__).parent / "fixtures" / "two-stroke-single-shaft.toml"
SHAFT_AXIS = 'axis_position = ["0 mm", "-65 mm"]'


def fixture(height_mm: float | None = None, negligible: float | None = None):
    """The fixture's scene, with its shaft at ``height_mm`` [mm] and a ``[model] negligible``."""
    text = FIXTURE.read_text(encoding="utf-8")
    if height_mm is not None:
        text = text.replace(SHAFT_AXIS, f'axis_position = ["0 mm", "{height_mm!r} mm"]')
    if negligible is not None:
        text = text.replace("[[cylinder]]", f"[model]\nnegligible = {negligible!r}\n\n[[cylinder]]")
    return scene_from_text(text, str(FIXTURE))


def roll(scene) -> complex:
    """The order-1 phasor of the moment about the crank axis [N m] by the exact time-domain model."""
    return complex(hb.order_spectrum(hb.simulate(scene))["moment"].sel(order=1, axis="x"))


def shaft_roll_couple(design) -> float:
    """Peak roll moment [N m] of the designed −1× shaft, closed form n²ω²U·√(y² + z²)."""
    (shaft,) = [e for e in design.elements if e.ratio == -1]
    unbalance = sum(u.unbalance for u in shaft.unbalances)
    return shaft.ratio**2 * design.scene.speeds[0] ** 2 * unbalance * float(np.hypot(shaft.y, shaft.z))


@pytest.fixture(scope="module")
def two_stroke():
    return hb.design(fixture())


def test_the_shaft_below_the_crank_raises_the_roll_by_its_couple(two_stroke):
    scene = fixture()
    before, after = roll(scene), roll(two_stroke.scene)
    scale = float(two_stroke.dataset["moment_scale"])
    # The only new element off the crank axis is the shaft: what it adds is its roll couple.
    assert abs(after - before) == pytest.approx(shaft_roll_couple(two_stroke), abs=1e-9 * scale)
    assert abs(after) > 10 * abs(before)  # the report: 6.5 -> 67.5 N m
    got = two_stroke.dataset[["amplitude_before", "amplitude_after"]].sel(checked_order=1, component="roll")
    assert float(got["amplitude_before"]) == pytest.approx(abs(before), abs=1e-9 * scale)
    assert float(got["amplitude_after"]) == pytest.approx(abs(after), abs=1e-9 * scale)


def test_the_design_names_the_roll_and_nothing_else(two_stroke):
    ds = two_stroke.dataset
    assert two_stroke.feasible  # the targets are met: a warning, not a failure
    flags = ds["worsened"]
    flagged = [(int(k), str(c)) for k in flags["checked_order"].values for c in flags["component"].values
               if flags.sel(checked_order=k, component=c)]
    assert flagged == [(1, "roll")]
    assert list(ds["checked_order"].values) == list(range(1, fixture().sampling.max_order + 1))
    (sentence,) = two_stroke.worsened
    assert sentence.startswith("order 1 roll moment made worse by the designed elements: ")
    assert ds.attrs["worsened"] == sentence
    was, now = (float(v) for v in re.search(r": (\S+) → (\S+) N m at 6400 rpm", sentence).groups())
    assert was == pytest.approx(abs(roll(fixture())), rel=1e-4)
    assert now == pytest.approx(abs(roll(two_stroke.scene)), rel=1e-4)


def test_verify_finds_what_the_design_found(two_stroke):
    check = hb.verify(two_stroke.scene)
    assert check.attrs["passed"] == "yes"
    np.testing.assert_array_equal(check["worsened"].values, two_stroke.dataset["worsened"].values)
    for name in ("force_negligible_level", "moment_negligible_level"):
        assert float(check[name]) == float(two_stroke.dataset[name])
    assert check.attrs["worsened"].startswith("order 1 roll moment made worse by the balancer elements: ")


def test_what_design_cancels_verify_finds_zero(two_stroke):
    """A residual design calls cancelled is round-off (class zero) by verify's exact model."""
    for design in (two_stroke, hb.design(hb.load_scene(ENGINES / "test-single.toml")),
                   hb.design(hb.load_scene(ENGINES / "inline-3.toml"))):
        check = hb.verify(design.scene)
        cancelled = design.dataset["cancelled"].sel(order=check["order"])
        assert cancelled.values.any()
        assert (check["exact_class"].values[cancelled.values] == ZERO).all()


def test_cli_warns_once_and_keeps_the_exit_status(tmp_path, capsys):
    out = tmp_path / "designed.toml"
    assert main(["design", str(FIXTURE), "-o", str(out)]) == 0
    printed = capsys.readouterr()
    warning = "harmbal: warning: order 1 roll moment made worse by the designed elements: "
    assert printed.err.count(warning) == 1 and printed.err.count("warning") == 1
    assert "Made worse (not targeted) by the new elements:\n  order 1 roll moment " in printed.out
    assert "Made worse (not targeted) by the balancer elements:\n  order 1 roll moment " in printed.out
    assert main(["verify", str(out)]) == 0
    printed = capsys.readouterr()
    assert printed.err.count("harmbal: warning: order 1 roll moment made worse by the balancer elements: ") == 1


def test_a_design_that_worsens_nothing_warns_about_nothing(tmp_path, capsys):
    # Reference engine B with a mirrored Lanchester pair: the two shafts' roll couples cancel, so the
    # first-order roll is the same before and after up to round-off.
    assert main(["design", str(ENGINES / "test-single.toml"), "-o", str(tmp_path / "b.toml")]) == 0
    printed = capsys.readouterr()
    assert "warning" not in printed.err
    scene = hb.load_scene(ENGINES / "test-single.toml")
    orders = f"orders 1-{scene.sampling.max_order}"
    assert f"Nothing else made worse by the new elements ({orders}, every component)." in printed.out
    design = hb.design(scene)
    assert not design.worsened and not design.dataset["worsened"].values.any()
    ds = design.dataset.sel(checked_order=1, component="roll")
    grown = float(ds["amplitude_after"] - ds["amplitude_before"])
    assert abs(grown) <= 1e-10 * float(design.dataset["moment_scale"])  # round-off, and not named


def test_growth_within_the_negligible_level_is_not_named():
    on_axis = hb.design(fixture(height_mm=0.0))
    level = float(on_axis.dataset["moment_negligible_level"])
    force = abs(complex(on_axis.dataset["before"].sel(order=1, component="force_counter")))  # what the shaft makes
    # A shaft this close to the crank axis adds a roll couple of at most half the negligible level.
    height = 0.5 * level / force
    design = hb.design(fixture(height_mm=height * 1e3))
    assert shaft_roll_couple(design) <= 0.51 * level
    assert not design.worsened and not design.dataset["worsened"].values.any()


def test_the_levels_follow_model_negligible():
    base = hb.design(fixture(height_mm=2.0))  # the shaft 2 mm above the crank: a small rise of the roll
    scale = float(base.dataset["moment_scale"])
    grown = abs(roll(base.scene)) - abs(roll(fixture(height_mm=2.0)))
    assert grown > 0
    for factor, named in ((0.8, True), (1.25, False)):
        negligible = factor * grown / scale  # one cylinder: the level is negligible × the load scale
        design = hb.design(fixture(height_mm=2.0, negligible=negligible))
        assert design.dataset.attrs["negligible"] == negligible
        assert float(design.dataset["moment_negligible_level"]) == pytest.approx(negligible * scale, rel=1e-12)
        assert bool(design.dataset["worsened"].sel(checked_order=1, component="roll")) is named
        check = hb.verify(design.scene)  # the designed scene keeps the setting
        assert bool(check["worsened"].sel(checked_order=1, component="roll")) is named
    # Scene.with_negligible (the CLI's --negligible) does the same, and the level is per cylinder.
    inline4 = hb.load_scene(ENGINES / "inline-4.toml").with_negligible(0.01)
    ds = hb.design(inline4).dataset
    assert float(ds["force_negligible_level"]) == pytest.approx(0.01 * float(ds["force_scale"]) / 4, rel=1e-12)


def axis_rows(table: str) -> dict[tuple[str, str, str], tuple[str, str]]:
    """The per-axis rows of a verify table: (order or "peak", force/moment, axis) → (before, after) cells."""
    rows = {}
    for line in table.splitlines():
        if re.match(r"^ *(peak|\d+)  (force|moment) [xyz] \[", line):
            cells = line.split()
            rows[tuple(cells[:3])] = (cells[-3], cells[-2])
    return rows


def test_verify_table_prints_round_off_as_0_and_negligible_as_tilde_0(two_stroke):
    table = verify_table(hb.verify(two_stroke.scene))
    rows = axis_rows(table)
    for key in (("1", "force", "y"), ("1", "force", "z"), ("peak", "force", "y")):
        assert rows[key][1] == "0", key  # the shaft and the counterweight cancel them: round-off
    assert "e-1" not in "".join(before + after for before, after in rows.values())
    # The shaft 7 mm below the crank nearly cancels the engine's 6.4 N m roll: the rest is negligible at 0.1 of
    # one cylinder's share of the engine's moment scale (4.6 N m; the levels never grow with the elements' loads).
    check = hb.verify(hb.design(fixture(height_mm=-7.0)).scene.with_negligible(0.1))
    coarse = axis_rows(verify_table(check))
    level = float(check["moment_negligible_level"])
    assert 0.0 < level < 6.3788
    assert coarse[("1", "moment", "x")] == ("6.3788", "~0")


def test_only_untargeted_free_growth_beyond_the_level_counts():
    scale, level = np.full(5, 1000.0), np.full(5, 1.0)
    before = np.array([[10.0, 10.0, 10.0, 0.0, 1e-13]])
    after = np.array([[10.0 + 0.99, 10.0 + 1.01, 50.0, 0.9, 1e-13 * (1 + 1e-3)]])  # within, beyond, targeted, ~0, 0
    targeted = np.array([[False, False, True, False, False]])
    got = made_worse_variables(before, after, targeted, scale, level)
    np.testing.assert_array_equal(got["worsened"][1], [[False, True, False, False, False]])
    np.testing.assert_array_equal(got["class_after"][1], [[FREE, FREE, FREE, NEGLIGIBLE, ZERO]])


def test_the_report_of_the_designed_scene_names_it(two_stroke, tmp_path):
    from harmbal.reporting.html import report

    report(hb.analyse(two_stroke.scene), tmp_path / "designed.html")
    html = (tmp_path / "designed.html").read_text(encoding="utf-8")
    section = html[html.index('id="balancers"'):]
    assert re.search(r"order 1 roll moment made worse[^<]*6\.\d+ → 67\.\d+ N m", section[: section.index("</section>")])
