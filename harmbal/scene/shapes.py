"""Counterweight blanks: plane shapes extruded by a thickness, with a density,
and their mass properties in closed form.

A blank lies in the plane normal to the crank axis, in its own frame (u, v):
the origin on the axis it turns about, u along the direction the scene's
``angle`` names, v 90° ahead of u in the direction of rotation. Every area
shape is defined in a frame of its own (origin at its circle's centre or its
own centre, symmetry axis along +u'), then turned by ``direction`` and moved
to ``centre``; its first moment turns and moves with it:

    S = R(direction)·S' + A·centre,

where A is the area and S' = ∫∫ (u', v') dA the first moment in the shape's
own frame. A hole is any shape with ``hole = True``: its mass counts
negative. Fasteners (bolts, nuts) are point masses at a radius and angle.
Mass m = Σ ±ρ·t·A, unbalance m·x = Σ ±ρ·t·S + Σ m_f·r_f·(cos, sin) [kg m].

Closed forms (own frame; R outer radius, ρ inner radius, α half-angle,
c chord distance from the circle's centre), all from ∫∫ dA and ∫∫ u' dA in
polar or Cartesian coordinates:

* annular sector, |φ| ≤ α, ρ ≤ r ≤ R: A = α(R² − ρ²),
  S'_u = ∫∫ r cos φ · r dr dφ = (2/3)·sin α·(R³ − ρ³), S'_v = 0;
* circular segment u' ≥ c of a disc of radius R (the part beyond a chord):
  A = ∫_c^R 2√(R² − u²) du = R²·acos(c/R) − c·√(R² − c²),
  S'_u = ∫_c^R 2u√(R² − u²) du = (2/3)·(R² − c²)^{3/2};
* strip near ≤ u' ≤ far of the disc (between two parallel chords; near = 0
  is the strip between a diameter and a chord): segment(near) − segment(far);
* box (rectangle) of width w along u' and height h along v', centred on its
  origin: A = w·h, S' = 0;
* disc of radius R about its origin: A = πR², S' = 0.

The sizing solver (the free dimension that meets a target unbalance) is
:func:`harmbal.balance.counterweights.size_blank`; the scene tables are in
``docs/scenes.md`` and the method in ``docs/shapes.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any


@dataclass(frozen=True)
class Sector:
    """Annular sector: radii ``inner_radius`` ≤ r ≤ ``outer_radius`` [m],
    angles within ``half_angle`` [rad] (0 < α ≤ π) of its axis.
    A half-disc is the sector with α = π/2 and no inner radius."""

    outer_radius: float
    half_angle: float
    inner_radius: float = 0.0
    direction: float = 0.0
    centre: tuple[float, float] = (0.0, 0.0)
    thickness: float | None = None
    hole: bool = False

    kind = "sector"

    def own_moments(self) -> tuple[float, float, float]:
        r_out, r_in, a = self.outer_radius, self.inner_radius, self.half_angle
        return a * (r_out**2 - r_in**2), 2.0 / 3.0 * math.sin(a) * (r_out**3 - r_in**3), 0.0


def _segment(radius: float, chord: float) -> tuple[float, float]:
    """Area and first moment along +u' of the part u' ≥ chord of a disc."""
    c = min(max(chord, -radius), radius)  # round-off at the ends of the range
    half = math.sqrt(max(radius * radius - c * c, 0.0))
    return radius * radius * math.acos(c / radius) - c * half, 2.0 / 3.0 * half**3


@dataclass(frozen=True)
class Segment:
    """Circular segment: the part of a disc of radius ``radius`` [m] beyond
    the chord at signed distance ``chord`` [m] from its centre (−R ≤ c ≤ R;
    c = 0 is a half-disc, c < 0 more than half)."""

    radius: float
    chord: float
    direction: float = 0.0
    centre: tuple[float, float] = (0.0, 0.0)
    thickness: float | None = None
    hole: bool = False

    kind = "segment"

    def own_moments(self) -> tuple[float, float, float]:
        area, moment = _segment(self.radius, self.chord)
        return area, moment, 0.0


@dataclass(frozen=True)
class Strip:
    """The part of a disc of radius ``radius`` [m] between two parallel
    chords at distances ``near`` < ``far`` [m] from its centre (near = 0:
    between a diameter and a chord)."""

    radius: float
    near: float
    far: float
    direction: float = 0.0
    centre: tuple[float, float] = (0.0, 0.0)
    thickness: float | None = None
    hole: bool = False

    kind = "strip"

    def own_moments(self) -> tuple[float, float, float]:
        a_near, s_near = _segment(self.radius, self.near)
        a_far, s_far = _segment(self.radius, self.far)
        return a_near - a_far, s_near - s_far, 0.0


@dataclass(frozen=True)
class Box:
    """Rectangle of ``width`` along its axis and ``height`` across it [m],
    centred on ``centre``."""

    width: float
    height: float
    direction: float = 0.0
    centre: tuple[float, float] = (0.0, 0.0)
    thickness: float | None = None
    hole: bool = False

    kind = "box"

    def own_moments(self) -> tuple[float, float, float]:
        return self.width * self.height, 0.0, 0.0


@dataclass(frozen=True)
class Disc:
    """Full disc of ``radius`` [m] about ``centre`` (with ``hole``: a bore)."""

    radius: float
    direction: float = 0.0
    centre: tuple[float, float] = (0.0, 0.0)
    thickness: float | None = None
    hole: bool = False

    kind = "circle"

    def own_moments(self) -> tuple[float, float, float]:
        return math.pi * self.radius**2, 0.0, 0.0


@dataclass(frozen=True)
class PointMass:
    """A fastener (bolt, nut, washer) as a point ``mass`` [kg] at ``radius``
    [m] and ``angle`` [rad] in the blank's frame."""

    mass: float
    radius: float
    angle: float = 0.0

    kind = "fastener"


