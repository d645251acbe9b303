"""Hard cases stay numerically stable: λ up to 0.95, offsets up to the assembly
limit, 1–24 cylinders of mixed types, orders up to 48, masses 1e-3–1e3 kg,
1 rpm to 30 000 rpm. Each case gives finite, accurate results or a clear
refusal. test_invariances.py and test_stars_oracles.py cover small engines
(λ ≤ 0.5, small offsets, ≤ 6 cylinders, order ≤ 12); this module covers the
rest. No oracle here uses harmbal's code:

* Momentum from positions alone. At unit speed F = −Σ m·G'', and for k ≥ 1
  the order-k phasor of −G'' is k²·C_k(G), so C_k(F) = ω² k² Σ m C_k(G). The
  body centroids G(θ) (piston, rod, unbalances) are written here in closed
  form and transformed with numpy's FFT. Every body moves in a plane
  x = const, so the transverse moments follow in the same way:
  C_k(M_y) = −ω² k² Σ m (x − p_x) C_k(G_z) and C_k(M_z) = ω² k² Σ m (x − p_x) C_k(G_y).
  No derivative formula is needed, so a wrong branch of the slider crank, a
  lost term or a sign error shows up.
* Planar momentum near toggle (one cylinder, with the roll moment and the
  drive torque): bodies in the cylinder plane, derivatives by mpmath at 30
  digits, F = −ω² Σ m G'', roll = −ω² Σ (m G × G'' + I ϑ'') + ω² d(KE₁)/dθ. The
  tolerance is the condition number κ = l²/(l² − (r + |e|)²) times ε.
* Symmetry. Identical cylinders cancel order k when the star sum
  Σ e^{ikφ_i}·e^{i(1∓k)β_i} vanishes (a cylinder's load turned by its bank).
  A crank that is mirror-symmetric about x = 0 cancels every transverse
  moment about a point on that plane. Opposed cylinders of a boxer twin at
  the same local angle cancel every force. A counterweight m_rot·r + m_rec·r/2
  at 180° cancels the co-rotating first-order force of a centric single
  cylinder, whose piston travel has no odd harmonic but the first.
* Threshold: a component is balanced when |C| ≤ balanced_rtol × load scale
  (docs/conventions.md). A crankshaft unbalance δ added to an engine whose
  forces cancel puts exactly δω² into the first-order co-rotating phasor, so δ
  can be set just below or just above the threshold.
* Scaling: loads scale exactly with ω² (one unit-speed solution times ω²) and
  linearly with all masses, inertias and unbalances together. Relabelling
  changes nothing; taking throw j as the origin multiplies C_k by e^{−ikΔ}.
  Mirroring flips F_y, M_x and M_z, and negates the moment phasors.
* Aliasing: a run with 8192 samples per revolution is the reference. The
  reported estimate must bound the real difference (plus 1e-13 of the load
  scale for round-off).
* Refusals (docs/scenes.md): l > r + |pin offset + cylinder offset|, finite
  values, positive masses, inertias, unbalances and speeds. The message must
  name the file, the key and the cylinder, and `harmbal run` must exit with
  status 2.
"""

from __future__ import annotations

import copy
import math
import warnings

import mpmath as mp
import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import harmbal as hb
from harmbal.cli import main
from harmbal.model.kinematics import slider_crank

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
EPS = np.finfo(float).eps
RPM = math.pi / 30
#: docs/conventions.md: balanced when |C| ≤ 1e-10 × load scale.
BALANCED_RTOL = 1e-10
DEG = math.pi / 180
ALL_EFFECTS = ["reciprocating", "rotating", "rod_inertia", "mass_torque"]
#: These cases probe the boundary between zero (round-off) and the rest: with the smallest negligible level
#: (1e-12 of one cylinder's share, below the zero threshold of 1e-10 of the load scale) nothing is negligible,
#: so "free" means "not zero" (tests/test_classes.py tests the negligible class).
ZERO_ONLY = 1e-12


# --------------------------------------------------------------------------
# Random hard engines


def _grid(lo, hi, step=1e-3):
    """Numbers in [lo, hi] on a grid: never a tiny non-zero value like 1e-300,
    whose products underflow to subnormals and lose the relative precision
    the scaling tests rely on."""
    return st.integers(round(lo / step), round(hi / step)).map(lambda i: i * step)


def _log(lo, hi):
    return st.floats(math.log(lo), math.log(hi), allow_nan=False, allow_infinity=False).map(math.exp)


def _degrees(lo, hi):
    """Angles on a whole-degree grid. Firing instants then either coincide up
    to round-off or are at least ~1e-3 rad apart. A separate test covers TDCs
    a few nanoradians apart (test_nearly_coincident_tdcs_do_not_crash)."""
    return st.integers(lo, hi).map(lambda d: d * DEG)


@st.composite
def cylinder_types(draw):
    """Geometry and masses of one cylinder type. λ is in 0.1–0.95. The offset
    of the pin path is up to 99 % of the assembly margin l − r, and it is often
    split into a pin offset and a cylinder offset of up to ±5 r that nearly
    cancel. Masses are in 1e-3–1e3 kg. The rod CG may sit anywhere from the big
    end to the small end, and up to 0.2 l off the rod axis."""
    r = draw(_log(0.005, 0.5))
    lam = draw(_grid(0.1, 0.95))
    l = r / lam
    total = draw(_grid(-0.99, 0.99)) * (l - r)
    split = draw(st.sampled_from([0.0, 1.0])) * draw(_grid(-5.0, 5.0)) * r
    rod_mass = draw(_log(1e-3, 1e3))
    return {
        "geometry": {"crank_radius": r, "rod_length": l, "pin_offset": total + split, "cylinder_offset": -split},
        "piston": {"mass": draw(_log(1e-3, 1e3)),
                   "cg_offset": [draw(_grid(-0.5, 0.5)) * r, draw(_grid(-0.5, 0.5)) * r]},
        "rod": {"mass": rod_mass, "cg_from_big_end": draw(_grid(0.0, 1.0)) * l, "cg_offset": draw(_grid(-0.2, 0.2)) * l,
                "inertia": rod_mass * l * l * draw(_grid(0.01, 0.2))},
    }


@st.composite
def hard_engines(draw, max_cylinders=24, piston_models=("exact", "series")):
    """A random valid engine of 1–24 cylinders with up to four cylinder types.
    It is either a regular crank (throws 360°/n apart, a few banks) or random
    throws and banks. Throw and crankshaft unbalances are 1e-4–1e2 kg m.
    Speeds are 1–3 values from {1 rpm, 30 000 rpm, anything between}. Any rod
    model, max_order 1–48, default or explicit sampling.accuracy (never fixed
    samples)."""
    n = draw(st.integers(1, max_cylinders))
    types = draw(st.lists(cylinder_types(), min_size=1, max_size=min(n, 4)))
    regular = draw(st.booleans())
    cylinders = []
    for i in range(n):
        cyl = {"label": f"c{i + 1}", "axial_position": 0.1 * i + draw(_grid(-0.02, 0.02)),
               "throw": math.remainder(2 * math.pi * i / n, 2 * math.pi) if regular else draw(_degrees(-180, 180)),
               "bank": draw(st.sampled_from([0.0, -45 * DEG, 90 * DEG])) if regular else draw(_degrees(-180, 180)),
               **copy.deepcopy(types[draw(st.integers(0, len(types) - 1))])}
        if draw(st.integers(0, 3)) == 0:
            cyl["throw_unbalance"] = [{"unbalance": draw(_log(1e-4, 1e2)), "angle": draw(_degrees(-180, 180)),
                                       "axial_offset": draw(_grid(-0.05, 0.05))}]
        cylinders.append(cyl)
    speeds = draw(st.lists(st.one_of(st.just(1.0), st.just(30000.0), _log(1.0, 30000.0)),
                           min_size=1, max_size=3, unique=True))
    model = {"effects": ALL_EFFECTS, "rod": draw(st.sampled_from(["rigid", "two_point_couple", "two_point"]))}
    if draw(st.sampled_from(piston_models)) == "series":
        model.update(piston="series", series_harmonics=draw(st.integers(1, 8)))
    sampling = {"max_order": draw(st.integers(1, 48))}
    if draw(st.booleans()):
        sampling["accuracy"] = draw(_log(1e-14, 1e-9))
    return {
        "engine": {"name": "hard", "speed": [f"{s!r} rpm" for s in speeds],
                   "rotation": draw(st.sampled_from(["clockwise", "counterclockwise"])),
                   "cycle": draw(st.sampled_from([2, 4])),
                   "reference_point": [draw(_grid(-0.5, 0.5)) for _ in range(3)]},
        "model": model,
        "sampling": sampling,
        "cylinder": cylinders,
        "crankshaft_unbalance": [{"unbalance": draw(_log(1e-4, 1e2)), "angle": draw(_degrees(-180, 180)),
                                  "axial_position": draw(_grid(-0.2, 2.5))} for _ in range(draw(st.integers(0, 2)))],
    }


