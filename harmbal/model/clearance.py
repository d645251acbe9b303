"""Clearance between moving parts over a revolution (the tractor thesis's
chapter 8 check, on simple 2-D outlines).

Each part is an :class:`~harmbal.scene.shapes.Outline`: a convex polygon
(one point: a circle, two: a rounded bar) grown by a radius, fixed in the
frame of a body: the crank, the con-rod (moved by the exact slider-crank of
:func:`harmbal.model.kinematics.slider_crank`), the piston, a balance shaft
turning at its speed ratio, or the block. Positions are complex numbers
w = z + i·t in the engine's plane normal to the crank axis (t = −sense·y,
90° ahead of +z in the direction of rotation), so a body's motion is a
translation plus a rotation factor, vectorised over crank angles, and the
parts of different cylinders are in one picture.

Signed distance of two convex sets grown by radii r₁, r₂ (exact, no
shapely): d(P, Q) − r₁ − r₂, where d is

* the Euclidean distance when P and Q are disjoint: the smallest distance
  between a vertex of one and a vertex or edge of the other;
* minus the penetration depth when they overlap: by the separating-axis
  theorem, the largest gap between the projections of P and Q over the edge
  normals (and, for a bar, its direction), which is negative exactly when
  they overlap and is then minus the shortest translation that separates
  them.

Growing both sets by discs changes the signed distance by exactly −r₁ − r₂
(the support function of P ⊕ B_r is h_P + r), so circles and rounded bars
are exact too. A negative distance is an overlap: a collision.

Over a revolution the distance of every pair of parts that can meet
(:meth:`~harmbal.scene.shapes.Outline.meets`) is sampled, and the sampled
local minima that can hold the smallest are refined by a golden-section
search in the crank angle.
"""

from __future__ import annotations

import math

import numpy as np

from ..labelled import dataset
from ..scene.schema import Problem, Scene, SceneError
from ..scene.shapes import Outline
from .kinematics import slider_crank

#: Crank angles sampled per revolution before the local minima are refined.
CLEARANCE_SAMPLES = 720
#: Iterations of the golden-section refinement: each keeps 0.618 of the bracket, so from ±2π/8 to 1e-13
#: rad takes 63; the limit only guards against a bracket that stops shrinking.
MAX_REFINEMENTS = 200


def _points(outline: Outline) -> np.ndarray:
    return np.array([complex(u, v) for u, v in outline.points])


