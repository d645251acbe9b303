"""The powertrain as one rigid body and the mounts it stands on, as a scene
gives them ([powertrain], [[mount]], [mount_design]; SI units throughout).

Read by :mod:`.read_mounts`; the model on plain arrays is
:mod:`harmbal.model.mounts`. Conventions (docs/mounts.md): engine frame x
along the crank axis, y transverse, z up; inertia tensors about the CG with
the tensor's products (I_xy = −∫xy dm); a mount's axes are the rows u, v, w
of an orthonormal right-handed matrix in the engine frame. The format is in
``docs/scenes.md``, "Powertrain and mounts".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Standard gravity in the engine frame [m/s²] (z up).
STANDARD_GRAVITY = (0.0, 0.0, -9.80665)
#: The local directions a mount's static load may compress.
PRELOAD_AXES = ("u", "v", "w", "-u", "-v", "-w")
#: What a mount design variable may change.
VARIABLE_KINDS = ("stiffness", "position", "angle")
#: What a mount design minimises.
MOUNT_OBJECTIVES = ("transmitted_force", "decoupling")

Vector = tuple[float, float, float]
Matrix = tuple[Vector, Vector, Vector]


@dataclass(frozen=True)
class RigidPart:
    """One rigid part of the powertrain (block, gearbox, …).

    Attributes
    ----------
    name : str
        The part's name.
    mass : float
        Mass [kg].
    cg : tuple of 3 float
        Centre of gravity in the engine frame [m].
    inertia : 3×3 tuple of float
        Inertia tensor about the part's own CG in engine axes [kg m²].
    """

    name: str
    mass: float
    cg: Vector
    inertia: Matrix


@dataclass(frozen=True)
class Powertrain:
    """The powertrain as one rigid body.

    Attributes
    ----------
    mass : float
        Total mass [kg].
    cg : tuple of 3 float
        Centre of gravity in the engine frame [m].
    inertia : 3×3 tuple of float
        Inertia tensor about the CG in engine axes [kg m²], positive
        definite (built from ``parts`` when the scene gives parts).
    parts : tuple of RigidPart
        The parts the totals were built from; empty if the scene gave the
        totals.
    idle_speed : float or None
        Idle crank speed [rad/s]; None: the scene's lowest speed
        (:meth:`idle`).
    drive_torque : float or None
        Full-load mean torque [N m] (> 0 drives the crank in its sense of
        rotation); None if not given.
    gravity : tuple of 3 float
        Acceleration of gravity in the engine frame [m/s²].
    points : tuple of (str, tuple of 3 float)
        Named points [m] whose motion is reported.
    spinning_inertia : float or None
        Polar moment of inertia [kg m²] of the parts spinning with the crank
        (crankshaft, flywheel, damper …) whose momentum turns with the
        powertrain (the gyroscopic moment); None: the [flywheel] table's
        inertia if the scene has one, else none.
    """

    mass: float
    cg: Vector
    inertia: Matrix
    parts: tuple[RigidPart, ...] = ()
    idle_speed: float | None = None
    drive_torque: float | None = None
    gravity: Vector = STANDARD_GRAVITY
    points: tuple[tuple[str, Vector], ...] = ()
    spinning_inertia: float | None = None

    def idle(self, speeds: tuple[float, ...]) -> float:
        """The idle speed [rad/s]: as given, else the lowest of ``speeds``."""
        return self.idle_speed if self.idle_speed is not None else min(speeds)


@dataclass(frozen=True)
class MountTable:
    """A mount's dynamic stiffness and loss factor over frequency; replaces
    the nominal values in the forced response (linear in frequency, held
    constant beyond the ends).

    Attributes
    ----------
    frequency : tuple of float
        Frequencies [Hz], strictly increasing, at least two.
    stiffness : tuple of (3 float)
        Stiffness along u, v, w at each frequency [N/m].
    loss_factor : tuple of (3 float)
        Loss factor along u, v, w at each frequency.
    """

    frequency: tuple[float, ...]
    stiffness: tuple[Vector, ...]
    loss_factor: tuple[Vector, ...]


@dataclass(frozen=True)
class Mount:
    """One elastic mount.

    Attributes
    ----------
    name : str
        The mount's name (unique in the scene).
    position : tuple of 3 float
        Its elastic centre in the engine frame [m].
    axes : 3×3 tuple of float
        Rows u, v, w: its principal directions in the engine frame
        (orthonormal, right-handed).
    stiffness : tuple of 3 float
        Nominal principal stiffnesses along u, v, w [N/m] (statics and modes).
    loss_factor : tuple of 3 float
        Hysteretic loss factors along u, v, w.
    damping : tuple of 3 float
        Viscous dampings along u, v, w [N s/m].
    table : MountTable or None
        Stiffness and loss factor over frequency for the forced response.
    preload_axis : str
        The local direction the static load compresses: one of
        :data:`PRELOAD_AXES`.
    """

    name: str
    position: Vector
    axes: Matrix
    stiffness: Vector
    loss_factor: Vector = (0.0, 0.0, 0.0)
    damping: Vector = (0.0, 0.0, 0.0)
    table: MountTable | None = None
    preload_axis: str = "w"


@dataclass(frozen=True)
class MountVariable:
    """One quantity a mount design may change.

    Attributes
    ----------
    mount : str
        The mount's name.
    kind : str
        ``"stiffness"`` (along local ``axis`` 0, 1, 2 = u, v, w),
        ``"position"`` (engine ``axis`` 0, 1, 2 = x, y, z; bounds absolute
        [m]) or ``"angle"`` (rotation of the mount's axes about engine
        ``axis``; bounds [rad] relative to the axes as written).
    axis : int
        0, 1 or 2.
    lower, upper : float
        Bounds, lower < upper, the value as written inside them.
    group : str or None
        Variables of one group share one value (a symmetric pair).
    """

    mount: str
    kind: str
    axis: int
    lower: float
    upper: float
    group: str | None = None


@dataclass(frozen=True)
class MountDesignRequest:
    """What a mount design is asked ([mount_design]).

    Attributes
    ----------
    variables : tuple of MountVariable
        What it may change.
    decoupling : float or None
        Least share of every mode's kinetic energy in its dominant DOF;
        None: no such constraint.
    frequency_band : (float, float) or None
        Every mode's frequency inside [Hz]; None: 5 Hz to the idle firing
        frequency / √2.
    max_static_roll : float or None
        Largest static roll angle under the full-load (or mean) torque [rad].
    max_tra_angle : float or None
        Largest angle between the torque roll axis and the roll mode [rad].
    objective : str
        ``"transmitted_force"`` or ``"decoupling"``.
    """

    variables: tuple[MountVariable, ...]
    decoupling: float | None = 0.9
    frequency_band: tuple[float, float] | None = None
    max_static_roll: float | None = None
    max_tra_angle: float | None = None
    objective: str = "transmitted_force"


def inertia_from_parts(masses, cgs, inertias) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, CG and inertia tensor about the CG of rigid parts (parallel axis theorem).

    Parameters
    ----------
    masses : array_like (n,)
        Masses of the parts [kg].
    cgs : array_like (n, 3)
        Their centres of gravity in the engine frame [m].
    inertias : array_like (n, 3, 3)
        Their inertia tensors about their own CGs [kg m²] (tensor convention,
        off-diagonal −∫xy dm).

    Returns
    -------
    mass : float
    cg : ndarray (3,)
    inertia : ndarray (3, 3)
        Σ [I_i + m_i (|d_i|² I₃ − d_i d_iᵀ)], d_i = c_i − c.
    """
    m = np.asarray(masses, dtype=float)
    c = np.asarray(cgs, dtype=float)
    mass = float(m.sum())
    if not mass > 0:
        raise ValueError(f"the parts' total mass must be positive, got {mass} kg")
    cg = m @ c / mass
    d = c - cg
    shift = m[:, None, None] * (np.einsum("ni,ni->n", d, d)[:, None, None] * np.eye(3) - d[:, :, None] * d[:, None, :])
    return mass, cg, np.sum(np.asarray(inertias, dtype=float) + shift, axis=0)
