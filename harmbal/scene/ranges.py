"""The range of every numeric scene key (docs/scenes.md, "Ranges").

Two tables, applied by the reader's ``quantity`` and ``integer`` primitives:

* :data:`MAGNITUDES`, one per dimension: a value of that dimension is 0 or
  lies between ``low`` and ``high`` in magnitude. Wide enough for any real
  machine, from a model engine to a 25 m marine two-stroke at 60 rpm, a
  20 000 rpm racing engine or a compressor; narrow enough that no product
  of quantities the model forms (m·r·ω²·x, squared in a least-squares
  design) overflows or comes near the denormals below 1e-308. ``low`` is no
  physical limit: it lies far below any real value of the dimension, so that
  offsets and positions swept across 0 or drawn at random around it pass,
  and only a typo of hundreds of decades (``"1e-300 mm"``) is refused.
* :data:`KEY_RANGES`, by the key's last name: the interval a dimensionless
  number or an integer must lie in, and narrower intervals where physics
  asks (a compression ratio, the gas pressures). Every dimensionless and
  integer key the reader reads must have one (the reader raises
  ``KeyError`` on one that has not, so a new key without a range fails its
  first test).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

#: The values ``[model] negligible`` may take (below 1e-12 it would only relabel round-off).
NEGLIGIBLE_RANGE = (1e-12, 0.1)
#: Most samples per revolution the accuracy setting chooses (harmbal.model.sampling); what the
#: scene asks for must be resolvable within it.
MAX_SAMPLES = 1 << 16
#: Most speeds a sweep may ask for (one evaluation serves them all; 10⁶ keeps the Datasets ~1 GB at most).
MAX_SPEEDS = 1_000_000
#: Largest |speed ratio| of a balancer element, and largest order of a Lanchester pair: real balance shafts turn
#: at 1× or 2×; beyond this no element is a balancer (and sampling it would cost |ratio| samples a revolution).
MAX_RATIO = 100
#: Largest ``model.series_harmonics``: the series then holds harmonics up to this order (the exact model is the
#: default; more terms only approach it).
MAX_SERIES_HARMONICS = 64
#: Largest ``sampling.max_order``: harmbal samples at least 4 × max_order per revolution, at most MAX_SAMPLES.
MAX_ORDER = MAX_SAMPLES // 4
#: Most fasteners sharing one balance weight's load.
MAX_FASTENERS = 1000


#: Relative round-off a closed end of a range admits.
_SLACK = 1e-12


@dataclass(frozen=True)
class Range:
    """An interval of values: ``low`` … ``high`` (either end open), shown in
    messages and the docs as ``scale``-multiples of ``unit`` (e.g. bar for
    Pa), with ``why`` saying what the range is for."""

    low: float
    high: float
    open_low: bool = False
    open_high: bool = False
    unit: str = ""
    scale: float = 1.0
    why: str = ""

    def __contains__(self, value: float) -> bool:
        # A closed end admits the round-off of a unit conversion ("3600 deg" is 20π rad to an ulp or two).
        above = value > self.low if self.open_low else value >= self.low - _SLACK * abs(self.low)
        below = value < self.high if self.open_high else value <= self.high + _SLACK * abs(self.high)
        return above and below

    def interval(self) -> str:
        """The interval as text, e.g. ``(1, 100]`` or ``[0.01, 100] bar``."""
        text = (f"{'(' if self.open_low else '['}{number(self.low / self.scale)}, "
                f"{number(self.high / self.scale)}{')' if self.open_high else ']'}")
        return f"{text} {self.unit}".rstrip()


#: Magnitude of a nonzero value of each dimension [SI]: ``low`` ≤ |value| ≤ ``high``. The ends are consistent:
#: an engine scaled to the smallest lengths and masses has inertias, unbalances and loads within theirs.
MAGNITUDES: dict[str, Range] = {
    "length": Range(1e-100, 1e3, unit="m", why="up to a kilometre"),
    "mass": Range(1e-9, 1e7, unit="kg", why="a microgram to 10 000 t"),
    "angle": Range(1e-100, 20 * math.pi, unit="rad", why="up to ten turns, 3600°"),
    "speed": Range(1e-3, 1e5, unit="rad/s", why="0.01 rpm to about 950 000 rpm"),
    "inertia": Range(1e-40, 1e13, unit="kg m^2", why="moments and products of inertia: mass × length²"),
    "unbalance": Range(1e-25, 1e10, unit="kg m", why="mass × radius"),
    "force": Range(1e-30, 1e20, unit="N", why="mass × length × speed²"),
    "moment": Range(1e-45, 1e23, unit="N m", why="force × length"),
    "pressure": Range(1.0, 1e9, unit="Pa", why="1 Pa to 10 000 bar; each gas pressure has a narrower range"),
    "time": Range(1e-6, 1e6, unit="s", why="a microsecond to 11 days"),
    "density": Range(1.0, 1e5, unit="kg/m^3", why="foams to the densest metals"),
    "stiffness": Range(1e-30, 1e15, unit="N/m", why="a mount's stiffness, up to 1e12 N/mm"),
    "damping": Range(1e-30, 1e12, unit="N s/m", why="a mount's viscous damping"),
    "acceleration": Range(1e-30, 1e6, unit="m/s^2", why="up to about 100 000 g"),
    "frequency": Range(1e-6, 1e6, unit="Hz", why="a microhertz to a megahertz"),
}

_BAR: dict[str, Any] = {"unit": "bar", "scale": 1e5}

#: The interval each dimensionless or integer key must lie in, and narrower intervals some quantities need, by
#: the key's last name.
KEY_RANGES: dict[str, Range] = {
    # [sampling], [model], [engine]
    "samples_per_rev": Range(8, MAX_SAMPLES, why="crank angles per revolution, and at least 2·max_order + 2"),
    "max_order": Range(1, MAX_ORDER, why="the highest order reported; harmbal samples at least 4 × max_order "
                                         f"and at most {MAX_SAMPLES} per revolution"),
    "accuracy": Range(1e-16, 0.1, open_high=True, why="relative error"),
    "negligible": Range(*NEGLIGIBLE_RANGE, why="a fraction of one cylinder's share of the load scale"),
    "series_harmonics": Range(1, MAX_SERIES_HARMONICS, why="harmonics the series piston model keeps"),
    "points": Range(2, MAX_SPEEDS, why="speeds of a sweep"),
    "cycle": Range(2, 4, why="strokes: 2 or 4"),
    # balancer elements and requests
    "ratio": Range(1, MAX_RATIO, why="the magnitude of a balancer element's speed ratio n (n < 0 turns against the "
                                     "crank)"),
    "order": Range(1, MAX_ORDER, why=f"an order; a Lanchester pair's at most {MAX_RATIO}, its shafts turning at "
                                     "±order ×"),
    "fasteners": Range(1, MAX_FASTENERS, why="fasteners sharing a weight's load"),
    "balance_factor": Range(0, 1, why="the share of the reciprocating masses the counterweights carry besides the "
                                      "rotating masses"),
    "tolerance": Range(0, 1, open_high=True, why="the share of each value without balancers that may remain"),
    "weights": Range(0, 1e6, why="relative weights of the orders in a lever design"),
    "target_coefficient": Range(1e-6, 1, open_high=True,
                                why="δ = (ω_max − ω_min)/ω_mean; engines need about 0.002–0.05"),
    # [gas]
    "compression_ratio": Range(1, 100, open_low=True, why="V_BDC/V_TDC; engines run from about 6 to 25"),
    "compression_exponent": Range(1, 2, open_low=True, open_high=True, why="a polytropic exponent"),
    "expansion_exponent": Range(1, 2, open_low=True, open_high=True, why="a polytropic exponent"),
    "shape": Range(0, 20, why="the Wiebe shape m (usually 0.5 to 3)"),
    "efficiency": Range(0.1, 50, why="the Wiebe a (6.908: 99.9 % burnt at the end of the duration)"),
    "crankcase_pressure": Range(1e3, 1e7, **_BAR, why="absolute pressure under the piston"),
    "intake_pressure": Range(1e3, 1e7, **_BAR, why="absolute cylinder pressure at inlet valve closing"),
    "exhaust_pressure": Range(1e3, 1e7, **_BAR, why="absolute cylinder pressure through the exhaust stroke"),
    "peak_pressure": Range(1e5, 5e7, **_BAR, why="no engine's cylinder peaks above 500 bar"),
    "imep": Range(1e3, 1e7, **_BAR, why="indicated mean effective pressure (engines reach about 30 bar)"),
    # [[mount]], [mount_design]
    "loss_factor": Range(0, 2, why="a mount's hysteretic loss factor η (rubber about 0.05–0.3, hydromounts up "
                                   "to about 1)"),
    "decoupling": Range(0, 1, why="the least share of each mode's kinetic energy in its dominant DOF (0: no "
                                  "constraint)"),
}


def number(value: float) -> str:
    """A bound as the docs write it: ``1e-9``, ``1e5``, ``0.1``, ``1000``, ``65536``."""
    if value > 0 and not 1e-3 < value < 1e4 and math.log10(value).is_integer():
        return f"1e{int(math.log10(value))}"
    text = f"{value:g}"
    mantissa, _, exponent = text.partition("e")
    return f"{mantissa}e{int(exponent)}" if exponent else text


def magnitude_problem(dimension: str, si: float, positive: bool = False) -> str | None:
    """Why ``si`` [SI] is out of its dimension's range, or None if it is not
    (0 always passes here: signs are the caller's rules)."""
    bounds = MAGNITUDES.get(dimension)
    if bounds is None or si == 0 or abs(si) in bounds:
        return None
    where, shown = ("", "") if positive else ("0 or ", " in magnitude")
    extent = (f"{number(bounds.low)} rad and 3600°" if dimension == "angle"
              else f"{number(bounds.low)} and {number(bounds.high)} {bounds.unit}")
    return (f"out of range: must be {where}between {extent}{shown} ({bounds.why}); check the number and its "
            "unit")


def key_problem(name: str, value: float) -> str | None:
    """Why ``value`` [SI] of the key named ``name`` is out of its range, or None."""
    bounds = KEY_RANGES.get(name)
    if bounds is None or value in bounds:
        return None
    return f"must lie in {bounds.interval()}: {bounds.why}"
