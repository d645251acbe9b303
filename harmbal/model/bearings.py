"""Bearing and interface loads: the crank train's joints with gas, the main
bearings of a multi-throw crankshaft, and the balancers' bearings, fasteners
and drive torque, on plain arrays.

Every load is affine in ω²: an inertia part at unit crank speed (scaled by
ω²) plus a part that does not depend on the speed (the gas force, static
loads such as a flywheel's weight or a belt pull). The functions here return
the two parts separately; :mod:`harmbal.views.loads` multiplies them out.

Gas. The pressure pushes the piston crown towards the crank along the bore
axis with P = (p − p_crankcase)·A and the cylinder head the other way on
the same line. Without inertia the con-rod is a two-force member, so the
piston-pin force lies along the rod: F = P·u/u_c with u the rod's direction
(from the crank pin to the piston pin) and u_c > 0 its component along the
cylinder axis; the wall takes the rest, W = P − F, purely across the axis,
and, when the pin is offset from the bore axis, the couple P·pin_offset (the
force on the crown acts on the bore axis, not through the pin). The joint
forces are linear in the applied loads, so these add to the inertial ones of
:func:`harmbal.model.mechanism.reactions` exactly.

Main bearings: the statically determinate split. Each load on the crankshaft
(a crank pin's force at its cylinder's axial position, a rotating unbalance
or counterweight, a static load) is carried by the two main bearings around
it in proportion to its position (the lever rule), as if the crankshaft were
cut at every bearing; a load outside the outermost bearings (an overhung
flywheel or pulley) goes to the last two by the same rule (the outer one
takes more than the load, the inner one a share of the opposite sign). A
couple unbalance has no axial position: the two outermost bearings react it
as a rigid shaft would. See docs/loads.md for what the continuous-beam
(statically indeterminate) solution changes.

Vectors in the plane normal to the crank axis are w-plane complex numbers
w = v_z + i·v_t, t = −sense·y (see :mod:`harmbal.model.linkage`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..scene import Scene
from ..scene.elements import Shaft
from .kinematics import slider_crank
from .mechanism import reactions

#: Values multiplied out at once when peaks are taken over a sweep: 2²³ complex values, ~200 MB with
#: their magnitudes, however many speeds the sweep has.
_PEAK_CHUNK = 1 << 23


def lever_shares(bearings: ArrayLike, x: ArrayLike) -> np.ndarray:
    """Share of a load at each axial position ``x`` [m] carried by each
    bearing at ``bearings`` [m] (any order, distinct, at least two), by the
    statically determinate split: the two bearings around the load share it
    by the lever rule; a load outside the outermost bearings goes to the last
    two by the same rule (the nearer one takes more than the load, the other
    a negative share).

    Returns
    -------
    ndarray
        (bearing, load); every column sums to 1 and its first moment about
        the bearings equals the load's position.
    """
    bearings = np.asarray(bearings, dtype=float)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    order = np.argsort(bearings)
    xs = bearings[order]
    j = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, xs.size - 2)
    span = xs[j + 1] - xs[j]
    upper = (x - xs[j]) / span
    shares = np.zeros((xs.size, x.size))
    columns = np.arange(x.size)
    shares[j, columns] = 1 - upper
    shares[j + 1, columns] = upper
    result = np.empty_like(shares)
    result[order] = shares
    return result


def couple_shares(bearings: ArrayLike, sense: int) -> np.ndarray:
    """Loads on the bearings [N per N m] (bearing,) that make a unit
    transverse couple (w-plane) at axial positions ``bearings`` [m]: the
    outermost two take ±M/(i·sense·(x_a − x_b)), the rest nothing (a rigid
    shaft between them)."""
    bearings = np.asarray(bearings, dtype=float)
    a, b = int(np.argmin(bearings)), int(np.argmax(bearings))
    shares = np.zeros(bearings.size, dtype=complex)
    # The moment of a force w at x about the origin is i·sense·x·w in the w-plane (harmbal.model.balancers).
    shares[a] = 1 / (1j * sense * (bearings[a] - bearings[b]))
    shares[b] = -shares[a]
    return shares


def to_w(force_yz: tuple[float, float], sense: int) -> complex:
    """An engine-axes force (y, z) as a w-plane vector z − i·sense·y."""
    y, z = force_yz
    return complex(z, -sense * y)


@dataclass(frozen=True)
class CrankTrain:
    """Joint loads of the crank train over ``theta`` (M angles), per cylinder
    (cylinder, M), each the inertial part at unit speed (``*_unit``) and the
    speed-independent gas part (``*_gas``). Complex w-plane forces:

    * ``pin``: the con-rod on the piston at the piston pin;
    * ``big_end``: the crank pin on the con-rod;
    * ``wall``: the cylinder wall on the piston (at the pin, across the
      axis), with the wall's couple on the piston ``couple`` [N m], positive
      in the direction of rotation;
    * ``crank_extra``: the crankshaft's other loads needing the main bearings
      at unit speed, (source, M), at axial positions ``crank_x`` (source,):
      its unbalances' m·a_G and the lever couplers' forces on it;
    * ``crank_couple``: the w-plane couple the crankshaft's couple
      unbalances exert on its bearings at unit speed (M,);
    * ``rod_axis``, ``crank_axis``: unit vectors along the rod (big end to
      small end) and along the throw (crank axis to crank pin), (cylinder, M);
    * ``gas_force``: P per cylinder (cylinder, M) [N], towards the crank.
    """

    theta: np.ndarray
    pin_unit: np.ndarray
    pin_gas: np.ndarray
    big_end_unit: np.ndarray
    big_end_gas: np.ndarray
    wall_unit: np.ndarray
    wall_gas: np.ndarray
    couple_unit: np.ndarray
    couple_gas: np.ndarray
    crank_extra: np.ndarray
    crank_x: np.ndarray
    crank_couple: np.ndarray
    rod_axis: np.ndarray
    crank_axis: np.ndarray
    gas_force: np.ndarray


def crank_train(scene: Scene, theta: np.ndarray, gas_force: np.ndarray | None) -> CrankTrain:
    """Joint loads of the scene's crank train over ``theta`` [rad].

    Parameters
    ----------
    scene : Scene
        Cylinders, balancer elements on the crank, lever balancers.
    theta : ndarray
        Crank angles [rad] (M,), e.g. one working cycle.
    gas_force : ndarray or None
        Gas force P [N] on each piston towards the crank (cylinder, M), as
        :func:`harmbal.model.gas.gas_loads` gives it; None: no gas.

    Returns
    -------
    CrankTrain
    """
    theta = np.asarray(theta, dtype=float)
    rx = reactions(scene, theta)
    labels = [c.label for c in scene.cylinders]
    pin_unit = np.stack([rx.forces[f"F{c}"] for c in labels])
    big_end_unit = np.stack([rx.forces[f"E{c}"] for c in labels])
    wall_unit = np.stack([rx.forces[f"W{c}"] for c in labels])
    gas_force = np.zeros(pin_unit.shape) if gas_force is None else np.asarray(gas_force, dtype=float)
    pin_gas = np.empty_like(pin_unit)
    wall_gas = np.empty_like(wall_unit)
    rod_axis = np.empty_like(pin_unit)
    crank_axis = np.empty_like(pin_unit)
    couple_gas = np.empty(pin_unit.shape)
    for i, cyl in enumerate(scene.cylinders):
        psi = theta + cyl.throw - cyl.bank
        kin = slider_crank(psi, cyl.crank_radius, cyl.rod_length, cyl.offset)
        arm = (kin.b - kin.a[0]) + 1j * (kin.e - kin.a[1])  # crank pin -> piston pin, length l
        turn = np.exp(1j * cyl.bank)
        pin_gas[i] = gas_force[i] * arm / arm.real * turn
        wall_gas[i] = -1j * gas_force[i] * arm.imag / arm.real * turn
        couple_gas[i] = cyl.pin_offset * gas_force[i]
        rod_axis[i] = arm / cyl.rod_length * turn
        crank_axis[i] = np.exp(1j * (theta + cyl.throw))
    # The crankshaft's own loads: m·a_G = −U·e^{i(θ+α)} per unbalance turning with it, and −(coupler on crank).
    extra, where = [], []
    for c in scene.cylinders:
        for u in c.throw_unbalances:
            extra.append(-u.unbalance * np.exp(1j * (theta + c.throw + u.angle)))
            where.append(u.x)
    for u in scene.crankshaft_unbalances:
        extra.append(-u.unbalance * np.exp(1j * (theta + u.angle)))
        where.append(u.x)
    couple = np.zeros(theta.shape, dtype=complex)
    for s in scene.shafts:
        if s.on_crank:
            for su in s.unbalances:
                extra.append(-su.unbalance * np.exp(1j * (theta + su.angle)))
                where.append(su.x)
            couple += s.couple * np.exp(1j * theta)
    for lever in scene.levers:
        extra.append(rx.forces[f"{lever.label}: C"])
        where.append(lever.x)
    return CrankTrain(theta, pin_unit, pin_gas, big_end_unit, pin_gas, wall_unit, wall_gas,
                      np.asarray(rx.wall_couple), couple_gas, np.array(extra).reshape(len(extra), theta.size),
                      np.array(where, dtype=float), couple, rod_axis, crank_axis, gas_force)


def main_bearings(train: CrankTrain, cylinder_x: ArrayLike, bearings: ArrayLike, static: list[tuple[complex, float]],
                  sense: int) -> tuple[np.ndarray, np.ndarray]:
    """Loads of the crankshaft on each main bearing (on the block), w-plane.

    Parameters
    ----------
    train : CrankTrain
        From :func:`crank_train`.
    cylinder_x : array_like
        Axial position [m] of each cylinder's crank pin (cylinder,).
    bearings : array_like
        Axial positions of the main bearings [m] (bearing,).
    static : list of (complex, float)
        Static forces on the crankshaft (w-plane [N], axial position [m]).
    sense : int
        +1 if the crank turns about +x, −1 otherwise.

    Returns
    -------
    unit, constant : ndarray
        (bearing, M): the part at unit speed (times ω²) and the
        speed-independent part (gas, static loads).
    """
    # The bearings supply what the crankshaft's equation of motion asks: Σ B = Σ E + Σ C + m·a_G − Σ S;
    # the load on each bearing is −B.
    cylinder_shares = lever_shares(bearings, cylinder_x)
    unit = -(cylinder_shares @ train.big_end_unit)
    if train.crank_x.size:
        unit -= lever_shares(bearings, train.crank_x) @ train.crank_extra
    unit += np.multiply.outer(couple_shares(bearings, sense), train.crank_couple)
    constant = -(cylinder_shares @ train.big_end_gas)
    for force, x in static:
        constant = constant + lever_shares(bearings, [x])[:, :1] * force
    return unit, constant


def shaft_bearings(shaft: Shaft, bearings: ArrayLike, theta: np.ndarray, static: list[tuple[complex, float]],
                   sense: int) -> tuple[np.ndarray, np.ndarray]:
    """Loads of a balance shaft on its two bearings (on the block), w-plane.

    Each static unbalance U at angle α and axial position x makes the
    centrifugal force n²·U·e^{i(nθ + α)} at unit crank speed (n the speed
    ratio), split by the lever rule; the couple unbalance C makes the
    couple n²·C·e^{inθ}, reacted by the pair; static loads (belt pull) split
    by the lever rule too.

    Parameters
    ----------
    shaft : Shaft
        The balance shaft (ratio, unbalances [kg m] with angles and axial
        positions, couple unbalance [kg m²]).
    bearings : array_like
        Axial positions of its two bearings [m].
    theta : ndarray
        Crank angles [rad] (M,).
    static : list of (complex, float)
        Static forces on the shaft (w-plane [N], axial position [m]).
    sense : int
        +1 if the crank turns about +x, −1 otherwise.

    Returns
    -------
    unit, constant : ndarray
        (2, M) and (2, 1): the loads at unit crank speed and the static part.
    """
    n = shaft.ratio
    turn = np.exp(1j * n * theta)
    unit = np.zeros((2, theta.size), dtype=complex)
    for u in shaft.unbalances:
        unit += lever_shares(bearings, [u.x]) * (n * n * u.unbalance * np.exp(1j * (n * theta + u.angle)))
    unit += np.multiply.outer(couple_shares(bearings, sense), n * n * shaft.couple * turn)
    constant = np.zeros((2, 1), dtype=complex)
    for force, x in static:
        constant += lever_shares(bearings, [x]) * force
    return unit, constant


def fastener_load(unbalance: ArrayLike, speed: ArrayLike, fasteners: ArrayLike):
    """Centrifugal load on each fastener of a rotating weight: F = m·x·ω²/n = U·ω²/n.

    Parameters
    ----------
    unbalance : array_like
        The weight's static unbalance m·x [kg m].
    speed : array_like
        Its angular speed ω [rad/s] (the crank speed times the speed ratio).
    fasteners : array_like
        Number n of fasteners sharing the load.

    Returns
    -------
    ndarray
        Load per fastener [N], radial, outwards.
    """
    return np.asarray(unbalance) * np.asarray(speed) ** 2 / np.asarray(fasteners)


def ramp_torque(inertia: ArrayLike, alpha: ArrayLike, end_speed: ArrayLike):
    """Drive torque of a speed ramp.

    Parameters
    ----------
    inertia : array_like
        The shaft's moment of inertia about its axis [kg m²].
    alpha : array_like
        Its angular acceleration [rad/s²].
    end_speed : array_like
        Its speed at the end of the ramp [rad/s].

    Returns
    -------
    torque, power : ndarray
        T = I·α [N m] and the power T·ω at the end speed [W] (no friction).
    """
    torque = np.asarray(inertia) * np.asarray(alpha)
    return torque, torque * np.asarray(end_speed)


def affine_extremes(w2: ArrayLike, unit: np.ndarray, constant: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Peak and mean of |w2·unit + constant| over the last axis, per speed.

    Parameters
    ----------
    w2 : ndarray
        ω² per speed (speed,).
    unit, constant : ndarray
        (..., M) complex or real; ``constant`` broadcasts against ``unit``.

    Returns
    -------
    peak, peak_index, mean : ndarray
        (speed, ...): max |·| over the angles, its index and the mean |·|.
    """
    w2 = np.atleast_1d(np.asarray(w2, dtype=float))
    constant = np.broadcast_to(constant, unit.shape)
    chunk = max(1, _PEAK_CHUNK // max(unit.size, 1))
    peak = np.empty((w2.size,) + unit.shape[:-1])
    index = np.empty(peak.shape, dtype=int)
    mean = np.empty(peak.shape)
    for start in range(0, w2.size, chunk):
        part = slice(start, start + chunk)
        values = np.abs(np.multiply.outer(w2[part], unit) + constant)
        index[part] = values.argmax(axis=-1)
        peak[part] = np.take_along_axis(values, index[part][..., None], axis=-1)[..., 0]
        mean[part] = values.mean(axis=-1)
    return peak, index, mean
