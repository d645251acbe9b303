"""The report's section "Powertrain on its mounts" (harmbal.reporting.mount_report).

Oracles: the ``/mounts`` Dataset the page is made from (cells parsed back out
of the page and compared with it at the digits printed; the figures' plotted
data compared with it), the order spectrum's classes (the orders it classes
zero must be the ones left out, and their transmitted force must be
round-off), and the HTML itself (the section only for scenes with mounts,
every figure an inline SVG of non-zero size, no text cut off).
"""

import math
import re
from pathlib import Path

import numpy as np
import pytest
from test_report import _parse
from test_report_clipping import outside

import harmbal as hb
from harmbal.reporting import mount_report as mr
from harmbal.reporting.mount_tables import ZERO_SHARE
from harmbal.reporting.svg import report_style

ENGINES = Path(__file__).resolve().parent.parent / "datasets" / "engines"
FIGURES = ("mount-modes", "mount-force-map", "mount-forces")


@pytest.fixture(scope="module")
def scene():
    return hb.load_scene(ENGINES / "tractor-3cyl-mounts.toml")


@pytest.fixture(scope="module")
def tree(scene):
    return hb.analyse(scene)


@pytest.fixture(scope="module")
def page(tree):
    return hb.report(tree)


@pytest.fixture(scope="module")
def section(page):
    start = page.index('<section id="mounts">')
    return page[start:page.index("</section>", start)]


def _rows(section: str, css: str) -> list[list[str]]:
    """The body rows of the section's table of class ``css`` as cell texts (tags stripped)."""
    table = re.search(rf'<table class="{css}".*?<tbody>(.*?)</tbody>', section, re.S).group(1)
    return [[re.sub(r"<[^>]+>", "", cell) for cell in re.findall(r"<td[^>]*>(.*?)</td>", row, re.S)]
            for row in re.findall(r"<tr>(.*?)</tr>", table, re.S)]


def test_the_section_is_there_only_with_mounts(page):
    assert page.count('<section id="mounts">') == 1
    assert page.index('<section id="mounts">') < page.index('<section id="provenance">')
    plain = hb.report(hb.analyse(hb.load_scene(ENGINES / "single.toml")))
    assert 'id="mounts"' not in plain and "Powertrain on its mounts" not in plain


def test_statics_cells_are_the_datasets(section, tree):
    ds = tree["mounts"].ds
    rows = _rows(section, "mount-statics")
    mounts = [str(m) for m in ds["mount"].values]
    assert len(rows) == ds.sizes["case"] * len(mounts)
    for i, case in enumerate(ds["case"].values):
        group = rows[i * len(mounts):(i + 1) * len(mounts)]
        assert group[0][0].startswith("weight")
        roll = math.degrees(float(ds["static_roll"].sel(case=case)))
        assert float(group[0][1]) == pytest.approx(roll, abs=5e-4)  # printed to 3 decimals
        for j, row in enumerate(group):
            cells = row[2:] if j == 0 else row  # the case and its roll span the group's rows
            assert cells[0] == mounts[j]
            preload = float(ds["preload"].sel(case=case).values[j])
            assert float(cells[1]) == pytest.approx(preload, rel=5e-5)
            deflection = ds["static_deflection"].sel(case=case).values[j] * 1e3
            np.testing.assert_allclose([float(c) for c in cells[2:5]], deflection, atol=5e-4)
    # Under the weight alone the four mounts carry it: Σ preload = m g (compression, along w = z).
    weight = sum(float(r[3 if j == 0 else 1]) for j, r in enumerate(rows[:len(mounts)]))
    assert weight == pytest.approx(ds.attrs["powertrain_mass"] * 9.80665, rel=1e-4)


def test_modes_and_the_energy_heat_table_are_the_datasets(section, tree):
    ds = tree["mounts"].ds
    rows = _rows(section, "mount-modes")
    energy = ds["energy"].transpose("dof", "mode").values
    assert len(rows) == 6
    for j, row in enumerate(rows):
        assert int(row[0]) == int(ds["mode"].values[j])
        assert float(row[1]) == pytest.approx(float(ds["natural_frequency"][j]), abs=5e-4)
        assert float(row[2]) == pytest.approx(float(ds["damped_frequency"][j]), abs=5e-4)
        assert float(row[3]) == pytest.approx(float(ds["damping_ratio"][j]), abs=5e-4)
        assert float(row[4]) == pytest.approx(float(ds["frequency_ratio_idle_firing"][j]), abs=5e-4)
        assert row[5] == str(ds["dominant_dof"].values[j])
        np.testing.assert_allclose([float(c) for c in row[6:]], 100 * np.clip(energy[:, j], 0, 1), atol=0.05)
    cells = re.findall(r'<td class="heat" style="background:rgba\(0,114,178,([0-9.]+)\);[^"]*"( data-dominant="yes")?>',
                       section)
    shares = np.array([float(a) for a, _ in cells]).reshape(6, 6)
    np.testing.assert_allclose(shares, np.clip(energy.T, 0, 1), atol=5e-4)  # the cell's blue is its share
    dominant = np.array([bool(d) for _, d in cells]).reshape(6, 6)
    assert (dominant.sum(axis=1) == 1).all()
    assert (dominant.argmax(axis=1) == energy.argmax(axis=0)).all()


