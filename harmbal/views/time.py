"""The time-domain view: exact shaking force and moment over one revolution as a Dataset."""

from __future__ import annotations

import functools

import numpy as np

from .._version import __version__
from ..labelled import AXES, CONVENTIONS, Speeds, dataset
from ..model.evaluate import UnitLoads, evaluate, moment_about, time_domain_evaluation
from ..model.gas import GasLoads, gas_loads
from ..model.sampling import simulates_gas
from ..orders.spectrum import ROUND_OFF_FLOOR, aliasing_estimate, phasors
from ..scene import EFFECTS, Scene


def simulate(scene: Scene, *, per_cylinder: bool = False, samples_per_rev: int | None = None):
    """Exact shaking force and moment on the block over one crank revolution.

    Parameters
    ----------
    scene : Scene
        A scene from :func:`harmbal.load_scene`.
    per_cylinder : bool, default False
        Also return each cylinder's contribution (``force_cylinder``,
        ``moment_cylinder``, dim ``cylinder``); crankshaft unbalances belong to
        no cylinder and are in the totals only.
    samples_per_rev : int, optional
        Override the scene's sampling.

    Returns
    -------
    xarray.Dataset
        Dims ``angle`` (crank angle θ [rad]), ``axis`` (x, y, z) and, when the
        scene has several speeds, ``speed`` [rad/s] (with an ``rpm``
        coordinate; the values over ``speed`` are the unit-speed values times
        ω², multiplied out lazily where read, see :mod:`harmbal.labelled`).
        Variables ``force`` [N] and ``moment`` [N m] about the
        scene's reference point, and ``force_scale``/``moment_scale``, the sums
        of bounds on the single bodies' peak loads (the same as
        :func:`harmbal.stars`'), used to judge what is "zero", and
        ``aliasing_error_force``/``aliasing_error_moment`` (per axis), the
        aliasing estimate of the order phasors summed body by body
        (:func:`body_aliasing`).

        With gas (effect ``gas``), ``angle`` spans the working cycle: two
        revolutions for a four-stroke engine (attribute ``revolutions``), and
        ``moment`` adds the reaction of the gas torque about the crank axis,
        which does not scale with ω² (see :mod:`harmbal.model.gas`). Unless
        ``samples_per_rev`` is given, the inertia loads are evaluated on the
        grid they need (attribute ``inertia_samples_per_rev``,
        :func:`harmbal.model.sampling.inertia_samples`) and interpolated
        onto the gas grid's.
    """
    if "speed_fluctuation" in scene.model.effects:
        if per_cylinder:
            raise ValueError("per_cylinder is not available at a fluctuating speed (effect speed_fluctuation)")
        return fluctuating_time_dataset(scene, samples_per_rev=samples_per_rev)
    unit, samples = time_domain_evaluation(scene, samples_per_rev)
    gas = gas_loads(scene, samples) if simulates_gas(scene) else None
    return time_dataset(unit, Speeds(scene.speeds), attributes(scene, unit.samples_per_rev, gas),
                        labels=[c.label for c in scene.cylinders] if per_cylinder else None, gas=gas)


def body_moments(unit: UnitLoads) -> tuple[np.ndarray, np.ndarray]:
    """Moments about the reference point of each cylinder (cylinder, axis,
    angle) and of the crankshaft with its elements (axis, angle)."""
    force, moment = unit.crankshaft()
    return (moment_about(unit.reference_point, unit.force_cylinder, unit.moment_cylinder),
            moment_about(unit.reference_point, force, moment))


