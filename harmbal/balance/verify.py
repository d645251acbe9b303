"""Verification of a balancer design by the exact model.

The judge is the exact time-domain model with the balancer elements (one
evaluation, :func:`harmbal.model.evaluate.evaluate`, on a fine grid, and the
FFT of its totals), not the order-domain phasors the design was computed
from. For every targeted order
and component the exact residual is set next to the residual the design
predicted (the scene's ``[verify]`` table, written by ``harmbal design``) and
passes if they agree within the tolerance; the loads without any balancer
elements give the "before" values, the peaks over the revolution per axis and
the percentage removed.
"""

from __future__ import annotations


import numpy as np

from ..labelled import Speeds, dataset
from ..model.evaluate import evaluate
from ..model.sampling import choose_samples
from ..orders.spectrum import BALANCED_RTOL, phasors, rotating_split
from ..scene import Scene
from ..scene.requests import COMPONENTS, PEAK_SAMPLES, VerifyRequest
from ..views.stars import VERIFY_RTOL
from ..views.time import body_aliasing


class VerifyError(ValueError):
    """Nothing to verify: no ``[verify]`` table and no orders given."""


def _components(spectrum: np.ndarray, sense: int) -> np.ndarray:
    """Per component of :data:`COMPONENTS`, the phasors (component, order) of
    one force and moment spectrum (force/moment, axis, order)."""
    co_f, counter_f = rotating_split(spectrum[0, 2], -sense * spectrum[0, 1])
    co_m, counter_m = rotating_split(spectrum[1, 2], -sense * spectrum[1, 1])
    return np.stack([co_f, counter_f, co_m, counter_m, spectrum[1, 0]])


