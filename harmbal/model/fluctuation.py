"""The crank's speed over the cycle when it fluctuates: the periodic solution
of :mod:`harmbal.model.speed` for an engine's gas torque and crank train, and
the loads on the block at that fluctuating speed.

At a fluctuating speed every acceleration is a = ν·ω² + μ·α, so the loads
are L(θ) = ω(θ)²·L_ν(θ) + α(θ)·L_μ(θ): the unit-speed evaluation and the
evaluation per unit crank acceleration (:func:`harmbal.model.evaluate.evaluate`
with ``tangential``). About the crank axis the block receives −dH/dt of the
moving parts (their roll loads, without the constant-speed drive torque),
−J₀·α of the constant rotating inertia and the reaction −T_L of the load
torque, which lies outside the block; the gas forces on head and piston
cancel on it (see docs/speed.md).
"""

from __future__ import annotations

import numpy as np

from ..scene.schema import Flywheel, Problem, SceneError
from .evaluate import UnitLoads
from .gas import GasLoads
from .speed import SpeedFluctuation, flywheel_for, periodic_speed


def crank_inertia(unit: UnitLoads, gas: GasLoads) -> tuple[np.ndarray, np.ndarray]:
    """J_var(θ) = 2·KE₁(θ) of the moving parts and its derivative 2·d(KE₁)/dθ
    over the cycle, on the gas loads' grid (``unit`` at rest of its mass
    torque or not: neither depends on it)."""
    energy, torque = gas.on_cycle(np.stack([unit.kinetic_energy.sum(axis=0), unit.drive_torque.sum(axis=0)]))
    return 2 * energy, 2 * torque


def crank_speeds(flywheel: Flywheel, speeds, unit: UnitLoads, gas: GasLoads) -> list[SpeedFluctuation]:
    """The periodic speed over the cycle at each of ``speeds`` [rad/s] (each
    the mean speed, in the sense of ``flywheel.mean``)."""
    variable, derivative = crank_inertia(unit, gas)
    torque = gas.total_torque
    try:
        return [periodic_speed(gas.theta, torque, flywheel.inertia + variable, w, load_torque=flywheel.load_torque,
                               inertia_derivative=derivative, mean=flywheel.mean)
                for w in np.atleast_1d(speeds)]
    except ValueError as exc:  # no periodic state: the crank stalls, the load differs from the mean, no convergence
        key = "load_torque" if flywheel.load_torque is not None and "load torque" in str(exc) else "inertia"
        raise _refused(key, getattr(flywheel, key), exc) from None


def flywheels_needed(flywheel: Flywheel, speeds, unit: UnitLoads, gas: GasLoads) -> list[float]:
    """The constant inertia J₀ that gives ``flywheel.target_coefficient`` at each of ``speeds`` [rad/s]."""
    assert flywheel.target_coefficient is not None  # asked for only with a target
    variable, derivative = crank_inertia(unit, gas)
    torque = gas.total_torque
    try:
        return [flywheel_for(flywheel.target_coefficient, gas.theta, torque, variable, w,
                             load_torque=flywheel.load_torque, inertia_derivative=derivative, mean=flywheel.mean)
                for w in np.atleast_1d(speeds)]
    except ValueError as exc:  # unreachable (the train stalls first), or no convergence
        raise _refused("target_coefficient", flywheel.target_coefficient, exc) from None


def _refused(key: str, value, exc: ValueError) -> SceneError:
    """The [flywheel] key to change, with why the periodic speed has no solution."""
    return SceneError([Problem("[flywheel]", f"flywheel.{key}", value, str(exc))])


def fluctuating_loads(unit: UnitLoads, per_alpha: UnitLoads, runs: list[SpeedFluctuation], revolutions: int,
                      inertia: float) -> tuple[np.ndarray, np.ndarray]:
    """Force and moment about the reference point on the block at each run's
    fluctuating speed, shape (speed, axis, angle) over the cycle.

    ``unit`` and ``per_alpha`` are the evaluations per ω² and per α of the
    scene without its constant-speed drive torque (``mass_torque``);
    ``inertia`` the constant rotating inertia J₀ [kg m²], whose −J₀·α the
    block receives."""
    f_nu, m_nu = (np.tile(a, revolutions) for a in unit.total())
    f_mu, m_mu = (np.tile(a, revolutions) for a in per_alpha.total())
    omega2 = np.array([r.omega**2 for r in runs])[:, None, :]
    alpha = np.array([r.alpha for r in runs])[:, None, :]
    force = omega2 * f_nu + alpha * f_mu
    moment = omega2 * m_nu + alpha * m_mu
    reaction = np.array([-inertia * r.alpha - r.load_torque for r in runs])
    moment[:, 0] += unit.sense * reaction
    return force, moment
