"""Report figures: the numbers drawn are the datasets' and the scenes' numbers."""

import re
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb

pytest.importorskip("matplotlib")

from harmbal.reporting.plots import (
    OKABE_ITO,
    lever_figure,
    locus_figure,
    order_spectrum_figure,
    phasing_figure,
    save_figure,
    time_traces_figure,
)

ENGINES = Path(__file__).parent.parent / "datasets" / "engines"
UNIT = re.compile(r"\[[^\]]+\]")


def scene(name):
    return hb.load_scene(ENGINES / f"{name}.toml")


@pytest.fixture(scope="module")
def data():
    """Scenes and their time-domain, order and joint datasets."""
    scenes = {name: scene(name) for name in ("inline-3", "inline-3-balanced", "test-single-balanced", "inline-4",
                                             "lever-single")}
    time = {name: hb.simulate(s) for name, s in scenes.items()}
    orders = {name: hb.order_spectrum(ds) for name, ds in time.items()}
    joints = {name: hb.joints(scenes[name]) for name in ("lever-single", "test-single-balanced")}
    return scenes, time, orders, joints


def by_gid(ax, gid):
    found = [a for a in ax.get_children() if a.get_gid() == gid]
    assert len(found) <= 1, gid
    return found[0] if found else None


def drawn_as_zero(value, ds, quantity, entry):
    """Zero to round-off or at most the negligible level (the roll's for the moment about x)."""
    level = ds["roll_negligible_level" if (quantity, entry) == ("moment", "x") else f"{quantity}_negligible_level"]
    return abs(complex(value)) <= max(ds.attrs["zero_rtol"] * float(ds[f"{quantity}_scale"]), float(level))


def series(ds, quantity):
    """(axes column, dataset variable, dim, entries) of the bar charts."""
    return ((0, ds[quantity], "axis", ("x", "y", "z")),
            (1, ds[f"{quantity}_rotating"], "rotation", ("co", "counter")))


@pytest.mark.parametrize("name", ["inline-3", "inline-3-balanced", "test-single-balanced"])
def test_bar_heights_are_the_phasor_magnitudes(data, name):
    ds = data[2][name]
    fig = order_spectrum_figure(ds)
    axes = np.reshape(fig.axes, (2, 2))
    for row, quantity in zip(axes, ("force", "moment")):
        for column, values, dim, entries in series(ds, quantity):
            for entry in entries:
                for k in ds.order.values:
                    value = values.sel({dim: entry, "order": k})
                    bar = by_gid(row[column], f"{quantity}-{entry}-order{k}")
                    expected = 0.0 if drawn_as_zero(value, ds, quantity, entry) else abs(complex(value))
                    assert bar.get_height() == pytest.approx(expected, rel=1e-12, abs=0)
                    assert bar.get_facecolor()[:3] in [tuple(int(c[i:i + 2], 16) / 255 for i in (1, 3, 5))
                                                       for c in OKABE_ITO.values()]


def test_chosen_components(data):
    # Inline three: a free first-order moment about y; its first-order force is balanced.
    ds = data[2]["inline-3"]
    ax_force, ax_force_rot, ax_moment, ax_moment_rot = order_spectrum_figure(ds).axes
    moment = abs(complex(ds.moment.sel(order=1, axis="y")))
    assert moment > 1000
    assert by_gid(ax_moment, "moment-y-order1").get_height() == pytest.approx(moment, rel=1e-12)
    counter = abs(complex(ds.moment_rotating.sel(order=1, rotation="counter")))
    assert by_gid(ax_moment_rot, "moment-counter-order1").get_height() == pytest.approx(counter, rel=1e-12)
    assert drawn_as_zero(ds.force.sel(order=1, axis="z"), ds, "force", "z")
    assert by_gid(ax_force, "force-z-order1").get_height() == 0
    assert by_gid(ax_force_rot, "force-co-order1").get_height() == 0


