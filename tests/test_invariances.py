"""Invariances of the exact model (property-based, hypothesis).

Each property is derived here from the conventions (design.md §3), not from
the implementation:

* relabelling / permuting cylinders changes nothing in the totals;
* taking another throw as the angle origin (φ_i → φ_i − Δ, crankshaft
  unbalances α → α − Δ) gives θ' = θ + Δ, s'(θ') = s(θ' − Δ), so
  C'_k = C_k e^{−ikΔ}, P'_co = P_co e^{−ikΔ}, P'_counter = P_counter e^{+ikΔ};
* turning the whole engine by δ about the crank axis (banks, throws,
  crankshaft unbalances and the reference point's (y, z) all turned by δ in the
  direction of rotation) multiplies every transverse vector w = z + i t by
  e^{iδ} and leaves the x components alone;
* all masses, inertias and unbalances times c: every load times c;
* loads scale with ω² exactly (inertia only, constant speed);
* mirror: the counterclockwise engine with the same scene numbers is the
  mirror image (y → −y) of the clockwise one (angles are measured in the
  direction of rotation, and t = −s·y flips with it). Forces are vectors:
  F_y → −F_y. Moments are pseudovectors: M → −R M, R = diag(1, −1, 1), so
  M_x → −M_x, M_y → M_y, M_z → −M_z (reference point mirrored too). In the
  rotating frame w = z + i t, t = −s y: the force w is unchanged and the
  moment w is negated (co stays co, counter stays counter);
* the FFT backend does not matter (numpy, scipy, pyFFTW agree to round-off).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import harmbal as hb

SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
SAMPLES = 96  # λ ≤ 0.4 and small offsets: aliasing ~ρ^88 is far below round-off
MAX_ORDER = 8
EFFECTS = ["reciprocating", "rotating", "rod_inertia", "mass_torque"]


def _f(lo, hi):
    # Within the documented ranges (docs/scenes.md, "Ranges"): hypothesis's 1e-300 near 0 is refused, so 0.
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False).map(lambda v: 0.0 if abs(v) < 1e-12 else v)


@st.composite
def engines(draw, max_cylinders=5):
    """A random engine description (plain SI numbers), cylinders at distinct
    axial positions so that any throw/bank combination is allowed."""
    n = draw(st.integers(1, max_cylinders))
    cylinders = []
    for i in range(n):
        r = draw(_f(0.02, 0.08))
        lam = draw(_f(0.15, 0.4))
        l = r / lam
        cyl = {
            "label": f"c{i + 1}",
            "throw": draw(_f(-math.pi, math.pi)),
            "bank": draw(_f(-1.6, 1.6)),
            "axial_position": 0.1 * i + draw(_f(-0.02, 0.02)),
            "geometry": {"crank_radius": r, "rod_length": l, "pin_offset": draw(_f(-0.003, 0.003)),
                         "cylinder_offset": draw(_f(-0.01, 0.01))},
            "piston": {"mass": draw(_f(0.2, 3.0)), "cg_offset": [draw(_f(-0.02, 0.02)), draw(_f(-0.003, 0.003))]},
            "rod": {"mass": draw(_f(0.2, 2.0)), "cg_from_big_end": draw(_f(0.15, 0.5)) * l,
                    "cg_offset": draw(_f(-0.004, 0.004)), "inertia": draw(_f(0.001, 0.03))},
        }
        if draw(st.booleans()):
            cyl["throw_unbalance"] = [{"unbalance": draw(_f(0.001, 0.08)), "angle": draw(_f(-math.pi, math.pi)),
                                       "axial_offset": draw(_f(-0.03, 0.03))}]
        cylinders.append(cyl)
    crankshaft = []
    if draw(st.booleans()):
        crankshaft = [{"unbalance": draw(_f(0.001, 0.1)), "angle": draw(_f(-math.pi, math.pi)),
                       "axial_position": draw(_f(-0.1, 0.5))}]
    return {
        "engine": {"name": "random", "speed": draw(_f(50.0, 700.0)),
                   "rotation": draw(st.sampled_from(["clockwise", "counterclockwise"])),
                   "reference_point": [draw(_f(-0.2, 0.4)), draw(_f(-0.1, 0.1)), draw(_f(-0.1, 0.1))]},
        "model": {"effects": EFFECTS, "rod": "rigid"},
        "sampling": {"samples_per_rev": SAMPLES, "max_order": MAX_ORDER},
        "cylinder": cylinders,
        "crankshaft_unbalance": crankshaft,
    }


def _copy(data):
    import copy

    return copy.deepcopy(data)


def _run(data, **kwargs):
    ds = hb.simulate(hb.load_scene(data), **kwargs)
    return ds, hb.order_spectrum(ds)


def _wrap(angle):
    return math.remainder(angle, 2 * math.pi)


def _scales(ds):
    """Tolerance scales: the largest total load plus the sum of the single
    bodies' peak loads (the size of what is being added up)."""
    f = float(np.abs(ds.force).max()) + float(ds.force_scale.max())
    m = float(np.abs(ds.moment).max()) + float(ds.moment_scale.max())
    return f, m


