"""Order spectrum: one-sided phasors per order of crank speed, the rotating
(co/counter) split of transverse vectors, and a spectral-tail error estimate.

Conventions (also in the dataset attributes and docs/conventions.md):

* A signal s(θ) sampled over one revolution is written
  s(θ) = Σ_k Re(C_k·e^{ikθ}); |C_k| is the peak amplitude of order k and
  arg C_k its phase relative to θ = 0. C_0 is the mean.
* A transverse vector (F_y, F_z) is written w = F_z + i·F_t, where t points
  90° ahead of +z in the direction of rotation (t = +y for an engine turning
  clockwise seen from the front, −y otherwise), so angles in the w-plane are
  measured like crank angles. Per order, w(θ) = P_co·e^{ikθ} + P_counter·e^{−ikθ}:
  P_co turns with the crank, P_counter against it; both are evaluated at θ = 0.
"""

from __future__ import annotations

import numpy as np

FFT_BACKENDS = ("scipy", "numpy", "pyfftw")

#: Relative tolerance (of the single-body load scale) below which an order
#: component is reported as balanced: its phase would be round-off noise.
BALANCED_RTOL = 1e-10

ROTATION = ("co", "counter")


def rfft(values: np.ndarray, backend: str = "scipy", workers: int | None = None) -> np.ndarray:
    """Real FFT along the last axis with the chosen backend.

    ``"scipy"`` (scipy.fft, default), ``"numpy"`` or ``"pyfftw"`` (optional,
    GPL: install ``harmbal[fftw]``). All give the same transform up to
    round-off.
    """
    if backend == "scipy":
        import scipy.fft

        return scipy.fft.rfft(values, axis=-1, workers=workers)
    if backend == "numpy":
        return np.fft.rfft(values, axis=-1)
    if backend == "pyfftw":
        try:
            import pyfftw.interfaces.scipy_fft as fftw
        except ImportError:
            raise ImportError("the pyfftw backend needs pyFFTW: pip install 'harmbal[fftw]'") from None
        return fftw.rfft(values, axis=-1, workers=workers or 1)
    raise ValueError(f"unknown FFT backend {backend!r}; choose one of {', '.join(FFT_BACKENDS)}")


def phasors(values: np.ndarray, backend: str = "scipy", workers: int | None = None) -> np.ndarray:
    """One-sided phasors C_0 … C_{N/2} of samples over one period (last axis)."""
    n = values.shape[-1]
    spectrum = rfft(values, backend, workers) / n
    spectrum[..., 1:] *= 2
    if n % 2 == 0:
        spectrum[..., -1] /= 2  # the Nyquist term has no mirror image
    return spectrum


def rotating_split(z: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Co- and counter-rotating phasors of w = z + i·t from the per-order
    phasors Z and T of its components (order along the last axis, starting at
    0). Order 0 is a fixed vector, reported as co-rotating."""
    co = (z + 1j * t) / 2
    counter = np.conj(z - 1j * t) / 2
    co[..., 0] = z[..., 0] + 1j * t[..., 0]
    counter[..., 0] = 0
    return co, counter


#: Round-off of the model and the FFT in units of ε·max|C| (measured against the 50-digit
#: reference: up to 1.7 on the bundled engines, tests/test_sampling.py).
ROUND_OFF = 4
#: Factor on the extrapolated tail: the further aliases and the fit's error (see aliasing_estimate).
ALIAS_SAFETY = 4


def aliasing_estimate(magnitudes: np.ndarray, samples: int, max_order: int, slowest_rate=0.0) -> np.ndarray:
    """Estimate the aliasing error of orders ≤ ``max_order`` from the tail.

    Order k of an N-sample spectrum is contaminated mostly by order N − k.
    The tail of the sampled band is fitted with a geometric decay through the
    largest magnitudes A₁ (at order i₁ in (N/4, 3N/8]) and A₂ (at i₂ in
    (3N/8, N/2]), ρ̂ = (A₂/A₁)^{1/(i₂−i₁)} ≤ 1, and extrapolated from i₂ to
    order N − max_order, the rate taken no faster than ``slowest_rate`` (the
    decay rate the geometry gives, when known: a coarse tail band can itself
    be aliased and fit too fast a decay); a factor ALIAS_SAFETY = 4 covers the further aliases N + k, 2N − k,
    … and the fit's error (with a factor 2 the estimate fell 1.3× short of
    the true error of a slider-crank's roll at λ = 0.7, against the 50-digit
    reference). The estimate never falls below the round-off floor,
    ROUND_OFF·ε·max|C|.
    """
    p1, p2 = samples // 4 + 1, (3 * samples) // 8 + 1
    band1, band2 = magnitudes[..., p1:p2], magnitudes[..., p2:]
    a1, a2 = band1.max(axis=-1), band2.max(axis=-1)
    i1, i2 = p1 + band1.argmax(axis=-1), p2 + band2.argmax(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        fitted = np.where(a1 > 0, np.minimum(a2 / a1, 1.0), 0.0) ** (1.0 / np.maximum(i2 - i1, 1))
    rate = np.maximum(fitted, slowest_rate)
    # Where the geometry's slow decay overrides the fit, the harmonics' polynomial growth (n² for
    # accelerations, one more power for the roll's products) is not in the fit either.
    growth = np.where(slowest_rate > fitted, (np.maximum(samples - max_order, i2) / i2) ** 3, 1.0)
    extrapolated = ALIAS_SAFETY * a2 * growth * rate ** np.maximum(samples - max_order - i2, 0)
    floor = ROUND_OFF * np.finfo(float).eps * magnitudes.max(axis=-1)
    return np.maximum(extrapolated, floor)


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

    from .timedomain import AccuracyWarning

    # The sampling is chosen from the decay rate of the harmonics, the estimate from the spectrum's
    # tail; the two can differ by a small factor, which is no reason to warn.
    limit = 10 * target if target > 0 else UNRESOLVED
    if reached > limit:
        asked = (f"10 × the accuracy asked for ({target:g})" if target > 0 else
                 f"{UNRESOLVED:g}: orders up to {max_order} are not resolved")
        warnings.warn(f"{engine}: with {samples} samples per revolution the estimated relative error of the order "
                      f"phasors is {reached:.2g}, above {asked}; use more samples per revolution (or "
                      "sampling.accuracy)", AccuracyWarning, stacklevel=3)


def is_balanced(amplitude, scale, rtol: float = BALANCED_RTOL):
    """True where an order component is zero up to round-off: its amplitude is
    at most ``rtol`` times the single-body load scale."""
    return np.abs(amplitude) <= rtol * np.asarray(scale)
