"""Optimal balance weight of a lever balancer, provably, and the thesis's search.

The shaking force on the block is −Σ m·a_G over all bodies, and the
kinematics do not depend on the masses, so the coupler (the balance weight)
enters it only through p = (m, m·x_G, m·y_G) (see
:func:`harmbal.model.linkage.weight_basis`):

    F(θ; p) = F_rest(θ) − [B''(θ), E(θ), i·E(θ)]·p,

linear in p, without the weight's moment of inertia. The transverse moments
about a point are linear in F at the lever's plane, so they are linear in p
too. Over a sampled revolution:

* the peak-to-peak value of a signal, max_j s_j − min_j s_j, and its peak
  max_j |s_j| are convex and piecewise linear in p: minimising their sum is
  a linear programme in p and one or two epigraph variables per signal,
  solved exactly (to the solver tolerance) by HiGHS;
* the order phasors are linear in p, so a weighted sum of squared order
  amplitudes is a convex quadratic: solved exactly by enumerating the active
  sets of its few linear constraints (KKT, 3 unknowns).

Bounds on m and on the CG's envelope (x_lo ≤ x_G ≤ x_hi ⇔ x_lo·m ≤ m·x_G ≤
x_hi·m for m ≥ 0) are linear constraints in p. Because everything scales with
ω², the optimum does not depend on speed.

:func:`compass_search` is the coordinate search with step halving used in the
source thesis (216 cycles, 4 min 35 s), kept to compare against in
``benchmarks/bench_lever.py``.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..model import evaluate as model
from ..model.linkage import four_bar, lever_loads, to_engine, weight_basis
from ..orders.spectrum import phasors, rotating_split
from ..scene import Scene
from ..scene.elements import LeverBalancer, LinkBody
from ..scene.requests import LEVER_OBJECTIVES, LEVER_SIGNALS, PEAK_SAMPLES, LeverDesignRequest
from .solvers import LP_TOLERANCES, BalancerDesign, DesignError

#: Orders reported in the per-order breakdown.
BREAKDOWN_ORDERS = 4


@dataclass(frozen=True)
class LeverProblem:
    """The signals of the sampled revolution as an affine map of p at unit
    speed: ``rest`` (signal, angle) + ``basis`` (signal, angle, 3) @ p."""

    theta: np.ndarray
    signals: tuple[str, ...]
    rest: np.ndarray
    basis: np.ndarray

    def values(self, p: np.ndarray) -> np.ndarray:
        return self.rest + self.basis @ np.asarray(p, dtype=float)


@dataclass(frozen=True)
class LeverDesign(BalancerDesign):
    """A balance weight and what it achieves (the result of :func:`design_lever`).

    ``start`` and ``weight`` are (m [kg], x_G [m], y_G [m]) of the scene's
    weight and of the optimum; ``criterion_start``/``criterion`` the
    objective at ``speed`` [rad/s] ([N] or [N m] for the peak objectives,
    their squares for "orders"); ``breakdown`` a Dataset with the criterion
    per signal and the force per order (co/counter) before and after;
    ``exact_criterion`` the criterion recomputed from the output scene by the
    full time-domain model, and ``verified`` whether it equals ``criterion``
    within ``tolerance``. ``method`` is "lp", "qp" or "compass";
    ``evaluations``/``cycles`` count the compass search's work and ``seconds``
    the solver time.
    """

    request: LeverDesignRequest
    lever: str
    method: str
    speed: float
    start: tuple[float, float, float]
    weight: tuple[float, float, float]
    criterion_start: float
    criterion: float
    exact_criterion: float
    tolerance: float
    verified: bool
    breakdown: object
    seconds: float
    evaluations: int
    cycles: int
    messages: tuple[str, ...]
    text: str
    scene: Scene

    def __repr__(self) -> str:
        """The weight (mass [kg], CG [mm]) and criterion at the start and
        found, and the exact model's check."""
        from .summaries import lever_text

        return lever_text(self)

    def _repr_html_(self) -> str:
        """:meth:`__repr__` as HTML tables, for notebooks."""
        from .summaries import lever_html

        return lever_html(self)