def body_motion(scene: Scene, body: str, plane: int, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Origin and rotation factor of a body's frame in the engine's plane
    normal to the crank axis, at crank angles θ [rad]: a point (u, v) of the
    body is at origin + (u + i·v)·rotation, as the complex w = z + i·t [m]
    (t = −sense·y: 90° ahead of +z in the direction of rotation, so that
    the picture is the same for either rotation sense).

    Parameters
    ----------
    scene : Scene
        Supplies the cylinder's geometry and the balance shafts.
    body : str
        ``"crank"``, ``"rod"``, ``"piston"``, ``"block"`` or a shaft's label.
    plane : int
        Index of the cylinder whose plane and crank train it is.
    theta : ndarray
        Crank angles θ [rad] (θ = 0: throw 1 up).

    Returns
    -------
    (ndarray, ndarray)
        Complex origin [m] and unit rotation factor, shaped like ``theta``.
    """
    cyl = scene.cylinders[plane]
    theta = np.asarray(theta, dtype=float)
    psi = theta + cyl.throw - cyl.bank
    ones = np.ones_like(theta)
    bank = np.exp(1j * cyl.bank)  # the cylinder frame (c along its axis, n ahead) turned into the w-plane
    if body == "block":
        return 0j * ones, bank * ones
    if body == "crank":
        return 0j * ones, np.exp(1j * psi) * bank
    if body in ("rod", "piston"):
        sc = slider_crank(psi, cyl.crank_radius, cyl.rod_length, cyl.offset)
        big_end = sc.a[0] + 1j * sc.a[1]
        small_end = sc.b + 1j * sc.e
        if body == "piston":
            return small_end * bank, bank * ones
        return big_end * bank, (small_end - big_end) / cyl.rod_length * bank
    shaft = next(s for s in scene.shafts if s.label == body)
    return complex(shaft.z, -scene.sense * shaft.y) * ones, np.exp(1j * shaft.ratio * theta)


def _segment_point(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distance from points p to segments a–b (broadcast)."""
    ab = b - a
    length2 = np.abs(ab) ** 2
    t = np.clip(np.real((p - a) * np.conj(ab)) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    return np.abs(p - (a + t * ab))


def _edges(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edge start and end points (..., n) of a polygon (..., n) (a point has none, a bar one)."""
    n = points.shape[-1]
    if n == 1:
        return points[..., :0], points[..., :0]
    if n == 2:
        return points[..., :1], points[..., 1:]
    return points, np.roll(points, -1, axis=-1)


def _axes(points: np.ndarray) -> np.ndarray:
    """Unit separating axes (..., k) of a convex polygon: its edge normals, and a bar's direction."""
    start, end = _edges(points)
    edge = end - start
    normal = -1j * edge / np.where(np.abs(edge) > 0, np.abs(edge), 1.0)
    if points.shape[-1] == 2:
        normal = np.concatenate([normal, 1j * normal], axis=-1)
    return normal


def signed_distance(p: np.ndarray, rp: float, q: np.ndarray, rq: float) -> np.ndarray:
    """Signed distance [m] between two convex polygons grown by radii.

    Parameters
    ----------
    p, q : ndarray
        Complex vertices (..., n) and (..., m) [m], counterclockwise, over
        leading (angle) axes that broadcast; one vertex is a point, two a
        segment. Each polygon moves rigidly over the leading axes (its shape
        is that of its first entry), as the parts of a mechanism do.
    rp, rq : float
        Radii [m] the polygons are grown by.

    Returns
    -------
    ndarray
        Distance [m] over the leading axes; negative: they overlap by that much
        (minus the penetration depth).
    """
    lead = np.broadcast_shapes(p.shape[:-1], q.shape[:-1])
    p = np.broadcast_to(p, lead + p.shape[-1:])
    q = np.broadcast_to(q, lead + q.shape[-1:])
    candidates = [np.abs(p[..., :, None] - q[..., None, :]).min(axis=(-2, -1))]
    for one, other in ((p, q), (q, p)):
        start, end = _edges(other)
        if start.shape[-1]:
            candidates.append(_segment_point(start[..., None, :], end[..., None, :], one[..., :, None])
                              .min(axis=(-2, -1)))
    euclid = np.minimum.reduce(candidates)
    if p.shape[-1] + q.shape[-1] == 2:  # two points: disjoint unless they coincide
        return euclid - rp - rq
    low, high = [], []
    for own, other in ((p, q), (q, p)):
        axes = _axes(own)
        if not axes.shape[-1]:
            continue
        # A rigid polygon's extent along its own axes is fixed relative to any one of its vertices: measured
        # once (on the first entry), it costs O(n) per angle instead of O(n²).
        first = (own.reshape(-1, own.shape[-1])[0], axes.reshape(-1, axes.shape[-1])[0])
        rel = np.real((first[0][:, None] - first[0][0]) * np.conj(first[1][None, :]))
        anchor = np.real(own[..., :1] * np.conj(axes))
        other_proj = np.real(other[..., :, None] * np.conj(axes[..., None, :]))
        low += [anchor + rel.min(axis=0), other_proj.min(axis=-2)]
        high += [anchor + rel.max(axis=0), other_proj.max(axis=-2)]
    # Gaps along every axis: projections of p and of q taken in pairs (own extent, the other's).
    gaps = [np.maximum(low[i + 1] - high[i], low[i] - high[i + 1]).max(axis=-1) for i in range(0, len(low), 2)]
    gap: np.ndarray = np.maximum.reduce(gaps)
    return np.where(gap > 0, euclid, gap) - rp - rq


def _placed(scene: Scene, outline: Outline, theta: np.ndarray) -> np.ndarray:
    origin, rotation = body_motion(scene, outline.body, outline.plane, theta)
    return origin[..., None] + _points(outline) * rotation[..., None]


def pair_distance(scene: Scene, first: Outline, second: Outline, theta: np.ndarray) -> np.ndarray:
    """Signed distance [m] between two outlines at crank angles θ [rad]."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    return signed_distance(_placed(scene, first, theta), first.radius, _placed(scene, second, theta), second.radius)


def _minimum(scene: Scene, first: Outline, second: Outline, samples: int) -> tuple[float, float]:
    """Smallest distance over a revolution and the crank angle where it occurs."""
    step = 2 * math.pi / samples
    theta = step * np.arange(samples)
    d = pair_distance(scene, first, second, theta)
    # Round-off in the positions is ~1e-16 of the mechanism's size; a distance that varies less is constant.
    size = max(float(np.abs(_points(o)).max()) + o.radius for o in (first, second))
    size += max(scene.cylinders[o.plane].crank_radius + scene.cylinders[o.plane].rod_length for o in (first, second))
    if d.max() - d.min() <= 1e-12 * size:  # constant: no angle is special
        return float(d.min()), 0.0
    before, after = np.roll(d, 1), np.roll(d, -1)
    # Between two samples the distance cannot fall below a sample by more than the largest change over one
    # step, so only the sampled local minima (a plateau by its ends) within that of the lowest can hold
    # the true minimum.
    reach = float(np.abs(after - d).max())
    local = np.flatnonzero((((d < before) & (d <= after)) | ((d <= before) & (d < after)))
                           & (d <= d.min() + reach))
    # Golden-section search on [θᵢ − step, θᵢ + step] around every such sample at once (one vectorised
    # evaluation per iteration), in the offset from the sample so that the tolerance is absolute.
    ratio = (math.sqrt(5) - 1) / 2
    low, high = np.full(local.size, -step), np.full(local.size, step)
    x1, x2 = high - ratio * (high - low), low + ratio * (high - low)
    f1 = pair_distance(scene, first, second, theta[local] + x1)
    f2 = pair_distance(scene, first, second, theta[local] + x2)
    for _ in range(MAX_REFINEMENTS):
        if not (local.size and np.max(high - low) > 1e-13):
            break
        left = f1 <= f2  # the minimum lies in [low, x2], where x1 becomes the upper inner point; else in [x1, high]
        high, low = np.where(left, x2, high), np.where(left, low, x1)
        kept_x, kept_f = np.where(left, x1, x2), np.where(left, f1, f2)
        new = np.where(left, high - ratio * (high - low), low + ratio * (high - low))
        value = pair_distance(scene, first, second, theta[local] + new)
        x1, f1 = np.where(left, new, kept_x), np.where(left, value, kept_f)
        x2, f2 = np.where(left, kept_x, new), np.where(left, kept_f, value)
    else:
        raise SceneError([Problem(scene.source, "outline", f"{first.part} / {second.part}", (
            f"the smallest distance does not converge in {MAX_REFINEMENTS} refinements: check the outlines' "
            "coordinates (a distance that is not finite)"))])
    best = np.concatenate([[d.min()], f1, f2])
    where = np.concatenate([[theta[int(np.argmin(d))]], theta[local] + x1, theta[local] + x2])
    i = int(np.argmin(best))
    return float(best[i]), float(where[i]) % (2 * math.pi)


def clearance(scene: Scene, *, samples: int = CLEARANCE_SAMPLES):
    """Minimum distance between the outlines of parts on different bodies,
    over one crank revolution.

    Parameters
    ----------
    scene : Scene
        A scene with ``[[outline]]`` tables (``scene.outlines``).
    samples : int
        Crank angles sampled per revolution before each sampled local minimum
        is refined (bounded scalar minimisation, to 1e-12 rad).

    Returns
    -------
    xarray.Dataset
        Over ``pair`` (every two outlines on different bodies that can meet,
        :meth:`~harmbal.scene.shapes.Outline.meets`): ``min_distance`` [m] (negative: overlap, a
        collision), ``angle`` [rad] of crank angle θ in [0, 2π) where it
        occurs, ``collision`` (bool); coordinates ``part_a``, ``part_b``,
        ``body_a``, ``body_b``, ``cylinder_a``, ``cylinder_b`` (the labels of
        the cylinders whose frames the outlines are given in).
    """
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 8:
        raise ValueError(f"samples must be an integer of at least 8, got {samples!r}")
    outlines = scene.outlines
    pairs = [(a, b) for i, a in enumerate(outlines) for b in outlines[i + 1:] if a.meets(b)]
    results = [_minimum(scene, a, b, samples) for a, b in pairs]
    distance = np.array([r[0] for r in results], dtype=float)
    angle = np.array([r[1] for r in results], dtype=float)
    names = [f"{a.part} / {b.part}" for a, b in pairs]
    return dataset(
        {
            "min_distance": ("pair", distance, {"units": "m", "long_name": "smallest distance over a revolution "
                                                "(negative: overlap)"}),
            "angle": ("pair", angle, {"units": "rad", "long_name": "crank angle theta of the smallest distance"}),
            "collision": ("pair", distance < 0, {"long_name": "the parts overlap somewhere in the revolution"}),
        },
        {
            "pair": ("pair", np.array(names, dtype=str)),
            "part_a": ("pair", np.array([a.part for a, _ in pairs], dtype=str)),
            "part_b": ("pair", np.array([b.part for _, b in pairs], dtype=str)),
            "body_a": ("pair", np.array([a.body for a, _ in pairs], dtype=str)),
            "body_b": ("pair", np.array([b.body for _, b in pairs], dtype=str)),
            "cylinder_a": ("pair", np.array([scene.cylinders[a.plane].label for a, _ in pairs], dtype=str)),
            "cylinder_b": ("pair", np.array([scene.cylinders[b.plane].label for _, b in pairs], dtype=str)),
        },
        {"title": f"harmbal clearance check: {scene.name}", "engine": scene.name, "samples": samples,
         "harmbal_conventions": "Outlines in the plane normal to the crank axis, each in a body's frame of one "
                                "cylinder; crank angle theta in the direction of rotation, 0 when throw 1 points "
                                "along +z; distances exact for convex polygons grown by radii (docs/shapes.md)."},
    )
