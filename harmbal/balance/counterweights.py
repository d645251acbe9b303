"""Counterweights as real shapes: sizing a blank's free dimension to a target
unbalance, and the centrifugal load on its fasteners.

The blank's mass properties are closed forms (:mod:`harmbal.scene.shapes`);
here one of its dimensions (a chord's cut depth, an outer radius, a sector's
half-angle …) is solved so that the blank's unbalance m·x equals a target,
as a designer does after ``harmbal design`` has given the m·x each plane
needs (the single-cylinder test engine thesis, §3.3–3.4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import bearings
from ..scene.shapes import SOLVABLE, Blank
from .solvers import DesignError

#: Samples of the free dimension over its range before the roots are bracketed: |m·x| of a blank is
#: monotone in the usual free dimensions, but a sector wider than a half-disc or a hole that the
#: dimension uncovers can make it turn; every sign change between samples is bracketed and solved.
SIZING_SAMPLES = 257


@dataclass(frozen=True)
class SizedBlank:
    """The result of :func:`size_blank`: the ``blank`` with its free
    dimension set to ``value`` [m or rad]; ``unbalance`` [kg m], ``mass``
    [kg] and ``radius`` [m] (of the centre of mass) are the sized blank's."""

    blank: Blank
    value: float
    unbalance: float
    mass: float
    radius: float


def _range(blank: Blank, solve: tuple[int, str], bounds: tuple[float, float] | None) -> tuple[float, float]:
    index, name = solve
    if not 0 <= index < len(blank.parts):
        raise ValueError(f"solve: part {index} does not exist (the blank has {len(blank.parts)} parts)")
    part = blank.parts[index]
    natural = SOLVABLE.get(part.kind, {}).get(name)
    if natural is None:
        options = ", ".join(SOLVABLE.get(part.kind, {})) or "none"
        raise ValueError(f"a {part.kind}'s {name!r} cannot be solved for; solvable: {options}")
    low, high = natural(part)
    if bounds is not None:
        low = bounds[0] if low is None else max(low, bounds[0])
        high = bounds[1] if high is None else min(high, bounds[1])
    if high is None or low is None:
        raise ValueError(f"a {part.kind}'s {name} has no natural upper bound: give the range to search "
                         "(solve_range = [low, high])")
    if not low < high:
        raise ValueError(f"empty range for the {part.kind}'s {name}: [{low:.6g}, {high:.6g}]")
    return low, high


def _bounds(blank: Blank, solve: tuple[int, str], bounds: tuple[float, float] | None):
    """The search range given, else the blank's own solve_range if it is for this dimension."""
    if bounds is not None:
        return bounds
    return blank.solve_range if tuple(solve) == tuple(blank.solve or ()) else None


def unbalance_range(blank: Blank, solve: tuple[int, str] | None = None,
                    bounds: tuple[float, float] | None = None) -> tuple[float, float]:
    """Smallest and largest unbalance m·x [kg m] the blank can give as its
    free dimension runs over its range.

    Parameters
    ----------
    blank : Blank
        The blank; ``solve`` and ``bounds`` default to its ``solve`` and
        ``solve_range``.
    solve : (int, str), optional
        Index of the part and name of the dimension that varies.
    bounds : (float, float), optional
        Range of that dimension [m or rad], intersected with its natural range.

    Returns
    -------
    (float, float)
        Minimum and maximum of |m·x| [kg m] (sampled, then refined by a
        bounded scalar minimisation around the best sample).
    """
    from scipy.optimize import minimize_scalar

    solve = solve or blank.solve
    if solve is None:
        raise ValueError("say which dimension to solve: solve = (part index, name)")
    low, high = _range(blank, solve, _bounds(blank, solve, bounds))
    grid = np.linspace(low, high, SIZING_SAMPLES)
    values = np.array([blank.with_dimension(p, solve).unbalance for p in grid])
    extremes = []
    for sign in (1.0, -1.0):
        i = int(np.argmin(sign * values))
        a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        best = minimize_scalar(lambda p, sign=sign: sign * blank.with_dimension(p, solve).unbalance, bounds=(a, b),
                               method="bounded", options={"xatol": 1e-14 * (high - low)})
        extremes.append(float(min(sign * values[i], best.fun) * sign))
    return extremes[0], extremes[1]


