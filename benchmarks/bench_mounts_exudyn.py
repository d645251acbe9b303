"""harmbal's powertrain on its mounts against the multibody code Exudyn, in the time domain.

Run from the repository root with harmbal and the optional Exudyn installed
(``pip install exudyn``; harmbal itself never imports it):

    python benchmarks/bench_mounts_exudyn.py [--quick] [--repeat 50] [--runs 3] [--no-crank-train]

Without Exudyn the script prints ``exudyn not installed: pip install exudyn``
and exits with code 0. ``tests/test_mounts_exudyn.py`` runs the same models
at coarse steps.

**1. Rigid block on spring-dampers** (the oracle of issue 30). The scene is
``tractor-3cyl-mounts.toml`` (gas, half orders) at one speed, its mounts made
viscous: ``loss_factor = 0`` and ``damping = [...]`` (a loss factor has no
time-domain equivalent), written as TOML text and read by
``hb.scene_from_text``. Exudyn models one rigid body with the powertrain's
mass, CG and full inertia tensor (products included) on one
``ObjectConnectorLinearSpringDamper`` per mount axis (marker 0 on the ground,
so each acts along its fixed local axis u, v or w), driven by harmbal's
*time-domain* shaking force (applied at the scene's reference point) and moment
(``hb.simulate``): the trigonometric interpolant of those samples, orders
1/2 … ``max_order`` (order 0 left out, and no gravity: the static mean roll
and sag are the statics' business, and a linearisation about a rolled state
would differ from harmbal's about the undeflected one by the static angle).
The spinning parts (``[powertrain] spinning_inertia``, harmbal's gyroscopic
term) are a rotor in the block (:func:`rotor_split`: a disc of polar inertia J
on the crank axis; block + rotor = the powertrain's mass, CG and inertia
exactly) held by a joint that locks all six relative motions but a rotation
sense·ω·t about x (:func:`add_spin_joint`): it turns at exactly ω relative to
the block, and the joint's reaction (the gyroscopic moment, and J times the
block's roll acceleration) goes into the block. The bodies start in harmbal's
harmonic state at θ = 0 (position and velocity of ``response``; the rotor's
spin added), run ``WARMUP_CYCLES`` cycles, and the next cycle's mount
forces (into the frame: ForceLocal × axis) are FFT'd into orders and compared
with ``transmitted_force``:

    error = max |C_exudyn − C_harmbal| / max |C_harmbal|   over orders, mounts, axes.

A wrong harmonic state would start a transient that the warm-up does not
remove (damping ratios ~0.05–0.1), so the start cannot hide a disagreement;
the periodicity residual (last two cycles) is printed. The step count per
cycle N is doubled until the error is at most the target; Richardson's
(4 C_N − C_{N/2}) / 3 shows what is left besides the integrator.

Exudyn's rigid body is geometrically exact; harmbal's model is linear. The
linear runs use the loads scaled by ±``SMALL`` (1e-4) and the mean of C(s)/s
and C(−s)/(−s): the nonlinearity's leading, quadratic part cancels (the cubic
left is ~1e-13); smaller loads would drown in Newton's absolute tolerance
against the rotor's large coordinates. (C(1) − C_linear) / max |C_harmbal| is
the part of the full-load mount forces that is not linear in the loads.

**2. The crank train on the mounts** (``--no-crank-train`` skips it). The
crank train of ``benchmarks/bench_exudyn.py`` (rigid rods, pistons on
prismatic joints) stands in a block that sits on the same mounts instead of
being clamped, without gas (that model has none), its crank turning at
constant ω relative to the block (:func:`add_spin_joint`; ``--ground-drive``:
relative to the ground instead) and carrying the spinning inertia J, for J in
``INERTIAS`` (harmbal's scene gets the same ``spinning_inertia``). The split:
the moving parts are the pistons, rods and the crank (1 kg, J isotropic, on
the crank axis); the block gets
the powertrain's mass minus theirs, its CG such that the mean CG of everything
is the powertrain's, and its inertia the powertrain's minus the moving parts'
cycle-averaged inertia about that CG (parallel axis theorem). The mount forces
are compared with harmbal's ``transmitted_force`` for the same scene without
gas: the difference is what harmbal's model leaves out (the block's motion
feeding back into the crank train, the moving parts' varying inertia,
geometric nonlinearity), as a fraction of the largest transmitted force; the
same without harmbal's gyroscopic term shows that term's weight.

**3. Timing.** ``hb.mounts(scene)`` (the whole ``/mounts`` Dataset, from the
scene) best of ``--repeat`` calls, against Exudyn's solve of the rigid block
at the step count that reached the target (build excluded; solve, sensors and
FFT), best of ``--runs``; the ratio is printed from the same run.

Numerics: generalized-alpha (spectral radius 0.9, Exudyn's default Newton
settings), fixed steps, dense solver (block and rotor). Exudyn's optimised module
is used where the CPU supports it.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
SCENE = "tractor-3cyl-mounts.toml"
RPM = 800                     # idle: the largest roll (gas torque) of the speed range
#: Each loss factor η is replaced by the viscous c = η k / Ω that dissipates as much at Ω = 2π × MATCH_HZ.
MATCH_HZ = 10.0
SPECTRAL_RADIUS = 0.9
WARMUP_CYCLES = 1           # after the harmonic start: the transient left is O(h²), Richardson removes it too
#: Load scale ±s of the linear runs (their mean: the quadratic part cancels, the cubic left ∝ s², ~1e-13).
#: Not smaller: Newton's absolute tolerance (1e-10, the floor with the rotor's large spin coordinates)
#: would show as ~1e-5 noise at 1e-6.
SMALL = 1e-4
#: The spinning parts' stand-in in the rigid block: a disc of this radius [m] (mass 2 J / r²).
ROTOR_RADIUS = 0.2
#: The crank of bench_exudyn.py: mass [kg] on the crank axis at x = 0 (its isotropic inertia: the
#: scene's spinning inertia).
CRANK_MASS = 1.0


# -- the scene --------------------------------------------------------------------

def viscous_scene_text(name: str = SCENE, rpm: float = RPM, *, gas: bool = True,
                       spinning: float | None = None) -> str:
    """The TOML text of bundled scene ``name`` at one speed, each mount's loss
    factor η replaced by the viscous damping c = η k / (2π ``MATCH_HZ``) that
    dissipates as much at that frequency, its stiffness table (if any) left
    out (its nominal stiffness stays); without ``[gas]`` if ``gas`` is false;
    ``[powertrain] spinning_inertia`` set to ``spinning`` [kg m²] if given."""
    from harmbal.scene import load_scene

    nominal = load_scene(ENGINES / name).mounts
    text = (ENGINES / name).read_text()
    text = re.sub(r"^\[mount\.table\][^\n]*\n(?:(?!\[)[^\n]*\n)*", "", text, flags=re.M)
    text, n = re.subn(r"^speed = .*$", f'speed = "{rpm} rpm"', text, count=1, flags=re.M)
    dampings = iter([np.asarray(m.loss_factor) * np.asarray(m.stiffness) / (2 * np.pi * MATCH_HZ) for m in nominal])

    def viscous(match) -> str:
        values = ", ".join(f'"{c:.6g} N s/m"' for c in next(dampings))
        return f"loss_factor = 0\ndamping = [{values}]"

    text, m = re.subn(r"^loss_factor = .*$", viscous, text, flags=re.M)
    if n != 1 or m != len(nominal):
        raise ValueError(f"{name}: expected one speed line and one loss_factor line per mount")
    if not gas:
        text = re.sub(r"^\[gas(\.[a-z]+)?\]\n(?:(?!\[)[^\n]*\n)*", "", text, flags=re.M)
    if spinning is not None:
        text, n = re.subn(r"^spinning_inertia = .*$", f'spinning_inertia = "{spinning!r} kg m^2"', text,
                          count=1, flags=re.M)
        if n != 1:
            raise ValueError(f"{name}: expected a spinning_inertia line")
    return text


def viscous_scene(name: str = SCENE, rpm: float = RPM, *, gas: bool = True, spinning: float | None = None):
    from harmbal.scene import scene_from_text

    return scene_from_text(viscous_scene_text(name, rpm, gas=gas, spinning=spinning), source=str(ENGINES / name))


def spinning_inertia(scene) -> float:
    """The polar inertia [kg m²] that spins with the crank: ``[powertrain]
    spinning_inertia``, else the [flywheel] table's, else 0 (as documented)."""
    if scene.powertrain.spinning_inertia is not None:
        return float(scene.powertrain.spinning_inertia)
    return float(scene.flywheel.inertia) if scene.flywheel is not None else 0.0


