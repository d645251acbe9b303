"""The order-domain view: phasors per order, co/counter split, as a Dataset."""

from __future__ import annotations

import numpy as np

from ..labelled import SPEED_SCALING, Speeds, dataset, unit_speed_values
from ..model.sampling import AccuracyWarning
from ..model.evaluate import UnitLoads
from ..orders.spectrum import BALANCED_RTOL, ROTATION, aliasing_estimate, phasors, rotating_split
from ..scene import Scene
from .time import attributes


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
    attrs = dict(ds.attrs)
    samples = ds.sizes["angle"]
    kmax = int(max_order if max_order is not None else attrs.get("max_order", 12))
    if kmax > samples // 2 - 1:
        raise ValueError(f"max_order {kmax} needs more than {samples} samples per revolution")
    lead = tuple(d for d in ds["force"].dims if d not in ("axis", "angle"))
    # A sweep from simulate holds unit-speed arrays: transform those, scale lazily. Otherwise the values as given.
    unit = {name: unit_speed_values(ds[name].variable) for name in ("force", "moment")}
    swept = lead == ("speed",) and all(v is not None for v in unit.values())
    speeds = Speeds(ds["speed"].values if swept else 1.0)
    spectra, tails, scales = {}, {}, {}
    for name in ("force", "moment"):
        values = unit[name] if swept else ds[name].transpose(*lead, "axis", "angle").values
        spectra[name] = phasors(values, backend, workers)
        alias = ds.get(f"aliasing_error_{name}")
        if alias is None:
            tails[name] = aliasing_estimate(np.abs(spectra[name]), samples, kmax)
        else:
            # From simulate, body by body: the total's tail misleads when the cylinders cancel orders
            # in the sampled tail band but not beyond it (or the other way round).
            tails[name] = unit_speed_values(alias.variable) if swept else alias.transpose(*lead, "axis").values
        scale = ds[f"{name}_scale"]
        scales[name] = unit_speed_values(scale.variable) if swept else scale.values
    coords = {name: ds[name].variable for name in ("speed", "rpm") if name in ds.coords}
    attrs.pop(SPEED_SCALING, None)
    values, attrs = order_arrays(spectra["force"], spectra["moment"], tails, scales, attrs, max_order=kmax,
                                 backend=backend)
    return orders_dataset(values, attrs, speeds, coords, lead=() if swept else lead)


def order_arrays(force: np.ndarray, moment: np.ndarray, tails: dict, scales: dict, attrs: dict, *, max_order: int,
                 backend: str = "scipy") -> tuple[dict, dict]:
    """The order view on plain arrays, from the spectra (..., axis, order ≥
    max_order) of the total force and moment, their aliasing estimates
    (..., axis) and load scales (...): ``force``, ``moment`` (..., order,
    axis), ``force_rotating``, ``moment_rotating`` (..., order, rotation),
    ``aliasing_error_*``, ``*_scale``, and the Dataset's attributes.

    Warns
    -----
    AccuracyWarning
        See :func:`order_spectrum`.
    """
    samples = int(attrs.get("samples_per_rev", 0)) or 2 * (force.shape[-1] - 1)
    kmax = max_order
    sense = 1 if attrs.get("rotation") == "counterclockwise" else -1
    values = {}
    for name, spectrum in (("force", force), ("moment", moment)):
        kept = spectrum[..., : kmax + 1]
        co, counter = rotating_split(kept[..., 2, :], -sense * kept[..., 1, :])
        values[name] = np.swapaxes(kept, -1, -2)
        values[f"{name}_rotating"] = np.stack([co, counter], axis=-1)
        values[f"aliasing_error_{name}"] = tails[name]
        values[f"{name}_scale"] = scales[name]
    # Relative errors do not depend on the speed: the unit-speed arrays (or each speed's) judge them.
    reached = 0.0
    for name in ("force", "moment"):
        tail, scale = np.asarray(tails[name]), np.expand_dims(np.asarray(scales[name], dtype=float), -1)
        relative = np.divide(tail, scale, out=np.zeros(np.broadcast_shapes(tail.shape, scale.shape)), where=scale > 0)
        reached = max(reached, float(relative.max(initial=0.0)))
    _check_resolved(reached, float(attrs.get("accuracy_target", 0.0)), samples, kmax, attrs.get("engine", ""))
    attrs = dict(attrs)
    attrs.update({
        "accuracy_reached": reached,
        "title": f"harmbal order spectrum: {attrs.get('engine', '')}",
        "amplitude": "peak (one-sided)",
        "phase": "arg C_k, relative to theta = 0 (throw 1 along +z)",
        "transverse_frame": f"w = z + i t, t = {'+' if sense < 0 else '-'}y",
        "fft_backend": backend,
        "balanced_rtol": BALANCED_RTOL,
    })
    return values, attrs


