"""What the design solvers share: the linear-programme tolerances and the design error."""

from __future__ import annotations

#: HiGHS's default feasibility tolerances (1e-7) leave the optimum ~1e-7
#: relative short of the true one, which a fine sweep can beat; these reach it.
LP_TOLERANCES = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}


class DesignError(ValueError):
    """A design that cannot be set up (no [design] table, a target order the
    scene does not resolve)."""