# -- harmbal side (public API) ---------------------------------------------------

@dataclass
class Reference:
    """harmbal's answer at one speed: ``orders`` (k,), ``force`` (k, mount, 3)
    transmitted into the frame and ``response`` (k, 6) complex phasors; the
    time-domain loads' phasors ``load_force``, ``load_moment`` (k, 3) about
    ``reference`` (from the samples of ``hb.simulate``), ``omega`` [rad/s]."""

    orders: np.ndarray
    force: np.ndarray
    response: np.ndarray
    load_force: np.ndarray
    load_moment: np.ndarray
    reference: np.ndarray
    omega: float


def harmbal_reference(scene) -> Reference:
    """Run ``hb.mounts`` and ``hb.simulate`` on a one-speed scene."""
    import harmbal as hb

    ds = hb.mounts(scene)
    orders = np.asarray(ds["order"].values, dtype=float)
    force = ds["transmitted_force"].transpose("order", "mount", "component").values
    response = ds["response"].transpose("order", "dof").values
    traces = hb.simulate(scene)
    revolutions = int(traces.attrs.get("revolutions", 1))
    phasor = {}
    for name in ("force", "moment"):
        samples = traces[name].transpose("angle", "axis").values
        spectrum = np.fft.rfft(samples, axis=0) / len(samples)
        index = np.rint(orders * revolutions).astype(int)
        phasor[name] = 2 * spectrum[index]
    return Reference(orders, force, response, phasor["force"], phasor["moment"],
                     np.asarray(scene.reference_point, dtype=float), float(scene.speeds[0]))


