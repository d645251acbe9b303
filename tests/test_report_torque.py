"""The torque section of the report and its figures (gas on).

Oracles: the ``/torque`` Dataset the figures and tables are drawn from (line
data, bar heights and table cells parsed back and compared with it), the
virtual-work identity T = (p − p_crankcase)·dV/dθ written here with a
finite difference of the ``volume`` the p–V diagram draws, the area of the
p–V loop against the indicated work IMEP × V_swept, and a scene without gas
(no torque section at all).
"""

from pathlib import Path

import numpy as np
import pytest
from test_report import _parse, _value

import harmbal as hb
from harmbal.reporting.plots import pressure_figure, speed_fluctuation_figure, torque_figure, torque_spectrum_figure

ENGINES = Path(__file__).resolve().parent.parent / "datasets" / "engines"


@pytest.fixture(scope="module")
def tractor():
    """Three cylinders, four-stroke, with a flywheel: half orders and speed fluctuation."""
    return hb.analyse(hb.load_scene(ENGINES / "tractor-3cyl-gas.toml"))


@pytest.fixture(scope="module")
def tractor_html(tractor):
    return hb.report(tractor)


def by_gid(fig, gid):
    found = [a for ax in fig.axes for a in ax.get_children() if a.get_gid() == gid]
    assert len(found) == 1, gid
    return found[0]


def test_volume_is_the_virtual_work_of_the_gas_torque(tractor):
    torque = tractor["torque"].ds
    scene = hb.load_scene(ENGINES / "tractor-3cyl-gas.toml")
    theta = torque["angle"].values
    h = theta[1] - theta[0]
    volume = torque["volume"].values
    # Central difference of V(θ) over the periodic cycle: O(h²) ≈ 1e-5 relative at 720 samples/rev.
    dv = (np.roll(volume, -1, axis=-1) - np.roll(volume, 1, axis=-1)) / (2 * h)
    for i, c in enumerate(scene.cylinders):
        expected = (torque["pressure"].values[i] - c.gas.crankcase_pressure) * dv[i]
        gas = torque["gas_torque"].values[i]
        np.testing.assert_allclose(gas, expected, atol=1e-4 * np.abs(gas).max())
        # TDC and BDC of an offset slider-crank fall between samples: within r·h²/2 of the extremes.
        swept = float(torque["swept_volume"][i])
        assert 0 <= volume[i].min() < 1e-5 * swept
        assert swept * (1 - 1e-5) < volume[i].max() <= swept


def test_pressure_figure_draws_the_trace_and_the_pv_loop(tractor):
    torque = tractor["torque"].ds
    fig = pressure_figure(torque)
    span = 720.0
    for i, label in enumerate(torque["cylinder"].values):
        x, y = by_gid(fig, f"pressure-{label}").get_data()
        np.testing.assert_array_equal(y[:-1], torque["pressure"].values[i] / 1e5)
        assert (x[-1], y[-1]) == (span, y[0])
        fire = by_gid(fig, f"firing-{label}").get_xdata()[0]
        assert fire == pytest.approx(np.degrees(float(torque["firing_angle"][i])) % span)
        v, p = by_gid(fig, f"pv-{label}").get_data()
        # The loop's area (shoelace) is the indicated work ∮p dV = IMEP·V_swept; the loop is sampled
        # every 0.5°, the trapezoidal error of the peak is ~1e-4.
        area = 0.5 * abs(np.dot(v[:-1], p[1:]) - np.dot(v[1:], p[:-1])) * 1e-6 * 1e5
        work = float(torque["imep"][i] * torque["swept_volume"][i])
        assert area == pytest.approx(work, rel=1e-3)
        assert by_gid(fig, f"swept-{label}").get_xdata()[0] == pytest.approx(float(torque["swept_volume"][i]) * 1e6)
    fig = pressure_figure(torque, cylinders=["1"])
    assert [a.get_gid() for ax in fig.axes for a in ax.get_lines() if str(a.get_gid()).startswith("pv-")] == ["pv-1"]
    with pytest.raises(ValueError, match="no cylinder 9"):
        pressure_figure(torque, cylinders=["9"])


def test_torque_figure_draws_the_dataset(tractor):
    torque = tractor["torque"].ds
    fig = torque_figure(torque)
    for gid, values in (("torque-gas", torque["gas_torque"].sum("cylinder").values),
                        ("torque-mass", torque["mass_torque"].values),
                        ("torque-delivered", torque["torque"].values)):
        x, y = by_gid(fig, gid).get_data()
        np.testing.assert_allclose(y[:-1], values, rtol=1e-15, atol=0)
        assert x[-1] == 720.0
    assert by_gid(fig, "torque-mean").get_ydata()[0] == pytest.approx(float(torque["mean_torque"]))
    # The mean of the delivered torque is the mean torque: the mass torque's mean is zero.
    assert torque["torque"].values.mean() == pytest.approx(float(torque["mean_torque"]), rel=1e-9)


