"""Balancer design and verification, judged by closed forms written here, by
slider-crank harmonics computed here, by a brute-force sweep, and by the exact
time-domain model (hb.simulate / hb.order_spectrum / hb.verify)."""

import copy
import dataclasses
import importlib.util
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import tomli_w

import harmbal as hb
from harmbal.balance.design import BOUND_SIDES
from harmbal.cli import main
from harmbal.scene import SceneError, scene_from_text
from harmbal.scene.requests import PEAK_SAMPLES, Candidate, DesignRequest

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"

_spec = importlib.util.spec_from_file_location("make_balanced", ROOT / "datasets" / "make_balanced.py")
make_balanced = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_balanced)

#: Engines written by datasets/make_balanced.py.
GENERATED = {name for name, _ in make_balanced.VARIANTS.values()}

#: Reference engine B (test-single.toml): masses and geometry [kg, m].
B_PISTON, B_ROD, B_ROD_CG, B_R, B_L, B_E = 2.229, 2.726, 0.072255, 0.060, 0.215, 0.0005
B_CRANK_UNBALANCE = 12.782 * 0.008047
B_PIN_X, B_CRANK_X = 0.086, 0.09201

#: A centric single cylinder whose crank also carries a static unbalance.
CENTRIC_SINGLE = {
    "engine": {"name": "centric single", "speed": "3000 rpm", "rotation": "clockwise"},
    "geometry": {"crank_radius": "40 mm", "rod_length": "140 mm"},
    "piston": {"mass": "0.45 kg"},
    "rod": {"mass": "0.5 kg", "cg_from_big_end": "40 mm", "inertia": "0.0012 kg m^2"},
    "crankshaft_unbalance": [{"unbalance": "3 kg mm", "angle": "40 deg", "axial_position": "20 mm"}],
    "cylinder": [{"axial_position": "30 mm"}],
}

#: A valid [design] table for tests that break one key at a time.
DESIGN = {"orders": [1], "counterweights": [{"label": "cw", "planes": ["-50 mm", "50 mm"]}]}


def load(stem):
    return hb.load_scene(ENGINES / f"{stem}.toml")


def spectrum(scene):
    """The exact model's order spectrum (the judge)."""
    return hb.order_spectrum(hb.simulate(scene))


def text_without_design(path):
    """A scene file's text up to its [design] table."""
    text = path.read_text(encoding="utf-8")
    return text[:re.search(r"(?m)^\[design\]", text).start()]


def phasor(values, k):
    """Order-k phasor C_k of samples over one revolution, s = Σ Re(C_k e^{ikψ})."""
    n = len(values)
    return 2 * np.sum(values * np.exp(-1j * k * 2 * np.pi * np.arange(n) / n)) / n


def piston_acceleration(r, l, e, psi):
    """d²c_B/dψ² of the offset slider-crank, c_B = r cos ψ + √(l² − (e − r sin ψ)²)."""
    g, dg, ddg = e - r * np.sin(psi), -r * np.cos(psi), r * np.sin(psi)
    s = np.sqrt(l**2 - g**2)
    return -r * np.cos(psi) - (dg**2 + g * ddg) / s - g**2 * dg**2 / s**3


def unbalance_phasors(shafts):
    """U·e^{iα} of every unbalance of the shafts, in order."""
    return np.array([u.unbalance * np.exp(1j * u.angle) for s in shafts for u in s.unbalances])


def designed_phasors(design):
    """The solver's unknowns U·e^{iα} as the design dataset reports them."""
    return design.dataset["unbalance"].values * np.exp(1j * design.dataset["unbalance_angle"].values)


def counterweights_only(scene, orders=(1,), **kwargs):
    """The scene's [design] counterweights candidate as the only candidate."""
    cw = next(c for c in scene.design.candidates if c.kind == "counterweights")
    return DesignRequest(orders, (dataclasses.replace(cw, **kwargs),))


def peak_objective(moment):
    """max|M_y| + max|M_z| over the samples of a moment array (axis, angle)."""
    return float(np.abs(moment[1]).max() + np.abs(moment[2]).max())


