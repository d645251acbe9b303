"""Design of balancers order by order, with their phasing.

Every balancer element is a static unbalance P = U·e^{iα} (mass × radius and
its angle at θ = 0) turning at n × crank speed; its loads on the block are
pure order-|n| phasors, linear in (Re P, Im P). So, per order, cancelling the
engine's free force and moment phasors is a small real linear problem
A·z = −b: the columns of A are the unit responses of the unknowns (computed
by the same code that simulates the elements, :mod:`harmbal.balancers`), b
the engine's phasors from :func:`harmbal.orders.phasors.order_phasors`. It is
solved by least squares in order of priority, the force first, then the
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
import math
import tomllib
from dataclasses import dataclass

import numpy as np

from ..scene.elements import Shaft, ShaftUnbalance
from ..model.balancers import shaft_loads, shaft_phasors
from ..orders.phasors import order_phasors
from ..scene.requests import (COMPONENTS, PEAK_SAMPLES, Candidate, DesignRequest, LeverDesignRequest, Placement, signed_ratio)
from ..orders.spectrum import ZERO, ZERO_RTOL, classify, rotating_split, zero_below_round_off
from ..scene import Scene, SceneError, scene_from_text
from .counterweights import SizedBlank, size_blank
from .solvers import LP_TOLERANCES, DesignError
from ..scene.writer import (angle_text, blank_table, length_text, quantity_text, signed_angle_text, toml_tables,
                            with_engine, without_tables)
from ..model.evaluate import moment_about, evaluate
from ..model.sampling import choose_samples
from .verify import CHECKED_ORDER, checked_orders, describe_component, made_worse_check, worsened_messages


#: Sides of the polygon inscribed in the circle |P| ≤ max_unbalance that the
#: linear programme uses (it gives away at most 1 − cos(π/64) = 0.12 %).
BOUND_SIDES = 64


@dataclass(frozen=True)
class Design:
    """The result of :func:`design`.

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
    dataset: object
    messages: tuple[str, ...]
    worsened: tuple[str, ...] = ()

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


