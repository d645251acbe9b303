"""The ``.harmbal`` accessor and the notebook reprs (issue 33, item 3).

Oracles: the Datasets themselves (the tables must hold their numbers: amplitude |C_k|, phase arg C_k,
the stored class codes), the co/counter split written out from the per-axis phasors
(docs/conventions.md: P_co = (Z + iT)/2, P_counter = conj(Z − iT)/2, t = +y for a clockwise engine),
ω² scaling between speeds, and the plotting functions called directly.
"""

import contextlib
import io
import re
import subprocess
import sys
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_close_to_scale

import harmbal as hb
from harmbal.orders.spectrum import CLASSES, ZERO, ZERO_RTOL
from harmbal.reporting.plots import order_spectrum_figure, stars_figure
from harmbal.scene import scene_from_text

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
TRACTOR = ENGINES / "tractor-3cyl.toml"
FIXTURE = Path(__file__).parent / "fixtures" / "two-stroke-single-shaft.toml"
SPEEDS_RPM = (1000.0, 2460.0, 3000.0)


def tractor(speeds=None, rotation="clockwise"):
    """The bundled tractor engine, at other speeds [rpm] or turning the other way."""
    data = tomllib.loads(TRACTOR.read_text(encoding="utf-8"))
    data["engine"]["rotation"] = rotation
    if speeds is not None:
        data["engine"]["speed"] = [f"{s:g} rpm" for s in speeds]
    return hb.load_scene(data)


@pytest.fixture(scope="module")
def tree():
    return hb.analyse(hb.load_scene(TRACTOR))


@pytest.fixture(scope="module")
def sweep():
    return hb.analyse(tractor(SPEEDS_RPM))


@pytest.fixture(scope="module")
def inline_4_design():
    return hb.design(hb.load_scene(ENGINES / "inline-4.toml"))


def _rows(frame):
    """The frame's columns as arrays: amplitude, phase, class code."""
    codes = frame["class"].cat.codes.to_numpy()
    return frame["amplitude"].to_numpy(), frame["phase"].to_numpy(), codes


# Tables: the Dataset's numbers.


@pytest.mark.parametrize("quantity", ["force", "moment"])
def test_amplitudes_are_the_phasors_magnitudes_and_arguments(tree, quantity):
    orders = tree["orders"].ds
    frame = tree.harmbal.amplitudes(quantity)
    phasors = orders[quantity].transpose("order", "axis").values.ravel()
    amplitude, phase, codes = _rows(frame)
    scale = float(orders[f"{quantity}_scale"])
    assert list(frame.index.names) == ["order", "axis"]
    assert frame.index.get_level_values("axis")[:3].tolist() == ["x", "y", "z"]
    assert_close_to_scale(amplitude, np.abs(phasors), scale)
    shown = codes != ZERO
    assert np.isnan(phase[~shown]).all()  # a round-off phasor has no phase
    assert np.all((phase[shown] > -180) & (phase[shown] <= 180))
    turn = np.angle(np.exp(1j * (np.radians(phase[shown]) - np.angle(phasors[shown]))))
    assert np.all(np.abs(turn) <= 1e-12 * np.pi)
    assert frame.attrs["units"] == {"amplitude": {"force": "N", "moment": "N m"}[quantity], "phase": "deg"}


def test_the_moment_table_of_the_tractor_at_2460_rpm(tree):
    # The reference engine's free first-order couple about y (docs/conventions.md: 2762.8 N m of the reciprocating
    # masses plus the rod's big-end share, standing and rotating) and the roll, which the mass torque makes
    # third order: what the amplitudes table must show.
    frame = tree.harmbal.amplitudes("moment")
    moment = tree["orders"].ds.moment
    assert frame.loc[(1, "y"), "amplitude"] == pytest.approx(abs(complex(moment.sel(order=1, axis="y"))), rel=1e-12)
    assert round(frame.loc[(1, "y"), "amplitude"]) == 4471
    assert frame.loc[(1, "x"), "class"] == "zero" and frame.loc[(3, "x"), "class"] == "free"


