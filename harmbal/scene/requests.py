"""What a balancer design asks for and what a verification checks.

A :class:`DesignRequest` names the orders to balance, the components to
cancel, and *candidate* balancer elements whose geometry (planes, shaft axis,
speed ratio) the designer chose and whose unbalances (size and angle) the
solver finds. A :class:`VerifyRequest` names the targeted orders and
components and what the design predicted for them. Both are read from the
``[design]`` and ``[verify]`` tables of a scene (docs/scenes.md) or built in
Python.

Each candidate is a set of complex unknowns P (mass × radius [kg m] as
U·e^{iα}, α the unbalance's angle at θ = 0). An unknown acts at one or more
:class:`Placement` s: an unbalance coefficient·P on a body turning at
``ratio`` × crank speed about the axis (y, z), in the plane x. Everything a
balancer does is linear in these unknowns, so design by order is a small
linear problem.
"""

from __future__ import annotations

from dataclasses import dataclass

from .shapes import Blank

#: Components of one order that a design can cancel: the transverse force
#: (co- and counter-rotating), the transverse moment, and the moment about the
#: crank axis.
CANCEL = ("force", "moment", "roll")

#: The per-order components verified and reported, as (name, cancel group).
COMPONENTS = (("force_co", "force"), ("force_counter", "force"), ("moment_co", "moment"),
              ("moment_counter", "moment"), ("roll", "roll"))

CANDIDATE_KINDS = ("counterweights", "balance_shaft", "moment_shaft", "lanchester_pair")

#: Objectives: least squares of the targeted phasors (exact where feasible,
#: minimum norm), or the smallest peak over the revolution of chosen signals.
OBJECTIVES = ("least_squares", "peak")

#: Samples per revolution for peaks over the revolution (the peak objective,
#: verification): the sampled peak of an order-k signal is within (πk/N)²/2
#: of the true peak, 1.2e-6 relative for order 1.
PEAK_SAMPLES = 2048

#: Signals whose peak over the revolution the "peak" objective can minimise.
PEAK_SIGNALS = ("force_y", "force_z", "moment_x", "moment_y", "moment_z")


def signed_ratio(ratio: int) -> str:
    """A speed ratio as written in messages: '+2×', '−1×'."""
    return f"{'+' if ratio > 0 else '−'}{abs(ratio)}×"


@dataclass(frozen=True)
class Placement:
    """Where an unknown complex unbalance P acts: coefficient·P on a body
    turning at ``ratio`` × crank speed about the axis (``y``, ``z``) [m], in
    the plane ``x`` [m]."""

    ratio: int
    y: float
    z: float
    x: float
    coefficient: float = 1.0


@dataclass(frozen=True)
class Candidate:
    """A balancer element with unknown unbalances.

    ``kind`` is one of :data:`CANDIDATE_KINDS`:

    * ``counterweights``: crank counterweights, one unknown per plane in
      ``planes``; with ``balance_factor`` f they are not solved but sized by
      the classic rule (rotating masses plus f × the reciprocating masses,
      static and couple balance over the planes).
    * ``balance_shaft``: a shaft at ``ratio`` with axis (``y``, ``z``), one
      unknown per plane.
    * ``moment_shaft``: a shaft carrying equal and opposite unbalances in its
      two planes, a pure couple (one unknown).
    * ``lanchester_pair``: two shafts at +``ratio`` and −``ratio`` in the
      plane ``planes[0]``, at ``heights`` (z₊, z₋) and ``lateral`` (y₊, y₋),
      one unknown each. Equal unbalances P₊ = U·e^{i(α+δ)} and
      P₋ = U·e^{i(α−δ)} make the standing vector 2n²U·e^{iα}·cos(nθ + δ):
      direction α, phasing δ.

    ``max_unbalance`` [kg m] bounds each unknown's size in the peak objective.
    ``blank`` is a blank with one free dimension (:mod:`.shapes`), sized to
    each unbalance designed for the element and written as its shape.
    """

    kind: str
    label: str
    ratio: int
    planes: tuple[float, ...]
    y: float = 0.0
    z: float = 0.0
    heights: tuple[float, float] = (0.0, 0.0)
    lateral: tuple[float, float] = (0.0, 0.0)
    balance_factor: float | None = None
    max_unbalance: float | None = None
    blank: Blank | None = None

    def unknowns(self) -> list[tuple[Placement, ...]]:
        """The placements of each complex unknown."""
        if self.kind == "counterweights":
            return [(Placement(1, 0.0, 0.0, x),) for x in self.planes]
        if self.kind == "balance_shaft":
            return [(Placement(self.ratio, self.y, self.z, x),) for x in self.planes]
        if self.kind == "moment_shaft":
            first, second = self.planes
            return [(Placement(self.ratio, self.y, self.z, first), Placement(self.ratio, self.y, self.z, second, -1.0))]
        if self.kind == "lanchester_pair":
            x = self.planes[0]
            return [(Placement(self.ratio, self.lateral[0], self.heights[0], x),),
                    (Placement(-self.ratio, self.lateral[1], self.heights[1], x),)]
        raise ValueError(f"unknown candidate kind {self.kind!r}")

    def names(self) -> list[str]:
        """A name for each unknown, e.g. 'counterweights at x = 55 mm'."""
        if self.kind == "lanchester_pair":
            return [f"{self.label} (+{self.ratio}×)", f"{self.label} (−{self.ratio}×)"]
        speed = signed_ratio(self.ratio)
        if self.kind == "moment_shaft":
            return [f"{self.label} ({speed}) couple, x = " + " / ".join(f"{x * 1e3:g}" for x in self.planes) + " mm"]
        if self.kind == "counterweights":  # the labels the written [[counterweight]] tables get
            return [f"{self.label} {j + 1}" for j in range(len(self.planes))] if len(self.planes) > 1 else [self.label]
        return [f"{self.label} ({speed}) at x = {x * 1e3:g} mm" for x in self.planes]

    def describe(self) -> str:
        """A short name for messages, e.g. 'crank counterweights' or 'a −1× shaft'."""
        if self.kind == "counterweights":
            return "crank counterweights"
        if self.kind == "lanchester_pair":
            return f"a ±{self.ratio}× Lanchester pair"
        what = "moment shaft" if self.kind == "moment_shaft" else "shaft"
        return f"a {'+' if self.ratio > 0 else '−'}{abs(self.ratio)}× {what}"


