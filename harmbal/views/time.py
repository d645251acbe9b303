"""The time-domain view: exact shaking force and moment over one revolution as a Dataset."""

from __future__ import annotations

import numpy as np

from .._version import __version__
from ..labelled import AXES, CONVENTIONS, speed_axis
from ..model.evaluate import moment_about, unit_speed_loads
from ..model.sampling import body_decay_rates, choose_samples
from ..scene import EFFECTS, Scene


def simulate(scene: Scene, *, per_cylinder: bool = False, samples_per_rev: int | None = None):
    """Exact shaking force and moment on the block over one crank revolution.

    Parameters
    ----------
    scene : Scene
        A scene from :func:`harmbal.load_scene`.
    per_cylinder : bool, default False
        Also return each cylinder's contribution (``force_cylinder``,
        ``moment_cylinder``, dim ``cylinder``); crankshaft unbalances belong to
        no cylinder and are in the totals only.
    samples_per_rev : int, optional
        Override the scene's sampling.

    Returns
    -------
    xarray.Dataset
        Dims ``angle`` (crank angle θ [rad]), ``axis`` (x, y, z) and, when the
        scene has several speeds, ``speed`` [rad/s] (with an ``rpm``
        coordinate). Variables ``force`` [N] and ``moment`` [N m] about the
        scene's reference point, and ``force_scale``/``moment_scale``, the sums
        of bounds on the single bodies' peak loads (the same as
        :func:`harmbal.stars`'), used to judge what is "zero", and
        ``aliasing_error_force``/``aliasing_error_moment`` (per axis), the
        aliasing estimate of the order phasors summed body by body
        (:func:`body_aliasing`).
    """
    import xarray as xr

    n = samples_per_rev or choose_samples(scene)
    unit = unit_speed_loads(scene, n)
    ref = np.asarray(scene.reference_point)
    moment_cyl = moment_about(ref, unit.force_cylinder, unit.moment_cylinder)
    moment_crank = moment_about(ref, unit.force_crankshaft, unit.moment_crankshaft)
    force = unit.force_cylinder.sum(axis=0) + unit.force_crankshaft
    moment = moment_cyl.sum(axis=0) + moment_crank

    # One definition of the load scale for both paths (the order domain's bound on each body's
    # peak), so that a component is "balanced" in harmbal run exactly when it is in harmbal stars.
    from ..orders.phasors import order_phasors

    bounds = order_phasors(scene, samples_per_rev=n)
    force_scale = float(bounds.peak_force.sum() + bounds.crankshaft_peak_force)
    moment_scale = float(bounds.peak_moment.sum() + bounds.crankshaft_peak_moment)
    rates = body_decay_rates(scene)
    alias_force = body_aliasing(unit.force_cylinder, unit.force_crankshaft, scene.sampling.max_order, rates)
    alias_moment = body_aliasing(moment_cyl, moment_crank, scene.sampling.max_order, rates)

    lead, w2, coords = speed_axis(scene)

    def scaled(values):
        """Unit-speed values times ω², with a leading speed dim if several."""
        return np.multiply.outer(w2, values) if lead else w2 * values

    coords.update({
        "angle": ("angle", unit.theta, {"units": "rad", "long_name": "crank angle θ",
                                        "description": "angle of throw 1 from +z, in the direction of rotation"}),
        "axis": ("axis", list(AXES), {"long_name": "engine axis"}),
    })
    data = {
        "force": (lead + ("axis", "angle"), scaled(force), {"units": "N", "long_name": "shaking force on the block"}),
        "moment": (lead + ("axis", "angle"), scaled(moment),
                   {"units": "N m", "long_name": "shaking moment on the block about the reference point"}),
        "force_scale": (lead, w2 * force_scale, {"units": "N", "long_name": "sum of single-body peak forces"}),
        "moment_scale": (lead, w2 * moment_scale, {"units": "N m", "long_name": "sum of single-body peak moments"}),
        "aliasing_error_force": (lead + ("axis",), scaled(alias_force), {
            "units": "N", "long_name": "estimated aliasing error of the force phasors, body by body"}),
        "aliasing_error_moment": (lead + ("axis",), scaled(alias_moment), {
            "units": "N m", "long_name": "estimated aliasing error of the moment phasors, body by body"}),
    }
    if per_cylinder:
        coords["cylinder"] = ("cylinder", [c.label for c in scene.cylinders], {"long_name": "cylinder label"})
        dims = lead + ("cylinder", "axis", "angle")
        data["force_cylinder"] = (dims, scaled(unit.force_cylinder), {"units": "N", "long_name": "force of one cylinder"})
        data["moment_cylinder"] = (dims, scaled(moment_cyl), {"units": "N m", "long_name": "moment of one cylinder"})
    return xr.Dataset(data, coords, attrs=attributes(scene, n))


def body_aliasing(per_cylinder: np.ndarray, crankshaft: np.ndarray, max_order: int,
                  rates: np.ndarray | float = 0.0) -> np.ndarray:
    """Aliasing estimate per axis of the orders ≤ ``max_order``, summed over
    the cylinders (and the crankshaft's elements) without cancellation.

    The tail of the *total* spectrum can mislead: an engine whose cylinders
    cancel every order in the sampled tail band (a W24 keeps only multiples
    of 12 in its moment) hides the orders beyond it that fold back onto the
    orders kept. Each body's own spectrum decays smoothly, so the sum of their
    tail estimates (:func:`harmbal.orders.aliasing_estimate`) bounds the
    total's aliasing whatever cancels. ``rates`` (per body, from
    :func:`body_decay_rates`) keeps each fit from decaying faster than the
    geometry allows.
    """
    from ..orders.spectrum import aliasing_estimate, phasors

    n = per_cylinder.shape[-1]
    bodies = np.concatenate([per_cylinder, crankshaft[None]])  # (body, axis, angle)
    slowest = np.broadcast_to(np.asarray(rates, dtype=float), bodies.shape[:1])[:, None]
    return aliasing_estimate(np.abs(phasors(bodies)), n, max_order, slowest).sum(axis=0)


def attributes(scene: Scene, samples: int) -> dict:
    model = scene.model
    return {
        "title": f"harmbal time-domain shaking loads: {scene.name}",
        "engine": scene.name,
        "harmbal_version": __version__,
        "conventions": CONVENTIONS,
        "rotation": scene.rotation,
        "cycle_strokes": scene.cycle,
        "reference_point": np.asarray(scene.reference_point, dtype=float),
        "reference_point_units": "m",
        "effects": " ".join(e for e in EFFECTS if e in model.effects),
        "piston_model": model.piston if model.piston == "exact" else f"series-{model.series_harmonics}",
        "rod_model": model.rod,
        "samples_per_rev": samples,
        "max_order": scene.sampling.max_order,
        # The relative accuracy asked for; 0 when the scene fixes samples_per_rev instead.
        "accuracy_target": float(scene.sampling.accuracy) if scene.sampling.samples_per_rev is None else 0.0,
    }