def harmonic_state(ref: Reference, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The CG's displacement and rotation q (6,) and their rates at θ = 0."""
    return (scale * ref.response.sum(axis=0).real,
            scale * (1j * ref.orders[:, None] * ref.omega * ref.response).sum(axis=0).real)


# -- Exudyn side -----------------------------------------------------------------

def solver_settings(steps: int, end_time: float):
    import exudyn as exu

    settings = exu.SimulationSettings()
    ti = settings.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = end_time
    ti.automaticStepSize = False
    ti.verboseMode = 0
    ti.generalizedAlpha.spectralRadius = SPECTRAL_RADIUS
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = 0.0   # every step
    settings.show.globalTimers = False
    return settings


def rotation_matrix(rotation_vector) -> np.ndarray:
    """Rodrigues: the rotation by |v| about v."""
    v = np.asarray(rotation_vector, dtype=float)
    angle = np.linalg.norm(v)
    if angle == 0.0:
        return np.eye(3)
    k = v / angle
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross


@dataclass
class Run:
    """An Exudyn model ready to solve: ``sensors`` (mount, axis) of the
    spring-dampers' ForceLocal, their ``directions`` (mount, axis, 3)."""

    mbs: object
    system: object
    settings: object
    sensors: list
    directions: np.ndarray
    steps: int
    warmup: int


def add_mounts(mbs, body: int, cg: np.ndarray, mounts) -> tuple[list, np.ndarray]:
    """One linear spring-damper per mount axis between the ground and ``body``
    (its reference point at ``cg``); returns the force sensors and axes."""
    import exudyn as exu
    import exudyn.itemInterface as items

    ground = mbs.AddObject(items.ObjectGround())
    sensors, directions = [], []
    for mount in mounts:
        p = np.asarray(mount.position, dtype=float)
        on_ground = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=ground, localPosition=list(p)))
        on_body = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=body, localPosition=list(p - cg)))
        row = []
        for axis, k, c in zip(mount.axes, mount.stiffness, mount.damping):
            spring = mbs.AddObject(items.ObjectConnectorLinearSpringDamper(
                markerNumbers=[on_ground, on_body], stiffness=k, damping=c, axisMarker0=list(axis)))
            row.append(mbs.AddSensor(items.SensorObject(objectNumber=spring, storeInternal=True, writeToFile=False,
                                                        outputVariableType=exu.OutputVariableType.ForceLocal)))
        sensors.append(row)
        directions.append(np.asarray(mount.axes, dtype=float))
    return sensors, np.array(directions)


def fourier_series(orders: np.ndarray, phasors: np.ndarray, omega: float, scale: float):
    """s(t) = scale Σ Re(C_k e^{ikωt}) (..., 3) as a function of t."""
    rates = orders * omega
    c = scale * phasors

    def series(t: float) -> np.ndarray:
        return (c * np.exp(1j * rates * t)[:, None]).sum(axis=0).real

    return series


def drive(mbs, loads: dict) -> None:
    """Set each load's vector (``loads``: load number -> series of t) at the
    end of every step, where generalized-alpha evaluates it (one Python call
    per step: a load user function costs ~4 calls per step)."""
    for load, series in loads.items():
        mbs.SetLoadParameter(load, "loadVector", list(series(0.0)))

    def pre_step(mbs, t):
        for load, series in loads.items():
            mbs.SetLoadParameter(load, "loadVector", list(series(t)))
        return True

    mbs.SetPreStepUserFunction(pre_step)


def rotor_split(scene) -> Split:
    """The powertrain as a block and a rotor standing for its spinning parts: a
    disc (polar inertia J = :func:`spinning_inertia`, transverse J/2, mass
    2 J / ``ROTOR_RADIUS``²) on the crank axis (y = z = 0) at the CG's x; the
    block gets the rest of the mass and inertia, so that the two together have
    the powertrain's mass, CG and inertia tensor exactly."""
    pt = scene.powertrain
    cg = np.asarray(pt.cg, dtype=float)
    polar = spinning_inertia(scene)
    mass = 2 * polar / ROTOR_RADIUS**2
    at = np.array([cg[0], 0.0, 0.0])
    block_mass = pt.mass - mass
    block_cg = (pt.mass * cg - mass * at) / block_mass
    rotor = np.diag([polar, polar / 2, polar / 2]) + steiner(mass, at - cg)
    block_inertia = np.asarray(pt.inertia, dtype=float) - rotor - steiner(block_mass, block_cg - cg)
    return Split(block_mass, block_cg, block_inertia, mass, at)