@pytest.mark.parametrize("rotation", ["clockwise", "counterclockwise"])
@pytest.mark.parametrize("quantity", ["force", "moment"])
def test_rotating_table_is_the_co_counter_split_of_the_axes(quantity, rotation):
    tree = hb.analyse(tractor(rotation=rotation))
    orders = tree["orders"].ds
    axes = tree.harmbal.amplitudes(quantity)
    rotating = tree.harmbal.rotating(quantity)
    scale = float(orders[f"{quantity}_scale"])
    assert list(rotating.index.names) == ["order", "rotation"]

    def phasor(frame, key):  # back from the table: amplitude and phase (no phase: zero)
        amplitude, phase = frame.loc[key, "amplitude"], frame.loc[key, "phase"]
        return 0j if np.isnan(phase) else amplitude * np.exp(1j * np.radians(phase))

    # Components of the class zero come back from the table as 0 (no phase): at most ZERO_RTOL × the scale off.
    t = 1 if rotation == "clockwise" else -1  # t points 90° ahead of +z in the direction of rotation
    for k in orders["order"].values[1:]:
        z, y = phasor(axes, (k, "z")), phasor(axes, (k, "y"))
        co, counter = (z + 1j * t * y) / 2, np.conj(z - 1j * t * y) / 2
        for name, value in (("co", co), ("counter", counter)):
            assert_close_to_scale(phasor(rotating, (k, name)), value, scale, rtol=ZERO_RTOL)
    stored = orders[f"{quantity}_rotating"].transpose("order", "rotation").values.ravel()
    assert_close_to_scale(rotating["amplitude"].to_numpy(), np.abs(stored), scale)


def test_tables_of_a_stars_dataset_equal_the_tree_s():
    # hb.stars' free vectors are /orders' with the class-zero components set to 0 (at most ZERO_RTOL × the scale).
    scene = hb.load_scene(ENGINES / "v8-cross-plane.toml")
    stars, tree = hb.stars(scene), hb.analyse(scene)
    assert list(stars.harmbal.amplitudes().index.names) == ["rpm", "order", "axis"]
    for i, rpm in enumerate(tree["orders"].ds.rpm.values):
        for method, quantity in (("amplitudes", "moment"), ("rotating", "force")):
            ours = getattr(stars.harmbal, method)(quantity, rpm=rpm)
            theirs = getattr(tree.harmbal, method)(quantity, rpm=rpm)
            scale = float(tree["orders"].ds.isel(speed=i)[f"{quantity}_scale"])
            assert ours.index.equals(theirs.index)
            assert_close_to_scale(ours["amplitude"].to_numpy(), theirs["amplitude"].to_numpy(), scale, rtol=1e-10)
            assert (ours["class"] == theirs["class"]).all()


def test_several_speeds_give_an_rpm_level_and_scale_with_the_square_of_the_speed(sweep):
    orders = sweep["orders"].ds
    frame = sweep.harmbal.amplitudes("force")
    assert list(frame.index.names) == ["rpm", "order", "axis"]
    assert frame.index.get_level_values("rpm").unique().tolist() == list(SPEEDS_RPM)
    for i, rpm in enumerate(SPEEDS_RPM):
        at = orders.isel(speed=i)
        assert_close_to_scale(frame.loc[rpm]["amplitude"].to_numpy(),
                              np.abs(at.force.transpose("order", "axis").values.ravel()), float(at.force_scale))
    low, high = (frame.loc[r]["amplitude"].to_numpy() for r in (1000.0, 3000.0))
    assert_close_to_scale(high, 9 * low, float(orders.force_scale.isel(speed=-1)))  # inertia only: ω²
    one = sweep.harmbal.amplitudes("force", rpm=3000)
    assert list(one.index.names) == ["order", "axis"]
    assert one["amplitude"].tolist() == frame.loc[3000.0]["amplitude"].tolist()


