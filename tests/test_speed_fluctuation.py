"""Periodic speed fluctuation of a rigid crank train (harmbal.model.speed).

Oracles, none sharing code with the implementation:

* constant J, T_g = T̄ + A sin kθ: ω² = C − b cos kθ with b = 2A/(kJ) in closed
  form, and both means through complete elliptic integrals
  (∫₀^{2π} dφ/sqrt(C − b cos φ) = 4K(m)/sqrt(C + b), ∫₀^{2π} sqrt(C − b cos φ) dφ
  = 4 sqrt(C + b) E(m), m = 2b/(C + b)), C solved here;
* the classic estimate δ ≈ ΔE_max/(J ω̄²), ΔE_max from the analytic integral of
  the torque series;
* direct integration of J ω dω/dθ + ½ J' ω² = T_g − T_L (solve_ivp) for a
  slider-crank inertia written out here;
* invariances (angle origin, torque/speed scaling, torque/inertia scaling).
"""

import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

from harmbal.model.speed import StallError, flywheel_for, periodic_speed

# A four-stroke single cylinder's torque as a series of half orders: mean, then
# amplitude and phase of order n/2 for n = 1..12 (smooth, so M = 256 resolves it).
MEAN_TORQUE = 12.0
ORDERS = np.arange(1, 13) / 2
AMPLITUDES = 90.0 * 0.7 ** np.arange(12)
PHASES = np.linspace(0.3, 2.9, 12)
# Slider-crank: radius, rod length, reciprocating mass.
R, L, MASS = 0.045, 0.15, 1.4


def four_stroke(m, origin=0.0):
    return origin + 4 * np.pi * np.arange(m) / m


def gas_torque(theta):
    return MEAN_TORQUE + (AMPLITUDES * np.sin(np.multiply.outer(theta, ORDERS) + PHASES)).sum(axis=-1)


def gas_work(theta):
    """∫₀^θ (T_g − T̄) dθ' of the series above, term by term."""
    return (AMPLITUDES / ORDERS * (np.cos(PHASES) - np.cos(np.multiply.outer(theta, ORDERS) + PHASES))).sum(axis=-1)


def piston_speed(theta):
    """dx/dθ and d²x/dθ² of the piston pin, x = r cos θ + sqrt(l² − r² sin² θ)."""
    s, c = np.sin(theta), np.cos(theta)
    root = np.sqrt(L**2 - (R * s) ** 2)
    dx = -R * s - R**2 * s * c / root
    ddx = -R * c - R**2 * (c * c - s * s) / root - R**4 * (s * c) ** 2 / root**3
    return dx, ddx


def variable_inertia(theta):
    """J_var = 2·KE at unit speed = m (dx/dθ)², and its derivative."""
    dx, ddx = piston_speed(theta)
    return MASS * dx * dx, 2 * MASS * dx * ddx


def sine_oracle(theta, amplitude, k, inertia, mean_speed, mean):
    """ω(θ), ω_max, ω_min for constant J and T_g − T̄ = A sin kθ, with the
    mean fixed through elliptic integrals."""
    b = 2 * amplitude / (k * inertia)

    def excess(c):
        m = 2 * b / (c + b)
        if mean == "time":
            return np.pi * np.sqrt(c + b) / (2 * ellipk(m)) - mean_speed
        return 2 / np.pi * np.sqrt(c + b) * ellipe(m) - mean_speed

    c = brentq(excess, b * (1 + 1e-14), b + 10 * mean_speed**2, xtol=1e-300, rtol=1e-15)
    return np.sqrt(c - b * np.cos(k * theta)), np.sqrt(c + b), np.sqrt(c - b)


def test_elliptic_oracle_is_right():
    # The oracle's own check: the elliptic forms against adaptive quadrature.
    c, b = 3.0, 1.7
    m = 2 * b / (c + b)
    assert quad(lambda p: 1 / np.sqrt(c - b * np.cos(p)), 0, 2 * np.pi, epsabs=0, epsrel=1e-13)[0] == \
        pytest.approx(4 * ellipk(m) / np.sqrt(c + b), rel=1e-12)
    assert quad(lambda p: np.sqrt(c - b * np.cos(p)), 0, 2 * np.pi, epsabs=0, epsrel=1e-13)[0] == \
        pytest.approx(4 * np.sqrt(c + b) * ellipe(m), rel=1e-12)


@pytest.mark.parametrize("mean", ["time", "angle"])
@pytest.mark.parametrize("m, k, origin, mean_speed", [(64, 3, 0.0, 100.0), (33, 5, 0.3, 100.0), (16, 3, -1.0, 40.0),
                                                      (64, 4, 0.3, 30.0)])