def test_torque_roll_axis_and_the_design_band(section, tree, scene):
    ds = tree["mounts"].ds
    angle = float(re.search(r"<strong>([0-9.]+)°</strong> from the torque roll axis", section).group(1))
    assert angle == pytest.approx(math.degrees(float(ds["tra_roll_mode_angle"])), abs=5e-3)
    tra = [float(v) for v in re.search(r"Torque roll axis \(([^)]+)\)", section).group(1).split(",")]
    np.testing.assert_allclose(tra, ds["torque_roll_axis"].values, atol=5e-5)
    low, high = scene.mount_design.frequency_band
    assert f"within {low:.4g}–{high:.4g} Hz" in section
    outside_band = [int(m) for m, f in zip(ds["mode"].values, ds["natural_frequency"].values) if not low <= f <= high]
    assert outside_band  # the tractor's roll mode is above 14 Hz: the page must say so
    assert f"mode{'s' if len(outside_band) > 1 else ''} {', '.join(map(str, outside_band))} outside" in section


def test_peak_forces_are_the_datasets(page, tree):
    ds = tree["mounts"].ds
    table = _parse(page).tables["mounts"][-1]
    header, rows = table[0], table[1:]
    orders = [float(h.split()[1].rstrip(":")) for h in header[1::2]]
    zero = mr.zero_orders(ds, tree["orders"].ds)
    assert [ds["order"].values[i] for i in mr.largest_orders(ds, zero)] == orders
    amplitude = ds["transmitted_force_amplitude"]
    rpm = ds["rpm"].values
    for row, mount in zip(rows, ds["mount"].values):
        assert row[0] == str(mount)
        for n, k in enumerate(orders):
            values = amplitude.sel(mount=mount, order=k).values
            assert float(row[1 + 2 * n]) == pytest.approx(values.max(), rel=5e-5)
            assert float(row[2 + 2 * n]) == pytest.approx(rpm[values.argmax()], rel=1e-6)
    total = np.sqrt((np.abs(ds["total_force"]) ** 2).sum("component"))
    assert rows[-1][0] == "total into the frame"
    for n, k in enumerate(orders):
        assert float(rows[-1][1 + 2 * n]) == pytest.approx(float(total.sel(order=k).max()), rel=5e-5)
    # The first order's couple drives the largest force (a three-cylinder's free moment).
    assert 1.0 in orders


def test_round_off_orders_are_the_spectrums_zero_ones_and_are_left_out(section, tree):
    ds, spectrum = tree["mounts"].ds, tree["orders"].ds
    unexcited = mr.unexcited_orders(ds, spectrum)
    k = ds["order"].values
    # An inline three on gas: the half orders that are not multiples of 1.5 cancel between the cylinders.
    assert set(k[unexcited]) >= {0.5, 2.5, 3.5}
    assert not unexcited[k == 1.0].any() and not unexcited[k == 1.5].any()
    amplitude = ds["transmitted_force_amplitude"].max(("speed", "mount")).values
    # What the classes call zero is round-off in the response too (the physics agrees with the classes).
    assert (amplitude[unexcited] <= 1e-12 * amplitude.max()).all()
    zero = mr.zero_orders(ds, spectrum)
    assert (zero >= unexcited).all()
    assert (amplitude[zero & ~unexcited] <= ZERO_SHARE * amplitude.max()).all()
    note = re.search(r"Round-off is not drawn:.*?</p>", section, re.S).group(0)
    assert "Orders 0.5, 2.5, 3.5" in note
    assert mr.largest_orders(ds, zero) and not zero[mr.largest_orders(ds, zero)].any()


