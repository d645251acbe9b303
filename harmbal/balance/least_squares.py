"""The order-domain linear system of a balancer design and its staged least squares.

Every balancer element is a static unbalance P = U·e^{iα} turning at n ×
crank speed; its loads are pure order-|n| phasors, linear in (Re P, Im P).
A design's targets (order, component) are the co/counter-rotating force and
moment and the roll moment of :data:`~harmbal.scene.requests.COMPONENTS`;
each target gives two real rows (real and imaginary part), so cancelling the
engine's targets b with the unknowns z is the real linear problem
A·z = −b, solved in order of priority by :func:`prioritised_least_squares`.

:func:`harmbal.design` builds and solves it for one scene;
:mod:`harmbal.balance.variants` solves it once for every mass variant of a
geometry (the solution is linear in b for a fixed A) and checks, through
:func:`priority_stages`, where a variant's rank decisions could differ.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.balancers import shaft_phasors
from ..model.evaluate import moment_about
from ..orders.spectrum import transverse_split
from ..scene.elements import Shaft, ShaftUnbalance
from ..scene.requests import COMPONENTS, DesignRequest, Placement

#: Singular values at most this fraction of the whole (weighted) matrix's
#: 2-norm are round-off in :func:`prioritised_least_squares`.
RANK_RTOL = 1e-10

#: The priority groups of :func:`prioritised_least_squares`, first to last (prefixes of the component names).
PRIORITIES = ("force", "moment", "roll")


def element_shafts(label: str, placements: tuple[Placement, ...], value: complex) -> tuple[Shaft, ...]:
    """The shafts (one unbalance each) of one unknown of a candidate at the
    complex value ``value``: each placement's unbalance is its coefficient ×
    ``value`` at its axial position."""
    return tuple(Shaft(label, p.ratio, p.y, p.z, (ShaftUnbalance(abs(p.coefficient * value),
                                                                  float(np.angle(p.coefficient * value)), p.x),))
                 for p in placements)


def element_phasors(placements: tuple[Placement, ...], value: complex, kmax: int, sense: int,
                    ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis order phasors (axis, order 0 … ``kmax``) of the force and of
    the moment about ``ref`` at unit speed of one unknown at ``value``.

    Parameters
    ----------
    placements : tuple of Placement
        The unknown's placements (:meth:`harmbal.scene.requests.Candidate.unknowns`).
    value : complex
        The unknown P [kg m].
    kmax : int
        The highest order kept.
    sense : {1, -1}
        The crank's sense of rotation (``Scene.sense``).
    ref : ndarray, shape (3,)
        The reference point of the moments [m].
    """
    force, moment = shaft_phasors(element_shafts("", placements, value), kmax, sense)
    return force, moment_about(ref, force, moment)


def component_phasors(force: np.ndarray, moment: np.ndarray, sense: int) -> dict[str, np.ndarray]:
    """The design's components per order from per-axis phasors.

    Parameters
    ----------
    force, moment : ndarray, shape (..., 3, order)
        Per-axis phasors (order from 0).
    sense : {1, -1}
        The crank's sense of rotation.

    Returns
    -------
    dict of ndarray, shape (..., order)
        By the names of :data:`~harmbal.scene.requests.COMPONENTS`: the co- and
        counter-rotating force and moment
        (:func:`~harmbal.orders.spectrum.transverse_split`) and the roll moment.
    """
    f_co, f_counter = transverse_split(force, sense)
    m_co, m_counter = transverse_split(moment, sense)
    return {"force_co": f_co, "force_counter": f_counter, "moment_co": m_co, "moment_counter": m_counter,
            "roll": moment[..., 0, :]}


def design_targets(request: DesignRequest) -> list[tuple[int, str]]:
    """The (order, component) pairs a request cancels, order by order."""
    return [(k, name) for k in request.orders for name, group in COMPONENTS if group in request.cancel]


def target_rows(components: dict[str, np.ndarray], targets: list[tuple[int, str]],
                weights: dict[str, float]) -> np.ndarray:
    """The real rows of the targets: the real parts of every target's
    weighted phasor, then the imaginary parts (so target i has rows i and
    i + len(targets)); ``components`` as :func:`component_phasors` gives them,
    any leading axes kept after the row axis."""
    values = np.array([components[name][..., k] * weights[name] for k, name in targets])
    return np.concatenate([values.real, values.imag])