def size_blank(blank: Blank, target: float, solve: tuple[int, str] | None = None,
               bounds: tuple[float, float] | None = None) -> SizedBlank:
    """Solve the blank's free dimension so that its unbalance is ``target``.

    The dimension is sampled over its range (:data:`SIZING_SAMPLES`
    points), every sign change of |m·x| − target between samples is
    bracketed and solved by Brent's method (:func:`scipy.optimize.brentq`,
    to the last bits of the dimension: the unbalance meets the target to
    ~1e-13 relative), and, if there are several roots, the lightest blank
    is returned.

    Parameters
    ----------
    blank : Blank
        The blank; its ``solve`` names the free dimension unless ``solve``
        is given, and its ``solve_range`` bounds it unless ``bounds`` is.
    target : float
        Unbalance m·x [kg m] to meet (≥ 0).
    solve : (int, str), optional
        Index into ``blank.parts`` and the dimension's name (see
        :data:`harmbal.scene.shapes.SOLVABLE`: a sector's ``outer_radius``,
        ``inner_radius`` or ``half_angle``, a segment's ``chord``, a strip's
        ``far`` or ``near``, a box's ``width`` or ``height``, a disc's or
        segment's ``radius``, a fastener's ``mass`` or ``radius``).
    bounds : (float, float), optional
        Range to search [m or rad], intersected with the dimension's natural
        range; required where there is none (radii, box sides, masses).

    Returns
    -------
    SizedBlank

    Raises
    ------
    DesignError
        If no value in the range meets the target, naming the smallest and
        largest unbalance the blank can give.
    ValueError
        If the dimension cannot be solved for or its range is unbounded.
    """
    from scipy.optimize import brentq

    solve = solve or blank.solve
    if solve is None:
        raise ValueError("say which dimension to solve: solve = (part index, name)")
    bounds = _bounds(blank, solve, bounds)
    low, high = _range(blank, solve, bounds)

    def excess(p: float) -> float:
        return blank.with_dimension(p, solve).unbalance - target

    grid = np.linspace(low, high, SIZING_SAMPLES)
    values = np.array([excess(p) for p in grid])
    roots = [grid[i] for i in np.flatnonzero(values == 0)]
    for i in np.flatnonzero(np.sign(values[:-1]) * np.sign(values[1:]) < 0):
        # A bracketed root converges in ~60 steps (bisection's worst case to 1e-15); past 200, refuse, never raise.
        root, found = brentq(excess, grid[i], grid[i + 1], xtol=1e-15 * (high - low), rtol=4 * np.finfo(float).eps,
                             maxiter=200, full_output=True, disp=False)
        if not found.converged:
            raise DesignError(f"sizing the blank's {solve[1]} did not converge near {_text(solve[1], root)} "
                              f"({found.iterations} iterations): check the blank's shapes")
        roots.append(root)
    if not roots:
        smallest, largest = unbalance_range(blank, solve, bounds)
        part, name = blank.parts[solve[0]], solve[1]
        raise DesignError(
            f"no {part.kind} {name} in [{_text(name, low)}, {_text(name, high)}] gives the unbalance "
            f"{target * 1e3:.6g} kg mm: this blank gives {smallest * 1e3:.6g} to {largest * 1e3:.6g} kg mm; "
            + ("make it thicker, denser or larger" if target > largest else "make it thinner or smaller"))
    sized = min((blank.with_dimension(p, solve) for p in roots), key=lambda b: b.mass)
    value = sized.dimension(solve)
    return SizedBlank(sized, value, sized.unbalance, sized.mass, sized.centroid_radius)


def _text(name: str, value: float) -> str:
    """A dimension in words: angles in degrees, masses in kg, lengths in mm."""
    if name == "half_angle":
        return f"{math.degrees(value):.6g}°"
    if name == "mass":
        return f"{value:.6g} kg"
    return f"{value * 1e3:.6g} mm"


def fastener_load(unbalance: float | Blank, speed: float, fasteners: int = 1) -> float:
    """Centrifugal load [N] on each fastener of a counterweight or a
    balance-shaft weight, given as a blank or its unbalance.

    F = m·ω²·x / n: the blank's centrifugal force at speed ω, shared
    equally by its n fasteners (the single-cylinder thesis writes
    F_h = ½·m·ω²·x for its two bolts per blank); the arithmetic is
    :func:`harmbal.model.bearings.fastener_load`'s, which ``hb.loads`` uses.

    Parameters
    ----------
    unbalance : float or Blank
        The blank's unbalance m·x [kg m], or the blank itself.
    speed : float
        Angular speed ω [rad/s] of the body carrying the blank (the maximum
        speed for a strength check).
    fasteners : int
        Number n of fasteners sharing the load.

    Returns
    -------
    float
        Load per fastener [N], radial, outwards.
    """
    if fasteners < 1:
        raise ValueError("fasteners must be at least 1")
    u = unbalance.unbalance if isinstance(unbalance, Blank) else float(unbalance)
    return float(bearings.fastener_load(u, speed, fasteners))