def test_tables_of_other_datasets_say_what_they_need(tree, inline_4_design):
    with pytest.raises(ValueError, match="free vectors"):
        tree["stars"].ds.harmbal.amplitudes()  # an analysis tree keeps them in /orders
    with pytest.raises(ValueError, match="orders or stars Dataset; this one is 'design'"):
        inline_4_design.dataset.harmbal.rotating()
    with pytest.raises(ValueError, match="'force' or 'moment'"):
        tree.harmbal.amplitudes("torque")
    with pytest.raises(KeyError, match="/loads"):
        tree.harmbal.plot_polar()


# Classes.


def test_classes_are_the_dataset_s_codes(tree):
    orders = tree["orders"].ds
    frame = tree.harmbal.classes()
    assert list(frame.columns) == ["force_co", "force_counter", "moment_co", "moment_counter", "roll"]
    assert frame["roll"].cat.categories.tolist() == list(CLASSES) and frame["roll"].cat.ordered
    for quantity in ("force", "moment"):
        for j, rotation in enumerate(("co", "counter")):
            codes = frame[f"{quantity}_{rotation}"].cat.codes.to_numpy()
            assert codes.tolist() == orders[f"{quantity}_class"].values[:, j].tolist()
    assert frame["roll"].cat.codes.tolist() == orders["roll_class"].values.tolist()
    assert frame.loc[1, "moment_co"] == "free" and frame.loc[3, "force_co"] == "negligible"
    assert frame.attrs["levels"]["N"] == pytest.approx(float(orders.force_negligible_level), rel=1e-15)


def test_classes_of_the_roll_follow_the_speed_with_gas():
    # With gas the roll's class is judged at each speed (roll_class over speed, order); the bundled scene's
    # classes happen to agree at its two speeds, so the second speed's are made to differ here.
    orders = hb.analyse(hb.load_scene(ENGINES / "inline-4-gas.toml"))["orders"].to_dataset()
    assert orders["roll_class"].dims == ("speed", "order")
    codes = orders["roll_class"].values.copy()
    codes[1] = np.roll(codes[1], 1)
    orders["roll_class"] = orders["roll_class"].copy(data=codes)
    frame = orders.harmbal.classes()
    for i, rpm in enumerate(orders.rpm.values):
        assert frame.loc[float(rpm)]["roll"].cat.codes.tolist() == codes[i].tolist()
        assert orders.harmbal.classes(rpm=rpm)["roll"].cat.codes.tolist() == codes[i].tolist()


# sel_rpm.


def test_sel_rpm_selects_exactly_and_says_which_speeds_there_are(sweep):
    orders = sweep["orders"].ds
    at = orders.harmbal.sel_rpm(2460)
    assert "speed" not in at.dims and float(at.rpm) == 2460.0
    assert_close_to_scale(at.moment.values, orders.moment.isel(speed=1).values, float(at.moment_scale))
    for wrong in (2461, 2460.001, 0):
        with pytest.raises(KeyError, match=r"2460.*rpm") as raised:
            orders.harmbal.sel_rpm(wrong)
        assert all(f"{s:g}" in str(raised.value) for s in SPEEDS_RPM)
    assert sweep.harmbal.sel_rpm(3000)["time"].ds.sizes.get("speed") is None
    assert float(sweep.harmbal.sel_rpm(3000)["stars"].ds.rpm) == 3000.0


def test_sel_rpm_works_with_rpm_as_an_indexed_coordinate(sweep):
    indexed = sweep["orders"].to_dataset().set_xindex("rpm")
    assert float(indexed.harmbal.sel_rpm(1000).speed) == pytest.approx(1000 * np.pi / 30, rel=1e-15)
    with pytest.raises(KeyError, match="1000, 2460, 3000 rpm"):
        indexed.harmbal.sel_rpm(1500)


def test_sel_rpm_of_one_speed(tree):
    orders = tree["orders"].ds
    assert orders.harmbal.sel_rpm(2460) is orders
    with pytest.raises(KeyError, match="its speeds are 2460 rpm"):
        orders.harmbal.sel_rpm(2500)