def couple_sweep(engine_moment, theta, sense, w2, half_span, u_max):
    """The thesis's method: the best max|M_y| + max|M_z| over counterweight
    couples ±U·e^{iα} at x = ±half_span (no net force), on a 41 × 72 grid of
    U ∈ [0, u_max] and α, refined once by a 41 × 41 grid around the best point.
    The couple's moments are written here: a counterweight U·e^{iα} at x exerts
    F_z = ω²U cos(θ + α), F_y = −sense·ω²U sin(θ + α), M_y = −x F_z, M_z = x F_y."""

    def grid(us, alphas):
        lever = 2 * half_span * w2 * us[:, None]
        values = np.array([np.abs(engine_moment[1] - lever * np.cos(theta + a)).max(-1)
                           + np.abs(engine_moment[2] - sense * lever * np.sin(theta + a)).max(-1) for a in alphas])
        j, i = np.unravel_index(values.argmin(), values.shape)
        return values[j, i], us[i], alphas[j]

    du, da = u_max / 40, 2 * np.pi / 72
    _, u, a = grid(np.linspace(0, u_max, 41), np.arange(72) * da)
    best, _, _ = grid(np.linspace(max(u - du, 0), min(u + du, u_max), 41), np.linspace(a - da, a + da, 41))
    return best


