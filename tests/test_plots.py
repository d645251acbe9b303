"""Figures: crank stars and phasor diagrams drawn from the stars dataset."""

import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import tomli_w

import harmbal as hb
from harmbal.cli import main

pytest.importorskip("matplotlib")

from harmbal.reporting.plots import (
    crank_star,
    default_orders,
    phasor_chain,
    phasor_diagram,
    save_figure,
    select_speed,
    stars_figure,
)

ENGINES = Path(__file__).parent.parent / "datasets" / "engines"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SVG = "{http://www.w3.org/2000/svg}"


def scene_path(name):
    return ENGINES / f"{name}.toml"


@pytest.fixture(scope="module")
def datasets():
    return {name: hb.stars(hb.load_scene(scene_path(name)))
            for name in ("inline-3", "inline-4", "v-twin-90", "v8-cross-plane")}


def svg_axes(path):
    root = ET.parse(path).getroot()
    return [g for g in root.iter(f"{SVG}g") if g.get("id", "").startswith("axes_")]


def by_gid(ax, gid):
    found = [a for a in ax.get_children() if a.get_gid() == gid]
    assert len(found) == 1, gid
    return found[0]


@pytest.mark.parametrize("name", ["inline-3", "inline-4", "v-twin-90", "v8-cross-plane"])
def test_figure_builds_and_writes_svg_and_png(datasets, tmp_path, name):
    ds = datasets[name]
    fig = stars_figure(ds)
    orders = default_orders(ds)
    assert 1 in orders and 2 in orders and len(orders) <= 6
    assert len(fig.axes) == 3 * len(orders)
    assert name in fig._suptitle.get_text() and "rpm" in fig._suptitle.get_text()
    for ax in fig.axes:
        assert ax.get_xlabel() and ax.get_ylabel() and ax.get_title()
        assert ax.get_aspect() == 1.0
    svg = save_figure(fig, tmp_path / "f.svg")
    assert svg == tmp_path / "f.svg" and svg.stat().st_size > 0
    assert len(svg_axes(svg)) == 3 * len(orders)
    png = save_figure(fig, tmp_path / "f.PNG")
    assert png.read_bytes().startswith(PNG_SIGNATURE)
    # Nothing else (no temporary files) is left behind.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.PNG", "f.svg"]


def test_default_orders_are_one_two_and_the_free_ones(datasets):
    ds = datasets["inline-4"]
    free = (ds.force_free | ds.moment_free).any("rotation")
    expected = sorted({1, 2} | {int(k) for k in ds.order.values[free.values] if 1 <= k <= 8})[:6]
    assert default_orders(ds) == expected
    # Inline four: the even orders add; 6 and 8 (≈ 4 N and 0.1 N at 6000 rpm) are below the negligible level.
    assert default_orders(ds) == [1, 2, 4]


def test_svg_is_deterministic(datasets, tmp_path):
    ds = datasets["v-twin-90"]
    a = save_figure(stars_figure(ds, orders=[1, 2]), tmp_path / "a.svg").read_bytes()
    b = save_figure(stars_figure(ds, orders=[1, 2]), tmp_path / "b.svg").read_bytes()
    assert a == b


@pytest.mark.parametrize("suffix", [".pdf", ".jpg", ""])
def test_wrong_extension_raises_and_writes_nothing(datasets, tmp_path, suffix):
    fig = stars_figure(datasets["inline-3"], orders=[1])
    with pytest.raises(ValueError, match="svg or .png"):
        save_figure(fig, tmp_path / f"x{suffix}")
    assert list(tmp_path.iterdir()) == []


def test_failed_write_leaves_nothing(datasets, tmp_path, monkeypatch):
    fig = stars_figure(datasets["inline-3"], orders=[1])

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(fig, "savefig", broken)
    with pytest.raises(RuntimeError):
        save_figure(fig, tmp_path / "x.svg")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["inline-3", "v-twin-90", "v8-cross-plane"])
