"""The order-domain view of a time-domain Dataset: phasors per order, co/counter split."""

from __future__ import annotations

import numpy as np

from ..orders.spectrum import BALANCED_RTOL, ROTATION, aliasing_estimate, phasors, rotating_split


def order_spectrum(ds, *, max_order: int | None = None, backend: str = "scipy", workers: int | None = None):
    """Order components of a time-domain dataset.

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`harmbal.simulate`: ``force`` and ``moment`` over one
        revolution of ``angle``.
    max_order : int, optional
        Highest order kept; default the scene's ``max_order`` (``ds.attrs``).
    backend : {"scipy", "numpy", "pyfftw"}
        FFT implementation.
    workers : int, optional
        Threads for the scipy and pyfftw backends.

    Returns
    -------
    xarray.Dataset
        Dims ``order`` (0 … max_order), ``axis`` and ``rotation`` (co,
        counter), plus ``speed`` if present. Complex ``force`` [N] and
        ``moment`` [N m]: phasors C_k with s(θ) = Σ Re(C_k e^{ikθ}).
        Complex ``force_rotating`` and ``moment_rotating``: co- and
        counter-rotating phasors of the transverse vector. Real
        ``aliasing_error_force``/``aliasing_error_moment`` per axis: an
        estimate of the aliasing error of the orders kept (``ds``'s own,
        body by body, from :func:`harmbal.simulate`, or else
        :func:`aliasing_estimate` of the totals). Attribute ``accuracy_reached``: the
        largest of those estimates relative to the single-body load scale
        (``force_scale``, ``moment_scale``).

    Warns
    -----
    AccuracyWarning
        If ``accuracy_reached`` exceeds ten times the scene's
        ``sampling.accuracy`` (attribute ``accuracy_target`` of ``ds``), or, for a fixed
        ``samples_per_rev``, exceeds 1e-6 (the orders asked for are not
        resolved).
    """
    import xarray as xr

    attrs = dict(ds.attrs)
    samples = ds.sizes["angle"]
    kmax = int(max_order if max_order is not None else attrs.get("max_order", 12))
    if kmax > samples // 2 - 1:
        raise ValueError(f"max_order {kmax} needs more than {samples} samples per revolution")
    sense = 1 if attrs.get("rotation") == "counterclockwise" else -1
    lead = tuple(d for d in ds["force"].dims if d not in ("axis", "angle"))
    orders = np.arange(kmax + 1)

    data = {}
    for name, units in (("force", "N"), ("moment", "N m")):
        values = ds[name].transpose(*lead, "axis", "angle").values
        spectrum = phasors(values, backend, workers)
        kept = spectrum[..., : kmax + 1]
        z, t = kept[..., 2, :], -sense * kept[..., 1, :]
        co, counter = rotating_split(z, t)
        if f"aliasing_error_{name}" in ds:
            # From simulate, body by body: the total's tail misleads when the cylinders cancel orders
            # in the sampled tail band but not beyond it (or the other way round).
            tail = ds[f"aliasing_error_{name}"].transpose(*lead, "axis").values
        else:
            tail = aliasing_estimate(np.abs(spectrum), samples, kmax)
        data[name] = (lead + ("order", "axis"), np.swapaxes(kept, -1, -2), {
            "units": units,
            "long_name": f"order phasor of the shaking {name}",
            "description": "C_k with signal(theta) = sum_k Re(C_k exp(i k theta)); |C_k| peak amplitude",
        })
        data[f"{name}_rotating"] = (lead + ("order", "rotation"), np.stack([co, counter], axis=-1), {
            "units": units,
            "long_name": f"co- and counter-rotating phasors of the transverse {name}",
            "description": "w = z + i t = P_co exp(i k theta) + P_counter exp(-i k theta); "
                           "t points 90 deg ahead of +z in the direction of rotation",
        })
        data[f"aliasing_error_{name}"] = (lead + ("axis",), tail, {
            "units": units,
            "long_name": f"estimated aliasing error of the {name} phasors (extrapolated spectral tail)",
        })
        data[f"{name}_scale"] = ds[f"{name}_scale"]

    coords = {
        "order": ("order", orders, {"long_name": "order of crank speed", "units": "1"}),
        "axis": ds["axis"],
        "rotation": ("rotation", list(ROTATION), {"long_name": "sense of rotation relative to the crank"}),
    }
    for name in ("speed", "rpm"):
        if name in ds.coords:
            coords[name] = ds[name]
    reached = 0.0
    for name in ("force", "moment"):
        tail, scale = data[f"aliasing_error_{name}"][1], np.expand_dims(ds[f"{name}_scale"].values, -1)
        relative = np.divide(tail, scale, out=np.zeros_like(tail), where=scale > 0)
        reached = max(reached, float(relative.max(initial=0.0)))
    _check_resolved(reached, float(attrs.get("accuracy_target", 0.0)), samples, kmax, attrs.get("engine", ""))
    attrs.update({
        "accuracy_reached": reached,
        "title": f"harmbal order spectrum: {attrs.get('engine', '')}",
        "amplitude": "peak (one-sided)",
        "phase": "arg C_k, relative to theta = 0 (throw 1 along +z)",
        "transverse_frame": f"w = z + i t, t = {'+' if sense < 0 else '-'}y",
        "fft_backend": backend,
        "balanced_rtol": BALANCED_RTOL,
    })
    return xr.Dataset(data, coords, attrs)


#: A fixed sampling whose estimated relative error exceeds this does not resolve the orders asked for.
UNRESOLVED = 1e-6


def _check_resolved(reached: float, target: float, samples: int, max_order: int, engine: str) -> None:
    """Warn when the estimated error misses the accuracy asked for, or, for a
    fixed sampling, when it is too large for orders ≤ max_order to mean much."""
    import warnings

    from ..model.sampling import AccuracyWarning

    # The sampling is chosen from the decay rate of the harmonics, the estimate from the spectrum's
    # tail; the two can differ by a small factor, which is no reason to warn.
    limit = 10 * target if target > 0 else UNRESOLVED
    if reached > limit:
        asked = (f"10 × the accuracy asked for ({target:g})" if target > 0 else
                 f"{UNRESOLVED:g}: orders up to {max_order} are not resolved")
        warnings.warn(f"{engine}: with {samples} samples per revolution the estimated relative error of the order "
                      f"phasors is {reached:.2g}, above {asked}; use more samples per revolution (or "
                      "sampling.accuracy)", AccuracyWarning, stacklevel=3)