def test_log_scale_omits_zero_and_negligible_components(data):
    ds = data[2]["inline-3-balanced"]
    fig = order_spectrum_figure(ds, log=True)
    axes = np.reshape(fig.axes, (2, 2))
    drawn = absent = 0
    for row, quantity in zip(axes, ("force", "moment")):
        for column, values, dim, entries in series(ds, quantity):
            ax = row[column]
            assert ax.get_yscale() == "log"
            heights = [p.get_height() for p in ax.patches]
            if heights:  # else every component is zero or negligible: nothing drawn
                assert min(heights) > 0
                bottom, top = ax.get_ylim()
                assert bottom <= min(heights) and top >= max(heights) and top / bottom >= 1e3  # three decades at least
            for entry in entries:
                for k in ds.order.values:
                    value = values.sel({dim: entry, "order": k})
                    bar = by_gid(ax, f"{quantity}-{entry}-order{k}")
                    if drawn_as_zero(value, ds, quantity, entry):
                        assert bar is None
                        absent += 1
                    else:
                        assert bar.get_height() == pytest.approx(abs(complex(value)), rel=1e-12)
                        drawn += 1
    assert drawn and absent
    # The designed balancers cancel order 1 entirely.
    assert by_gid(fig.axes[2], "moment-y-order1") is None
    assert by_gid(fig.axes[3], "moment-co-order1") is None


def test_max_order(data):
    ds = data[2]["inline-3"]
    ax = order_spectrum_figure(ds, max_order=4).axes[2]
    gids = {p.get_gid() for p in ax.patches}
    assert gids == {f"moment-{a}-order{k}" for a in "xyz" for k in range(5)}


def test_time_traces_are_the_simulated_values(data):
    before, after = data[1]["inline-3"], data[1]["inline-3-balanced"]
    fig = time_traces_figure(before, hide_negligible=False)  # inline-3's force is negligible
    for ax, quantity in zip(fig.axes, ("force", "moment")):
        assert len(ax.get_lines()) == 3 + 1  # the axes and the zero line
        assert all(line.get_linestyle() == "-" for line in ax.get_lines())
        for axis in "xyz":
            line = by_gid(ax, f"{quantity}-{axis}-before")
            x, y = line.get_data()
            np.testing.assert_array_equal(y[:-1], before[quantity].sel(axis=axis).values)
            np.testing.assert_allclose(x[:-1], np.degrees(before.angle.values), rtol=1e-15)
            assert (x[-1], y[-1]) == (360.0, y[0])
        assert "after" not in [t.get_text() for t in ax.get_legend().get_texts()]

    fig = time_traces_figure(before, after=after, hide_negligible=False)
    for ax, quantity in zip(fig.axes, ("force", "moment")):
        for axis in "xyz":
            solid, dashed = by_gid(ax, f"{quantity}-{axis}-before"), by_gid(ax, f"{quantity}-{axis}-after")
            assert dashed.get_linestyle() == "--" and solid.get_linestyle() == "-"
            assert dashed.get_color() == solid.get_color()
            np.testing.assert_array_equal(dashed.get_ydata()[:-1], after[quantity].sel(axis=axis).values)
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert legend[-2:] == ["before", "after"]


def test_locus_is_the_transverse_components(data):
    before, after = data[1]["inline-3"], data[1]["inline-3-balanced"]
    fig = locus_figure(before, hide_negligible=False)  # inline-3's force is negligible
    for ax, quantity in zip(fig.axes, ("force", "moment")):
        line = by_gid(ax, f"{quantity}-locus-before")
        x, y = line.get_data()
        np.testing.assert_array_equal(x[:-1], before[quantity].sel(axis="y").values)
        np.testing.assert_array_equal(y[:-1], before[quantity].sel(axis="z").values)
        assert (x[-1], y[-1]) == (x[0], y[0])
        assert list(by_gid(ax, f"{quantity}-origin").get_xydata()[0]) == [0, 0]
        assert ax.get_aspect() == 1.0
        assert by_gid(ax, f"{quantity}-locus-after") is None and ax.get_legend() is None

    fig = locus_figure(before, after=after, hide_negligible=False)
    for ax, quantity in zip(fig.axes, ("force", "moment")):
        dashed = by_gid(ax, f"{quantity}-locus-after")
        assert dashed.get_linestyle() == "--"
        np.testing.assert_array_equal(dashed.get_xdata()[:-1], after[quantity].sel(axis="y").values)
        assert [t.get_text() for t in ax.get_legend().get_texts()] == ["before", "after"]