@pytest.mark.parametrize("quantity", ["force", "moment"])
@pytest.mark.parametrize("order", [1, 2, 4])
def test_phasor_arrows_end_at_the_resultant(datasets, name, quantity, order):
    ds = datasets[name]
    sel, _ = select_speed(ds)
    ax = phasor_diagram(ds, order, quantity)
    tol = 1e-9 * float(sel[f"{quantity}_scale"])
    for rotation in ("co", "counter"):
        resultant = complex(sel[f"{quantity}_rotating"].sel(order=order, rotation=rotation))
        per_cylinder = sel[f"{quantity}_cylinder"].sel(order=order, rotation=rotation).values
        chain = by_gid(ax, f"order{order}-{quantity}-{rotation}-cylinders")
        # Page coordinates: horizontal t = Im w, vertical z = Re w.
        tails = chain.Y + 1j * chain.X
        arrows = chain.V + 1j * chain.U
        np.testing.assert_allclose(arrows[:len(per_cylinder)], per_cylinder, rtol=0, atol=tol)
        assert tails[0] == 0
        np.testing.assert_allclose(tails[1:], (tails + arrows)[:-1], rtol=0, atol=tol)  # head to tail
        assert abs((tails + arrows)[-1] - resultant) <= tol
        drawn = by_gid(ax, f"order{order}-{quantity}-{rotation}-resultant")
        if resultant == 0:
            assert not bool(sel[f"{quantity}_free"].sel(order=order, rotation=rotation))
            assert list(drawn.get_xdata()) == [0] and list(drawn.get_ydata()) == [0]
        else:
            assert (drawn.X[0], drawn.Y[0]) == (0, 0)
            assert drawn.V[0] + 1j * drawn.U[0] == pytest.approx(resultant)
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert len(legend) == 2
    unit = "N m" if quantity == "moment" else "N"
    for text, rotation in zip(legend, ("co", "counter")):
        assert text.startswith(rotation)
        assert "balanced" in text or text.endswith("°") and f"{unit} at" in text


def test_resultant_amplitude_in_legend(datasets):
    ds = datasets["v-twin-90"]
    ax = phasor_diagram(ds, 1, "force")
    co, counter = (t.get_text() for t in ax.get_legend().get_texts())
    amplitude = abs(complex(ds.force_rotating.sel(order=1, rotation="co")))
    assert co == f"co Σ: {amplitude / 1000:.4g} kN at 0.0°"
    assert counter == "counter: balanced"  # 90° V-twin: cos γ = 0


def test_crankshaft_unbalances_close_the_chain(tmp_path, base_scene):
    base_scene["crankshaft_unbalance"] = [{"unbalance": "0.02 kg m", "angle": "30 deg", "axial_position": "10 mm"}]
    path = tmp_path / "cw.toml"
    path.write_text(tomli_w.dumps(base_scene))
    ds = hb.stars(hb.load_scene(path))
    labels, arrows, resultant = phasor_chain(ds, 1, "force", "co")
    assert labels == ["1", "2", "crankshaft"]
    assert abs(arrows.sum() - resultant) <= 1e-9 * float(ds.force_scale)
    # A static unbalance U at α: co-rotating U·ω²·e^{iα}.
    assert arrows[-1] == pytest.approx(0.02 * float(ds.speed) ** 2 * np.exp(1j * np.radians(30)))
    assert phasor_chain(ds, 1, "force", "counter")[0] == ["1", "2"]
    ax = phasor_diagram(ds, 1, "force")
    chain = by_gid(ax, "order1-force-co-cylinders")
    assert len(chain.U) == 3


def test_crank_star_arms(datasets):
    ds = datasets["inline-3"]
    ax = crank_star(ds, 1)
    for label, throw in zip(ds.cylinder.values, ds.throw.values):
        arm = by_gid(ax, f"order1-star-arm-{label}")
        x, y = arm.get_data()
        # Angle a drawn at (sin a, cos a): +z up, clockwise in the direction of rotation.
        np.testing.assert_allclose([x[0], y[0], x[1], y[1]], [0, 0, np.sin(throw), np.cos(throw)],
                                   atol=1e-12)  # scale: 1 (the unit circle)
    assert "regular" in ax.get_title() and "not" not in ax.get_title()
    ax = crank_star(ds, 6)  # one arm, three cylinders
    by_gid(ax, "order6-star-arm-1,2,3")
    assert "not regular" in ax.get_title()


