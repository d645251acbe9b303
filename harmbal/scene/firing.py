"""Firing sequence and firing intervals from the crank geometry.

Each cylinder fires at top dead centre (TDC): once per revolution in a
two-stroke, once every other revolution in a four-stroke. TDC is where the
crank and the rod are in line, at local crank angle ψ = asin(e/(l + r)) for a
pin-path offset e, i.e. at crank angle θ = ψ_TDC − φ + β for throw φ and
bank β.

* A two-stroke's firing sequence follows from the geometry alone.
* A four-stroke can fire each cylinder at either of its two TDCs. Given a
  firing order, consecutive firings are one of the cylinders' TDCs apart, and
  the revolutions that close the cycle go to the shortest gaps, which makes
  the firing as even as the order allows. Without an order, cylinders sharing
  a TDC first alternate between the two revolutions; if that is not even,
  the most even assignment is searched for exhaustively (up to 16 cylinders).
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np

TWO_PI = 2 * np.pi
#: Angles closer than this [rad] are the same firing instant.
ANGLE_TOL = 1e-9
#: Largest engine whose four-stroke firing assignment is searched exhaustively.
EXHAUSTIVE_LIMIT = 16


class FiringOrderError(ValueError):
    """A firing order that the crank geometry cannot realise."""


class FiringWarning(UserWarning):
    """A firing order the crank can realise only by firing two cylinders it
    lists one after the other at the same instant."""


@dataclass(frozen=True)
class Firing:
    """A firing sequence.

    Attributes
    ----------
    sequence : tuple of int
        Cylinder indices in firing order, starting with cylinder index 0.
    angle : ndarray
        Crank angle θ [rad] at which each cylinder fires (by cylinder index),
        in [0, 2π·cycle/2).
    interval : ndarray
        Crank angle [rad] from each firing in ``sequence`` to the next (the
        last one back to the first); they sum to the cycle, 2π·cycle/2.
    given : bool
        True if the order came from the scene, False if derived.
    """

    sequence: tuple[int, ...]
    angle: np.ndarray
    interval: np.ndarray
    given: bool

    @property
    def even(self) -> bool:
        """True if all firing intervals are equal."""
        return bool(np.ptp(self.interval) <= ANGLE_TOL * len(self.interval))


def tdc_angles(throw, bank, crank_radius, rod_length, offset) -> np.ndarray:
    """Crank angles θ in [0, 2π) at which each cylinder is at TDC [rad]."""
    psi = np.arcsin(np.asarray(offset, float) / (np.asarray(rod_length, float) + np.asarray(crank_radius, float)))
    angles = np.mod(psi - np.asarray(throw, float) + np.asarray(bank, float), TWO_PI)
    return np.where(angles < TWO_PI, angles, 0.0)  # mod of a tiny negative angle rounds to 2π


def _canonical(angles: np.ndarray) -> np.ndarray:
    """Angles in [0, 2π) with values within the tolerance of 2π mapped to 0."""
    angles = np.mod(angles, TWO_PI)
    return np.where(TWO_PI - angles < ANGLE_TOL, 0.0, angles)


def _from_sequence(tdc: np.ndarray, sequence: tuple[int, ...], revolutions: int, given: bool) -> Firing:
    """Firing angles and intervals for a given cyclic sequence of cylinders."""
    n = len(sequence)
    base = _canonical(tdc[list(sequence[1:]) + [sequence[0]]] - tdc[list(sequence)])
    turns = round(float(base.sum()) / TWO_PI)
    spare = revolutions - turns
    if spare < 0:
        raise FiringOrderError(
            f"the order winds {turns} times round the crank; a {2 * revolutions}-stroke cycle allows {revolutions}")
    interval = base.copy()
    for _ in range(spare):  # each spare revolution goes to the shortest gap: the most even firing
        interval[int(np.argmin(interval + np.arange(n) * ANGLE_TOL))] += TWO_PI
    angle = np.empty(n)
    angle[list(sequence)] = tdc[sequence[0]] + np.concatenate([[0.0], np.cumsum(interval[:-1])])
    angle = np.mod(angle, TWO_PI * revolutions)
    return Firing(tuple(sequence), angle, interval, given)


def firing(throw, bank, crank_radius, rod_length, offset, cycle: int, order: tuple[int, ...] | None = None) -> Firing:
    """Firing sequence and intervals of an engine.

    Parameters
    ----------
    throw, bank, crank_radius, rod_length, offset : array_like
        Per cylinder: throw and bank angles [rad], crank radius, rod length and
        pin-path offset [m].
    cycle : {2, 4}
        Strokes per cycle.
    order : tuple of int, optional
        A firing order (cylinder indices, each once). Without it, the most even
        firing the geometry allows is derived.

    Returns
    -------
    Firing

    Raises
    ------
    FiringOrderError
        If ``order`` cannot be realised by the geometry.
    """
    tdc = tdc_angles(throw, bank, crank_radius, rod_length, offset)
    n = len(tdc)
    revolutions = cycle // 2
    if order is not None:
        start = order.index(0)
        return _from_sequence(tdc, tuple(order[start:] + order[:start]), revolutions, given=True)
    relative = _canonical(tdc - tdc[0])
    if revolutions == 1 or n == 1:
        return _from_sequence(tdc, _sorted(relative), revolutions, given=False)
    # Cylinders sharing a TDC alternate between the revolutions; when that
    # fires evenly nothing can be more even.
    alternating = relative.copy()
    for k, i in enumerate(_sorted(relative)):
        alternating[i] += TWO_PI * (k % 2)
    result = _from_sequence(tdc, _sorted(alternating), revolutions, given=False)
    if result.even or n > EXHAUSTIVE_LIMIT:
        return result
    choices = np.array(list(itertools.product((0.0, TWO_PI), repeat=n - 1)))
    fire = relative[1:] + choices
    sorted_fire = np.sort(fire, axis=1)
    gaps = np.diff(np.concatenate([np.zeros((len(fire), 1)), sorted_fire, np.full((len(fire), 1), 2 * TWO_PI)],
                                  axis=1), axis=1)
    worst = gaps.max(axis=1)
    best = np.flatnonzero(worst <= worst.min() + ANGLE_TOL)
    candidates = [_sorted(np.concatenate([[0.0], fire[i]])) for i in best]
    return _from_sequence(tdc, min(candidates), revolutions, given=False)


def cylinder_firing(cylinders, cycle: int, order: tuple[int, ...] | None = None) -> Firing:
    """:func:`firing` of a sequence of :class:`harmbal.scene.Cylinder`
    (remembered for the last few engines: its arrays are read-only)."""
    return _cached_firing(tuple(c.throw for c in cylinders), tuple(c.bank for c in cylinders),
                          tuple(c.crank_radius for c in cylinders), tuple(c.rod_length for c in cylinders),
                          tuple(c.offset for c in cylinders), cycle, None if order is None else tuple(order))


@functools.lru_cache(maxsize=64)
def _cached_firing(*args) -> Firing:
    result = firing(*args)
    for array in (result.angle, result.interval):
        array.flags.writeable = False
    return result


def _sorted(angles: np.ndarray) -> tuple[int, ...]:
    """Cylinder indices by angle (ties by index), rotated to start at 0."""
    sequence = sorted(range(len(angles)), key=lambda i: (round(float(angles[i]) / ANGLE_TOL), i))
    start = sequence.index(0)
    return tuple(sequence[start:] + sequence[:start])
