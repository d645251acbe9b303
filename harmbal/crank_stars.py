"""Crank stars and the free force and free moment vectors of each order,
computed in the order domain.

Cylinders that differ only in throw, bank, axial position and label share one
exact single-cylinder spectrum: it is computed once per group (by FFT of the
exact model of that cylinder in its own frame), and every cylinder's phasors
follow from the shift theorem. Cylinder i runs at local crank angle
ψ_i = θ + φ_i − β_i, so its order-k phasor is the group's times
e^{ik(φ_i − β_i)}, turned by the bank angle β_i into the engine frame.
Static unbalances on the crankshaft are pure co-rotating first-order
phasors, written down in closed form. The sum over cylinders gives the free
force and free moment per order, exactly (up to the aliasing of the single
cylinder's spectrum), in a fraction of the time-domain path's cost.

The crank star of order k is the set of angles {k·φ_i}; it is *regular* when
its distinct arms are equally spaced round the circle with equal
multiplicity, which makes the order's force vanish for identical inline
cylinders.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .balancers import Shaft, ShaftUnbalance, shaft_amplitudes, shaft_phasors
from .firing import cylinder_firing
from .orders import BALANCED_RTOL, ROTATION, aliasing_estimate, is_balanced, phasors, rotating_split
from .linkage import lever_loads
from .scene import Cylinder, Scene
from .timedomain import AXES, attributes, choose_samples, moment_about, planar_loads, speed_axis

#: Angles of a crank star closer than this [rad] form one arm.
STAR_TOL = 1e-9

#: Relative tolerance of :func:`verify_orders`, of the largest single
#: cylinder's peak load.
VERIFY_RTOL = 1e-12


@dataclass(frozen=True)
class OrderPhasors:
    """Unit-speed (ω = 1 rad/s) order phasors from the order-domain path.

    Force and moment (about the scene's reference point) per cylinder
    (cylinder, axis, order) including the cylinder's throw unbalances, and of
    the crankshaft unbalances (axis, order). ``peak_force``/``peak_moment``
    bound each cylinder's peak load (for tolerances) and ``alias_force``/
    ``alias_moment`` estimate each cylinder's aliasing error. Lever balancers
    are not harmonic: their phasors come from the FFT of their exact loads.
    """

    force_cylinder: np.ndarray
    moment_cylinder: np.ndarray
    force_crankshaft: np.ndarray
    moment_crankshaft: np.ndarray
    peak_force: np.ndarray
    peak_moment: np.ndarray
    crankshaft_peak_force: float
    crankshaft_peak_moment: float
    alias_force: np.ndarray
    alias_moment: np.ndarray
    samples_per_rev: int
    groups: int
    #: Aliasing estimates of the lever balancers (sampled, not closed form).
    crankshaft_alias_force: float = 0.0
    crankshaft_alias_moment: float = 0.0

    @property
    def aliasing(self) -> tuple[float, float]:
        """Total aliasing estimates (force [N], moment [N m]) at unit speed."""
        return (float(self.alias_force.sum()) + self.crankshaft_alias_force,
                float(self.alias_moment.sum()) + self.crankshaft_alias_moment)

    @property
    def force(self) -> np.ndarray:
        return self.force_cylinder.sum(axis=0) + self.force_crankshaft

    @property
    def moment(self) -> np.ndarray:
        return self.moment_cylinder.sum(axis=0) + self.moment_crankshaft


#: Cylinder fields that place a cylinder in the engine; all other fields
#: (geometry and masses) define its type. A meta-test checks that the two sets
#: cover every field.
PLACEMENT_FIELDS = ("label", "throw", "bank", "x", "throw_unbalances")
TYPE_FIELDS = ("crank_radius", "rod_length", "pin_offset", "cylinder_offset", "piston", "rod")


def cylinder_groups(cylinders: tuple[Cylinder, ...]) -> tuple[list[Cylinder], np.ndarray]:
    """Cylinders that share one single-cylinder spectrum.

    Returns one representative per type (its placement is ignored) and each
    cylinder's group index.
    """
    groups: dict[tuple, int] = {}
    representatives = []
    index = np.empty(len(cylinders), dtype=int)
    for i, c in enumerate(cylinders):
        key = tuple(getattr(c, name) for name in TYPE_FIELDS)
        if key not in groups:
            groups[key] = len(representatives)
            representatives.append(c)
        index[i] = groups[key]
    return representatives, index


def _unbalance_phasors(angle: float, u, sense: int) -> tuple[np.ndarray, np.ndarray]:
    """First-order force and moment (about the origin) phasors per axis of a
    static unbalance ``u`` turning with the crank on its axis, pointing at
    ``angle``: a shaft at ratio 1 (:func:`harmbal.balancers.shaft_amplitudes`)."""
    return shaft_amplitudes(Shaft("", 1, 0.0, 0.0, (ShaftUnbalance(u.unbalance, angle, u.x),)), sense)


def order_phasors(scene: Scene, *, samples_per_rev: int | None = None, backend: str = "scipy") -> OrderPhasors:
    """Per-cylinder order phasors at unit speed by the shift theorem.

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`.
    samples_per_rev : int, optional
        Samples of each single-cylinder spectrum; default as the time domain
        (:func:`harmbal.timedomain.choose_samples`).
    backend : {"scipy", "numpy", "pyfftw"}
        FFT implementation.

    Returns
    -------
    OrderPhasors
    """
    n = samples_per_rev or choose_samples(scene)
    kmax = scene.sampling.max_order
    sense = scene.sense
    cyls = scene.cylinders
    ncyl = len(cyls)
    order = np.arange(kmax + 1)
    theta = 2 * np.pi * np.arange(n) / n

    representatives, group = cylinder_groups(cyls)
    force = np.zeros((ncyl, 3, kmax + 1), dtype=complex)
    moment = np.zeros((ncyl, 3, kmax + 1), dtype=complex)
    peak_force = np.zeros(ncyl)
    peak_roll = np.zeros(ncyl)
    alias_force = np.zeros(ncyl)
    alias_roll = np.zeros(ncyl)

    planar = planar_loads(scene, representatives, np.broadcast_to(theta, (len(representatives), n)))
    if planar is not None:
        samples = np.stack(planar, axis=1)  # (group, c/n/roll, angle)
        spectrum = phasors(samples, backend)
        tail = aliasing_estimate(np.abs(spectrum), n, kmax)
        a, b, roll = (spectrum[group, j, : kmax + 1] for j in range(3))
        bank = np.array([c.bank for c in cyls])[:, None]
        shift = np.exp(1j * order * (np.array([c.throw for c in cyls])[:, None] - bank))
        x = np.array([c.x for c in cyls])[:, None]
        fz = (a * np.cos(bank) - b * np.sin(bank)) * shift
        ft = (a * np.sin(bank) + b * np.cos(bank)) * shift
        force[:, 1] = -sense * ft
        force[:, 2] = fz
        moment[:, 0] = sense * roll * shift
        moment[:, 1] = -x * force[:, 2]
        moment[:, 2] = x * force[:, 1]
        peak_force += np.hypot(samples[:, 0], samples[:, 1]).max(axis=-1)[group]
        peak_roll += np.abs(samples[:, 2]).max(axis=-1)[group]
        alias_force += np.hypot(tail[:, 0], tail[:, 1])[group]
        alias_roll += tail[:, 2][group]

    crank_force = np.zeros((3, kmax + 1), dtype=complex)
    crank_moment = np.zeros((3, kmax + 1), dtype=complex)
    crank_peak = 0.0
    rotating = "rotating" in scene.model.effects and kmax >= 1
    if rotating:
        for i, c in enumerate(cyls):
            for u in c.throw_unbalances:
                f, m = _unbalance_phasors(c.throw + u.angle, u, sense)
                force[i, :, 1] += f
                moment[i, :, 1] += m
                peak_force[i] += u.unbalance
        for u in scene.crankshaft_unbalances:
            f, m = _unbalance_phasors(u.angle, u, sense)
            crank_force[:, 1] += f
            crank_moment[:, 1] += m
            crank_peak += u.unbalance
    shafts = scene.shafts if "balancers" in scene.model.effects else ()
    if shafts:
        shaft_force, shaft_moment = shaft_phasors(shafts, kmax, sense)
        crank_force += shaft_force
        crank_moment += shaft_moment

    ref = np.asarray(scene.reference_point, dtype=float)
    lever_peak_force = lever_peak_moment = lever_alias_force = lever_alias_moment = 0.0
    levers = scene.levers if "balancers" in scene.model.effects else ()
    if levers:
        f, m = lever_loads(levers, theta, sense, "mass_torque" in scene.model.effects)
        spec_f, spec_m = phasors(np.stack([f, m]), backend)  # (axis, order), moment about the origin
        crank_force += spec_f[:, : kmax + 1]
        crank_moment += spec_m[:, : kmax + 1]
        lever_peak_force = float(np.linalg.norm(f, axis=0).max())
        lever_peak_moment = float(np.linalg.norm(moment_about(ref, f, m), axis=0).max())
        lever_alias_force, lever_alias_moment = (
            float(np.linalg.norm(aliasing_estimate(np.abs(spec), n, kmax)))
            for spec in (spec_f, moment_about(ref, spec_f, spec_m)))
    moment = moment_about(ref, force, moment)
    crank_moment = moment_about(ref, crank_force, crank_moment)
    # |M_i| ≤ |roll| + |r − ref|·|F| with r the farthest point of cylinder i's loads.
    lever = np.array([max([abs(c.x - ref[0])] + [abs(u.x - ref[0]) for u in c.throw_unbalances]) for c in cyls])
    lever = np.hypot(lever, np.hypot(ref[1], ref[2]))
    crank_lever = max([0.0] + [float(np.hypot(u.x - ref[0], np.hypot(ref[1], ref[2])))
                               for u in scene.crankshaft_unbalances])
    shaft_peak_force = shaft_peak_moment = 0.0
    for shaft in shafts:
        n2 = shaft.ratio**2
        shaft_peak_force += n2 * sum(u.unbalance for u in shaft.unbalances)
        shaft_peak_moment += n2 * (abs(shaft.couple) + sum(
            u.unbalance * float(np.linalg.norm(np.array([u.x, shaft.y, shaft.z]) - ref)) for u in shaft.unbalances))
    return OrderPhasors(
        force_cylinder=force, moment_cylinder=moment,
        force_crankshaft=crank_force, moment_crankshaft=crank_moment,
        peak_force=peak_force, peak_moment=peak_roll + lever * peak_force,
        crankshaft_peak_force=crank_peak + shaft_peak_force + lever_peak_force,
        crankshaft_peak_moment=crank_lever * crank_peak + shaft_peak_moment + lever_peak_moment,
        alias_force=alias_force, alias_moment=alias_roll + lever * alias_force,
        samples_per_rev=n, groups=len(representatives),
        crankshaft_alias_force=lever_alias_force, crankshaft_alias_moment=lever_alias_moment,
    )


def star_arms(angles: np.ndarray, tol: float = STAR_TOL) -> list[tuple[float, list[int]]]:
    """Distinct arms of a crank star: each arm's angle [rad, in [0, 2π)] and
    the indices of the cylinders on it, in order of angle. Angles within
    ``tol`` of an arm's first angle, also across 0 = 2π, are one arm."""
    angles = np.mod(np.asarray(angles, dtype=float), 2 * np.pi)
    arms: list[tuple[float, list[int]]] = []
    for i in np.argsort(angles, kind="stable"):
        a = float(angles[i])
        if arms and a - arms[-1][0] <= tol:
            arms[-1][1].append(int(i))
        else:
            arms.append((a, [int(i)]))
    if len(arms) > 1 and arms[0][0] + 2 * np.pi - arms[-1][0] <= tol:
        arms[0][1].extend(arms.pop()[1])
    return arms


def star_is_regular(angles: np.ndarray, tol: float = STAR_TOL) -> bool:
    """True if the arms {angles} are equally spaced round the circle (at least
    two distinct arms) with equal multiplicity."""
    arms = star_arms(angles, tol)
    m = len(arms)
    if m < 2 or len({len(members) for _, members in arms}) != 1:
        return False
    first = np.array([a for a, _ in arms])
    gaps = np.diff(np.append(first, first[0] + 2 * np.pi))
    return bool(np.all(np.abs(gaps - 2 * np.pi / m) <= m * tol))


def _stars(scene: Scene, kmax: int):
    """Star angles (order, cylinder), regularity and resultants of the whole
    crank and of each bank."""
    throw = np.array([c.throw for c in scene.cylinders])
    bank = np.array([c.bank for c in scene.cylinders])
    banks = []
    for b in bank:
        if not any(abs(np.remainder(b - q + np.pi, 2 * np.pi) - np.pi) <= STAR_TOL for q in banks):
            banks.append(b)
    member = [np.abs(np.remainder(bank - q + np.pi, 2 * np.pi) - np.pi) <= STAR_TOL for q in banks]
    order = np.arange(kmax + 1)
    angles = np.mod(np.outer(order, throw), 2 * np.pi)
    unit = np.exp(1j * angles)
    regular = np.array([star_is_regular(row) for row in angles])
    bank_regular = np.array([[star_is_regular(row[m]) for m in member] for row in angles])
    bank_resultant = np.stack([unit[:, m].sum(axis=1) for m in member], axis=1)
    return angles, regular, unit.sum(axis=1), np.array(banks), bank_regular, bank_resultant


def stars(scene: Scene, *, samples_per_rev: int | None = None, backend: str = "scipy"):
    """Crank stars, firing and the free force and moment of every order,
    computed in the order domain.

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`.
    samples_per_rev : int, optional
        Samples of each single-cylinder spectrum; default the scene's sampling.
    backend : {"scipy", "numpy", "pyfftw"}
        FFT implementation for the single-cylinder spectra.

    Returns
    -------
    xarray.Dataset
        Dims ``order`` (0 … the scene's ``max_order``), ``cylinder``,
        ``axis``, ``rotation`` (co, counter), ``bank`` (distinct bank angles),
        ``firing`` (position in the firing sequence), plus ``speed`` if the
        scene has several.

        * ``star_angle`` (order, cylinder): k·φ_i mod 2π [rad];
          ``star_regular`` and ``star_resultant`` = Σ e^{ikφ_i} per order;
          ``bank_star_regular`` and ``bank_star_resultant`` per order and bank.
        * ``force``, ``moment`` (order, axis) [N], [N m]: complex phasors C_k
          with s(θ) = Σ Re(C_k e^{ikθ}), moments about the reference point;
          ``force_rotating``, ``moment_rotating`` (order, rotation): co- and
          counter-rotating phasors of the transverse vector, as in
          :func:`harmbal.order_spectrum`. Components at or below
          ``balanced_rtol`` × the load scale are exactly 0 (no noise phase).
        * ``force_cylinder``, ``moment_cylinder`` (cylinder, order, rotation):
          each cylinder's rotating phasors (with its throw unbalances), the
          arrows of the phasor diagram.
        * ``force_free``, ``moment_free`` (order, rotation) and ``roll_free``
          (order, the moment about the crank axis): the classification.
        * ``firing_angle`` (cylinder) [rad], ``firing_sequence`` and
          ``firing_interval`` [rad] (firing).
    """
    import xarray as xr

    p = order_phasors(scene, samples_per_rev=samples_per_rev, backend=backend)
    kmax = scene.sampling.max_order
    sense = scene.sense
    lead, w2, coords = speed_axis(scene)
    labels = [c.label for c in scene.cylinders]

    def scaled(values):
        return np.multiply.outer(w2, values) if lead else w2 * values

    def rotating(per_axis):
        return np.stack(rotating_split(per_axis[..., 2, :], -sense * per_axis[..., 1, :]), axis=-1)

    force_scale = float(p.peak_force.sum() + p.crankshaft_peak_force)
    moment_scale = float(p.peak_moment.sum() + p.crankshaft_peak_moment)
    force, moment = p.force, p.moment
    force_rot, moment_rot = rotating(force), rotating(moment)
    force_free = ~is_balanced(force_rot, force_scale)
    moment_free = ~is_balanced(moment_rot, moment_scale)
    roll_free = ~is_balanced(moment[0], moment_scale)

    def cleaned(values, scale):
        return np.where(is_balanced(values, scale), 0, values)

    angles, regular, resultant, banks, bank_regular, bank_resultant = _stars(scene, kmax)
    cyl = scene.cylinders
    fire = cylinder_firing(cyl, scene.cycle, scene.firing_order)

    lo = lead + ("order",)
    data = {
        "star_angle": (("order", "cylinder"), angles, {"units": "rad", "long_name": "crank star arm k·φ_i"}),
        "star_regular": ("order", regular, {"long_name": "crank star arms equally spaced with equal multiplicity"}),
        "star_resultant": ("order", resultant, {"units": "1", "long_name": "sum of the star's unit arms"}),
        "bank_star_regular": (("order", "bank"), bank_regular, {"long_name": "crank star of one bank is regular"}),
        "bank_star_resultant": (("order", "bank"), bank_resultant,
                                {"units": "1", "long_name": "sum of the unit arms of one bank's star"}),
        "force": (lo + ("axis",), scaled(cleaned(force, force_scale).T),
                  {"units": "N", "long_name": "free force phasor"}),
        "moment": (lo + ("axis",), scaled(cleaned(moment, moment_scale).T),
                   {"units": "N m", "long_name": "free moment phasor about the reference point"}),
        "force_rotating": (lo + ("rotation",), scaled(cleaned(force_rot, force_scale)),
                           {"units": "N", "long_name": "co- and counter-rotating free force phasors"}),
        "moment_rotating": (lo + ("rotation",), scaled(cleaned(moment_rot, moment_scale)),
                            {"units": "N m", "long_name": "co- and counter-rotating free moment phasors"}),
        "force_cylinder": (lead + ("cylinder", "order", "rotation"), scaled(rotating(p.force_cylinder)),
                           {"units": "N", "long_name": "one cylinder's rotating force phasors"}),
        "moment_cylinder": (lead + ("cylinder", "order", "rotation"), scaled(rotating(p.moment_cylinder)),
                            {"units": "N m", "long_name": "one cylinder's rotating moment phasors"}),
        "force_free": (("order", "rotation"), force_free, {"long_name": "rotating force component is free"}),
        "moment_free": (("order", "rotation"), moment_free, {"long_name": "rotating moment component is free"}),
        "roll_free": ("order", roll_free, {"long_name": "moment about the crank axis is free"}),
        "force_scale": (lead, w2 * force_scale, {"units": "N", "long_name": "sum of single-body peak forces"}),
        "moment_scale": (lead, w2 * moment_scale, {"units": "N m", "long_name": "sum of single-body peak moments"}),
        "aliasing_error_force": (lead, w2 * p.aliasing[0],
                                 {"units": "N", "long_name": "estimated aliasing error of the force phasors"}),
        "aliasing_error_moment": (lead, w2 * p.aliasing[1],
                                  {"units": "N m", "long_name": "estimated aliasing error of the moment phasors"}),
        "firing_angle": ("cylinder", fire.angle, {"units": "rad", "long_name": "crank angle θ of firing"}),
        "firing_sequence": ("firing", [labels[i] for i in fire.sequence], {"long_name": "cylinder firing"}),
        "firing_interval": ("firing", fire.interval, {"units": "rad", "long_name": "crank angle to the next firing"}),
    }
    coords.update({
        "order": ("order", np.arange(kmax + 1), {"long_name": "order of crank speed", "units": "1"}),
        "cylinder": ("cylinder", labels, {"long_name": "cylinder label"}),
        "throw": ("cylinder", np.array([c.throw for c in cyl]), {"units": "rad", "long_name": "throw angle φ"}),
        "cylinder_bank": ("cylinder", np.array([c.bank for c in cyl]), {"units": "rad", "long_name": "bank angle β"}),
        "axis": ("axis", list(AXES), {"long_name": "engine axis"}),
        "rotation": ("rotation", list(ROTATION), {"long_name": "sense of rotation relative to the crank"}),
        "bank": ("bank", banks, {"units": "rad", "long_name": "bank angle"}),
        "firing": ("firing", np.arange(1, len(cyl) + 1), {"long_name": "position in the firing sequence"}),
    })
    attrs = attributes(scene, p.samples_per_rev)
    attrs.update({
        "title": f"harmbal crank stars and free vectors: {scene.name}",
        "path": "order domain: one exact spectrum per cylinder type, shift theorem per cylinder",
        "cylinder_types": p.groups,
        "amplitude": "peak (one-sided)",
        "phase": "arg C_k, relative to theta = 0 (throw 1 along +z)",
        "transverse_frame": f"w = z + i t, t = {'+' if sense < 0 else '-'}y",
        "balanced_rtol": BALANCED_RTOL,
        "firing_order": "-".join(labels[i] for i in fire.sequence),
        "firing_order_given": "yes" if fire.given else "no",
        "firing_even": "yes" if fire.even else "no",
    })
    return xr.Dataset(data, coords, attrs)


def verify_orders(scene: Scene, *, backend: str = "scipy"):
    """Compare the order-domain free vectors with the FFT of the exact
    time-domain model.

    Both paths use the scene's sampling. The tolerance per speed is
    ``VERIFY_RTOL`` × the largest single cylinder's peak load plus the
    aliasing estimates of both paths.

    Returns
    -------
    xarray.Dataset
        ``force_order_domain``, ``force_time_domain`` (order, axis) and the
        same for ``moment``; ``force_difference`` (order), the largest
        difference over the axes, ``force_tolerance`` and ``force_passed``
        (order); likewise for the moment. The attribute ``passed`` is
        ``"yes"`` if every order passes.
    """
    import xarray as xr

    from .orders import order_spectrum
    from .timedomain import simulate

    p = order_phasors(scene, backend=backend)
    time = order_spectrum(simulate(scene, samples_per_rev=p.samples_per_rev), backend=backend)
    lead, w2, coords = speed_axis(scene)
    coords.update({
        "order": time["order"], "axis": time["axis"],
    })
    data = {}
    passed = True
    for name, units, values, peak, alias in (("force", "N", p.force, p.peak_force, p.aliasing[0]),
                                            ("moment", "N m", p.moment, p.peak_moment, p.aliasing[1])):
        order_domain = np.multiply.outer(w2, values.T) if lead else w2 * values.T
        time_domain = time[name].values
        difference = np.abs(order_domain - time_domain).max(axis=-1)
        tol = w2 * (VERIFY_RTOL * peak.max(initial=0.0) + alias) + time[f"aliasing_error_{name}"].values.max(axis=-1)
        ok = difference <= np.expand_dims(tol, -1)
        passed = passed and bool(ok.all())
        data.update({
            f"{name}_order_domain": (lead + ("order", "axis"), order_domain, {"units": units}),
            f"{name}_time_domain": (lead + ("order", "axis"), time_domain, {"units": units}),
            f"{name}_difference": (lead + ("order",), difference,
                                   {"units": units, "long_name": "largest difference over the axes"}),
            f"{name}_tolerance": (lead, tol, {"units": units}),
            f"{name}_passed": (lead + ("order",), ok),
        })
    return xr.Dataset(data, coords, {
        "title": f"harmbal order-domain verification: {scene.name}",
        "engine": scene.name,
        "samples_per_rev": p.samples_per_rev,
        "verify_rtol": VERIFY_RTOL,
        "tolerance": "verify_rtol x largest single-cylinder peak load + aliasing estimates of both paths",
        "passed": "yes" if passed else "no",
    })