def add_spin_joint(mbs, on_block: int, on_rotor: int, rate: float) -> None:
    """Lock the rotor's marker to the block's but for a rotation rate × t about
    the markers' x axis: the rotor turns at exactly ``rate`` relative to the
    block (a Lagrange multiplier, so its reaction, gyroscopic moment and all,
    goes into the block). Exudyn composes the offset rotation exactly: the
    relative angle stays rate × t to round-off over many revolutions."""
    import exudyn.itemInterface as items

    def offset(mbs, t, item, parameters):
        return [0.0, 0.0, 0.0, rate * t, 0.0, 0.0]

    mbs.AddObject(items.ObjectJointGeneric(markerNumbers=[on_block, on_rotor], constrainedAxes=[1] * 6,
                                           offsetUserFunction=offset))


def build_block(scene, ref: Reference, steps: int, *, warmup: int = WARMUP_CYCLES, scale: float = 1.0) -> Run:
    """The rigid powertrain on its mounts under harmbal's loads (× ``scale``),
    its spinning parts a rotor turning at sense·ω relative to it
    (:func:`rotor_split`; the spin is not scaled: the gyroscopic moment is
    linear in the motion), from harmbal's harmonic state, ``steps`` steps per
    cycle, ``warmup`` cycles before the measured one."""
    import exudyn as exu
    import exudyn.itemInterface as items

    split = rotor_split(scene)
    period = 2 * np.pi * cycle_revolutions(ref) / ref.omega
    system = exu.SystemContainer()
    mbs = system.AddSystem()
    start = HarmonicStart(np.asarray(scene.powertrain.cg, dtype=float), *harmonic_state(ref, scale))
    body = start.body(mbs, split.block_mass, split.block_inertia, split.block_cg)
    sensors, directions = add_mounts(mbs, body, split.block_cg, scene.mounts)
    if split.moving_mass > 0:
        polar = split.moving_mass * ROTOR_RADIUS**2 / 2
        rotor = start.body(mbs, split.moving_mass, np.diag([polar, polar / 2, polar / 2]), split.moving_cg,
                           spin=scene.sense * ref.omega)
        add_spin_joint(mbs, mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=body, localPosition=list(
            split.moving_cg - split.block_cg))), mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=rotor,
                                                                                      localPosition=[0, 0, 0])),
            scene.sense * ref.omega)
    at_reference = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=body,
                                                       localPosition=list(ref.reference - split.block_cg)))
    drive(mbs, {mbs.AddLoad(items.LoadForceVector(markerNumber=at_reference)):
                fourier_series(ref.orders, ref.load_force, ref.omega, scale),
                mbs.AddLoad(items.LoadTorqueVector(markerNumber=at_reference)):
                fourier_series(ref.orders, ref.load_moment, ref.omega, scale)})
    mbs.Assemble()
    total = (warmup + 1) * steps
    settings = solver_settings(total, (warmup + 1) * period)
    settings.linearSolver.solverType = exu.LinearSolverType.EXUdense
    return Run(mbs, system, settings, sensors, directions, steps, warmup)


@dataclass
class HarmonicStart:
    """harmbal's harmonic state at θ = 0: the powertrain's rigid motion (the
    CG's displacement and small rotation q (6,), their rates) about ``cg``."""

    cg: np.ndarray
    q: np.ndarray
    rate: np.ndarray

    def body(self, mbs, mass: float, inertia: np.ndarray, at: np.ndarray, *, spin: float = 0.0) -> int:
        """A rigid body (reference point and CG ``at``) moving with the
        powertrain, plus ``spin`` [rad/s] about the powertrain's x axis."""
        import exudyn as exu
        from exudyn.rigidBodyUtilities import RigidBodyInertia

        rotation = rotation_matrix(self.q[3:])
        arm = rotation @ (at - self.cg)
        angular = self.rate[3:] + spin * rotation[:, 0]
        return mbs.CreateRigidBody(inertia=RigidBodyInertia(mass, inertia), referencePosition=list(at),
                                   initialDisplacement=list(self.q[:3] + arm - (at - self.cg)),
                                   initialRotationMatrix=rotation, initialAngularVelocity=list(angular),
                                   initialVelocity=list(self.rate[:3] + np.cross(self.rate[3:], arm)),
                                   nodeType=exu.NodeType.RotationRxyz, returnDict=True)["bodyNumber"]


def cycle_revolutions(ref: Reference) -> int:
    """Revolutions per cycle of the orders (2 with half orders)."""
    return int(round(1 / np.min(np.diff(np.concatenate([[0.0], ref.orders])))))