def _lever(scene: Scene, label: str | None) -> tuple[int, LeverBalancer]:
    if not scene.levers:
        raise DesignError(f"{scene.source}: no [[lever_balancer]] to design")
    if label is None:
        if len(scene.levers) > 1:
            raise DesignError(f"{scene.source}: design.lever.label: the scene has several lever balancers "
                              f"({', '.join(l.label for l in scene.levers)}); name one")
        return 0, scene.levers[0]
    for i, lever in enumerate(scene.levers):
        if lever.label == label:
            return i, lever
    raise DesignError(f"{scene.source}: design.lever.label = {label!r}: no such lever balancer "
                      f"({', '.join(l.label for l in scene.levers)})")


def _weight_p(body: LinkBody) -> np.ndarray:
    return np.array([body.mass, body.mass * body.cg[0], body.mass * body.cg[1]])


def _signals(force: np.ndarray, moment: np.ndarray, names: tuple[str, ...]) -> np.ndarray:
    """Pick the named signals from engine-axis arrays (axis, ...)."""
    axes = {"x": 0, "y": 1, "z": 2}
    return np.stack([(force if n.startswith("force") else moment)[axes[n[-1]]] for n in names])


def _black_box(scene: Scene, lever: LeverBalancer, request: LeverDesignRequest, theta: np.ndarray):
    """The criterion at the scene's first speed as a function of the weight
    (m, x_G, y_G), evaluated as the thesis did: the lever's exact loads
    recomputed for every trial weight (no use of linearity)."""
    ref = np.asarray(scene.reference_point, dtype=float)
    mass_torque = "mass_torque" in scene.model.effects
    force, moment = model.evaluate(scene, len(theta)).total(ref)
    own_force, own_moment = lever_loads((lever,), theta, scene.sense, mass_torque)
    rest_force, rest_moment = force - own_force, moment - model.moment_about(ref, own_force, own_moment)
    w2 = scene.speeds[0] ** 2

    def evaluate(weight) -> float:
        f, m = lever_loads((_with_weight(lever, weight),), theta, scene.sense, mass_torque)
        values = _signals(rest_force + f, rest_moment + model.moment_about(ref, f, m), request.signals) * w2
        return criterion(values, request.objective, request.orders, request.weights)

    return evaluate


def lever_problem(scene: Scene, request: LeverDesignRequest, samples: int = PEAK_SAMPLES) -> LeverProblem:
    """Set up the signals as an affine function of the weight's p."""
    if "balancers" not in scene.model.effects:
        raise DesignError(f"{scene.source}: model.effects: add \"balancers\"; without it the lever balancer "
                          "is not simulated")
    _, lever = _lever(scene, request.lever)
    sense = scene.sense
    theta = 2 * np.pi * np.arange(samples) / samples
    ref = np.asarray(scene.reference_point, dtype=float)
    total = _signals(*model.evaluate(scene, samples).total(ref), request.signals)
    # The weight's own force is −basis·p; its moment about ref acts at the lever's plane.
    columns = weight_basis(four_bar(lever, theta, sense))  # (3, angle) complex: m·a_G per unit p
    fy, fz = to_engine(-columns, sense)
    arm = lever.x - ref[0]
    zeros = np.zeros_like(fy)
    basis = _signals(np.stack([zeros, fy, fz]), np.stack([zeros, -arm * fz, arm * fy]), request.signals)
    basis = np.moveaxis(basis, 1, -1)  # (signal, angle, 3)
    rest = total - basis @ _weight_p(lever.coupler)
    return LeverProblem(theta, request.signals, rest, basis)


def criterion(values: np.ndarray, objective: str, orders=(1,), weights=()) -> float:
    """The objective of sampled signals (signal, angle) at one speed."""
    if objective == "peak_to_peak":
        return float((values.max(axis=-1) - values.min(axis=-1)).sum())
    if objective == "peak":
        return float(np.abs(values).max(axis=-1).sum())
    if objective == "orders":
        spectrum = phasors(values)
        w = np.asarray(weights or [1.0] * len(orders), dtype=float)
        return float((w * (np.abs(spectrum[:, list(orders)]) ** 2).sum(axis=0)).sum())
    raise ValueError(f"unknown objective {objective!r}; choose one of {', '.join(LEVER_OBJECTIVES)}")