AreaShape = Sector | Segment | Strip | Box | Disc

#: The dimension of each shape that a sizing can solve for, with its natural range (None: no natural bound,
#: the caller gives one). Ranges are callables of the shape so that they follow its other dimensions.
SOLVABLE = {
    "sector": {"outer_radius": lambda s: (s.inner_radius, None), "half_angle": lambda s: (0.0, math.pi),
               "inner_radius": lambda s: (0.0, s.outer_radius)},
    "segment": {"chord": lambda s: (-s.radius, s.radius), "radius": lambda s: (abs(s.chord), None)},
    "strip": {"far": lambda s: (s.near, s.radius), "near": lambda s: (-s.radius, s.far)},
    "box": {"width": lambda s: (0.0, None), "height": lambda s: (0.0, None)},
    "circle": {"radius": lambda s: (0.0, None)},
    "fastener": {"mass": lambda s: (0.0, None), "radius": lambda s: (0.0, None)},
}


def area_moments(shape: AreaShape) -> tuple[float, float, float]:
    """Area [m²] and first moment (S_u, S_v) [m³] of an area shape in the
    blank's frame (turned by ``direction``, moved to ``centre``), unsigned
    (a hole's sign is applied by :class:`Blank`)."""
    area, s_u, s_v = shape.own_moments()
    c, s = math.cos(shape.direction), math.sin(shape.direction)
    return area, c * s_u - s * s_v + area * shape.centre[0], s * s_u + c * s_v + area * shape.centre[1]


@dataclass(frozen=True)
class Blank:
    """A counterweight blank: area shapes of ``density`` [kg/m³] and
    ``thickness`` [m] (a part may give its own thickness), holes, fasteners.

    ``solve`` optionally names the dimension a sizing may change, as
    (index into ``parts``, field name), with ``solve_range`` (low, high)
    [m or rad] when the dimension has no natural bound (:data:`SOLVABLE`).
    """

    density: float
    thickness: float
    parts: tuple[AreaShape | PointMass, ...]
    solve: tuple[int, str] | None = None
    solve_range: tuple[float, float] | None = None

    def part_mass_moment(self, part: AreaShape | PointMass) -> tuple[float, complex]:
        """Signed mass [kg] and first moment of mass m·(u + iv) [kg m] of one part."""
        if isinstance(part, PointMass):
            return part.mass, part.mass * part.radius * complex(math.cos(part.angle), math.sin(part.angle))
        area, s_u, s_v = area_moments(part)
        factor = (-1.0 if part.hole else 1.0) * self.density * (self.thickness if part.thickness is None
                                                                 else part.thickness)
        return factor * area, factor * complex(s_u, s_v)

    @property
    def mass(self) -> float:
        """Mass [kg]: the shapes minus the holes, plus the fasteners."""
        return math.fsum(self.part_mass_moment(p)[0] for p in self.parts)

    @property
    def moment(self) -> complex:
        """First moment of mass m·(u_G + i·v_G) [kg m] in the blank's frame:
        the unbalance as a complex number."""
        moments = [self.part_mass_moment(p)[1] for p in self.parts]
        return complex(math.fsum(m.real for m in moments), math.fsum(m.imag for m in moments))

    @property
    def unbalance(self) -> float:
        """Unbalance m·x [kg m] (size of :attr:`moment`)."""
        return abs(self.moment)

    @property
    def unbalance_angle(self) -> float:
        """Direction [rad] of the unbalance from the blank's u axis, in the
        direction of rotation."""
        return math.atan2(self.moment.imag, self.moment.real)

    @property
    def centroid(self) -> tuple[float, float]:
        """Centre of mass (u_G, v_G) [m] in the blank's frame."""
        m = self.mass
        return self.moment.real / m, self.moment.imag / m

    @property
    def centroid_radius(self) -> float:
        """Distance x [m] of the centre of mass from the axis: unbalance / mass."""
        return self.unbalance / self.mass

    def with_dimension(self, value: float, solve: tuple[int, str] | None = None) -> "Blank":
        """The same blank with the dimension ``solve`` (default
        :attr:`solve`) set to ``value``."""
        index, name = self._chosen(solve)
        parts = list(self.parts)
        change: dict[str, Any] = {name: value}
        parts[index] = replace(parts[index], **change)
        return replace(self, parts=tuple(parts))

    def _chosen(self, solve: tuple[int, str] | None) -> tuple[int, str]:
        """``solve``, else the blank's own :attr:`solve`, which a sized blank has."""
        chosen = solve or self.solve
        assert chosen is not None, "a blank without solve needs the dimension to change"
        return chosen

    def dimension(self, solve: tuple[int, str] | None = None) -> float:
        """The current value of the dimension ``solve`` (default :attr:`solve`)."""
        index, name = self._chosen(solve)
        return getattr(self.parts[index], name)