def solve_forces(run: Run) -> np.ndarray:
    """Solve; the mount forces into the frame (step, mount, 3) over the last cycle."""
    run.mbs.SolveDynamic(run.settings)
    local = np.array([[run.mbs.GetSensorStoredData(s)[:, 1] for s in row] for row in run.sensors])
    expected = (run.warmup + 1) * run.steps + 1
    if local.shape[-1] != expected:
        raise RuntimeError(f"expected {expected} sensor records, got {local.shape[-1]}")
    forces = np.einsum("mat,mac->tmc", local, run.directions)
    return forces[run.warmup * run.steps:]      # steps + 1 records: the cycle and its end


def order_phasors(forces: np.ndarray, orders: np.ndarray, revolutions: int) -> np.ndarray:
    """Peak phasors (order, mount, 3) of one cycle's samples (step, mount, 3)."""
    spectrum = np.fft.rfft(forces, axis=0) / len(forces)
    return 2 * spectrum[np.rint(orders * revolutions).astype(int)]


def exudyn_phasors(scene, ref: Reference, steps: int, *, scale: float = 1.0) -> tuple[np.ndarray, float]:
    """The mount forces' phasors (order, mount, 3) of Exudyn's rigid block and
    the periodicity residual (last cycle's end against its start, relative)."""
    forces = solve_forces(build_block(scene, ref, steps, scale=scale))
    residual = np.abs(forces[-1] - forces[0]).max() / np.abs(forces).max()
    return order_phasors(forces[:-1], ref.orders, cycle_revolutions(ref)), residual


def relative_error(phasors: np.ndarray, ref: Reference) -> float:
    return float(np.abs(phasors - ref.force).max() / np.abs(ref.force).max())


def converge(scene, ref: Reference, start: int, target: float, max_steps: int, *, scale: float = SMALL) -> dict:
    """Double the steps per cycle from ``start`` until the linear run's error
    (loads × ``scale``, phasors / ``scale``) is at most ``target``, then step
    back to the coarsest N the order-2 law predicts (N_prev √(error_prev /
    target), rounded up to 50, raised 5 % until it passes) so that Exudyn is
    timed where it just reaches the target; each row: steps, error,
    Richardson error against the row before (doubling only), residual."""
    rows: list[dict] = []
    steps = start
    while not rows or (rows[-1]["error"] > target and 2 * steps <= max_steps):
        if rows:
            steps *= 2
        rows.append(_row(scene, ref, steps, scale, rows[-1]["phasors"] if rows else None))
    if len(rows) > 1 and rows[-1]["error"] <= target:
        steps = int(50 * np.ceil(rows[-2]["steps"] * np.sqrt(rows[-2]["error"] / target) / 50))
        while steps < rows[-1]["steps"]:
            row = _row(scene, ref, steps, scale, None)
            rows.append(row)
            if row["error"] <= target:
                return {"rows": rows, "steps": steps, "reached": True, "phasors": row["phasors"]}
            steps = int(50 * np.ceil(1.05 * steps / 50))
        steps = max(r["steps"] for r in rows)
    best = next(r for r in rows if r["steps"] == steps)
    return {"rows": rows, "steps": steps, "reached": best["error"] <= target, "phasors": best["phasors"]}


def linear_phasors(scene, ref: Reference, steps: int, scale: float = SMALL) -> tuple[np.ndarray, float]:
    """The mount forces' phasors linear in the loads: the mean of C(s)/s and
    C(−s)/(−s) (the geometric nonlinearity's leading, quadratic part is even in
    the loads and cancels), and the larger periodicity residual."""
    (plus, first), (minus, second) = (exudyn_phasors(scene, ref, steps, scale=x) for x in (scale, -scale))
    return (plus - minus) / (2 * scale), max(first, second)


def _row(scene, ref: Reference, steps: int, scale: float, previous) -> dict:
    phasors, residual = linear_phasors(scene, ref, steps, scale)
    richardson = None if previous is None else relative_error((4 * phasors - previous) / 3, ref)
    row = {"steps": steps, "error": relative_error(phasors, ref), "richardson": richardson,
           "residual": residual, "phasors": phasors}
    print(f"  N = {steps:6d} steps/cycle: error {row['error']:.2e}"
          + ("" if richardson is None else f", Richardson (N/2, N) {richardson:.2e}")
          + f", periodicity residual {residual:.1e}")
    return row


def nonlinear_share(scene, ref: Reference, steps: int, linear: np.ndarray) -> float:
    """The part of the full-load mount forces not linear in the loads, as a
    fraction of harmbal's largest: |C(1) − C(s)/s| at the same steps."""
    full, _ = exudyn_phasors(scene, ref, steps, scale=1.0)
    return float(np.abs(full - linear).max() / np.abs(ref.force).max())


