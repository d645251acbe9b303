"""How finely to sample a revolution: the decay rate of each body's harmonics and the
samples per revolution that meet the scene's accuracy target."""

from __future__ import annotations

import functools
import math

import numpy as np

from ..scene import Scene
from ..scene.schema import MAX_SAMPLES
from .kinematics import decay_rate
from .linkage import decay_rate as linkage_decay_rate

#: Factor on the extrapolated tail: the further aliases and the fit's error (see aliasing_estimate).
ALIAS_SAFETY = 4


#: Fewest samples per revolution when gas is simulated (0.5°): pressure traces are smooth only to
#: their interpolation's order, so their harmonics decay algebraically, not geometrically.
GAS_SAMPLES_PER_REV = 720


def simulates_gas(scene: Scene) -> bool:
    """Whether the scene's effects include gas and a cylinder has a pressure."""
    return "gas" in scene.model.effects and any(c.gas is not None for c in scene.cylinders)


class AccuracyWarning(UserWarning):
    """The requested accuracy needs more samples than harmbal will choose."""


def choose_samples(scene: Scene, decay_rates: np.ndarray | None = None, *, gas: bool | None = None) -> int:
    """Samples per revolution: the scene's fixed count, or the smallest count
    whose aliasing error meets the scene's target accuracy.

    The slider-crank harmonics decay geometrically, |C_n| ≲ n²ρⁿ relative to
    the first order for accelerations (ρ from
    :func:`harmbal.model.kinematics.decay_rate`); order k ≤ K is contaminated by
    orders ≥ N − K. The count is also at least 4K so that the spectral-tail
    estimate in :func:`harmbal.order_spectrum` covers the orders of interest,
    and above |n| + K for a balancer element turning at n× (a single harmonic
    that would otherwise alias onto an order kept). With gas, at least
    :data:`GAS_SAMPLES_PER_REV` (``gas``: whether that minimum applies,
    default whether the scene simulates gas). ``decay_rates``:
    :func:`body_decay_rates` if already computed.
    """
    sampling = scene.sampling
    if sampling.samples_per_rev is not None:
        return sampling.samples_per_rev
    assert sampling.accuracy is not None  # a scene gives samples_per_rev or an accuracy
    k = sampling.max_order
    rho = float((body_decay_rates(scene) if decay_rates is None else decay_rates).max())
    n = 4 * k
    if "balancers" in scene.model.effects:
        # A shaft at n× is one harmonic: it must not alias onto the orders kept (N − |n| > K).
        n = max([n] + [abs(shaft.ratio) + k + 1 for shaft in scene.shafts])
    if rho > 0:
        m = _tail_order(rho, sampling.accuracy, k)
        n = max(n, m + k)
        if m * m * rho**m > sampling.accuracy / ALIAS_SAFETY:
            import warnings

            warnings.warn(f"{scene.source}: sampling.accuracy = {sampling.accuracy:g} needs more than {MAX_SAMPLES} "
                          f"samples per revolution (harmonics decay only like {rho:.6g}^k: a slider-crank with "
                          f"λ close to 1 or a linkage close to its toggle position); using {8 * math.ceil(n / 8)}, the "
                          "results may be less accurate than asked: compare with a larger sampling.samples_per_rev",
                          AccuracyWarning, stacklevel=2)
    if gas is None:
        gas = simulates_gas(scene)
    if gas:
        n = max(n, GAS_SAMPLES_PER_REV)
    return 8 * math.ceil(n / 8)


def inertia_samples(scene: Scene, decay_rates: np.ndarray | None = None, samples: int | None = None) -> int:
    """Samples per revolution of the inertia loads, which with gas are
    evaluated on a grid of their own and brought to the gas grid by
    trigonometric interpolation (:func:`interpolate`).

    The interpolant of N samples holds the orders below N/2 (and the cosine
    of order N/2): between the samples it misses the orders ≥ N/2 and their
    aliases, so the bound |C_n| ≲ n²ρⁿ of :func:`choose_samples` must meet the
    accuracy target at n = N/2 rather than at N − K, and a shaft's single
    harmonic must lie below N/4 (below N/2 for the interpolant, and out of
    the tail that :func:`harmbal.orders.spectrum.aliasing_estimate` fits).
    The count is also what the inertia needs without gas, and never more
    than the gas grid's (:func:`choose_samples`), on which the inertia is
    then evaluated directly. Without gas, or with a fixed
    ``samples_per_rev``, it is :func:`choose_samples`' count. ``decay_rates``
    and ``samples``: :func:`body_decay_rates` and :func:`choose_samples`' count
    if already computed.
    """
    rates = body_decay_rates(scene) if decay_rates is None else decay_rates
    n = choose_samples(scene, rates) if samples is None else samples
    if not simulates_gas(scene) or scene.sampling.samples_per_rev is not None:
        return n
    own = choose_samples(scene, rates, gas=False)
    assert scene.sampling.accuracy is not None  # a scene gives samples_per_rev or an accuracy
    rho = float(rates.max())
    needed = [2 * _tail_order(rho, scene.sampling.accuracy, scene.sampling.max_order)] if rho > 0 else []
    if "balancers" in scene.model.effects:
        # Not only below N/2: in the tail band (N/4, N/2] the aliasing estimate would take a shaft's single
        # harmonic for a tail that does not decay.
        needed += [4 * abs(shaft.ratio) for shaft in scene.shafts]
    return min(n, max(own, 8 * math.ceil(max(needed, default=0) / 8)))


