"""Designs that are physically sane: ill-conditioned requests refused with what to change.

A design request fixes the geometry (planes, shaft axes, heights) and the
solver finds the unbalances. Some geometries make that problem
ill-conditioned: two candidate planes 1 µm apart can make a couple only with
enormous opposite unbalances; a Lanchester pair whose shafts sit at nearly one
height can make a roll moment only with enormous forces. The least squares
then "cancel" the target with elements far larger than the engine, whose
untargeted loads are as absurd as they are. Two checks refuse such requests
before anything is written (:class:`~harmbal.balance.solvers.DesignError`,
exit 2 on the command line: the request is what must change):

* **Leverage** (before solving, independent of the engine's loads): the
  least-squares system of each priority stage (force, moment, roll) with each
  unknown measured by its *gross force* (the sum over its placements of
  n²·|coefficient|: what one kg m of it pulls on the block, per ω²) and the
  moment and roll rows divided by the engine's length (:func:`engine_length`).
  Its smallest singular value above round-off (RANK_RTOL of the largest, as
  the solver judges), the *leverage*, is the target a unit of gross element
  force can cancel. Below :data:`LEVERAGE_MIN`
  a target as large as the engine's own load needs elements more than 1000
  times larger. Well-posed requests have leverages of order 1 (0.6 to 1.4 in
  the bundled designs).
* **Size** (after solving, on the unbalances as written): each unknown's
  gross force against the engine's force scale (the sum of its single bodies'
  peak forces without any balancer element, per ω², i.e. kg m: the engine's
  own unbalance). Above :data:`ELEMENT_LIMIT` times it is refused. This also
  covers what the leverage cannot see (the balance-factor rule, a direction
  the solver keeps that the leverage's decomposition calls round-off).

Both thresholds leave three orders of magnitude to any real design: the
bundled designs' elements are 0.008 to 0.6 times the engine's own unbalance
and their leverages 0.64 to 1.41. They
also keep round-off harmless: elements at most 1e3 times the engine add at
most ~1e-13 of its load scale of round-off, far below the zero level
(ZERO_RTOL = 1e-10) that design and verify judge "cancelled" by.
"""

from __future__ import annotations

import math

import numpy as np

from ..scene import Scene
from ..scene.requests import COMPONENTS
from .least_squares import priority_stages, response_matrix
from .solvers import DesignError

#: Smallest leverage (target per unit of gross element force, moments per the
#: engine's length) a design may use; below it the request is refused.
LEVERAGE_MIN = 1e-3
#: Largest gross force of one designed unbalance, in units of the engine's own
#: unbalance (its force scale per ω²); above it the request is refused.
ELEMENT_LIMIT = 1e3
#: A candidate takes part in a weak direction if its share of the direction is
#: at least this fraction of the largest candidate's.
_TAKES_PART = 0.1


def engine_length(scene: Scene) -> float:
    """The engine's length [m] that turns moments into forces for the
    leverage: the farthest cylinder from the reference point, or the longest
    crank radius + rod length (the arm of a roll moment), whichever is larger.
    It depends on the geometry only, so every mass variant of a scene is
    judged alike."""
    ref = np.asarray(scene.reference_point, dtype=float)
    arms = [float(np.linalg.norm(np.array([c.x, 0.0, 0.0]) - ref)) for c in scene.cylinders]
    heights = [c.crank_radius + c.rod_length for c in scene.cylinders]
    return max(arms + heights + [0.0])


def gross_force(placements) -> float:
    """What one kg m of an unknown pulls on the block per ω², over its
    placements: Σ n²·|coefficient| [N per (kg m · rad²/s²), i.e. 1]."""
    return float(sum(p.ratio**2 * abs(p.coefficient) for p in placements))


def _mm(values) -> str:
    return "[" + ", ".join(f"{v * 1e3:.6g} mm" for v in values) + "]"


def advice(candidate, group: str) -> str:
    """What to change in a candidate's keys to make ``group`` (force, moment,
    roll) well-posed."""
    key = f"design.{candidate.kind} {candidate.label!r}"
    if group == "roll":
        if candidate.kind == "lanchester_pair":
            return (f"set {key} heights (now {_mm(candidate.heights)}) or lateral (now {_mm(candidate.lateral)}) "
                    "further apart")
        if candidate.kind == "counterweights":
            return f"drop {key}: on the crank axis it makes no roll moment"
        return f"move {key} axis_position (now {_mm((candidate.y, candidate.z))}) further from the crank axis"
    if group == "moment":
        if candidate.kind == "lanchester_pair":
            return f"add a candidate in another plane than {key} axial_position (now {_mm(candidate.planes)})"
        return f"move {key} planes (now {_mm(candidate.planes)}) apart"
    return f"drop {key} or the candidate it duplicates"