def test_crank_star_colours_banks(datasets):
    ds = datasets["v-twin-90"]
    ax = crank_star(ds, 1)
    one, two = by_gid(ax, "order1-star-arm-1"), by_gid(ax, "order1-star-arm-2")
    assert one.get_color() != two.get_color()
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend[0].startswith("bank -45°") and legend[1].startswith("bank +45°")
    # Inline engines: one bank, no legend.
    assert crank_star(datasets["inline-3"], 1).get_legend() is None


def test_several_speeds(datasets):
    ds = datasets["v8-cross-plane"]
    assert "speed" in ds.dims and ds.sizes["speed"] == 2
    rpm = [float(v) for v in ds.rpm.values]
    assert stars_figure(ds, orders=[1])._suptitle.get_text().count(f"{rpm[0]:g} rpm") == 1
    fig = stars_figure(ds, orders=[1], speed=rpm[1])
    assert f"{rpm[1]:g} rpm" in fig._suptitle.get_text()
    ax = phasor_diagram(ds, 1, "moment", speed=rpm[1])
    chain = by_gid(ax, "order1-moment-co-cylinders")
    fast = ds.moment_cylinder.isel(speed=1).sel(order=1, rotation="co").values
    np.testing.assert_allclose(chain.V + 1j * chain.U, fast, atol=1e-9 * float(ds.moment_scale[1]))
    with pytest.raises(ValueError, match="speed"):
        stars_figure(ds, speed=1234.0)


def test_bad_arguments(datasets):
    ds = datasets["inline-3"]
    with pytest.raises(ValueError, match="order"):
        stars_figure(ds, orders=[ds.sizes["order"]])
    with pytest.raises(ValueError, match="positive"):
        stars_figure(ds, orders=[0])
    with pytest.raises(ValueError, match="quantity"):
        phasor_diagram(ds, 1, "torque")


def test_cli_plot_writes_svg_and_png(tmp_path, capsys):
    out = tmp_path / "s.svg"
    assert main(["stars", str(scene_path("v-twin-90")), "--plot", str(out)]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    assert len(svg_axes(out)) == 3 * 3  # orders 1, 2, 4 (6 and 8 are below the negligible level)
    png = tmp_path / "s.png"
    assert main(["stars", str(scene_path("inline-4")), "--plot", str(png), "--orders", "2"]) == 0
    assert png.read_bytes().startswith(PNG_SIGNATURE)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.png", "s.svg"]


def test_cli_plot_wrong_extension_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "x.pdf"
    assert main(["stars", str(scene_path("inline-3")), "--plot", str(out)]) == 2
    assert ".svg or .png" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_import_harmbal_does_not_import_matplotlib():
    code = ("import harmbal, harmbal.reporting.plots, sys; "
            "assert 'matplotlib' not in sys.modules, 'matplotlib imported'")
    root = Path(__file__).parent.parent
    env = {**os.environ, "PYTHONPATH": str(root)}
    subprocess.run([sys.executable, "-c", code], check=True, cwd=root, env=env)


def test_figures_do_not_touch_pyplot(datasets):
    stars_figure(datasets["inline-3"], orders=[1])
    if "matplotlib.pyplot" in sys.modules:  # imported by someone else: it must have no figures of ours
        import matplotlib.pyplot as plt

        assert plt.get_fignums() == []


@pytest.mark.parametrize("name", ["inline-3", "inline-4", "v-twin-90", "v8-cross-plane"])
def test_docs_figures_exist_and_are_small(name):
    """docs/make_figures.py output, committed: SVG with whole rows of axes, < 300 kB."""
    path = Path(__file__).parent.parent / "docs" / "figures" / f"stars-{name}.svg"
    assert path.is_file(), "run python docs/make_figures.py"
    assert 0 < path.stat().st_size < 300_000
    axes = len(svg_axes(path))
    assert axes >= 6 and axes % 3 == 0
