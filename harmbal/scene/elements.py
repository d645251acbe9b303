"""Balancer elements as the scene describes them: rotating shafts (balance shafts,
counterweights, the crankshaft's mass data) and lever (linkage) balancers, with the
closed-form check that a lever's loop closes (a scene that cannot assemble is refused).

Their loads are computed in :mod:`harmbal.model.balancers` and :mod:`harmbal.model.linkage`.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np

#: Sign conventions for products of inertia: "integral" is J_xy = +∫x·y dm;
#: "tensor" is the inertia-tensor entry D_xy = −∫x·y dm.
PRODUCT_CONVENTIONS = ("integral", "tensor")


@dataclass(frozen=True)
class ShaftUnbalance:
    """Static unbalance on a shaft: mass × radius [kg m] pointing at ``angle``
    [rad] at θ = 0, at axial position ``x`` [m]."""

    unbalance: float
    angle: float
    x: float


@dataclass(frozen=True)
class Shaft:
    """A body turning at ``ratio`` × crank speed about the axis through
    (``y``, ``z``) parallel to x.

    ``couple`` is the complex couple unbalance [kg m²] in the w-plane at
    θ = 0 (see the module docstring).
    """

    label: str
    ratio: int
    y: float
    z: float
    unbalances: tuple[ShaftUnbalance, ...] = ()
    couple: complex = 0j

    @property
    def on_crank(self) -> bool:
        """Part of the crankshaft: turns with it on its axis (counterweights,
        the crankshaft's CAD data)."""
        return self.ratio == 1 and self.y == 0 and self.z == 0


def couple_from_products(j_xy: float, j_xz: float, convention: str, sense: int) -> complex:
    """The complex couple unbalance [kg m²] from products of inertia about the
    shaft's reference point, in the engine frame at θ = 0."""
    if convention not in PRODUCT_CONVENTIONS:
        raise ValueError(f"unknown product-of-inertia convention {convention!r}")
    sign = 1.0 if convention == "integral" else -1.0
    return complex(sign * j_xy, sign * sense * j_xz)


def couple_from_moment(moment: float, angle: float) -> complex:
    """The complex couple unbalance from its size [kg m²] (moment / Ω²) and the
    direction [rad] of its moment vector at θ = 0."""
    return cmath.rect(moment, angle)


#: Assembly modes: B ahead of (+1) or behind (−1) the directed line A→C.
ASSEMBLY_MODES = {"ahead": 1, "behind": -1}


#: Below this minimum transmission angle a lever balancer gets a warning: the
#: force at B is the links' inertia divided by a·b·sin γ, and the links'
#: accelerations themselves grow as γ → 0, so the joint forces rise steeply and
#: the motion becomes sensitive to tolerances (textbooks ask for at least 40°).
TRANSMISSION_WARNING = math.radians(30.0)


class LinkageWarning(UserWarning):
    """A lever balancer that assembles but works close to its toggle position."""


@dataclass(frozen=True)
class LinkBody:
    """A link's mass [kg], CG (x, y) [m] in its local frame and moment of
    inertia about the CG [kg m²]."""

    mass: float
    cg: tuple[float, float]
    inertia: float


@dataclass(frozen=True)
class LeverBalancer:
    """A four-bar lever balancer (see the module docstring for the frames).

    ``pivot`` is A as engine coordinates (y, z) [m]; ``assembly`` one of
    :data:`ASSEMBLY_MODES`.
    """

    label: str
    x: float
    pin_radius: float
    pin_angle: float
    pivot: tuple[float, float]
    rocker_length: float
    coupler_length: float
    assembly: str
    rocker: LinkBody
    coupler: LinkBody

    def pivot_w(self, sense: int) -> complex:
        """A in the w-plane."""
        y, z = self.pivot
        return complex(z, -sense * y)


@dataclass(frozen=True)
class Closure:
    """Whether and how well a lever balancer's loop closes over the revolution.

    ``distance`` is the range (min, max) of |A→C| [m] and ``range`` the
    interval (|a − b|, a + b) it must stay strictly inside; ``failure`` names
    the crank angle θ [rad] of the worst violation (None if it closes).
    ``margin`` = min sin²γ = min Δ/(4a²b²) over the revolution (0 at toggle)
    and ``min_transmission_angle`` = min over θ of min(γ, π − γ) [rad], with
    the crank angle where it occurs.
    """

    distance: tuple[float, float]
    range: tuple[float, float]
    failure: tuple[str, float] | None
    margin: float
    min_transmission_angle: float
    min_transmission_theta: float


def closure(lever: LeverBalancer, sense: int) -> Closure:
    """Check in closed form that the loop closes at every crank angle.

    |A→C| runs between | |A| − r_C | and |A| + r_C; the extremes occur with C
    pointing towards A and away from it. The discriminant Δ (module
    docstring) is smallest at one of these two extremes, so the minimum
    transmission angle is exact, not sampled.
    """
    a, b, r = lever.rocker_length, lever.coupler_length, lever.pin_radius
    pivot = lever.pivot_w(sense)
    dist = abs(pivot)
    towards = math.atan2(pivot.imag, pivot.real)  # direction of A from D in the w-plane
    # C at angle θ + pin_angle: nearest A at θ = towards − pin_angle, farthest half a turn later.
    near_theta = (towards - lever.pin_angle) % (2 * math.pi)
    far_theta = (near_theta + math.pi) % (2 * math.pi)
    d_min, d_max = abs(dist - r), dist + r
    low, high = abs(a - b), a + b
    failure = None
    if d_max >= high:
        failure = ("long", far_theta)
    elif d_min <= low:
        failure = ("short", near_theta)

    def sin2(d: float) -> float:
        return ((a + b) ** 2 - d * d) * (d * d - (a - b) ** 2) / (4 * a * a * b * b)

    # In numpy floats: lengths far out of scale (a scene's typo) overflow to inf or nan here instead of
    # raising, and the failure above is reported in words.
    a, b, d_min, d_max = (np.float64(v) for v in (a, b, d_min, d_max))
    with np.errstate(all="ignore"):
        margin = float(min(sin2(d_min), sin2(d_max)))  # at the same extreme as the smallest acute γ below
        # γ from cos γ = (a² + b² − d²)/(2ab); the acute angle is the one that matters.
        gammas = []
        for d, th in ((d_min, near_theta), (d_max, far_theta)):
            g = float(np.arccos(np.clip((a * a + b * b - d * d) / (2 * a * b), -1.0, 1.0)))
            gammas.append((min(g, math.pi - g), th))
    gamma, gamma_theta = min(gammas)
    d_min, d_max = float(d_min), float(d_max)
    return Closure((d_min, d_max), (low, high), failure, margin, gamma, gamma_theta)


def closure_message(lever: LeverBalancer, result: Closure) -> str:
    """Why the loop cannot close, in words with the numbers."""
    assert result.failure is not None, "only a loop that cannot close has a failure to word"
    kind, theta = result.failure
    a, b = lever.rocker_length * 1e3, lever.coupler_length * 1e3
    d_min, d_max = (v * 1e3 for v in result.distance)
    where = f"at crank angle θ = {math.degrees(theta):.6g}°"
    if kind == "long":
        verb = "exceeds" if d_max > a + b else "equals (toggle: rocker and coupler in line)"
        return (f"the linkage cannot close {where}: pivot-to-pin distance |A→C| = {d_max:.6g} mm {verb} "
                f"rocker_length + coupler_length = {a + b:.6g} mm")
    verb = "is below" if d_min < abs(a - b) else "equals (toggle: rocker and coupler folded)"
    return (f"the linkage cannot close {where}: pivot-to-pin distance |A→C| = {d_min:.6g} mm {verb} "
            f"|rocker_length − coupler_length| = {abs(a - b):.6g} mm")