def run_cli(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


# --------------------------------------------------------------------------
# 1. Reference engine B: a single cylinder with a pin offset


def test_single_counterweights_cancel_the_transverse_force_at_every_order():
    """Oracle: the exact model. Only the rotating masses move sideways (the
    piston stays on its line), so counterweights sized for them (balance
    factor 0) leave no force along y at any order."""
    scene = load("test-single")
    request = counterweights_only(scene)
    assert request.candidates[0].balance_factor == 0
    orders = spectrum(hb.design(scene, request).scene)
    assert np.abs(orders.force.sel(axis="y")).max() <= 1e-12 * orders.force_scale


def test_single_counterweights_closed_form():
    """Oracle: static and couple balance of the rotating masses written here,
    U₁ + U₂ = m_rot·r + U_crank and U₁x₁ + U₂x₂ = m_rot·r·x_pin + U_crank·x_crank,
    with m_rot = m_rod·(l − a)/l, both opposite the pin."""
    scene = load("test-single")
    x1, x2 = scene.design.candidates[0].planes
    m_rot = B_ROD * (B_L - B_ROD_CG) / B_L
    total = m_rot * B_R + B_CRANK_UNBALANCE
    moment = m_rot * B_R * B_PIN_X + B_CRANK_UNBALANCE * B_CRANK_X
    u2 = (moment - total * x1) / (x2 - x1)
    expected = -np.array([total - u2, u2])  # opposite the pin: angle 180°
    design = hb.design(scene, counterweights_only(scene))
    np.testing.assert_allclose(designed_phasors(design), expected, rtol=1e-12, atol=1e-12 * total)
    np.testing.assert_allclose(unbalance_phasors(design.elements), expected, rtol=1e-12, atol=1e-12 * total)


def test_single_balanced_dataset_cancels_the_first_order_and_keeps_the_second():
    """Oracle: the exact model of test-single-balanced.toml against the
    unbalanced engine: no first-order force, the second order untouched (the
    first-order elements cannot act on it)."""
    balanced = spectrum(load("test-single-balanced"))
    plain = spectrum(load("test-single"))
    scale = float(balanced.force_scale)
    assert np.abs(balanced.force.sel(order=1)).max() <= 1e-12 * scale
    difference = balanced.force.sel(order=2) - plain.force.sel(order=2)
    assert np.abs(difference).max() <= 1e-12 * scale
    assert np.abs(plain.force.sel(order=2)).max() > 0.05 * scale


def test_single_thesis_literal_shafts_leave_only_the_pin_offset_terms():
    """Oracle: the offset slider-crank's first harmonic computed here. The
    thesis's shafts (a ±1× pair of 0.5·m_rec·r each, opposite the pin at
    θ = 0, no phasing) cancel m_rec·r·ω²·cos θ; what remains is the first
    harmonic of the piston acceleration beyond −r cos ψ, −m_rec·C₁(c_B'' + r cos ψ),
    along z: nonzero, but under 0.5 % of the reciprocating first order."""
    m_rec = B_PISTON + B_ROD * B_ROD_CG / B_L
    data = tomllib.loads((ENGINES / "test-single-balanced.toml").read_text(encoding="utf-8"))
    (pair,) = data["lanchester_pair"]
    pair.update(unbalance=0.5 * m_rec * B_R, angle="180 deg", phase="0 deg")
    orders = spectrum(hb.load_scene(data))
    w2 = float(orders.speed) ** 2

    psi = 2 * np.pi * np.arange(256) / 256
    beyond = piston_acceleration(B_R, B_L, B_E, psi) + B_R * np.cos(psi)
    expected = -m_rec * phasor(beyond, 1) * w2
    residual = orders.force.sel(order=1).values
    assert abs(residual[1]) <= 1e-12 * float(orders.force_scale)
    assert abs(residual[2] - expected) <= 1e-9 * abs(expected)
    assert 1e-4 < abs(expected) / (m_rec * B_R * w2) < 5e-3


# --------------------------------------------------------------------------
# 2. Balance factor


@pytest.mark.parametrize("planes", [(0.03,), (0.0, 0.06)], ids=["one plane", "two planes"])
@pytest.mark.parametrize("factor", [0, 0.25, 0.5, 1])
def test_balance_factor_moves_the_first_order_force_from_z_to_y(planes, factor):
    """Oracle: the classic rule. Counterweights for the rotating masses plus f
    times the reciprocating ones turn m_rec·r·ω²·cos θ along z into
    (1 − f)·m_rec·r·ω² along z and f·m_rec·r·ω² along y (exact for a centric
    slider-crank, whose first harmonic is exactly r cos ψ); f = ½ leaves a
    purely counter-rotating vector."""
    scene = hb.load_scene(CENTRIC_SINGLE)
    candidate = Candidate("counterweights", "counterweights", 1, planes, balance_factor=factor)
    orders = spectrum(hb.design(scene, DesignRequest((1,), (candidate,))).scene)
    reciprocating = (0.45 + 0.5 * 40 / 140) * 0.04 * float(orders.speed) ** 2
    force = np.abs(orders.force.sel(order=1).values)
    assert force[0] <= 1e-12 * reciprocating
    np.testing.assert_allclose(force[1:] / reciprocating, [factor, 1 - factor], rtol=1e-12,
                               atol=1e-12)  # scale: 1 (the reciprocating force)
    if factor == 0.5:
        co, counter = np.abs(orders.force_rotating.sel(order=1).values)
        assert co <= 1e-12 * reciprocating
        assert counter == pytest.approx(reciprocating / 2, rel=1e-12)


def test_balance_factor_counterweights_include_the_crankshaft_cg_offset():
    """Oracle: as for reference engine B, only rotating masses push sideways,
    so counterweights for them (f = 0) leave no force along y, whether the
    crank's static unbalance is a [[crankshaft_unbalance]] or the CG offset of
    its [crankshaft] mass data."""
    data = {key: value for key, value in CENTRIC_SINGLE.items() if key != "crankshaft_unbalance"}
    data["crankshaft"] = {"mass": "10 kg", "cg_offset": ["0 mm", "2 mm"], "axial_position": "30 mm"}
    candidate = Candidate("counterweights", "counterweights", 1, (0.03,), balance_factor=0)
    orders = spectrum(hb.design(hb.load_scene(data), DesignRequest((1,), (candidate,), cancel=("force",))).scene)
    assert abs(orders.force.sel(order=1, axis="y")) <= 1e-12 * orders.force_scale


# --------------------------------------------------------------------------
# 3. Inline four: Lanchester pair


def inline4_second_order():
    """The unbalanced inline four's order-2 phasor of F_z at unit speed,
    computed here: 4·m_rec times the centric slider-crank's second harmonic
    of −c_B'' (the rotating masses and first orders cancel over the crank)."""
    m_rec = 0.50 + 0.55 * 45 / 145
    psi = 2 * np.pi * np.arange(256) / 256
    return phasor(-4 * m_rec * piston_acceleration(0.043, 0.145, 0.0, psi), 2)


def test_inline4_lanchester_pair_closed_form():
    """Oracle: the standing vector 2n²U of a pair equals |F₂| (n = 2) from the
    slider-crank harmonic computed here, opposite F₂; the exact model of the
    designed scene has no second-order force at either speed."""
    f2 = inline4_second_order()
    (pair,) = tomllib.loads((ENGINES / "inline-4-lanchester.toml").read_text(encoding="utf-8"))["lanchester_pair"]
    scene = load("inline-4-lanchester")
    np.testing.assert_allclose(unbalance_phasors(scene.shafts), [-f2 / 8, -f2 / 8], rtol=1e-12)
    assert pair["phase"] == "0.0 deg"
    orders = spectrum(scene)
    assert (np.abs(orders.force.sel(order=2)).max("axis") <= 1e-12 * orders.force_scale).all()


def inline4_roll_design(heights):
    candidate = Candidate("lanchester_pair", "pair", 2, (0.0,), heights=heights, lateral=(0.0, 0.0))
    return hb.design(load("inline-4"), DesignRequest((2,), (candidate,), cancel=("force", "moment", "roll")))


def inline4_height_difference():
    """z₊ − z₋ that cancels the order-2 roll moment M_x,2 (exact model, unit
    speed): the pair P₊ = P₋ = −F₂/(2n²) pushes sideways with F_y,± = ±i·sense·n²·P
    (phasors), equal and opposite, so its roll −z₊F_y,₊ − z₋F_y,₋ is
    −(z₊ − z₋)·F_y,₊."""
    scene = load("inline-4")
    orders = spectrum(scene)
    roll = orders.moment.sel(order=2, axis="x").values[0] / orders.speed.values[0] ** 2
    lateral = 1j * scene.sense * 4 * (-inline4_second_order() / 8)
    dz = roll / lateral
    assert abs(dz.imag) <= 1e-9 * abs(dz)  # the roll moment is in phase with the pair's lateral force
    return dz.real


def test_inline4_pair_at_the_right_height_difference_cancels_the_roll():
    """Oracle: the height difference derived here; the exact model of the
    design has no order-2 roll moment at either speed, and the opposite
    height difference does not work."""
    dz = inline4_height_difference()
    design = inline4_roll_design((-0.11 + dz / 2, -0.11 - dz / 2))
    assert design.feasible, design.messages
    orders = spectrum(design.scene)
    assert (np.abs(orders.moment.sel(order=2, axis="x")) <= 1e-12 * orders.moment_scale).all()
    assert (np.abs(orders.force.sel(order=2)).max("axis") <= 1e-12 * orders.force_scale).all()
    assert not inline4_roll_design((-0.11 - dz / 2, -0.11 + dz / 2)).feasible


def test_inline4_pair_at_one_height_cannot_cancel_the_roll():
    """Oracle: the geometry. With equal heights and no lateral offset the
    pair's roll moment vanishes, so the order-2 roll target is infeasible and
    the messages say so."""
    design = inline4_roll_design((-0.11, -0.11))
    assert not design.feasible
    assert any("roll" in m for m in design.messages)


def test_inline4_design_names_the_height_difference_that_cancels_the_roll():
    """Oracle: the height difference derived in the test; the design's hint
    for a pair at one height states it (6 significant digits)."""
    dz = inline4_height_difference()
    messages = inline4_roll_design((-0.11, -0.11)).messages
    hint = [m for m in messages if "the pair would also cancel the order 2 roll" in m]
    assert len(hint) == 1
    stated = float(hint[0].split("z₊ − z₋ = ")[1].split(" mm")[0])
    assert stated == pytest.approx(dz * 1e3, rel=1e-5)


# --------------------------------------------------------------------------
# 4. Inline three


def test_inline3_counterweights_and_moment_shaft_closed_form():
    """Oracle: first-order moments of the centric inline three written here.
    Per cylinder (throw φ, position x) the first-order force in the w-plane is
    (m_rot + m_rec/2)·r·e^{iφ} co-rotating and m_rec/2·r·e^{−iφ} counter-rotating;
    a couple ±P in the planes ∓120 mm cancels the moment Σx·(...) if
    P = Σx·(...)/0.24 m: |co| = √3(m_rec/2 + m_rot)·r·a, |counter| = √3/2·m_rec·r·a."""
    m_rec, m_rot, r, a = 0.50 + 0.55 * 45 / 145, 0.55 * 100 / 145, 0.043, 0.096
    x = np.array([a, 0.0, -a])
    throw = np.radians([0, 240, 120])
    co = np.sum(x * (m_rot + m_rec / 2) * r * np.exp(1j * throw))
    counter = np.sum(x * m_rec / 2 * r * np.exp(-1j * throw))
    assert abs(co) == pytest.approx(math.sqrt(3) * (m_rec / 2 + m_rot) * r * a, rel=1e-14)
    assert abs(counter) == pytest.approx(math.sqrt(3) / 2 * m_rec * r * a, rel=1e-14)

    design = hb.design(load("inline-3"))
    assert list(design.dataset["element"].values) == [
        "counterweights 1", "counterweights 2",
        "balance shaft (−1×) couple, x = -120 / 120 mm"]
    expected = [co / 0.24, -co / 0.24, counter / 0.24]
    np.testing.assert_allclose(designed_phasors(design), expected, rtol=1e-9)
    np.testing.assert_allclose(unbalance_phasors(design.elements), expected + [-counter / 0.24], rtol=1e-9)


def test_inline3_balanced_dataset_has_no_first_order_moment():
    """Oracle: the exact model of inline-3-balanced.toml."""
    orders = spectrum(load("inline-3-balanced"))
    assert np.abs(orders.moment.sel(order=1, axis=["y", "z"])).max() <= 1e-12 * orders.moment_scale
    assert np.abs(orders.force.sel(order=1)).max() <= 1e-12 * orders.force_scale


# --------------------------------------------------------------------------
# 5. Every shipped layout


SHIPPED = sorted(p for p in ENGINES.glob("*.toml") if p.stem not in GENERATED)


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_layout_balances_orders_one_and_two(path):
    """Oracle: hb.verify (the exact model with and without the elements).
    Counterweights, a −1× shaft and ±2× shafts, two planes each beyond the
    outer cylinders, can cancel the first- and second-order force and moment
    of any layout."""
    scene = hb.load_scene(path)
    xs = [c.x for c in scene.cylinders]
    planes = (min(xs) - 0.05, max(xs) + 0.05)
    request = DesignRequest((1, 2), (
        Candidate("counterweights", "cw", 1, planes),
        Candidate("balance_shaft", "minus one", -1, planes, y=0.06, z=-0.09),
        Candidate("balance_shaft", "plus two", 2, planes, y=-0.05, z=-0.1),
        Candidate("balance_shaft", "minus two", -2, planes, y=0.05, z=-0.1),
    ))
    design = hb.design(scene, request)
    assert design.feasible, design.messages
    check = hb.verify(design.scene)
    assert check.attrs["passed"] == "yes"
    assert check["targeted"].sel(component=["force_co", "force_counter", "moment_co", "moment_counter"]).all()


# --------------------------------------------------------------------------
# 6. Infeasible requests


def test_counterweights_alone_cannot_cancel_the_counter_rotating_first_order():
    """Oracle: what a crank counterweight can do (co-rotating order 1 only)."""
    scene = load("test-single")
    design = hb.design(scene, counterweights_only(scene, balance_factor=None))
    assert not design.feasible
    message = next(m for m in design.messages if "order 1 counter-rotating force" in m)
    assert "cannot be cancelled by crank counterweights" in message
    assert "add a −1× shaft" in message
    assert not any("co-rotating" in m for m in design.messages)


def test_counterweights_alone_at_order_two_ask_for_both_second_order_shafts():
    """Oracle: a counterweight turns at 1×; order 2 needs shafts at +2× and −2×."""
    scene = load("test-single")
    design = hb.design(scene, counterweights_only(scene, orders=(2,), balance_factor=None))
    assert not design.feasible
    text = "\n".join(design.messages)
    assert "+2× shaft" in text and "−2× shaft" in text


def test_what_the_balance_factor_leaves_is_named_as_such():
    """Oracle: the rule. Counterweights with balance factor 0 alone leave the
    co-rotating half of the first-order reciprocating force; the message says
    that the balance factor leaves it, not that counterweights cannot
    cancel it."""
    scene = load("test-single")
    design = hb.design(scene, counterweights_only(scene))
    message = next(m for m in design.messages if "order 1 co-rotating force" in m)
    assert "is what the balance factor of 'counterweight' leaves" in message
    assert "add a +1× shaft" in message and "cannot be cancelled" not in message


def test_cli_design_writes_nothing_for_an_infeasible_request_unless_partial(tmp_path, capsys):
    """Oracle: the documented exit codes; the --partial output's predicted
    residuals are confirmed by the exact model (hb.verify)."""
    scene = tmp_path / "single.toml"
    scene.write_text(text_without_design(ENGINES / "test-single.toml")
                     + '[design]\norders = [1]\n\n[[design.counterweights]]\nplanes = ["55 mm", "117 mm"]\n',
                     encoding="utf-8")
    out = tmp_path / "out.toml"
    code, _, err = run_cli(capsys, "design", scene, "-o", out)
    assert code == 1 and "nothing written" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["single.toml"]
    code, text, _ = run_cli(capsys, "design", scene, "-o", out, "--partial")
    assert code == 0 and f"wrote {out}" in text
    assert hb.verify(hb.load_scene(out)).attrs["passed"] == "yes"


# --------------------------------------------------------------------------
# 7. The output scene


def test_output_text_is_the_input_with_elements_and_verify():
    """Oracle: the input file's own text: its comments and tables up to
    [design] are kept verbatim; no [design] table is left."""
    path = ENGINES / "test-single.toml"
    design = hb.design(hb.load_scene(path))
    assert design.text.startswith("#")
    assert text_without_design(path).rstrip() in design.text
    assert re.search(r"(?m)^\[verify\]$", design.text)
    assert not re.search(r"(?m)^\s*\[\[?design", design.text)
    assert "design" not in tomllib.loads(design.text)


def test_output_elements_are_the_solved_unbalances():
    """Oracle: the solver's unknowns (design.dataset); the scene loaded from
    the text has exactly these unbalances (1e-12), one per shaft here."""
    design = hb.design(load("test-single"))
    loaded = scene_from_text(design.text, "out.toml")
    new = loaded.shafts[-len(design.elements):]
    assert new == design.elements
    assert [s.label for s in new] == ["counterweight 1", "counterweight 2", "first-order balance shafts (+1×)",
                                      "first-order balance shafts (−1×)"]
    expected = designed_phasors(design)
    np.testing.assert_allclose(unbalance_phasors(new), expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("stem", ["inline-3", "inline-4", "v6-90-split-pin", "test-single"])
def test_designing_the_output_again_adds_nothing(stem):
    """Oracle: the output itself. With the input's [design] table added back
    to the output, the existing elements are part of the engine: the second
    design finds nothing left to cancel (every unbalance at round-off) and
    writes the same scene data."""
    path = ENGINES / f"{stem}.toml"
    design = hb.design(hb.load_scene(path))
    again = design.text + "\n" + path.read_text(encoding="utf-8")[len(text_without_design(path)):]
    second = hb.design(scene_from_text(again, str(path)))
    assert second.feasible and second.elements == ()
    assert np.all(second.dataset["unbalance"].values <= 1e-12 * design.dataset["unbalance"].values.max())
    assert tomllib.loads(second.text) == tomllib.loads(design.text)


@pytest.mark.parametrize("partial", [False, True], ids=["feasible", "partial"])
def test_verify_of_the_output_confirms_the_predicted_residuals(partial):
    """Oracle: hb.verify, with the predictions read back from the output's
    [verify] table: they equal the design's (1e-12) and the exact model
    agrees with them; for the partial design they are not zero."""
    scene = load("test-single")
    design = hb.design(scene, counterweights_only(scene, balance_factor=None) if partial else None)
    check = hb.verify(design.scene)
    assert check.attrs["passed"] == "yes"
    targeted = design.dataset["targeted"]
    predicted = design.dataset["predicted"].where(targeted, 0).values
    read_back = check["predicted"].sel(order=design.dataset.order).where(targeted, 0).values
    scale = float(check.force_scale)
    np.testing.assert_allclose(read_back, predicted, rtol=1e-12, atol=1e-12 * scale)
    assert (np.abs(predicted).max() > 0.1 * scale) == partial


# --------------------------------------------------------------------------
# 8. The generated datasets


@pytest.mark.parametrize("stem", sorted(make_balanced.VARIANTS))
def test_generated_dataset_is_up_to_date(stem, monkeypatch):
    """Oracle: the committed file; datasets/make_balanced.py rewrites it."""
    monkeypatch.chdir(ROOT)
    name, _ = make_balanced.VARIANTS[stem]
    written = make_balanced.designed_text(stem)
    committed = (ENGINES / f"{name}.toml").read_text(encoding="utf-8")
    # The text must match except in the last digits of the solved numbers: the LP and least-squares solvers
    # of another scipy/numpy build round differently (seen: 1e-15 relative on the lever weight's CG).
    assert _NUMBER.sub("#", written) == _NUMBER.sub("#", committed)
    np.testing.assert_allclose([float(x) for x in _NUMBER.findall(written)],
                               [float(x) for x in _NUMBER.findall(committed)], rtol=1e-9,
                               atol=1e-12)  # scale: numbers ≥ 2e-3 (SI) but for written zeros


_NUMBER = re.compile(r"-?\d+\.?\d*(?:[eE][-+]?\d+)?")


# --------------------------------------------------------------------------
# 9. Peak objective


def tractor_peak_problem():
    """Reference engine A's [design] (a counterweight couple in the planes
    ±250 mm, smallest max|M_y| + max|M_z|), the exact model's moment without
    the couple on PEAK_SAMPLES angles, and the scene's speed squared."""
    scene = load("tractor-3cyl-balanced")
    (candidate,) = scene.design.candidates
    assert candidate.planes == (-0.25, 0.25)
    ds = hb.simulate(scene, samples_per_rev=PEAK_SAMPLES)
    return scene, ds.moment.values, ds.angle.values, float(ds.speed) ** 2


def peak_of(scene):
    return peak_objective(hb.simulate(scene, samples_per_rev=PEAK_SAMPLES).moment.values)


def test_peak_objective_matches_the_thesis_sweep():
    """Oracle: a brute-force sweep over the couple's size and angle (the
    thesis's method) with the couple's moments written here: the linear
    programme is at least as good as every swept couple and the refined sweep
    comes within 0.1 % of it."""
    scene, moment, theta, w2 = tractor_peak_problem()
    design = hb.design(scene)
    assert design.feasible
    optimum = peak_of(design.scene)
    sweep = couple_sweep(moment, theta, scene.sense, w2, 0.25, u_max=0.02)
    assert optimum <= sweep * (1 + 1e-9)
    assert sweep <= optimum * (1 + 1e-3)
    assert optimum < 0.95 * peak_objective(moment)


def test_peak_objective_respects_max_unbalance():
    """Oracle: the bound itself and the sweep within it: a max_unbalance half
    the unbounded optimum's is respected, costs peak moment, and the bounded
    programme still beats every couple within the disc its polygon contains."""
    scene, moment, theta, w2 = tractor_peak_problem()
    free = hb.design(scene)
    bound = 0.5 * free.dataset["unbalance"].values.max()
    (candidate,) = scene.design.candidates
    request = dataclasses.replace(scene.design, candidates=(dataclasses.replace(candidate, max_unbalance=bound),))
    bounded = hb.design(scene, request)
    assert bounded.feasible, bounded.messages
    assert np.all(bounded.dataset["unbalance"].values <= bound * (1 + 1e-12))
    objective = peak_of(bounded.scene)
    assert objective > peak_of(free.scene) * (1 + 1e-4)
    inscribed = bound * math.cos(math.pi / BOUND_SIDES)
    assert objective <= couple_sweep(moment, theta, scene.sense, w2, 0.25, u_max=inscribed) * (1 + 1e-9)


# --------------------------------------------------------------------------
# 10. Command line and validation


def test_cli_design_without_design_table_exits_2_naming_the_file(tmp_path, capsys):
    scene = ENGINES / "inline-5.toml"
    code, _, err = run_cli(capsys, "design", scene, "-o", tmp_path / "out.toml")
    assert code == 2 and str(scene) in err and "[design]" in err
    assert not (tmp_path / "out.toml").exists()


def test_cli_design_refuses_to_overwrite_its_input(tmp_path, capsys):
    scene = tmp_path / "single.toml"
    text = (ENGINES / "test-single.toml").read_text(encoding="utf-8")
    scene.write_text(text, encoding="utf-8")
    code, _, err = run_cli(capsys, "design", scene, "-o", scene)
    assert code == 2 and "overwrite" in err
    assert scene.read_text(encoding="utf-8") == text


def test_cli_verify_without_anything_to_verify_exits_2(capsys):
    code, _, err = run_cli(capsys, "verify", ENGINES / "inline-5.toml")
    assert code == 2 and "--orders" in err


def test_cli_verify_fails_where_the_first_order_is_not_cancelled(capsys):
    """Oracle: the tractor's balancers are pure couples, so its first-order
    moment is not cancelled."""
    code, out, _ = run_cli(capsys, "verify", ENGINES / "tractor-3cyl-balanced.toml", "--orders", "1")
    assert code == 1 and "FAILED" in out


def test_cli_verify_passes_a_designed_scene(capsys):
    code, out, _ = run_cli(capsys, "verify", ENGINES / "inline-3-balanced.toml")
    assert code == 0 and "PASSED" in out


@pytest.mark.parametrize("edit, key", [
    (lambda d: d.update(objectiv="peak"), "design.objectiv"),
    (lambda d: d["counterweights"][0].update(balance_factor=1.5), "design.counterweights[1].balance_factor"),
    (lambda d: d.update(moment_shaft=[{"ratio": -1, "planes": ["-1 mm", "0 mm", "1 mm"]}]),
     "design.moment_shaft[1].planes"),
    (lambda d: d.update(orders=[1, 13]), "design.orders"),
    (lambda d: d.update(balance_shaft=[{"label": "cw", "ratio": -1, "planes": ["0 mm"]}]), "design = 'cw'"),
    (lambda d: d["counterweights"][0].update(planes=["50 mm", "50 mm"]), "design.counterweights[1].planes"),
    (lambda d: d.update(balance_shaft=[{"ratio": -13, "planes": ["0 mm"]}]), "design.balance_shaft[1].ratio"),
    (lambda d: d.update(lanchester_pair=[{"order": 13}]), "design.lanchester_pair[1].order"),
])
def test_bad_design_table_names_file_and_key(base_scene, edit, key):
    design = copy.deepcopy(DESIGN)
    edit(design)
    base_scene["design"] = design
    with pytest.raises(SceneError) as info:
        scene_from_text(tomli_w.dumps(base_scene), "bad.toml")
    assert f"bad.toml: {key}" in str(info.value)


def test_valid_design_table_loads(base_scene):
    base_scene["design"] = copy.deepcopy(DESIGN)
    request = hb.load_scene(base_scene).design
    assert request == DesignRequest((1,), (Candidate("counterweights", "cw", 1, (-0.05, 0.05)),))
