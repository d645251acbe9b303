"""harmbal against the multibody code Exudyn: the same crank trains, the same block loads.

Run from the repository root with harmbal and the optional Exudyn installed
(``pip install exudyn``; harmbal itself never imports it):

    python benchmarks/bench_exudyn.py [--quick] [--repeat 200] [--runs 5]

``--quick`` is a smoke run (error target 1e-4 instead of 1e-6, one Exudyn run,
fewer harmbal calls; well under a minute). Without Exudyn the script prints
``exudyn not installed: pip install exudyn`` and exits with code 0.

What it compares, for reference engine A (``tractor-3cyl.toml``, inline three)
and the cross-plane V8 (``v8-cross-plane.toml``, its first speed): the order-1
and order-2 phasors of the shaking force and moment on the block, harmbal's
``hb.analyse(scene)["orders"]`` against an independent Exudyn multibody model.

The Exudyn model is built from the Scene's fields only (no harmbal formula in
it): a crankshaft turning about the engine x axis (a rigid body; throw and
crankshaft unbalances are point masses on it); per cylinder, in the plane
x = x_i tilted by its bank angle, a rigid con-rod (mass, CG and its lateral
offset, inertia about the CG; x is a principal axis, so the isotropic tensor
J·1 is used) on a revolute joint at the crank pin, and a rigid piston on a
prismatic joint along the cylinder axis (line n = pin_offset + cylinder_offset,
its CG offsets included), joined to the rod's small end by a point-in-plane
constraint (the pin's axial constraint would be redundant). All bodies are
3-D (Tait-Bryan nodes). The main bearing (revolute about x) and the cylinder
walls connect the moving parts to the *block*, a rigid body clamped to ground
at the reference point by six point constraints (3 + 2 + 1 translations at
p, p + e_x, p + e_y: statically determinate, forces only). The load of the
moving parts on the block is then the sum of the clamp forces, and its moment
about the reference point the sum of their moments: one exact rigid-body
equilibrium, with no assumption about where Exudyn puts a joint's reaction.

The crank is driven at constant ω from ground: a velocity-level coordinate
constraint on its rotation angle, whose reaction goes to ground, not to the
block. That is harmbal's convention with the ``mass_torque`` effect: the roll
moment is the block's load when the torque that keeps ω constant comes from
outside the block (the load, the flywheel, a dynamometer). Were the drive to
react on the block, the block would feel -dH/dt only, i.e. harmbal *without*
``mass_torque``; the single-cylinder check below runs both and shows it.

Numerics: generalized-alpha (index 3, spectral radius 0.9, Exudyn's default;
Newton tolerances also Exudyn's defaults; Eigen's sparse LU, which is
1.5-2.4× faster here than the dense default; ``--linear-solver dense``),
fixed steps of 2π/(ωN). The initial state is consistent (exact slider-crank
positions and velocities from the scene's geometry), but generalized-alpha
starts with a decaying spurious mode in the Lagrange multipliers, so the run
starts WARMUP_STEPS steps before θ = 0 (they are part of the timed run) and
the following N steps, θ = 0 … 2π(N - 1)/N, are kept and FFT'd: one-sided
peak phasors C_k with s(θ) = Σ Re(C_k e^{ikθ}), as harmbal's. N is doubled
from the start value until the error on orders 1 and 2 is at most the target (1e-6), then
bisected between the last failing and the first passing N (to within 1/32, multiples of 8)
so that Exudyn is timed at the coarsest step that reaches the target, not up to 4× finer, where

    error = max |C_exudyn - C_harmbal| / max |C_harmbal|,  over axes and orders 1-2,

separately for force and moment. Both engines' order-1 and order-2 *forces*
vanish (harmbal: ~1e-12 N), so for the force the denominator is harmbal's
``force_scale`` (sum of the single bodies' peak forces) whenever
max |C_harmbal| is below 1e-6 of it (marked "of scale"); the absolute force
error in N is printed too. If the target is not reached at ``--max-steps``,
the Richardson extrapolation (4 C_N - C_{N/2}) / 3 is reported instead and
marked as such.

Timing: a reaction-sign calibration and the single-cylinder check run first,
untimed. Exudyn: at the final N, ``--runs`` fresh models; "solve" is
``SolveDynamic`` plus reading the sensors and the FFT (model building
excluded), "build + solve" adds creating the items and ``Assemble``; median
over the runs. Exudyn's optimised module (``exudynCPPfast``, no range checks)
is used when the CPU supports it (``--checked`` for the default module).
harmbal: ``hb.analyse(scene)`` (the whole DataTree), median of ``--repeat``
calls after a warm-up call; the array path is harmbal's internal order-phasor
function (``order_phasors`` × ω², plain arrays; internal, so looked up under
its known module paths and reported as n/a if it has moved), median of
``10 × --repeat`` calls. harmbal's sampling targets 1e-12, so it is timed at
equal or better accuracy; its agreement with ``analyse`` is checked.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from timing import median_seconds

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"

#: Engine label -> scene file (the first speed is used).
SCENES = {"tractor-3cyl": "tractor-3cyl.toml", "V8 cross-plane": "v8-cross-plane.toml"}

SPECTRAL_RADIUS = 0.9   # generalized-alpha ρ∞ (Exudyn's default)
WARMUP_STEPS = 300      # the start-up mode decays like ~0.93^k: < 1e-9 after 300 steps
LINEAR_SOLVER = "sparse"  # Eigen's sparse LU: 1.5-2.4x faster here than Exudyn's dense default
FORCE_FLOOR = 1e-6      # below this fraction of force_scale, a force phasor counts as zero

#: Single cylinder exercising every scene field the Exudyn model reads:
#: counterclockwise, off-origin reference point, pin and cylinder offsets,
#: piston and rod CG offsets, throw and crankshaft unbalances, throw, bank, x.
SINGLE = {
    "engine": {"name": "exudyn-check", "speed": "3000 rpm", "rotation": "counterclockwise",
               "reference_point": ["10 mm", "-20 mm", "30 mm"]},
    "geometry": {"crank_radius": "60 mm", "rod_length": "215 mm", "pin_offset": "0.5 mm",
                 "cylinder_offset": "2 mm"},
    "piston": {"mass": "2.0 kg", "cg_offset": ["5 mm", "2 mm"]},
    "rod": {"mass": "2.7 kg", "cg_from_big_end": "72 mm", "cg_offset": "1.47 mm", "inertia": "0.0285 kg m^2"},
    "throw_unbalance": [{"unbalance": "0.05 kg m", "angle": "150 deg", "axial_offset": "20 mm"}],
    "crankshaft_unbalance": [{"unbalance": "0.03 kg m", "angle": "100 deg", "axial_position": "-40 mm"}],
    "cylinder": [{"throw": "40 deg", "bank": "25 deg", "axial_position": "50 mm"}],
}
RIGID_EFFECTS = {"reciprocating", "rotating", "rod_inertia"}


# -- harmbal side (public API) ---------------------------------------------------

def _first_speed(data):
    return data.isel(speed=0) if "speed" in data.dims else data


def harmbal_orders(scene) -> dict:
    """Orders 1-2 of force and moment, (order, axis), and the load scales."""
    import harmbal as hb

    ds = hb.analyse(scene)["orders"].ds
    pick = lambda name: _first_speed(ds[name]).sel(order=[1, 2]).transpose("order", "axis").values
    return {"force": pick("force"), "moment": pick("moment"),
            "force_scale": float(_first_speed(ds["force_scale"])),
            "moment_scale": float(_first_speed(ds["moment_scale"]))}


def array_path(scene):
    """harmbal's internal order-phasor function as ``f() -> (force, moment)``,
    orders 1-2 (order, axis) at the scene's speed, and its dotted name; None if
    it is not found where it used to live."""
    import importlib

    from harmbal.model.evaluate import evaluate

    omega2 = float(scene.speeds[0]) ** 2
    for module in ("harmbal.orders.phasors",):
        try:
            order_phasors = importlib.import_module(module).order_phasors
        except (ImportError, AttributeError):
            continue

        def arrays(order_phasors=order_phasors):
            p = order_phasors(evaluate(scene))
            return p.force[:, 1:3].T * omega2, p.moment[:, 1:3].T * omega2

        return arrays, f"{module}.order_phasors"
    return None


# -- Exudyn side: independent multibody model -------------------------------------

def direction(alpha: float, sense: int) -> np.ndarray:
    """Unit vector at angle ``alpha`` from +z, measured in the direction of
    rotation: a clockwise engine (sense -1) turns from +z towards +y."""
    return np.array([0.0, -sense * np.sin(alpha), np.cos(alpha)])


def slider_crank(cyl, theta: float, omega: float, sense: int) -> dict:
    """Positions and velocities of one cylinder's bodies at crank angle θ, from
    the scene's geometry (used only for the initial state and the markers)."""
    r, l, e = cyl.crank_radius, cyl.rod_length, cyl.pin_offset + cyl.cylinder_offset
    axis_c, axis_n = direction(cyl.bank, sense), direction(cyl.bank + np.pi / 2, sense)
    psi = theta + cyl.throw - cyl.bank                    # local crank angle, 0 at TDC
    big = r * np.array([np.cos(psi), np.sin(psi)])          # plane coordinates (c, n)
    big_dot = r * omega * np.array([-np.sin(psi), np.cos(psi)])
    root = np.sqrt(l * l - (r * np.sin(psi) - e) ** 2)
    pin = np.array([r * np.cos(psi) + root, e])
    pin_dot = np.array([-r * omega * np.sin(psi) - (r * np.sin(psi) - e) * r * omega * np.cos(psi) / root, 0.0])
    along = (pin - big) / l
    across = np.array([-along[1], along[0]])               # 90° ahead in the direction of rotation
    rel = pin_dot - big_dot
    rod_rate = (along[0] * rel[1] - along[1] * rel[0]) / l
    cg = big + cyl.rod.cg_from_big_end * along + cyl.rod.cg_lateral * across
    cg_dot = big_dot + rod_rate * np.array([-(cg - big)[1], (cg - big)[0]])
    piston_cg = pin + np.array([cyl.piston.cg_axial, cyl.piston.cg_lateral])

    def point(v):
        return np.array([cyl.x, 0.0, 0.0]) + v[0] * axis_c + v[1] * axis_n

    return {"big_end": point(big), "pin": point(pin), "rod_cg": point(cg),
            "rod_velocity": cg_dot[0] * axis_c + cg_dot[1] * axis_n,
            "rod_rate": np.array([sense * rod_rate, 0.0, 0.0]),
            "piston_cg": point(piston_cg), "piston_velocity": pin_dot[0] * axis_c,
            "axes": np.column_stack([axis_c, axis_n, np.cross(axis_c, axis_n)])}


