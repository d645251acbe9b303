"""Order phasors of a scene as a linear function of its masses and unbalances.

For a fixed geometry, every inertial load is linear in the cylinders' piston
mass, rod mass and rod inertia (:mod:`harmbal.model.linear`) and in the size
(mass × radius) of each static unbalance. :func:`linear_phasors` computes,
once per geometry, the free force and moment phasors per unit of each such
*slot* and the part that depends on none of them (balance shafts); the
phasors of any variant of the masses are then one matrix product,
:func:`combine`, vectorised over a leading ``variant`` axis (and chunkable:
it only needs the slot values of the variants it is given).

The per-cylinder phasors follow from one exact single-cylinder spectrum by
the shift theorem, as in :func:`harmbal.orders.phasors.order_phasors`, so
they agree with the single-scene analysis to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..model.balancers import shaft_amplitudes, shaft_phasors
from ..model.evaluate import moment_about
from ..model.linear import PROPERTIES, planar_basis
from ..model.sampling import body_decay_rates, choose_samples
from ..scene import Scene
from ..scene.elements import Shaft, ShaftUnbalance
from .spectrum import phasors

#: Cylinder fields that fix a cylinder's loads per unit mass (its geometry); the masses are slots.
_GEOMETRY = ("crank_radius", "rod_length", "pin_offset", "cylinder_offset")


@dataclass(frozen=True)
class LinearPhasors:
    """Unit-speed (ω = 1 rad/s) order phasors of one geometry, per slot.

    ``slots`` names the linear quantities (``cylinder[i].piston_mass`` [kg],
    ``cylinder[i].rod_mass`` [kg], ``cylinder[i].rod_inertia`` [kg m²],
    ``cylinder[i].throw_unbalance[j]`` and ``crankshaft_unbalance[j]`` [kg m]);
    ``values`` their values in the scene the basis was made from.
    ``force``/``moment`` (slot, axis, order) are the phasors per unit of each
    slot [N per unit, N m per unit], moment about the reference point;
    ``constant_force``/``constant_moment`` (axis, order) the rest (balance
    shafts). The phasors of the scene are ``values @ force + constant_force``.
    """

    slots: tuple[str, ...]
    values: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    constant_force: np.ndarray
    constant_moment: np.ndarray
    samples_per_rev: int


def slot_values(scene: Scene) -> tuple[tuple[str, ...], np.ndarray]:
    """Names and values of a scene's linear slots (see :class:`LinearPhasors`)."""
    names, values = [], []
    for i, c in enumerate(scene.cylinders, start=1):
        for prop, value in zip(PROPERTIES, (c.piston.mass, c.rod.mass, c.rod.inertia or 0.0)):
            names.append(f"cylinder[{i}].{prop}")
            values.append(value)
        for j, u in enumerate(c.throw_unbalances, start=1):
            names.append(f"cylinder[{i}].throw_unbalance[{j}]")
            values.append(u.unbalance)
    for j, u in enumerate(scene.crankshaft_unbalances, start=1):
        names.append(f"crankshaft_unbalance[{j}]")
        values.append(u.unbalance)
    return tuple(names), np.array(values, dtype=float)


def geometry_key(scene: Scene) -> Scene:
    """The scene with every slot set to zero and no source text: two scenes
    with equal keys differ only in their slot values (and so share one
    :class:`LinearPhasors`)."""
    cylinders = tuple(replace(
        c, piston=replace(c.piston, mass=0.0),
        rod=replace(c.rod, mass=0.0, inertia=None if c.rod.inertia is None else 0.0),
        throw_unbalances=tuple(replace(u, unbalance=0.0) for u in c.throw_unbalances)) for c in scene.cylinders)
    return replace(scene, cylinders=cylinders, source_text="", source="",
                   crankshaft_unbalances=tuple(replace(u, unbalance=0.0) for u in scene.crankshaft_unbalances))