def best_exudyn_seconds(scene, ref: Reference, steps: int, runs: int) -> float:
    """Best of ``runs``: Exudyn's solve at ``steps`` per cycle (model built
    before the clock starts), the sensors read and the orders taken."""
    best = np.inf
    for _ in range(runs):
        run = build_block(scene, ref, steps, scale=SMALL)
        start = time.perf_counter()
        order_phasors(solve_forces(run)[:-1], ref.orders, cycle_revolutions(ref))
        best = min(best, time.perf_counter() - start)
    return best


# -- 2. the crank train standing on the mounts -----------------------------------

@dataclass
class Split:
    """The powertrain split into the block and the moving parts (their mass,
    cycle-mean CG and cycle-averaged inertia about the powertrain's CG)."""

    block_mass: float
    block_cg: np.ndarray
    block_inertia: np.ndarray
    moving_mass: float
    moving_cg: np.ndarray


def steiner(mass: float, offset: np.ndarray) -> np.ndarray:
    return mass * (offset @ offset * np.eye(3) - np.outer(offset, offset))


def split_powertrain(scene, samples: int = 360) -> Split:
    """Block = powertrain − (pistons, rods and the crank: ``CRANK_MASS``, the
    spinning inertia isotropic, on the crank axis at x = 0), averaged over a
    revolution at ``samples`` crank angles."""
    from bench_exudyn import slider_crank

    pt = scene.powertrain
    cg = np.asarray(pt.cg, dtype=float)
    mass, moment = CRANK_MASS, np.zeros(3)
    inertia = spinning_inertia(scene) * np.eye(3) + steiner(CRANK_MASS, -cg)
    for cyl in scene.cylinders:
        for theta in 2 * np.pi * np.arange(samples) / samples:
            state = slider_crank(cyl, theta, 1.0, scene.sense)
            for m, j, at in ((cyl.rod.mass, cyl.rod.inertia, state["rod_cg"]),
                             (cyl.piston.mass, 1e-3, state["piston_cg"])):
                moment = moment + m * at / samples
                inertia = inertia + (j * np.eye(3) + steiner(m, at - cg)) / samples
        mass += cyl.rod.mass + cyl.piston.mass
    moving_cg = moment / mass
    block_mass = pt.mass - mass
    block_cg = (pt.mass * cg - moment) / block_mass
    block_inertia = np.asarray(pt.inertia, dtype=float) - inertia - steiner(block_mass, block_cg - cg)
    return Split(block_mass, block_cg, block_inertia, mass, moving_cg)


def build_crank_train(scene, split: Split, steps: int, revolutions: int, *, ground_drive: bool = False) -> Run:
    """bench_exudyn's crank train (its crank carrying the spinning parts'
    inertia, :func:`spinning_inertia`, isotropic) in a block of ``split``
    standing on the scene's mounts, from rest at θ = 0, ``revolutions``
    revolutions of ``steps`` steps; the last is kept. The crank turns at
    sense·ω relative to the block (:func:`add_spin_joint`, harmbal's
    assumption), or with ``ground_drive`` its Rxyz angle about x at that rate
    relative to the ground (a crank free to keep its absolute speed: the block
    rolls under it, and its polar inertia leaves the block's roll)."""
    import exudyn as exu
    import exudyn.itemInterface as items
    from bench_exudyn import slider_crank, supported
    from exudyn.rigidBodyUtilities import RigidBodyInertia

    supported(scene)
    omega, sense = float(scene.speeds[0]), scene.sense
    rxyz = exu.NodeType.RotationRxyz
    system = exu.SystemContainer()
    mbs = system.AddSystem()
    block = mbs.CreateRigidBody(inertia=RigidBodyInertia(split.block_mass, split.block_inertia),
                                referencePosition=list(split.block_cg), nodeType=rxyz, returnDict=True)["bodyNumber"]
    sensors, directions = add_mounts(mbs, block, split.block_cg, scene.mounts)

    def on_block(position, rotation=None):
        return mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=block, localHT=exu.HT(
            rotation=np.eye(3) if rotation is None else rotation,
            translation=list(np.asarray(position) - split.block_cg))))

    crank = mbs.CreateRigidBody(inertia=RigidBodyInertia(CRANK_MASS, spinning_inertia(scene) * np.eye(3)),
                                nodeType=rxyz, returnDict=True, initialAngularVelocity=[sense * omega, 0, 0])
    on_crank = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=crank["bodyNumber"], localPosition=[0, 0, 0]))
    if not ground_drive:
        add_spin_joint(mbs, on_block([0, 0, 0]), on_crank, sense * omega)
    else:
        mbs.AddObject(items.ObjectJointGeneric(constrainedAxes=[1, 1, 1, 0, 1, 1],         # main bearing
                                               markerNumbers=[on_block([0, 0, 0]), on_crank]))
        ground = mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(items.NodePointGround()),
                                                          coordinate=0))
        turning = mbs.AddMarker(items.MarkerNodeCoordinate(nodeNumber=crank["nodeNumber"], coordinate=3))
        mbs.AddObject(items.ObjectConnectorCoordinate(markerNumbers=[ground, turning], offset=sense * omega,
                                                      velocityLevel=True))
    for cyl in scene.cylinders:
        _add_cylinder(mbs, cyl, slider_crank(cyl, 0.0, omega, sense), crank["bodyNumber"], on_block)
    mbs.Assemble()
    settings = solver_settings(revolutions * steps, revolutions * 2 * np.pi / omega)
    settings.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    return Run(mbs, system, settings, sensors, directions, steps, revolutions - 1)