def verify(scene: Scene, request: VerifyRequest | None = None, *, backend: str = "scipy"):
    """Check balancer elements against the exact model.

    Parameters
    ----------
    scene : Scene
        A scene with balancer elements, e.g. the output of ``harmbal design``.
    request : VerifyRequest, optional
        Targeted orders and components and the predicted residuals; default
        the scene's ``[verify]`` table. Without predictions every targeted
        component must vanish.
    backend : {"scipy", "numpy", "pyfftw"}
        FFT implementation.

    Returns
    -------
    xarray.Dataset
        Dims ``order`` (the targeted orders), ``component`` (force_co,
        force_counter, moment_co, moment_counter, roll), ``axis``, plus
        ``speed`` if the scene has several. ``before`` (without balancer
        elements), ``predicted`` and ``exact`` phasors, ``difference`` =
        |exact − predicted|, ``tolerance`` and ``passed`` per order and
        component (non-targeted components always pass); per axis,
        ``peak_force_before``/``_after`` and ``peak_moment_before``/``_after``
        over the revolution (all orders) with ``peak_force_removed`` and
        ``peak_moment_removed`` [%]; per order and axis, the amplitudes
        ``force_before``/``force_after`` (and moment) with the share removed.
        The attribute ``passed`` is ``"yes"`` if everything passes.

    Raises
    ------
    VerifyError
        If there is no request or it names an order above the scene's
        ``max_order``.
    """
    request = request or scene.verify
    if request is None:
        raise VerifyError(f"{scene.source}: nothing to verify: the scene has no [verify] table (harmbal design "
                          "writes one); give the orders to check")
    if max(request.orders) > scene.sampling.max_order:
        raise VerifyError(f"{scene.source}: order {max(request.orders)} is above sampling.max_order = "
                          f"{scene.sampling.max_order}")
    samples = max(choose_samples(scene), PEAK_SAMPLES)  # peaks over the revolution need fine sampling
    unit = evaluate(scene, samples)  # one evaluation: "before" is the same loads without the elements
    orders = list(request.orders)
    after, before = np.stack(unit.total()), np.stack(unit.total(elements=False))  # (force/moment, axis, angle)
    spectra = phasors(np.stack([after, before]), backend)[..., : max(orders) + 1]  # (after/before, f/m, axis, order)
    # The co/counter split needs the orders from 0 (order 0 is a fixed vector); then keep the orders asked for.
    exact, unbalanced = (_components(spectrum, unit.sense)[:, orders] for spectrum in spectra)  # (component, order)
    spectra = spectra[..., orders]
    alias_force, alias_moment = body_aliasing(unit, backend)

    names = [n for n, _ in COMPONENTS]
    is_force = np.array([g == "force" for _, g in COMPONENTS])
    targeted = np.array([g in request.cancel for _, g in COMPONENTS])
    speeds = Speeds(scene.speeds)
    w2, lead, at_speed = np.asarray(speeds.w2), speeds.lead, speeds.scaled

    predicted = np.zeros((len(orders), len(names)), dtype=complex)
    for k, name, value in request.predicted:
        predicted[orders.index(k), names.index(name)] = value
    ratio = w2 / request.speed**2 if request.speed else np.ones_like(w2)  # predictions scale with ω² too
    predicted = np.multiply.outer(ratio, predicted) if lead else ratio * predicted
    exact, unbalanced = at_speed(exact.T), at_speed(unbalanced.T)  # (speed, order, component)
    scale = np.where(is_force, at_speed(unit.force_scale)[..., None], at_speed(unit.moment_scale)[..., None])
    alias = np.where(is_force, at_speed(alias_force.max())[..., None], at_speed(alias_moment.max())[..., None])
    scale, alias = scale[..., None, :], alias[..., None, :]  # broadcast over order
    tolerance = request.tolerance * np.abs(unbalanced) + VERIFY_RTOL * scale + alias
    difference = np.abs(exact - predicted)
    passed = ~targeted | (difference <= tolerance)

    def removed(was, now, scale):
        """Share removed [%]; 0 where there was nothing to remove."""
        share = 100 * (1 - now / np.where(was > 0, was, 1))
        return np.where(was > BALANCED_RTOL * scale, share, 0.0)

    ocx = lead + ("order", "component")
    described = ("w = z + i t = P_co exp(i k theta) + P_counter exp(-i k theta); t points 90 deg ahead of +z in the "
                 "direction of rotation; roll: the order phasor of the moment about x")
    data = {
        "before": (ocx, np.where(np.abs(unbalanced) <= BALANCED_RTOL * scale, 0, unbalanced),
                   {"long_name": "phasor without balancer elements", "units": "N or N m", "description": described}),
        "predicted": (ocx, predicted, {"long_name": "residual phasor the design predicted", "units": "N or N m",
                                     "description": described}),
        "exact": (ocx, exact, {"long_name": "residual phasor of the exact model", "units": "N or N m",
                                 "description": described}),
        "difference": (ocx, difference, {"long_name": "|exact - predicted|", "units": "N or N m"}),
        "tolerance": (ocx, tolerance, {"units": "N or N m", "long_name": "largest |exact - predicted| that passes"}),
        "targeted": ("component", targeted, {"long_name": "component the design cancels"}),
        "passed": (ocx, passed, {"long_name": "difference within the tolerance (always for components not targeted)"}),
    }
    for j, (name, units) in enumerate((("force", "N"), ("moment", "N m"))):
        s = at_speed(unit.force_scale if name == "force" else unit.moment_scale)
        was, now = at_speed(np.abs(before[j]).max(axis=-1)), at_speed(np.abs(after[j]).max(axis=-1))
        data[f"peak_{name}_before"] = (lead + ("axis",), was, {
            "units": units, "long_name": f"peak {name} over the revolution without balancer elements (all orders)"})
        data[f"peak_{name}_after"] = (lead + ("axis",), now, {
            "units": units, "long_name": f"peak {name} over the revolution with the balancer elements (all orders)"})
        data[f"peak_{name}_removed"] = (lead + ("axis",), removed(was, now, np.expand_dims(s, -1)), {"units": "%"})
        was, now = at_speed(np.abs(spectra[1, j]).T), at_speed(np.abs(spectra[0, j]).T)  # (speed, order, axis)
        data[f"{name}_before"] = (lead + ("order", "axis"), was, {
            "units": units, "long_name": f"{name} amplitude per order and axis without balancer elements"})
        data[f"{name}_after"] = (lead + ("order", "axis"), now, {
            "units": units, "long_name": f"{name} amplitude per order and axis with the balancer elements"})
        data[f"{name}_removed"] = (lead + ("order", "axis"), removed(was, now, np.reshape(s, np.shape(s) + (1, 1))),
                                   {"units": "%"})
        data[f"{name}_scale"] = (lead, s, {"units": units, "long_name": f"sum of single-body peak {name}s"})
    coords = speeds.coords()
    coords.update({
        "order": ("order", np.array(orders), {}),
        "component": ("component", names, {}),
        "component_units": ("component", ["N" if g == "force" else "N m" for _, g in COMPONENTS], {}),
        "axis": ("axis", ["x", "y", "z"], {"long_name": "engine axis"}),
    })
    ok = bool(passed.all())
    return dataset(data, coords, {
        "title": f"harmbal verification of balancer elements: {scene.name}",
        "engine": scene.name,
        "samples_per_rev": samples,
        "cancel": " ".join(request.cancel),
        "tolerance_rule": (f"{request.tolerance:g} x value without balancers + {VERIFY_RTOL:g} x sum of single-body "
                           "peak loads + aliasing estimate"),
        "predicted_speed": request.speed if request.speed else "none (every targeted component must vanish)",
        "passed": "yes" if ok else "no",
    })