def solver_settings(steps: int, end_time: float):
    import exudyn as exu

    settings = exu.SimulationSettings()
    ti = settings.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = end_time
    ti.automaticStepSize = False
    ti.verboseMode = 0
    ti.generalizedAlpha.spectralRadius = SPECTRAL_RADIUS
    settings.linearSolver.solverType = (exu.LinearSolverType.EXUdense if LINEAR_SOLVER == "dense"
                                        else exu.LinearSolverType.EigenSparse)
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = 0.0   # every step
    settings.show.globalTimers = False
    return settings


def supported(scene) -> None:
    model = scene.model
    problems = []
    if model.rod != "rigid" or model.piston != "exact":
        problems.append(f"model rod={model.rod!r}, piston={model.piston!r} (needs 'rigid', 'exact')")
    if not RIGID_EFFECTS <= set(model.effects):
        problems.append(f"effects {sorted(model.effects)} (needs all of {sorted(RIGID_EFFECTS)})")
    if scene.shafts or scene.levers:
        problems.append("balance shafts / lever balancers are not modelled")
    if problems:
        raise ValueError(f"{scene.name}: the Exudyn model covers " + "; ".join(problems))


@dataclass
class ExudynModel:
    mbs: object
    system: object          # keeps the SystemContainer alive
    settings: object
    clamps: list            # (sensor, lever arm from the reference point)
    steps: int
    warmup: int