def _element_phasors(placements: tuple[Placement, ...], value: complex, kmax: int, sense: int,
                     ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis order phasors (axis, order) of force and moment about ``ref``
    at unit speed when the unknown is ``value``."""
    shafts = _shafts("", placements, value)
    force, moment = shaft_phasors(shafts, kmax, sense)
    return force, moment_about(ref, force, moment)


def _element_loads(placements, value: complex, theta: np.ndarray, sense: int, ref: np.ndarray):
    force, moment = shaft_loads(_shafts("", placements, value), theta, sense)
    return force, moment_about(ref, force, moment)


def _shafts(label: str, placements: tuple[Placement, ...], value: complex) -> tuple[Shaft, ...]:
    return tuple(Shaft(label, p.ratio, p.y, p.z, (ShaftUnbalance(abs(p.coefficient * value),
                                                                  float(np.angle(p.coefficient * value)), p.x),))
                 for p in placements)


def _components(force: np.ndarray, moment: np.ndarray, sense: int) -> dict[str, np.ndarray]:
    """The verified components per order from per-axis phasors (..., axis, order)."""
    f_co, f_counter = rotating_split(force[..., 2, :], -sense * force[..., 1, :])
    m_co, m_counter = rotating_split(moment[..., 2, :], -sense * moment[..., 1, :])
    return {"force_co": f_co, "force_counter": f_counter, "moment_co": m_co, "moment_counter": m_counter,
            "roll": moment[..., 0, :]}


def _targets(request: DesignRequest) -> list[tuple[int, str]]:
    return [(k, name) for k in request.orders for name, group in COMPONENTS if group in request.cancel]


def _rows(components: dict[str, np.ndarray], targets: list[tuple[int, str]], weights: dict[str, float]) -> np.ndarray:
    """Real rows (re, im per target), weighted."""
    values = np.array([components[name][..., k] * weights[name] for k, name in targets])
    return np.concatenate([values.real, values.imag])


def _factor_scenes(scene: Scene) -> tuple[Scene, Scene]:
    """The two scenes whose phasors the balance-factor rule sizes counterweights
    by: the rotating masses with the counterweights already on the crank, and
    the reciprocating masses."""
    on_crank = tuple(e for e in scene.shafts if e.on_crank)
    return (dataclasses.replace(scene.with_effects({"rotating", "balancers"}), shafts=on_crank),
            scene.with_effects({"reciprocating"}))


def _factor_system(candidate: Candidate, kmax: int, sense: int, ref: np.ndarray,
                   weights: dict[str, float]) -> tuple[np.ndarray, list[tuple[int, str]]]:
    """The balance-factor rule's matrix and its targets: the first-order
    co-rotating force, and moment if there is more than one plane."""
    rows = [(1, "force_co")] + ([(1, "moment_co")] if len(candidate.planes) > 1 else [])
    return _matrix(candidate.unknowns(), rows, kmax, sense, ref, weights), rows


def _factor_counterweights(scene: Scene, candidate: Candidate, kmax: int, ref: np.ndarray,
                           weights: dict[str, float]) -> np.ndarray:
    """Unknowns of counterweights sized by the balance-factor rule: together
    with the counterweights already on the crank they cancel the first-order
    co-rotating force and moment (static balance alone with one plane) of the
    rotating masses (throw and crankshaft unbalances, rod big ends, the
    crankshaft's own CG) plus 2f × those of the reciprocating masses."""
    rot, rec = (order_phasors(evaluate(s)) for s in _factor_scenes(scene))
    f = candidate.balance_factor
    target = _components(rot.force + 2 * f * rec.force, rot.moment + 2 * f * rec.moment, scene.sense)
    a, rows = _factor_system(candidate, kmax, scene.sense, ref, weights)
    return np.linalg.lstsq(a, -_rows(target, rows, weights), rcond=None)[0]


def _matrix(unknowns, targets, kmax, sense, ref, weights) -> np.ndarray:
    """Columns: the weighted rows of each real unknown (Re P, Im P)."""
    columns = [_rows(_components(*_element_phasors(placements, value, kmax, sense, ref), sense), targets, weights)
               for placements in unknowns for value in (1.0, 1j)]
    return np.array(columns).T if columns else np.zeros((2 * len(targets), 0))


def _with_elements(force: np.ndarray, moment: np.ndarray, candidates, values, kmax: int, sense: int,
                   ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis phasors (axis, order) plus those of the candidates at their
    designed values."""
    force, moment = force.copy(), moment.copy()
    for c in candidates:
        for placements, v in zip(c.unknowns(), values[c.label]):
            f, m = _element_phasors(placements, v, kmax, sense, ref)
            force += f
            moment += m
    return force, moment


def _remedy(order: int, name: str) -> str:
    if name == "roll":
        return f"shafts at ±{order}× set off the crank axis, e.g. a ±{order}× Lanchester pair at different heights"
    if name.endswith("_co"):
        return "crank counterweights or a +1× shaft" if order == 1 else f"a +{order}× shaft"
    return f"a −{order}× shaft"


def _check_request(scene: Scene, request: DesignRequest | None) -> None:
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
           description: str | None = None) -> Design:
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
    Design
        The designed elements, the output scene (text and loaded), the
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
        or the scene does not simulate balancers.
    """
    import xarray as xr

    request = request or scene.design
    if isinstance(request, LeverDesignRequest):
        from .lever import design_lever

        return design_lever(scene, request, name=name, description=description)
    _check_request(scene, request)
    kmax = scene.sampling.max_order
    sense = scene.sense
    ref = np.asarray(scene.reference_point, dtype=float)
    engine = order_phasors(evaluate(scene))
    force_scale = float(engine.peak_force.sum() + engine.crankshaft_peak_force)
    moment_scale = float(engine.peak_moment.sum() + engine.crankshaft_peak_moment)
    scales = {name: force_scale if group == "force" else moment_scale for name, group in COMPONENTS}
    weights = {name: 1.0 / s if s > 0 else 1.0 for name, s in scales.items()}
    targets = _targets(request)

    # The engine, with the counterweights that the balance-factor rule sizes.
    fixed = [c for c in request.candidates if c.balance_factor is not None]
    free = [c for c in request.candidates if c.balance_factor is None]
    values: dict[str, list[complex]] = {}
    for c in fixed:
        z = _factor_counterweights(scene, c, kmax, ref, weights)
        values[c.label] = list(z[0::2] + 1j * z[1::2])
    base_force, base_moment = _with_elements(engine.force, engine.moment, fixed, values, kmax, sense, ref)
    b = _rows(_components(base_force, base_moment, sense), targets, weights)
    unknowns = [u for c in free for u in c.unknowns()]
    a = _matrix(unknowns, targets, kmax, sense, ref, weights)
    z = _prioritised_least_squares(a, b, targets)

    def residual(z):
        return b + a @ z

    ok = _cancelled(residual(z), targets)
    if request.objective == "peak" and unknowns:
        z = _peak_design(scene, request, free, unknowns, z, a, b, ok, ref, fixed=(fixed, values))
        ok = _cancelled(residual(z), targets)

    i = 0
    for c in free:
        n = len(c.unknowns())
        values[c.label] = list(z[2 * i:2 * (i + n):2] + 1j * z[2 * i + 1:2 * (i + n):2])
        i += n

    # Predicted residual phasors at unit speed.
    predicted = _components(*_with_elements(base_force, base_moment, free, values, kmax, sense, ref), sense)
    for (k, component), cancelled in ok.items():
        if cancelled:  # round-off, not a prediction: no noise phase
            predicted[component][k] = 0
    before = {n: zero_below_round_off(v, scales[n])
              for n, v in _components(engine.force, engine.moment, sense).items()}
    w2 = scene.speeds[0] ** 2
    messages = _messages(request, targets, ok, predicted, before, a, w2, scene.speeds[0])
    messages += _height_hints(request, values, predicted, ok, (kmax, sense, ref), w2, ZERO_RTOL * moment_scale)
    messages += _bound_messages(request, values)

    blanks: dict[str, SizedBlank] = {}  # filled as the elements are written
    text = _scene_text(scene, request, values, predicted, {"name": name, "description": description},
                       negligible=ZERO_RTOL * force_scale, blanks=blanks)
    try:
        designed = dataclasses.replace(scene_from_text(text, f"{scene.source} (designed)"), source=scene.source)
    except SceneError as exc:  # e.g. a candidate's label already names an element of the scene
        raise DesignError(f"the designed scene does not load:\n{exc}") from None
    designed = designed.with_negligible(scene.model.negligible)  # e.g. set by --negligible, not in the text
    labels = {e.label for e in scene.shafts}
    elements = tuple(e for e in designed.shafts if e.label not in labels)

    target_names = [n for n, _ in COMPONENTS]
    data = {
        "before": (("order", "component"), w2 * np.array([[before[n][k] for n in target_names]
                                                             for k in request.orders]),
                   {"long_name": "phasor without the designed elements", "units_by_component": "component_units"}),
        "predicted": (("order", "component"), w2 * np.array([[predicted[n][k] for n in target_names]
                                                                for k in request.orders]),
                      {"long_name": "residual phasor the design predicts", "units_by_component": "component_units"}),
        "targeted": (("order", "component"), np.array([[(k, n) in targets for n in target_names]
                                                        for k in request.orders])),
        "cancelled": (("order", "component"), np.array([[ok.get((k, n), False) for n in target_names]
                                                         for k in request.orders])),
        "unbalance": ("element", [abs(v) for c in request.candidates for v in values[c.label]],
                      {"units": "kg m", "long_name": "designed unbalance (mass x radius)"}),
        "unbalance_angle": ("element", [float(np.angle(v)) for c in request.candidates for v in values[c.label]],
                            {"units": "rad", "long_name": "direction of the unbalance at theta = 0"}),
        **_made_worse(engine, designed, targets),
    }
    coords = {
        "order": ("order", list(request.orders), {"long_name": "order of crank speed"}),
        "component": ("component", target_names),
        "component_units": ("component", ["N" if g == "force" else "N m" for _, g in COMPONENTS]),
        "element": ("element", [n for c in request.candidates for n in c.names()]),
        "speed": ((), scene.speeds[0], {"units": "rad/s"}),
        "rpm": ((), scene.speeds[0] * 30 / math.pi, {"units": "rpm"}),
        CHECKED_ORDER: (CHECKED_ORDER, checked_orders(kmax), {"long_name": "order compared for components made worse"}),
    }
    dataset = xr.Dataset(data, coords, {
        "title": f"harmbal balancer design: {scene.name}",
        "engine": scene.name,
        "objective": request.objective,
        "cancel": " ".join(request.cancel),
        "feasible": "no" if messages else "yes",
        "messages": "\n".join(messages),
        "blanks": "\n".join(_blank_note(label, sized) for label, sized in blanks.items()),
        "negligible": scene.model.negligible,
        "zero_rtol": ZERO_RTOL,
    })
    worsened = worsened_messages(dataset, by="the designed elements")
    dataset.attrs["worsened"] = "\n".join(worsened)
    return Design(designed, text, elements, dataset, tuple(messages), tuple(worsened))


def _made_worse(engine, designed: Scene, targets) -> dict:
    """The made-worse check of every order and component at the design
    speed: the engine's order phasors (with the elements it already has)
    against those of the designed scene, judged by the designed scene's
    load scales on verify's samples (the scales :func:`harmbal.verify`
    judges it by: the bodies' peaks are sampled), with ``force_scale`` [N]
    and ``moment_scale`` [N m]."""
    after = order_phasors(evaluate(designed, max(choose_samples(designed), PEAK_SAMPLES)))
    w2 = designed.speeds[0] ** 2
    scales = (w2 * float(after.peak_force.sum() + after.crankshaft_peak_force),
              w2 * float(after.peak_moment.sum() + after.crankshaft_peak_moment))
    names = [n for n, _ in COMPONENTS]
    before, after = (w2 * np.array([_components(p.force, p.moment, designed.sense)[n] for n in names])[:, 1:].T
                     for p in (engine, after))  # (order 1 … max_order, component)
    targeted = np.array([[(k, n) in targets for n in names] for k in checked_orders(designed.sampling.max_order)])
    return {**made_worse_check(before, after, targeted, scales, len(designed.cylinders), designed.model.negligible),
            **{f"{kind}_scale": ((), s, {"units": units, "long_name": f"sum of single-body peak {kind}s of the "
                                                                       "designed scene"})
               for kind, units, s in (("force", "N", scales[0]), ("moment", "N m", scales[1]))}}


#: Singular values at most this fraction of the whole (weighted) matrix's
#: 2-norm are round-off in :func:`_prioritised_least_squares`.
RANK_RTOL = 1e-10


@dataclass(frozen=True)
class _Stage:
    """One priority group of :func:`_prioritised_least_squares`: its real
    ``rows``, the orthonormal ``basis`` of the minimisers left by the groups
    before, and the SVD ``u``, ``singular``, ``vt`` of ``a[rows] @ basis``
    of which the first ``rank`` singular values are kept."""

    group: str
    rows: list[int]
    basis: np.ndarray
    u: np.ndarray
    singular: np.ndarray
    vt: np.ndarray
    rank: int


def _stages(a: np.ndarray, targets) -> tuple[list[_Stage], np.ndarray]:
    """The stages of :func:`_prioritised_least_squares` for the matrix ``a``
    (they do not depend on the right-hand side) and the basis of the
    minimisers left after the last."""
    n = len(targets)
    basis = np.eye(a.shape[1])
    cutoff = RANK_RTOL * (np.linalg.norm(a, 2) if a.size else 0.0)
    stages = []
    for group in ("force", "moment", "roll"):
        rows = [i for i, (_, name) in enumerate(targets) if name.startswith(group)]
        if not rows or basis.shape[1] == 0:
            continue
        rows += [i + n for i in rows]
        u, singular, vt = np.linalg.svd(a[rows] @ basis)
        rank = int((singular > cutoff).sum())
        stages.append(_Stage(group, rows, basis, u, singular, vt, rank))
        basis = basis @ vt[rank:].T
    return stages, basis


def _prioritised_least_squares(a: np.ndarray, b: np.ndarray, targets) -> np.ndarray:
    """Minimise |b + a·z| for the force rows, then, among those minimisers,
    for the moment rows, then for the roll rows; finally take the smallest z.

    Each stage is exact where it can be and least squares where it cannot,
    and never gives up what an earlier stage achieved. The minimisers of a
    stage form z₀ + N·y with N spanning the null space of that stage's rows
    restricted to the earlier null space. Singular values are judged against
    the whole matrix (rows are already scaled alike), not within a stage:
    a stage whose restricted rows are round-off must not be solved with them.
    ``b`` may be a matrix (rows, ...): then z is one column per column of b,
    the solution being linear in b for a fixed a.
    """
    stages, null = _stages(a, targets)
    z = np.zeros(a.shape[1:] + b.shape[1:])
    for s in stages:
        rhs = -(b[s.rows] + a[s.rows] @ z)
        step = np.divide((s.u[:, :s.rank].T @ rhs).T, s.singular[:s.rank]).T
        z = z + s.basis @ (s.vt[:s.rank].T @ step)
    return z - null @ (null.T @ z)  # the smallest unbalances among the minimisers


def _cancelled(residual: np.ndarray, targets) -> dict[tuple[int, str], bool]:
    """Targets whose (weighted) residual is zero up to round-off."""
    n = len(targets)
    size = np.hypot(residual[:n], residual[n:])
    zero = classify(size, 1.0, 0.0) == ZERO  # the rows are divided by the load scales: the scale is 1
    return {t: bool(z) for t, z in zip(targets, zero)}


def _messages(request, targets, ok, predicted, before, a, w2, omega) -> list[str]:
    """In words, each target left: cannot be cancelled (no candidate acts on
    it: which element would) or only partly (too few degrees of freedom)."""
    rpm = omega * 30 / math.pi
    n = len(targets)
    messages = []
    for row, (k, name) in enumerate(targets):
        if ok[(k, name)]:
            continue
        units = "N" if name.startswith("force") else "N m"
        left = abs(predicted[name][k]) * w2
        was = abs(before[name][k]) * w2
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

        def roll(heights):
            pair = dataclasses.replace(c, heights=heights)
            return _with_elements(zero, zero, [pair], {c.label: values[c.label]}, *frame)[1][0, k]

        plus, minus = c.heights
        slope = roll((plus + 0.5, minus - 0.5)) - roll(c.heights)  # per metre of height difference
        if abs(slope) == 0:
            continue
        left = predicted["roll"][k]
        change = -float((np.conj(slope) * left).real) / abs(slope) ** 2
        rest = abs(left + change * slope)
        hints.append(f"{c.label}: with z₊ − z₋ = {(plus - minus + change) * 1e3:.6g} mm (now {(plus - minus) * 1e3:.6g} "
                     f"mm) the pair would also cancel the order {k} roll moment"
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
        elif c.kind == "lanchester_pair" and abs(abs(vs[0]) - abs(vs[1])) <= 1e-9 * max(map(abs, vs)):
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
        row = {"order": k}
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
    engine = {k: v for k, v in engine.items() if v is not None}
    expected["engine"] = {**expected["engine"], **engine}
    header = [f"# Balancer elements designed by harmbal {__version__} from {scene.source}",
              f"# (orders {', '.join(map(str, request.orders))}; cancel {', '.join(request.cancel)}; "
              f"objective {request.objective}):"] + [f"#   {n}" for n in notes]
    top = [f"# {expected['engine'].get('name', scene.name)}: {scene.source} with balancer elements designed by "
           f"'harmbal design' (see the block before [verify]).", "#"]
    body = with_engine(without_tables(scene.source_text, {"design", "verify"}), engine)
    text = "\n".join(top) + "\n" + body + "\n" + "\n".join(header) + "\n" + toml_tables(addition)
    try:
        if tomllib.loads(text) == expected:
            return text
    except tomllib.TOMLDecodeError:
        pass
    return "\n".join(top + header) + "\n" + tomli_w.dumps(expected)