def test_after_at_another_speed_raises(data):
    with pytest.raises(ValueError, match="rpm"):
        time_traces_figure(data[1]["inline-3"], after=data[1]["test-single-balanced"])
    with pytest.raises(ValueError, match="rpm"):
        locus_figure(data[1]["inline-3"], after=data[1]["test-single-balanced"])


def test_speed_index_selects_the_speed(data):
    time, orders = data[1]["inline-4"], data[2]["inline-4"]
    rpm = [float(v) for v in time.rpm.values]
    assert len(rpm) == 2 and rpm[0] != rpm[1]
    for figure in (time_traces_figure, locus_figure, order_spectrum_figure):
        dataset = orders if figure is order_spectrum_figure else time
        assert f"{rpm[0]:g} rpm" in figure(dataset).get_suptitle()
        assert f"{rpm[1]:g} rpm" in figure(dataset, speed=1).get_suptitle()
    ax = time_traces_figure(time, speed=1).axes[0]
    np.testing.assert_array_equal(by_gid(ax, "force-z-before").get_ydata()[:-1],
                                  time.force.isel(speed=1).sel(axis="z").values)
    ax = order_spectrum_figure(orders, speed=1).axes[0]
    fast = abs(complex(orders.force.isel(speed=1).sel(order=2, axis="z")))
    assert fast > abs(complex(orders.force.isel(speed=0).sel(order=2, axis="z")))
    assert by_gid(ax, "force-z-order2").get_height() == pytest.approx(fast, rel=1e-12)
    with pytest.raises(ValueError, match="single speed"):
        time_traces_figure(data[1]["inline-3"], speed=1)


@pytest.mark.parametrize("name", ["inline-3-balanced", "test-single-balanced"])
def test_phasing_arrows_are_n_squared_u_at_their_angles(data, name):
    s = data[0][name]
    ax = phasing_figure(s).axes[0]
    elements = [shaft for shaft in s.shafts if shaft.unbalances]
    assert len(elements) >= 3
    for i, shaft in enumerate(elements):
        arrows = by_gid(ax, f"phasing-{i}")
        assert list(arrows.X) == [0] * len(shaft.unbalances) and list(arrows.Y) == [0] * len(shaft.unbalances)
        for u, v, unbalance in zip(arrows.U, arrows.V, shaft.unbalances):
            length = shaft.ratio**2 * unbalance.unbalance
            # +z up, the direction of rotation (t) to the right.
            assert (u, v) == pytest.approx((length * np.sin(unbalance.angle), length * np.cos(unbalance.angle)),
                                           rel=1e-12, abs=1e-12 * length)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert len(labels) == len(elements)
    for label, shaft in zip(labels, elements):
        assert label.startswith(shaft.label)
        assert label.count(f"{'+' if shaft.ratio > 0 else '−'}{abs(shaft.ratio)}×") == 1
    assert "+z up" in ax.get_title() and "rotation to the right" in ax.get_title()


def test_phasing_from_the_scene_file():
    # inline-3-balanced.toml: counterweights 1 is 0.021290… kg m at 330°; the
    # balance shaft (ratio −1) carries 0.00999… kg m at 30° and at 210°.
    ax = phasing_figure(scene("inline-3-balanced")).axes[0]
    cw = by_gid(ax, "phasing-0")
    u = 0.021290487978416463
    assert (cw.U[0], cw.V[0]) == pytest.approx((u * np.sin(np.radians(330)), u * np.cos(np.radians(330))))
    shaft = by_gid(ax, "phasing-2")
    u = 0.00999034960627745
    np.testing.assert_allclose(shaft.U, u * np.sin(np.radians([30, 210])), rtol=1e-12)
    np.testing.assert_allclose(shaft.V, u * np.cos(np.radians([30, 210])), rtol=1e-12)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "counterweights 1 +1×", "counterweights 2 +1×", "balance shaft −1×"]