def conditioning_error(source: str, free, unknown_owner: list[int], targets, stage, index: int) -> DesignError:
    """The refusal for the weak direction ``index`` of a stage
    (:class:`~harmbal.balance.least_squares.Stage`):
    which orders, which candidates, and what to change."""
    leverage = float(stage.singular[index])
    direction = stage.basis @ stage.vt[index]  # over the real unknowns
    share = np.zeros(len(free))
    for column, value in enumerate(direction):
        share[unknown_owner[column // 2]] += value**2
    parts = [c for c, s in zip(free, share) if s >= _TAKES_PART * share.max()]
    n = len(targets)
    weight = np.abs(stage.u[:, index])
    orders = sorted({targets[row % n][0] for row, w in zip(stage.rows, weight) if w >= _TAKES_PART * weight.max()})
    what = "roll moment" if stage.group == "roll" else stage.group
    names = ", ".join(f"design.{c.kind} {c.label!r}" for c in parts)
    times = f"{1 / leverage:.3g}" if leverage > 0 and math.isfinite(1 / leverage) else "infinitely many"
    return DesignError(
        f"{source}: the request is ill-conditioned: {names} {'acts' if len(parts) == 1 else 'act'} "
        f"on the order {', '.join(map(str, orders))} {what} "
        f"only weakly (leverage {leverage:.3g}, refused below {LEVERAGE_MIN:g}): cancelling it would take elements "
        f"{times} times larger than what they cancel; {'; or '.join(advice(c, stage.group) for c in parts)} "
        "(docs/design.md, \"Ill-conditioned requests\")")


def check_conditioning(scene: Scene, free, targets: list[tuple[int, str]]) -> None:
    """Refuse a request whose least-squares system has a weak direction.

    Parameters
    ----------
    scene : Scene
        The scene being balanced (its order range, sense, reference point
        and :func:`engine_length`).
    free : list of Candidate
        The candidates the least squares solve (not the balance-factor ones).
    targets : list of (int, str)
        :func:`harmbal.balance.least_squares.design_targets` of the request.

    Raises
    ------
    DesignError
        If a kept singular value of a stage is below :data:`LEVERAGE_MIN` in
        the system whose unknowns are measured by their gross force and whose
        moment rows are divided by the engine's length
        (:func:`conditioning_error`). Independent of the engine's loads and
        masses.
    """
    kmax, sense, ref = scene.sampling.max_order, scene.sense, np.asarray(scene.reference_point, dtype=float)
    unknowns = [u for c in free for u in c.unknowns()]
    if not unknowns or not targets:
        return
    length = engine_length(scene)
    weights = {name: 1.0 if group == "force" else 1.0 / length if length > 0 else 1.0 for name, group in COMPONENTS}
    gross = np.repeat([gross_force(u) for u in unknowns], 2)
    a = response_matrix(unknowns, targets, kmax, sense, ref, weights) / np.where(gross > 0, gross, 1.0)
    owner = [i for i, c in enumerate(free) for _ in c.unknowns()]
    stages, _ = priority_stages(a, targets)
    for stage in stages:
        if stage.rank and stage.singular[stage.rank - 1] < LEVERAGE_MIN:
            raise conditioning_error(scene.source, free, owner, targets, stage, stage.rank - 1)


def size_error(source: str, candidates, values, force_scale: float) -> DesignError | None:
    """The refusal for designed unbalances whose gross force exceeds
    :data:`ELEMENT_LIMIT` × the engine's own unbalance ``force_scale``
    [kg m], or None. ``values`` maps each candidate's label to its unknowns'
    complex unbalances [kg m]."""
    worst = None
    for c in candidates:
        for name, placements, v in zip(c.names(), c.unknowns(), values[c.label]):
            size = gross_force(placements) * abs(v)
            ratio = size / force_scale if force_scale > 0 else (math.inf if size > 0 else 0.0)
            if ratio > ELEMENT_LIMIT and (worst is None or ratio > worst[0]):
                worst = (ratio, c, name, abs(v))
    if worst is None:
        return None
    ratio, c, name, size = worst
    times = f"{ratio:.3g} times" if math.isfinite(ratio) else "infinitely many times"
    group = "roll" if c.kind == "lanchester_pair" else "moment"
    return DesignError(
        f"{source}: the request is ill-conditioned: {name} would need {size * 1e3:.4g} kg mm, {times} the engine's "
        f"own unbalance ({force_scale * 1e3:.4g} kg mm: the sum of its bodies' peak forces / ω²; refused above "
        f"{ELEMENT_LIMIT:g} times); {advice(c, group)}, or drop design.{c.kind} {c.label!r} "
        "(docs/design.md, \"Ill-conditioned requests\")")
