"""Mount design: stiffnesses, positions and orientations of the mounts,
within bounds, for what a mount engineer asks ([mount_design]).

The problem (docs/mounts.md):

* variables: the request's :class:`~harmbal.scene.mounts.MountVariable`;
  the variables of one ``group`` share one value (a symmetric pair), so the
  optimiser sees one parameter per group and one per ungrouped variable,
  each scaled to [0, 1] by its bounds (a group's bounds: the intersection of
  its members'). A stiffness variable of a mount with a table over frequency
  scales the table's column by the same factor as the nominal stiffness;
* objective ``"transmitted_force"``: the RMS transmitted mount force
  J = √( 1/(S·O) Σ_speeds Σ_orders Σ_mounts Σ_xyz |f|² ) [N], f the peak
  phasors of the force each mount transmits into the frame, over the
  scene's speeds (S) and every order > 0 (O), normalised by its value
  before the design. The sum is over the mounts, not of the total force into
  the frame, so that the roll torque the mounts carry as opposing forces
  counts as well. ``"decoupling"``: maximise the smallest dominant-DOF
  energy share of the six modes (an epigraph variable t: maximise t with
  every mode's share ≥ t);
* constraints: every mode's dominant-DOF energy share ≥ ``decoupling``; the
  six natural frequencies inside ``frequency_band`` (default 5 Hz to the
  idle firing frequency / √2); |static roll| under the weight plus the
  full-load torque (else the mean gas torque) ≤ ``max_static_roll``; the
  angle between the torque roll axis and the roll mode ≤ ``max_tra_angle``.

Solved by SLSQP (:func:`scipy.optimize.minimize`, finite-difference
gradients). Eigenvalue constraints are not smooth where modes cross, so the
solver runs from several starts: the nominal design, then up to
:data:`LATIN_STARTS` Latin-hypercube points (seed :data:`SEED`,
deterministic), until a feasible end point matches the best one found
before it (the optimum found twice); the best feasible end point is kept
(else the least violating one; the nominal design itself is a candidate).
Inside the loop one :class:`~harmbal.views.mounts.Excitation` serves every
evaluation (the engine does not change) and the objective reads
at most :data:`LOOP_SPEEDS` of the scene's speeds; the result is judged at all
of them. The optimiser satisfies each scaled constraint with a margin
(:data:`MARGIN`) so that the design as written meets it strictly.

The designed mounts are written as a scene
(:func:`harmbal.scene.writer.mounts_scene_text`), read back, and its
``/mounts`` recomputed from the re-read scene: ``after`` is that, and the
feasibility is judged on it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..labelled import Speeds
from ..model import mounts as rigid
from ..scene import Scene, SceneError, scene_from_text
from ..scene.mounts import Mount, MountDesignRequest, MountTable
from ..scene.writer import mounts_scene_text
from ..views.mounts import (
    Excitation,
    Operating,
    mount_loads,
    mount_system,
    mounts,
    mounts_dataset,
    operating,
    static_cases,
)
from .solvers import DesignError

#: Latin-hypercube starts of the local optimiser besides the nominal design.
LATIN_STARTS = 4
#: Seed of the Latin hypercube: the same scene gives the same design.
SEED = 0
#: The objective inside the optimisation loop reads at most this many of the scene's speeds (evenly spread,
#: first and last kept); the reported objective reads all of them.
LOOP_SPEEDS = 32
#: Two feasible end points whose objectives agree to this share are the same optimum (the starts stop).
SAME_OPTIMUM = 1e-6
#: SLSQP's tolerance on the objective (J normalised by its value at the start, or a share).
FTOL = 1e-9
#: Each scaled constraint (a share, a frequency ratio, …, of order 1) is asked with this margin.
MARGIN = 1e-6
#: Relative agreement between the optimiser's prediction and the recomputed scene that ``verified`` asks.
VERIFY_RTOL = 1e-8
#: SI units of each kind of variable.
VARIABLE_UNITS = {"stiffness": "N/m", "position": "m", "angle": "rad"}
#: The default frequency band starts here [Hz].
BAND_LOW = 5.0
_AXES = {"stiffness": "uvw", "position": "xyz", "angle": "xyz"}


@dataclass(frozen=True)
class DesignedVariable:
    """One variable of the request, before and after the design.

    Attributes
    ----------
    mount, kind, axis, group
        As in :class:`~harmbal.scene.mounts.MountVariable` (``axis`` as the
        letter: u v w for a stiffness, x y z for a position or an angle).
    lower, upper : float
        Its bounds (a group's: the intersection of its members'), SI.
    before, after : float
        Its value as the scene writes it and as designed (an angle: the
        rotation from the axes as written, so 0 before), SI.
    units : str
        ``"N/m"``, ``"m"`` or ``"rad"``.
    """

    mount: str
    kind: str
    axis: str
    group: str | None
    lower: float
    upper: float
    before: float
    after: float
    units: str


@dataclass(frozen=True)
class DesignConstraint:
    """One constraint of the request, before and after the design.

    Attributes
    ----------
    name : str
        ``"decoupling"`` (the smallest dominant-DOF share of the modes),
        ``"lowest frequency"``, ``"highest frequency"`` [Hz],
        ``"static roll"`` (|roll| under torque) or ``"tra angle"`` [rad].
    sense : str
        ``">="`` or ``"<="``: value sense limit is the requirement.
    limit, before, after : float
        The limit and the value before and after (``after`` recomputed from
        the designed scene read back).
    units : str
    """

    name: str
    sense: str
    limit: float
    before: float
    after: float
    units: str

    @property
    def satisfied(self) -> bool:
        """Whether the designed scene meets it."""
        return self.after >= self.limit if self.sense == ">=" else self.after <= self.limit


@dataclass(frozen=True, eq=False)
class MountDesign:
    """The result of :func:`design_mounts`.

    Attributes
    ----------
    request : MountDesignRequest
    variables : tuple of DesignedVariable
        Every variable of the request, before and after (the members of a
        group have the same ``after``).
    objective : str
        ``"transmitted_force"`` or ``"decoupling"``.
    objective_before, objective_after : float
        The RMS transmitted mount force J [N] (module docstring) over all the
        scene's speeds, or the smallest dominant-DOF share [1], before and
        after (recomputed from the designed scene).
    constraints : tuple of DesignConstraint
    scene : Scene
        The designed scene, read back from ``text``.
    text : str
        Its TOML text.
    before, after : xarray.Dataset
        ``/mounts`` of the scene as given and of the designed scene, the
        latter recomputed from the re-read scene.
    feasible : bool
        Whether the designed scene meets every constraint.
    verified : bool
        Whether the recomputed results agree with the optimiser's
        predictions (objective, frequencies, shares, roll, angle) to
        :data:`VERIFY_RTOL` of their scale: the scene as written is the design.
    messages : tuple of str
        The constraints violated, in words (empty if feasible).
    starts : int
        Local optimisations run (nominal + Latin hypercube).
    mismatches : tuple of str
        Where the recomputed results differ from the predictions (empty if
        ``verified``), in words.
    """

    request: MountDesignRequest
    variables: tuple[DesignedVariable, ...]
    objective: str
    objective_before: float
    objective_after: float
    constraints: tuple[DesignConstraint, ...]
    scene: Scene
    text: str
    before: object
    after: object
    feasible: bool
    verified: bool
    messages: tuple[str, ...]
    starts: int
    mismatches: tuple[str, ...] = ()

    @property
    def improvement(self) -> float:
        """``objective_after / objective_before`` (< 1: less force; for
        ``"decoupling"`` > 1 is better)."""
        return self.objective_after / self.objective_before

    def __repr__(self) -> str:
        """The variables and constraints before → after, and the verdict."""
        lines = [f"mount design of {self.scene.name}: objective {self.objective} {self.objective_before:.6g} -> "
                 f"{self.objective_after:.6g}; {'feasible' if self.feasible else 'INFEASIBLE'}, "
                 f"{'verified' if self.verified else 'NOT verified'} by recomputation"]
        lines += [f"  {v.mount}: {v.kind} {v.axis} {v.before:.6g} -> {v.after:.6g} {v.units} [{v.lower:.6g}, "
                  f"{v.upper:.6g}]" + (f" (group {v.group})" if v.group else "") for v in self.variables]
        lines += [f"  {c.name} {c.sense} {c.limit:.6g} {c.units}: {c.before:.6g} -> {c.after:.6g}"
                  f"{'' if c.satisfied else '  VIOLATED'}" for c in self.constraints]
        return "\n".join(lines + [f"  {m}" for m in self.messages + self.mismatches])


@dataclass(frozen=True)
class _Parameter:
    """One value the optimiser varies: a group's, or one ungrouped variable's
    (``members``: indices into the request's variables)."""

    name: str
    members: tuple[int, ...]
    lower: float
    upper: float
    nominal: float

    def value(self, z: float) -> float:
        """The SI value at the scaled ``z`` in [0, 1]."""
        return self.lower + float(z) * (self.upper - self.lower)

    def scaled(self, value: float) -> float:
        return (value - self.lower) / (self.upper - self.lower)


@dataclass(frozen=True)
class _Metrics:
    """What the objective and the constraints read of one design."""

    frequency: np.ndarray
    share: np.ndarray
    dominant: np.ndarray
    roll: float
    tra_angle: float
    force: float


def design_mounts(scene: Scene, *, name: str | None = None, request: MountDesignRequest | None = None,
                  starts: int = LATIN_STARTS, seed: int = SEED) -> MountDesign:
    """Design the mounts of ``scene`` for its ``[mount_design]`` request.

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`, with ``[powertrain]`` and
        ``[[mount]]`` tables.
    name : str, optional
        ``engine.name`` of the written scene; default the input's.
    request : MountDesignRequest, optional
        Default the scene's ``mount_design``.
    starts, seed : int
        Latin-hypercube starts besides the nominal design, and their seed.

    Returns
    -------
    MountDesign
        The designed scene (text and read back), the variables, objective and
        constraints before and after, ``/mounts`` before and after (the
        latter recomputed from the re-read scene). An infeasible request is
        not an error: ``feasible`` is False and ``messages`` name the
        violated constraints (the design closest to feasible is returned).

    Raises
    ------
    DesignError
        If the scene has no mounts or no request, a group's bounds do not
        overlap, or ``max_static_roll`` is asked of a scene with neither
        gas nor ``drive_torque``.
    """
    request = request or scene.mount_design
    if scene.powertrain is None or not scene.mounts:
        raise DesignError(f"{scene.source}: no [powertrain] and [[mount]] tables to design (docs/mounts.md)")
    if request is None or not request.variables:
        raise DesignError(f"{scene.source}: no [mount_design] table with [[mount_design.variable]] entries")
    loads, attrs = mount_loads(scene)
    op = operating(scene)
    params = _parameters(scene, request)
    problem = _Problem(scene, request, loads, op, _loop_speeds(scene.speeds))
    z0 = np.array([p.scaled(p.nominal) for p in params])
    z, starts_run = _optimise(problem, params, z0, starts, seed)
    designed_mounts = _designed(scene.mounts, request, params, z)
    text = _header(scene, request) + mounts_scene_text(scene, designed_mounts, name)
    designed = _read_back(scene, text)
    before = mounts_dataset(mount_system(scene.powertrain, scene.mounts), loads, Speeds(scene.speeds), attrs, op)
    after = mounts(designed)
    full = _Problem(scene, request, loads, op, np.asarray(scene.speeds, dtype=float))
    predicted = full.metrics(designed_mounts)
    recomputed = _dataset_metrics(after, full)
    mismatches = _mismatches(predicted, recomputed)
    constraints = _constraint_rows(problem, full.metrics(scene.mounts), recomputed)
    return MountDesign(
        request=request, variables=_variable_rows(scene.mounts, request, params, z), objective=request.objective,
        objective_before=_objective_value(request, full.metrics(scene.mounts)),
        objective_after=_objective_value(request, recomputed),
        constraints=constraints, scene=designed, text=text, before=before, after=after,
        feasible=all(c.satisfied for c in constraints),
        verified=not mismatches, mismatches=tuple(mismatches),
        messages=tuple(_violations(constraints, recomputed)), starts=starts_run)


def _loop_speeds(speeds) -> np.ndarray:
    """At most :data:`LOOP_SPEEDS` of ``speeds``, evenly spread, the first and last kept."""
    speeds = np.asarray(speeds, dtype=float)
    if speeds.size <= LOOP_SPEEDS:
        return speeds
    return speeds[np.unique(np.round(np.linspace(0, speeds.size - 1, LOOP_SPEEDS)).astype(int))]


def _parameters(scene: Scene, request: MountDesignRequest) -> list[_Parameter]:
    """One parameter per group and per ungrouped variable, in the order they first appear."""
    by_name = {m.name: m for m in scene.mounts}
    members: dict[tuple, list[int]] = {}
    for i, v in enumerate(request.variables):
        if v.mount not in by_name:
            raise DesignError(f"{scene.source}: mount_design.variable[{i + 1}]: no mount named {v.mount!r}")
        members.setdefault(("group", v.group) if v.group is not None else ("variable", i), []).append(i)
    params = []
    for key, indices in members.items():
        variables = [request.variables[i] for i in indices]
        lower, upper = max(v.lower for v in variables), min(v.upper for v in variables)
        label = key[1] if key[0] == "group" else _label(variables[0])
        if not lower < upper:
            raise DesignError(f"{scene.source}: mount_design group {label!r}: its members' bounds do not overlap")
        nominal = float(np.mean([_written(by_name[v.mount], v) for v in variables]))
        params.append(_Parameter(label, tuple(indices), lower, upper, min(max(nominal, lower), upper)))
    return params


def _label(variable) -> str:
    return f"{variable.mount}: {variable.kind} {_AXES[variable.kind][variable.axis]}"


def _written(mount: Mount, variable) -> float:
    """The variable's value as the scene writes it (an angle: 0, the axes as written)."""
    if variable.kind == "stiffness":
        return float(mount.stiffness[variable.axis])
    if variable.kind == "position":
        return float(mount.position[variable.axis])
    return 0.0


def _rotation(axis: int, angle: float) -> np.ndarray:
    """The right-handed rotation by ``angle`` about engine ``axis``."""
    c, s = math.cos(angle), math.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    q = np.eye(3)
    q[i, i], q[i, j], q[j, i], q[j, j] = c, -s, s, c
    return q


def _designed(mounts_given: tuple[Mount, ...], request: MountDesignRequest, params: list[_Parameter],
              z: np.ndarray) -> tuple[Mount, ...]:
    """The mounts with every variable at its parameter's value (scaled ``z``)."""
    changes: dict[str, dict] = {m.name: {} for m in mounts_given}
    for p, zi in zip(params, z):
        for i in p.members:
            v = request.variables[i]
            changes[v.mount].setdefault(v.kind, []).append((v.axis, p.value(zi)))
    return tuple(_changed(m, changes[m.name]) for m in mounts_given)


def _changed(mount: Mount, change: dict) -> Mount:
    """``mount`` with its stiffnesses, position and axes changed (angles about
    engine axes applied in the request's order to the axes as written)."""
    if not change:
        return mount
    stiffness, position = list(mount.stiffness), list(mount.position)
    axes = np.array(mount.axes, dtype=float)
    for axis, value in change.get("stiffness", ()):
        stiffness[axis] = value
    for axis, value in change.get("position", ()):
        position[axis] = value
    for axis, value in change.get("angle", ()):
        axes = axes @ _rotation(axis, value).T  # rows u, v, w each rotated
    table = mount.table
    if table is not None and "stiffness" in change:
        factor = np.array(stiffness) / np.array(mount.stiffness)
        table = MountTable(table.frequency, tuple(_vector(np.array(row) * factor) for row in table.stiffness),
                           table.loss_factor)
    axes_rows = (_vector(axes[0]), _vector(axes[1]), _vector(axes[2]))
    return dataclasses.replace(mount, stiffness=_vector(stiffness), position=_vector(position), axes=axes_rows,
                               table=table)


def _vector(values) -> tuple[float, float, float]:
    """Three floats as a scene object holds them."""
    x, y, z = (float(v) for v in values)
    return x, y, z


class _Problem:
    """The objective's and the constraints' quantities of any mount set, for
    one scene, request and set of speeds (the loads computed once)."""

    def __init__(self, scene: Scene, request: MountDesignRequest, loads: Excitation, op: Operating,
                 speeds: np.ndarray):
        assert scene.powertrain is not None
        self.powertrain, self.mounts, self.request, self.op = scene.powertrain, scene.mounts, request, op
        positive = loads.positive()
        self.cg = np.asarray(scene.powertrain.cg, dtype=float)
        self.load = positive.about(self.cg, speeds)  # (speed, order, 6)
        self.omega = speeds[:, None] * positive.orders[None, :]
        self.gyroscopic = op.gyroscopic(speeds)  # the spinning parts' moment, as /mounts has it
        self.torque = _torque_case(scene, request, loads, op)
        self.tra = rigid.torque_roll_axis(np.asarray(scene.powertrain.inertia, dtype=float))
        self.band = request.frequency_band or (BAND_LOW, op.idle_firing_frequency / math.sqrt(2))
        self._cache: dict[bytes, _Metrics] = {}

    def metrics(self, mount_set: tuple[Mount, ...]) -> _Metrics:
        """Modes, shares, roll under torque, TRA angle and the RMS mount force."""
        system = mount_system(self.powertrain, mount_set)
        M, K = system.mass_matrix, system.stiffness_matrix
        frequency, shapes = rigid.modes(M, K)
        energy = rigid.energy_distribution(M, shapes)
        roll = math.nan if self.torque is None else float(np.linalg.solve(K, self.torque)[3])
        _, force = rigid.direct_response(M, system.axes, system.transforms, system.local_stiffness(self.omega),
                                         self.omega, self.load, self.gyroscopic)
        rms = math.sqrt(float((np.abs(force) ** 2).sum(axis=(-1, -2)).mean()))
        return _Metrics(frequency, energy.max(axis=0), energy.argmax(axis=0), roll,
                        float(rigid.tra_angle(self.tra, shapes, energy)), rms)

    def cached(self, mount_set: tuple[Mount, ...], z: np.ndarray) -> _Metrics:
        """:meth:`metrics` remembered by the scaled point ``z`` (the objective
        and the constraints ask for the same points)."""
        key = np.asarray(z, dtype=float).tobytes()
        if key not in self._cache:
            if len(self._cache) > 256:
                self._cache.clear()
            self._cache[key] = self.metrics(mount_set)
        return self._cache[key]

    def scaled_constraints(self, m: _Metrics) -> np.ndarray:
        """Every constraint as g ≥ 0, each of order 1."""
        r = self.request
        g = list(m.share - r.decoupling) if r.decoupling else []
        g += [m.frequency[0] / self.band[0] - 1.0, 1.0 - m.frequency[-1] / self.band[1]]
        if r.max_static_roll is not None:
            g.append(1.0 - (m.roll / r.max_static_roll) ** 2)
        if r.max_tra_angle is not None:
            g.append(1.0 - m.tra_angle / r.max_tra_angle)
        return np.array(g, dtype=float)


def _torque_case(scene: Scene, request: MountDesignRequest, loads: Excitation, op: Operating) -> np.ndarray | None:
    """The static load (6,) of the weight and the full-load torque (else the
    mean gas torque): :func:`~harmbal.views.mounts.static_cases`' case; None
    when neither torque is known."""
    assert scene.powertrain is not None
    cases = static_cases(mount_system(scene.powertrain, scene.mounts), loads, op)
    for name in ("weight+full_load", "weight+mean_torque"):
        if name in cases:
            return cases[name]
    if request.max_static_roll is not None:
        raise DesignError(f"{scene.source}: mount_design.max_static_roll: the scene has neither gas nor "
                          "powertrain.drive_torque: give drive_torque, or leave max_static_roll out")
    return None


def _optimise(problem: _Problem, params: list[_Parameter], z0: np.ndarray, latin: int,
              seed: int) -> tuple[np.ndarray, int]:
    """The best end point of SLSQP from the nominal ``z0`` and up to
    ``latin`` Latin-hypercube starts, and the number of starts run: the
    starts stop once a feasible end point matches the best one before it
    (:data:`SAME_OPTIMUM`), the optimum found twice."""
    from scipy.stats import qmc

    starts = [z0]
    if latin > 0:
        starts += list(qmc.LatinHypercube(d=len(params), seed=seed).random(latin))
    best, run = z0, 0
    for start in starts:
        run += 1
        z = _local(problem, params, start)
        new, old = _rank(problem, params, z), _rank(problem, params, best)
        again = run > 1 and new[0] == old[0] == 0.0 and abs(new[1] - old[1]) <= SAME_OPTIMUM * abs(old[1])
        if new < old:
            best = z
        if again:
            break
    return best, run


def _rank(problem: _Problem, params: list[_Parameter], z: np.ndarray) -> tuple[float, float]:
    """Feasible points first (by objective), then the others by their violation."""
    m = problem.cached(_designed_for(problem, params, z), z)
    violation = float(np.clip(-problem.scaled_constraints(m), 0.0, None).sum())
    return violation, _objective(problem.request, m, problem)


def _designed_for(problem: _Problem, params: list[_Parameter], z: np.ndarray) -> tuple[Mount, ...]:
    return _designed(problem.mounts, problem.request, params, z)


def _objective(request: MountDesignRequest, m: _Metrics, problem: _Problem) -> float:
    """The value the optimiser minimises: J (or minus the smallest share)."""
    return m.force if request.objective == "transmitted_force" else -float(m.share.min())


def _local(problem: _Problem, params: list[_Parameter], start: np.ndarray) -> np.ndarray:
    """One SLSQP run from ``start`` (scaled), its end point clipped to the bounds."""
    from scipy.optimize import minimize

    n = len(params)
    force0 = problem.cached(_designed_for(problem, params, start), start).force
    share = problem.request.objective == "decoupling"

    def metrics(x):
        z = np.clip(x[:n], 0.0, 1.0)
        return problem.cached(_designed_for(problem, params, z), z)

    def objective(x):
        return -x[n] if share else metrics(x).force / force0

    def constraints(x):
        m = metrics(x)
        g = problem.scaled_constraints(m) - MARGIN
        return np.concatenate([g, m.share - x[n] - MARGIN]) if share else g

    x0 = np.append(start, 0.0) if share else start
    result = minimize(objective, x0, method="SLSQP", bounds=[(0.0, 1.0)] * len(x0),
                      constraints=[{"type": "ineq", "fun": constraints}], options={"maxiter": 200, "ftol": FTOL})
    return np.clip(result.x[:n], 0.0, 1.0)


def _header(scene: Scene, request: MountDesignRequest) -> str:
    """Comment lines that say where the designed scene comes from."""
    from .._version import __version__

    return (f"# Mounts designed by 'harmbal mounts --design' (harmbal {__version__}) from {scene.source}:\n"
            f"# objective {request.objective}, {len(request.variables)} variables within their bounds "
            "([mount_design]); /mounts recomputed from this file.\n")


def _read_back(scene: Scene, text: str) -> Scene:
    """The designed scene read from its text (the judge of what is written)."""
    try:
        files = dict(scene.files) or None  # the trace files the scene read: not read again
        designed = scene_from_text(text, f"{scene.source} (designed)", files=files)
    except SceneError as exc:
        raise DesignError(f"the designed scene does not load:\n{exc}") from None
    return dataclasses.replace(designed, source=scene.source).with_negligible(scene.model.negligible)


def _dataset_metrics(ds, problem: _Problem) -> _Metrics:
    """:class:`_Metrics` read from a ``/mounts`` Dataset (all its speeds)."""
    from ..views.mounts import DOF

    case = next((c for c in ("weight+full_load", "weight+mean_torque") if c in ds.case.values), None)
    roll = math.nan if case is None or problem.torque is None else float(ds.static_roll.sel(case=case))
    force = np.abs(ds.transmitted_force.transpose(..., "mount", "component").values) ** 2
    dominant = np.array([DOF.index(d) for d in ds.dominant_dof.values])
    return _Metrics(ds.natural_frequency.values, ds.decoupling.values, dominant, roll,
                    float(ds.tra_roll_mode_angle), math.sqrt(float(force.sum(axis=(-1, -2)).mean())))


def _objective_value(request: MountDesignRequest, m: _Metrics) -> float:
    """The reported objective: J [N] or the smallest dominant-DOF share."""
    return m.force if request.objective == "transmitted_force" else float(m.share.min())


def _constraint_values(problem: _Problem, m: _Metrics) -> list[tuple[str, str, float, float, str]]:
    """(name, sense, limit, value, units) of every constraint of the request."""
    r = problem.request
    rows = [("decoupling", ">=", r.decoupling, float(m.share.min()), "1")] if r.decoupling else []
    rows += [("lowest frequency", ">=", problem.band[0], float(m.frequency[0]), "Hz"),
             ("highest frequency", "<=", problem.band[1], float(m.frequency[-1]), "Hz")]
    if r.max_static_roll is not None:
        rows.append(("static roll", "<=", r.max_static_roll, abs(m.roll), "rad"))
    if r.max_tra_angle is not None:
        rows.append(("tra angle", "<=", r.max_tra_angle, m.tra_angle, "rad"))
    return rows


def _constraint_rows(problem: _Problem, before: _Metrics, after: _Metrics) -> tuple[DesignConstraint, ...]:
    rows = zip(_constraint_values(problem, before), _constraint_values(problem, after))
    return tuple(DesignConstraint(name, sense, float(limit), value, a[3], units)
                 for (name, sense, limit, value, units), a in rows)


def _violations(constraints: tuple[DesignConstraint, ...], m: _Metrics) -> list[str]:
    """The violated constraints in words, naming the modes."""
    from ..views.mounts import DOF

    out = []
    for c in (c for c in constraints if not c.satisfied):
        if c.name == "decoupling":
            out += [f"mode {j + 1} keeps {m.share[j]:.6g} of its kinetic energy in {DOF[m.dominant[j]]}, less than "
                    f"mount_design.decoupling = {c.limit:.6g}" for j in np.flatnonzero(m.share < c.limit)]
        elif c.name.endswith("frequency"):
            side = "below" if c.sense == ">=" else "above"
            out += [f"mode {j + 1} at {f:.6g} Hz, {side} the frequency band's {c.limit:.6g} Hz"
                    for j, f in enumerate(m.frequency) if (f < c.limit if c.sense == ">=" else f > c.limit)]
        else:
            what = "static roll under torque" if c.name == "static roll" else "angle between the TRA and the roll mode"
            key = "max_static_roll" if c.name == "static roll" else "max_tra_angle"
            out.append(f"{what} {math.degrees(c.after):.6g} deg, more than mount_design.{key} = "
                       f"{math.degrees(c.limit):.6g} deg")
    return out


def _mismatches(predicted: _Metrics, recomputed: _Metrics) -> list[str]:
    """The quantities where the recomputed scene does not give what the
    optimiser predicted to :data:`VERIFY_RTOL` of their scale, in words."""
    pairs = {"natural frequencies": (predicted.frequency, recomputed.frequency,
                                     float(np.abs(predicted.frequency).max())),
             "dominant-DOF shares": (predicted.share, recomputed.share, 1.0),
             "TRA–roll-mode angle": (predicted.tra_angle, recomputed.tra_angle, math.pi / 2),
             "RMS mount force": (predicted.force, recomputed.force, abs(predicted.force))}
    if not math.isnan(predicted.roll):
        pairs["static roll"] = (predicted.roll, recomputed.roll, abs(predicted.roll))
    out = []
    for name, (a, b, scale) in pairs.items():
        error = float(np.max(np.abs(np.asarray(a) - np.asarray(b)))) / scale
        if not error <= VERIFY_RTOL:
            out.append(f"{name}: the written scene differs from the design by {error:.3g} of their scale")
    return out


def _variable_rows(given: tuple[Mount, ...], request: MountDesignRequest, params: list[_Parameter],
                   z: np.ndarray) -> tuple[DesignedVariable, ...]:
    by_name = {m.name: m for m in given}
    rows = {}
    for p, zi in zip(params, z):
        for i in p.members:
            v = request.variables[i]
            rows[i] = DesignedVariable(v.mount, v.kind, _AXES[v.kind][v.axis], v.group, p.lower, p.upper,
                                       _written(by_name[v.mount], v), p.value(zi), VARIABLE_UNITS[v.kind])
    return tuple(rows[i] for i in range(len(request.variables)))