def _close(a, b, scale, rtol=1e-12):
    np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=0, atol=rtol * scale)


# --------------------------------------------------------------------------


@SETTINGS
@given(engines(), st.randoms(use_true_random=False))
def test_permuting_cylinders_changes_nothing(data, rnd):
    ds, orders = _run(data, per_cylinder=True)
    permuted = _copy(data)
    rnd.shuffle(permuted["cylinder"])
    ds2, orders2 = _run(permuted, per_cylinder=True)
    fs, ms = _scales(ds)
    _close(ds2.force, ds.force, fs)
    _close(ds2.moment, ds.moment, ms)
    _close(orders2.force, orders.force, fs)
    _close(orders2.moment_rotating, orders.moment_rotating, ms)
    # each cylinder's own contribution travels with its label
    labels = list(ds.cylinder.values)
    _close(ds2.force_cylinder.sel(cylinder=labels), ds.force_cylinder, fs, 1e-14)
    _close(ds2.moment_cylinder.sel(cylinder=labels), ds.moment_cylinder, ms, 1e-14)
    # and the totals are the sums of the parts (no crankshaft unbalance here)
    if not data["crankshaft_unbalance"]:
        _close(ds.force_cylinder.sum("cylinder"), ds.force, fs)
        _close(ds.moment_cylinder.sum("cylinder"), ds.moment, ms)


@SETTINGS
@given(engines(), st.integers(0, 4))
def test_shifting_the_angle_origin(data, pick):
    ds, orders = _run(data)
    j = pick % len(data["cylinder"])
    delta = data["cylinder"][j]["throw"]
    shifted = _copy(data)
    for cyl in shifted["cylinder"]:
        cyl["throw"] = _wrap(cyl["throw"] - delta)
    for ub in shifted["crankshaft_unbalance"]:
        ub["angle"] = _wrap(ub["angle"] - delta)
    ds2, orders2 = _run(shifted)
    fs, ms = _scales(ds)
    k = orders.order.values
    turn = np.exp(-1j * k * delta)
    _close(orders2.force, orders.force * turn[:, None], fs)
    _close(orders2.moment, orders.moment * turn[:, None], ms)
    co, counter = orders.force_rotating.sel(rotation="co"), orders.force_rotating.sel(rotation="counter")
    _close(orders2.force_rotating.sel(rotation="co"), co * turn, fs)
    _close(orders2.force_rotating.sel(rotation="counter"), counter * np.conj(turn), fs)
    co, counter = orders.moment_rotating.sel(rotation="co"), orders.moment_rotating.sel(rotation="counter")
    _close(orders2.moment_rotating.sel(rotation="co"), co * turn, ms)
    _close(orders2.moment_rotating.sel(rotation="counter"), counter * np.conj(turn), ms)