def _add_cylinder(mbs, cyl, now: dict, crank: int, on_block) -> None:
    """Rod and piston of ``cyl`` at its state ``now`` (bench_exudyn's joints)."""
    import exudyn as exu
    import exudyn.itemInterface as items
    from exudyn.rigidBodyUtilities import RigidBodyInertia

    rxyz = exu.NodeType.RotationRxyz
    rod = mbs.CreateRigidBody(inertia=RigidBodyInertia(cyl.rod.mass, cyl.rod.inertia * np.eye(3)), nodeType=rxyz,
                              referencePosition=list(now["rod_cg"]), initialVelocity=list(now["rod_velocity"]),
                              initialAngularVelocity=list(now["rod_rate"]))
    piston = mbs.CreateRigidBody(inertia=RigidBodyInertia(cyl.piston.mass, 1e-3 * np.eye(3)), nodeType=rxyz,
                                 referencePosition=list(now["piston_cg"]), initialVelocity=list(now["piston_velocity"]))

    def marker(body, at):
        return mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=body, localPosition=list(at)))

    mbs.AddObject(items.ObjectJointGeneric(constrainedAxes=[1, 1, 1, 0, 1, 1], markerNumbers=[
        marker(crank, now["big_end"]), marker(rod, now["big_end"] - now["rod_cg"])]))
    mbs.AddObject(items.ObjectJointGeneric(constrainedAxes=[0, 1, 1, 0, 0, 0], markerNumbers=[
        marker(rod, now["pin"] - now["rod_cg"]), marker(piston, now["pin"] - now["piston_cg"])]))
    axes = now["axes"]                                     # joint x along the cylinder axis: free
    on_piston = mbs.AddMarker(items.MarkerBodyRigid(bodyNumber=piston,
                                                    localHT=exu.HT(rotation=axes, translation=[0, 0, 0])))
    mbs.AddObject(items.ObjectJointGeneric(markerNumbers=[on_block(now["piston_cg"], axes), on_piston],
                                           constrainedAxes=[0, 1, 1, 1, 1, 1]))


def coupling(scene, ref: Reference, steps: int, revolutions: int, *, ground_drive: bool = False) -> dict:
    """Mount-force phasors of the crank train on the mounts, of the rigid block
    (with its rotor) under the clamped loads (full scale, same steps per
    revolution), and the differences as fractions of harmbal's largest
    transmitted force; ``gyroscopic``: harmbal's own share of the spinning
    parts (its forces with and without them)."""
    split = split_powertrain(scene)
    run = build_crank_train(scene, split, steps, revolutions, ground_drive=ground_drive)
    train = order_phasors(solve_forces(run)[:-1], ref.orders, 1)
    block, _ = exudyn_phasors(scene, ref, steps, scale=1.0)
    scale = np.abs(ref.force).max()
    no_spin = harmbal_reference(scene_with_spin(scene, 0.0)).force
    return {"split": split, "train": train, "block": block,
            "coupling": float(np.abs(train - block).max() / scale),
            "nonlinear": float(np.abs(block - ref.force).max() / scale),
            "total": float(np.abs(train - ref.force).max() / scale),
            "gyroscopic": float(np.abs(ref.force - no_spin).max() / scale),
            "without_gyroscopic": float(np.abs(train - no_spin).max() / scale)}


def scene_with_spin(scene, inertia: float):
    """``scene`` with ``[powertrain] spinning_inertia`` = ``inertia`` [kg m²]."""
    from dataclasses import replace

    return replace(scene, powertrain=replace(scene.powertrain, spinning_inertia=inertia))


# -- the report -------------------------------------------------------------------

def ms(seconds: float) -> str:
    return f"{seconds * 1e3:.3g} ms" if seconds < 1 else f"{seconds:.3g} s"