# --------------------------------------------------------------------------
# Outlines for the clearance check

#: Bodies an outline can move with, besides a balancer shaft named by its label.
OUTLINE_BODIES = ("crank", "rod", "piston", "block")

#: Largest distance [m] by which a sector outline's circumscribed polygon stands outside its arc.
ARC_TOLERANCE = 1e-5


@dataclass(frozen=True)
class Outline:
    """A part's 2-D outline for the clearance check: the set of points within
    ``radius`` [m] of the convex polygon ``points`` [m] (counterclockwise, in
    the frame of ``body``): one point with a radius is a circle, two a
    rounded bar, more a polygon (``radius`` 0: sharp corners).

    ``body`` is one of :data:`OUTLINE_BODIES` or a balancer shaft's label;
    ``plane`` the index (0-based) of the cylinder in whose frames it is
    given (its throw, rod, piston and axis). Frames (u, v): crank:
    origin on the crank axis, u towards this cylinder's crank pin; rod:
    origin at the crank-pin centre, u along the rod towards the piston pin;
    piston: origin at the piston pin, u along the cylinder axis away from
    the crank; block: origin on the crank axis, u along the cylinder axis;
    a shaft: origin on its axis, u up (+z) at θ = 0. In every frame v is 90°
    ahead of u in the direction of rotation. ``axial_range`` (x_min, x_max)
    [m] is the part's extent along the crank axis: two parts whose ranges
    do not overlap pass each other (None: it meets the parts of its own
    cylinder's plane only).
    """

    part: str
    body: str
    plane: int
    points: tuple[tuple[float, float], ...]
    radius: float = 0.0
    axial_range: tuple[float, float] | None = None

    @property
    def moving_body(self) -> tuple[str, int | None]:
        """The rigid body it is fixed to: each cylinder has its own rod and
        piston; the crank, the block and a shaft are one body for all."""
        return (self.body, self.plane if self.body in ("rod", "piston") else None)

    def meets(self, other: "Outline") -> bool:
        """Whether the two parts can touch: on different bodies, and either
        both with overlapping axial ranges or, if either has none, in the same
        cylinder's plane."""
        if self.moving_body == other.moving_body:
            return False
        if self.axial_range is None or other.axial_range is None:
            return self.plane == other.plane
        return self.axial_range[0] < other.axial_range[1] and other.axial_range[0] < self.axial_range[1]


def sector_polygon(radius: float, half_angle: float, direction: float = 0.0,
                   centre: tuple[float, float] = (0.0, 0.0)) -> tuple[tuple[float, float], ...]:
    """A pie sector (0 < α ≤ π/2) as a convex polygon that contains it: its
    arc replaced by tangent segments standing at most :data:`ARC_TOLERANCE`
    outside it (R·(sec(δ/2) − 1) ≤ tolerance for segments of angle δ), so a
    clearance computed with it is conservative by at most that much."""
    step = 2.0 * math.acos(1.0 / (1.0 + ARC_TOLERANCE / radius))
    count = max(1, math.ceil(2.0 * half_angle / step))
    delta = 2.0 * half_angle / count
    angles = [-half_angle + (k + 0.5) * delta for k in range(count)]
    ring = ([(radius, -half_angle)] + [(radius / math.cos(delta / 2), a) for a in angles]
            + [(radius, half_angle)])
    points = [(0.0, 0.0)] + [(r * math.cos(a + direction), r * math.sin(a + direction)) for r, a in ring]
    return tuple((centre[0] + u, centre[1] + v) for u, v in points)


def convex_ccw(points) -> tuple[tuple[float, float], ...] | None:
    """The vertices counterclockwise if they form a convex polygon (in the
    order given, either way round), else None. One or two points pass."""
    pts: list[tuple[float, float]] = [tuple(map(float, p)) for p in points]  # type: ignore[misc]  # pairs
    if len(pts) < 3:
        return tuple(pts)
    n = len(pts)
    cross = [(pts[(i + 1) % n][0] - pts[i][0]) * (pts[(i + 2) % n][1] - pts[(i + 1) % n][1])
             - (pts[(i + 1) % n][1] - pts[i][1]) * (pts[(i + 2) % n][0] - pts[(i + 1) % n][0]) for i in range(n)]
    scale = max(abs(c) for c in cross)
    if scale == 0:
        return None
    if all(c >= -1e-12 * scale for c in cross):
        return tuple(pts)
    if all(c <= 1e-12 * scale for c in cross):
        return tuple(reversed(pts))
    return None