@dataclass(frozen=True)
class DesignRequest:
    """Balance ``orders`` by cancelling the ``cancel`` components (of
    :data:`CANCEL`) with the ``candidates``, by the ``objective`` (of
    :data:`OBJECTIVES`); ``peak`` names the signals (of
    :data:`PEAK_SIGNALS`) whose summed peaks the "peak" objective
    minimises, subject to cancelling what can be cancelled."""

    orders: tuple[int, ...]
    candidates: tuple[Candidate, ...]
    cancel: tuple[str, ...] = ("force", "moment")
    objective: str = "least_squares"
    peak: tuple[str, ...] = ("moment_y", "moment_z")


@dataclass(frozen=True)
class VerifyRequest:
    """Orders and components to verify, and the residuals the design
    predicted.

    ``predicted`` maps (order, component name of :data:`COMPONENTS`) to the
    complex phasor [N or N m] at the speed ``speed`` [rad/s]; components not
    in it are predicted to vanish. ``tolerance`` is the share of each
    component's value without the balancers that may remain on top of the
    exact-arithmetic tolerance (0 for a design by harmbal)."""

    orders: tuple[int, ...]
    cancel: tuple[str, ...] = ("force", "moment")
    speed: float | None = None
    predicted: tuple[tuple[int, str, complex], ...] = ()
    tolerance: float = 0.0


#: Objectives of a lever-balancer design: the summed peak-to-peak values or
#: the summed peaks |·| over the revolution of the chosen signals (linear
#: programmes), or a weighted sum of squared order amplitudes (a quadratic
#: programme).
LEVER_OBJECTIVES = ("peak_to_peak", "peak", "orders")

#: Signals a lever design can judge: those linear in the balance weight's
#: (m, m·x_G, m·y_G). The moment about the crank axis is not (it holds
#: m·|r_G|² and the moment of inertia).
LEVER_SIGNALS = ("force_y", "force_z", "moment_y", "moment_z")


@dataclass(frozen=True)
class LeverDesignRequest:
    """Find the balance weight (the coupler's mass m and CG (x_G, y_G) in its
    local frame) of the lever balancer ``lever`` that minimises
    ``objective`` (of :data:`LEVER_OBJECTIVES`) over ``signals`` (of
    :data:`LEVER_SIGNALS`).

    ``orders`` and ``weights`` define the "orders" objective
    Σ_k w_k·Σ_signals |C_k|² (weights default to 1). ``mass`` [kg], ``cg_x``
    and ``cg_y`` [m] are optional (low, high) bounds; the CG bounds describe
    the weight's envelope in its local frame.
    """

    lever: str | None = None
    objective: str = "peak_to_peak"
    signals: tuple[str, ...] = ("force_y", "force_z")
    orders: tuple[int, ...] = (1,)
    weights: tuple[float, ...] = ()
    mass: tuple[float, float] | None = None
    cg_x: tuple[float, float] | None = None
    cg_y: tuple[float, float] | None = None