def build_model(scene, omega: float, steps: int, *, warmup: int = WARMUP_STEPS,
                drive_on_block: bool = False) -> ExudynModel:
    """The crank train of ``scene`` at constant ω, ``steps`` steps per revolution,
    starting ``warmup`` steps before θ = 0."""
    import exudyn as exu
    import exudyn.itemInterface as items
    from exudyn.rigidBodyUtilities import RigidBodyInertia

    supported(scene)
    sense = scene.sense
    ref = np.asarray(scene.reference_point, dtype=float)
    step = 2 * np.pi / omega / steps
    theta0 = -warmup * step * omega
    rxyz = exu.NodeType.RotationRxyz
    ex = np.array([1.0, 0.0, 0.0])

    system = exu.SystemContainer()
    mbs = system.AddSystem()
    ground = mbs.AddObject(items.ObjectGround())

    # The block, clamped at ref by 3 + 2 + 1 point constraints (statically determinate).
    block = mbs.CreateRigidBody(inertia=RigidBodyInertia(1.0, np.eye(3)), referencePosition=list(ref),
                                nodeType=rxyz, returnDict=True)
    clamps = []
    for arm, axes in (((0, 0, 0), (1, 1, 1)), ((1, 0, 0), (0, 1, 1)), ((0, 1, 0), (0, 0, 1))):
        arm = np.array(arm, dtype=float)
        on_ground = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=ground, localPosition=list(ref + arm)))
        on_block = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=block["bodyNumber"], localPosition=list(arm)))
        joint = mbs.AddObject(items.ObjectJointGeneric(markerNumbers=[on_ground, on_block],
                                                       constrainedAxes=[*axes, 0, 0, 0]))
        clamps.append((joint, arm))

    def block_marker(position, rotation=None):
        return mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=block["bodyNumber"], localHT=exu.HT(
            rotation=np.eye(3) if rotation is None else rotation, translation=list(np.asarray(position) - ref))))

    # Crankshaft: a rigid body on the x axis; unbalances as point masses of 1 kg.
    inertia = RigidBodyInertia(1.0, 0.1 * np.eye(3))
    points = [(u.x, cyl.throw + u.angle, u.unbalance) for cyl in scene.cylinders for u in cyl.throw_unbalances]
    points += [(u.x, u.angle, u.unbalance) for u in scene.crankshaft_unbalances]
    for x, angle, unbalance in points:
        inertia = inertia + RigidBodyInertia(1.0, np.zeros((3, 3)), inertiaTensorAtCOM=True,
                                             com=x * ex + unbalance * direction(angle, sense))
    c0, s0 = np.cos(sense * theta0), np.sin(sense * theta0)
    crank = mbs.CreateRigidBody(inertia=inertia, nodeType=rxyz, returnDict=True,
                                initialRotationMatrix=np.array([[1, 0, 0], [0, c0, -s0], [0, s0, c0]]),
                                initialAngularVelocity=[sense * omega, 0, 0])
    crank_body = crank["bodyNumber"]
    on_crank = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=crank_body, localPosition=[0, 0, 0]))
    mbs.AddObject(items.ObjectJointGeneric(markerNumbers=[block_marker([0, 0, 0]), on_crank],
                                           constrainedAxes=[1, 1, 1, 0, 1, 1]))   # main bearing
    # Drive: d(crank angle about +x)/dt = sense·ω, reacting on ground (or on the block).
    if drive_on_block:
        fixed = mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=block["nodeNumber"], coordinate=3))
    else:
        fixed = mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(items.NodePointGround()),
                                                         coordinate=0))
    turning = mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=crank["nodeNumber"], coordinate=3))
    mbs.AddObject(items.ObjectConnectorCoordinate(markerNumbers=[fixed, turning], offset=sense * omega,
                                                  velocityLevel=True))

    for cyl in scene.cylinders:
        at0 = slider_crank(cyl, 0.0, omega, sense)       # crank-fixed marker positions (θ = 0)
        now = slider_crank(cyl, theta0, omega, sense)     # initial state
        j = cyl.rod.inertia
        rod = mbs.CreateRigidBody(inertia=RigidBodyInertia(cyl.rod.mass, j * np.eye(3)), nodeType=rxyz,
                                  referencePosition=list(now["rod_cg"]), initialVelocity=list(now["rod_velocity"]),
                                  initialAngularVelocity=list(now["rod_rate"]))
        piston = mbs.CreateRigidBody(inertia=RigidBodyInertia(cyl.piston.mass, 1e-3 * np.eye(3)), nodeType=rxyz,
                                     referencePosition=list(now["piston_cg"]),
                                     initialVelocity=list(now["piston_velocity"]))
        crank_pin = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=crank_body, localPosition=list(at0["big_end"])))
        big_end = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=rod, localPosition=list(now["big_end"] - now["rod_cg"])))
        mbs.AddObject(items.ObjectJointGeneric(markerNumbers=[crank_pin, big_end], constrainedAxes=[1, 1, 1, 0, 1, 1]))
        small_end = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=rod, localPosition=list(now["pin"] - now["rod_cg"])))
        piston_pin = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=piston, localPosition=list(now["pin"] - now["piston_cg"])))
        mbs.AddObject(items.ObjectJointGeneric(markerNumbers=[small_end, piston_pin], constrainedAxes=[0, 1, 1, 0, 0, 0]))
        axes = now["axes"]                                # joint x along the cylinder axis: free
        on_piston = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=piston, localHT=exu.HT(rotation=axes, translation=[0, 0, 0])))
        mbs.AddObject(items.ObjectJointGeneric(markerNumbers=[block_marker(now["piston_cg"], axes), on_piston],
                                               constrainedAxes=[0, 1, 1, 1, 1, 1]))

    sensors = [(mbs.AddSensor(items.SensorObject(objectNumber=joint, outputVariableType=exu.OutputVariableType.ForceLocal,
                                                 storeInternal=True, writeToFile=False)), arm) for joint, arm in clamps]
    mbs.Assemble()
    settings = solver_settings(warmup + steps, (warmup + steps) * step)
    return ExudynModel(mbs, system, settings, sensors, steps, warmup)


