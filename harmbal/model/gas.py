"""Gas loads: the cylinder pressure on each piston, its torque on the crankshaft
and the reaction on the block, over one working cycle.

The gas pushes the piston towards the crank with F = (p − p_crankcase)·A and
the cylinder head the other way with the same force on the same line (the
bore axis), so it exerts no force and no transverse moment on the block. It
drives the crankshaft with the torque T = −F·dc_B/dψ (virtual work: c_B is
the piston pin's travel along the cylinder axis, exact for every offset),
and the load that takes the engine's torque lies outside the block, so the
block receives −T about the crank axis: the only gas load in the shaking
moment. Unlike the inertia loads the gas loads do not scale with ω² (the
scene gives one pressure trace for every speed), and a four-stroke cycle
takes two revolutions: their period is 2π·cycle/2 and their spectrum has
half orders.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .evaluate import ON_GRID
from .kinematics import slider_crank
from .pressure import check_gas, cylinder_pressure, stroke, top_dead_centre_travel
from .sampling import interpolate
from ..scene import Scene
from ..scene.firing import cylinder_firing


@dataclass(frozen=True, eq=False)
class GasLoads:
    """Gas loads of every cylinder on ``theta`` (M angles of one cycle, starting at 0).

    * ``pressure`` (cylinder, M) [Pa]: absolute cylinder pressure;
    * ``force`` (cylinder, M) [N]: (p − p_crankcase)·A on the piston, towards the crank;
    * ``torque`` (cylinder, M) [N m]: on the crankshaft, in the direction of rotation;
    * ``firing_angle`` (cylinder,) [rad]: θ of each cylinder's firing TDC;
    * ``volume`` (cylinder, M) [m³]: displaced volume above TDC, A·(c_TDC − c_B(θ)),
      from 0 at TDC to the swept volume at BDC (the clearance volume is not
      known from a measured trace, so it is left out);
    * ``swept_volume`` (cylinder,) [m³]: piston area × stroke (0 without gas).
    """

    theta: np.ndarray
    revolutions: int
    sense: int
    pressure: np.ndarray
    force: np.ndarray
    torque: np.ndarray
    firing_angle: np.ndarray
    volume: np.ndarray
    swept_volume: np.ndarray

    @property
    def roll(self) -> np.ndarray:
        """Moment of the gas on the block about the crank axis, in the
        direction of rotation, per cylinder (cylinder, M) [N m]."""
        return -self.torque

    def moment(self, torque: np.ndarray | None = None) -> np.ndarray:
        """The gas moment on the block in engine axes (axis, M) [N m]
        (about any point: it is a pure couple); of ``torque`` (cylinder, …)
        instead of ``self.torque`` if given: the moment is linear in the
        torques, so their order phasors give its phasors."""
        torque = self.torque if torque is None else torque
        moment = np.zeros((3, torque.shape[-1]), dtype=torque.dtype)
        moment[0] = -self.sense * torque.sum(axis=0)
        return moment

    def on_cycle(self, values: np.ndarray) -> np.ndarray:
        """Samples of one revolution (last axis; as many as the cycle's grid
        has per revolution, or fewer: the inertia's own grid, see
        :func:`harmbal.model.sampling.inertia_samples`) on the cycle's grid:
        interpolated trigonometrically (:func:`harmbal.model.sampling.interpolate`)
        and repeated each revolution."""
        return np.tile(interpolate(values, self.theta.size // self.revolutions), self.revolutions)

    @property
    def moment_scale(self) -> float:
        """Sum of the cylinders' peak gas torques [N m]."""
        return float(np.abs(self.torque).max(axis=-1, initial=0.0).sum())


def grid_steps(delta: float, samples_per_rev: int) -> int | None:
    """``delta`` [rad] in whole samples of a grid of ``samples_per_rev`` per
    revolution, or None if it is not on the grid to within
    :data:`~harmbal.model.evaluate.ON_GRID` (relative)."""
    steps = delta * samples_per_rev / (2 * np.pi)
    nearest = round(steps)
    return nearest if abs(steps - nearest) <= ON_GRID * max(abs(steps), 1.0) else None


def gas_loads(scene: Scene, samples_per_rev: int) -> GasLoads:
    """Evaluate the gas loads of every cylinder over one cycle.

    Parameters
    ----------
    scene : Scene
        Cylinders (geometry and ``gas``), cycle, firing order and sense.
    samples_per_rev : int
        Samples per revolution; the cycle has ``samples_per_rev`` × cycle/2.

    Returns
    -------
    GasLoads
    """
    check_gas(scene)
    cyls = scene.cylinders
    revolutions = scene.cycle // 2
    m = samples_per_rev * revolutions
    theta = 2 * np.pi * np.arange(m) / samples_per_rev
    firing_angle = np.asarray(cylinder_firing(cyls, scene.cycle, scene.firing_order).angle, dtype=float)
    pressure, force, torque, volume = (np.zeros((len(cyls), m)) for _ in range(4))
    swept = np.zeros(len(cyls))
    series = scene.model.series_harmonics if scene.model.piston == "series" else None
    # Cylinders with the same trace and slider-crank have the same loads, shifted to their firing TDC: each
    # such group is evaluated once and the others rolled, when their firing TDCs are whole samples apart.
    evaluated: dict[tuple, int] = {}
    shifted: list[tuple[int, int, int]] = []  # (cylinder, the one evaluated, firing whole samples later)
    for i, c in enumerate(cyls):
        gas = c.gas
        if gas is None:
            continue
        key = (gas, c.crank_radius, c.rod_length, c.offset)
        first = evaluated.get(key)
        steps = None if first is None else grid_steps(firing_angle[i] - firing_angle[first], samples_per_rev)
        if steps is not None:
            shifted.append((i, first, steps))
            continue
        evaluated.setdefault(key, i)
        kin = slider_crank(theta + c.throw - c.bank, c.crank_radius, c.rod_length, c.offset, series)
        pressure[i] = cylinder_pressure(gas, c.crank_radius, c.rod_length, c.offset, scene.cycle,
                                        theta - firing_angle[i])
        force[i] = (pressure[i] - gas.crankcase_pressure) * gas.piston_area
        torque[i] = -force[i] * kin.db
        volume[i] = gas.piston_area * (top_dead_centre_travel(c.crank_radius, c.rod_length, c.offset) - kin.b)
        swept[i] = gas.piston_area * stroke(c.crank_radius, c.rod_length, c.offset)
    for i, first, steps in shifted:
        k = steps % m
        for values in (pressure, force, torque, volume):  # np.roll by k, without its copies
            values[i, k:] = values[first, : m - k]
            values[i, :k] = values[first, m - k:]
        swept[i] = swept[first]
    return GasLoads(theta=theta, revolutions=revolutions, sense=scene.sense, pressure=pressure, force=force,
                    torque=torque, firing_angle=firing_angle, volume=volume, swept_volume=swept)
