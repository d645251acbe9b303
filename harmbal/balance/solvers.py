"""What the design solvers share: the linear-programme tolerances, the design error and the common base of
their results."""

from __future__ import annotations

#: HiGHS's default feasibility tolerances (1e-7) leave the optimum ~1e-7
#: relative short of the true one, which a fine sweep can beat; these reach it.
LP_TOLERANCES = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}


class DesignError(ValueError):
    """A design that cannot be set up (no [design] table, a target order the
    scene does not resolve)."""


class BalancerDesign:
    """What every design result is: :class:`~harmbal.balance.design.Design`
    (balancer elements designed order by order) or
    :class:`~harmbal.balance.lever.LeverDesign` (a lever balancer's weight),
    the two results :func:`harmbal.design` returns.

    Both hold the designed ``scene`` (loaded from ``text``, the scene file
    harmbal writes) and ``messages`` in words; the rest is their own.
    """

    scene: object
    text: str
    messages: tuple[str, ...]
