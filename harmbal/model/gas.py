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
    * ``swept_volume`` (cylinder,) [m³]: piston area × stroke (0 without gas);
    * ``template``, ``shift`` (cylinder,): each cylinder's loads are those of
      cylinder ``template`` rolled by ``shift`` samples (its own index and 0
      for a cylinder evaluated, or without gas).
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
    template: np.ndarray
    shift: np.ndarray

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
    loads = np.zeros((4, len(cyls), m))  # pressure, force, torque, volume
    swept = np.zeros(len(cyls))
    template, shift = np.arange(len(cyls)), np.zeros(len(cyls), dtype=int)
    series = scene.model.series_harmonics if scene.model.piston == "series" else None
    # Cylinders with the same trace and slider-crank have the same loads, shifted to their firing TDC: each
    # such group is evaluated once and the others rolled, when their firing TDCs are whole samples apart.
    evaluated: list[int] = []
    for i, c in enumerate(cyls):
        gas = c.gas
        if gas is None:
            continue
        # Compared, not hashed: a measured trace's table hashes anew at every lookup, which costs more than the
        # comparison (none at all for the same object, the usual case).
        first = next((j for j in evaluated if _same_loads(cyls[j], c)), None)
        steps = None if first is None else grid_steps(firing_angle[i] - firing_angle[first], samples_per_rev)
        if steps is not None:
            k = steps % m
            template[i], shift[i] = first, k
            loads[:, i, k:] = loads[:, first, : m - k]  # np.roll by k, without its copies
            loads[:, i, :k] = loads[:, first, m - k:]
            swept[i] = swept[first]
            continue
        if first is None:
            evaluated.append(i)
        # The slider-crank repeats every revolution: evaluated over one.
        kin = slider_crank(theta[:samples_per_rev] + c.throw - c.bank, c.crank_radius, c.rod_length, c.offset,
                           series)
        loads[0, i] = cylinder_pressure(gas, c.crank_radius, c.rod_length, c.offset, scene.cycle, theta - firing_angle[i])
        loads[1, i] = (loads[0, i] - gas.crankcase_pressure) * gas.piston_area
        loads[2, i] = -loads[1, i] * np.tile(kin.db, revolutions)
        travel = top_dead_centre_travel(c.crank_radius, c.rod_length, c.offset) - kin.b
        loads[3, i] = gas.piston_area * np.tile(travel, revolutions)
        swept[i] = gas.piston_area * stroke(c.crank_radius, c.rod_length, c.offset)
    pressure, force, torque, volume = loads
    return GasLoads(theta=theta, revolutions=revolutions, sense=scene.sense, pressure=pressure, force=force,
                    torque=torque, firing_angle=firing_angle, volume=volume, swept_volume=swept, template=template,
                    shift=shift)


def _same_loads(a, b) -> bool:
    """Whether cylinders ``a`` and ``b`` have the same gas table and slider-crank."""
    return (a.crank_radius, a.rod_length, a.offset) == (b.crank_radius, b.rod_length, b.offset) and a.gas == b.gas