def response_matrix(unknowns, targets: list[tuple[int, str]], kmax: int, sense: int, ref: np.ndarray,
                    weights: dict[str, float]) -> np.ndarray:
    """The matrix A (row, real unknown) of the unknowns' unit responses.

    Column 2j is the weighted rows (:func:`target_rows`) of unknown j at
    P = 1, column 2j + 1 those at P = i: the responses to Re P and Im P.
    ``unknowns`` are tuples of placements (:func:`element_phasors`).
    """
    columns = [target_rows(component_phasors(*element_phasors(placements, value, kmax, sense, ref), sense), targets,
                           weights)
               for placements in unknowns for value in (1.0, 1j)]
    return np.array(columns).T if columns else np.zeros((2 * len(targets), 0))


@dataclass(frozen=True)
class Stage:
    """One priority group of :func:`prioritised_least_squares`.

    Attributes
    ----------
    group : str
        ``"force"``, ``"moment"`` or ``"roll"``.
    rows : list of int
        Its real rows of the matrix.
    basis : ndarray
        Orthonormal basis of the minimisers left by the groups before.
    u, singular, vt : ndarray
        The SVD of ``a[rows] @ basis``.
    rank : int
        How many singular values are kept (above round-off).
    """

    group: str
    rows: list[int]
    basis: np.ndarray
    u: np.ndarray
    singular: np.ndarray
    vt: np.ndarray
    rank: int


def priority_stages(a: np.ndarray, targets: list[tuple[int, str]]) -> tuple[list[Stage], np.ndarray]:
    """The stages of :func:`prioritised_least_squares` for the matrix ``a``
    (they do not depend on the right-hand side) and the basis of the
    minimisers left after the last.

    Singular values at most RANK_RTOL × the 2-norm of the whole ``a`` are
    round-off: rows scaled alike are judged alike, and a stage whose rows,
    restricted to what earlier stages leave, are round-off is not solved
    with them.
    """
    n = len(targets)
    basis = np.eye(a.shape[1])
    cutoff = RANK_RTOL * (np.linalg.norm(a, 2) if a.size else 0.0)
    stages = []
    for group in PRIORITIES:
        rows = [i for i, (_, name) in enumerate(targets) if name.startswith(group)]
        if not rows or basis.shape[1] == 0:
            continue
        rows += [i + n for i in rows]
        u, singular, vt = np.linalg.svd(a[rows] @ basis)
        rank = int((singular > cutoff).sum())
        stages.append(Stage(group, rows, basis, u, singular, vt, rank))
        basis = basis @ vt[rank:].T
    return stages, basis


def prioritised_least_squares(a: np.ndarray, b: np.ndarray, targets: list[tuple[int, str]]) -> np.ndarray:
    """Minimise |b + a·z| for the force rows, then, among those minimisers,
    for the moment rows, then for the roll rows; finally take the smallest z.

    Parameters
    ----------
    a : ndarray, shape (row, unknown)
        The real matrix (:func:`response_matrix`), rows scaled alike.
    b : ndarray, shape (row,) or (row, ...)
        The right-hand side (:func:`target_rows`); with more axes, one
        solution per column (the solution is linear in b for a fixed a).
    targets : list of (int, str)
        The targets of the rows (:func:`design_targets`): which rows belong
        to which priority group.

    Returns
    -------
    ndarray, shape (unknown,) or (unknown, ...)

    Notes
    -----
    Each stage is exact where it can be and least squares where it cannot,
    and never gives up what an earlier stage achieved. The minimisers of a
    stage form z₀ + N·y with N spanning the null space of that stage's rows
    restricted to the earlier null space (:func:`priority_stages`).
    """
    stages, null = priority_stages(a, targets)
    z = np.zeros(a.shape[1:] + b.shape[1:])
    for s in stages:
        rhs = -(b[s.rows] + a[s.rows] @ z)
        step = np.divide((s.u[:, :s.rank].T @ rhs).T, s.singular[:s.rank]).T
        z = z + s.basis @ (s.vt[:s.rank].T @ step)
    return z - null @ (null.T @ z)  # the smallest unbalances among the minimisers