def test_constant_inertia_sine_torque_matches_closed_form(mean, m, k, origin, mean_speed):
    theta = origin + 2 * np.pi * np.arange(m) / m
    amplitude, inertia = 50.0, 0.2
    result = periodic_speed(theta, 10.0 + amplitude * np.sin(k * theta), inertia, mean_speed, mean=mean)
    omega, top, bottom = sine_oracle(theta, amplitude, k, inertia, mean_speed, mean)
    np.testing.assert_allclose(result.omega, omega, rtol=1e-12, atol=0)
    np.testing.assert_allclose(result.alpha, amplitude * np.sin(k * theta) / inertia,
                               rtol=0, atol=1e-12 * amplitude / inertia)
    np.testing.assert_allclose(result.energy, 0.5 * inertia * omega**2, rtol=1e-12)
    # The extremes lie between the samples when the origin is off them: the
    # interpolant's Newton polish finds them to round-off.
    assert result.max_speed == pytest.approx(top, rel=1e-12)
    assert result.min_speed == pytest.approx(bottom, rel=1e-12)
    assert result.coefficient == pytest.approx((top - bottom) / mean_speed, rel=1e-11)
    assert result.load_torque == pytest.approx(10.0, rel=1e-14)
    if mean == "time":
        assert result.cycle_time == pytest.approx(2 * np.pi / mean_speed, rel=1e-12)
    else:
        assert np.mean(result.omega) == pytest.approx(mean_speed, rel=1e-12)


def test_classic_small_fluctuation_estimate():
    theta = four_stroke(256)
    fine = np.linspace(0, 4 * np.pi, 200_001)
    swing = np.ptp(gas_work(fine))  # ΔE_max, to ~1e-9 relative
    mean_speed = 300.0
    ratios, deltas = [], []
    for inertia in (0.05, 0.5, 5.0, 50.0):
        delta = periodic_speed(theta, gas_torque(theta), inertia, mean_speed).coefficient
        ratios.append(delta * inertia * mean_speed**2 / swing)
        deltas.append(delta)
    errors = np.abs(np.array(ratios) - 1)
    assert np.all(errors <= np.array(deltas))  # O(δ), with a constant below 1 here
    assert np.all(np.diff(errors) < 0) and errors[-1] < 1e-4


@pytest.mark.parametrize("given_derivative", [False, True])
@pytest.mark.parametrize("mean", ["time", "angle"])
def test_direct_integration_returns_and_matches(given_derivative, mean):
    m, j0, mean_speed = 256, 0.12, 250.0
    theta = four_stroke(m, origin=0.4)
    j_var, dj_var = variable_inertia(theta)
    result = periodic_speed(theta, gas_torque(theta), j0 + j_var, mean_speed, mean=mean,
                            inertia_derivative=dj_var if given_derivative else None)
    assert result.coefficient > 0.01  # a visible fluctuation, not a trivial check

    def slope(t, w):
        jv, djv = variable_inertia(t)
        return (gas_torque(t) - MEAN_TORQUE - 0.5 * djv * w**2) / ((j0 + jv) * w)

    def motion(t, y):  # y = (ω, time)
        return [slope(t, y[0]), 1 / y[0]]

    end = theta[0] + 4 * np.pi
    solution = solve_ivp(motion, (theta[0], end), [result.omega[0], 0.0], method="DOP853", rtol=1e-11,
                         atol=1e-12, t_eval=np.append(theta, end))
    assert solution.success
    omega, time = solution.y
    np.testing.assert_allclose(omega[:-1], result.omega, rtol=1e-8)
    assert omega[-1] == pytest.approx(omega[0], rel=1e-8)  # periodic
    assert result.cycle_time == pytest.approx(time[-1], rel=1e-8)
    # α = ω dω/dθ of the integrated solution.
    np.testing.assert_allclose(result.alpha, omega[:-1] * slope(theta, omega[:-1]),
                               rtol=0, atol=1e-8 * np.abs(result.alpha).max())
    if mean == "time":
        assert time[-1] == pytest.approx(4 * np.pi / mean_speed, rel=1e-8)
    else:
        assert np.mean(omega[:-1]) == pytest.approx(mean_speed, rel=1e-8)


def test_shifting_the_angle_origin_shifts_the_result():
    m, shift = 128, 37
    theta = four_stroke(m)
    j = 0.1 + variable_inertia(theta)[0]
    torque = gas_torque(theta)
    base = periodic_speed(theta, torque, j, 200.0)
    moved = periodic_speed(theta[shift] + theta, np.roll(torque, -shift), np.roll(j, -shift), 200.0)
    np.testing.assert_allclose(moved.omega, np.roll(base.omega, -shift), rtol=1e-12)
    np.testing.assert_allclose(moved.alpha, np.roll(base.alpha, -shift), rtol=0, atol=1e-11 * np.abs(base.alpha).max())
    assert moved.coefficient == pytest.approx(base.coefficient, rel=1e-12)
    assert moved.cycle_time == pytest.approx(base.cycle_time, rel=1e-13)


