"""Exact zero, negligible, free: the three classes of an order component
(harmbal.orders.spectrum.classify), in the datasets, the verdicts, the tables
and the archive.

Oracles: the class definitions re-derived from the amplitudes and the load
scales (no shared code with the classifier), the bundled engines, and the
closed-form inline-3 (forces cancel at orders 1, 2, 4: zero; the first-order
moment √3·m r ω² a: free)."""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.cli import main
from harmbal.orders.spectrum import CLASSES, classify, negligible_level, phase_degrees
from harmbal.reporting.tables import stars_table, verdict
from harmbal.scene.schema import DEFAULT_NEGLIGIBLE
from harmbal.views.stars import stars, with_free_vectors

ROOT = Path(__file__).resolve().parent.parent
SCENES = sorted((ROOT / "datasets" / "engines").glob("*.toml"))


def _analyse(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return hb.analyse(hb.load_scene(path), **kwargs)


def _expected(amplitude, scale, cylinders, fraction):
    """The classes by their definition: zero at most 1e-10 of the load scale, free above
    ``fraction`` × the scale / cylinders, negligible between."""
    a = np.abs(amplitude)
    return np.select([a <= 1e-10 * scale, a <= fraction * scale / cylinders], [0, 1], 2)


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_no_bundled_engine_calls_a_load_below_the_level_free(path, monkeypatch):
    monkeypatch.chdir(ROOT)
    scene = hb.load_scene(path)
    tree = _analyse(path)
    stars = with_free_vectors(tree["stars"].ds, tree["orders"].ds)
    n = len(scene.cylinders)
    for sel in ([stars.isel(speed=i) for i in range(stars.sizes["speed"])] if "speed" in stars.dims else [stars]):
        # /stars judges the inertial loads at unit speed: the same classes at every speed.
        for name in ("force", "moment"):
            scale = float(sel[f"{name}_scale"])
            level = float(sel[f"{name}_negligible_level"])
            assert level == pytest.approx(DEFAULT_NEGLIGIBLE * scale / n, rel=1e-12)
            amplitude = np.abs(sel[f"{name}_rotating"].values)
            codes = sel[f"{name}_class"].values
            # Amplitudes within round-off of a boundary could go either way; none of the bundled ones is.
            assert np.array_equal(codes, _expected(amplitude, scale, n, DEFAULT_NEGLIGIBLE)), name
            assert np.array_equal(sel[f"{name}_free"].values, amplitude > level)
        for k in sel["order"].values[1:]:
            text = verdict(sel, int(k))
            free = [float(np.abs(sel[f"{q}_rotating"].sel(order=k)).max()) for q in ("force", "moment")
                    if bool(sel[f"{q}_free"].sel(order=k).any())]
            if "(" in text:  # a remedy: only for a component above the negligible level
                assert free, (path.stem, k, text)
            if text in ("balanced", "negligible"):
                assert not free and not bool(sel["roll_free"].sel(order=k))


@pytest.mark.parametrize("stem", ["v8-cross-plane", "tractor-3cyl-gas", "v8-cross-plane-gas", "single"])
def test_the_orders_classes_follow_their_definition(stem):
    scene = hb.load_scene(ROOT / "datasets" / "engines" / f"{stem}.toml")
    orders = _analyse(ROOT / "datasets" / "engines" / f"{stem}.toml")["orders"].ds
    n = len(scene.cylinders)
    assert orders.attrs["negligible"] == DEFAULT_NEGLIGIBLE and orders.attrs["cylinders"] == n
    for i in range(orders.sizes.get("speed", 1)):
        sel = orders.isel(speed=i) if "speed" in orders.dims else orders
        roll = sel["moment"].values[:, 0]
        # The roll is judged against the whole moment scale at this speed (with the gas torque's)...
        scale = float(sel["moment_scale"])
        assert np.array_equal(sel["roll_class"].values, _expected(roll, scale, n, DEFAULT_NEGLIGIBLE))
        assert float(sel["roll_negligible_level"]) == pytest.approx(DEFAULT_NEGLIGIBLE * scale / n, rel=1e-12)
    # ... the force and the transverse moment against the inertial scale: the same classes at every speed.
    for name in ("force", "moment"):
        assert orders[f"{name}_class"].dims == ("order", "rotation")
        assert list(orders[f"{name}_class"].attrs["flag_meanings"].split()) == list(CLASSES)


def test_inline_3_zero_and_free_are_the_closed_form_s():
    tree = _analyse(ROOT / "datasets" / "engines" / "inline-3.toml")
    stars = tree["stars"].ds
    assert all(int(stars["force_class"].sel(order=k).max()) == 0 for k in (1, 2, 4))
    assert (stars["moment_class"].sel(order=1).values == 2).all()


def test_the_setting_moves_the_level(tmp_path):
    text = (ROOT / "datasets" / "engines" / "tractor-3cyl.toml").read_text(encoding="utf-8")
    assert "[model]" not in text
    scene_file = tmp_path / "tractor.toml"
    scene_file.write_text(text + "\n[model]\nnegligible = 1e-2\n", encoding="utf-8")
    scene = hb.load_scene(scene_file)
    assert scene.model.negligible == 1e-2
    coarse = stars(scene)
    fine = stars(scene.with_negligible(1e-6))
    # The tractor's fourth-order moment (≈ 8 N m at 2460 rpm) is free at 1e-3 and 1e-6, negligible at 1e-2.
    level = float(coarse["moment_negligible_level"])
    amplitude = float(np.abs(coarse["moment_rotating"].sel(order=4)).max())
    assert level / 10 < amplitude < level
    assert (coarse["moment_class"].sel(order=4).values == 1).all()
    assert (fine["moment_class"].sel(order=4).values == 2).all()
    assert float(fine["moment_negligible_level"]) == pytest.approx(level * 1e-4, rel=1e-12)


@pytest.mark.parametrize("value", ["0", "0.5", "-1e-3", '"much"'])
def test_a_bad_setting_is_refused_naming_the_key(tmp_path, capsys, value):
    text = (ROOT / "datasets" / "engines" / "tractor-3cyl.toml").read_text(encoding="utf-8")
    scene_file = tmp_path / "tractor.toml"
    scene_file.write_text(text + f"\n[model]\nnegligible = {value}\n", encoding="utf-8")
    assert main(["run", str(scene_file)]) == 2
    err = capsys.readouterr().err
    assert "model.negligible" in err and str(scene_file) in err


def test_the_cli_setting_overrides_the_scene(capsys):
    scene = str(ROOT / "datasets" / "engines" / "tractor-3cyl.toml")
    assert main(["stars", scene, "--negligible", "1e-2"]) == 0
    row = next(line for line in capsys.readouterr().out.splitlines() if re.match(r"\s+4\s", line))
    assert row.rstrip().endswith("negligible")
    with pytest.raises(SystemExit) as exit_:
        main(["run", scene, "--negligible", "1"])
    assert exit_.value.code == 2 and "--negligible" in capsys.readouterr().err


def test_tables_print_negligible_as_such_not_noise(capsys):
    # The V-twin's order 12 (≈ 2.5e-5 N at 9000 rpm) used to be "free", with "+12× and −12× shafts".
    assert main(["stars", str(ROOT / "datasets" / "engines" / "v-twin-90.toml")]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if re.match(r"\s+12\s", line))
    assert "shaft" not in row and "pair" not in row and row.rstrip().endswith("negligible")
    assert re.sub(r"[\s~0]", "", row.split("negligible")[0][6:]) == ""
    assert "~0: negligible" in out


def test_the_archive_keeps_the_classes_and_the_setting(tmp_path):
    scene = hb.load_scene(ROOT / "datasets" / "engines" / "v8-cross-plane.toml").with_negligible(2e-3)
    tree = hb.analyse(scene)
    hb.save(tree, tmp_path / "v8.nc")
    back = hb.open_archive(tmp_path / "v8.nc")
    for group in ("orders", "stars"):
        assert back[group].attrs["negligible"] == 2e-3
        for name in ("force_class", "moment_class", "roll_class"):
            assert np.array_equal(back[group][name].values, tree[group][name].values)
            assert back[group][name].attrs["flag_meanings"] == "zero negligible free"
        for name in ("force_negligible_level", "moment_negligible_level"):
            np.testing.assert_allclose(back[group][name].values, tree[group][name].values, rtol=1e-15)


def test_classify_on_the_boundaries():
    scale = 1e4
    level = negligible_level(scale, 4, 1e-3)
    assert level == 2.5
    codes = classify(np.array([0, 2e-6, 1e-6, 2.5, 2.5000001, 1e3]), scale, level)
    assert codes.tolist() == [0, 1, 0, 1, 2, 2]


@pytest.mark.parametrize("phasor, expected", [(complex(-1, -1e-9), 180.0), (complex(-1, 1e-9), 180.0),
                                              (complex(1, -1e-9), 0.0), (complex(0, -1), -90.0),
                                              (np.exp(-1j * np.radians(179.96)), 180.0),
                                              (np.exp(-1j * np.radians(179.94)), -179.9)])
def test_phases_print_in_the_half_open_interval(phasor, expected):
    phase = phase_degrees(phasor, 1)
    assert phase == expected and -180.0 < phase <= 180.0
    assert str(phase) != "-0.0"


def test_stars_table_of_an_old_archive_without_classes():
    # Archives written before the classes have only the *_free flags: zero or free.
    stars = _analyse(ROOT / "datasets" / "engines" / "inline-3.toml")["stars"].ds
    old = stars.drop_vars(["force_class", "moment_class", "roll_class", "force_negligible_level",
                           "moment_negligible_level"])
    stars_table(with_free_vectors(old, _analyse(ROOT / "datasets" / "engines" / "inline-3.toml")["orders"].ds))