def cycle_loads(unit: UnitLoads, gas: GasLoads) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The inertia's total force and moment about the reference point
    (:meth:`UnitLoads.total`, (axis, M)) and the moving parts' drive torque
    (M,) on the gas cycle's grid (:meth:`GasLoads.on_cycle`), for /time and
    /torque: one interpolation for the seven rows."""
    force, moment = unit.total()
    cycle = gas.on_cycle(np.concatenate([force, moment, unit.drive_torque.sum(axis=0, keepdims=True)]))
    return cycle[:3], cycle[3:6], cycle[6]


def body_aliasing(unit: UnitLoads, backend: str = "scipy", moments: tuple | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Aliasing estimates per axis (force, moment) of the orders ≤
    ``max_order``, summed over the cylinders and the crankshaft without
    cancellation, at unit speed.

    The tail of the *total* spectrum can mislead: an engine whose cylinders
    cancel every order in the sampled tail band (a W24 keeps only multiples
    of 12 in its moment) hides the orders beyond it that fold back onto the
    orders kept. Each body's own spectrum decays smoothly, so the sum of their
    tail estimates (:func:`harmbal.orders.spectrum.aliasing_estimate`) bounds
    the total's aliasing whatever cancels; each fit decays no faster than the
    body's geometry allows (``unit.decay_rates``). ``moments``:
    :func:`body_moments` if already computed.

    The crankshaft's static unbalances and balance shafts are single
    harmonics: sampled with N > order + ``max_order`` (as the scene's sampling
    ensures) they fold onto no order kept, so their lines in the tail band (a
    20× shaft at 48 samples) are left out of the crankshaft's fit, though not
    out of its round-off floor.
    """
    moment_cylinder, moment_crankshaft = moments if moments is not None else body_moments(unit)
    n = unit.samples_per_rev
    crank_force, _ = unit.crankshaft()
    # One batched FFT of every body's force and moment: (body, force/moment × axis, angle).
    bodies = np.concatenate([np.concatenate([unit.force_cylinder, moment_cylinder], axis=1),
                             np.concatenate([crank_force, moment_crankshaft])[None]])
    magnitudes = np.abs(phasors(bodies, backend))
    slowest = unit.decay_rates[:, None]
    tails = aliasing_estimate(magnitudes, n, unit.max_order, slowest)
    lines = _exact_lines(unit.harmonic_orders, n, unit.max_order)
    if lines:
        crank = magnitudes[-1].copy()
        crank[:, lines] = 0.0
        floor = ROUND_OFF_FLOOR * magnitudes[-1].max(axis=-1)
        tails[-1] = np.maximum(aliasing_estimate(crank, n, unit.max_order, slowest[-1]), floor)
    tail = tails.sum(axis=0)
    return tail[:3], tail[3:]


def _exact_lines(orders: tuple, samples: int, max_order: int) -> list[int]:
    """The bins above ``max_order`` of an N-sample spectrum where the single
    harmonics of ``orders`` stand (none if one of them folds onto an order
    kept, N ≤ order + max_order: then the fit must see it)."""
    if any(k + max_order >= samples for k in orders):
        return []
    return sorted({k if 2 * k <= samples else samples - k for k in orders if k > max_order})


def gas_aliasing(gas: GasLoads, max_order: int, backend: str = "scipy") -> np.ndarray:
    """Aliasing estimate of the gas moment's phasors per axis (only x is
    nonzero), summed over the cylinders without cancellation."""
    return gas_phasors(gas, max_order, backend)[1]


def gas_phasors(gas: GasLoads, max_order: int, backend: str = "scipy") -> tuple[np.ndarray, np.ndarray]:
    """Order phasors of each cylinder's gas torque, orders 0 … ``max_order``
    in steps of 1/revolutions (cylinder, order), and :func:`gas_aliasing`.

    One FFT per cylinder evaluated (``gas.template``): a cylinder whose
    torque is another's rolled by s of the M samples has that one's phasors
    times e^{−2πiks/M} (the shift theorem, exact for a roll) and the same
    magnitudes, hence the same tail estimate.
    """
    rows, position = gas.templates
    spectrum = phasors(gas.torque[rows], backend)
    m, count = gas.theta.size, gas.revolutions * max_order + 1
    orders = spectrum[position, :count] * _shift_factors(m, tuple(gas.shift.tolist()), count)
    tail = aliasing_estimate(np.abs(spectrum), m, count - 1)[position].sum()
    return orders, np.array([tail, 0.0, 0.0])


@functools.lru_cache(maxsize=16)
def _shift_factors(m: int, shift: tuple[int, ...], count: int) -> np.ndarray:
    """e^{−2πiks/M} for each shift s (cylinder) and order k < ``count``
    (read-only; cached like the firing stars: a scene's shifts do not change
    between its analyses), read from the M-th roots of unity: the same to
    round-off as the exponential, at a third of its cost."""
    roots = np.exp(-2j * np.pi * np.arange(m) / m)
    factors = roots[np.multiply.outer(np.array(shift), np.arange(count)) % m]
    factors.flags.writeable = False
    return factors