@pytest.mark.parametrize("mean", ["time", "angle"])
def test_speed_scales_with_the_root_of_the_torque(mean):
    theta = four_stroke(128)
    j = 0.1 + variable_inertia(theta)[0]
    base = periodic_speed(theta, gas_torque(theta), j, 200.0, mean=mean)
    s = 1.7
    scaled = periodic_speed(theta, s**2 * gas_torque(theta), j, s * 200.0, mean=mean)
    np.testing.assert_allclose(scaled.omega, s * base.omega, rtol=1e-12)
    np.testing.assert_allclose(scaled.alpha, s**2 * base.alpha, rtol=0, atol=1e-11 * s**2 * np.abs(base.alpha).max())
    np.testing.assert_allclose(scaled.energy, s**2 * base.energy, rtol=1e-12)
    assert scaled.coefficient == pytest.approx(base.coefficient, rel=1e-11)
    # Torque and inertia scaled alike: the same motion.
    same = periodic_speed(theta, s * gas_torque(theta), s * j, 200.0, mean=mean)
    np.testing.assert_allclose(same.omega, base.omega, rtol=1e-12)


@pytest.mark.parametrize("mean", ["time", "angle"])
@pytest.mark.parametrize("target", [0.005, 0.02, 0.1])
def test_flywheel_for_meets_the_target(mean, target):
    theta = four_stroke(256)
    j_var = variable_inertia(theta)[0]
    torque = gas_torque(theta)
    j0 = flywheel_for(target, theta, torque, j_var, 250.0, mean=mean)
    assert j0 > 0
    assert periodic_speed(theta, torque, j0 + j_var, 250.0, mean=mean).coefficient == pytest.approx(
        target, abs=1e-10)  # scale: 1 (a speed ratio)
    # The variable inertia's own (mass) torque adds to the swing at this speed:
    # the classic estimate J ≈ ΔE_max/(δ ω̄²) of the gas work alone falls ~10 % short.
    swing = np.ptp(gas_work(np.linspace(0, 4 * np.pi, 200_001)))
    assert 1.05 < j0 * target * 250.0**2 / swing < 1.2


@pytest.mark.parametrize("mean", ["time", "angle"])
@pytest.mark.parametrize("target", [0.01, 0.2])
def test_flywheel_for_constant_inertia_matches_closed_form(mean, target):
    # T − T̄ = A sin kθ, J constant: δ(J) through the elliptic oracle, solved for J here.
    theta = 0.2 + 2 * np.pi * np.arange(48) / 48
    amplitude, k, mean_speed = 80.0, 2, 150.0

    def excess(inertia):
        _, top, bottom = sine_oracle(theta, amplitude, k, inertia, mean_speed, mean)
        return (top - bottom) / mean_speed - target

    expected = brentq(excess, 1e-2, 1e3, xtol=1e-300, rtol=1e-15)  # no stall at 1e-2 kg m²
    j0 = flywheel_for(target, theta, 5.0 + amplitude * np.sin(k * theta), 0.0, mean_speed, mean=mean)
    assert j0 == pytest.approx(expected, rel=1e-10)
    # The classic estimate, ΔE_max = 2A/k, to O(δ).
    assert 2 * amplitude / k / (target * mean_speed**2) / j0 == pytest.approx(1, abs=target)


def test_flywheel_for_is_zero_when_the_given_inertia_suffices():
    theta = four_stroke(128)
    torque = gas_torque(theta)
    delta = periodic_speed(theta, torque, 0.3, 250.0).coefficient
    assert flywheel_for(1.01 * delta, theta, torque, 0.3, 250.0) == 0.0
    assert flywheel_for(0.99 * delta, theta, torque, 0.3, 250.0) > 0.0


@pytest.mark.parametrize("mean", ["time", "angle"])
def test_flywheel_for_refuses_a_target_beyond_the_stall(mean):
    # δ stays finite as J₀ falls to the stall (ω_min → 0, δ → ω_max/ω̄), so a
    # large enough target is never met.
    theta = 0.2 + 2 * np.pi * np.arange(48) / 48
    torque = 5.0 + 80.0 * np.sin(2 * theta)
    with pytest.raises(ValueError, match="unreachable: the crank train stalls"):
        flywheel_for(3.0, theta, torque, 0.0, 150.0, mean=mean)
    j0 = flywheel_for(1.0, theta, torque, 0.0, 150.0, mean=mean)  # a large one that is met
    assert periodic_speed(theta, torque, j0, 150.0, mean=mean).coefficient == pytest.approx(
        1.0, abs=1e-10)  # scale: 1 (a speed ratio)