def linear_phasors(scene: Scene, samples_per_rev: int | None = None, backend: str = "scipy") -> LinearPhasors:
    """The order phasors of ``scene``'s geometry per unit of each slot.

    Parameters
    ----------
    scene : Scene
        Without gas, lever balancers or speed fluctuation (their loads are not
        linear in the masses).
    samples_per_rev : int, optional
        Samples of each single-cylinder spectrum; default the scene's sampling
        (:func:`harmbal.model.sampling.choose_samples`), as
        :func:`harmbal.analyse` chooses it.
    backend : {"scipy", "numpy", "pyfftw"}
        FFT implementation.

    Returns
    -------
    LinearPhasors
    """
    n = samples_per_rev or choose_samples(scene, body_decay_rates(scene))
    kmax, sense, cyls = scene.sampling.max_order, scene.sense, scene.cylinders
    order = np.arange(kmax + 1)
    names, values = slot_values(scene)
    force = np.zeros((len(names), 3, kmax + 1), dtype=complex)
    moment = np.zeros_like(force)
    slot = {name: s for s, name in enumerate(names)}

    # One spectrum per distinct geometry, every cylinder's by the shift theorem.
    groups: dict[tuple, int] = {}
    group = np.array([groups.setdefault(tuple(getattr(c, f) for f in _GEOMETRY)
                                        + (c.piston.cg_lateral, c.rod.cg_from_big_end, c.rod.cg_lateral), len(groups))
                      for c in cyls])
    representatives = [cyls[int(np.flatnonzero(group == g)[0])] for g in range(len(groups))]
    theta = 2 * np.pi * np.arange(n) / n
    basis = planar_basis(scene.model, representatives, np.broadcast_to(theta, (len(representatives), n)))
    if basis is not None:
        spectrum = phasors(basis, backend)[..., : kmax + 1]  # (property, c/n/roll, group, order)
        for i, c in enumerate(cyls):
            a, b, roll = spectrum[:, 0, group[i]], spectrum[:, 1, group[i]], spectrum[:, 2, group[i]]
            shift = np.exp(1j * order * (c.throw - c.bank))
            fz = (a * np.cos(c.bank) - b * np.sin(c.bank)) * shift
            ft = (a * np.sin(c.bank) + b * np.cos(c.bank)) * shift
            rows = [slot[f"cylinder[{i + 1}].{prop}"] for prop in PROPERTIES]
            force[rows, 1] = -sense * ft
            force[rows, 2] = fz
            moment[rows, 0] = sense * roll * shift
            moment[rows, 1] = -c.x * fz
            moment[rows, 2] = c.x * force[rows, 1]

    if "rotating" in scene.model.effects:
        def unit(angle, x):  # first-order phasors of 1 kg m turning with the crank
            return shaft_amplitudes(Shaft("", 1, 0.0, 0.0, (ShaftUnbalance(1.0, angle, x),)), sense)

        for i, c in enumerate(cyls, start=1):
            for j, u in enumerate(c.throw_unbalances, start=1):
                s = slot[f"cylinder[{i}].throw_unbalance[{j}]"]
                force[s, :, 1], moment[s, :, 1] = unit(c.throw + u.angle, u.x)
        for j, u in enumerate(scene.crankshaft_unbalances, start=1):
            s = slot[f"crankshaft_unbalance[{j}]"]
            force[s, :, 1], moment[s, :, 1] = unit(u.angle, u.x)

    constant_force = np.zeros((3, kmax + 1), dtype=complex)
    constant_moment = np.zeros_like(constant_force)
    if "balancers" in scene.model.effects and scene.shafts:
        constant_force, constant_moment = shaft_phasors(scene.shafts, kmax, sense)
    ref = np.asarray(scene.reference_point, dtype=float)
    return LinearPhasors(slots=names, values=values, force=force, moment=moment_about(ref, force, moment),
                         constant_force=constant_force,
                         constant_moment=moment_about(ref, constant_force, constant_moment), samples_per_rev=n)


def real_matmul(weights: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """weights (variant, slot) @ complex basis (slot, ...) in real arithmetic
    (a complex product would promote the real weights and cost four times)."""
    flat = np.ascontiguousarray(basis.reshape(basis.shape[0], -1)).view(float)
    return (weights @ flat).view(complex).reshape((weights.shape[0],) + basis.shape[1:])


def combine(basis: LinearPhasors, values: np.ndarray, orders=None) -> tuple[np.ndarray, np.ndarray]:
    """Force and moment phasors of many variants of one geometry.

    Parameters
    ----------
    basis : LinearPhasors
        From :func:`linear_phasors`.
    values : ndarray
        Slot values, shape (variant, slot), in the order of ``basis.slots``.
    orders : sequence of int, optional
        Orders to compute (default 0 … max_order).

    Returns
    -------
    force, moment : ndarray
        Complex phasors at unit speed [N], [N m], shape (variant, axis, order).
    """
    force, moment = basis.force, basis.moment
    constant_force, constant_moment = basis.constant_force, basis.constant_moment
    if orders is not None:
        force, moment = force[..., orders], moment[..., orders]
        constant_force, constant_moment = constant_force[..., orders], constant_moment[..., orders]
    values = np.asarray(values, dtype=float)
    return real_matmul(values, force) + constant_force, real_matmul(values, moment) + constant_moment


def time_basis(basis: LinearPhasors, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Force and moment over ``samples`` angles of one revolution, per slot
    (slot, axis, angle) and of the constant part (axis, angle), rebuilt from
    the phasors up to max_order: s(θ) = Σ_k Re(C_k e^{ikθ})."""
    theta = 2 * np.pi * np.arange(samples) / samples
    waves = np.exp(1j * np.arange(basis.force.shape[-1])[:, None] * theta)  # (order, angle)
    return tuple((part @ waves).real for part in (basis.force, basis.moment, basis.constant_force,
                                                   basis.constant_moment))


def peaks(force_time: np.ndarray, moment_time: np.ndarray, constant_force: np.ndarray, constant_moment: np.ndarray,
          values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest magnitude over the sampled angles of the force and moment
    vectors of each variant (``values`` (variant, slot)), from
    :func:`time_basis`; shape (variant,) each."""
    values = np.asarray(values, dtype=float)
    out = []
    for part, constant in ((force_time, constant_force), (moment_time, constant_moment)):
        t = (values @ part.reshape(part.shape[0], -1)).reshape((values.shape[0],) + part.shape[1:]) + constant
        out.append(np.sqrt((t * t).sum(axis=1)).max(axis=-1))
    return out[0], out[1]