def test_torque_spectrum_bars_are_the_phasor_magnitudes_at_half_orders(tractor):
    torque = tractor["torque"].ds
    fig = torque_spectrum_figure(torque)
    gas = torque["gas_torque_order"].sum("cylinder")
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert "1.5" in labels and "0.5" in labels
    for k in (1.5, 3.0, 4.5):
        label = f"{k:g}"
        assert by_gid(fig, f"torque-gas-order{label}").get_height() == pytest.approx(abs(complex(gas.sel(order=k))))
        assert by_gid(fig, f"torque-delivered-order{label}").get_height() == pytest.approx(
            abs(complex(torque["torque_order"].sel(order=k))))
    # A three-cylinder four-stroke fires every 240°: the major orders are the multiples of 1.5, and the other
    # gas orders cancel (drawn as 0).
    majors = sorted(float(a.get_gid().removeprefix("major-order")) for a in fig.axes[0].get_children()
                    if str(a.get_gid()).startswith("major-order"))
    np.testing.assert_allclose(majors, np.arange(1, len(majors) + 1) * 1.5)
    assert by_gid(fig, "torque-gas-order1").get_height() == 0.0
    assert by_gid(fig, "torque-gas-order0.5").get_height() == 0.0


def test_speed_fluctuation_figure(tractor):
    torque = tractor["torque"].ds
    fig = speed_fluctuation_figure(torque)
    x, y = by_gid(fig, "speed").get_data()
    np.testing.assert_allclose(y[:-1], torque["omega"].values * 30 / np.pi, rtol=1e-15)
    # δ is taken at the extremes of the periodic solution between the samples, so the samples' spread is
    # a little smaller (0.5° apart: ~1e-4 relative).
    delta = (y.max() - y.min()) / float(torque["rpm"])
    assert delta <= float(torque["fluctuation_coefficient"])
    assert delta == pytest.approx(float(torque["fluctuation_coefficient"]), rel=1e-4)
    without = hb.analyse(hb.load_scene(ENGINES / "v8-cross-plane-gas.toml"))["torque"].ds
    with pytest.raises(ValueError, match=r"\[flywheel\]"):
        speed_fluctuation_figure(without)


def test_torque_section_tables_equal_the_dataset(tractor, tractor_html):
    torque = tractor["torque"].ds
    page = _parse(tractor_html)
    assert {"pressure", "torque", "torque-spectrum", "speed-fluctuation"} <= {name for name, _ in page.figures}
    cylinders, summary, orders, flywheel, fluctuation = page.tables["torque"]
    for row, imep, volume in zip(cylinders[1:], torque["imep"].values, torque["swept_volume"].values):
        assert _value(row[2]) == pytest.approx(volume * 1e6, rel=1e-4)
        assert _value(row[3]) == pytest.approx(imep / 1e5, rel=1e-3)
    assert _value(summary[1][1]) == pytest.approx(float(torque["mean_torque"]), rel=1e-4)
    gas = torque["gas_torque_order"].sum("cylinder").values
    printed = {float(row[0]): row for row in orders[1:]}
    assert set(printed) == set(torque["order"].values[1:])
    for k, row in printed.items():
        i = int(round(2 * k))
        assert (row[1] == "major") == bool(torque["major_order"].values[i])
        for cell, want in ((row[2], torque["torque_order"].values[i]), (row[4], gas[i])):
            assert _value(cell) == pytest.approx(abs(want), rel=1e-4, abs=1e-10 * np.abs(gas).max())
    assert _value(fluctuation[1][1]) == pytest.approx(float(torque["fluctuation_coefficient"]), rel=1e-3)
    assert _value(fluctuation[1][2]) == pytest.approx(float(torque["flywheel_inertia_needed"]), rel=1e-4)
    # The spectrum and traces of the loads run in half orders over 720°.
    spectrum = page.tables["spectrum"][1]
    assert [row[0] for row in spectrum[1:4]] == ["0.5", "1", "1.5"]
    assert "Over the working cycle (2 revolutions)" in tractor_html


def test_no_torque_section_without_gas():
    html = hb.report(hb.analyse(hb.load_scene(ENGINES / "tractor-3cyl.toml")))
    page = _parse(html)
    assert "torque" not in page.tables
    assert not {"pressure", "torque", "torque-spectrum"} & {name for name, _ in page.figures}
    assert "Over one revolution" in html