def test_flywheel_for_refuses_a_bad_target():
    theta = four_stroke(64)
    for target in (0.0, -0.01, np.nan):
        with pytest.raises(ValueError, match="positive"):
            flywheel_for(target, theta, gas_torque(theta), variable_inertia(theta)[0], 250.0)


def test_mean_mismatch_has_no_periodic_state():
    theta = four_stroke(64)
    torque = gas_torque(theta)
    with pytest.raises(ValueError, match="no periodic steady state"):
        periodic_speed(theta, torque, 0.2, 200.0, load_torque=MEAN_TORQUE * 1.001)
    # Within the stated tolerance (1e-9 of the peak torque) the mismatch is round-off.
    within = periodic_speed(theta, torque, 0.2, 200.0, load_torque=np.mean(torque) + 1e-11 * np.abs(torque).max())
    assert within.omega == pytest.approx(periodic_speed(theta, torque, 0.2, 200.0).omega, rel=1e-14)


@pytest.mark.parametrize("bad", [0.0, -0.1])
def test_inertia_must_be_positive(bad):
    theta = four_stroke(64)
    j = np.full(64, 0.2)
    j[10] = bad
    with pytest.raises(ValueError, match="inertia must be positive"):
        periodic_speed(theta, gas_torque(theta), j, 200.0)
    with pytest.raises(ValueError, match="inertia must be positive"):
        periodic_speed(theta, gas_torque(theta), bad, 200.0)
    # J_var alone is zero at the dead centres.
    with pytest.raises(ValueError, match="inertia must be positive"):
        periodic_speed(theta, gas_torque(theta), variable_inertia(theta)[0], 200.0)


@pytest.mark.parametrize("mean", ["time", "angle"])
def test_too_low_a_mean_speed_stalls(mean):
    theta = four_stroke(128)
    with pytest.raises(StallError, match="stall") as raised:
        periodic_speed(theta, gas_torque(theta), 0.05, 2.0, mean=mean)
    assert isinstance(raised.value, ValueError)


def test_the_angle_mean_has_a_stall_floor():
    # Constant J, T − T̄ = A sin kθ: E touches zero when C = b, where the angle
    # mean is (2/π)·sqrt(2b)·E(1) = 2 sqrt(2b)/π.
    theta = 2 * np.pi * np.arange(64) / 64
    amplitude, k, inertia = 50.0, 3, 0.2
    floor = 2 * np.sqrt(4 * amplitude / (k * inertia)) / np.pi
    torque = amplitude * np.sin(k * theta)
    with pytest.raises(StallError, match="would stall"):
        periodic_speed(theta, torque, inertia, 0.999 * floor, mean="angle")
    assert periodic_speed(theta, torque, inertia, 1.5 * floor, mean="angle").min_speed > 0


def test_bad_arguments():
    theta = four_stroke(64)
    torque = gas_torque(theta)
    with pytest.raises(ValueError, match="uniformly spaced"):
        periodic_speed(theta**1.01, torque, 0.2, 200.0)
    with pytest.raises(ValueError, match="one value per angle"):
        periodic_speed(theta, torque[:-1], 0.2, 200.0)
    with pytest.raises(ValueError, match="mean_speed"):
        periodic_speed(theta, torque, 0.2, -5.0)
    with pytest.raises(ValueError, match="mean must be"):
        periodic_speed(theta, torque, 0.2, 200.0, mean="rms")


def test_module_imports_only_numpy():
    code = "import sys, harmbal.model.speed; print(sorted(m for m in ('scipy', 'xarray', 'pint') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_worked_example_in_the_docs_is_current():
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / "docs" / "speed.md").read_text(encoding="utf-8")
    namespace = {}
    exec(re.search(r"```python\n(.*?)```", text, re.DOTALL).group(1), namespace)  # noqa: S102 - the page's own snippet
    result = namespace["result"]
    assert f"{result.min_speed:.3f} … {result.max_speed:.3f} rad/s" in text
    assert f"| δ | {result.coefficient:.5f} |" in text
    assert f"| δ with J frozen at its mean | {namespace['frozen'].coefficient:.5f} |" in text
    assert f"| J₀ for δ = 0.01 | {namespace['j0']:.5f} kg m² |" in text
    assert f"{namespace['estimate']:.5f} kg m²" in text
