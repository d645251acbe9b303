"""Joint forces of the whole mechanism: Newton–Euler per body, per crank angle.

The bodies are, per cylinder, the piston group and the con-rod, then the
crankshaft and, per lever balancer, its rocker and coupler. At constant crank
speed every acceleration is known from the kinematics, so the equations of
motion are linear in the joint forces and block-triangular; each block is
solved in closed form, vectorised over angles:

1. piston and rod of each cylinder (in the cylinder's plane frame, complex
   ζ = c + i·n): the piston's axial equation gives the piston-pin force along
   the axis, the rod's moment about the crank pin its lateral part, then the
   wall force, the wall couple and the crank-pin force follow;
2. rocker and coupler of each lever balancer: their moment equations about A
   and C give the 2×2 system for the force at B, whose determinant is
   a·b·sin γ (γ the transmission angle; zero at the toggle position), then
   the forces at A and C follow;
3. the crankshaft: its force equation gives the main-bearing force D and its
   moment equation about the crank axis the drive torque.

Every force is a w-plane vector (see :mod:`harmbal.model.linkage`) until the
Dataset is built in engine axes (y, z). Joint forces are what the first-named
body exerts on the second (e.g. "frame on rocker"). The reactions on the
frame sum to the shaking force −Σ m·a_G exactly (tested).

The mechanism is simulated whole, whatever the scene's effect list (a partial
mechanism has no meaningful joint forces); the con-rod is the rigid body the
scene's rod model implies (``two_point``: CG on the axis and the two-point
inertia m·a·(l − a); ``two_point_couple``: CG on the axis, the true inertia;
``rigid``: as given); the piston follows the exact slider-crank. No gas forces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..labelled import Speeds, with_speed_indexes
from ..scene import Scene
from ..scene.elements import TRANSMISSION_WARNING, closure
from ..scene.requests import PEAK_SAMPLES
from .kinematics import slider_crank
from .linkage import four_bar, to_engine
from .sampling import choose_samples


def _cross(p, q):
    return (np.conj(p) * q).imag


@dataclass(frozen=True)
class Reactions:
    """Unit-speed joint forces (complex, w-plane) over θ, in joint order.

    ``forces`` maps a joint name to its force; ``describe`` to its meaning.
    ``drive_torque`` [N m] is the torque on the crankshaft that keeps ω
    constant (in the direction of rotation), ``wall_couple`` per cylinder the
    couple [N m] of the cylinder wall on the piston (the wall force acts at
    the piston pin). ``frame_force`` and ``frame_roll`` are the reactions'
    force and moment about the crank axis on the block (w-plane, in the
    direction of rotation).
    """

    theta: np.ndarray
    forces: dict[str, np.ndarray]
    describe: dict[str, str]
    drive_torque: np.ndarray
    wall_couple: np.ndarray
    frame_force: np.ndarray
    frame_roll: np.ndarray


def _rod_body(scene: Scene, cyl):
    """Mass, CG (along, lateral) and inertia of the rigid rod the rod model implies."""
    rod, l = cyl.rod, cyl.rod_length
    two_point = rod.mass * rod.cg_from_big_end * (l - rod.cg_from_big_end)
    if scene.model.rod == "two_point" or rod.inertia is None:
        return rod.mass, rod.cg_from_big_end, 0.0, two_point
    lateral = rod.cg_lateral if scene.model.rod == "rigid" else 0.0
    return rod.mass, rod.cg_from_big_end, lateral, rod.inertia


def reactions(scene: Scene, theta: np.ndarray) -> Reactions:
    """Joint forces of the scene's mechanism at unit crank speed.

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`.
    theta : ndarray
        Crank angles θ [rad].

    Returns
    -------
    Reactions
    """
    theta = np.asarray(theta, dtype=float)
    sums = _Sums.zeros(theta)
    _cylinder_reactions(scene, theta, sums)
    _lever_reactions(scene, theta, sums)
    # The crankshaft: unbalances turning with it (throws, crankshaft,
    # counterweights and CAD data on its axis) have m·a_G = −U·e^{i(θ+α)}.
    unbalance = sum((u.unbalance * np.exp(1j * (c.throw + u.angle)) for c in scene.cylinders
                     for u in c.throw_unbalances), 0j)
    unbalance += sum((u.unbalance * np.exp(1j * u.angle) for u in scene.crankshaft_unbalances), 0j)
    unbalance += sum((u.unbalance * np.exp(1j * u.angle) for s in scene.shafts if s.on_crank
                      for u in s.unbalances), 0j)
    bearing = sums.crank_pins + sums.couplers - unbalance * np.exp(1j * theta)
    forces = {"D": bearing, **sums.forces}
    describe = {"D": "frame on crankshaft (main bearings, resultant)", **sums.describe}
    frame_force = -(bearing + sums.pivots + sums.walls)
    couples = sums.couples
    return Reactions(theta=theta, forces=forces, describe=describe, drive_torque=sums.torque,
                     wall_couple=np.array(couples).reshape(len(couples), len(theta)), frame_force=frame_force,
                     frame_roll=sums.frame_roll)


@dataclass(eq=False)
class _Sums:
    """What :func:`reactions` gathers over the bodies: each joint's force and
    words, the forces of the crank on the rods (``crank_pins``) and on the
    couplers, of the frame on the rockers (``pivots``) and the walls on the
    pistons, the drive torque, the frame's roll and the pistons' wall couples."""

    forces: dict
    describe: dict
    crank_pins: np.ndarray
    couplers: np.ndarray
    pivots: np.ndarray
    walls: np.ndarray
    torque: np.ndarray
    frame_roll: np.ndarray
    couples: list

    @classmethod
    def zeros(cls, theta: np.ndarray) -> _Sums:
        return cls(forces={}, describe={}, crank_pins=np.zeros_like(theta, dtype=complex),
                   couplers=np.zeros_like(theta, dtype=complex), pivots=np.zeros_like(theta, dtype=complex),
                   walls=np.zeros_like(theta, dtype=complex), torque=np.zeros_like(theta),
                   frame_roll=np.zeros_like(theta), couples=[])


def _cylinder_reactions(scene: Scene, theta: np.ndarray, sums: _Sums) -> None:
    """Add the joints of each cylinder's piston and rod, solved in its plane frame, to ``sums``."""
    for cyl in scene.cylinders:
        psi = theta + cyl.throw - cyl.bank
        kin = slider_crank(psi, cyl.crank_radius, cyl.rod_length, cyl.offset)
        m_rod, along, lateral, inertia = _rod_body(scene, cyl)
        m_pis = cyl.piston.mass
        e_pin = kin.a[0] + 1j * kin.a[1]
        f_pin = kin.b + 1j * kin.e
        (gc, gn), _, (ddgc, ddgn) = kin.rod_point(along, lateral, cyl.rod_length)
        rod_force = m_rod * (ddgc + 1j * ddgn)  # m·a_G of the rod
        pin_axial = m_pis * kin.ddb  # piston: F_F,c = m·c_B''
        about_e = _cross(gc + 1j * gn - e_pin, rod_force) + inertia * kin.ddrod_angle
        arm = f_pin - e_pin  # rod about the crank pin: (F − E) × (−F_F) = about_e
        pin_lateral = (arm.imag * pin_axial - about_e) / arm.real  # arm.real = sqrt(l² − g²) > 0
        on_piston = pin_axial + 1j * pin_lateral
        wall = -1j * pin_lateral  # F_F + i·N = m·c_B'' (real): N = −F_F,n
        on_rod = on_piston + rod_force  # crank on rod at E
        turn = np.exp(1j * cyl.bank)
        label = cyl.label
        sums.forces[f"E{label}"] = on_rod * turn
        sums.describe[f"E{label}"] = f"crankshaft on con-rod {label} (crank pin)"
        sums.forces[f"F{label}"] = on_piston * turn
        sums.describe[f"F{label}"] = f"con-rod on piston {label} (piston pin)"
        sums.forces[f"W{label}"] = wall * turn
        sums.describe[f"W{label}"] = f"cylinder wall on piston {label} (at the pin)"
        couple = -cyl.piston.cg_lateral * m_pis * kin.ddb
        sums.couples.append(couple)
        sums.crank_pins += on_rod * turn
        sums.torque += _cross(e_pin * turn, on_rod * turn)
        sums.walls += wall * turn
        sums.frame_roll -= _cross(f_pin * turn, wall * turn) + couple


def _lever_reactions(scene: Scene, theta: np.ndarray, sums: _Sums) -> None:
    """Add the joints of each lever balancer's rocker and coupler to ``sums``."""
    for lever in scene.levers:
        motion = four_bar(lever, theta, scene.sense)
        g2, _, dd2 = motion.point("rocker", complex(*lever.rocker.cg))
        g3, _, dd3 = motion.point("coupler", complex(*lever.coupler.cg))
        m2a, m3a = lever.rocker.mass * dd2, lever.coupler.mass * dd3
        about_c = _cross(g3 - motion.c, m3a) + lever.coupler.inertia * motion.ddcoupler
        about_a = _cross(g2 - motion.pivot, m2a) + lever.rocker.inertia * motion.ddrocker
        u, v = motion.b - motion.c, motion.b - motion.pivot
        on_coupler_b = (about_c * v + about_a * u) / _cross(u, v)  # u × F = about_c, v × F = −about_a
        on_coupler_c = m3a - on_coupler_b
        on_rocker_a = m2a + on_coupler_b
        name = lever.label
        sums.forces[f"{name}: A"] = on_rocker_a
        sums.describe[f"{name}: A"] = f"frame on rocker of {name} (pivot A)"
        sums.forces[f"{name}: B"] = on_coupler_b
        sums.describe[f"{name}: B"] = f"rocker on coupler of {name} (joint B)"
        sums.forces[f"{name}: C"] = on_coupler_c
        sums.describe[f"{name}: C"] = f"crankshaft on coupler of {name} (second crank pin C)"
        sums.couplers += on_coupler_c
        sums.pivots += on_rocker_a
        sums.torque += _cross(motion.c, on_coupler_c)
        sums.frame_roll -= _cross(np.full_like(motion.c, motion.pivot), on_rocker_a)


def joints(scene: Scene, *, samples_per_rev: int | None = None):
    """Joint forces, drive torque and toggle diagnostics as a Dataset.

    Parameters
    ----------
    scene : Scene
        From :func:`harmbal.load_scene`.
    samples_per_rev : int, optional
        Default: the scene's sampling, at least
        :data:`harmbal.scene.requests.PEAK_SAMPLES` so that peaks are accurate.

    Returns
    -------
    xarray.Dataset
        ``joint_force`` [N] (joint, axis y/z, angle; what the first-named body
        exerts on the second, see ``joint_description``), its magnitude's
        peak ``joint_force_peak`` and the angle of the peak,
        ``drive_torque`` [N m], ``wall_couple`` [N m], the reactions on the
        frame ``frame_force`` [N] and ``frame_moment_x`` [N m] (about the
        crank axis, engine x), and per lever balancer the
        ``transmission_angle`` over θ, ``min_transmission_angle`` and
        ``discriminant_margin`` (min sin²γ). A leading ``speed`` dim when the
        scene has several speeds.
    """
    import xarray as xr

    n = samples_per_rev or max(choose_samples(scene), PEAK_SAMPLES)
    theta = 2 * np.pi * np.arange(n) / n
    sense = scene.sense
    result = reactions(scene, theta)
    speeds = Speeds(scene.speeds)
    lead, scaled, coords = speeds.lead, speeds.scaled, speeds.coords()

    names = list(result.forces)
    stacked = np.stack([np.stack(to_engine(result.forces[j], sense)) for j in names])  # (joint, axis, angle)
    magnitude = np.abs(np.stack([result.forces[j] for j in names]))
    peak_index = magnitude.argmax(axis=-1)
    coords.update({
        "angle": ("angle", theta, {"units": "rad", "long_name": "crank angle θ"}),
        "axis": ("axis", ["y", "z"], {"long_name": "engine axis"}),
        "joint": ("joint", names, {"long_name": "joint"}),
        "joint_description": ("joint", [result.describe[j] for j in names],
                              {"long_name": "which body acts on which"}),
        "cylinder": ("cylinder", [c.label for c in scene.cylinders], {"long_name": "cylinder label"}),
    })
    frame = np.stack(to_engine(result.frame_force, sense))
    data = {
        "joint_force": (lead + ("joint", "axis", "angle"), scaled(stacked),
                        {"units": "N", "long_name": "joint force (first-named body on the second)"}),
        "joint_force_peak": (lead + ("joint",), scaled(magnitude.max(axis=-1)),
                             {"units": "N", "long_name": "peak magnitude of the joint force over the revolution"}),
        "joint_force_peak_angle": (("joint",), theta[peak_index],
                                   {"units": "rad", "long_name": "crank angle of the peak"}),
        "drive_torque": (lead + ("angle",), scaled(result.drive_torque),
                         {"units": "N m", "long_name": "torque on the crankshaft keeping ω constant",
                          "description": "positive in the direction of rotation"}),
        "wall_couple": (lead + ("cylinder", "angle"), scaled(result.wall_couple),
                        {"units": "N m", "long_name": "couple of the cylinder wall on the piston",
                         "description": "positive in the direction of rotation; the wall force acts at the pin"}),
        "frame_force": (lead + ("axis", "angle"), scaled(frame),
                        {"units": "N", "long_name": "force of the joint reactions on the block"}),
        "frame_moment_x": (lead + ("angle",), scaled(sense * result.frame_roll),
                           {"units": "N m", "long_name": "moment of the joint reactions on the block about the "
                                                        "crank axis (engine x)"}),
    }
    if scene.levers:
        coords["lever"] = ("lever", [lever.label for lever in scene.levers], {"long_name": "lever balancer"})
        gamma = np.stack([np.arcsin(np.clip(four_bar(lever, theta, sense).sin_gamma, 0, 1))
                          for lever in scene.levers])
        checks = [closure(lever, sense) for lever in scene.levers]
        data.update({
            "transmission_angle": (("lever", "angle"), gamma,
                                   {"units": "rad", "long_name": "transmission angle, acute side min(γ, π − γ)"}),
            "min_transmission_angle": (("lever",), [c.min_transmission_angle for c in checks],
                                       {"units": "rad", "long_name": "minimum transmission angle (closed form)"}),
            "min_transmission_theta": (("lever",), [c.min_transmission_theta for c in checks],
                                       {"units": "rad", "long_name": "crank angle of the minimum"}),
            "discriminant_margin": (("lever",), [c.margin for c in checks],
                                    {"units": "1", "long_name": "closure margin min Δ/(4a²b²) = min sin²γ"}),
        })
    return with_speed_indexes(xr.Dataset(data, coords, attrs={
        "title": f"harmbal joint forces: {scene.name}",
        "engine": scene.name,
        "samples_per_rev": n,
        "transmission_warning": math.degrees(TRANSMISSION_WARNING),
        "harmbal_conventions": "joint_force: force of the first-named body on the second (joint_description), "
                               "engine axes y, z; constant crank speed, no gas forces, whole mechanism whatever "
                               "model.effects.",
    }))