def time_dataset(unit: UnitLoads, speeds: Speeds, attrs: dict, *, labels: list[str] | None = None, moments=None,
                 aliasing=None, gas: GasLoads | None = None, gas_tail=None, cycle=None, backend: str = "scipy"):
    """The time-domain Dataset of one evaluation (see :func:`simulate`) at
    ``speeds``, with the Dataset's ``attrs`` (:func:`attributes`); each
    cylinder's loads too, under the cylinder ``labels``, if given.
    ``moments`` = :func:`body_moments`, ``aliasing`` = :func:`body_aliasing`,
    ``gas_tail`` = :func:`gas_aliasing` and ``cycle`` = :func:`cycle_loads`
    if already computed; ``gas`` the gas loads if simulated (on the cycle's
    grid, onto which ``unit``'s revolution is interpolated and repeated:
    :meth:`GasLoads.on_cycle`)."""
    per_cylinder = labels is not None
    moments = moments if moments is not None else body_moments(unit)
    moment_cyl = moments[0]
    alias_force, alias_moment = aliasing if aliasing is not None else body_aliasing(unit, moments=moments)
    # Speed-independent parts (gas) of the moment, its scale and aliasing estimate; the inertia repeats each turn.
    theta, force_cyl, extra = unit.theta, unit.force_cylinder, {}
    if gas is None:
        force, moment = unit.total()
    else:
        theta = gas.theta
        force, moment, _ = cycle if cycle is not None else cycle_loads(unit, gas)
        if per_cylinder:
            force_cyl, moment_cyl = gas.on_cycle(np.stack([force_cyl, moment_cyl]))
        extra = {"moment": gas.moment(), "moment_scale": gas.moment_scale,
                 "aliasing_error_moment": gas_aliasing(gas, unit.max_order, backend) if gas_tail is None else gas_tail}

    def var(dims, values, attrs, name=None):
        return speeds.variable(dims, values, attrs, constant=extra.get(name))

    coords = speeds.coords()
    coords.update({
        "angle": ("angle", theta, {"units": "rad", "long_name": "crank angle θ",
                                   "description": "angle of throw 1 from +z, in the direction of rotation"}),
        "axis": ("axis", list(AXES), {"long_name": "engine axis"}),
    })
    data = {
        "force": var(("axis", "angle"), force, {"units": "N", "long_name": "shaking force on the block"}),
        "moment": var(("axis", "angle"), moment,
                      {"units": "N m", "long_name": "shaking moment on the block about the reference point"}, "moment"),
        "force_scale": var((), unit.force_scale, {"units": "N", "long_name": "sum of single-body peak forces"}),
        "moment_scale": var((), unit.moment_scale, {"units": "N m", "long_name": "sum of single-body peak moments"},
                            "moment_scale"),
        "aliasing_error_force": var(("axis",), alias_force, {
            "units": "N", "long_name": "estimated aliasing error of the force phasors, body by body"}),
        "aliasing_error_moment": var(("axis",), alias_moment, {
            "units": "N m", "long_name": "estimated aliasing error of the moment phasors, body by body"},
            "aliasing_error_moment"),
    }
    if per_cylinder:
        coords["cylinder"] = ("cylinder", list(labels), {"long_name": "cylinder label"})
        dims = ("cylinder", "axis", "angle")
        data["force_cylinder"] = var(dims, force_cyl, {"units": "N", "long_name": "force of one cylinder"})
        if gas is not None:
            extra["moment_cylinder"] = np.zeros_like(moment_cyl)
            extra["moment_cylinder"][:, 0] = gas.sense * gas.roll
        data["moment_cylinder"] = var(dims, moment_cyl, {"units": "N m", "long_name": "moment of one cylinder"},
                                      "moment_cylinder")
    return dataset(data, coords, attrs)