# --------------------------------------------------------------------------
# Helpers


def _quiet(function, *args, **kwargs):
    """Call with every warning turned into an error. Inside the documented
    ranges nothing may warn (e.g. AccuracyWarning or numpy's overflow)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return function(*args, **kwargs)


def _nonfinite(ds, path="") -> list[str]:
    """Every numeric variable or coordinate holding NaN or inf, in a Dataset or
    in every group of a DataTree."""
    if hasattr(ds, "subtree"):
        return [bad for node in ds.subtree for bad in _nonfinite(node.ds, node.path)]
    return [f"{path}:{name}" for name, var in {**ds.data_vars, **ds.coords}.items()
            if var.dtype.kind in "fc" and not np.all(np.isfinite(var.values))]


def _scales(ds) -> tuple[float, float]:
    """Largest load scales (force, moment) over the speeds."""
    return float(np.max(ds.force_scale)), float(np.max(ds.moment_scale))


def _close(actual, expected, atol):
    np.testing.assert_allclose(np.asarray(actual), np.asarray(expected), rtol=0, atol=atol)


def _close_cleaned(actual, expected, scale, rtol):
    """Like _close for stars phasors, which are stored as exactly 0 when
    balanced. Where only one side was cleaned, the other side must still lie
    within the balanced threshold."""
    a, b = np.asarray(actual), np.asarray(expected)
    one_cleaned = (a == 0) != (b == 0)
    bound = rtol * scale + np.where(one_cleaned, BALANCED_RTOL * scale * (1 + 1e-6), 0.0)
    assert np.all(np.abs(a - b) <= bound), np.max(np.abs(a - b) - bound)


def _same_flags(flags_a, flags_b, amplitude, threshold):
    """The free/balanced flags agree, except for components within 0.1 % of
    the threshold, where round-off in the invariance may decide."""
    amplitude = np.abs(np.asarray(amplitude))
    clear = np.abs(amplitude - threshold) > 1e-3 * threshold
    np.testing.assert_array_equal(np.asarray(flags_a)[clear], np.asarray(flags_b)[clear])


def _unit_speed(ds, name):
    """A stars variable at unit speed, first speed, where its classification is made."""
    values = ds[name].values
    w2 = np.atleast_1d(ds.speed.values)[0] ** 2
    return (values[0] if "speed" in ds[name].dims else values) / w2


def _cells(line: str):
    """Order, cells and the rest of one printed table row. A cell is None for
    a balanced "0", otherwise the amplitude (which comes with a phase)."""
    tokens = line.split()
    cells, i = [], 1
    while i < len(tokens):
        if tokens[i] == "0":
            cells.append(None)
            i += 1
        elif i + 1 < len(tokens) and tokens[i + 1].endswith("°"):
            cells.append(float(tokens[i]))
            i += 2
        else:
            break
    return int(tokens[0]), cells, " ".join(tokens[i:])


def _table(text: str, header: str) -> list[dict]:
    """The rows under every header line of a load table (it names units, "[")
    starting with ``header`` ("Free force", "Free moment" of `harmbal run`,
    "order" of `harmbal stars`), as one dict per speed block: order → (cells,
    rest of the line)."""
    blocks, rows = [], None
    for line in text.splitlines():
        stripped = line.strip()
        if line.startswith("Speed "):
            blocks.append({})
            rows = None
        elif stripped.startswith(header) and "[" in stripped and blocks:
            rows = blocks[-1]
        elif rows is not None and stripped[:1].isdigit():
            order, cells, rest = _cells(stripped)
            rows[order] = (cells, rest)
        else:
            rows = None
    return blocks


def _write(tmp_path, name, data):
    path = tmp_path / name
    path.write_text(tomli_w.dumps(data))
    return path


# --------------------------------------------------------------------------
# Oracle: order phasors of force and transverse moment from body positions


def _si_speed(text: str) -> float:
    number, unit = text.split()
    assert unit == "rpm"
    return float(number) * RPM


def _body_positions(data, theta):
    """Mass and centroid of every moving body over θ, written from the
    conventions: (mass, x, y(θ), z(θ)) per body. A point (c, n) in a cylinder's
    plane is w = (c + i n)·e^{iβ} in the transverse plane, with z = Re w and
    y = −s·Im w (t = −s·y points 90° ahead of +z in the direction of rotation)."""
    s = 1 if data["engine"]["rotation"] == "counterclockwise" else -1
    rigid = data["model"]["rod"] == "rigid"
    bodies = []

    def add(mass, x, w):
        bodies.append((mass, x, -s * w.imag, w.real))

    for cyl in data["cylinder"]:
        g, p, rod = cyl["geometry"], cyl["piston"], cyl["rod"]
        r, l = g["crank_radius"], g["rod_length"]
        e = g["pin_offset"] + g["cylinder_offset"]
        phi, beta, x = cyl["throw"], cyl["bank"], cyl["axial_position"]
        psi = theta + phi - beta
        turn = np.exp(1j * beta)
        pin = r * np.exp(1j * psi)  # crank pin A as c + i n
        c_b = r * np.cos(psi) + np.sqrt(l * l - (e - r * np.sin(psi)) ** 2)
        piston_pin = c_b + 1j * e  # B on the line n = e, on the far side of the crank
        add(p["mass"], x, (piston_pin + p["cg_offset"][0] + 1j * p["cg_offset"][1]) * turn)
        axis = (piston_pin - pin) / l  # unit vector along the rod; i·axis is 90° ahead
        lateral = rod.get("cg_offset", 0.0) if rigid else 0.0
        add(rod["mass"], x, (pin + rod["cg_from_big_end"] * axis + lateral * 1j * axis) * turn)
        for u in cyl.get("throw_unbalance", []):
            # a unit mass at radius U, pointing at θ + φ + α from +z
            add(1.0, x + u.get("axial_offset", 0.0), u["unbalance"] * np.exp(1j * (theta + phi + u["angle"])))
    for u in data.get("crankshaft_unbalance", []):
        add(1.0, u["axial_position"], u["unbalance"] * np.exp(1j * (theta + u["angle"])))
    return bodies


def momentum_oracle(data, kmax, samples):
    """Order phasors at unit speed from the body positions (module docstring):
    the force (order, axis x/y/z) and the transverse moments (order, axis y/z)
    about the reference point."""
    theta = 2 * np.pi * np.arange(samples) / samples
    k = np.arange(kmax + 1)
    px = data["engine"]["reference_point"][0]

    def minus_acceleration(values):
        """C_k(−G'') = k² C_k(G); order 0 (the mean of an acceleration) is 0."""
        return (2 * np.fft.rfft(values) / samples)[: kmax + 1] * k**2

    force = np.zeros((kmax + 1, 3), complex)
    moment = np.zeros((kmax + 1, 2), complex)
    for mass, x, y, z in _body_positions(data, theta):
        fy, fz = mass * minus_acceleration(y), mass * minus_acceleration(z)
        force[:, 1] += fy
        force[:, 2] += fz
        moment[:, 0] -= (x - px) * fz
        moment[:, 1] += (x - px) * fy
    return force, moment


# --------------------------------------------------------------------------
# 1. Random hard engines: finite, silent, and the two paths agree with the oracle


@SETTINGS
@given(hard_engines())
def test_hard_engines_give_finite_outputs_without_warnings(data):
    """Every variable and coordinate of every group of hb.analyse is finite, and
    nothing warns. verify_orders passes: the order-domain and time-domain paths
    agree within their own tolerance."""
    scene = _quiet(hb.load_scene, data)
    tree = _quiet(hb.analyse, scene, per_cylinder=True)
    assert not _nonfinite(tree)
    check = _quiet(hb.verify_orders, scene)
    assert check.attrs["passed"] == "yes", (check.force_difference.values, check.force_tolerance.values,
                                            check.moment_difference.values, check.moment_tolerance.values)
    assert not _nonfinite(check)


@SETTINGS
@given(hard_engines(piston_models=("exact",)))
def test_hard_engines_obey_momentum(data):
    """Force and transverse moments of every order, from both paths (time
    domain + FFT, and the order-domain stars), match the momentum oracle from
    the body positions. The tolerance is round-off: the oracle's position
    round-off ε·l magnified by k² ≤ max_order², the FFTs' ε·log₂N, and for the
    moment ε·|x|·|F| (harmbal takes moments about the origin, then shifts them
    to the reference point). The errors measured stay below a quarter of it."""
    scene = hb.load_scene(data)
    orders = hb.order_spectrum(hb.simulate(scene))
    stars = hb.stars(scene)
    kmax = scene.sampling.max_order
    samples = 2 * orders.attrs["samples_per_rev"]  # positions decay like the loads; twice the samples is ample
    force, moment = momentum_oracle(data, kmax, samples)
    omega = np.array([_si_speed(s) for s in data["engine"]["speed"]])
    slender = max(c["geometry"]["rod_length"] / c["geometry"]["crank_radius"] for c in data["cylinder"])
    rtol = 8 * EPS * (kmax**2 * (slender + 1) + math.log2(samples))
    reach = (max(abs(c["axial_position"]) + 0.05 for c in data["cylinder"] + data["crankshaft_unbalance"]
                 if "axial_position" in c) + float(np.linalg.norm(data["engine"]["reference_point"])))
    for i, w in enumerate(omega):
        for ds in (orders, stars):
            pick = {"speed": i} if "speed" in ds.dims else {}
            fs, ms = float(ds.force_scale.isel(pick)), float(ds.moment_scale.isel(pick))
            shift = 8 * EPS * reach * fs
            _close_cleaned(ds.force.isel(pick).values, w**2 * force, fs, rtol)
            _close_cleaned(ds.moment.isel(pick).values[:, 1:], w**2 * moment, ms, rtol + shift / ms)


def test_momentum_oracle_is_sane():
    """The oracle itself, on a centric single cylinder turning clockwise at
    x = 0.3 with its rod as a point mass on the crank pin. Order 1: the piston
    and rod give (m_p + m_rod) r along z, and the rod r·sin θ along y (the pin
    passes +y at θ = 90°), i.e. the phasor −i·m_rod·r. Order 3 is empty (no odd
    piston harmonic but the first), and M_y = −x F_z."""
    r, l = 0.05, 0.2
    data = {"engine": {"rotation": "clockwise", "reference_point": [0.0, 0.0, 0.0]}, "model": {"rod": "two_point"},
            "cylinder": [{"throw": 0.0, "bank": 0.0, "axial_position": 0.3,
                          "geometry": {"crank_radius": r, "rod_length": l, "pin_offset": 0.0, "cylinder_offset": 0.0},
                          "piston": {"mass": 2.0, "cg_offset": [0.0, 0.0]},
                          "rod": {"mass": 1.0, "cg_from_big_end": 0.0}}]}
    force, moment = momentum_oracle(data, 4, 256)
    scale = 3 * r  # the largest component, at 1 rad/s
    _close(force[1], [0, -1j * r, 3 * r], 1e-12 * scale)
    _close(force[3], [0, 0, 0], 1e-12 * scale)
    _close(moment[:, 0], -0.3 * force[:, 2], 1e-12 * 0.3 * scale)


# --------------------------------------------------------------------------
# 2. Invariances of random hard engines


@SETTINGS
@given(hard_engines(max_cylinders=12))
def test_hard_engines_omega_squared_at_extreme_speeds(data):
    """One scene at 1 rpm, 30 000 rpm and a third speed. The time-domain loads
    and the stars dataset at speed i are (ω_i/ω_0)² times speed 0, element by
    element, to 1e-13: harmbal solves once at unit speed and scales. The order
    spectrum is an FFT per speed, which is linear only up to round-off, so it
    is held to 1e-13 of the load scale. The speed coordinate is the rpm value
    times π/30."""
    speeds = [1.0, 30000.0, _si_speed(data["engine"]["speed"][0]) / RPM]
    if speeds[2] in speeds[:2]:
        speeds[2] = 1234.5
    data["engine"]["speed"] = [f"{s!r} rpm" for s in speeds]
    scene = hb.load_scene(data)
    time = _quiet(hb.simulate, scene)
    orders = hb.order_spectrum(time)
    stars = hb.stars(scene)
    np.testing.assert_allclose(time.speed.values, np.array(speeds) * RPM, rtol=2 * EPS, atol=0)
    ratio = (time.speed.values / time.speed.values[0]) ** 2
    for ds, names in ((time, ("force", "moment", "force_scale", "moment_scale")),
                      (stars, ("force", "moment", "force_rotating", "moment_rotating", "force_cylinder",
                               "moment_cylinder", "force_scale", "moment_scale", "aliasing_error_force",
                               "aliasing_error_moment"))):
        for name in names:
            values = ds[name].transpose("speed", ...).values
            assert np.all(np.isfinite(values)), name
            for i in (1, 2):
                np.testing.assert_allclose(values[i], ratio[i] * values[0], rtol=1e-13, atol=0, err_msg=name)
    for name in ("force", "moment", "force_rotating", "moment_rotating"):
        scale = orders[f"{name.split('_')[0]}_scale"].values
        values = orders[name].transpose("speed", ...).values
        for i in (1, 2):
            _close(values[i], ratio[i] * values[0], 1e-13 * scale[i])


@SETTINGS
@given(hard_engines(max_cylinders=12), _log(1e-3, 1e3))
def test_hard_engines_scale_with_all_masses(data, c):
    """All masses, rod inertias and unbalances times c: every load times c, and
    the classification is unchanged (it is relative to the load scale)."""
    heavy = copy.deepcopy(data)
    for cyl in heavy["cylinder"]:
        cyl["piston"]["mass"] *= c
        cyl["rod"]["mass"] *= c
        cyl["rod"]["inertia"] *= c
        for u in cyl.get("throw_unbalance", []):
            u["unbalance"] *= c
    for u in heavy["crankshaft_unbalance"]:
        u["unbalance"] *= c
    a, b = hb.load_scene(data), hb.load_scene(heavy)
    orders_a, orders_b = hb.order_spectrum(hb.simulate(a)), hb.order_spectrum(hb.simulate(b))
    stars_a, stars_b = hb.stars(a), hb.stars(b)
    fs, ms = _scales(orders_a)
    _close(orders_b.force, c * orders_a.force, 1e-12 * c * fs)
    _close(orders_b.moment, c * orders_a.moment, 1e-12 * c * ms)
    fs, ms = _scales(stars_a)
    _close_cleaned(stars_b.force_rotating, c * stars_a.force_rotating, c * fs, 1e-12)
    _close_cleaned(stars_b.moment_rotating, c * stars_a.moment_rotating, c * ms, 1e-12)
    for name, kind in (("force_free", "force"), ("moment_free", "moment")):
        scale = float(_unit_speed(stars_a, f"{kind}_scale"))
        _same_flags(stars_b[name], stars_a[name], _unit_speed(stars_a, f"{kind}_rotating"), BALANCED_RTOL * scale)


@SETTINGS
@given(hard_engines(), st.randoms(use_true_random=False), st.integers(0, 23))
def test_hard_engines_relabel_permute_and_shift_origin(data, rnd, pick):
    """Shuffle and relabel the cylinders, and take cylinder j's throw as the
    angle origin (every throw and crankshaft unbalance angle minus Δ). Then
    C'_k = C_k e^{−ikΔ}, P'_co = P_co e^{−ikΔ} and P'_counter = P_counter e^{+ikΔ},
    in both paths. Each cylinder's arrows stay with it, and the classification
    does not change."""
    delta = data["cylinder"][pick % len(data["cylinder"])]["throw"]
    other = copy.deepcopy(data)
    rnd.shuffle(other["cylinder"])
    for cyl in other["cylinder"]:
        cyl["label"] = "new-" + cyl["label"]
        cyl["throw"] = math.remainder(cyl["throw"] - delta, 2 * math.pi)
    for u in other["crankshaft_unbalance"]:
        u["angle"] = math.remainder(u["angle"] - delta, 2 * math.pi)
    a, b = hb.load_scene(data), hb.load_scene(other)
    k = np.arange(a.sampling.max_order + 1)
    turn = np.exp(-1j * k * delta)
    rotation = np.stack([turn, np.conj(turn)], axis=-1)
    # the shifted angles carry a round-off of ~ε·π, magnified k times in the phase
    rtol = 1e-12 * max(k[-1], 1)
    orders_a, orders_b = hb.order_spectrum(hb.simulate(a)), hb.order_spectrum(hb.simulate(b))
    fs, ms = _scales(orders_a)
    _close(orders_b.force.transpose(..., "order", "axis"), orders_a.force.transpose(..., "order", "axis")
           * turn[:, None], rtol * fs)
    _close(orders_b.moment_rotating, orders_a.moment_rotating * rotation, rtol * ms)
    stars_a, stars_b = hb.stars(a), hb.stars(b)
    fs, ms = _scales(stars_a)
    _close_cleaned(stars_b.force_rotating, stars_a.force_rotating * rotation, fs, rtol)
    _close_cleaned(stars_b.moment, stars_a.moment.transpose(..., "order", "axis") * turn[:, None], ms, rtol)
    labels = ["new-" + label for label in stars_a.cylinder.values]
    _close(stars_b.force_cylinder.sel(cylinder=labels), stars_a.force_cylinder * rotation, rtol * fs)
    for name, kind in (("force_free", "force"), ("moment_free", "moment")):
        scale = float(_unit_speed(stars_a, f"{kind}_scale"))
        _same_flags(stars_b[name], stars_a[name], _unit_speed(stars_a, f"{kind}_rotating"), BALANCED_RTOL * scale)


@SETTINGS
@given(hard_engines())
def test_hard_engines_mirror(data):
    """The same numbers turning the other way (reference point mirrored too)
    are the mirror image in the x–z plane. F_y changes sign, and so do M_x and
    M_z (moments are axial vectors). The force phasors are unchanged and the
    moment phasors are negated."""
    cw, ccw = copy.deepcopy(data), copy.deepcopy(data)
    cw["engine"]["rotation"], ccw["engine"]["rotation"] = "clockwise", "counterclockwise"
    ccw["engine"]["reference_point"][1] *= -1
    a, b = hb.load_scene(cw), hb.load_scene(ccw)
    flip_f, flip_m = np.array([1, -1, 1]), np.array([-1, 1, -1])
    orders_a, orders_b = hb.order_spectrum(hb.simulate(a)), hb.order_spectrum(hb.simulate(b))
    fs, ms = _scales(orders_a)
    _close(orders_b.force, orders_a.force * flip_f, 1e-12 * fs)
    _close(orders_b.moment, orders_a.moment * flip_m, 1e-12 * ms)
    _close(orders_b.moment_rotating, -orders_a.moment_rotating, 1e-12 * ms)
    stars_a, stars_b = hb.stars(a), hb.stars(b)
    fs, ms = _scales(stars_a)
    _close_cleaned(stars_b.force_rotating, stars_a.force_rotating, fs, 1e-12)
    _close_cleaned(stars_b.moment_rotating, -stars_a.moment_rotating, ms, 1e-12)


# --------------------------------------------------------------------------
# 3. Accuracy at high λ: the default sampling against 8192 samples per revolution


def _pair(lam, fraction, split=0.0, *, max_order=12, **sampling):
    """Two cylinder types on a 70° V, all effects, rigid rods with their CG off
    the axis. Type 1 runs at λ with a pin-path offset e = ``fraction`` of the
    assembly margin l − r, written as pin offset ``split`` + e and cylinder
    offset −``split``. Type 2 has a shorter stroke, a third of that offset and
    2.5 times the masses."""
    r, l = 0.05, 0.05 / lam

    def kind(radius, offset, mass):
        return {"geometry": {"crank_radius": radius, "rod_length": l, "pin_offset": offset + split,
                             "cylinder_offset": -split},
                "piston": {"mass": mass, "cg_offset": [0.01, 0.002]},
                "rod": {"mass": 0.6 * mass, "cg_from_big_end": 0.3 * l, "cg_offset": 0.003, "inertia": 0.002 * mass}}

    return {
        "engine": {"name": "pair", "speed": "6000 rpm", "rotation": "clockwise",
                   "reference_point": [0.05, 0.02, -0.03]},
        "model": {"negligible": ZERO_ONLY, "effects": ALL_EFFECTS, "rod": "rigid"},
        "sampling": {"max_order": max_order, **sampling},
        "cylinder": [{"throw": 0.0, "bank": -35 * DEG, "axial_position": 0.06, **kind(r, fraction * (l - r), 1.0)},
                     {"throw": 200 * DEG, "bank": 35 * DEG, "axial_position": -0.06,
                      **kind(0.8 * r, fraction * (l - r) / 3, 2.5)}],
    }


def _reference(data, samples=8192):
    fine = copy.deepcopy(data)
    fine["sampling"] = {"max_order": data["sampling"]["max_order"], "samples_per_rev": samples}
    return hb.load_scene(fine)


@pytest.mark.parametrize("lam", [0.9, 0.95])
@pytest.mark.parametrize("fraction,split", [(0.0, 0.0), (0.6, 0.0), (0.99, 0.1), (-0.99, -0.2)])
@pytest.mark.parametrize("max_order", [12, 48])
def test_default_sampling_at_high_lambda(lam, fraction, split, max_order):
    """At the default accuracy (1e-12) the phasors of both paths differ from
    the 8192-sample reference by less than the reported aliasing estimate plus
    1e-13 of the load scale, and by less than 1e-12 of the load scale (the
    accuracy asked for)."""
    data = _pair(lam, fraction, split, max_order=max_order)
    scene, fine = _quiet(hb.load_scene, data), _reference(data)
    orders = _quiet(hb.order_spectrum, _quiet(hb.simulate, scene))
    reference = hb.order_spectrum(hb.simulate(fine))
    assert orders.attrs["samples_per_rev"] < 8192 // 2
    for name in ("force", "moment"):
        scale = float(orders[f"{name}_scale"])
        difference = np.abs(orders[name] - reference[name]).max("order")
        assert np.all(difference <= orders[f"aliasing_error_{name}"] + 1e-13 * scale), name
        assert np.all(difference <= 1e-12 * scale), name
    stars, stars_ref = _quiet(hb.stars, scene), hb.stars(fine)
    for name in ("force", "moment"):
        scale = float(stars[f"{name}_scale"])
        bound = float(stars[f"aliasing_error_{name}"]) + 1e-13 * scale
        _close_cleaned(stars[name], stars_ref[name], scale, bound / scale)




@pytest.mark.parametrize("lam,fraction,sampling,cylinders", [
    (0.9, 0.0, {"samples_per_rev": 32, "max_order": 8}, 2),  # beats between the cylinders in the tail band
    (0.95, 0.0, {"samples_per_rev": 32, "max_order": 8}, 2),
    (0.95, 0.6, {"accuracy": 1e-3}, 2),
    (0.95, 0.99, {"accuracy": 1e-3}, 2),
    (0.9, -0.3, {"samples_per_rev": 32, "max_order": 8}, 1),
    (0.95, 0.6, {"samples_per_rev": 64}, 1),
    (0.9, 0.99, {"samples_per_rev": 48}, 1),  # near the offset limit: ρ ≈ 0.98
    (0.95, 0.99, {"samples_per_rev": 48}, 1),  # near the offset limit: ρ ≈ 0.98
    (0.95, -0.99, {"samples_per_rev": 64}, 2),
])
def test_coarse_sampling_estimates_are_honest(lam, fraction, sampling, cylinders):
    """With deliberately coarse sampling (fixed samples, or a loose accuracy)
    the reported aliasing estimates of both paths still bound the real
    difference from the 8192-sample reference."""
    sampling = dict(sampling)
    data = _pair(lam, fraction, max_order=sampling.pop("max_order", 12), **sampling)
    data["cylinder"] = data["cylinder"][:cylinders]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", hb.AccuracyWarning)  # a fixed coarse sampling may warn; the estimate is tested
        scene = hb.load_scene(data)
        orders = hb.order_spectrum(hb.simulate(scene))
        stars = hb.stars(scene)
    fine = _reference(data)
    reference, stars_ref = hb.order_spectrum(hb.simulate(fine)), hb.stars(fine)
    for name in ("force", "moment"):
        scale = float(orders[f"{name}_scale"])
        difference = np.abs(orders[name] - reference[name]).max("order")
        assert difference.max() > 1e-12 * scale  # the sampling really is coarse
        estimate = orders[f"aliasing_error_{name}"]
        assert np.all(difference <= estimate + 1e-13 * scale), (name, (difference / estimate).values)
        difference = float(np.abs(stars[name] - stars_ref[name]).max())
        assert difference <= float(stars[f"aliasing_error_{name}"]) + 1e-13 * scale, name


# --------------------------------------------------------------------------
# 4. Exactly cancelling engines


def _hard_type(lam=0.95, fraction=0.9):
    """One near-toggle cylinder type: λ = 0.95, a pin-path offset of 90 % of the
    assembly margin written as a large pin offset (+3 r) and a nearly opposite
    cylinder offset, piston and rod CGs off their axes."""
    r = 0.04
    l = r / lam
    e = fraction * (l - r)
    return {"geometry": {"crank_radius": r, "rod_length": l, "pin_offset": 3 * r + e, "cylinder_offset": -3 * r},
            "piston": {"mass": 0.45, "cg_offset": [0.01, 0.001]},
            "rod": {"mass": 0.5, "cg_from_big_end": 0.3 * l, "cg_offset": 0.002, "inertia": 0.0015}}


def _layout(name):
    """(cylinders, reference x) of a layout; every cylinder of the hard type.
    Mirror-symmetric cranks are centred on x = 0."""
    if name == "boxer twin, staggered":
        return [{"throw": "0 deg", "bank": "-90 deg", "axial_position": 0.02},
                {"throw": "180 deg", "bank": "90 deg", "axial_position": -0.02}], 0.05
    throws, banks = {"inline 6": ([0, 240, 120, 120, 240, 0], [0]),
                     "V12 60°": ([0, 240, 120, 120, 240, 0], [-30, 30]),
                     "inline 24": ([0, 150, 60, 270, 180, 30, 240, 90, 300, 120, 330, 210], [0])}[name]
    if name == "inline 24":
        throws = throws + throws[::-1]
    n = len(throws)
    return [{"throw": f"{phi} deg", "bank": f"{beta} deg", "axial_position": 0.09 * (j - (n - 1) / 2)}
            for beta in banks for j, phi in enumerate(throws)], 0.0


def _expected_free(cylinders, px, kmax):
    """Which components of each order are free, from star sums alone. For
    identical cylinders the order-k co-rotating force is α_k Σ e^{ikφ_i} e^{i(1−k)β_i}
    and the counter-rotating one is γ_k Σ e^{−ikφ_i} e^{i(1+k)β_i} (a cylinder's
    load turned by its bank). The transverse moments carry the extra weight
    (x_i − p_x), and the roll is R_k Σ e^{ik(φ_i − β_i)}. α_k, γ_k and R_k are
    non-zero at this geometry, and order 0 (a mean of accelerations) is always
    zero."""
    phi = np.array([float(c["throw"].split()[0]) * DEG for c in cylinders])
    beta = np.array([float(c["bank"].split()[0]) * DEG for c in cylinders])
    lever = np.array([c["axial_position"] - px for c in cylinders])
    k = np.arange(kmax + 1)[:, None]
    co, counter = np.exp(1j * k * phi + 1j * (1 - k) * beta), np.exp(-1j * k * phi + 1j * (1 + k) * beta)
    roll = np.exp(1j * k * (phi - beta))
    tol = 1e-9 * len(cylinders) * max(1.0, float(np.abs(lever).max()))

    def free(terms, weight=1.0):
        out = np.abs((terms * weight).sum(axis=1)) > tol
        out[0] = False
        return out

    return {"force": np.stack([free(co), free(counter)], axis=-1),
            "moment": np.stack([free(co, lever), free(counter, lever)], axis=-1),
            "roll": free(roll)}


@pytest.mark.parametrize("name", ["inline 6", "V12 60°", "inline 24", "boxer twin, staggered"])
def test_symmetric_engines_cancel_exactly(name, tmp_path, capsys):
    """λ = 0.95 near the offset limit, all effects, orders up to 48, at 1 rpm
    and 30 000 rpm. Every component that the star sums cancel is classified
    balanced and stored as exactly 0 in the stars dataset (no noise phase).
    It is at most 1e-13 of the load scale in the order spectrum of the time
    domain, and `harmbal run` and `harmbal stars` print it as 0. Every other
    component is free."""
    cylinders, px = _layout(name)
    data = {"engine": {"name": name, "speed": ["1 rpm", "30000 rpm"], "rotation": "counterclockwise",
                       "reference_point": [px, 0.0, 0.0]},
            "model": {"negligible": ZERO_ONLY, "effects": ALL_EFFECTS, "rod": "rigid"}, "sampling": {"max_order": 48},
            **_hard_type(), "cylinder": cylinders}
    expected = _expected_free(cylinders, px, 48)
    assert expected["force"].any() or expected["moment"].any()  # not trivially balanced
    scene = _quiet(hb.load_scene, data)
    stars = _quiet(hb.stars, scene)
    np.testing.assert_array_equal(stars.force_free.values, expected["force"])
    np.testing.assert_array_equal(stars.moment_free.values, expected["moment"])
    np.testing.assert_array_equal(stars.roll_free.values, expected["roll"])
    for kind in ("force", "moment"):
        rotating = stars[f"{kind}_rotating"].values  # (speed, order, rotation)
        assert np.all((rotating == 0) == ~expected[kind]), kind
    cancelled = ~expected["force"].any(axis=1)
    assert np.all(stars.force.values[:, cancelled] == 0)
    transverse_zero = ~expected["moment"].any(axis=1)
    assert np.all(stars.moment.sel(axis=["y", "z"]).values[:, transverse_zero] == 0)
    assert np.all((stars.moment.sel(axis="x").values == 0) == ~expected["roll"])

    orders = _quiet(hb.order_spectrum, _quiet(hb.simulate, scene))
    for i in range(2):
        for kind, flags in (("force", expected["force"]), ("moment", expected["moment"])):
            scale = float(orders[f"{kind}_scale"][i])
            amplitude = np.abs(orders[f"{kind}_rotating"].values[i])
            assert np.all(amplitude[~flags] <= 1e-13 * scale), kind
            assert np.all(amplitude[flags] > BALANCED_RTOL * scale), kind

    path = _write(tmp_path, "engine.toml", data)
    assert main(["run", str(path)]) == 0
    text = capsys.readouterr().out
    for kind, label in (("force", "Free force"), ("moment", "Free moment")):
        blocks = _table(text, label)
        assert len(blocks) == 2  # 1 rpm and 30 000 rpm
        for rows in blocks:
            assert 0 not in rows  # order 0 is balanced: the row is left out
            for k in range(1, 49):
                cells = rows[k][0]
                assert (cells[3] is None, cells[4] is None) == tuple(~expected[kind][k]), (kind, k, cells)
                if kind == "moment":
                    assert (cells[0] is None) == (not expected["roll"][k]), (k, cells)
                if not expected[kind][k].any():
                    assert cells[1] is None and cells[2] is None, (kind, k, cells)
    assert main(["stars", str(path)]) == 0
    for rows in _table(capsys.readouterr().out, "order"):
        for k in range(1, 49):
            cells, verdict = rows[k]
            nothing_free = not (expected["force"][k].any() or expected["moment"][k].any() or expected["roll"][k])
            assert (verdict == "balanced") == nothing_free, (k, verdict)
            assert [c is None for c in cells] == [*~expected["force"][k], *~expected["moment"][k],
                                                  not expected["roll"][k]], (k, cells)


def test_counterweight_cancels_the_first_order_co_force():
    """Centric single cylinder at λ = 0.95 (its piston travel has no odd
    harmonic but the first, A_1 = 1): a throw counterweight of
    m_rot·r + m_rec·r/2 at 180° cancels the co-rotating first-order force and,
    in the cylinder's own plane, the co-rotating first-order moment. The
    counter-rotating half stays free."""
    r, lam = 0.06, 0.95
    l = r / lam
    m_p, m_rod, a = 2.2, 2.7, 0.34 * l
    small = m_rod * a / l  # the two-point split: small end with the piston, big end with the pin
    u = (m_rod - small) * r + (m_p + small) * r / 2
    data = {"engine": {"name": "single", "speed": ["1 rpm", "30000 rpm"], "reference_point": [0.3, 0.0, 0.0]},
            "model": {"negligible": ZERO_ONLY, "effects": ALL_EFFECTS, "rod": "rigid"}, "sampling": {"max_order": 48},
            "geometry": {"crank_radius": r, "rod_length": l},
            "piston": {"mass": m_p, "cg_offset": [0.02, 0.003]},
            "rod": {"mass": m_rod, "cg_from_big_end": a, "inertia": 0.03},
            "cylinder": [{"throw": "50 deg", "bank": "30 deg", "axial_position": 0.086,
                          "throw_unbalance": {"unbalance": u, "angle": "180 deg"}}]}
    scene = _quiet(hb.load_scene, data)
    stars = _quiet(hb.stars, scene)
    assert not stars.force_free.sel(order=1, rotation="co") and stars.force_free.sel(order=1, rotation="counter")
    assert not stars.moment_free.sel(order=1, rotation="co")
    assert np.all(stars.force_rotating.sel(order=1, rotation="co").values == 0)
    assert np.all(stars.moment_rotating.sel(order=1, rotation="co").values == 0)
    counter = stars.force_rotating.sel(order=1, rotation="counter").values
    np.testing.assert_allclose(np.abs(counter), (m_p + small) * r / 2 * stars.speed.values**2, rtol=1e-12)
    orders = _quiet(hb.order_spectrum, _quiet(hb.simulate, scene))
    co = np.abs(orders.force_rotating.sel(order=1, rotation="co").values)
    assert np.all(co <= 1e-13 * orders.force_scale.values)


def test_a_light_cylinder_beside_cancelling_heavy_ones_is_resolved():
    """Masses 1e3 kg and 1e-3 kg in one engine: two heavy opposed cylinders
    cancel every force exactly, so the free force is the light cylinder's
    alone, 1e-6 of the load scale and far above the balanced threshold. It
    equals the light cylinder run on its own to 1e-13 of the heavy load scale."""
    light = copy.deepcopy(_hard_type())
    light["piston"]["mass"], light["rod"]["mass"], light["rod"]["inertia"] = 1e-3, 1e-3, 1e-7
    heavy = copy.deepcopy(_hard_type())
    heavy["piston"]["mass"], heavy["rod"]["mass"], heavy["rod"]["inertia"] = 1e3, 1e3, 3.0
    light_cylinder = {"throw": "30 deg", "bank": "0 deg", "axial_position": 0.1, **light}
    data = {"engine": {"name": "mixed", "speed": "30000 rpm"},
            "model": {"negligible": ZERO_ONLY, "effects": ALL_EFFECTS},
            "sampling": {"max_order": 48},
            "cylinder": [{"throw": "0 deg", "bank": "-90 deg", "axial_position": 0.0, **heavy},
                         {"throw": "180 deg", "bank": "90 deg", "axial_position": 0.0, **heavy}, light_cylinder]}
    alone = {**data, "cylinder": [light_cylinder]}
    mixed, single = _quiet(hb.stars, hb.load_scene(data)), _quiet(hb.stars, hb.load_scene(alone))
    scale = float(mixed.force_scale)
    assert float(single.force_scale) < 1e-5 * scale
    free = single.force_free.values
    np.testing.assert_array_equal(mixed.force_free.values, free)
    assert free[1:5].all()
    _close(mixed.force_rotating, single.force_rotating, 1e-13 * scale)


# --------------------------------------------------------------------------
# 5. Components at the balanced threshold


def _boxer(x=0.0, unbalances=()):
    """Boxer twin of the hard type with both cylinders in the plane x: every
    force and transverse moment cancels exactly, only the roll stays free."""
    return {"engine": {"name": "boxer", "speed": "30000 rpm"},
            "model": {"negligible": ZERO_ONLY, "effects": ALL_EFFECTS, "rod": "rigid"}, "sampling": {"max_order": 12},
            **_hard_type(),
            "cylinder": [{"throw": "0 deg", "bank": "-90 deg", "axial_position": x},
                         {"throw": "180 deg", "bank": "90 deg", "axial_position": x}],
            "crankshaft_unbalance": list(unbalances)}


def _run_and_stars_rows(data, tmp_path, capsys, order):
    """Order ``order``'s rows as printed by `harmbal run` (free force, free
    moment) and by `harmbal stars` (cells, verdict), at the first speed."""
    path = _write(tmp_path, "scene.toml", data)
    assert main(["run", str(path)]) == 0
    text = capsys.readouterr().out
    force, moment = _table(text, "Free force")[0][order][0], _table(text, "Free moment")[0][order][0]
    assert main(["stars", str(path)]) == 0
    return force, moment, _table(capsys.readouterr().out, "order")[0][order]


@pytest.mark.parametrize("c", [0.5, 0.999, 1.001, 2.0])
def test_classification_flips_at_the_threshold(c, tmp_path, capsys):
    """A crankshaft unbalance δ = c × 1e-10 × load scale on an engine whose
    forces cancel exactly: the first-order co-rotating force is δω², balanced
    for c ≤ 1 and free above. hb.stars, the order spectrum, `harmbal run` and
    `harmbal stars` all flip between 0.999 and 1.001. A balanced component is
    stored as exactly 0 and printed as 0, and a free one is δω² at 40°."""
    base = _quiet(hb.stars, _quiet(hb.load_scene, _boxer()))
    w2 = float(base.speed) ** 2
    delta = c * BALANCED_RTOL * float(base.force_scale) / w2
    data = _boxer(unbalances=[{"unbalance": delta, "angle": "40 deg", "axial_position": 0.0}])
    scene = _quiet(hb.load_scene, data)
    free = c > 1
    stars = _quiet(hb.stars, scene)
    assert bool(stars.force_free.sel(order=1, rotation="co")) == free
    co = stars.force_rotating.sel(order=1, rotation="co").item()
    if free:
        assert co == pytest.approx(delta * w2 * np.exp(40j * DEG), rel=1e-5)  # the cancelled cylinders leave ~1e-16
    else:
        assert co == 0
    orders = _quiet(hb.order_spectrum, _quiet(hb.simulate, scene))
    amplitude = abs(orders.force_rotating.sel(order=1, rotation="co").item())
    assert (amplitude > BALANCED_RTOL * float(orders.force_scale)) == free
    force, _, (cells, verdict) = _run_and_stars_rows(data, tmp_path, capsys, 1)
    assert (force[3] is not None) == free and force[4] is None
    assert (cells[0] is not None) == free and ("F co" in verdict) == free


def test_moment_classification_agrees_between_the_paths(tmp_path, capsys):
    """Boxer twin in the plane x = 0.05 (transverse moments cancel) plus a
    crankshaft couple (δ at x = ±0.1, 180° apart): a pure first-order
    co-rotating moment 0.2·δ·ω². δ is set between the time-domain and
    order-domain thresholds, if they differ. Both paths must classify it the
    same way."""
    time = _quiet(hb.simulate, _quiet(hb.load_scene, _boxer(x=0.05)))
    stars = _quiet(hb.stars, _quiet(hb.load_scene, _boxer(x=0.05)))
    w2 = float(stars.speed) ** 2
    threshold = BALANCED_RTOL * math.sqrt(float(time.moment_scale) * float(stars.moment_scale)) / w2
    delta = threshold / 0.2
    data = _boxer(x=0.05, unbalances=[{"unbalance": delta, "angle": "0 deg", "axial_position": 0.1},
                                      {"unbalance": delta, "angle": "180 deg", "axial_position": -0.1}])
    _, moment, (cells, _) = _run_and_stars_rows(data, tmp_path, capsys, 1)
    assert (moment[3] is None) == (cells[2] is None), (moment, cells)


# --------------------------------------------------------------------------
# 6. Refusals


def _refusal(tmp_path, capsys, data):
    """The SceneError's problems and `harmbal run -o`'s stderr for a bad scene
    file; the run must exit with status 2 and write nothing."""
    path = _write(tmp_path, "bad.toml", data)
    with pytest.raises(hb.SceneError) as info:
        hb.load_scene(path)
    out = tmp_path / "out.nc"
    assert main(["run", str(path), "-o", str(out)]) == 2
    assert not out.exists()
    err = capsys.readouterr().err
    for problem in info.value.problems:
        assert problem.source == str(path)
        assert f"harmbal: error: {path}: {problem.key} = " in err
    return info.value.problems


def _six(**geometry):
    return {"engine": {"name": "six", "speed": "3000 rpm"},
            "geometry": {"crank_radius": "40 mm", "rod_length": "140 mm", **geometry},
            "piston": {"mass": "0.5 kg"}, "rod": {"mass": "0.4 kg", "cg_from_big_end": "30 mm",
                                                   "inertia": "0.001 kg m^2"},
            "cylinder": [{"throw": f"{60 * i} deg", "axial_position": f"{90 * i} mm"} for i in range(6)]}


@pytest.mark.parametrize("geometry,limit", [
    ({"rod_length": "40 mm"}, "40 mm"),  # λ = 1
    ({"rod_length": "38 mm"}, "40 mm"),  # λ > 1
    ({"pin_offset": "60 mm", "cylinder_offset": "40 mm"}, "140 mm"),  # l = r + |e + h| exactly
    ({"pin_offset": "-300 mm", "cylinder_offset": "199.9 mm"}, "140.1 mm"),  # large offsets, sum just too large
])
def test_impossible_crank_trains_are_refused(tmp_path, capsys, geometry, limit):
    """λ ≥ 1, or offsets that leave the rod unable to reach the pin path at
    some angle: one problem naming the file, geometry.rod_length and the limit
    r + |pin offset + cylinder offset|; `harmbal run` exits with status 2."""
    data = _six(**geometry)
    data["rod"]["cg_from_big_end"] = "10 mm"  # keep the CG on the rod so that only the assembly is wrong
    (problem,) = _refusal(tmp_path, capsys, data)
    assert problem.key == "geometry.rod_length"
    assert "cannot assemble" in problem.rule and limit in problem.rule


def test_largest_allowed_offsets_are_accepted():
    """Just inside the limit (l − r − |e + h| = 1 µm of a 100 mm margin, with
    pin and cylinder offsets of ±0.3 m that nearly cancel) the scene loads."""
    scene = hb.load_scene(_six(pin_offset="-300 mm", cylinder_offset="200.001 mm"))
    assert scene.cylinders[0].offset == pytest.approx(-0.099999, abs=1e-12)  # scale: the ±0.3 m offsets


def test_an_impossible_cylinder_override_names_its_cylinder(tmp_path, capsys):
    """A cylinder whose own rod length is too short is named in the key."""
    data = _six()
    data["cylinder"][3]["geometry"] = {"rod_length": "39 mm"}
    data["rod"]["cg_from_big_end"] = "10 mm"
    (problem,) = _refusal(tmp_path, capsys, data)
    assert problem.key == "cylinder[4].geometry.rod_length" and "cannot assemble" in problem.rule


def test_an_impossible_offset_override_names_its_cylinder(tmp_path, capsys):
    data = _six()
    data["cylinder"][3]["geometry"] = {"pin_offset": "60 mm", "cylinder_offset": "41 mm"}
    (problem,) = _refusal(tmp_path, capsys, data)
    assert "cylinder[4]" in problem.key or "cylinder[4]" in problem.rule, str(problem)


def test_non_finite_and_non_positive_values_are_refused(tmp_path, capsys):
    """NaN and inf, as TOML literals or as quantity strings, and zero or
    negative masses, inertias, unbalances and speeds. All are reported at
    once, each with its key and the rule; `harmbal run` exits with status 2."""
    text = """