def part_block(args, scene, ref: Reference) -> dict:
    """1 and 3: agreement, convergence, nonlinearity share and timing."""
    import harmbal as hb

    amplitude = np.abs(ref.response).sum(axis=0)
    print(f"{scene.name} at {RPM} rpm, viscous mounts (η k / 2π {MATCH_HZ:g} Hz): largest transmitted force "
          f"{np.abs(ref.force).max():.4g} N; response (sum over orders of |Q|): translations "
          f"{amplitude[:3].max() * 1e6:.0f} µm, rotations {amplitude[3:].max() * 1e3:.2f} mrad")
    print(f"Exudyn rigid block, loads × {SMALL:g} (linear), from harmbal's harmonic state, "
          f"{WARMUP_CYCLES} warm-up cycle(s), doubling N until the error <= {args.target:g}:")
    result = converge(scene, ref, args.start, args.target, args.max_steps)
    share = nonlinear_share(scene, ref, result["steps"], result["phasors"])
    print(f"  nonlinearity's share at full load (N = {result['steps']}): {share:.2e} of the largest force")
    t_harmbal = best_seconds(lambda: hb.mounts(scene), args.repeat)
    t_exudyn = best_exudyn_seconds(scene, ref, result["steps"], args.runs)
    print(f"  timing: hb.mounts {ms(t_harmbal)} (best of {args.repeat}), Exudyn {ms(t_exudyn)} at "
          f"N = {result['steps']} (best of {args.runs}): ratio {t_exudyn / t_harmbal:,.0f}")
    return {**result, "share": share, "harmbal": t_harmbal, "exudyn": t_exudyn}


def part_crank_train(args) -> list:
    """2: the crank train on the mounts, for the spinning inertias of INERTIAS."""
    steps, revolutions = (180, 12) if args.quick else (360, 24)
    drive = "the ground (Rxyz angle rate)" if args.ground_drive else "the block"
    print(f"Crank train on the mounts (no gas), crank driven at ω relative to {drive}, {steps} steps/rev, "
          f"{revolutions} revolutions from rest; harmbal with spinning_inertia = the crank's (fractions of "
          f"harmbal's largest transmitted force):")
    rows = []
    for inertia in INERTIAS:
        scene = viscous_scene(gas=False, spinning=inertia)
        ref = harmbal_reference(scene)
        result = coupling(scene, ref, steps, revolutions, ground_drive=args.ground_drive)
        by_order = np.abs(result["train"] - ref.force).max(axis=(1, 2)) / np.abs(ref.force).max()
        worst = ", ".join(f"order {k:g} {e:.1e}" for k, e in zip(ref.orders[:3], by_order[:3]))
        print(f"  J = {inertia:g} kg m² (largest force {np.abs(ref.force).max():.4g} N, harmbal's gyroscopic "
              f"share {result['gyroscopic']:.2e}): crank train vs harmbal {result['total']:.2e} ({worst}; "
              f"vs harmbal without G "
              f"{result['without_gyroscopic']:.2e}), crank train vs rigid block {result['coupling']:.2e}, "
              f"rigid block vs harmbal {result['nonlinear']:.2e}")
        rows.append((inertia, result))
    return rows


#: Spinning (crank) inertias [kg m²] of the coupling run: almost none (no gyroscopic moment),
#: bench_exudyn's crank, and the tractor's crankshaft + flywheel + damper (its scene's spinning_inertia).
INERTIAS = (1e-4, 0.1, 1.6)


def best_seconds(function, repeat: int) -> float:
    function()
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: target 1e-4, short runs")
    parser.add_argument("--repeat", type=int, default=None, help="hb.mounts calls, best of (default 50, quick 5)")
    parser.add_argument("--runs", type=int, default=None, help="Exudyn runs, best of (default 3, quick 1)")
    parser.add_argument("--target", type=float, default=None, help="error target (default 1e-6, quick 1e-4)")
    parser.add_argument("--start", type=int, default=500, help="first steps per cycle")
    parser.add_argument("--max-steps", type=int, default=2 ** 16, help="largest steps per cycle")
    parser.add_argument("--no-crank-train", action="store_true", help="skip the crank train on the mounts")
    parser.add_argument("--ground-drive", action="store_true",
                        help="crank train: drive the crank relative to the ground, not the block")
    parser.add_argument("--checked", action="store_true", help="Exudyn's default module instead of exudynCPPfast")
    args = parser.parse_args()
    args.repeat = args.repeat or (5 if args.quick else 50)
    args.runs = args.runs or (1 if args.quick else 3)
    args.target = args.target or (1e-4 if args.quick else 1e-6)
    if not args.checked:
        sys.exudynFast = True   # exudyn loads exudynCPPfast if the CPU has AVX2
    try:
        import exudyn
    except ImportError:
        print("exudyn not installed: pip install exudyn")
        return 0
    import harmbal as hb

    print(f"exudyn {exudyn.__version__}, harmbal {hb.__version__}, numpy {np.__version__}; "
          f"generalized-alpha ρ∞ = {SPECTRAL_RADIUS}")
    scene = viscous_scene()
    part_block(args, scene, harmbal_reference(scene))
    if not args.no_crank_train:
        part_crank_train(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
