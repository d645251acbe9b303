"""Cylinder pressure over one working cycle, from a scene's [gas] table.

A measured trace (:class:`~harmbal.scene.schema.PressureTrace`) is read
periodically by a periodic cubic spline or a trigonometric polynomial. A
parametric one (:class:`~harmbal.scene.schema.Combustion`) is built here: the
closed part of a four-stroke cycle (inlet valve closing at the BDC before
firing TDC to exhaust valve opening at the BDC after it) integrates the first
law of a single zone with a Wiebe heat release, the heat solved so that the
peak pressure or the IMEP meets the scene's target; the open part is a
blow-down, the exhaust stroke, a valve-overlap transition and the intake
stroke. The model, its constants and its accuracy: ``docs/gas.md``.

Angles α are crank angles from the cylinder's firing TDC: the TDC of the
offset slider-crank (the piston's highest position, at ψ = :func:`firing_tdc_angle`),
not ψ = 0.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache, partial

import numpy as np

from ..scene.schema import Combustion, Gas, PressureTrace, Problem, Scene, SceneError
from .kinematics import slider_crank

#: Step of the parametric trace's internal table [deg]: 14 400 points per four-stroke cycle, read by a
#: periodic cubic spline (docs/gas.md gives its error).
TABLE_STEP_DEG = 0.05
#: Blow-down after exhaust valve opening [deg]: the pressure falls to the exhaust pressure along a half cosine.
BLOWDOWN_DEG = 40.0
#: Valve overlap [deg], centred on the gas-exchange TDC: the pressure goes from exhaust to intake pressure
#: along a half cosine.
OVERLAP_DEG = 40.0
#: Relative and absolute tolerances of the closed-cycle integration (dimensionless pressure and work).
_RTOL, _ATOL = 1e-12, 1e-14
#: Largest number of points evaluated at once by the trigonometric sum (bounds its memory to ~64 MB).
_CHUNK = 1 << 22
#: Iteration limits of the parametric trace's solvers. The closed-cycle integration takes 1 500-6 000
#: evaluations of its right-hand side for any real engine (compression ratio up to 10⁶: 6 000, 0.3 s); a
#: tiny clearance volume makes it ever stiffer (10⁸: 1.2 million, 40 s), so it stops at this many (~2 s).
MAX_EVALUATIONS = 50_000
#: Doublings of the heat bracket for a peak-pressure target, and Brent's iterations (it needs ~50).
MAX_DOUBLINGS, MAX_ITERATIONS = 200, 200


def firing_tdc_angle(crank_radius: float, rod_length: float, offset: float) -> float:
    """Local crank angle ψ [rad] of top dead centre of an offset slider-crank.

    At TDC crank and rod are in line, so the crank pin points at the piston
    pin, which is then at (l + r) from the crank axis on the line n = e:
    ψ_TDC = arcsin(e / (l + r)). Zero for a centric crank.

    Parameters
    ----------
    crank_radius, rod_length : float
        r and l [m].
    offset : float
        Total offset e of the piston-pin path (pin offset + cylinder offset) [m].

    Returns
    -------
    float
        ψ at TDC [rad], small and of the sign of ``offset``.
    """
    return math.asin(offset / (rod_length + crank_radius))


def bottom_dead_centre_angle(crank_radius: float, rod_length: float, offset: float) -> float:
    """Local crank angle ψ [rad] of bottom dead centre: π + arcsin(e / (l − r))
    (crank pin pointing away from the piston pin, crank and rod in line)."""
    return math.pi + math.asin(offset / (rod_length - crank_radius))


def top_dead_centre_travel(crank_radius: float, rod_length: float, offset: float) -> float:
    """Piston-pin travel c_B [m] along the cylinder axis at top dead centre,
    crank and rod in line: √((l+r)² − e²)."""
    return math.sqrt((rod_length + crank_radius) ** 2 - offset**2)


def stroke(crank_radius: float, rod_length: float, offset: float) -> float:
    """Piston stroke [m] of an offset slider-crank: √((l+r)² − e²) − √((l−r)² − e²) (2r when e = 0)."""
    bottom = math.sqrt((rod_length - crank_radius) ** 2 - offset**2)
    return top_dead_centre_travel(crank_radius, rod_length, offset) - bottom


def cylinder_pressure(gas: Gas, crank_radius: float, rod_length: float, offset: float, cycle: int,
                      alpha: np.ndarray) -> np.ndarray:
    """Absolute cylinder pressure [Pa] at crank angles alpha [rad] measured
    from the cylinder's firing TDC (any real values; periodic with period π·cycle).

    Parameters
    ----------
    gas : Gas
        The cylinder's [gas] table: a measured trace or a parametric one.
    crank_radius, rod_length, offset : float
        The slider-crank [m] (``offset`` = pin offset + cylinder offset);
        used by the parametric trace, whose volume they give.
    cycle : int
        Strokes per cycle (2 or 4): the period is π·cycle.
    alpha : array_like
        Crank angles from firing TDC [rad].

    Returns
    -------
    ndarray
        Pressure [Pa], the shape of ``alpha``.

    Raises
    ------
    SceneError
        If a parametric target cannot be met (naming ``gas.combustion.peak_pressure``
        or ``gas.combustion.imep``).
    """
    alpha = np.asarray(alpha, dtype=float)
    if isinstance(gas.trace, PressureTrace):
        return _measured(gas.trace, cycle)(alpha)
    return combustion_trace(gas, crank_radius, rod_length, offset).evaluate(alpha)


def check_gas(scene: Scene) -> None:
    """Build every cylinder's parametric trace now, so that an infeasible
    target is reported as a :class:`SceneError` naming the scene file, the
    key and the cylinder before anything is computed."""
    problems: list[Problem] = []
    solved: list[tuple[tuple, list[Problem]]] = []
    for c in scene.cylinders:
        if c.gas is None or not isinstance(c.gas.trace, Combustion):
            continue
        # The traces are cached, but each lookup hashes the table anew (a frozen dataclass keeps no hash):
        # cylinders of the same table and slider-crank, usually the same objects, are looked up once.
        key = (c.gas, c.crank_radius, c.rod_length, c.offset)
        failed = next((done for seen, done in solved if seen == key), None)
        if failed is None:
            try:
                combustion_trace(*key)
                failed = []
            except SceneError as exc:
                failed = exc.problems
            solved.append((key, failed))
        problems += [Problem(scene.source, p.key, p.value, f"cylinder {c.label}: {p.rule}") for p in failed]
    if problems:
        raise SceneError(problems)


# --------------------------------------------------------------------------
# Measured traces


@lru_cache(maxsize=256)
def _measured(trace: PressureTrace, cycle: int):
    """The periodic interpolant of a measured trace (cached: traces hash by value)."""
    period = math.pi * cycle
    angle = np.asarray(trace.angle)
    pressure = np.asarray(trace.pressure)
    spline = _periodic_spline(angle, pressure, period)
    if trace.interpolation == "spline":
        return spline
    return _trigonometric(angle, pressure, period, spline)


def _periodic_spline(angle: np.ndarray, values: np.ndarray, period: float):
    """Periodic cubic spline through the table closed by its first point one period on."""
    from scipy.interpolate import CubicSpline

    spline = CubicSpline(np.append(angle, angle[0] + period), np.append(values, values[0]), bc_type="periodic")
    return _PeriodicCubic(spline.x, spline.c, period)


class _PeriodicCubic:
    """A periodic piecewise cubic read at any angles: the polynomial of the
    interval each angle falls in, as :class:`scipy.interpolate.PPoly` reads
    it, at a fifth of its cost.

    The coefficients are stored one interval to a row, so that each angle
    reads one cache line of a table that is often out of cache (14 400
    intervals for a parametric trace); on a uniform table the interval is
    found by a division rather than a binary search. ``breaks`` (n + 1,)
    and ``coefficients`` (4, n) as :class:`~scipy.interpolate.CubicSpline`
    holds them.
    """

    def __init__(self, breaks: np.ndarray, coefficients: np.ndarray, period: float):
        self.start, self.period = float(breaks[0]), period
        self.offsets = breaks[:-1] - self.start
        self.rows = np.ascontiguousarray(coefficients.T)
        step = period / self.offsets.size
        self.uniform = bool(np.allclose(np.diff(breaks), step, rtol=1e-9, atol=0))
        self.inverse_step = 1 / step

    def __call__(self, alpha: np.ndarray) -> np.ndarray:
        u = np.asarray(alpha, dtype=float).ravel() - self.start
        u -= self.period * np.floor(u / self.period)  # into [0, period]; np.mod costs four times as much
        last = self.offsets.size - 1
        if self.uniform:
            # An angle on a break may land in the interval before it: both polynomials agree there.
            interval = np.minimum((u * self.inverse_step).astype(np.intp), last)
        else:
            interval = np.clip(np.searchsorted(self.offsets, u, side="right") - 1, 0, last)
        d = u - self.offsets.take(interval)
        c = self.rows.take(interval, axis=0).T
        value = c[0] * d
        for k in (1, 2):
            value += c[k]
            value *= d
        value += c[3]
        return value.reshape(np.shape(alpha))


def _trigonometric(angle: np.ndarray, pressure: np.ndarray, period: float, spline):
    """The trigonometric polynomial through N uniformly spaced samples (exact
    for a trace band-limited below N/2 harmonics of the cycle). A
    non-uniform table is first resampled by its periodic spline onto N
    uniform points from its first angle, so it is then only as good as the spline."""
    n = angle.size
    step = period / n
    uniform = np.allclose(np.diff(angle), step, rtol=1e-9, atol=0) and abs(angle[-1] + step - angle[0] - period) <= (
        1e-9 * step)
    if not uniform:
        pressure = spline(angle[0] + step * np.arange(n))
    coefficients = np.fft.rfft(pressure) / n
    weights = np.full(coefficients.size, 2.0)
    weights[0] = 1.0
    if n % 2 == 0:
        weights[-1] = 1.0  # the Nyquist term, real for real samples: its cosine alone
    coefficients = coefficients * weights
    harmonics = np.arange(coefficients.size)
    start = angle[0]

    def evaluate(alpha: np.ndarray) -> np.ndarray:
        alpha = np.asarray(alpha, dtype=float)
        t = (2 * np.pi / period) * (alpha.ravel() - start)
        out = np.empty(t.size)
        rows = max(1, _CHUNK // harmonics.size)
        for i in range(0, t.size, rows):  # chunks bound the (points × harmonics) matrix
            phase = np.exp(1j * np.outer(t[i:i + rows], harmonics))
            out[i:i + rows] = (phase @ coefficients).real
        return out.reshape(alpha.shape)

    return evaluate


# --------------------------------------------------------------------------
# Parametric traces


@dataclass(frozen=True, eq=False)
class CombustionTrace:
    """A solved parametric trace of one four-stroke cylinder.

    Attributes
    ----------
    alpha, pressure : ndarray
        The internal table: uniform angles from inlet valve closing [rad]
        (one cycle, 4π, step :data:`TABLE_STEP_DEG`) and absolute pressure [Pa].
    heat : float
        Heat released by combustion over the cycle, Q [J] (the Wiebe
        function's asymptote; the share burnt by EVO is ``burnt_at_evo``).
    burnt_at_evo : float
        x_b at exhaust valve opening.
    imep : float
        Indicated mean effective pressure ∮p dV / V_swept [Pa].
    peak_pressure, peak_angle : float
        Largest pressure [Pa] and its angle from firing TDC [rad].
    motored_peak, motored_imep : float
        The same without combustion (Q = 0) [Pa].
    swept_volume, clearance_volume : float
        [m³].
    ivc, evo : float
        Inlet valve closing and exhaust valve opening (the BDCs) from firing TDC [rad].
    """

    alpha: np.ndarray
    pressure: np.ndarray
    heat: float
    burnt_at_evo: float
    imep: float
    peak_pressure: float
    peak_angle: float
    motored_peak: float
    motored_imep: float
    swept_volume: float
    clearance_volume: float
    ivc: float
    evo: float

    def evaluate(self, alpha: np.ndarray) -> np.ndarray:
        """Pressure [Pa] at angles from firing TDC [rad] (periodic, 4π)."""
        return self._spline(alpha)

    @property
    def _spline(self):
        spline = self.__dict__.get("_cached_spline")
        if spline is None:
            spline = _periodic_spline(self.alpha, self.pressure, 4 * math.pi)
            object.__setattr__(self, "_cached_spline", spline)
        return spline


def combustion_trace(gas: Gas, crank_radius: float, rod_length: float, offset: float,
                     heat: float | None = None) -> CombustionTrace:
    """Solve (or, with ``heat``, just integrate) a parametric four-stroke trace.

    Parameters
    ----------
    gas : Gas
        With a :class:`~harmbal.scene.schema.Combustion` trace.
    crank_radius, rod_length, offset : float
        The slider-crank [m].
    heat : float, optional
        Heat released, Q [J]; if given, the target of the scene is ignored
        (``heat=0`` gives the motored trace).

    Returns
    -------
    CombustionTrace

    Raises
    ------
    SceneError
        If the target peak pressure or IMEP cannot be reached by any heat
        release Q > 0.
    """
    if not isinstance(gas.trace, Combustion):
        raise TypeError("combustion_trace needs a gas table with a Combustion trace")
    return _combustion_trace(gas.trace, gas.bore, crank_radius, rod_length, offset, heat)


@dataclass(frozen=True)
class _Cycle:
    """What the parametric trace's pieces share: the combustion table, the
    slider-crank, and the cycle's volumes and valve events. Dimensionless:
    pressures in p_IVC, volumes in V_swept, heat in p_IVC·V_swept."""

    c: Combustion
    r: float
    l: float
    e: float
    area: float
    psi_tdc: float
    c_tdc: float
    swept: float
    clearance: float
    ivc: float
    evo: float

    @classmethod
    def of(cls, c: Combustion, bore: float, r: float, l: float, e: float) -> _Cycle:
        area = math.pi * bore**2 / 4
        psi_tdc = firing_tdc_angle(r, l, e)
        psi_bdc = bottom_dead_centre_angle(r, l, e)
        swept = area * stroke(r, l, e)
        return cls(c=c, r=r, l=l, e=e, area=area, psi_tdc=psi_tdc, c_tdc=top_dead_centre_travel(r, l, e),
                   swept=swept, clearance=swept / (c.compression_ratio - 1), ivc=psi_bdc - 2 * math.pi - psi_tdc,
                   evo=psi_bdc - psi_tdc)


@dataclass(frozen=True, eq=False)
class _ClosedCycle:
    """The closed part integrated, linear in the heat Q: the table's angles,
    which of them are closed, the pressure there as ``table[0] + Q·table[1]``,
    the dense solutions per segment ``(low, high, sol)`` and the state at EVO
    ``(p_h, p_q, W_h, W_q)``."""

    alpha: np.ndarray
    closed: np.ndarray
    table: np.ndarray
    solutions: list
    at_evo: np.ndarray


@lru_cache(maxsize=256)
def _combustion_trace(c: Combustion, bore: float, r: float, l: float, e: float,
                      heat: float | None) -> CombustionTrace:
    cycle = _Cycle.of(c, bore, r, l, e)
    p_ref, q_ref = c.intake_pressure, c.intake_pressure * cycle.swept
    closed = _integrate_closed(cycle)
    p_h_evo, p_q_evo, w_h, w_q = closed.at_evo
    w_base, w_blow = _open_work(cycle)
    # IMEP/p_IVC = a + b·Q (dimensionless), exactly linear in the heat.
    imep_a = w_h + w_base + p_h_evo * w_blow
    imep_b = w_q + p_q_evo * w_blow
    peak = partial(_peak, closed)
    motored_peak = peak(0.0)[0]
    q = heat / q_ref if heat is not None else _heat_for_target(c, peak, motored_peak, imep_a, imep_b)
    alpha, inside = closed.alpha, closed.closed
    pressure = np.empty(alpha.size)
    pressure[inside] = closed.table[0] + q * closed.table[1]
    pressure[~inside] = _base(cycle, alpha[~inside]) + (p_h_evo + q * p_q_evo) * _blow(cycle, alpha[~inside])
    peak_value, peak_angle = peak(q)
    return CombustionTrace(
        alpha=alpha, pressure=pressure * p_ref, heat=q * q_ref, burnt_at_evo=float(_burnt(c, cycle.evo)[0]),
        imep=(imep_a + q * imep_b) * p_ref, peak_pressure=peak_value * p_ref, peak_angle=float(peak_angle),
        motored_peak=motored_peak * p_ref, motored_imep=imep_a * p_ref, swept_volume=cycle.swept,
        clearance_volume=cycle.clearance, ivc=cycle.ivc, evo=cycle.evo)


def _volume(cycle: _Cycle, alpha):
    """V / V_swept and its α-derivative."""
    kin = slider_crank(np.asarray(alpha, dtype=float) + cycle.psi_tdc, cycle.r, cycle.l, cycle.e)
    return (cycle.clearance + cycle.area * (cycle.c_tdc - kin.b)) / cycle.swept, -cycle.area * kin.db / cycle.swept


def _burnt(c: Combustion, alpha):
    """Wiebe x_b and dx_b/dα (continued past the end of the duration: no jump in the heat release rate)."""
    alpha = np.asarray(alpha, dtype=float)
    s = np.clip((alpha - c.start) / c.duration, 0.0, None)
    decay = np.exp(-c.efficiency * s ** (c.shape + 1))
    rate = np.where(alpha > c.start, c.efficiency * (c.shape + 1) / c.duration * s**c.shape * decay, 0.0)
    return 1 - decay, rate


def _rates(cycle: _Cycle, evaluations, alpha, y):
    """The closed cycle's first law: y = (p_h, p_q, W_h, W_q), the pressure
    linear in Q, p = p_h + Q·p_q, and so is the work. Raises :class:`_Stiff`
    past :data:`MAX_EVALUATIONS` calls (counted by ``evaluations``)."""
    if next(evaluations) > MAX_EVALUATIONS:
        raise _Stiff
    c = cycle.c
    v, dv = _volume(cycle, alpha)
    x, dx = _burnt(c, alpha)
    kappa = c.compression_exponent + (c.expansion_exponent - c.compression_exponent) * x
    return [-kappa * y[0] * dv / v, -kappa * y[1] * dv / v + (kappa - 1) * dx / v, y[0] * dv, y[1] * dv]


def _integrate_closed(cycle: _Cycle) -> _ClosedCycle:
    """Integrate the closed part, IVC to EVO, on the table's angles."""
    from scipy.integrate import solve_ivp

    c, ivc, evo = cycle.c, cycle.ivc, cycle.evo
    rates = partial(_rates, cycle, itertools.count(1))
    n = round(720 / TABLE_STEP_DEG)
    alpha = ivc + (4 * math.pi / n) * np.arange(n)
    closed = alpha <= evo + 1e-9 * (4 * math.pi / n)
    # Integrate piecewise so that the non-smooth start of the heat release (s^m) is a segment boundary.
    breaks = [ivc, min(max(c.start, ivc), evo), min(max(c.start + c.duration, ivc), evo), evo]
    y, solutions, table = [1.0, 0.0, 0.0, 0.0], [], np.zeros((2, int(closed.sum())))
    for low, high in itertools.pairwise(breaks):
        inside = (alpha >= low) & (alpha <= high) & closed
        try:
            solution = solve_ivp(rates, (low, high), y, method="DOP853", rtol=_RTOL, atol=_ATOL, dense_output=True,
                                 t_eval=np.clip(alpha[inside], low, high))
        except _Stiff:
            raise _infeasible("compression_ratio", c.compression_ratio, (
                f"the closed cycle does not integrate in {MAX_EVALUATIONS} steps (a clearance volume of "
                f"{cycle.clearance / cycle.swept:.3g} of the swept volume makes it too stiff): lower "
                "compression_ratio to a real engine's (below 100)"), unit=None) from None
        if solution.status != 0:
            raise _infeasible("compression_ratio", c.compression_ratio, f"the closed cycle does not integrate "
                              f"({solution.message}): check compression_ratio and the exponents", unit=None)
        table[:, inside[closed]] = solution.y[:2]
        solutions.append((low, high, solution.sol))
        y = solution.y[:, -1] if solution.t.size and solution.t[-1] == high else solution.sol(high)
    return _ClosedCycle(alpha=alpha, closed=closed, table=table, solutions=solutions, at_evo=np.asarray(y))


def _closed_pressure(closed: _ClosedCycle, a: float, q: float) -> float:
    """The closed part's pressure at angle ``a`` for heat ``q``, from the dense solutions."""
    for low, high, sol in closed.solutions:
        if low <= a <= high:
            values = sol(a)
            return values[0] + q * values[1]
    raise ValueError(a)


# The open part: p = base(α) + p_EVO·blow(α), both explicit; its work splits the same way.


def _blow(cycle: _Cycle, a):
    """The blow-down's share of the pressure at EVO: 1 at EVO, down to 0 along a half cosine."""
    s = np.clip((np.asarray(a, dtype=float) - cycle.evo) / math.radians(BLOWDOWN_DEG), 0.0, 1.0)
    return 0.5 * (1 + np.cos(np.pi * s))


def _base(cycle: _Cycle, a):
    """The open part's pressure without the blow-down: exhaust pressure, then
    intake pressure after the valve overlap."""
    overlap, exchange = math.radians(OVERLAP_DEG), 2 * math.pi
    p_exh, p_int = cycle.c.exhaust_pressure / cycle.c.intake_pressure, 1.0
    a = np.asarray(a, dtype=float)
    s = np.clip((a - exchange + overlap / 2) / overlap, 0.0, 1.0)
    return p_exh * (1 - _blow(cycle, a)) + (p_int - p_exh) * 0.5 * (1 - np.cos(np.pi * s))


def _open_work(cycle: _Cycle) -> tuple[float, float]:
    """The open part's work per V_swept: of ``base``, and of ``blow`` per unit pressure at EVO."""
    from scipy.integrate import quad

    blowdown, overlap, exchange, evo = math.radians(BLOWDOWN_DEG), math.radians(OVERLAP_DEG), 2 * math.pi, cycle.evo
    points = [evo + blowdown, exchange - overlap / 2, exchange + overlap / 2]
    end = cycle.ivc + 4 * math.pi
    w_base = quad(lambda a: float(_base(cycle, a) * _volume(cycle, a)[1]), evo, end, points=points, epsabs=1e-13,
                  epsrel=1e-12, limit=200)[0]
    w_blow = quad(lambda a: float(_blow(cycle, a) * _volume(cycle, a)[1]), evo, evo + blowdown, epsabs=1e-13,
                  epsrel=1e-12)[0]
    return w_base, w_blow


def _peak(closed: _ClosedCycle, q: float) -> tuple[float, float]:
    """The largest pressure for heat ``q`` and its angle: the table's largest,
    refined between its neighbours on the dense solution."""
    from scipy.optimize import minimize_scalar

    alpha, table = closed.alpha, closed.table
    values = table[0] + q * table[1]
    i = int(np.argmax(values))
    low, high = alpha[max(i - 1, 0)], alpha[min(i + 1, table.shape[1] - 1)]
    found = minimize_scalar(lambda a: -_closed_pressure(closed, a, q), bounds=(low, high), method="bounded",
                            options={"xatol": 1e-12})
    return (-found.fun, found.x) if -found.fun > values[i] else (values[i], alpha[i])


def _heat_for_target(c: Combustion, peak, motored_peak: float, imep_a: float, imep_b: float) -> float:
    """The heat release (dimensionless) that meets the scene's target, peak
    pressure or IMEP (``a + b·Q``); refuses a target no heat Q > 0 reaches."""
    p_ref = c.intake_pressure
    if c.peak_pressure is not None:
        target = c.peak_pressure / p_ref
        if not target > motored_peak:
            raise _infeasible("peak_pressure", c.peak_pressure,
                              f"below the motored peak pressure {motored_peak * p_ref / 1e5:.6g} bar (compression "
                              "alone reaches it): raise the target, or lower compression_ratio or intake_pressure")
        return _heat_for_peak(peak, target, c.peak_pressure)
    assert c.imep is not None  # a combustion table gives peak_pressure or imep
    target = c.imep / p_ref
    q = (target - imep_a) / imep_b if imep_b > 0 else -1.0
    if not q > 0:
        raise _infeasible("imep", c.imep, f"no heat release reaches it: the motored IMEP is "
                          f"{imep_a * p_ref / 1e5:.6g} bar and heat released by EVO adds to it only "
                          f"{'positively' if imep_b > 0 else 'nothing'}")
    return q


def _heat_for_peak(peak, target: float, given: float) -> float:
    """The heat release (dimensionless) whose peak pressure is ``target``:
    bracketed by doubling from 1, then Brent's method, each within its
    iteration limit (the peak grows linearly with the heat, so neither needs
    more than a few dozen)."""
    from scipy.optimize import brentq

    high = 1.0
    for _ in range(MAX_DOUBLINGS):
        if peak(high)[0] >= target:
            break
        high *= 2
    else:
        raise _infeasible("peak_pressure", given, f"no heat release up to {high:.3g} × p_IVC·V_swept reaches it: "
                          "lower the target")
    try:
        return brentq(lambda q: peak(q)[0] - target, 0.0, high, xtol=1e-14, rtol=1e-14, maxiter=MAX_ITERATIONS)
    except (RuntimeError, ValueError) as exc:  # no convergence, or no sign change (a peak that is not finite)
        raise _infeasible("peak_pressure", given, f"the heat release that reaches it is not found ({exc}): check "
                          "the [gas.combustion] values") from None


class _Stiff(Exception):
    """The closed-cycle integration reached :data:`MAX_EVALUATIONS`."""


def _infeasible(key: str, value: float, rule: str, unit: str | None = "bar") -> SceneError:
    shown = f"{value / 1e5:.6g} bar" if unit == "bar" else value
    return SceneError([Problem("[gas]", f"gas.combustion.{key}", shown, rule)])
