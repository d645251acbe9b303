"""Verification of a balancer design by the exact model.

The judge is the exact time-domain model with the balancer elements
(:func:`harmbal.simulate`, then :func:`harmbal.order_spectrum`), not the
order-domain phasors the design was computed from. For every targeted order
and component the exact residual is set next to the residual the design
predicted (the scene's ``[verify]`` table, written by ``harmbal design``) and
passes if they agree within the tolerance; the loads without any balancer
elements give the "before" values, the peaks over the revolution per axis and
the percentage removed.
"""

from __future__ import annotations


import numpy as np

from ..views.stars import VERIFY_RTOL
from ..scene.requests import COMPONENTS, PEAK_SAMPLES, VerifyRequest
from ..orders.spectrum import BALANCED_RTOL
from ..views.orders import order_spectrum
from ..scene import Scene
from ..model.sampling import choose_samples
from ..views.time import simulate


class VerifyError(ValueError):
    """Nothing to verify: no ``[verify]`` table and no orders given."""


def _components(orders) -> dict:
    """Per component, the phasors (..., order) of an order spectrum."""
    f = orders["force_rotating"]
    m = orders["moment_rotating"]
    parts = {"force_co": f.sel(rotation="co"), "force_counter": f.sel(rotation="counter"),
             "moment_co": m.sel(rotation="co"), "moment_counter": m.sel(rotation="counter"),
             "roll": orders["moment"].sel(axis="x")}
    return {name: part.drop_vars(["rotation", "axis"], errors="ignore") for name, part in parts.items()}


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
    import xarray as xr

    request = request or scene.verify
    if request is None:
        raise VerifyError(f"{scene.source}: nothing to verify: the scene has no [verify] table (harmbal design "
                          "writes one); give the orders to check")
    if max(request.orders) > scene.sampling.max_order:
        raise VerifyError(f"{scene.source}: order {max(request.orders)} is above sampling.max_order = "
                          f"{scene.sampling.max_order}")
    samples = max(choose_samples(scene), PEAK_SAMPLES)  # peaks over the revolution need fine sampling
    bare = scene.with_effects(scene.model.effects - {"balancers"})
    time_after = simulate(scene, samples_per_rev=samples)
    time_before = simulate(bare, samples_per_rev=samples)
    after = order_spectrum(time_after, backend=backend).sel(order=list(request.orders))
    before = order_spectrum(time_before, backend=backend).sel(order=list(request.orders))
    names = [n for n, _ in COMPONENTS]
    exact = xr.concat([_components(after)[n] for n in names], dim="component")
    unbalanced = xr.concat([_components(before)[n] for n in names], dim="component")
    component = xr.DataArray(names, dims="component")
    exact = exact.assign_coords(component=component)
    unbalanced = unbalanced.assign_coords(component=component)

    omega = after["speed"]
    predicted = np.zeros((len(request.orders), len(names)), dtype=complex)
    for k, name, value in request.predicted:
        predicted[request.orders.index(k), names.index(name)] = value
    ratio = (omega / request.speed) ** 2 if request.speed else xr.ones_like(omega)
    predicted = ratio * xr.DataArray(predicted, dims=("order", "component"),
                                     coords={"order": list(request.orders), "component": names})

    is_force = xr.DataArray([g == "force" for _, g in COMPONENTS], dims="component", coords={"component": names})
    scale = xr.where(is_force, after["force_scale"], after["moment_scale"])
    alias = xr.where(is_force, after["aliasing_error_force"].max("axis"), after["aliasing_error_moment"].max("axis"))
    tolerance = request.tolerance * abs(unbalanced) + VERIFY_RTOL * scale + alias
    difference = abs(exact - predicted)
    targeted = xr.DataArray([g in request.cancel for _, g in COMPONENTS], dims="component",
                            coords={"component": names})
    passed = ~targeted | (difference <= tolerance)

    def removed(was, now, scale):
        """Share removed [%]; 0 where there was nothing to remove."""
        share = 100 * (1 - now / xr.where(was > 0, was, 1))
        return xr.where(was > BALANCED_RTOL * scale, share, 0.0)

    def peak(ds, name):
        return abs(ds[name]).max("angle")

    data = {
        "before": unbalanced.assign_attrs(long_name="phasor without balancer elements", units="N or N m"),
        "predicted": predicted.assign_attrs(long_name="residual phasor the design predicted", units="N or N m"),
        "exact": exact.assign_attrs(long_name="residual phasor of the exact model", units="N or N m"),
        "difference": difference.assign_attrs(long_name="|exact - predicted|", units="N or N m"),
        "tolerance": tolerance.assign_attrs(units="N or N m"),
        "targeted": targeted,
        "passed": passed,
    }
    for name, units in (("force", "N"), ("moment", "N m")):
        was, now = peak(time_before, name), peak(time_after, name)
        s = time_after[f"{name}_scale"]
        data[f"peak_{name}_before"] = was.assign_attrs(units=units, long_name=f"peak {name} over the revolution "
                                                       "without balancer elements (all orders)")
        data[f"peak_{name}_after"] = now.assign_attrs(units=units, long_name=f"peak {name} over the revolution "
                                                      "with the balancer elements (all orders)")
        data[f"peak_{name}_removed"] = removed(was, now, s).assign_attrs(units="%")
        was, now = abs(before[name]), abs(after[name])
        data[f"{name}_before"] = was.assign_attrs(units=units, long_name=f"{name} amplitude per order and axis "
                                                  "without balancer elements")
        data[f"{name}_after"] = now.assign_attrs(units=units, long_name=f"{name} amplitude per order and axis "
                                                 "with the balancer elements")
        data[f"{name}_removed"] = removed(was, now, s).assign_attrs(units="%")
    data["force_scale"] = time_after["force_scale"]
    data["moment_scale"] = time_after["moment_scale"]
    data["before"] = xr.where(abs(unbalanced) <= BALANCED_RTOL * scale, 0, unbalanced).assign_attrs(
        data["before"].attrs)
    ds = xr.Dataset(data).transpose("speed", "order", "component", "axis", missing_dims="ignore")
    ds = ds.assign_coords(component_units=("component", ["N" if g == "force" else "N m" for _, g in COMPONENTS]))
    ok = bool(passed.all())
    ds.attrs.update({
        "title": f"harmbal verification of balancer elements: {scene.name}",
        "engine": scene.name,
        "samples_per_rev": samples,
        "cancel": " ".join(request.cancel),
        "tolerance_rule": (f"{request.tolerance:g} x value without balancers + {VERIFY_RTOL:g} x sum of single-body "
                           "peak loads + aliasing estimate"),
        "predicted_speed": request.speed if request.speed else "none (every targeted component must vanish)",
        "passed": "yes" if ok else "no",
    })
    return ds