def interpolate(values: np.ndarray, samples: int) -> np.ndarray:
    """Trigonometric interpolation of N samples over one period (last axis)
    onto ``samples`` ≥ N equally spaced points of the same period, from the
    same first angle (the samples themselves if ``samples`` = N).

    The interpolant is the band-limited signal through the samples: their
    orders below N/2 and, for an even N, the order N/2 as the cosine the
    samples show. It is exact (to round-off) for a signal without orders
    ≥ N/2; otherwise it misses, between the samples, those orders and their
    aliases on the orders below N/2 (:func:`inertia_samples` chooses N so
    that they are below the accuracy target). numpy's FFT: a change of grid
    within the model, not an order analysis, whose FFT backend the caller
    chooses. The interpolant is linear in the samples: onto a small grid
    (N × ``samples`` ≤ :data:`BASIS_LIMIT`, the inertia's 48 samples onto the
    gas grid's 720) it is one product with the interpolants of the unit
    samples, a third of the cost of the two FFTs for the few rows interpolated.
    """
    n = values.shape[-1]
    if samples < n:
        raise ValueError(f"interpolate onto {samples} points from {n} samples: not a finer grid")
    if samples == n:
        return values
    if n * samples <= BASIS_LIMIT:
        return values @ _interpolation_basis(n, samples)
    return _interpolate_fft(values, samples)


#: Largest N × samples for which :func:`interpolate` keeps its basis (1 MB; four are cached).
BASIS_LIMIT = 1 << 17


@functools.lru_cache(maxsize=4)
def _interpolation_basis(n: int, samples: int) -> np.ndarray:
    """Row j: the interpolant of the j-th unit sample of N on ``samples`` points (read-only)."""
    basis = _interpolate_fft(np.eye(n), samples)
    basis.flags.writeable = False
    return basis


def _interpolate_fft(values: np.ndarray, samples: int) -> np.ndarray:
    """:func:`interpolate` by zero-padding the spectrum of the N samples."""
    n = values.shape[-1]
    spectrum = np.fft.rfft(values, axis=-1) * (samples / n)
    if n % 2 == 0:
        spectrum[..., -1] /= 2  # the order N/2 is one cosine on N samples, two mirror images on the finer grid
    padded = np.zeros(values.shape[:-1] + (samples // 2 + 1,), dtype=complex)
    padded[..., : n // 2 + 1] = spectrum
    return np.fft.irfft(padded, samples, axis=-1)


def _tail_order(rho: float, accuracy: float, max_order: int) -> int:
    """The lowest order m > ``max_order`` from which the harmonics' bound
    m²ρᵐ (relative to the first order) stays below ``accuracy`` /
    ALIAS_SAFETY, so that the estimate reported meets the target too (at
    most MAX_SAMPLES)."""
    m = max_order + 1
    while m * m * rho**m > accuracy / ALIAS_SAFETY and m < MAX_SAMPLES:
        m += 1
    return m


def body_decay_rates(scene: Scene) -> np.ndarray:
    """Decay rate ρ of the harmonics of each cylinder and of the crankshaft's
    elements (pure harmonics, or a lever balancer's linkage), in the order of
    :func:`body_aliasing`'s bodies."""
    cyls = scene.cylinders
    rho = decay_rate(np.array([c.crank_radius for c in cyls]), np.array([c.rod_length for c in cyls]),
                     np.array([c.offset for c in cyls]))
    levers = ([linkage_decay_rate(lever, scene.sense) for lever in scene.levers]
              if "balancers" in scene.model.effects else [])
    return np.append(rho, max(levers, default=0.0))