def reaction_sign() -> float:
    """+1 if a GenericJoint's ForceLocal, in SolveDynamic, is the force that
    marker 1's body puts on marker 0 (here: the block on the ground), -1 if the
    opposite. Found with a clamped body under gravity, the same solver."""
    import exudyn as exu
    import exudyn.itemInterface as items
    from exudyn.rigidBodyUtilities import RigidBodyInertia

    system = exu.SystemContainer()
    mbs = system.AddSystem()
    gravity = np.array([1.0, -2.0, -9.0])
    body = mbs.CreateRigidBody(inertia=RigidBodyInertia(2.0, np.eye(3)), gravity=list(gravity),
                               nodeType=exu.NodeType.RotationRxyz)
    ground = mbs.AddObject(items.ObjectGround())
    joint = mbs.AddObject(items.ObjectJointGeneric(markerNumbers=[
        mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=ground, localPosition=[0, 0, 0])),
        mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=body, localPosition=[0, 0, 0]))]))
    sensor = mbs.AddSensor(items.SensorObject(objectNumber=joint, outputVariableType=exu.OutputVariableType.ForceLocal,
                                              storeInternal=True, writeToFile=False))
    mbs.Assemble()
    mbs.SolveDynamic(solver_settings(4, 0.01))
    force = mbs.GetSensorStoredData(sensor)[-1, 1:4]
    sign = float(np.sign(force @ (2.0 * gravity)))
    if not np.allclose(sign * force, 2.0 * gravity, rtol=1e-9):
        raise RuntimeError(f"reaction sign calibration failed: ForceLocal {force}, load {2.0 * gravity}")
    return sign