def test_shift_by_whole_samples_rolls_the_time_domain():
    """With Δ a multiple of 2π/N the shifted time series is the old one rolled
    by Δ/(2π/N) samples: s'(θ'_j) = s(θ'_j − Δ)."""
    data = {
        "engine": {"name": "roll", "speed": 300.0, "rotation": "clockwise", "reference_point": [0.05, 0.01, -0.02]},
        "model": {"effects": EFFECTS, "rod": "rigid"},
        "sampling": {"samples_per_rev": 72, "max_order": 8},
        "geometry": {"crank_radius": 0.05, "rod_length": 0.16, "pin_offset": 0.001},
        "piston": {"mass": 0.9, "cg_offset": [0.01, 0.002]},
        "rod": {"mass": 0.7, "cg_from_big_end": 0.05, "inertia": 0.004, "cg_offset": 0.002},
        "cylinder": [{"throw": "0 deg", "bank": "-30 deg", "axial_position": 0.0},
                     {"throw": "100 deg", "bank": "30 deg", "axial_position": 0.1},
                     {"throw": "250 deg", "bank": "-30 deg", "axial_position": 0.2}],
        "crankshaft_unbalance": [{"unbalance": 0.02, "angle": "40 deg", "axial_position": 0.25}],
    }
    shifted = _copy(data)
    delta_deg = 100
    shifted["cylinder"] = [dict(c, throw=f"{int(c['throw'].split()[0]) - delta_deg} deg") for c in data["cylinder"]]
    shifted["crankshaft_unbalance"][0]["angle"] = f"{40 - delta_deg} deg"
    ds, _ = _run(data)
    ds2, _ = _run(shifted)
    steps = delta_deg // 5  # 72 samples: 5° each
    fs, ms = _scales(ds)
    _close(ds2.force.values, np.roll(ds.force.values, steps, axis=-1), fs)
    _close(ds2.moment.values, np.roll(ds.moment.values, steps, axis=-1), ms)


@SETTINGS
@given(engines(), _f(-math.pi, math.pi))
def test_turning_the_engine_about_the_crank_axis(data, delta):
    ds, orders = _run(data)
    turned = _copy(data)
    for cyl in turned["cylinder"]:
        cyl["throw"] = _wrap(cyl["throw"] + delta)
        cyl["bank"] = _wrap(cyl["bank"] + delta)
    for ub in turned["crankshaft_unbalance"]:
        ub["angle"] = _wrap(ub["angle"] + delta)
    sense = 1 if data["engine"]["rotation"] == "counterclockwise" else -1
    px, py, pz = data["engine"]["reference_point"]
    w = (pz + 1j * (-sense * py)) * np.exp(1j * delta)  # the reference point turns with the engine
    turned["engine"]["reference_point"] = [px, -sense * w.imag, w.real]
    ds2, orders2 = _run(turned)
    fs, ms = _scales(ds)
    # time domain, sample by sample (θ is unchanged: the pins keep their ψ)
    for name, scale in (("force", fs), ("moment", ms)):
        a, b = ds[name], ds2[name]
        _close(b.sel(axis="x"), a.sel(axis="x"), scale)
        wa = a.sel(axis="z").values + 1j * (-sense * a.sel(axis="y").values)
        wb = b.sel(axis="z").values + 1j * (-sense * b.sel(axis="y").values)
        _close(wb, wa * np.exp(1j * delta), scale)
        rot = orders[f"{name}_rotating"].values
        _close(orders2[f"{name}_rotating"].values, rot * np.exp(1j * delta), scale)


@SETTINGS
@given(engines(), _f(0.01, 100.0))
def test_scaling_all_masses(data, c):
    ds, orders = _run(data)
    heavy = _copy(data)
    for cyl in heavy["cylinder"]:
        cyl["piston"]["mass"] *= c
        cyl["rod"]["mass"] *= c
        cyl["rod"]["inertia"] *= c
        for ub in cyl.get("throw_unbalance", []):
            ub["unbalance"] *= c
    for ub in heavy["crankshaft_unbalance"]:
        ub["unbalance"] *= c
    ds2, orders2 = _run(heavy)
    fs, ms = _scales(ds)
    _close(ds2.force, c * ds.force, c * fs)
    _close(ds2.moment, c * ds.moment, c * ms)
    _close(orders2.force_rotating, c * orders.force_rotating, c * fs)
    _close(orders2.moment, c * orders.moment, c * ms)


@SETTINGS
@given(engines(max_cylinders=3), _f(10.0, 1500.0), _f(10.0, 1500.0))
def test_omega_squared_scaling(data, w1, w2):
    if abs(w1 - w2) < 1e-6 * w1:
        w2 = 2 * w1
    single = _copy(data)
    single["engine"]["speed"] = w1
    ds1, orders1 = _run(single)
    several = _copy(data)
    several["engine"]["speed"] = [w1, w2]
    ds, orders = _run(several)
    fs, ms = _scales(ds1)
    ratio = (w2 / w1) ** 2
    assert ds.sizes["speed"] == 2
    _close(ds.force.isel(speed=0), ds1.force, fs)
    _close(ds.moment.isel(speed=0), ds1.moment, ms)
    _close(ds.force.isel(speed=1), ratio * ds1.force, ratio * fs)
    _close(ds.moment.isel(speed=1), ratio * ds1.moment, ratio * ms)
    _close(orders.force.isel(speed=1), ratio * orders1.force, ratio * fs)
    _close(orders.moment_rotating.isel(speed=1), ratio * orders1.moment_rotating, ratio * ms)
    np.testing.assert_allclose(ds.rpm.values, np.array([w1, w2]) * 30 / math.pi, rtol=1e-15)


