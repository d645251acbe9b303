"""Crank stars: the angles k·φ_i of each order, their arms and regularity."""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

#: Angles of a crank star closer than this [rad] form one arm.
STAR_TOL = 1e-9


def star_arms(angles: np.ndarray, tol: float = STAR_TOL) -> list[tuple[float, list[int]]]:
    """Distinct arms of a crank star: each arm's angle [rad, in [0, 2π)] and
    the indices of the cylinders on it, in order of angle. Angles within
    ``tol`` of an arm's first angle, also across 0 = 2π, are one arm."""
    angles = np.mod(np.asarray(angles, dtype=float), 2 * np.pi)
    arms: list[tuple[float, list[int]]] = []
    for i in np.argsort(angles, kind="stable"):
        a = float(angles[i])
        if arms and a - arms[-1][0] <= tol:
            arms[-1][1].append(int(i))
        else:
            arms.append((a, [int(i)]))
    if len(arms) > 1 and arms[0][0] + 2 * np.pi - arms[-1][0] <= tol:
        arms[0][1].extend(arms.pop()[1])
    return arms


def star_is_regular(angles: np.ndarray, tol: float = STAR_TOL) -> bool:
    """True if the arms {angles} are equally spaced round the circle (at least
    two distinct arms) with equal multiplicity."""
    arms = star_arms(angles, tol)
    m = len(arms)
    if m < 2 or len({len(members) for _, members in arms}) != 1:
        return False
    first = np.array([a for a, _ in arms])
    gaps = np.diff(np.append(first, first[0] + 2 * np.pi))
    return bool(np.all(np.abs(gaps - 2 * np.pi / m) <= m * tol))


def crank_stars(throws: Sequence[float] | np.ndarray, banks: Sequence[float] | np.ndarray, max_order: int):
    """Star angles (order, cylinder), regularity and resultants of the whole
    crank and of each bank, for cylinders with these throw and bank angles
    [rad]. Cached: a design loop or a repeated analysis asks for the same
    stars again (read-only arrays)."""
    return _crank_stars(tuple(map(float, throws)), tuple(map(float, banks)), int(max_order))


@functools.lru_cache(maxsize=256)
def _crank_stars(throws: tuple[float, ...], banks: tuple[float, ...], kmax: int):
    throw = np.array(throws)
    bank = np.array(banks)
    distinct: list[float] = []  # the bank angles, each once
    for b in bank:
        if not any(abs(np.remainder(b - q + np.pi, 2 * np.pi) - np.pi) <= STAR_TOL for q in distinct):
            distinct.append(b)
    member = [np.abs(np.remainder(bank - q + np.pi, 2 * np.pi) - np.pi) <= STAR_TOL for q in distinct]
    order = np.arange(kmax + 1)
    angles = np.mod(np.outer(order, throw), 2 * np.pi)
    unit = np.exp(1j * angles)
    regular = np.array([star_is_regular(row) for row in angles])
    bank_regular = np.array([[star_is_regular(row[m]) for m in member] for row in angles])
    bank_resultant = np.stack([unit[:, m].sum(axis=1) for m in member], axis=1)
    out = angles, regular, unit.sum(axis=1), np.array(distinct), bank_regular, bank_resultant
    for array in out:
        array.flags.writeable = False
    return out