def exudyn_loads(model: ExudynModel, sign: float) -> tuple[np.ndarray, np.ndarray]:
    """Solve; the moving parts' load on the block (angle, axis) at θ_k = 2πk/N,
    force and moment about the reference point."""
    model.mbs.SolveDynamic(model.settings)
    force = moment = 0.0
    for sensor, arm in model.clamps:
        data = model.mbs.GetSensorStoredData(sensor)
        f = sign * data[:, 1:4]
        force = force + f
        moment = moment + np.cross(arm, f)
    if len(data) != model.warmup + model.steps + 1:
        raise RuntimeError(f"expected {model.warmup + model.steps + 1} sensor records, got {len(data)}")
    keep = slice(model.warmup, model.warmup + model.steps)
    return force[keep], moment[keep]


def phasors(samples: np.ndarray) -> np.ndarray:
    """One-sided peak phasors C_0 … of samples over one revolution (angle, axis)."""
    spectrum = np.fft.rfft(samples, axis=0) / len(samples)
    spectrum[1:] *= 2
    return spectrum


# -- the checks and the benchmark -------------------------------------------------

def check_single(sign: float, quick: bool) -> None:
    """A single cylinder against hb.simulate's time traces, drive from ground
    (all effects) and reacting on the block (without mass_torque)."""
    import harmbal as hb

    print("Single-cylinder check against hb.simulate (time traces at harmbal's angles):")
    no_drive = {**SINGLE, "model": {"effects": sorted(RIGID_EFFECTS)}}
    for label, mapping, on_block in (("drive from ground vs all effects", SINGLE, False),
                                     ("drive on the block vs without mass_torque", no_drive, True)):
        scene = hb.load_scene(mapping)
        traces = hb.simulate(scene)
        force_h = _first_speed(traces["force"]).transpose("angle", "axis").values
        moment_h = _first_speed(traces["moment"]).transpose("angle", "axis").values
        n = len(force_h)
        steps = n * (8 if quick else 64)
        force, moment = exudyn_loads(build_model(scene, float(scene.speeds[0]), steps, drive_on_block=on_block), sign)
        idx = np.arange(n) * (steps // n)
        e_f = np.abs(force[idx] - force_h).max() / np.abs(force_h).max()
        e_m = np.abs(moment[idx] - moment_h).max() / np.abs(moment_h).max()
        print(f"  {label}: {steps} steps/rev, max deviation / peak: force {e_f:.1e}, moment {e_m:.1e}")
        if max(e_f, e_m) > (1e-3 if quick else 1e-5):
            raise SystemExit("single-cylinder check failed: the Exudyn model does not reproduce harmbal's traces")


def errors(force, moment, ref) -> dict:
    """Errors of orders 1-2 (order, axis) against harmbal's."""
    d_force = np.abs(force - ref["force"]).max()
    f_max = np.abs(ref["force"]).max()
    of_scale = f_max < FORCE_FLOOR * ref["force_scale"]
    return {"force": d_force / (ref["force_scale"] if of_scale else f_max), "force_abs": d_force,
            "force_of_scale": of_scale,
            "moment": np.abs(moment - ref["moment"]).max() / np.abs(ref["moment"]).max(),
            "moment_abs": np.abs(moment - ref["moment"]).max()}


def converge(scene, ref, sign, start: int, target: float, max_steps: int) -> dict:
    omega = float(scene.speeds[0])
    steps, previous = start, None
    while True:
        force, moment = exudyn_loads(build_model(scene, omega, steps), sign)
        c_force, c_moment = phasors(force)[1:3], phasors(moment)[1:3]
        err = errors(c_force, c_moment, ref)
        print(f"  N = {steps:6d} steps/rev: force {err['force']:.2e}"
              f"{' of scale' if err['force_of_scale'] else ''} ({err['force_abs']:.1e} N), moment {err['moment']:.2e}")
        if max(err["force"], err["moment"]) <= target:
            passed = {"steps": steps, "method": "plain", **err, "c_force": c_force, "c_moment": c_moment}
            return passed if previous is None else _coarsest(scene, ref, sign, omega, steps // 2, passed, target)
        if steps * 2 > max_steps:
            if previous is None:
                return {"steps": steps, "method": "plain (target missed)", **err, "c_force": c_force, "c_moment": c_moment}
            c_force = (4 * c_force - previous[0]) / 3
            c_moment = (4 * c_moment - previous[1]) / 3
            err = errors(c_force, c_moment, ref)
            print(f"  Richardson (N/2, N): force {err['force']:.2e}, moment {err['moment']:.2e}")
            return {"steps": steps, "method": "Richardson", **err, "c_force": c_force, "c_moment": c_moment}
        previous = (c_force, c_moment)
        steps *= 2


def _coarsest(scene, ref, sign, omega: float, failing: int, passed: dict, target: float) -> dict:
    """Bisect the steps per revolution between ``failing`` and ``passed``'s."""
    while passed["steps"] - failing > max(8, passed["steps"] // 32):
        steps = 8 * round((failing + passed["steps"]) / 16)
        if steps in (failing, passed["steps"]):
            break
        force, moment = exudyn_loads(build_model(scene, omega, steps), sign)
        c_force, c_moment = phasors(force)[1:3], phasors(moment)[1:3]
        err = errors(c_force, c_moment, ref)
        print(f"  N = {steps:6d} steps/rev: force {err['force']:.2e}"
              f"{' of scale' if err['force_of_scale'] else ''} ({err['force_abs']:.1e} N), moment {err['moment']:.2e}"
              " (bisecting)")
        if max(err["force"], err["moment"]) <= target:
            passed = {"steps": steps, "method": "plain", **err, "c_force": c_force, "c_moment": c_moment}
        else:
            failing = steps
    return passed


def time_exudyn(scene, steps: int, sign: float, runs: int) -> tuple[float, float]:
    omega = float(scene.speeds[0])
    solve, total = [], []
    for _ in range(runs):
        start = time.perf_counter()
        model = build_model(scene, omega, steps)
        built = time.perf_counter()
        force, moment = exudyn_loads(model, sign)
        phasors(force), phasors(moment)
        end = time.perf_counter()
        solve.append(end - built)
        total.append(end - start)
    return statistics.median(solve), statistics.median(total)


def ms(seconds) -> str:
    if seconds is None:
        return "n/a"
    return f"{seconds * 1e3:.3g} ms" if seconds < 1 else f"{seconds:.3g} s"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: target 1e-4, one Exudyn run")
    parser.add_argument("--repeat", type=int, default=None, help="calls per harmbal timing (default 200, quick 20)")
    parser.add_argument("--runs", type=int, default=None, help="Exudyn runs at the final step (default 5, quick 1)")
    parser.add_argument("--target", type=float, default=None, help="error target on orders 1-2 (default 1e-6, quick 1e-4)")
    parser.add_argument("--start", type=int, default=None, help="first steps per revolution (default 120, quick 60)")
    parser.add_argument("--max-steps", type=int, default=2 ** 17, help="largest steps per revolution before Richardson")
    parser.add_argument("--checked", action="store_true", help="Exudyn's default module instead of exudynCPPfast")
    parser.add_argument("--linear-solver", choices=("sparse", "dense"), default="sparse",
                        help="Exudyn's linear solver: EigenSparse (default) or EXUdense")
    args = parser.parse_args()
    global LINEAR_SOLVER
    LINEAR_SOLVER = args.linear_solver
    repeat = args.repeat or (20 if args.quick else 200)
    runs = args.runs or (1 if args.quick else 5)
    target = args.target or (1e-4 if args.quick else 1e-6)
    start = args.start or (60 if args.quick else 120)

    if not args.checked:
        sys.exudynFast = True   # exudyn loads exudynCPPfast if the CPU has AVX2
    try:
        import exudyn
    except ImportError:
        print("exudyn not installed: pip install exudyn")
        return 0

    import harmbal as hb

    sign = reaction_sign()
    check_single(sign, args.quick)

    rows, details = [], []
    for label, name in SCENES.items():
        scene = hb.load_scene(ENGINES / name)
        scene = scene.with_speeds([scene.speeds[0]])
        omega = float(scene.speeds[0])
        ref = harmbal_orders(scene)
        print(f"{label} at {omega * 30 / np.pi:.0f} rpm: Exudyn, halving the step until the error on orders 1-2 <= {target:g}, then bisecting")
        result = converge(scene, ref, sign, start, target, args.max_steps)
        solve, total = time_exudyn(scene, result["steps"], sign, runs)
        t_analyse = median_seconds(lambda scene=scene: hb.analyse(scene), repeat)

        t_arrays = arrays_error = None
        arrays_name = "n/a"
        try:
            found = array_path(scene)
            if found is not None:
                arrays, arrays_name = found
                force_a, moment_a = arrays()
                arrays_error = max(np.abs(force_a - ref["force"]).max() / ref["force_scale"],
                                   np.abs(moment_a - ref["moment"]).max() / np.abs(ref["moment"]).max())
                t_arrays = median_seconds(arrays, 10 * repeat)
        except Exception as error:  # noqa: BLE001 - internal API: report n/a, never fail the benchmark
            print(f"  array path unavailable: {type(error).__name__}: {error}")
            t_arrays = None

        step = 2 * np.pi / omega / result["steps"]
        rows.append((label, result, step, solve, total, t_analyse, t_arrays))
        details.append((label, result, ref))
        print(f"  array path: {arrays_name}" + (f", agrees with analyse to {arrays_error:.1e}" if arrays_error is not None else ""))

    compiled = next((m.split(".")[-1] for m in ("exudyn.exudynCPPfast", "exudyn.exudynCPP") if m in sys.modules), "?")
    print()
    print(f"machine: {platform.platform()}, {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"{platform.python_implementation()} {platform.python_version()}, numpy {np.__version__}, "
          f"exudyn {exudyn.__version__} ({compiled}), "
          f"harmbal {hb.__version__}; generalized-alpha ρ∞ = {SPECTRAL_RADIUS}, {WARMUP_STEPS} warm-up steps, "
          f"{LINEAR_SOLVER} linear solver, "
          f"Exudyn median of {runs} run(s), harmbal median of {repeat} (arrays {10 * repeat}) calls")
    print()
    print("| engine | Exudyn steps/rev (Δt) | Exudyn error, orders 1–2: force / moment | Exudyn solve | "
          "Exudyn build + solve | `analyse` | array path | Exudyn solve / `analyse` | Exudyn solve / array path |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, result, step, solve, total, t_analyse, t_arrays in rows:
        note = "" if result["method"] == "plain" else f" ({result['method']})"
        force_note = " of scale" if result["force_of_scale"] else ""
        ratio_arrays = f"{solve / t_arrays:,.0f}" if t_arrays else "n/a"
        print(f"| {label} | {result['steps']} ({step * 1e6:.3g} µs){note} | {result['force']:.1e}{force_note} / "
              f"{result['moment']:.1e} | {ms(solve)} | {ms(total)} | {ms(t_analyse)} | {ms(t_arrays)} | "
              f"{solve / t_analyse:,.0f} | {ratio_arrays} |")
    print()
    print("| engine | order | max abs. error: force [N] | harmbal max force [N] | max abs. error: moment [N m] | harmbal max moment [N m] | moment error / max |")
    print("|---|---|---|---|---|---|---|")
    for label, result, ref in details:
        for k in (0, 1):
            d_f = np.abs(result["c_force"][k] - ref["force"][k]).max()
            d_m = np.abs(result["c_moment"][k] - ref["moment"][k]).max()
            m_max = np.abs(ref["moment"][k]).max()
            print(f"| {label} | {k + 1} | {d_f:.2e} | {np.abs(ref['force'][k]).max():.2e} | {d_m:.2e} | "
                  f"{m_max:.4g} | {d_m / np.abs(ref['moment']).max():.1e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