# Figures: the plotting functions of harmbal.reporting, at the speed asked for.


def _title(fig) -> str:
    return fig.get_suptitle() or fig.axes[0].get_title()


def test_figures_are_the_reporting_figures(sweep):
    from matplotlib.figure import Figure

    orders = sweep["orders"].ds
    spectrum = sweep.harmbal.plot_spectrum(rpm=3000)
    assert isinstance(spectrum, Figure)
    assert _title(spectrum) == _title(order_spectrum_figure(orders, speed=2)) and "3000 rpm" in _title(spectrum)
    stars = sweep.harmbal.plot_stars(rpm=1000)
    assert "1000 rpm" in _title(stars) and len(stars.axes) == len(
        stars_figure(hb.stars(tractor(SPEEDS_RPM))).axes)
    assert isinstance(sweep.harmbal.plot_campbell("moment"), Figure)
    assert isinstance(sweep.harmbal.plot_traces(rpm=2460), Figure)
    assert isinstance(sweep.harmbal.plot_locus(), Figure)
    assert isinstance(hb.stars(tractor()).harmbal.plot_stars([1, 2]), Figure)
    with pytest.raises(KeyError, match="speeds are"):
        sweep.harmbal.plot_spectrum(rpm=1234)


def test_polar_figures_of_the_loads():
    from matplotlib.figure import Figure

    tree = hb.analyse(hb.load_scene(ENGINES / "tractor-3cyl-loads-gas.toml"))
    pin, bearings = tree.harmbal.plot_polar(), tree.harmbal.plot_polar("main_bearing")
    assert isinstance(pin, Figure) and isinstance(bearings, Figure)
    assert len(bearings.get_axes()) >= tree["loads"].ds.sizes["bearing"]
    with pytest.raises(ValueError, match="crank_pin"):
        tree.harmbal.plot_polar("big_end")


# Reprs and summaries: what was designed and what remains, escaped in HTML.


def test_design_repr_names_the_elements_and_what_remains(inline_4_design):
    ds = inline_4_design.dataset
    text, page = repr(inline_4_design), inline_4_design._repr_html_()
    assert not text.startswith("Design(scene=")  # not the dataclass dump
    for label, unbalance, angle in zip(ds.element.values, ds.unbalance.values, ds.unbalance_angle.values):
        for shown in (str(label), f"{unbalance * 1e3:.6g}", f"{np.degrees(angle) % 360:.2f}"):
            assert shown in text and shown in page
    before = complex(ds.before.sel(order=2, component="force_co"))
    assert f"order 2 co-rotating force {abs(before):.5g} N at" in " ".join(text.split())
    assert "cancelled" in text and "Nothing else made worse" in text
    assert str(inline_4_design) == text


def test_design_repr_lists_what_it_makes_worse():
    design = hb.design(scene_from_text(FIXTURE.read_text(encoding="utf-8"), str(FIXTURE)))
    assert design.worsened
    for sentence in design.worsened:
        assert sentence in repr(design) and sentence in design._repr_html_()
    summary = design.dataset.harmbal.summary()
    assert design.worsened[0] in summary.text and design.worsened[0] in summary._repr_html_()


def test_html_escapes_user_text():
    scene = hb.load_scene(ENGINES / "inline-4.toml")
    pair = hb.Candidate("lanchester_pair", "<i>pair</i> & co", 2, (0.0,), heights=(-0.110, -0.110),
                        lateral=(0.045, -0.045))
    design = hb.design(scene, hb.DesignRequest(orders=(2,), candidates=(pair,)), name="<b>bold</b>")
    check = hb.verify(design.scene)
    pages = [design._repr_html_(), check.harmbal.summary()._repr_html_(), design.dataset.harmbal.summary().html]
    for page in pages[:2]:
        assert "&lt;b&gt;bold&lt;/b&gt;" in page
    for page in pages:
        assert "<b>" not in page and "<i>" not in page
    assert "&lt;i&gt;pair&lt;/i&gt; &amp; co" in pages[0]
    assert "<b>bold</b>" in repr(design)  # text stays text