def _envelope(request: LeverDesignRequest, length: float) -> dict[str, tuple[float, float]]:
    """Bounds on m, x_G and y_G: the request's, and by default m ≥ 0 and a
    CG within one coupler length ``length`` of the link B–C (x_G in [−b, 2b],
    y_G in [−b, b]). A CG bound is needed: without one, m → 0 with a finite
    m·x_G (a weight of no mass infinitely far away) could pass for a design."""
    return {"mass": request.mass or (0.0, math.inf), "cg_x": request.cg_x or (-length, 2 * length),
            "cg_y": request.cg_y or (-length, length)}


def _constraints(bounds: dict[str, tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    """The bounds as G·p ≤ h in p = (m, m·x_G, m·y_G)."""
    low_mass, high_mass = bounds["mass"]
    rows: list[list[float] | np.ndarray] = [[-1.0, 0.0, 0.0]]
    rhs = [-low_mass]
    if math.isfinite(high_mass):
        rows.append([1.0, 0.0, 0.0])
        rhs.append(high_mass)
    for j, key in ((1, "cg_x"), (2, "cg_y")):
        low, high = np.zeros(3), np.zeros(3)
        low[0], low[j] = bounds[key][0], -1.0  # x_lo·m − m·x_G ≤ 0
        high[0], high[j] = -bounds[key][1], 1.0  # m·x_G − x_hi·m ≤ 0
        rows += [low, high]
        rhs += [0.0, 0.0]
    return np.array(rows, dtype=float), np.array(rhs, dtype=float)


def _check_bounds(bounds: dict[str, tuple[float, float]]) -> None:
    for key, (low, high) in bounds.items():
        if not low <= high:
            raise DesignError(f"design.lever.{key} = [{low:g}, {high:g}]: the lower bound exceeds the upper one")
    if bounds["mass"][0] < 0:
        raise DesignError(f"design.lever.mass: a lower bound of {bounds['mass'][0]:g} kg; masses are not negative")


def _solve_lp(problem: LeverProblem, objective: str, g: np.ndarray, h: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """min Σ_s (u_s − l_s) or Σ_s t_s subject to the sampled signals, in
    scaled unknowns p = scale·z."""
    from scipy.optimize import linprog

    nsig, nang, _ = problem.basis.shape
    # Normalise each signal so that HiGHS's absolute tolerances are relative ones.
    size = np.maximum(np.abs(problem.rest).max(axis=-1), np.abs(problem.basis * scale).max(axis=(1, 2)))
    size = np.where(size > 0, size, 1.0)
    a = problem.basis * scale / size[:, None, None]
    b = problem.rest / size[:, None]
    extra = 2 if objective == "peak_to_peak" else 1
    nvar = 3 + extra * nsig
    c = np.zeros(nvar)
    rows, rhs = [], []
    for s in range(nsig):
        upper = np.zeros((nang, nvar))
        upper[:, :3] = a[s]
        upper[:, 3 + extra * s] = -1.0  # s_j ≤ u_s (or t_s)
        lower = np.zeros((nang, nvar))
        lower[:, :3] = -a[s]
        if objective == "peak_to_peak":
            lower[:, 4 + 2 * s] = 1.0  # l_s ≤ s_j
            c[3 + 2 * s], c[4 + 2 * s] = size[s], -size[s]
        else:
            lower[:, 3 + s] = -1.0  # −t_s ≤ s_j
            c[3 + s] = size[s]
        rows += [upper, lower]
        rhs += [-b[s], b[s]]
    bound_rows = np.zeros((len(h), nvar))
    bound_rows[:, :3] = g * scale
    result = linprog(c, A_ub=np.vstack(rows + [bound_rows]), b_ub=np.concatenate(rhs + [h]),
                     bounds=[(None, None)] * nvar, method="highs", options=LP_TOLERANCES)
    if result.status == 2:
        raise DesignError("the bounds on the weight contradict each other (no feasible weight)")
    if not result.success:
        raise DesignError(f"the linear programme failed: {result.message}")
    return result.x[:3] * scale


def _solve_qp(problem: LeverProblem, orders, weights, g: np.ndarray, h: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """min Σ_k w_k Σ_s |C_k,s(p)|² subject to g·p ≤ h, by enumerating the
    active sets (every KKT point of a convex QP is a global minimum)."""
    spectrum_rest = phasors(problem.rest)[:, list(orders)]  # (signal, order)
    spectrum_basis = phasors(np.moveaxis(problem.basis * scale, -1, 0))[:, :, list(orders)]  # (3, signal, order)
    w = np.sqrt(np.asarray(weights or [1.0] * len(orders), dtype=float))
    rows = (spectrum_basis * w).reshape(3, -1).T  # complex residual r = rows @ z + rest
    rest = (spectrum_rest * w).ravel()
    a = np.vstack([rows.real, rows.imag])
    b = np.concatenate([rest.real, rest.imag])
    norm = max(float(np.abs(a).max()), float(np.abs(b).max()), 1e-300)
    a, b = a / norm, b / norm
    hess, grad = a.T @ a, a.T @ b
    gs = g * scale
    best, best_value = None, math.inf
    for count in range(0, 4):
        for active in itertools.combinations(range(len(h)), count):
            rows_active = gs[list(active)]
            kkt = np.zeros((3 + count, 3 + count))
            kkt[:3, :3] = hess
            kkt[:3, 3:] = rows_active.T
            kkt[3:, :3] = rows_active
            solution, *_ = np.linalg.lstsq(kkt, np.concatenate([-grad, h[list(active)]]), rcond=None)
            z, lam = solution[:3], solution[3:]
            if not np.allclose(kkt @ solution, np.concatenate([-grad, h[list(active)]]), atol=1e-10, rtol=1e-10):
                continue  # inconsistent system: this set of constraints cannot all be active
            if np.any(gs @ z > h + 1e-10 * (1 + np.abs(h))) or np.any(lam < -1e-12):
                continue
            value = float(np.sum((a @ z + b) ** 2))
            if value < best_value - 1e-15:
                best, best_value = z, value
    if best is None:
        raise DesignError("the bounds on the weight contradict each other (no feasible weight)")
    return best * scale


def compass_search(function: Callable[[np.ndarray], float], start, steps, *, min_step: float = 1e-6,
                   max_cycles: int = 10_000) -> tuple[np.ndarray, float, int, int]:
    """Coordinate (compass) search with step halving, as in the source thesis.

    Each cycle tries +step and −step along every coordinate in turn, keeping
    any improvement; a cycle without improvement halves all steps. Stops when
    the steps are below ``min_step`` × their initial sizes.

    Returns
    -------
    (x, f(x), cycles, evaluations)
    """
    x = np.array(start, dtype=float)
    steps = np.array(steps, dtype=float)
    smallest = steps * min_step
    best = function(x)
    evaluations, cycles = 1, 0
    while np.any(steps > smallest) and cycles < max_cycles:
        cycles += 1
        improved = False
        for j in range(len(x)):
            for sign in (1.0, -1.0):
                trial = x.copy()
                trial[j] += sign * steps[j]
                value = function(trial)
                evaluations += 1
                if value < best:
                    x, best, improved = trial, value, True
                    break
        if not improved:
            steps = steps / 2
    return x, best, cycles, evaluations


def _with_weight(lever: LeverBalancer, weight) -> LeverBalancer:
    m, x, y = weight
    return replace(lever, coupler=replace(lever.coupler, mass=float(m), cg=(float(x), float(y))))


def _as_weight(p: np.ndarray, fallback: tuple[float, float]) -> tuple[float, float, float]:
    """(m, x_G, y_G) from p; a zero mass keeps the old CG (it does not matter)."""
    m = float(p[0])
    if m <= 1e-12 * max(1.0, abs(p[1]), abs(p[2])):
        return 0.0, *fallback
    return m, float(p[1] / m), float(p[2] / m)


def _breakdown(scene: Scene, problem: LeverProblem, request: LeverDesignRequest, before: np.ndarray,
               after: np.ndarray, w2: float, objective_values):
    """Criterion per signal and the transverse force per order, before/after."""
    import xarray as xr

    kmax = min(BREAKDOWN_ORDERS, scene.sampling.max_order)
    per_signal = {}
    for label, p in (("start", before), ("optimum", after)):
        values = problem.values(p) * w2
        per_signal[label] = [criterion(values[[i]], request.objective, request.orders, request.weights)
                             for i in range(len(problem.signals))]
    force = {}
    force_signals = ("force_y", "force_z")
    force_problem = problem if problem.signals == force_signals else lever_problem(
        scene, replace(request, signals=force_signals), len(problem.theta))
    for label, p in (("start", before), ("optimum", after)):
        fy, fz = force_problem.values(p) * w2
        spec = phasors(np.stack([fz, -scene.sense * fy]))  # w = z + i·t, t = −sense·y
        co, counter = rotating_split(spec[0, : kmax + 1], spec[1, : kmax + 1])
        force[label] = np.abs(np.stack([co, counter], axis=-1))
    units = ["N" if s.startswith("force") else "N m" for s in problem.signals]
    return xr.Dataset(
        {
            "criterion": (("weight", "signal"), np.array([per_signal["start"], per_signal["optimum"]]),
                          {"long_name": f"{request.objective} per signal", "units": units[0]}),
            "force": (("weight", "order", "rotation"), np.stack([force["start"], force["optimum"]]),
                      {"units": "N", "long_name": "free force per order (magnitude)"}),
            "total": (("weight",), np.array(objective_values), {"long_name": f"{request.objective}, all signals"}),
        },
        {"weight": ["start", "optimum"], "signal": list(problem.signals), "order": np.arange(kmax + 1),
         "rotation": ["co", "counter"], "signal_units": ("signal", units)},
    )


def design_lever(scene: Scene, request: LeverDesignRequest | None = None, *, method: str = "exact",
                 name: str | None = None, description: str | None = None) -> LeverDesign:
    """The optimal balance weight of a lever balancer.

    Parameters
    ----------
    scene : Scene
        With a ``[[lever_balancer]]``; its coupler's mass and CG are the start.
    request : LeverDesignRequest, optional
        Default: the scene's ``[design]`` table.
    method : {"exact", "compass"}
        "exact" solves the linear (or quadratic) programme; "compass" runs the
        thesis's coordinate search from the scene's weight, inside the bounds.
    name, description : str, optional
        ``engine.name`` and ``engine.description`` of the output scene.

    Returns
    -------
    LeverDesign
    """
    from ..scene import SceneError, scene_from_text

    request = _lever_request(scene, request)
    index, lever = _lever(scene, request.lever)
    problem = lever_problem(scene, request)
    speed = scene.speeds[0]
    w2 = speed**2
    start = (lever.coupler.mass, *lever.coupler.cg)
    p_start = _weight_p(lever.coupler)
    length = lever.coupler_length

    def judge(p) -> float:
        return criterion(problem.values(p) * w2, request.objective, request.orders, request.weights)

    bounds = _envelope(request, length)
    _check_bounds(bounds)
    g, h = _constraints(bounds)
    evaluations = cycles = 0
    clock = time.perf_counter()
    if method == "exact":
        p, used = _exact_optimum(scene, lever, problem, request, (g, h))
    elif method == "compass":
        p, cycles, evaluations = _compass_optimum(scene, lever, problem, request, (g, h))
        used = "compass"
    else:
        raise ValueError(f"unknown method {method!r}: 'exact' or 'compass'")
    seconds = time.perf_counter() - clock
    weight = _as_weight(p, lever.coupler.cg)
    value_start, value = judge(p_start), judge(p)
    breakdown = _breakdown(scene, problem, request, p_start, p, w2, (value_start, value))

    designed = _with_weight(lever, weight)
    levers = scene.levers[:index] + (designed,) + scene.levers[index + 1:]
    exact = _exact_criterion(replace(scene, levers=levers), problem, request)
    scale_value = float(np.abs(problem.rest).max() + np.abs(problem.basis @ p).max()) * w2
    tolerance = 1e-9 * (scale_value**2 if request.objective == "orders" else scale_value) * len(request.signals)
    text = _scene_text(scene, index, designed, request, used, (value_start, value), name, description)
    try:
        out = scene_from_text(text, f"{scene.source} (designed)", files=dict(scene.files) or None)
    except SceneError as exc:  # e.g. a weight outside the reader's ranges
        raise DesignError(f"the designed scene does not load:\n{exc}") from None
    messages = []
    if weight[0] == 0.0:
        messages.append("the optimum is no weight at all: the lever balancer makes the criterion worse")
    if not _same(out, scene, levers):
        messages.append("the scene was changed in Python after it was read: the output text is its file's with the "
                        "new weight, not this scene")
    return LeverDesign(request=request, lever=lever.label, method=used, speed=speed, start=start, weight=weight,
                       criterion_start=value_start, criterion=value, exact_criterion=exact, tolerance=tolerance,
                       verified=abs(exact - value) <= tolerance, breakdown=breakdown, seconds=seconds,
                       evaluations=evaluations, cycles=cycles, messages=tuple(messages), text=text, scene=out)


def _lever_request(scene: Scene, request: LeverDesignRequest | None) -> LeverDesignRequest:
    """The request :func:`design_lever` solves (default the scene's ``[design]``), refused if it is not one."""
    chosen = request or scene.design
    if not isinstance(chosen, LeverDesignRequest):
        raise DesignError(f"{scene.source}: no [design.lever] table: say which lever balancer's weight to "
                               "optimise (docs/lever.md)")
    request = chosen
    if request.objective not in LEVER_OBJECTIVES or any(s not in LEVER_SIGNALS for s in request.signals):
        raise DesignError(f"objective must be one of {LEVER_OBJECTIVES} and signals of {LEVER_SIGNALS}")
    if request.objective == "orders" and max(request.orders) > scene.sampling.max_order:
        raise DesignError(f"{scene.source}: design.orders must not exceed sampling.max_order")
    return request


def _exact_optimum(scene: Scene, lever: LeverBalancer, problem: LeverProblem, request: LeverDesignRequest,
                   constraints: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, str]:
    """The optimal weight's parameters by the linear programme (the
    quadratic one for the "orders" objective) within the bounds ``g p ≤ h``,
    and which ("lp" or "qp"); a weight that is not finite is refused."""
    g, h = constraints
    mass, length = max(lever.coupler.mass, 1.0), lever.coupler_length
    scale = np.array([mass, mass * length, mass * length])
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # a weight not finite is refused
            if request.objective == "orders":
                p = _solve_qp(problem, request.orders, request.weights, g, h, scale)
                used = "qp"
            else:
                p = _solve_lp(problem, request.objective, g, h, scale)
                used = "lp"
    except (np.linalg.LinAlgError, FloatingPointError) as exc:
        raise DesignError(f"{scene.source}: the lever design's linear algebra failed ({exc}): check the lever "
                          "balancer's geometry and masses and design.lever's bounds") from None
    if not np.isfinite(p).all():
        raise DesignError(f"{scene.source}: the lever design gives a weight that is not finite: check the lever "
                          "balancer's geometry and masses and design.lever's bounds")
    return p, used


def _compass_optimum(scene: Scene, lever: LeverBalancer, problem: LeverProblem, request: LeverDesignRequest,
                     constraints: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, int, int]:
    """The thesis's compass search from the scene's weight, inside the
    bounds ``g p ≤ h``, on the full model: the weight's parameters and the
    search's cycles and evaluations."""
    g, h = constraints
    black_box = _black_box(scene, lever, request, problem.theta)
    start, length = (lever.coupler.mass, *lever.coupler.cg), lever.coupler_length

    def bounded(weight) -> float:  # the search stays inside the bounds
        return black_box(weight) if np.all(g @ _weight_p(_with_weight(lever, weight).coupler) <= h) else math.inf

    best, _, cycles, evaluations = compass_search(
        bounded, start, (0.1 * max(start[0], 0.1), 0.05 * length, 0.05 * length))
    return _weight_p(_with_weight(lever, best).coupler), cycles, evaluations


def _exact_criterion(designed: Scene, problem: LeverProblem, request: LeverDesignRequest) -> float:
    """The criterion of the scene with the new weight by the full
    time-domain model: the judge, independent of the affine map."""
    from ..views.time import simulate

    time_ds = simulate(designed, samples_per_rev=len(problem.theta))
    if "speed" in time_ds.dims:
        time_ds = time_ds.isel(speed=0)
    return criterion(_signals(time_ds.force.values, time_ds.moment.values, request.signals), request.objective,
                     request.orders, request.weights)


def _same(out: Scene, scene: Scene, levers: tuple[LeverBalancer, ...]) -> bool:
    """Whether the output scene read from its text is ``scene`` with ``levers``
    (weights to the 1e-13 that writing decimals costs; names and the
    [design]/[verify] tables aside)."""
    def engine(s: Scene) -> Scene:
        return replace(s, levers=(), name="", description="", design=None, verify=None, source="", source_text="")

    def weight(lever: LeverBalancer) -> np.ndarray:
        return np.array([lever.coupler.mass, *lever.coupler.cg])

    return (engine(out) == engine(scene) and len(out.levers) == len(levers)
            and all(a == replace(b, coupler=replace(b.coupler, mass=a.coupler.mass, cg=a.coupler.cg))
                    and np.allclose(weight(a), weight(b), rtol=1e-13, atol=1e-15) for a, b in zip(levers, out.levers)))


def _scene_text(scene: Scene, index: int, lever: LeverBalancer, request: LeverDesignRequest, method: str,
                values: tuple[float, float], name: str | None, description: str | None) -> str:
    """The input scene's text without [design] and [verify], with the lever's
    coupler mass and CG replaced (comments kept). Falls back to a plain TOML
    dump if the text cannot be edited safely."""
    import tomllib

    import tomli_w

    from .._version import __version__
    from ..scene.writer import HEADER, length_text, quantity_text, with_engine, without_tables

    mass = quantity_text(lever.coupler.mass, "kg")
    cg = [length_text(v) for v in lever.coupler.cg]
    original = tomllib.loads(scene.source_text)
    expected = {k: v for k, v in original.items() if k not in ("design", "verify")}
    entries = [dict(e) for e in expected["lever_balancer"]]
    entries[index]["coupler"] = {**entries[index]["coupler"], "mass": mass, "cg": cg}
    expected["lever_balancer"] = entries
    engine = {k: v for k, v in (("name", name), ("description", description)) if v is not None}
    expected["engine"] = {**expected["engine"], **engine}
    unit = "N m" if any(s.startswith("moment") for s in request.signals) else "N"
    units = unit + "²" if request.objective == "orders" else unit
    rpm = scene.speeds[0] * 30 / math.pi
    note = (f"# Balance weight of {lever.label!r} designed by harmbal {__version__} ({method}, objective "
            f"{request.objective} of {', '.join(request.signals)}): {values[0]:.6g} -> {values[1]:.6g} {units} "
            f"at {rpm:.6g} rpm")
    lines, entry, section, done = [], -1, None, set()
    for line in with_engine(without_tables(scene.source_text, {"design", "verify"}), engine).splitlines():
        match = HEADER.match(line)
        if match:
            section = match.group(1).replace(" ", "")
            if section == "lever_balancer" and line.lstrip().startswith("[["):
                entry += 1
            if section == "lever_balancer.coupler" and entry == index:
                lines.append(note)
        elif section == "lever_balancer.coupler" and entry == index:
            key = line.split("=", 1)[0].strip()
            if key in ("mass", "cg") and key not in done:
                value = mass if key == "mass" else "[" + ", ".join(f'"{v}"' for v in cg) + "]"
                old = line.split("=", 1)[1].split("#", 1)[0].strip()
                line = f"{key} = {value if key == 'cg' else chr(34) + value + chr(34)}  # was {old}"
                done.add(key)
        lines.append(line)
    text = "\n".join(lines) + "\n"
    try:
        if done == {"mass", "cg"} and tomllib.loads(text) == expected:
            return text
    except tomllib.TOMLDecodeError:
        pass
    return note + "\n" + tomli_w.dumps(expected)