def test_figures_are_inline_svgs_of_the_datasets_numbers(page, tree, scene):
    figures = {name: attrs for name, attrs in _parse(page).figures if name.startswith("mount")}
    assert set(figures) == set(FIGURES)
    for attrs in figures.values():
        assert float(attrs["width"].rstrip("pt")) > 0 and float(attrs["height"].rstrip("pt")) > 0
    ds = tree["mounts"].ds
    zero = mr.zero_orders(ds, tree["orders"].ds)
    with report_style():
        shown = mr.largest_orders(ds, zero)
        lines = mr.mount_force_figure(ds, orders=tuple(shown)).axes[0].get_lines()
        drawn = mr.force_map_figure(ds, zero=zero).axes[0].collections[0].get_array()
        modes = mr.modes_figure(ds, zero=zero, band=mr.design_band(scene.mount_design, ds)).axes[0]
    first = ds["transmitted_force_amplitude"].isel(mount=0)
    for line, i in zip(lines, shown):
        np.testing.assert_array_equal(line.get_ydata(), first.isel(order=i).values)
    amplitude = np.sqrt((np.abs(ds["total_force"].transpose("speed", "order", "component").values) ** 2).sum(-1))
    grid = np.ma.getmaskarray(drawn).reshape(ds.sizes["order"], ds.sizes["speed"])
    assert grid[zero].all() and not grid[~zero].any()  # the orders not excited are blank, the others drawn
    values = np.asarray(drawn).reshape(grid.shape)
    floor = amplitude.max() * 10.0 ** -mr.MAP_DECADES
    np.testing.assert_allclose(values[~zero], np.maximum(amplitude.T[~zero], floor), rtol=1e-15)
    heights = sorted({round(float(line.get_ydata()[0]), 12) for line in modes.get_lines()
                      if len(line.get_ydata()) == 2 and np.ptp(line.get_ydata()) == 0})
    assert set(np.round(ds["natural_frequency"].values, 12)) <= set(heights)


def test_no_text_of_the_sections_figures_is_cut_off(tree, scene):
    ds = tree["mounts"].ds
    zero = mr.zero_orders(ds, tree["orders"].ds)
    with report_style():
        figures = [mr.modes_figure(ds, zero=zero, band=mr.design_band(scene.mount_design, ds)),
                   mr.force_map_figure(ds, zero=zero),
                   mr.mount_force_figure(ds, orders=tuple(mr.largest_orders(ds, zero)))]
        for fig in figures:
            assert not outside(fig)


def test_a_three_point_system_at_one_speed():
    """The transverse inline four on its pendulum mounts at one speed: no map (it needs speeds), the
    other figures and tables; a mount count that leaves a panel empty keeps its axis labelled."""
    scene = hb.load_scene(ENGINES / "inline-4-transverse-mounts.toml")
    tree = hb.analyse(scene.with_speeds(np.array([3000.0]) * np.pi / 30))
    text = hb.report(tree)
    figures = {name for name, _ in _parse(text).figures if name.startswith("mount")}
    assert figures == {"mount-modes", "mount-forces"}
    table = _parse(text).tables["mounts"][-1]
    ds = tree["mounts"].ds
    assert [row[0] for row in table[1:]] == [str(m) for m in ds["mount"].values] + ["total into the frame"]
    order = float(table[0][1].split()[1].rstrip(":"))
    assert float(table[1][1]) == pytest.approx(float(ds["transmitted_force_amplitude"].sel(order=order)[0]),
                                               rel=5e-5)
    # The pendulum's lateral and roll modes share their energy: below the design's share, said and coloured.
    weak = [int(m) for m, e in zip(ds["mode"].values, ds["decoupling"].values) if e < scene.mount_design.decoupling]
    assert weak
    assert f"mode{'s' if len(weak) > 1 else ''} {', '.join(map(str, weak))} below the share" in text
    rows = _rows(text[text.index('<section id="mounts">'):], "mount-modes")
    assert len(rows) == 6
    coloured = re.findall(r'<td class="text" style="color:#a33b00[^"]*">([a-z]+)</td>', text)
    assert coloured == [str(ds["dominant_dof"].values[m - 1]) for m in weak]
    with report_style():
        fig = mr.mount_force_figure(ds, orders=(1,))
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == 3 and all(ax.get_xlabel() for ax in visible[-2:])


def test_the_section_from_an_archive_is_the_same_page(tmp_path):
    """/mounts read back from an archive lays out the same page, byte for byte (three speeds: a map)."""
    scene = hb.load_scene(ENGINES / "inline-4-transverse-mounts.toml")
    tree = hb.analyse(scene.with_speeds(np.array([1000.0, 3000.0, 5000.0]) * np.pi / 30))
    direct = hb.report(tree)
    assert 'data-figure="mount-force-map"' in direct
    hb.save(tree, tmp_path / "mounts.nc")
    assert hb.report(hb.open_archive(tmp_path / "mounts.nc")) == direct