def test_lever_design_repr():
    scene = hb.load_scene(ENGINES / "lever-single.toml")
    from harmbal.balance.lever import design_lever

    result = design_lever(scene, name="<b>lever</b>")
    text, page = repr(result), result._repr_html_()
    assert not text.startswith("LeverDesign(request=")
    for mass, x, y in (result.start, result.weight):  # kg, and the CG in mm
        assert re.search(rf"{mass:.6g}\s+{x * 1e3:.6g}\s+{y * 1e3:.6g}", text)
    assert f"{result.criterion:.8g}" in text and f"{result.criterion:.8g}" in page
    assert repr(result.lever) in text and "verified" in text and "criterion [N]" in text
    assert "&lt;b&gt;lever&lt;/b&gt;" in page and "<b>lever</b>" not in page


def test_verify_summary(inline_4_design):
    check = hb.verify(inline_4_design.scene)
    summary = check.harmbal.summary()
    assert repr(summary) == summary.text and "PASSED" in summary.text
    page = summary._repr_html_()
    for rpm in np.atleast_1d(check.rpm.values):
        assert f"At {rpm:.6g} rpm" in page
    removed = float(check.peak_force_removed.isel(speed=0).sel(axis="z"))
    assert f"{removed:.1f} %" in page and page.count("<td") > 20
    tree = hb.analyse(hb.load_scene(ENGINES / "inline-3-balanced.toml"))
    both = tree.harmbal.summary()
    assert "Free moment" in both.text and "balancers verified" in both.text and "Verification" in both.html


def test_summary_of_other_datasets_say_what_they_need(tree):
    with pytest.raises(ValueError, match="summary"):
        tree["time"].ds.harmbal.summary()


# Registration: the accessor comes with harmbal's functions, not with `import harmbal`.


