"""Design of balancers order by order, with their phasing.

Every balancer element is a static unbalance P = U·e^{iα} (mass × radius and
its angle at θ = 0) turning at n × crank speed; its loads on the block are
pure order-|n| phasors, linear in (Re P, Im P). So, per order, cancelling the
engine's free force and moment phasors is a small real linear problem
A·z = −b: the columns of A are the unit responses of the unknowns (computed
by the same code that simulates the elements, :mod:`harmbal.model.balancers`), b
the engine's phasors from :func:`harmbal.orders.phasors.order_phasors`. It is
solved by least squares in order of priority
(:mod:`harmbal.balance.least_squares`), the force first, then the
moment, then the roll moment: each exact where it can be, least squares where
it cannot, without giving up what the one before achieved; among the designs
that remain, the smallest unbalances. What is left is reported component by
component, in words where it cannot be cancelled.

Two refinements:

* crank counterweights with a *balance factor* f are not solved but sized by
  the classic rule: they cancel the rotating masses' first-order force and
  moment plus 2f times the co-rotating half of the reciprocating masses'
  (f = 0.5 cancels all of the co-rotating first order), split over their
  planes for static and couple balance;
* the *peak* objective keeps the cancelled components as equality
  constraints and spends the remaining freedom on the smallest peak over the
  revolution of chosen signals (e.g. the moments about y and z): the signals
  are linear in the unknowns, so this is a linear programme
  (scipy.optimize.linprog) over the sampled revolution, exact at the samples.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import tomllib
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model.balancers import shaft_loads
from ..model.evaluate import evaluate, moment_about
from ..orders.phasors import OrderPhasors, order_phasors
from ..orders.spectrum import ZERO, ZERO_RTOL, classify, zero_below_round_off
from ..scene import Scene, SceneError, scene_from_text
from ..scene.elements import Shaft
from ..scene.requests import COMPONENTS, PEAK_SAMPLES, Candidate, DesignRequest, LeverDesignRequest, signed_ratio
from ..scene.writer import (
    angle_text,
    blank_table,
    length_text,
    quantity_text,
    signed_angle_text,
    toml_tables,
    with_engine,
    without_tables,
)
from .counterweights import SizedBlank, size_blank
from .least_squares import (
    RANK_RTOL,
    component_phasors,
    design_targets,
    element_phasors,
    element_shafts,
    prioritised_least_squares,
    response_matrix,
    target_rows,
)
from .sanity import check_conditioning, size_error
from .solvers import LP_TOLERANCES, BalancerDesign, DesignError
from .verify import (
    CHECKED_ORDER,
    WORSENED_VALUES,
    checked_orders,
    describe_component,
    engine_scales,
    made_worse_check,
    residual_spectra,
    spectrum_components,
    verify_samples,
    worsened_rows_of_arrays,
    worsened_sentences,
)

#: A Lanchester pair's two unbalances are written as one pair (one size, the
#: mean) if they differ by at most this share: round-off of a standing vector's
#: equal halves. The mean moves each shaft's load by at most half of it, far
#: below the zero level even for elements at the size limit (sanity.py).
PAIR_RTOL = 1e-14

#: Sides of the polygon inscribed in the circle |P| ≤ max_unbalance that the
#: linear programme uses (it gives away at most 1 − cos(π/64) = 0.12 %).
BOUND_SIDES = 64


@dataclass(frozen=True)
class Design(BalancerDesign):
    """The result of :func:`design` for balancer elements.

    ``scene`` is the scene with the designed elements, loaded from ``text``,
    the scene file harmbal writes (it has a ``[verify]`` table with the
    targets and the predicted residuals, and no ``[design]`` table).
    ``elements`` are the designed balancer elements; ``dataset`` holds, per
    targeted order and component, the value without the new elements, the
    predicted residual and whether it is cancelled, and over every order the
    components made worse; ``messages`` explain in words what could not be
    cancelled; ``worsened`` names, one sentence each, the components that
    are not targeted and that the new elements make worse (warnings: they do
    not make the design infeasible).
    """

    scene: Scene
    text: str
    elements: tuple[Shaft, ...]
    arrays: tuple[dict, dict, dict]
    messages: tuple[str, ...]
    worsened: tuple[str, ...] = ()
    #: The written scene's exact model on verify's samples, as design judged it (for verify to reuse).
    evaluation: Any = dataclasses.field(default=None, repr=False, compare=False)

    @functools.cached_property
    def dataset(self):
        """The Dataset of :attr:`arrays` (its variables, coordinates and
        attributes), built on first use: a table needs only the arrays."""
        import xarray as xr

        data, coords, attrs = self.arrays
        return xr.Dataset(data, coords, dict(attrs))

    @property
    def feasible(self) -> bool:
        """True if every targeted component is cancelled."""
        return not self.messages

    def __repr__(self) -> str:
        """What was designed (elements, unbalance [kg mm], angle [deg]) and
        what remains (targets before → predicted [N or N m], made worse)."""
        from .summaries import design_text

        return design_text(self.dataset, self.scene.name, self.messages, self.worsened)

    def _repr_html_(self) -> str:
        """:meth:`__repr__` as HTML tables, for notebooks."""
        from .summaries import design_html

        return design_html(self.dataset, self.scene.name, self.messages, self.worsened)


def _element_loads(placements, value: complex, theta: np.ndarray, sense: int, ref: np.ndarray):
    force, moment = shaft_loads(element_shafts("", placements, value), theta, sense)
    return force, moment_about(ref, force, moment)


def factor_scenes(scene: Scene) -> tuple[Scene, Scene]:
    """The two scenes whose phasors the balance-factor rule sizes counterweights
    by: the rotating masses with the counterweights already on the crank, and
    the reciprocating masses."""
    on_crank = tuple(e for e in scene.shafts if e.on_crank)
    return (dataclasses.replace(scene.with_effects({"rotating", "balancers"}), shafts=on_crank),
            scene.with_effects({"reciprocating"}))


def factor_system(candidate: Candidate, kmax: int, sense: int, ref: np.ndarray,
                  weights: dict[str, float]) -> tuple[np.ndarray, list[tuple[int, str]]]:
    """The balance-factor rule's matrix and its targets: the first-order
    co-rotating force, and moment if there is more than one plane."""
    rows = [(1, "force_co")] + ([(1, "moment_co")] if len(candidate.planes) > 1 else [])
    return response_matrix(candidate.unknowns(), rows, kmax, sense, ref, weights), rows


def _factor_counterweights(scene: Scene, candidate: Candidate, kmax: int, ref: np.ndarray,
                           weights: dict[str, float]) -> np.ndarray:
    """Unknowns of counterweights sized by the balance-factor rule: together
    with the counterweights already on the crank they cancel the first-order
    co-rotating force and moment (static balance alone with one plane) of the
    rotating masses (throw and crankshaft unbalances, rod big ends, the
    crankshaft's own CG) plus 2f × those of the reciprocating masses."""
    rot, rec = (order_phasors(evaluate(s)) for s in factor_scenes(scene))
    f = candidate.balance_factor
    assert f is not None  # only candidates sized by a balance factor come here
    target = component_phasors(rot.force + 2 * f * rec.force, rot.moment + 2 * f * rec.moment, scene.sense)
    a, rows = factor_system(candidate, kmax, scene.sense, ref, weights)
    return np.linalg.lstsq(a, -target_rows(target, rows, weights), rcond=None)[0]


def _with_elements(force: np.ndarray, moment: np.ndarray, candidates, values, kmax: int, sense: int,
                   ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis phasors (axis, order) plus those of the candidates at their
    designed values."""
    force, moment = force.copy(), moment.copy()
    for c in candidates:
        for placements, v in zip(c.unknowns(), values[c.label]):
            f, m = element_phasors(placements, v, kmax, sense, ref)
            force += f
            moment += m
    return force, moment


def _remedy(order: int, name: str) -> str:
    if name == "roll":
        return f"shafts at ±{order}× set off the crank axis, e.g. a ±{order}× Lanchester pair at different heights"
    if name.endswith("_co"):
        return "crank counterweights or a +1× shaft" if order == 1 else f"a +{order}× shaft"
    return f"a −{order}× shaft"


def check_request(scene: Scene, request: DesignRequest | None) -> None:
    """Refuse a request that cannot be set up: none, a scene that does not
    simulate balancers, orders or shaft ratios above the scene's max_order."""
    if request is None:
        raise DesignError(f"{scene.source}: no [design] table: say which orders to balance with which elements "
                          "(docs/design.md)")
    if "balancers" not in scene.model.effects:
        raise DesignError(f"{scene.source}: model.effects: add \"balancers\"; without it the designed elements "
                          "would not be simulated")
    kmax = scene.sampling.max_order
    if max(request.orders) > kmax or max((abs(c.ratio) for c in request.candidates), default=0) > kmax:
        raise DesignError(f"{scene.source}: design.orders: orders and shaft ratios must not exceed "
                          f"sampling.max_order = {kmax}")


def design(scene: Scene, request: DesignRequest | LeverDesignRequest | None = None, *, name: str | None = None,
           description: str | None = None) -> BalancerDesign:
    """Design balancer elements order by order and write them into a scene.

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`; its existing balancer elements are
        part of the engine being balanced.
    request : DesignRequest or LeverDesignRequest, optional
        What to design; default the scene's ``[design]`` table. A
        :class:`~harmbal.scene.requests.LeverDesignRequest` is passed on to
        :func:`harmbal.balance.lever.design_lever`, which returns a
        :class:`~harmbal.balance.lever.LeverDesign`.
    name, description : str, optional
        ``engine.name`` and ``engine.description`` of the output scene;
        default the input's.

    Returns
    -------
    BalancerDesign
        A :class:`Design` (a :class:`~harmbal.balance.lever.LeverDesign` for
        a lever request, as described there): the designed elements, the output scene (text and loaded), the
        predicted residuals and messages on what cannot be cancelled; and,
        over every order 1 … ``max_order`` (dim ``checked_order``), the
        components that are not targeted and that the new elements make
        worse (``dataset["worsened"]``, ``Design.worsened`` in words): free
        with them and grown by more than the negligible level
        (``force_negligible_level`` [N], ``moment_negligible_level`` [N m]:
        the scene's ``[model] negligible`` × the designed scene's load scale
        / the number of cylinders, at the design speed).

    Raises
    ------
    DesignError
        If there is no request, it targets orders the scene does not keep,
        the scene does not simulate balancers, its loads are not finite, or
        the request is ill-conditioned (:mod:`harmbal.balance.sanity`:
        candidates that act on a target only weakly, elements beyond 1000
        times the engine's own unbalance), naming the keys to change.

    Notes
    -----
    A target is cancelled when the residual of the elements as written is
    of the class zero (ZERO_RTOL) of the engine's load scale without any
    balancer element (:func:`harmbal.balance.verify.engine_scales`), checked
    on the written scene as :func:`harmbal.verify` evaluates it: what design
    calls cancelled verifies as zero.
    """
    request = request or scene.design
    if isinstance(request, LeverDesignRequest):
        from .lever import design_lever

        return design_lever(scene, request, name=name, description=description)
    check_request(scene, request)
    assert request is not None  # check_request refuses None
    plan, solution = _planned_and_solved(scene, request)
    values, ok, predicted = solution.values, solution.ok, solution.predicted
    w2 = scene.speeds[0] ** 2
    before = {n: zero_below_round_off(v, plan.zero_scales[n])
              for n, v in component_phasors(plan.engine.force, plan.engine.moment, scene.sense).items()}

    blanks: dict[str, SizedBlank] = {}  # filled as the elements are written
    designed, text = _designed_scene(scene, request, values, predicted, {"name": name, "description": description},
                                     plan.negligible, blanks)
    labels = {e.label for e in scene.shafts}
    elements = tuple(e for e in designed.shafts if e.label not in labels)
    # The written scene judged as verify judges it: what design calls cancelled must verify as zero.
    unit = evaluate(designed, verify_samples(designed))
    confirmed = _confirm(unit, plan, ok, predicted)
    if confirmed is not None:
        ok, predicted = confirmed
        designed, text = _designed_scene(scene, request, values, predicted, {"name": name,
                                                                             "description": description},
                                         plan.negligible, blanks)
    messages = _messages(request, plan.targets, ok, predicted, before, w2, scene.speeds[0], solution)
    messages += _height_hints(request, values, predicted, ok, plan.frame, w2,
                              ZERO_RTOL * plan.zero_scales["roll"])
    messages += _bound_messages(request, values)
    data = {**_design_variables(request, plan, before, predicted, ok, values, w2), **_made_worse(plan, designed, unit)}
    coords = _design_coords(scene, request, plan)
    attrs = {
        "title": f"harmbal balancer design: {scene.name}",
        "engine": scene.name,
        "objective": request.objective,
        "cancel": " ".join(request.cancel),
        "feasible": "no" if messages else "yes",
        "messages": "\n".join(messages),
        "blanks": "\n".join(_blank_note(label, sized) for label, sized in blanks.items()),
        "negligible": scene.model.negligible,
        "zero_rtol": ZERO_RTOL,
    }
    checked = {name: np.asarray((data if name in data else coords)[name][1]) for name in WORSENED_VALUES}
    worsened = worsened_sentences(worsened_rows_of_arrays(checked), by="the designed elements")
    attrs["worsened"] = "\n".join(worsened)
    return Design(scene=designed, text=text, elements=elements, arrays=(data, coords, attrs), messages=tuple(messages),
                  worsened=tuple(worsened), evaluation=unit)


def _planned_and_solved(scene: Scene, request: DesignRequest) -> tuple[_Plan, _Solution]:
    """:func:`design`'s plan and solution; failed linear algebra and elements
    beyond the size limit are refused (:class:`DesignError`)."""
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # non-finite results are refused
            plan = _plan(scene, request)
            solution = _solve(scene, request, plan)
    except (np.linalg.LinAlgError, FloatingPointError) as exc:
        raise DesignError(f"{scene.source}: the design's linear algebra failed ({exc}): check the scene's masses "
                          "and lengths and the [design] candidates' planes and positions") from None
    error = size_error(scene.source, request.candidates, solution.written, plan.zero[0])
    if error is not None:
        raise error
    return plan, solution


def _design_variables(request: DesignRequest, plan: _Plan, before, predicted, ok, values, w2: float) -> dict:
    """The variables of :func:`design`'s Dataset per targeted order and
    component (at the design speed, ``w2`` = ω²) and per designed element."""
    target_names = [n for n, _ in COMPONENTS]
    return {
        "before": (("order", "component"), w2 * np.array([[before[n][k] for n in target_names]
                                                             for k in request.orders]),
                   {"long_name": "phasor without the designed elements", "units_by_component": "component_units"}),
        "predicted": (("order", "component"), w2 * np.array([[predicted[n][k] for n in target_names]
                                                                for k in request.orders]),
                      {"long_name": "residual phasor the design predicts", "units_by_component": "component_units"}),
        "targeted": (("order", "component"), np.array([[(k, n) in plan.targets for n in target_names]
                                                        for k in request.orders])),
        "cancelled": (("order", "component"), np.array([[ok.get((k, n), False) for n in target_names]
                                                         for k in request.orders])),
        "unbalance": ("element", [abs(v) for c in request.candidates for v in values[c.label]],
                      {"units": "kg m", "long_name": "designed unbalance (mass x radius)"}),
        "unbalance_angle": ("element", [float(np.angle(v)) for c in request.candidates for v in values[c.label]],
                            {"units": "rad", "long_name": "direction of the unbalance at theta = 0"}),
    }


def _design_coords(scene: Scene, request: DesignRequest, plan: _Plan) -> dict:
    """The coordinates of :func:`design`'s Dataset."""
    target_names = [n for n, _ in COMPONENTS]
    return {
        "order": ("order", list(request.orders), {"long_name": "order of crank speed"}),
        "component": ("component", target_names),
        "component_units": ("component", ["N" if g == "force" else "N m" for _, g in COMPONENTS]),
        "element": ("element", [n for c in request.candidates for n in c.names()]),
        "speed": ((), scene.speeds[0], {"units": "rad/s"}),
        "rpm": ((), scene.speeds[0] * 30 / math.pi, {"units": "rpm"}),
        CHECKED_ORDER: (CHECKED_ORDER, checked_orders(plan.frame[0]), {"long_name": "order compared for components "
                                                                                    "made worse"}),
    }


@dataclass(frozen=True)
class _Plan:
    """What :func:`design` solves: the engine's order phasors, the row
    ``weights`` (1 / the load scales of the scene as given, existing elements
    included), the ``zero`` scales (force [N], moment [N m] at unit speed: the
    engine alone, :func:`~harmbal.balance.verify.engine_scales`, the scale
    verify judges by) and per component ``zero_scales``; the targets, the
    ``negligible`` unbalance [kg m] below which an element is not written, and
    ``frame`` = (max_order, sense, reference point)."""

    engine: OrderPhasors
    weights: dict[str, float]
    zero: tuple[float, float]
    zero_scales: dict[str, float]
    targets: list[tuple[int, str]]
    negligible: float
    frame: tuple[int, int, np.ndarray]


def _plan(scene: Scene, request: DesignRequest) -> _Plan:
    """The engine's phasors and the scales that weigh and judge the design;
    loads that are not finite are refused (they would give a design of NaN)."""
    unit = evaluate(scene)
    engine = order_phasors(unit)
    force_scale, moment_scale = unit.force_scale, unit.moment_scale
    zero = engine_scales(scene, unit)
    if not all(math.isfinite(v) for v in (force_scale, moment_scale, *zero)) or not (
            np.isfinite(engine.force).all() and np.isfinite(engine.moment).all()):
        raise DesignError(f"{scene.source}: the engine's loads are not finite (force scale {force_scale:.3g} N, "
                          f"moment scale {moment_scale:.3g} N m at 1 rad/s): check the scene's masses, lengths and "
                          "unbalances")
    scales = {name: force_scale if group == "force" else moment_scale for name, group in COMPONENTS}
    return _Plan(engine=engine, weights={name: 1.0 / s if s > 0 else 1.0 for name, s in scales.items()}, zero=zero,
                 zero_scales={name: zero[0] if group == "force" else zero[1] for name, group in COMPONENTS},
                 targets=design_targets(request), negligible=ZERO_RTOL * force_scale,
                 frame=(scene.sampling.max_order, scene.sense, np.asarray(scene.reference_point, dtype=float)))


@dataclass(frozen=True)
class _Solution:
    """The solved design: each candidate's unknowns as solved (``values``) and
    as written (``written``: those too small to write are 0), the targets
    cancelled by the elements as written (``ok``) and by every unbalance
    solved (``ok_solved``), the residual phasors (component -> (order,)) at
    unit speed of the elements as written, 0 where cancelled, and the weighted
    matrix ``a`` of the free unknowns."""

    values: dict[str, list[complex]]
    written: dict[str, list[complex]]
    ok: dict[tuple[int, str], bool]
    ok_solved: dict[tuple[int, str], bool]
    predicted: dict[str, np.ndarray]
    a: np.ndarray


def _solve(scene: Scene, request: DesignRequest, plan: _Plan) -> _Solution:
    """The unknowns of every candidate: the balance-factor counterweights by
    their rule, the others by the prioritised least squares (or the peak LP),
    after refusing an ill-conditioned request; then the residual of the
    elements as written."""
    (kmax, sense, ref), weights, targets = plan.frame, plan.weights, plan.targets
    fixed = [c for c in request.candidates if c.balance_factor is not None]
    free = [c for c in request.candidates if c.balance_factor is None]
    values: dict[str, list[complex]] = {}
    for c in fixed:  # the engine, with the counterweights that the balance-factor rule sizes
        z = _factor_counterweights(scene, c, kmax, ref, weights)
        values[c.label] = list(z[0::2] + 1j * z[1::2])
    base_force, base_moment = _with_elements(plan.engine.force, plan.engine.moment, fixed, values, *plan.frame)
    b = target_rows(component_phasors(base_force, base_moment, sense), targets, weights)
    unknowns = [u for c in free for u in c.unknowns()]
    check_conditioning(scene, free, targets)
    a = response_matrix(unknowns, targets, kmax, sense, ref, weights)
    z = prioritised_least_squares(a, b, targets)
    if request.objective == "peak" and unknowns:
        ok = _cancelled(_residual_components(plan, fixed + free, {**values, **_unpack(free, z)}), targets, plan)
        z = _peak_design(scene, request, free, unknowns, z, a, b, ok, ref, fixed=(fixed, values))
        z = _onto_cancelled(z, a, b, ok)
    values.update(_unpack(free, z))
    if not all(np.isfinite(v) for vs in values.values() for v in vs):
        raise DesignError(f"{scene.source}: the design is not finite: check the [design] candidates' planes and "
                          "positions and the scene's masses")
    written = _written(request.candidates, values, plan.negligible)
    predicted = _residual_components(plan, request.candidates, written)
    ok = _cancelled(predicted, targets, plan)
    ok_solved = _cancelled(_residual_components(plan, request.candidates, values), targets, plan)
    for (k, component), cancelled in ok.items():
        if cancelled:  # round-off, not a prediction: no noise phase
            predicted[component][k] = 0
    return _Solution(values, written, ok, ok_solved, predicted, a)


def _unpack(free, z: np.ndarray) -> dict[str, list[complex]]:
    """The complex unknowns of each free candidate from the real vector z."""
    values, i = {}, 0
    for c in free:
        n = len(c.unknowns())
        values[c.label] = list(z[2 * i:2 * (i + n):2] + 1j * z[2 * i + 1:2 * (i + n):2])
        i += n
    return values


def _written(candidates, values, negligible: float) -> dict[str, list[complex]]:
    """The unknowns as the scene text writes them: 0 where every placement's
    unbalance is at most ``negligible`` [kg m] (left out, :func:`_elements_toml`)."""
    return {c.label: [v if max(abs(p.coefficient * v) for p in u) > negligible else 0j
                      for u, v in zip(c.unknowns(), values[c.label])] for c in candidates}


def _residual_components(plan: _Plan, candidates, values) -> dict[str, np.ndarray]:
    """The components (name -> (order,)) at unit speed of the engine with the
    candidates at ``values``."""
    return component_phasors(*_with_elements(plan.engine.force, plan.engine.moment, candidates, values, *plan.frame),
                       plan.frame[1])


def _onto_cancelled(z: np.ndarray, a: np.ndarray, b: np.ndarray, ok) -> np.ndarray:
    """``z`` moved the least onto the cancelled targets' rows: the linear
    programme meets its equality constraints only to its feasibility tolerance
    (1e-10 of the weighted rows), the zero level itself; what design calls
    cancelled must be cancelled to round-off."""
    keep = [r for r, t in enumerate(ok) if ok[t]]
    if not keep:
        return z
    rows = keep + [r + len(ok) for r in keep]
    step = np.linalg.lstsq(a[rows], b[rows] + a[rows] @ z, rcond=RANK_RTOL)[0]
    return z - step


def _designed_scene(scene: Scene, request: DesignRequest, values, predicted, engine: dict, negligible: float,
                    blanks: dict) -> tuple[Scene, str]:
    """The output scene, loaded from its text (the judge of what is written), and the text."""
    text = _scene_text(scene, request, values, predicted, engine, negligible=negligible, blanks=blanks)
    try:
        files = dict(scene.files) or None  # the trace files the scene read: not read again
        designed = dataclasses.replace(scene_from_text(text, f"{scene.source} (designed)", files=files),
                                       source=scene.source)
    except SceneError as exc:  # e.g. a candidate's label already names an element of the scene
        raise DesignError(f"the designed scene does not load:\n{exc}") from None
    return designed.with_negligible(scene.model.negligible), text  # e.g. set by --negligible, not in the text


def _confirm(unit, plan: _Plan, ok, predicted):
    """The targets and predictions judged on the written scene's exact model
    (``unit``, evaluated as :func:`harmbal.verify` evaluates it, the residual
    by its very code): a target design cancelled whose exact residual is not
    of the class zero is not cancelled, and a prediction the exact residual
    leaves more than half the zero level from is replaced by the exact
    residual (text, angles rounded to the text's precision, the order
    domain's sampling). None if nothing changes (the rule; the elements as
    written are what the order domain solved)."""
    kmax, sense, _ = plan.frame
    exact = dict(zip([n for n, _ in COMPONENTS], spectrum_components(residual_spectra(unit, kmax)[0], sense)))
    ok, predicted, changed = dict(ok), {n: v.copy() for n, v in predicted.items()}, False
    for (k, name), cancelled in ok.items():
        e, zero = exact[name][k], ZERO_RTOL * plan.zero_scales[name]
        if cancelled and classify(abs(e), plan.zero_scales[name], 0.0) != ZERO:
            ok[(k, name)], predicted[name][k], changed = False, e, True
        elif not cancelled and abs(e - predicted[name][k]) > zero / 2:
            predicted[name][k], changed = e, True
    return (ok, predicted) if changed else None


def _made_worse(plan: _Plan, designed: Scene, unit) -> dict:
    """The made-worse check of every order and component at the design
    speed: the engine's order phasors (with the elements it already has)
    against those of the designed scene on verify's samples (``unit``),
    judged by the engine's load scales (without any balancer element, the
    scales :func:`harmbal.verify` judges by), with ``force_scale`` [N] and
    ``moment_scale`` [N m]."""
    designed_phasors = order_phasors(unit)
    w2 = designed.speeds[0] ** 2
    scales = (w2 * plan.zero[0], w2 * plan.zero[1])
    names = [n for n, _ in COMPONENTS]
    before, after = (w2 * np.array([component_phasors(p.force, p.moment, designed.sense)[n] for n in names])[:, 1:].T
                     for p in (plan.engine, designed_phasors))  # (order 1 … max_order, component)
    targeted = np.array([[(k, n) in plan.targets for n in names]
                         for k in checked_orders(designed.sampling.max_order)])
    return {**made_worse_check(before, after, targeted, scales, len(designed.cylinders), designed.model.negligible),
            **{f"{kind}_scale": ((), s, {"units": units, "long_name": f"sum of single-body peak {kind}s without "
                                                                       "balancer elements"})
               for kind, units, s in (("force", "N", scales[0]), ("moment", "N m", scales[1]))}}


def _cancelled(components: dict[str, np.ndarray], targets, plan: _Plan) -> dict[tuple[int, str], bool]:
    """Targets whose residual (``components``: name -> (order,) at unit speed)
    is of the class zero of the engine's load scale: the classification and
    the scale :func:`harmbal.verify` judges by."""
    return {(k, name): bool(classify(abs(components[name][k]), plan.zero_scales[name], 0.0) == ZERO)
            for k, name in targets}


def _messages(request, targets, ok, predicted, before, w2, omega, solution: _Solution) -> list[str]:
    """In words, each target left: cannot be cancelled (no candidate acts on
    it: which element would), only partly (too few degrees of freedom), only
    by unbalances too small to write, or not in the exact model of the
    written scene although in the order domain (``ok`` against
    ``solution.ok``)."""
    rpm = omega * 30 / math.pi
    n = len(targets)
    a = solution.a
    messages = []
    for row, (k, name) in enumerate(targets):
        if ok[(k, name)]:
            continue
        units = "N" if name.startswith("force") else "N m"
        left = abs(predicted[name][k]) * w2
        was = abs(before[name][k]) * w2
        if solution.ok[(k, name)]:
            messages.append(f"{describe_component(k, name)} is left at {left:.4g} {units} at {rpm:.6g} rpm in the "
                            "exact model of the scene as written, though the order-domain design cancels it: "
                            "refine [sampling] (accuracy or samples_per_rev)")
            continue
        if solution.ok_solved[(k, name)]:
            messages.append(f"{describe_component(k, name)} is left at {left:.4g} {units} at {rpm:.6g} rpm: the "
                            "unbalances that would cancel it are too small to write (at most 1e-10 of the load "
                            "scale), so the scene as written leaves it")
            continue
        acting = np.hypot(a[row], a[row + n]) > ZERO_RTOL * np.abs(a).max(initial=0.0)
        fixed = [c.label for c in request.candidates if c.balance_factor is not None]
        what = describe_component(k, name)
        if not acting.any() and k == 1 and name.endswith("_co") and fixed:
            messages.append(f"{what} {left:.4g} {units} at {rpm:.6g} rpm is what the balance factor "
                            f"of {', '.join(map(repr, fixed))} leaves (0.5 cancels it); to cancel it add a +1× shaft")
        elif not acting.any():
            names = ", ".join(c.describe() for c in request.candidates if c.balance_factor is None) or "the candidates"
            messages.append(f"{what} {left:.4g} {units} at {rpm:.6g} rpm cannot be cancelled by "
                            f"{names}; add {_remedy(k, name)}")
        else:
            messages.append(f"{what} is left at {left:.4g} {units} (was {was:.4g} {units}) at {rpm:.6g} "
                            f"rpm: the elements acting at order {k} have too few degrees of freedom for all the "
                            "targets (force first, then moment, then roll); add a plane or a shaft")
    return messages


def _height_hints(request: DesignRequest, values, predicted, ok, frame, w2: float, tolerance: float) -> list[str]:
    """For a Lanchester pair whose order's roll moment is targeted but left:
    the height difference z₊ − z₋ that cancels it (the pair's two lateral
    force components are equal and opposite, so its roll moment is linear in
    the height difference and nothing else depends on the heights)."""
    hints = []
    for c in request.candidates:
        k = c.ratio
        if c.kind != "lanchester_pair" or ok.get((k, "roll"), True):
            continue
        zero = np.zeros((3, frame[0] + 1), dtype=complex)

        def roll(heights):  # called only within this iteration, so the loop variables it reads are current
            pair = dataclasses.replace(c, heights=heights)  # noqa: B023
            return _with_elements(zero, zero, [pair], {c.label: values[c.label]}, *frame)[1][0, k]  # noqa: B023

        plus, minus = c.heights
        slope = roll((plus + 0.5, minus - 0.5)) - roll(c.heights)  # per metre of height difference
        if abs(slope) == 0:
            continue
        left = predicted["roll"][k]
        change = -float((np.conj(slope) * left).real) / abs(slope) ** 2
        rest = abs(left + change * slope)
        hints.append(f"{c.label}: with z₊ − z₋ = {(plus - minus + change) * 1e3:.6g} mm "
                     f"(now {(plus - minus) * 1e3:.6g} mm) the pair would also cancel the order {k} roll moment"
                     + (f" down to {rest * w2:.4g} N m" if rest > tolerance else ""))
    return hints


def _bound_messages(request: DesignRequest, values) -> list[str]:
    messages = []
    for c in request.candidates:
        if c.max_unbalance is not None and any(abs(v) > c.max_unbalance * (1 + 1e-9) for v in values[c.label]):
            largest = max(abs(v) for v in values[c.label])
            messages.append(f"{c.label}: unbalance {largest * 1e3:.5g} kg mm exceeds max_unbalance "
                            f"{c.max_unbalance * 1e3:.5g} kg mm (the least-squares design ignores bounds; use "
                            "objective = \"peak\")")
    return messages


def _peak_design(scene, request, free, unknowns, z0, a, b, ok, ref, fixed) -> np.ndarray:
    """Minimise the summed peaks of the chosen signals over the sampled
    revolution with the cancelled targets as equality constraints: a linear
    programme in (z, t). The signals are the engine's with the ``fixed``
    (candidates, values) elements."""
    from scipy.optimize import linprog

    sense = scene.sense
    n = PEAK_SAMPLES
    theta = 2 * np.pi * np.arange(n) / n
    force, moment = evaluate(scene, n).total(ref)
    for c in fixed[0]:
        for placements, v in zip(c.unknowns(), fixed[1][c.label]):
            f, m = _element_loads(placements, v, theta, sense, ref)
            force, moment = force + f, moment + m
    signals = {"force": force, "moment": moment}
    responses = []
    for placements in unknowns:
        for value in (1.0, 1j):
            f, m = _element_loads(placements, value, theta, sense, ref)
            responses.append({"force": f, "moment": m})
    axis = {"x": 0, "y": 1, "z": 2}
    nz = len(z0)
    a_ub, b_ub = [], []
    for j, signal in enumerate(request.peak):
        kind, ax = signal.split("_")
        e = signals[kind][axis[ax]]
        g = np.array([r[kind][axis[ax]] for r in responses]).T  # (sample, unknown)
        scale = max(float(np.abs(e).max()), float(np.abs(g).max()), 1e-300)
        t = np.zeros((n, len(request.peak)))
        t[:, j] = -1.0
        # −t ≤ e + g z ≤ t
        a_ub += [np.hstack([g / scale, t]), np.hstack([-g / scale, t])]
        b_ub += [-e / scale, e / scale]
    # Bounds |P| ≤ max_unbalance as an inscribed polygon.
    i = 0
    for c in free:
        count = len(c.unknowns())
        if c.max_unbalance is not None:
            phi = 2 * np.pi * np.arange(BOUND_SIDES) / BOUND_SIDES
            for u in range(i, i + count):
                row = np.zeros((BOUND_SIDES, nz + len(request.peak)))
                row[:, 2 * u], row[:, 2 * u + 1] = np.cos(phi), np.sin(phi)
                a_ub.append(row)
                b_ub.append(np.full(BOUND_SIDES, c.max_unbalance * math.cos(math.pi / BOUND_SIDES)))
        i += count
    keep = [r for r, t in enumerate(ok) if ok[t]]
    m = len(ok)
    eq_rows = keep + [r + m for r in keep]
    a_eq = np.hstack([a[eq_rows], np.zeros((len(eq_rows), len(request.peak)))]) if eq_rows else None
    b_eq = -b[eq_rows] if eq_rows else None
    cost = np.concatenate([np.zeros(nz), np.ones(len(request.peak))])
    bounds = [(None, None)] * nz + [(0, None)] * len(request.peak)
    result = linprog(cost, A_ub=np.vstack(a_ub), b_ub=np.concatenate(b_ub), A_eq=a_eq, b_eq=b_eq, bounds=bounds,
                     method="highs", options=LP_TOLERANCES)
    if not result.success:
        raise DesignError(f"{scene.source}: the peak objective's linear programme failed: {result.message}")
    return result.x[:nz]


# --------------------------------------------------------------------------
# The output scene


def _blank_note(label: str, sized: SizedBlank) -> str:
    """The sized dimension in words, for the drawing office."""
    assert sized.blank.solve is not None  # a sized blank names its sized dimension
    index, name = sized.blank.solve
    part = sized.blank.parts[index]
    value = f"{math.degrees(sized.value):.6g}°" if name == "half_angle" else (
        f"{sized.value:.6g} kg" if name == "mass" else f"{sized.value * 1e3:.6g} mm")
    return (f"{label}: blank sized, {part.kind} (shape {index + 1}) {name} = {value}; mass {sized.mass:.6g} kg, "
            f"centre of mass at {sized.radius * 1e3:.6g} mm, {sized.unbalance * 1e3:.6g} kg mm")


def _elements_toml(request: DesignRequest, values, negligible: float,
                   blanks: dict[str, SizedBlank]) -> tuple[dict, list[str]]:
    """The designed elements as scene tables, and comment lines with rounded
    values for the drawing office. Unbalances below ``negligible`` [kg m]
    are left out (an element the design does not need). A candidate with a
    blank has each of its unbalances written as the blank sized to it,
    turned so that its unbalance points the designed way; the sized blanks
    are put in ``blanks`` by name."""
    tables: dict[str, list] = {"counterweight": [], "balance_shaft": [], "lanchester_pair": []}
    notes = []

    def fitted(c, name: str, p: complex) -> dict:
        """The keys of the unbalance p: its size and angle, or c's blank sized to it."""
        if c.blank is None:
            return {"unbalance": quantity_text(abs(p), "kg m"), "angle": angle_text(np.angle(p))}
        try:
            sized = size_blank(c.blank, abs(p))
        except DesignError as exc:
            raise DesignError(f"{name}: {exc}") from None
        blanks[name] = sized
        notes.append(_blank_note(name, sized))
        return {"angle": angle_text(np.angle(p) - sized.blank.unbalance_angle), **blank_table(sized.blank)}

    def unbalance(c, name: str, p: complex, x: float) -> dict:
        return {**fitted(c, name, p), "axial_position": length_text(x)}

    def note(label: str, p: complex, where: str) -> None:
        notes.append(f"{label}: {abs(p) * 1e3:.5g} kg mm at {math.degrees(np.angle(p)) % 360:.2f}° {where}")

    for c in request.candidates:
        vs = values[c.label]
        if all(abs(v) <= negligible for v in vs):
            notes.append(f"{c.label}: not needed (zero unbalance)")
            continue
        if c.kind == "counterweights":
            for label, x, v in zip(c.names(), c.planes, vs):
                if abs(v) > negligible:
                    note(label, v, f"from throw 1, x = {x * 1e3:.6g} mm")
                    tables["counterweight"].append({"label": label, **unbalance(c, label, v, x)})
        elif c.kind == "lanchester_pair" and min(map(abs, vs)) > negligible and (
                abs(abs(vs[0]) - abs(vs[1])) <= PAIR_RTOL * max(map(abs, vs))):
            # Equal unbalances: a pair with direction α and phasing δ.
            plus, minus = vs
            phase = float(np.angle(plus / minus)) / 2
            angle = float(np.angle(minus)) + phase
            notes.append(f"{c.label} (±{c.ratio}×): {abs(plus) * 1e3:.5g} kg mm per shaft, standing vector along "
                         f"{math.degrees(angle) % 360:.2f}°, phasing {round(math.degrees(phase), 2) + 0.0:.2f}°")
            size = (abs(plus) + abs(minus)) / 2
            tables["lanchester_pair"].append({
                "label": c.label, "order": c.ratio, **fitted(c, c.label, size * complex(np.cos(angle), np.sin(angle))),
                "phase": signed_angle_text(phase), "axial_position": length_text(c.planes[0]),
                "heights": [length_text(h) for h in c.heights], "lateral": [length_text(y) for y in c.lateral]})
        else:
            if c.kind == "lanchester_pair":  # unequal unbalances: two separate shafts
                shafts = [(name, ratio, y, z, [(v, c.planes[0])]) for name, ratio, y, z, v in zip(
                    c.names(), (c.ratio, -c.ratio), c.lateral, c.heights, vs)]
            else:
                parts = [(p.coefficient * v, p.x) for u, v in zip(c.unknowns(), vs) for p in u]
                shafts = [(c.label, c.ratio, c.y, c.z, parts)]
            for label, ratio, y, z, parts in shafts:
                parts = [(p, x) for p, x in parts if abs(p) > negligible]
                for p, x in parts:
                    note(label if c.kind == "lanchester_pair" else f"{label} ({signed_ratio(ratio)})", p,
                         f"at θ = 0, x = {x * 1e3:.6g} mm")
                if parts:
                    tables["balance_shaft"].append({"label": label, "ratio": ratio,
                                                    "axis_position": [length_text(y), length_text(z)],
                                                    "unbalance": [unbalance(c, f"{label} at x = {x * 1e3:.6g} mm", p, x)
                                                                  for p, x in parts]})
    return {k: v for k, v in tables.items() if v}, notes


def _verify_toml(scene: Scene, request: DesignRequest, predicted) -> dict:
    w2 = scene.speeds[0] ** 2
    rows = []
    for k in request.orders:
        row: dict[str, Any] = {"order": k}
        for name, group in COMPONENTS:
            if group in request.cancel:
                p = predicted[name][k] * w2
                row[name] = [quantity_text(abs(p), "N" if group == "force" else "N m"), angle_text(np.angle(p))]
        rows.append(row)
    return {"orders": list(request.orders), "cancel": list(request.cancel),
            "speed": f"{scene.speeds[0] * 30 / math.pi:.15g} rpm", "predicted": rows}


def _scene_text(scene: Scene, request: DesignRequest, values, predicted, engine: dict[str, str | None],
                negligible: float, blanks: dict[str, SizedBlank]) -> str:
    """The input scene's text without [design] and [verify], with the designed
    elements and the new [verify] appended (comments kept). Falls back to a
    plain TOML dump if the text cannot be edited safely."""
    import tomli_w

    from .._version import __version__

    original = tomllib.loads(scene.source_text)
    tables, notes = _elements_toml(request, values, negligible, blanks)
    addition = {**tables, "verify": _verify_toml(scene, request, predicted)}
    expected = {k: v for k, v in original.items() if k not in ("design", "verify")}
    for key, entries in tables.items():
        expected[key] = list(expected.get(key, [])) + entries
    expected["verify"] = addition["verify"]
    given = {k: v for k, v in engine.items() if v is not None}
    expected["engine"] = {**expected["engine"], **given}
    header = [f"# Balancer elements designed by harmbal {__version__} from {scene.source}",
              f"# (orders {', '.join(map(str, request.orders))}; cancel {', '.join(request.cancel)}; "
              f"objective {request.objective}):"] + [f"#   {n}" for n in notes]
    top = [f"# {expected['engine'].get('name', scene.name)}: {scene.source} with balancer elements designed by "
           f"'harmbal design' (see the block before [verify]).", "#"]
    body = with_engine(without_tables(scene.source_text, {"design", "verify"}), given)
    text = "\n".join(top) + "\n" + body + "\n" + "\n".join(header) + "\n" + toml_tables(addition)
    try:
        if tomllib.loads(text) == expected:
            return text
    except tomllib.TOMLDecodeError:
        pass
    return "\n".join(top + header) + "\n" + tomli_w.dumps(expected)