@SETTINGS
@given(engines())
def test_mirror_clockwise_counterclockwise(data):
    cw = _copy(data)
    cw["engine"]["rotation"] = "clockwise"
    ccw = _copy(data)
    ccw["engine"]["rotation"] = "counterclockwise"
    px, py, pz = data["engine"]["reference_point"]
    ccw["engine"]["reference_point"] = [px, -py, pz]
    ds1, orders1 = _run(cw)
    ds2, orders2 = _run(ccw)
    fs, ms = _scales(ds1)
    flip_f = np.array([1, -1, 1])[:, None]
    flip_m = np.array([-1, 1, -1])[:, None]
    _close(ds2.force.transpose("axis", "angle"), flip_f * ds1.force.transpose("axis", "angle"), fs)
    _close(ds2.moment.transpose("axis", "angle"), flip_m * ds1.moment.transpose("axis", "angle"), ms)
    _close(orders2.force.transpose("axis", "order"), flip_f * orders1.force.transpose("axis", "order"), fs)
    _close(orders2.moment.transpose("axis", "order"), flip_m * orders1.moment.transpose("axis", "order"), ms)
    _close(orders2.force_rotating, orders1.force_rotating, fs)
    _close(orders2.moment_rotating, -orders1.moment_rotating, ms)
    # amplitudes per axis are the same
    _close(np.abs(orders2.moment), np.abs(orders1.moment), ms)


# --------------------------------------------------------------------------
# FFT backends


@settings(max_examples=15, deadline=None)
@given(engines())
def test_fft_backends_agree(data):
    ds = hb.simulate(hb.load_scene(data))
    fs, ms = _scales(ds)
    scipy_ = hb.order_spectrum(ds, backend="scipy")
    numpy_ = hb.order_spectrum(ds, backend="numpy")
    for name, scale in (("force", fs), ("moment", ms)):
        for var in (name, f"{name}_rotating"):
            _close(numpy_[var], scipy_[var], scale, 1e-13)
    assert numpy_.attrs["fft_backend"] == "numpy"


def test_pyfftw_backend_agrees():
    pytest.importorskip("pyfftw")
    data = {
        "engine": {"name": "fftw", "speed": "3000 rpm", "reference_point": [0.1, 0.0, 0.0]},
        "geometry": {"crank_radius": "40 mm", "rod_length": "140 mm", "pin_offset": "0.8 mm"},
        "piston": {"mass": "0.45 kg"},
        "rod": {"mass": "0.5 kg", "cg_from_big_end": "40 mm", "inertia": "0.0021 kg m^2", "cg_offset": "1 mm"},
        "cylinder": [{"throw": "0 deg", "axial_position": 0.0}, {"throw": "180 deg", "axial_position": 0.09},
                     {"throw": "180 deg", "axial_position": 0.18}, {"throw": "0 deg", "axial_position": 0.27}],
    }
    ds = hb.simulate(hb.load_scene(data))
    fs, ms = _scales(ds)
    ref = hb.order_spectrum(ds, backend="scipy")
    got = hb.order_spectrum(ds, backend="pyfftw")
    for name, scale in (("force", fs), ("moment", ms)):
        for var in (name, f"{name}_rotating", f"aliasing_error_{name}"):
            _close(got[var], ref[var], scale, 1e-13)


def test_unknown_backend_is_refused():
    ds = hb.simulate(hb.load_scene({
        "engine": {"name": "x", "speed": 100.0},
        "geometry": {"crank_radius": 0.05, "rod_length": 0.2},
        "piston": {"mass": 1.0}, "rod": {"mass": 1.0, "cg_from_big_end": 0.05, "inertia": 0.01},
        "cylinder": [{}],
    }))
    with pytest.raises(ValueError, match="backend"):
        hb.order_spectrum(ds, backend="fftpack")