def fluctuating_time_dataset(scene: Scene, *, samples_per_rev: int | None = None, backend: str = "scipy"):
    """The time-domain Dataset at a fluctuating crank speed (effect
    ``speed_fluctuation``): each speed is the mean of ω(θ) over the cycle
    (:mod:`harmbal.model.fluctuation`); the values are multiplied out per
    speed (no ω² scaling holds). The load scales and aliasing estimates
    bound those of the parts ω²·L_ν and α·L_μ at the largest ω² and |α|."""
    from ..model.fluctuation import crank_speeds, fluctuating_loads

    # No drive holds the speed: the roll carries the load torque's reaction instead of the drive's.
    base = scene.with_effects(scene.model.effects - {"mass_torque"})
    unit = evaluate(base, samples_per_rev)
    per_alpha = evaluate(base, unit.samples_per_rev, tangential=True)
    gas = gas_loads(scene, unit.samples_per_rev)
    runs = crank_speeds(scene.flywheel, scene.speeds, unit, gas)
    force, moment = fluctuating_loads(unit, per_alpha, runs, gas.revolutions, scene.flywheel.inertia)
    w2 = np.array([r.omega.max() ** 2 for r in runs])
    alpha = np.array([np.abs(r.alpha).max() for r in runs])
    reaction = np.array([scene.flywheel.inertia * a + abs(r.load_torque) for r, a in zip(runs, alpha)])
    alias_nu, alias_mu = body_aliasing(unit, backend), body_aliasing(per_alpha, backend)
    gas_alias = gas_aliasing(gas, scene.sampling.max_order, backend)
    scales = {
        "force_scale": w2 * unit.force_scale + alpha * per_alpha.force_scale,
        "moment_scale": w2 * unit.moment_scale + alpha * per_alpha.moment_scale + reaction + gas.moment_scale,
        "aliasing_error_force": np.multiply.outer(w2, alias_nu[0]) + np.multiply.outer(alpha, alias_mu[0]),
        "aliasing_error_moment": (np.multiply.outer(w2, alias_nu[1]) + np.multiply.outer(alpha, alias_mu[1])
                                  + gas_alias),
    }
    speeds = Speeds(scene.speeds)

    def per_speed(values):
        return values if speeds.several else values[0]

    coords = speeds.coords()
    coords.update({
        "angle": ("angle", gas.theta, {"units": "rad", "long_name": "crank angle θ",
                                       "description": "angle of throw 1 from +z, in the direction of rotation"}),
        "axis": ("axis", list(AXES), {"long_name": "engine axis"}),
    })
    lead = speeds.lead
    data = {
        "force": (lead + ("axis", "angle"), per_speed(force),
                  {"units": "N", "long_name": "shaking force on the block at the fluctuating speed"}),
        "moment": (lead + ("axis", "angle"), per_speed(moment), {
            "units": "N m", "long_name": "shaking moment on the block about the reference point at the fluctuating speed"}),
        "force_scale": (lead, per_speed(scales["force_scale"]),
                        {"units": "N", "long_name": "bound on the sum of single-body peak forces"}),
        "moment_scale": (lead, per_speed(scales["moment_scale"]),
                         {"units": "N m", "long_name": "bound on the sum of single-body peak moments"}),
        "aliasing_error_force": (lead + ("axis",), per_speed(scales["aliasing_error_force"]), {
            "units": "N", "long_name": "estimated aliasing error of the force phasors, body by body"}),
        "aliasing_error_moment": (lead + ("axis",), per_speed(scales["aliasing_error_moment"]), {
            "units": "N m", "long_name": "estimated aliasing error of the moment phasors, body by body"}),
        "omega": (lead + ("angle",), per_speed(np.array([r.omega for r in runs])),
                  {"units": "rad/s", "long_name": "crank speed over the cycle"}),
    }
    attrs = attributes(scene, unit.samples_per_rev)
    attrs.update({"revolutions": gas.revolutions, "speed_mean": scene.flywheel.mean})
    return dataset(data, coords, attrs)


def attributes(scene: Scene, samples: int, gas: GasLoads | None = None) -> dict:
    """The attributes every view's Dataset shares, ``samples`` per revolution
    of the unit evaluation; with ``gas``, the cycle's grid and revolutions,
    the inertia's own grid as ``inertia_samples_per_rev``."""
    model = scene.model
    attrs = {
        "title": f"harmbal time-domain shaking loads: {scene.name}",
        "engine": scene.name,
        "harmbal_version": __version__,
        "harmbal_conventions": CONVENTIONS,
        "rotation": scene.rotation,
        "cycle_strokes": scene.cycle,
        "reference_point": np.asarray(scene.reference_point, dtype=float),
        "reference_point_units": "m",
        "effects": " ".join(e for e in EFFECTS if e in model.effects),
        "piston_model": model.piston if model.piston == "exact" else f"series-{model.series_harmonics}",
        "rod_model": model.rod,
        "cylinders": len(scene.cylinders),
        "negligible": float(model.negligible),
        "samples_per_rev": samples,
        "max_order": scene.sampling.max_order,
        # The relative accuracy asked for; 0 when the scene fixes samples_per_rev instead.
        "accuracy_target": float(scene.sampling.accuracy) if scene.sampling.samples_per_rev is None else 0.0,
    }
    if gas is not None:
        attrs.update({"samples_per_rev": gas.theta.size // gas.revolutions, "inertia_samples_per_rev": samples,
                      "revolutions": gas.revolutions})
    return attrs