def test_the_accessor_registers_without_import_harmbal_importing_xarray():
    code = (
        "import sys, harmbal\n"
        "assert 'xarray' not in sys.modules\n"
        "harmbal.load_scene\n"
        "assert 'xarray' not in sys.modules and 'harmbal.accessor' not in sys.modules\n"
        "import xarray as xr\n"
        "assert not hasattr(xr.Dataset(), 'harmbal')\n"
        "harmbal.analyse\n"
        "assert hasattr(xr.Dataset(), 'harmbal') and hasattr(xr.DataTree(), 'harmbal')\n"
        "assert 'matplotlib' not in sys.modules\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


# pint-xarray: every unit string harmbal writes is one pint reads, and means what it says.


def _datasets_of(path: Path):
    scene = hb.load_scene(path)
    for node in hb.analyse(scene).subtree:
        if node.has_data:
            yield node.path, node.to_dataset()
    if scene.design is not None:
        result = hb.design(scene)
        yield "design", result.breakdown if isinstance(result, hb.LeverDesign) else result.dataset
    if scene.verify is not None:
        yield "verify", hb.verify(scene)


@pytest.mark.parametrize("path", sorted(ENGINES.glob("*.toml")), ids=lambda p: p.stem)
def test_every_dataset_quantifies_with_pint_xarray(path):
    pytest.importorskip("pint_xarray")
    import pint

    ureg = pint.get_application_registry()
    failed = []
    for where, ds in _datasets_of(path):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pint's UnitStrippedWarning for index coordinates
            try:
                quantified = ds.pint.quantify()
            except Exception as error:  # noqa: BLE001  (pint raises a group of parse errors)
                failed.append(f"{where}: {error!r}: {_unparsed(ds)}")
                continue
        if "rpm" in ds.coords and "speed" in ds.coords:  # the two speed coordinates agree through pint
            rad_s = quantified["rpm"].pint.to("rad/s").pint.magnitude
            assert_close_to_scale(np.asarray(rad_s), ds["speed"].values, float(np.max(ds["speed"].values)))
        for name, units in (("force", ureg.newton), ("moment", ureg.newton * ureg.meter)):
            if name in ds and ds[name].attrs.get("units"):
                assert quantified[name].pint.units.dimensionality == units.dimensionality, (where, name)
    assert not failed, "\n".join(failed)


def _unparsed(ds) -> list[str]:
    """The variables whose units pint cannot read, with the unit strings."""
    import pint

    ureg = pint.get_application_registry()
    bad = []
    for name, variable in ds.variables.items():
        units = variable.attrs.get("units")
        try:
            if units is not None:
                ureg.Unit(units)
        except Exception:  # noqa: BLE001
            bad.append(f"{name} = {units!r}")
    return bad


# The notebook example of docs/api.md runs and prints what the page shows.

MARKER = "<!-- notebook example: tests/test_accessor.py runs this block and checks what it prints -->"
EXAMPLE = re.compile(re.escape(MARKER) + r"\s*```python\n(?P<code>.*?)```.*?```text\n(?P<shown>.*?)```", re.S)


def _example():
    match = EXAMPLE.search((ROOT / "docs" / "api.md").read_text(encoding="utf-8"))
    assert match, "docs/api.md has no notebook example under its marker"
    return match["code"], match["shown"]


def _normal(text: str) -> list[str]:
    return [" ".join(line.split()) for line in text.splitlines() if line.strip()]


@pytest.fixture(scope="module")
def example_output():
    code, _ = _example()
    printed = io.StringIO()
    with contextlib.chdir(ROOT), contextlib.redirect_stdout(printed):
        exec(compile(code, "docs/api.md (notebook example)", "exec"), {"__name__": "__notebook__"})
    return printed.getvalue()


def test_the_notebook_example_prints_what_the_doc_shows(example_output):
    _, shown = _example()
    assert _normal(example_output) == _normal(shown)


def _row(printed: str, label: str) -> list[str]:
    """The cells of the first printed row whose first cell is ``label``."""
    for line in printed.splitlines():
        cells = line.split()
        if cells and cells[0] == label:
            return cells[1:]
    raise AssertionError(f"no row {label!r} in\n{printed}")


def _agrees(shown: str, value: float) -> bool:
    """A printed number agrees with ``value`` to its last printed digit."""
    decimals = len(shown.split(".")[1]) if "." in shown else 0
    return abs(float(shown) - value) <= 0.5 * 10.0**-decimals * (1 + 1e-9)


def test_the_notebook_example_s_numbers_are_the_analysis_s(example_output, tree):
    moment = tree["orders"].ds.moment.sel(order=1)
    rotating = tree["orders"].ds.moment_rotating.sel(order=1)
    for label, phasor in (("y", complex(moment.sel(axis="y"))), ("z", complex(moment.sel(axis="z"))),
                          ("co", complex(rotating.sel(rotation="co"))),
                          ("counter", complex(rotating.sel(rotation="counter")))):
        amplitude, phase, verdict = _row(example_output, label)
        assert _agrees(amplitude, abs(phasor)) and _agrees(phase, np.degrees(np.angle(phasor))), label
        assert verdict == "free"
    assert _row(example_output, "y")[0] == "4471.0"  # the reference engine's first-order couple about y
    classes = dict(zip(["force_co", "force_counter", "moment_co", "moment_counter", "roll"], _row(example_output, "3")))
    codes = tree["orders"].ds.sel(order=3)
    assert classes["force_co"] == CLASSES[int(codes.force_class.sel(rotation="co"))]
    assert classes["roll"] == CLASSES[int(codes.roll_class)]
    design = hb.design(hb.load_scene(ENGINES / "inline-4.toml")).dataset
    for label, unbalance in zip(design.element.values, design.unbalance.values):
        assert re.search(re.escape(str(label)) + rf"\s+{unbalance * 1e3:.6g} kg mm", example_output)