def test_phasing_without_balancers(data):
    ax = phasing_figure(data[0]["inline-3"]).axes[0]
    assert "no balancer elements" in [t.get_text() for t in ax.texts]
    assert not [c for c in ax.get_children() if (c.get_gid() or "").startswith("phasing")]


def test_lever_figure(data):
    joints = data[3]["lever-single"]
    left, right = lever_figure(joints).axes
    lines = left.get_lines()
    assert [line.get_label() for line in lines] == [str(j) for j in joints.joint.values]
    magnitude = np.hypot(joints.joint_force.sel(axis="y"), joints.joint_force.sel(axis="z"))
    for line, expected in zip(lines, magnitude.transpose("joint", "angle").values):
        np.testing.assert_allclose(line.get_ydata()[:-1], expected, rtol=1e-14)
        assert line.get_xdata()[-1] == 360
    assert [t.get_text() for t in left.get_legend().get_texts()] == [str(j) for j in joints.joint.values]

    gamma = by_gid(right, "transmission-0")
    np.testing.assert_allclose(gamma.get_ydata()[:-1], np.degrees(joints.transmission_angle.sel(lever="lever")),
                               rtol=1e-14)
    marker = by_gid(right, "min-transmission-0")
    low = np.degrees(float(joints.min_transmission_angle.sel(lever="lever")))
    where = np.degrees(float(joints.min_transmission_theta.sel(lever="lever")))
    assert tuple(marker.get_xydata()[0]) == pytest.approx((where, low), rel=1e-14)
    assert low == pytest.approx(69.2, abs=0.05)  # as the scene file says
    assert gamma.get_ydata().min() >= low - 1e-6  # the sampled curve never dips below the closed form
    np.testing.assert_allclose(by_gid(right, "transmission-warning").get_ydata(), [30, 30], rtol=1e-12)


def test_lever_figure_without_a_lever(data):
    left, right = lever_figure(data[3]["test-single-balanced"]).axes
    assert "no lever balancer" in [t.get_text() for t in right.texts]
    assert not right.get_lines()
    assert len(left.get_lines()) == data[3]["test-single-balanced"].sizes["joint"]


def figures(data):
    scenes, time, orders, joints = data
    return {
        "orders": lambda: order_spectrum_figure(orders["inline-3-balanced"]),
        "orders-log": lambda: order_spectrum_figure(orders["inline-4"], log=True, speed=1),
        "traces": lambda: time_traces_figure(time["inline-3"], after=time["inline-3-balanced"]),
        "locus": lambda: locus_figure(time["inline-3"], after=time["inline-3-balanced"]),
        "phasing": lambda: phasing_figure(scenes["test-single-balanced"]),
        "phasing-none": lambda: phasing_figure(scenes["inline-3"]),
        "lever": lambda: lever_figure(joints["lever-single"]),
        "lever-none": lambda: lever_figure(joints["test-single-balanced"]),
    }


def test_every_axes_is_labelled_with_units(data):
    from matplotlib.figure import Figure

    for name, make in figures(data).items():
        fig = make()
        assert isinstance(fig, Figure), name
        assert fig.axes, name
        for ax in fig.axes:
            assert UNIT.search(ax.get_xlabel()) and UNIT.search(ax.get_ylabel()), (name, ax.get_title())


def test_svg_is_deterministic(data, tmp_path):
    for name, make in figures(data).items():
        a = save_figure(make(), tmp_path / f"{name}-a.svg").read_bytes()
        b = save_figure(make(), tmp_path / f"{name}-b.svg").read_bytes()
        assert a == b, name
        assert b"<svg" in a