[engine]
name = "bad"
speed = ["1 rpm", "-30000 rpm", "inf rpm"]
[geometry]
crank_radius = "40 mm"
rod_length = "140 mm"
pin_offset = "nan mm"
[piston]
mass = "nan kg"
[rod]
mass = 0.0
cg_from_big_end = "30 mm"
inertia = nan
[[cylinder]]
throw = "0 deg"
[[cylinder]]
throw = "180 deg"
axial_position = "90 mm"
geometry = { cylinder_offset = "-inf mm" }
piston = { mass = "-0.5 kg" }
throw_unbalance = { mass = "1e-3 kg", radius = "0 mm" }
[[crankshaft_unbalance]]
unbalance = -inf
"""
    path = tmp_path / "bad.toml"
    path.write_text(text)
    expected = {"engine.speed[2]": "positive", "engine.speed[3]": "finite", "geometry.pin_offset": "finite",
                "piston.mass": "finite", "rod.mass": "positive", "rod.inertia": "finite",
                "cylinder[2].geometry.cylinder_offset": "finite", "cylinder[2].piston.mass": "positive",
                "cylinder[2].throw_unbalance.radius": "positive", "crankshaft_unbalance[1].unbalance": "finite"}
    with pytest.raises(hb.SceneError) as info:
        hb.load_scene(path)
    found = {p.key: p.rule for p in info.value.problems}
    for key, rule in expected.items():
        assert key in found and rule in found[key], (key, found)
    assert all(p.source == str(path) for p in info.value.problems)
    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err
    assert all(f"{path}: {key} = " in err for key in expected)


# --------------------------------------------------------------------------
# 7. Near toggle: no branch flip, momentum, and a warning at the very limit


def _toggle(fraction, lam=0.95, r=0.05, split=0.25):
    """Crank radius, rod length and pin-path offset of a crank train at
    ``fraction`` of the assembly margin, and its condition number
    κ = l²/(l² − (r + |e|)²) (the cancellation in l² − g² at the worst angle)."""
    l = r / lam
    e = fraction * (l - r)
    return r, l, e, l * l / (l * l - (r + abs(e)) ** 2)


@pytest.mark.parametrize("fraction", [0.999, -0.999, 0.99999])
def test_near_toggle_slider_crank_is_single_valued(fraction):
    """λ = 0.95 with the pin path 0.1 % (and 0.001 %) of the margin from the
    limit. The piston pin follows the far branch
    c_B = r cos ψ + √(l² − (e − r sin ψ)²) everywhere, is continuous (no step
    larger than max|c_B'|·Δψ), and its ψ-derivatives and the rod angle's
    match mpmath at 30 digits, including the worst angle ψ = −sign(e)·90°,
    to 2κε of their peak (κ is the condition number of l² − g²)."""
    r, l, e, kappa = _toggle(fraction)
    psi = np.concatenate([np.linspace(0, 2 * np.pi, 4096, endpoint=False), [-np.sign(e) * np.pi / 2]])
    kin = slider_crank(psi, r, l, e)
    closed = r * np.cos(psi) + np.sqrt(l * l - (e - r * np.sin(psi)) ** 2)
    assert np.all(np.isfinite(kin.b)) and np.all(np.isfinite(kin.ddb))
    _close(kin.b, closed, 4 * EPS * l * math.sqrt(kappa))
    assert np.all(kin.b > r * np.cos(psi))  # the far branch: the pin is beyond the crank pin
    step = np.abs(np.diff(kin.b[:4096]))
    assert step.max() <= np.abs(kin.db).max() * 2 * np.pi / 4096 * (1 + 1e-9)
    with mp.workdps(30):
        def travel(t):
            return r * mp.cos(t) + mp.sqrt(l * l - (e - r * mp.sin(t)) ** 2)

        def rod_angle(t):
            return mp.asin((e - r * mp.sin(t)) / l)

        picks = list(range(0, 4096, 257)) + [4096]
        for _name, f, order, got in (("db", travel, 1, kin.db), ("ddb", travel, 2, kin.ddb),
                                     ("drod", rod_angle, 1, kin.drod_angle), ("ddrod", rod_angle, 2, kin.ddrod_angle)):
            want = np.array([float(mp.diff(f, mp.mpf(float(psi[i])), order)) for i in picks])
            _close(got[picks], want, 2 * kappa * EPS * np.abs(want).max())


def _planar_oracle(r, l, e, body, throw, bank, sense, thetas):
    """Force (z, y) and moment x on the block at unit speed of one cylinder,
    from the bodies' positions in the cylinder plane (mpmath derivatives):
    F = −Σ m G'', roll = −Σ (m G × G'') − I ϑ'' + d(KE)/dθ, turned into the
    engine frame by the bank angle."""
    m_p, p_ax, p_lat, m_r, a, q, inertia = body
    fz, fy, mx = [], [], []
    with mp.workdps(30):
        def pin(t):
            c_a, n_a = r * mp.cos(t), r * mp.sin(t)
            c_b = c_a + mp.sqrt(l * l - (e - n_a) ** 2)
            return c_a, n_a, c_b, mp.mpf(e)

        def points(t):
            c_a, n_a, c_b, n_b = pin(t)
            uc, un = (c_b - c_a) / l, (n_b - n_a) / l
            return ((c_b + p_ax, n_b + p_lat), (c_a + a * uc - q * un, n_a + a * un + q * uc), mp.atan2(un, uc))

        for theta in thetas:
            t = mp.mpf(float(theta)) + throw - bank
            derivative = [[mp.diff(lambda s, i=i, j=j: points(s)[i][j], t, n) for n in (0, 1, 2)]
                          for i in (0, 1) for j in (0, 1)]
            angle = [mp.diff(lambda s: points(s)[2], t, n) for n in (1, 2)]
            force_c = force_n = roll = mp.mpf(0)
            for (c, n), mass in zip(((derivative[0], derivative[1]), (derivative[2], derivative[3])), (m_p, m_r)):
                force_c -= mass * c[2]
                force_n -= mass * n[2]
                roll -= mass * (c[0] * n[2] - n[0] * c[2])
                roll += mass * (c[1] * c[2] + n[1] * n[2])
            roll += -inertia * angle[1] + inertia * angle[0] * angle[1]
            w = complex(force_c + 1j * force_n) * complex(mp.exp(1j * bank))
            fz.append(w.real)
            fy.append(-sense * w.imag)
            mx.append(sense * float(roll))
    return np.array(fz), np.array(fy), np.array(mx)


@pytest.mark.parametrize("fraction,rotation", [(0.999, "clockwise"), (-0.999, "counterclockwise")])
def test_near_toggle_momentum(fraction, rotation):
    """One cylinder at λ = 0.95, 0.1 % of the margin from the limit. The pin
    path is written as a pin offset of +0.25 m and a cylinder offset of almost
    −0.25 m. Rigid rod with its CG off the axis, piston CG off the pin, all
    effects. On 64 crank angles, which include the worst one, the force and
    the moment about the crank axis equal the planar momentum oracle to 4κε
    of the peak load (the errors are about 0.6κε)."""
    r, l, e, kappa = _toggle(fraction)
    sense = 1 if rotation == "counterclockwise" else -1
    throw, bank = 0.0, 45 * DEG  # ψ = θ − 45°: the worst ψ = ∓90° falls on the 64-sample grid
    body = (0.45, 0.01, 0.002, 0.5, 0.3 * l, 0.003, 0.0015)
    data = {"engine": {"name": "toggle", "speed": 1.0, "rotation": rotation},
            "model": {"negligible": ZERO_ONLY, "effects": ALL_EFFECTS, "rod": "rigid"},
            "sampling": {"samples_per_rev": 64, "max_order": 8},
            "geometry": {"crank_radius": r, "rod_length": l, "pin_offset": 0.25 + e, "cylinder_offset": -0.25},
            "piston": {"mass": body[0], "cg_offset": [body[1], body[2]]},
            "rod": {"mass": body[3], "cg_from_big_end": body[4], "cg_offset": body[5], "inertia": body[6]},
            "cylinder": [{"throw": throw, "bank": bank}]}
    ds = _quiet(hb.simulate, _quiet(hb.load_scene, data))
    theta = ds.angle.values
    worst = int(np.argmin(np.abs(np.remainder(theta - bank + np.sign(e) * np.pi / 2 + np.pi, 2 * np.pi) - np.pi)))
    assert abs(math.remainder(theta[worst] - bank + np.sign(e) * np.pi / 2, 2 * np.pi)) < 1e-12
    fz, fy, mx = _planar_oracle(r, l, e, body, throw, bank, sense, theta)
    peak_f = float(np.hypot(fz, fy).max())
    _close(ds.force.sel(axis="z"), fz, 4 * kappa * EPS * peak_f)
    _close(ds.force.sel(axis="y"), fy, 4 * kappa * EPS * peak_f)
    _close(ds.moment.sel(axis="x"), mx, 4 * kappa * EPS * float(np.abs(mx).max()))
    assert np.hypot(fz, fy)[worst] > 0.5 * peak_f  # the worst angle is where the load peaks


def test_at_the_very_limit_the_sampling_warns_and_stays_finite():
    """1e-12 of the margin from the limit the harmonics hardly decay: the
    automatic sampling stops at its cap with an AccuracyWarning (not a silent
    loss of accuracy), and every output is still finite."""
    r, l, e, _ = _toggle(1 - 1e-12)
    data = {"engine": {"name": "limit", "speed": "30000 rpm"},
            "model": {"negligible": ZERO_ONLY, "effects": ALL_EFFECTS},
            "geometry": {"crank_radius": r, "rod_length": l, "pin_offset": e},
            "piston": {"mass": 0.5}, "rod": {"mass": 0.4, "cg_from_big_end": 0.3 * l, "inertia": 0.001},
            "cylinder": [{}]}
    scene = hb.load_scene(data)
    with pytest.warns(hb.AccuracyWarning) as caught:
        tree = hb.analyse(scene)
    assert any("65536" in str(w.message) for w in caught)
    assert not _nonfinite(tree)


# --------------------------------------------------------------------------
# 8. Firing with top dead centres a few nanoradians apart


def test_nearly_coincident_tdcs_do_not_crash():
    """Three cylinders whose TDCs are 0, 4e-9 and 2e-9 rad apart (e.g. angles
    written with 9 digits in radians) fire as one: intervals 0, 0 and 360°."""
    data = {"engine": {"name": "tdc", "speed": 100.0, "cycle": 2}, "model": {"rod": "two_point"},
            "geometry": {"crank_radius": 0.05, "rod_length": 0.2}, "piston": {"mass": 1.0},
            "rod": {"mass": 0.5, "cg_from_big_end": 0.05},
            "cylinder": [{"throw": 0.0, "axial_position": 0.0}, {"throw": -4e-9, "axial_position": 0.1},
                         {"throw": -2e-9, "axial_position": 0.2}]}
    tree = hb.analyse(hb.load_scene(data))
    intervals = np.sort(np.degrees(tree["stars"].ds.firing_interval.values))
    np.testing.assert_allclose(intervals, [0, 0, 360], atol=1e-5)
