"""Physics oracles for the exact time-domain model and its order spectrum.

Every expected value here is derived independently of :mod:`harmbal`:

* piston-acceleration harmonics by mpmath quadrature (34 digits) of a closed-form
  acceleration written below, and the λ-series written out by hand;
* a three-dimensional rigid-body oracle (positions of every body as functions of
  the crank angle, written in global vectors, differentiated by central
  differences at 50 digits) for momentum, angular momentum and the drive
  torque d(KE)/dθ·ω²;
* closed forms for the classic layouts (inline three, inline four, cross-plane
  V8, V-twin on a common pin) and for reference engine B.

Conventions used by the oracles (design.md §3, stated here so that a failure can
be read without the implementation): x along the crank axis to the front, y to
the right seen from the front, z up. s = +1 if the crank turns counterclockwise
seen from the front (about +x), −1 if clockwise; e_ω = s·e_x. The transverse
direction "ahead of +z in the direction of rotation" is e_t = −s·e_y. A
cylinder's axis is c = cos β e_z + sin β e_t, and n = −sin β e_z + cos β e_t is
90° ahead of it (c × n = e_ω). The crank pin of a throw φ is at angle θ + φ from
+z in the direction of rotation. Order phasors: s(θ) = Σ Re(C_k e^{ikθ}); the
transverse vector w = F_z + i·F_t = P_co e^{ikθ} + P_counter e^{−ikθ}.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path

import mpmath as mp
import numpy as np
import pytest

import harmbal as hb

ROOT = Path(__file__).resolve().parent.parent

# --------------------------------------------------------------------------
# Independent helpers


@functools.lru_cache(maxsize=None)
def piston_harmonics(lam: str, kmax: int = 12) -> tuple[float, ...]:
    """A_0 … A_kmax of −x''(θ)/r = Σ A_k cos kθ for a centric slider-crank,
    x(θ) = r cos θ + sqrt(l² − r² sin² θ), by mpmath quadrature.

    Closed-form second derivative (derived by hand, checked against mp.diff in
    ``test_own_acceleration_formula``):
        x'' = −r cos θ − r² cos 2θ / u − r⁴ sin²θ cos²θ / u³,  u = sqrt(l² − r² sin²θ).
    """
    with mp.workdps(30):
        lam_ = mp.mpf(lam)
        l = 1 / lam_  # r = 1

        def minus_acc(t):
            u = mp.sqrt(l * l - mp.sin(t) ** 2)
            return mp.cos(t) + mp.cos(2 * t) / u + (mp.sin(t) * mp.cos(t)) ** 2 / u**3

        nodes = mp.linspace(0, 2 * mp.pi, 5)
        out = []
        for k in range(kmax + 1):
            integral = mp.quad(lambda t: minus_acc(t) * mp.cos(k * t), nodes)  # noqa: B023 (integrated at once)
            out.append(float(integral / (2 * mp.pi if k == 0 else mp.pi)))
        return tuple(out)


def _scene(cylinders, *, effects=("reciprocating",), rod="two_point", piston="exact", harmonics=None,
           speed=100.0, rotation="clockwise", reference=(0.0, 0.0, 0.0), sampling=None, crankshaft=()):
    model = {"effects": list(effects), "rod": rod, "piston": piston}
    if harmonics is not None:
        model["series_harmonics"] = harmonics
    data = {
        "engine": {"name": "oracle", "speed": speed, "rotation": rotation, "reference_point": list(reference)},
        "model": model,
        "cylinder": cylinders,
    }
    if sampling:
        data["sampling"] = sampling
    if crankshaft:
        data["crankshaft_unbalance"] = list(crankshaft)
    return hb.load_scene(data)


def _cyl(*, r, l, mp_, rod_m=1e-3, rod_a=None, rod_I=None, throw=0.0, bank=0.0, x=0.0, e=0.0, h=0.0,
         p_cg=(0.0, 0.0), rod_q=0.0, unbalances=(), label=None):
    """A scene cylinder table (plain SI numbers)."""
    rod = {"mass": rod_m, "cg_from_big_end": l / 3 if rod_a is None else rod_a}
    if rod_I is not None:
        rod["inertia"] = rod_I
    if rod_q:
        rod["cg_offset"] = rod_q
    entry = {
        "throw": throw, "bank": bank, "axial_position": x,
        "geometry": {"crank_radius": r, "rod_length": l, "pin_offset": e, "cylinder_offset": h},
        "piston": {"mass": mp_, "cg_offset": list(p_cg)},
        "rod": rod,
    }
    if unbalances:
        entry["throw_unbalance"] = [{"unbalance": u, "angle": a, "axial_offset": dx} for u, a, dx in unbalances]
    if label is not None:
        entry["label"] = label
    return entry


def _rotating_split(Z, T):
    """Co/counter phasors of w = z + i t from the per-order phasors of z and t
    (derived: Re(Z e^{ikθ}) = (Z e^{ikθ} + conj(Z) e^{−ikθ})/2)."""
    return (Z + 1j * T) / 2, (np.conj(Z) + 1j * np.conj(T)) / 2


# --------------------------------------------------------------------------
# 1. Piston-acceleration harmonics of the exact centric slider-crank

LAMBDAS = ["0.2", "0.3", "0.5", "0.7", "0.9"]


def test_own_acceleration_formula():
    """The hand-derived x'' used by the quadrature oracle agrees with mp.diff of x."""
    with mp.workdps(30):
        r, l = mp.mpf("0.06"), mp.mpf("0.215")
        def x(t):
            return r * mp.cos(t) + mp.sqrt(l * l - (r * mp.sin(t)) ** 2)

        for t in (mp.mpf("0.3"), mp.mpf("1.7"), mp.mpf("4.1")):
            u = mp.sqrt(l * l - (r * mp.sin(t)) ** 2)
            mine = -r * mp.cos(t) - r**2 * mp.cos(2 * t) / u - r**4 * (mp.sin(t) * mp.cos(t)) ** 2 / u**3
            assert abs(mine - mp.diff(x, t, 2)) < mp.mpf("1e-25")
        # at TDC the piston decelerates towards the crank: x''(0) = −r(1 + λ)
        assert abs(mp.diff(x, 0, 2) + r * (1 + r / l)) < mp.mpf("1e-25")


@pytest.mark.slow
def test_piston_harmonics_oracle_is_sane():
    """A_1 = 1, odd orders above 1 vanish, mean zero, and A_2, A_4, A_6 follow
    the λ-series at small λ."""
    for lam in LAMBDAS:
        a = piston_harmonics(lam)
        assert a[1] == pytest.approx(1.0, abs=1e-15)  # scale: 1; mpmath at 30 digits, rounded once
        assert max(abs(a[k]) for k in (0, 3, 5, 7, 9, 11)) < 1e-15
    # at λ = 0.1 the first omitted terms are O(λ²) smaller than the last kept one
    lam = 0.1
    a = piston_harmonics("0.1")
    assert a[2] == pytest.approx(lam + lam**3 / 4 + 15 * lam**5 / 128, rel=1e-6)
    assert a[2] - (lam + lam**3 / 4) == pytest.approx(15 * lam**5 / 128, rel=2e-2)
    assert -a[4] == pytest.approx(lam**3 / 4 + 3 * lam**5 / 16, rel=1e-4)
    assert -a[4] - lam**3 / 4 == pytest.approx(3 * lam**5 / 16, rel=2e-2)
    assert a[6] == pytest.approx(9 * lam**5 / 128, rel=3e-2)


@pytest.mark.slow
@pytest.mark.parametrize("rod_model", ["two_point", "rigid"])
@pytest.mark.parametrize("lam", LAMBDAS)
def test_exact_piston_harmonics(lam, rod_model):
    """Single centric cylinder, reciprocating only: order-k z-force phasor is
    m_rec·r·ω²·A_k (real), with m_rec = m_piston + m_rod·a/l; nothing in x, y."""
    r = 0.05
    l = r / float(lam)
    m_p, m_rod, a = 1.3, 0.9, 0.37 * l
    omega = 314.0
    cyl = _cyl(r=r, l=l, mp_=m_p, rod_m=m_rod, rod_a=a, rod_I=0.01)
    scene = _scene([cyl], rod=rod_model, speed=omega)
    orders = hb.order_spectrum(hb.simulate(scene))
    scale = (m_p + m_rod * a / l) * r * omega**2
    expected = scale * np.array(piston_harmonics(lam))
    fz = orders.force.sel(axis="z").values
    np.testing.assert_allclose(fz, expected, rtol=0, atol=1e-12 * scale)
    assert np.max(np.abs(orders.force.sel(axis=["x", "y"]).values)) <= 1e-12 * scale
    # the rotating split of a force along +z: half co, half counter, both real
    rot = orders.force_rotating.values
    np.testing.assert_allclose(rot[1:, 0], expected[1:] / 2, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(rot[1:, 1], expected[1:] / 2, rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("lam,e_over_r", [(0.3, 0.1), (0.5, -0.2), (0.25, 0.02)])
def test_offset_piston_harmonics(lam, e_over_r):
    """Pin offset e: odd orders appear. Oracle without any differentiation
    formula: C_k(F_z) = −m ω² C_k(x'') = m ω² k² X_k, with X_k the Fourier
    coefficient of the pin travel x(θ) = r cos θ + sqrt(l² − (e − r sin θ)²)
    (e towards +n, 90° ahead of the cylinder axis), by mpmath quadrature."""
    r = 0.05
    l, e = r / lam, e_over_r * r
    m, omega = 1.1, 250.0
    kmax = 8
    with mp.workdps(25):
        def x(t):
            return r * mp.cos(t) + mp.sqrt(l * l - (e - r * mp.sin(t)) ** 2)

        nodes = mp.linspace(0, 2 * mp.pi, 5)
        # each integrand is integrated at once, with its own k (B023)
        X = [complex(mp.quad(lambda t: x(t) * mp.cos(k * t), nodes) / mp.pi  # noqa: B023
                     - 1j * mp.quad(lambda t: x(t) * mp.sin(k * t), nodes) / mp.pi) for k in range(kmax + 1)]  # noqa: B023
    expected = m * omega**2 * np.arange(kmax + 1) ** 2 * np.array(X)
    for rotation in ("clockwise", "counterclockwise"):
        scene = _scene([_cyl(r=r, l=l, mp_=m, rod_m=1e-3, rod_a=0.0, e=e)], speed=omega, rotation=rotation,
                       sampling={"max_order": kmax})
        fz = hb.order_spectrum(hb.simulate(scene)).force.sel(axis="z").values
        scale = m * r * omega**2
        np.testing.assert_allclose(fz, expected, rtol=0, atol=1e-12 * scale)
        assert abs(fz[3]) > 1e-4 * scale  # odd orders are really there


@pytest.mark.parametrize("lam,samples", [("0.5", 16), ("0.5", 24), ("0.9", 24), ("0.9", 32), ("0.9", 48)])
def test_aliasing_estimate_bounds_the_true_error(lam, samples):
    """With deliberately coarse sampling the reported estimate bounds the true
    error of every order kept (true values from quadrature), and is realistic:
    within a factor 10 of it."""
    r = 0.05
    l = r / float(lam)
    omega = 100.0
    kmax = samples // 4
    scene = _scene([_cyl(r=r, l=l, mp_=1.0, rod_m=1e-3, rod_a=0.0)], speed=omega,
                   sampling={"samples_per_rev": samples, "max_order": kmax})
    orders = hb.order_spectrum(hb.simulate(scene))
    scale = r * omega**2
    true_error = np.abs(orders.force.sel(axis="z").values - scale * np.array(piston_harmonics(lam)[: kmax + 1]))
    estimate = orders.aliasing_error_force.sel(axis="z").item()
    assert true_error.max() > 1e-11 * scale  # the coarse sampling does alias
    assert true_error.max() <= estimate <= 10 * true_error.max()


def test_block_force_at_tdc_points_up():
    """Time domain, sign: at θ = 0 the piston decelerates (acceleration towards
    the crank, −z) so the block is pushed +z with m r ω² (1 + λ)."""
    r, l, m = 0.06, 0.2, 2.0
    scene = _scene([_cyl(r=r, l=l, mp_=m, rod_m=1e-6)], speed=50.0)
    ds = hb.simulate(scene)
    m_rec = m + 1e-6 / 3
    f0 = ds.force.sel(axis="z").isel(angle=0).item()
    assert f0 == pytest.approx(m_rec * r * 50.0**2 * (1 + r / l), rel=1e-13)


# --------------------------------------------------------------------------
# 2. Series model


@pytest.mark.parametrize("lam", [0.2, 0.28, 0.45])
def test_series_two_harmonics(lam):
    r = 0.04
    l = r / lam
    m_p, m_rod, a = 0.8, 0.5, 0.3 * l
    omega = 200.0
    scene = _scene([_cyl(r=r, l=l, mp_=m_p, rod_m=m_rod, rod_a=a)], piston="series", harmonics=2, speed=omega)
    fz = hb.order_spectrum(hb.simulate(scene)).force.sel(axis="z").values
    scale = (m_p + m_rod * a / l) * r * omega**2
    expected = np.zeros_like(fz)
    expected[1], expected[2] = scale, scale * lam
    np.testing.assert_allclose(fz, expected, rtol=0, atol=1e-13 * scale)


@pytest.mark.parametrize("e_over_l", [0.01, -0.03])
def test_series_two_harmonics_with_offset(e_over_l):
    """N = 2 with g = e − r sin θ: S ≈ l − g²/(2l), so
    x'' = −r cos θ − (e r/l) sin θ − (r²/l) cos 2θ and C_1 = m r ω² (1 − i e/l),
    C_2 = m r ω² λ, nothing else."""
    r, lam = 0.04, 0.3
    l = r / lam
    e = e_over_l * l
    omega = 200.0
    scene = _scene([_cyl(r=r, l=l, mp_=1.0, rod_m=1e-3, rod_a=0.0, e=e)], piston="series", harmonics=2, speed=omega)
    fz = hb.order_spectrum(hb.simulate(scene)).force.sel(axis="z").values
    scale = r * omega**2
    expected = np.zeros_like(fz)
    expected[1], expected[2] = scale * (1 - 1j * e / l), scale * lam
    np.testing.assert_allclose(fz, expected, rtol=0, atol=1e-13 * scale)


@pytest.mark.parametrize("lam", [0.2, 0.28, 0.45])
def test_series_four_harmonics(lam):
    """S = l(1 − u/2 − u²/8), u = λ² sin²θ, sin⁴θ = (3 − 4 cos 2θ + cos 4θ)/8:
    A_2 = λ + λ³/4, A_4 = −λ³/4, nothing else."""
    r = 0.04
    l = r / lam
    omega = 200.0
    scene = _scene([_cyl(r=r, l=l, mp_=1.0, rod_m=1e-3, rod_a=0.0)], piston="series", harmonics=4, speed=omega)
    fz = hb.order_spectrum(hb.simulate(scene)).force.sel(axis="z").values
    scale = 1.0 * r * omega**2
    expected = np.zeros_like(fz)
    expected[1], expected[2], expected[4] = scale, scale * (lam + lam**3 / 4), -scale * lam**3 / 4
    np.testing.assert_allclose(fz, expected, rtol=0, atol=1e-13 * scale)


# --------------------------------------------------------------------------
# 3. Reference engine B (single-cylinder test engine, 2300 rpm)

B_OMEGA = 2300 * math.pi / 30
B_R, B_L = 0.060, 0.215
B_M_REC = 2.229 + 2.726 * 72.255 / 215
B_M_ROT = (2.726 - 2.726 * 72.255 / 215) + 12.782 * 8.047 / 60


def _engine_b(effects):
    return hb.load_scene({
        "engine": {"name": "test-single", "speed": "2300 rpm"},
        "model": {"effects": effects, "rod": "two_point", "piston": "series", "series_harmonics": 2},
        "geometry": {"crank_radius": "60 mm", "rod_length": "215 mm", "pin_offset": 0},
        "piston": {"mass": "2.229 kg"},
        "rod": {"mass": "2.726 kg", "cg_from_big_end": "72.255 mm"},
        "crankshaft_unbalance": {"mass": "12.782 kg", "radius": "8.047 mm", "axial_position": "92.01 mm"},
        "cylinder": [{"axial_position": "86 mm"}],
    })


def test_engine_b_reciprocating():
    orders = hb.order_spectrum(hb.simulate(_engine_b(["reciprocating"])))
    f1 = abs(orders.force.sel(axis="z", order=1).item())
    f2 = abs(orders.force.sel(axis="z", order=2).item())
    first = B_M_REC * B_R * B_OMEGA**2
    assert f1 == pytest.approx(first, rel=1e-12)
    assert f2 == pytest.approx(first * B_R / B_L, rel=1e-12)
    # the thesis's published values (10 947 N; 3 054 N, which it computed with
    # the rounded λ = 0.279, whereas 60/215 = 0.27907 gives 3 055.03 N)
    assert abs(f1 - 10947) < 1.0
    assert abs(f2 - 3054) < 1.5
    assert abs(first * 0.279 - 3054) < 1.0


def test_engine_b_rotating():
    orders = hb.order_spectrum(hb.simulate(_engine_b(["rotating"])))
    rot = orders.force_rotating.sel(order=1).values
    expected = B_M_ROT * B_R * B_OMEGA**2  # 12 266.45 N with the text's masses
    assert abs(rot[0]) == pytest.approx(expected, rel=1e-12)
    assert abs(rot[1]) < 1e-12 * expected
    # thesis: 12 265 N from its rounded rotating mass (3.524 kg -> 12 265.9 N)
    assert abs(abs(rot[0]) - 12265) < 2.0
    # the centrifugal force of an unbalance at θ = 0 points +z (towards the pin)
    ds = hb.simulate(_engine_b(["rotating"]))
    assert ds.force.sel(axis="z").isel(angle=0).item() == pytest.approx(expected, rel=1e-13)


# --------------------------------------------------------------------------
# 3-D rigid-body oracle (used by tests 4 and 5)


@dataclass
class OCyl:
    throw: float
    bank: float
    x: float
    r: float
    l: float
    e: float
    h: float
    m_p: float
    p_cg: tuple[float, float]
    rod_m: float
    rod_a: float
    rod_q: float
    rod_I: float
    unbalances: list = field(default_factory=list)  # (U, angle rel. throw, axial offset)

    def table(self):
        return _cyl(r=self.r, l=self.l, mp_=self.m_p, rod_m=self.rod_m, rod_a=self.rod_a, rod_I=self.rod_I,
                    throw=self.throw, bank=self.bank, x=self.x, e=self.e, h=self.h, p_cg=self.p_cg,
                    rod_q=self.rod_q, unbalances=self.unbalances)


def _add(*vs):
    return tuple(sum(c) for c in zip(*vs))


def _mul(k, v):
    return tuple(k * c for c in v)


def _dot(u, v):
    return sum(a * b for a, b in zip(u, v))


def _cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _bodies(cyls, crankshaft, sense, rod_model, theta):
    """All moving bodies at crank angle θ (mpf): list of
    (mass, position vector, rotation angle about e_ω or None, inertia)."""
    s = mp.mpf(sense)
    ex, ez, et, ew = (1, 0, 0), (0, 0, 1), (0, -s, 0), (s, 0, 0)
    out = []
    for cy in cyls:
        beta = mp.mpf(cy.bank)
        c = _add(_mul(mp.cos(beta), ez), _mul(mp.sin(beta), et))
        n = _add(_mul(-mp.sin(beta), ez), _mul(mp.cos(beta), et))
        ang = theta + mp.mpf(cy.throw)
        X = mp.mpf(cy.x)
        A = _add(_mul(X, ex), _mul(cy.r * mp.cos(ang), ez), _mul(cy.r * mp.sin(ang), et))
        offset = mp.mpf(cy.e) + mp.mpf(cy.h)
        # piston pin B on the line {X e_x + b c + offset n}, at distance l from A
        b = _dot(A, c) + mp.sqrt(mp.mpf(cy.l) ** 2 - (offset - _dot(A, n)) ** 2)
        B = _add(_mul(X, ex), _mul(b, c), _mul(offset, n))
        out.append((mp.mpf(cy.m_p), _add(B, _mul(cy.p_cg[0], c), _mul(cy.p_cg[1], n)), None, 0))
        u = _mul(1 / mp.mpf(cy.l), _add(B, _mul(-1, A)))
        if rod_model == "rigid":
            w = _cross(ew, u)
            G = _add(A, _mul(cy.rod_a, u), _mul(cy.rod_q, w))
            out.append((mp.mpf(cy.rod_m), G, mp.atan2(_dot(u, n), _dot(u, c)), mp.mpf(cy.rod_I)))
        else:
            small = mp.mpf(cy.rod_m) * cy.rod_a / mp.mpf(cy.l)
            out.append((mp.mpf(cy.rod_m) - small, A, None, 0))
            out.append((small, B, None, 0))
        for U, alpha, dx in cy.unbalances:  # a unit point mass at radius U
            a2 = ang + mp.mpf(alpha)
            out.append((mp.mpf(1), _add(_mul(X + mp.mpf(dx), ex), _mul(U * mp.cos(a2), ez), _mul(U * mp.sin(a2), et)),
                        None, 0))
    for U, alpha, xu in crankshaft:
        a2 = theta + mp.mpf(alpha)
        out.append((mp.mpf(1), _add(_mul(mp.mpf(xu), ex), _mul(U * mp.cos(a2), ez), _mul(U * mp.sin(a2), et)),
                    None, 0))
    return out


def rigid_body_oracle(cyls, crankshaft, sense, rod_model, reference, omega, thetas, mass_torque=True):
    """Force and moment on the block from momentum and angular momentum:
    F = −Σ m a_G, M_P = −Σ (r_G − P) × m a_G − Σ I ϑ̈ e_ω + T e_ω with
    T = d(KE)/dt / ω = ω²·d(KE₁)/dθ (KE₁ at unit speed). Derivatives by central
    differences at 50 digits (h = 1e-16: truncation ~1e-32, round-off ~1e-18).
    Returns float arrays (3, angle) and the per-angle sums of body load
    magnitudes (for tolerances)."""
    F, M, fscale, mscale = [], [], [], []
    with mp.workdps(50):
        h = mp.mpf("1e-16")
        P = tuple(mp.mpf(p) for p in reference)
        ew = (mp.mpf(sense), 0, 0)
        w2 = mp.mpf(omega) ** 2
        for th in thetas:
            th = mp.mpf(th)
            lo, mid, hi = (_bodies(cyls, crankshaft, sense, rod_model, th + d) for d in (-h, 0, h))
            f = (0, 0, 0)
            m = (0, 0, 0)
            fs = ms = 0
            for (mass, g0, t0, inertia), (_, gm, tm, _), (_, gp, tp, _) in zip(mid, lo, hi):
                v = _mul(1 / (2 * h), _add(gp, _mul(-1, gm)))
                a = _mul(1 / h**2, _add(gp, _mul(-2, g0), gm))
                fb = _mul(-mass * w2, a)
                mb = _cross(_add(g0, _mul(-1, P)), fb)
                power = mass * _dot(v, a)
                if t0 is not None:
                    dt = (tp - tm) / (2 * h)
                    ddt = (tp - 2 * t0 + tm) / h**2
                    mb = _add(mb, _mul(-inertia * ddt * w2, ew))
                    power += inertia * dt * ddt
                if mass_torque:
                    mb = _add(mb, _mul(power * w2, ew))
                f = _add(f, fb)
                m = _add(m, mb)
                fs += mp.sqrt(_dot(fb, fb))
                ms += mp.sqrt(_dot(mb, mb))
            F.append([float(c) for c in f])
            M.append([float(c) for c in m])
            fscale.append(float(fs))
            mscale.append(float(ms))
    return np.array(F).T, np.array(M).T, max(fscale), max(mscale)


def rod_angle_derivatives(cy: OCyl, thetas):
    """ϑ'(θ), ϑ''(θ) of ϑ = asin((e + h − r sin ψ)/l), ψ = θ + φ − β (angle of the
    rod from the cylinder axis towards n), by central differences at 50 digits."""
    d1, d2 = [], []
    with mp.workdps(50):
        h = mp.mpf("1e-16")

        def vartheta(t):
            return mp.asin((mp.mpf(cy.e) + cy.h - cy.r * mp.sin(t + mp.mpf(cy.throw) - cy.bank)) / cy.l)

        for th in thetas:
            th = mp.mpf(th)
            lo, mid, hi = vartheta(th - h), vartheta(th), vartheta(th + h)
            d1.append(float((hi - lo) / (2 * h)))
            d2.append(float((hi - 2 * mid + lo) / h**2))
    return np.array(d1), np.array(d2)


def _random_v_engine(seed, sense):
    """Four-cylinder 'V' on two throws with random geometry, pin and cylinder
    offsets, piston and rod CG offsets, throw and crankshaft unbalances."""
    rng = np.random.default_rng(seed)
    cyls = []
    gamma = rng.uniform(0.5, 1.8)
    throws = [0.0, rng.uniform(0.5, 6.0)]
    for j, throw in enumerate(throws):
        for side in (-1, 1):
            r = rng.uniform(0.03, 0.07)
            l = r / rng.uniform(0.2, 0.45)
            cyls.append(OCyl(
                throw=throw, bank=side * gamma / 2 + rng.uniform(-0.1, 0.1), x=0.1 * j + 0.02 * side,
                r=r, l=l, e=rng.uniform(-0.004, 0.004), h=rng.uniform(-0.01, 0.01),
                m_p=rng.uniform(0.3, 2.0), p_cg=(rng.uniform(-0.01, 0.02), rng.uniform(-0.003, 0.003)),
                rod_m=rng.uniform(0.3, 1.5), rod_a=rng.uniform(0.2, 0.45) * l, rod_q=rng.uniform(-0.004, 0.004),
                rod_I=rng.uniform(0.002, 0.02),
                unbalances=[(rng.uniform(0.005, 0.05), rng.uniform(-3, 3), rng.uniform(-0.03, 0.03))],
            ))
    crankshaft = [(rng.uniform(0.01, 0.1), rng.uniform(-3, 3), rng.uniform(-0.05, 0.2))]
    reference = tuple(rng.uniform(-0.1, 0.1, 3))
    return cyls, crankshaft, reference


def _scene_from(cyls, crankshaft, sense, rod_model, reference, omega, effects, samples):
    return _scene([cy.table() for cy in cyls], effects=effects, rod=rod_model, speed=omega,
                  rotation="counterclockwise" if sense > 0 else "clockwise", reference=reference,
                  sampling={"samples_per_rev": samples, "max_order": 4},
                  crankshaft=[{"unbalance": U, "angle": a, "axial_position": x} for U, a, x in crankshaft])


# --------------------------------------------------------------------------
# 4. Two-point versus rigid rod


@pytest.mark.parametrize("sense", [1, -1])
@pytest.mark.parametrize("with_mass_torque", [False, True])
def test_two_point_versus_rigid_rod(sense, with_mass_torque):
    """Same force and transverse moments; the moment about the crank axis
    differs by the rod-inertia couple −(I − m a (l − a))·ϑ''·ω² along e_ω (and,
    with the mass torque, by its power term (I − m a (l − a))·ϑ'ϑ''·ω²)."""
    omega = 260.0
    cyls = [
        OCyl(throw=0.0, bank=0.3, x=0.05, r=0.045, l=0.15, e=0.002, h=-0.004, m_p=0.7, p_cg=(0.01, 0.001),
             rod_m=0.6, rod_a=0.04, rod_q=0.0, rod_I=0.004),
        OCyl(throw=2.0, bank=-0.5, x=-0.07, r=0.05, l=0.17, e=-0.001, h=0.0, m_p=0.9, p_cg=(0.0, 0.0),
             rod_m=0.8, rod_a=0.05, rod_q=0.0, rod_I=0.0025),  # deficit < 0 for this one
    ]
    effects = ["reciprocating", "rotating", "rod_inertia"] + (["mass_torque"] if with_mass_torque else [])
    reference = (0.02, -0.05, 0.08)

    def run(rod):
        return hb.simulate(_scene_from(cyls, [], sense, rod, reference, omega, effects, 64))

    rigid, split = run("rigid"), run("two_point")
    theta = rigid.angle.values
    fscale = np.abs(rigid.force).max().item()
    np.testing.assert_allclose(rigid.force.values, split.force.values, rtol=0, atol=1e-12 * fscale)
    diff = rigid.moment.values - split.moment.values
    expected = np.zeros_like(diff)
    for cy in cyls:
        d1, d2 = rod_angle_derivatives(cy, theta)
        deficit = cy.rod_I - cy.rod_m * cy.rod_a * (cy.l - cy.rod_a)
        roll = -deficit * d2 * omega**2
        if with_mass_torque:
            roll += deficit * d1 * d2 * omega**2
        expected[0] += sense * roll
    mscale = np.abs(expected).max()
    assert mscale > 1.0  # the effect is not trivially small
    np.testing.assert_allclose(diff, expected, rtol=0, atol=1e-11 * mscale)


# --------------------------------------------------------------------------
# 5. Momentum and angular momentum of a random V engine


@pytest.mark.parametrize("rod_model", ["rigid", "two_point", "two_point_couple"])
@pytest.mark.parametrize("seed,sense", [(1, 1), (2, -1), (3, -1)])
def test_momentum_and_angular_momentum(seed, sense, rod_model):
    """rigid: the full rigid rod with its CG off the axis; two_point: two point
    masses at the pins; two_point_couple with the CG on the axis: the rigid rod
    again (the couple restores the inertia)."""
    cyls, crankshaft, reference = _random_v_engine(seed, sense)
    if rod_model != "rigid":
        for cy in cyls:
            cy.rod_q = 0.0  # a two-point split has its CG on the rod axis
    omega = 300.0
    ds = hb.simulate(_scene_from(cyls, crankshaft, sense, rod_model, reference, omega,
                                 ["reciprocating", "rotating", "rod_inertia", "mass_torque"], 24))
    oracle_model = "two_point" if rod_model == "two_point" else "rigid"
    F, M, fscale, mscale = rigid_body_oracle(cyls, crankshaft, sense, oracle_model, reference, omega,
                                             ds.angle.values)
    np.testing.assert_allclose(ds.force.values, F, rtol=0, atol=1e-12 * fscale)
    np.testing.assert_allclose(ds.moment.values, M, rtol=0, atol=1e-12 * mscale)


@pytest.mark.parametrize("sense", [1, -1])
def test_momentum_without_mass_torque(sense):
    """Leaving out the mass torque removes exactly T·e_ω (rigid rod, one seed)."""
    cyls, crankshaft, reference = _random_v_engine(7, sense)
    omega = 150.0
    ds = hb.simulate(_scene_from(cyls, crankshaft, sense, "rigid", reference, omega,
                                 ["reciprocating", "rotating", "rod_inertia"], 16))
    F, M, fscale, mscale = rigid_body_oracle(cyls, crankshaft, sense, "rigid", reference, omega,
                                             ds.angle.values, mass_torque=False)
    np.testing.assert_allclose(ds.force.values, F, rtol=0, atol=1e-12 * fscale)
    np.testing.assert_allclose(ds.moment.values, M, rtol=0, atol=1e-12 * mscale)


def test_mass_torque_alone_is_dke_dtheta():
    """Single centric cylinder with a massless-ish rod: the mass-torque reaction
    about e_ω is ω²·d/dθ(½ m x'²) with x the piston travel (hand formula)."""
    r, l, m, omega = 0.05, 0.18, 1.5, 120.0
    for sense, rotation in ((1, "counterclockwise"), (-1, "clockwise")):
        scene = _scene([_cyl(r=r, l=l, mp_=m, rod_m=1e-3, rod_a=0.0)], effects=["reciprocating", "mass_torque"],
                       speed=omega, rotation=rotation, sampling={"samples_per_rev": 40})
        ds = hb.simulate(scene)
        t = ds.angle.values
        u = np.sqrt(l * l - (r * np.sin(t)) ** 2)
        x1 = -r * np.sin(t) - r * r * np.sin(t) * np.cos(t) / u
        x2 = -r * np.cos(t) - r * r * np.cos(2 * t) / u - r**4 * (np.sin(t) * np.cos(t)) ** 2 / u**3
        expected = sense * m * x1 * x2 * omega**2
        scale = m * r * r * omega**2
        np.testing.assert_allclose(ds.moment.sel(axis="x").values, expected, rtol=0, atol=1e-13 * scale)


# --------------------------------------------------------------------------
# 6. Classic layouts

LAM = "0.3"
R, L = 0.05, 0.05 / 0.3
M_REC = 1.2  # piston; rod small-end share 1e-3 * a / l with a = 0 below -> exactly 1.2
OMEGA = 400.0
U1 = M_REC * R * OMEGA**2


def _layout(throws_banks_x, *, effects=("reciprocating",), rotation="clockwise", rod_m=1e-3, rod_a=0.0):
    cyls = [_cyl(r=R, l=L, mp_=M_REC, rod_m=rod_m, rod_a=rod_a, throw=math.radians(t), bank=math.radians(b), x=x)
            for t, b, x in throws_banks_x]
    return hb.order_spectrum(hb.simulate(_scene(cyls, effects=effects, rotation=rotation, speed=OMEGA)))


@pytest.mark.parametrize("rotation,sense", [("clockwise", -1), ("counterclockwise", 1)])
def test_inline_three(rotation, sense):
    a = 0.136
    o = _layout([(0, 0, a), (240, 0, 0.0), (120, 0, -a)], rotation=rotation)
    A = piston_harmonics(LAM)
    fz = o.force.sel(axis="z").values
    tol = 1e-12 * 3 * U1
    for k in (1, 2, 3, 4, 5):
        assert abs(fz[k]) < tol, k
    assert fz[6] == pytest.approx(3 * A[6] * U1, abs=tol)
    assert np.max(np.abs(o.force.sel(axis=["x", "y"]).values)) < tol
    # first-order pitching moment: M_y = −Σ x_i F_z,i, C = −U1 Σ x_i e^{iφ_i}
    my1 = o.moment.sel(axis="y", order=1).item()
    expected = -U1 * a * (1 - np.exp(2j * np.pi / 3))
    assert my1 == pytest.approx(expected, abs=1e-12 * U1 * a)
    assert abs(my1) == pytest.approx(math.sqrt(3) * U1 * a, rel=1e-12)
    co, counter = o.moment_rotating.sel(order=1).values
    # w_M = M_z + i M_t with M_t = −s M_y and M_z = 0
    exp_co, exp_counter = _rotating_split(0.0, -sense * expected)
    assert co == pytest.approx(exp_co, abs=1e-12 * U1 * a)
    assert counter == pytest.approx(exp_counter, abs=1e-12 * U1 * a)
    assert abs(co) == pytest.approx(math.sqrt(3) / 2 * U1 * a, rel=1e-12)
    assert abs(counter) == pytest.approx(math.sqrt(3) / 2 * U1 * a, rel=1e-12)
    # orders 2 and 4 pitch too (Σ x e^{ikφ} ≠ 0), order 3 does not (A_3 = 0)
    assert abs(o.moment.sel(axis="y", order=2).item()) == pytest.approx(math.sqrt(3) * A[2] * U1 * a, rel=1e-12)
    assert abs(o.moment.sel(axis="y", order=3).item()) < 1e-12 * U1 * a


def test_inline_four():
    a = 0.09
    o = _layout([(0, 0, 1.5 * a), (180, 0, 0.5 * a), (180, 0, -0.5 * a), (0, 0, -1.5 * a)])
    A = piston_harmonics(LAM)
    fz = o.force.sel(axis="z").values
    tol = 1e-12 * 4 * U1
    expected = np.zeros(13)
    for k in range(2, 13, 2):
        expected[k] = 4 * A[k] * U1
    np.testing.assert_allclose(fz, expected, rtol=0, atol=tol)
    assert fz[2] == pytest.approx(4 * A[2] * U1, rel=1e-13)
    assert np.max(np.abs(o.moment.values)) < 1e-12 * 4 * U1 * a


@pytest.mark.parametrize("rotation,sense", [("clockwise", -1), ("counterclockwise", 1)])
def test_cross_plane_v8(rotation, sense):
    """Banks ±45°, throws 0/90/270/180 on common pins at x = 1.5a … −1.5a.
    Each 90° pair gives a pure co-rotating first-order force m r ω² e^{iφ}; the
    moment is w_M = i·s·x·w_F, so P_co = i s m r ω² Σ x_j e^{iφ_j} = i s m r ω² a (3 + i)."""
    a = 0.1
    xs = [1.5 * a, 0.5 * a, -0.5 * a, -1.5 * a]
    throws = [0, 90, 270, 180]
    layout = [(t, b, x) for t, x in zip(throws, xs) for b in (-45, 45)]
    o = _layout(layout, rotation=rotation)
    co, counter = o.moment_rotating.sel(order=1).values
    expected = 1j * sense * U1 * a * (3 + 1j)
    assert co == pytest.approx(expected, abs=1e-12 * U1 * a)
    assert abs(co) == pytest.approx(math.sqrt(10) * U1 * a, rel=1e-12)
    assert abs(counter) < 1e-12 * U1 * a
    # free forces of orders 1 and 2 and the second-order moment vanish
    for k in (1, 2):
        assert np.max(np.abs(o.force.sel(order=k).values)) < 1e-12 * 8 * U1
    assert np.max(np.abs(o.moment.sel(order=2).values)) < 1e-12 * 8 * U1 * a

    # rotating only: two big ends per pin, U = 2 m_b r, also purely co-rotating
    m_rod, cg = 0.9, 0.3 * L
    o_rot = _layout(layout, effects=("rotating",), rotation=rotation, rod_m=m_rod, rod_a=cg)
    ub = 2 * (m_rod - m_rod * cg / L) * R * OMEGA**2
    co_r, counter_r = o_rot.moment_rotating.sel(order=1).values
    assert co_r == pytest.approx(1j * sense * ub * a * (3 + 1j), abs=1e-12 * ub * a)
    assert abs(counter_r) < 1e-12 * ub * a


GAMMAS = [30, 45, 60, 72, 90, 120, 135, 180]


@pytest.mark.parametrize("gamma", GAMMAS)
@pytest.mark.parametrize("rotation", ["clockwise", "counterclockwise"])
def test_v_twin_common_pin(gamma, rotation):
    """Banks ±γ/2, common throw φ: per order
    P_co = m r ω² A_k e^{ikφ} cos((k − 1)γ/2),  P_counter = m r ω² A_k e^{−ikφ} cos((k + 1)γ/2)."""
    phi = 0.7
    g = math.radians(gamma)
    cyls = [_cyl(r=R, l=L, mp_=M_REC, rod_m=1e-3, rod_a=0.0, throw=phi, bank=side * g / 2) for side in (-1, 1)]
    o = hb.order_spectrum(hb.simulate(_scene(cyls, rotation=rotation, speed=OMEGA)))
    A = np.array(piston_harmonics(LAM))
    k = np.arange(13)
    co = U1 * A * np.exp(1j * k * phi) * np.cos((k - 1) * g / 2)
    counter = U1 * A * np.exp(-1j * k * phi) * np.cos((k + 1) * g / 2)
    got = o.force_rotating.values
    np.testing.assert_allclose(got[1:, 0], co[1:], rtol=0, atol=1e-12 * U1)
    np.testing.assert_allclose(got[1:, 1], counter[1:], rtol=0, atol=1e-12 * U1)


@pytest.mark.parametrize("name", ["tractor-3cyl", "v6-90-split-pin", "lever-single"])
def test_kinetic_energy_derivative_is_the_drive_torque(name):
    """Work–energy: the drive torque that keeps ω constant is d(KE)/dθ (spectral
    derivative of the kinetic energy, exact for the band-limited samples)."""
    from harmbal.model.evaluate import evaluate

    scene = hb.load_scene(ROOT / "datasets" / "engines" / f"{name}.toml")
    unit = evaluate(scene, 512)
    energy, torque = unit.kinetic_energy.sum(axis=0), unit.drive_torque.sum(axis=0)
    k = np.fft.rfftfreq(512, 1 / 512)
    derivative = np.fft.irfft(1j * k * np.fft.rfft(energy), 512)
    np.testing.assert_allclose(derivative, torque, rtol=0, atol=1e-10 * np.abs(torque).max())
    assert energy.min() > 0
