"""How finely to sample a revolution: the decay rate of each body's harmonics and the
samples per revolution that meet the scene's accuracy target."""

from __future__ import annotations

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


def choose_samples(scene: Scene, decay_rates: np.ndarray | None = None) -> int:
    """Samples per revolution: the scene's fixed count, or the smallest count
    whose aliasing error meets the scene's target accuracy.

    The slider-crank harmonics decay geometrically, |C_n| ≲ n²ρⁿ relative to
    the first order for accelerations (ρ from
    :func:`harmbal.model.kinematics.decay_rate`); order k ≤ K is contaminated by
    orders ≥ N − K. The count is also at least 4K so that the spectral-tail
    estimate in :func:`harmbal.order_spectrum` covers the orders of interest,
    and above |n| + K for a balancer element turning at n× (a single harmonic
    that would otherwise alias onto an order kept). With gas, at least
    :data:`GAS_SAMPLES_PER_REV`. ``decay_rates``: :func:`body_decay_rates`
    if already computed.
    """
    sampling = scene.sampling
    if sampling.samples_per_rev is not None:
        return sampling.samples_per_rev
    k = sampling.max_order
    rho = float((body_decay_rates(scene) if decay_rates is None else decay_rates).max())
    n = 4 * k
    if "balancers" in scene.model.effects:
        # A shaft at n× is one harmonic: it must not alias onto the orders kept (N − |n| > K).
        n = max([n] + [abs(shaft.ratio) + k + 1 for shaft in scene.shafts])
    if rho > 0:
        m = k + 1
        target = sampling.accuracy / ALIAS_SAFETY  # so that the estimate reported meets the target too
        while m * m * rho**m > target and m < MAX_SAMPLES:
            m += 1
        n = max(n, m + k)
        if m * m * rho**m > target:
            import warnings

            warnings.warn(f"{scene.source}: sampling.accuracy = {sampling.accuracy:g} needs more than {MAX_SAMPLES} "
                          f"samples per revolution (harmonics decay only like {rho:.6g}^k: a slider-crank with "
                          f"λ close to 1 or a linkage close to its toggle position); using {8 * math.ceil(n / 8)}, the "
                          "results may be less accurate than asked: compare with a larger sampling.samples_per_rev",
                          AccuracyWarning, stacklevel=2)
    if simulates_gas(scene):
        n = max(n, GAS_SAMPLES_PER_REV)
    return 8 * math.ceil(n / 8)


def body_decay_rates(scene: Scene) -> np.ndarray:
    """Decay rate ρ of the harmonics of each cylinder and of the crankshaft's
    elements (pure harmonics, or a lever balancer's linkage), in the order of
    :func:`body_aliasing`'s bodies."""
    cyls = scene.cylinders
    rho = decay_rate(np.array([c.crank_radius for c in cyls]), np.array([c.rod_length for c in cyls]),
                     np.array([c.offset for c in cyls]))
    levers = [linkage_decay_rate(lever, scene.sense) for lever in scene.levers] if "balancers" in scene.model.effects else []
    return np.append(rho, max(levers, default=0.0))