def unit_orders(scene: Scene, unit: UnitLoads, aliasing: tuple, backend: str = "scipy") -> tuple[dict, dict]:
    """:func:`order_arrays` of one evaluation at unit speed (``aliasing`` from
    :func:`harmbal.views.time.body_aliasing`)."""
    force, moment = unit.total()
    spectrum = phasors(np.stack([force, moment]), backend)  # (force/moment, axis, order)
    return order_arrays(spectrum[0], spectrum[1], {"force": aliasing[0], "moment": aliasing[1]},
                        {"force": unit.force_scale, "moment": unit.moment_scale},
                        attributes(scene, unit.samples_per_rev), max_order=scene.sampling.max_order, backend=backend)


def orders_dataset(values: dict, attrs: dict, speeds: Speeds, coords: dict, *, lead: tuple = ()):
    """The order Dataset of :func:`order_arrays`' values over ``lead`` dims as
    given, times ``speeds``' ω²."""
    var = speeds.variable
    data = {}
    for name, units in (("force", "N"), ("moment", "N m")):
        data[name] = var(lead + ("order", "axis"), values[name], {
            "units": units,
            "long_name": f"order phasor of the shaking {name}",
            "description": "C_k with signal(theta) = sum_k Re(C_k exp(i k theta)); |C_k| peak amplitude",
        })
        data[f"{name}_rotating"] = var(lead + ("order", "rotation"), values[f"{name}_rotating"], {
            "units": units,
            "long_name": f"co- and counter-rotating phasors of the transverse {name}",
            "description": "w = z + i t = P_co exp(i k theta) + P_counter exp(-i k theta); "
                           "t points 90 deg ahead of +z in the direction of rotation",
        })
        data[f"aliasing_error_{name}"] = var(lead + ("axis",), values[f"aliasing_error_{name}"], {
            "units": units,
            "long_name": f"estimated aliasing error of the {name} phasors (extrapolated spectral tail)",
        })
        data[f"{name}_scale"] = var(lead, values[f"{name}_scale"], {
            "units": units, "long_name": f"sum of single-body peak {name}s"})
    coords = dict(coords)
    coords.update({
        "order": ("order", np.arange(values["force"].shape[-2]), {"long_name": "order of crank speed", "units": "1"}),
        "axis": ("axis", ["x", "y", "z"], {"long_name": "engine axis"}),
        "rotation": ("rotation", list(ROTATION), {"long_name": "sense of rotation relative to the crank"}),
    })
    return dataset(data, coords, attrs)


#: A fixed sampling whose estimated relative error exceeds this does not resolve the orders asked for.
UNRESOLVED = 1e-6


def _check_resolved(reached: float, target: float, samples: int, max_order: int, engine: str) -> None:
    """Warn when the estimated error misses the accuracy asked for, or, for a
    fixed sampling, when it is too large for orders ≤ max_order to mean much."""
    import warnings

    # The sampling is chosen from the decay rate of the harmonics, the estimate from the spectrum's
    # tail; the two can differ by a small factor, which is no reason to warn.
    limit = 10 * target if target > 0 else UNRESOLVED
    if reached > limit:
        asked = (f"10 × the accuracy asked for ({target:g})" if target > 0 else
                 f"{UNRESOLVED:g}: orders up to {max_order} are not resolved")
        warnings.warn(f"{engine}: with {samples} samples per revolution the estimated relative error of the order "
                      f"phasors is {reached:.2g}, above {asked}; use more samples per revolution (or "
                      "sampling.accuracy)", AccuracyWarning, stacklevel=4)
