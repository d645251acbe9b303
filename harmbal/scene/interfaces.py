"""What the bearing and interface loads need beyond the mechanism: the [loads]
table of a scene (SI units throughout).

The main bearings' axial positions (for the statically determinate split of
the crankshaft's loads), static forces on the crankshaft (a flywheel's
weight, a belt pull), per balancer element the axial positions of its two
bearings, its moment of inertia, its fastener count and static forces on it,
the speed the fasteners are checked at, and a speed ramp for the balancers'
drive torque. Read by :mod:`.read_loads`, used by :mod:`harmbal.views.loads`;
the format is in ``docs/scenes.md`` and the method in ``docs/loads.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Standard gravity [m/s²], for a static load given as a mass (its weight along −z).
GRAVITY = 9.80665


@dataclass(frozen=True)
class StaticLoad:
    """A force that does not turn and does not depend on the speed: ``force``
    (y, z) [N] on the shaft it is attached to, at axial position ``x`` [m]."""

    label: str
    force: tuple[float, float]
    x: float


@dataclass(frozen=True)
class ElementLoads:
    """Interface data of one balancer element of the scene.

    ``shafts`` are the labels of the scene's shafts it names (two for a
    Lanchester pair); ``bearings`` the axial positions [m] of the shaft's two
    bearings (balance shafts only), ``inertia`` its moment of inertia about
    its own axis [kg m²] (for the drive torque of a speed ramp),
    ``fasteners`` the number of fasteners sharing each weight's centrifugal
    load, ``static_loads`` forces on the shaft such as a belt pull.
    """

    label: str
    shafts: tuple[str, ...]
    bearings: tuple[float, float] | None = None
    inertia: float | None = None
    fasteners: int | None = None
    static_loads: tuple[StaticLoad, ...] = ()


@dataclass(frozen=True)
class Ramp:
    """A crank speed ramp from ``start`` to ``end`` [rad/s] in ``time`` [s] at
    constant angular acceleration."""

    start: float
    end: float
    time: float

    @property
    def alpha(self) -> float:
        """Crank angular acceleration [rad/s²]."""
        return (self.end - self.start) / self.time


@dataclass(frozen=True)
class LoadsRequest:
    """The [loads] table: ``main_bearings`` axial positions [m] (empty: no
    main-bearing split), ``static_loads`` on the crankshaft, ``elements``
    (balancer interface data), ``max_speed`` [rad/s] for the fastener loads
    (None: the scene's highest speed) and a speed ``ramp`` (None: none)."""

    main_bearings: tuple[float, ...] = ()
    static_loads: tuple[StaticLoad, ...] = ()
    elements: tuple[ElementLoads, ...] = ()
    max_speed: float | None = None
    ramp: Ramp | None = None
