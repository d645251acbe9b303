"""Gas in sweeps: the gas torque's order phasors of every distinct pressure
trace of a sweep, and what they add to each variant's loads.

The gas exerts a pure couple about the crank axis (:mod:`harmbal.model.gas`):
no force, no transverse moment, a roll moment −sense·ΣT that does not scale
with the speed, with half orders over a four-stroke cycle. It depends on the
geometry keys (the slider-crank, the throws and banks that place each
cylinder's firing) and on the *gas keys*: the keys of the ``[gas]`` tables
(``gas.…``, ``cylinder[i].gas.…``) and ``engine.firing_order``, never on a
linear key (masses). So each distinct combination of the geometry and gas
keys' values is one gas evaluation, made exactly as :func:`harmbal.analyse`
makes it (:func:`harmbal.model.gas.gas_loads` on the scene's gas grid,
:func:`harmbal.views.evaluation.gas_phasors`), with two shortcuts that are
exact to round-off:

* an IMEP target (``gas.combustion.imep``) moves the pressure affinely (the
  parametric trace is p_motored + Q·p_heat and the IMEP is affine in the heat
  Q, :mod:`harmbal.model.pressure`): the traces at its smallest and largest
  value give every value between;
* a firing order moves only which revolution each cylinder fires in (its
  TDC is fixed by the geometry): each cylinder's phasors are the nominal
  order's times e^{−ik·Δθ} (the shift theorem; Δθ a whole turn, so ±1).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..model.gas import gas_loads
from ..model.sampling import body_decay_rates, choose_samples, simulates_gas
from ..orders.linear import with_geometry_fields
from ..scene import Scene
from ..scene.firing import cylinder_firing
from .keys import toml_value
from .variants import SceneVariants, Variants

#: Keys of the pressure alone (a [gas] table, shared or a cylinder's) and the firing order.
_GAS_KEY = re.compile(r"(cylinder\[\d+\]\.)?gas\..+")
FIRING_ORDER = "engine.firing_order"
#: Gas keys the pressure is affine in (the parametric trace's IMEP target).
_AFFINE_KEY = re.compile(r"(cylinder\[\d+\]\.)?gas\.combustion\.imep")


def is_gas_key(key: str) -> bool:
    """Whether ``key`` changes the gas loads alone (a [gas] key or the firing order)."""
    return key == FIRING_ORDER or _GAS_KEY.fullmatch(key) is not None


@dataclass(frozen=True)
class GasPlan:
    """The gas torque of every distinct combination of the keys it depends on.

    Attributes
    ----------
    columns : list of int
        The plan's key columns the gas depends on (geometry and gas keys).
    combos : ndarray of int
        Sorted numbers of their combinations (:meth:`Variants.combinations`).
    torque : ndarray
        (combination, gas order) complex [N m]: Σ over the cylinders of the
        gas torque's order phasors, orders 0 … ``max_order`` in steps of
        1/``revolutions``.
    revolutions : int
        Revolutions per cycle (2 for a four-stroke: half orders).
    sense : int
        The scene's sense of rotation (the roll moment is −sense·torque).
    moment_scale : float
        The nominal scene's gas moment scale (sum of the cylinders' peak gas torques) [N m].
    """

    columns: list[int]
    combos: np.ndarray
    torque: np.ndarray
    revolutions: int
    sense: int
    moment_scale: float

    def block(self, variants: Variants, start: int, stop: int) -> np.ndarray:
        """(variant, gas order) the gas torque phasors of the variants ``start`` … ``stop - 1``."""
        if not self.columns:
            return np.broadcast_to(self.torque[0], (stop - start,) + self.torque.shape[1:])
        index = variants.index(start, stop)
        return self.torque[np.searchsorted(self.combos, variants.combination(index, self.columns))]

    def orders(self, count: int) -> np.ndarray:
        """The first ``count`` gas orders (k / revolutions)."""
        return np.arange(count) / self.revolutions


def unsupported_with_gas(scene: Scene, options) -> tuple[str, object, str] | None:
    """(key, value, why and the fix) if a sweep of a scene with gas asks what is not swept with gas yet, else None."""
    if len(scene.speeds) > 1:
        rpm = [f"{w * 30 / np.pi:.6g} rpm" for w in scene.speeds]
        return "engine.speed", rpm, ("a sweep with gas takes one speed (the gas couple does not scale with ω², so the "
                                f"amplitudes at {len(scene.speeds)} speeds are not ω² times one speed's): give one "
                                "speed in [engine], or in Python sweep scene.with_speeds([ω]) for each speed")
    if options.peaks:
        return "peaks", True, "peaks over the gas cycle are not swept yet: leave out peaks (--peaks)"
    if options.design:
        return "design", True, ("designs with gas are not swept yet: leave out design (--design), or hb.design "
                                "each variant")
    return None


def gas_plan(reader: SceneVariants, values: Mapping[str, Sequence | np.ndarray], si: Mapping[str, np.ndarray],
             variants: Variants, geometry: Sequence[str], gas_keys: Sequence[str], fields=None,
             backend: str = "scipy", progress: Callable[[int, int], None] | None = None) -> GasPlan | None:
    """The :class:`GasPlan` of a sweep (None if the scene simulates no gas).

    Parameters
    ----------
    reader : SceneVariants
        The swept scene's reader (each gas combination is read through it, which validates it).
    values : mapping
        Every key's values as given.
    si : mapping
        Every key's values in SI (a firing order's: its text).
    variants : Variants
        The variant axis.
    geometry, gas_keys : sequence of str
        The geometry keys and the gas keys (:func:`is_gas_key`).
    fields : FieldMap, optional
        The geometry keys as geometry fields (:mod:`.geometry`); None: read each combination as a scene.
    backend : {"scipy", "numpy", "pyfftw"}
        FFT implementation.
    progress : callable, optional
        ``progress(done, total)`` after each gas evaluation.
    """
    scene = reader.scene
    if not simulates_gas(scene) and not any(k in values for k in gas_keys):
        return None
    keys = list(values)
    depends = [k for k in keys if k in geometry or k in gas_keys]
    columns = [keys.index(k) for k in depends]
    combos = variants.combinations(columns)
    affine = [k for k in gas_keys if _AFFINE_KEY.fullmatch(k)]
    evaluate = _Evaluator(reader, values, si, fields, backend)
    shared: dict[tuple, np.ndarray] = {}   # the torque of each combination of the keys it is not affine in
    torque = None
    for n, combo in enumerate(combos):
        chosen = dict(zip(depends, variants.values_of(int(combo), columns)))
        total = evaluate.affine(chosen, affine, shared)
        if torque is None:
            torque = np.empty((len(combos), total.size), dtype=complex)
        torque[n] = total
        if progress is not None:
            progress(n + 1, len(combos))
    nominal = gas_loads(scene, choose_samples(scene, body_decay_rates(scene)))
    assert torque is not None
    return GasPlan(columns, combos, torque, scene.cycle // 2, scene.sense, float(nominal.moment_scale))


class _Evaluator:
    """Evaluates the gas torque of combinations of key values, each distinct
    trace once (and a firing order by the shift theorem from its trace)."""

    def __init__(self, reader: SceneVariants, values: Mapping, si: Mapping, fields, backend: str):
        self.reader, self.values, self.si, self.fields, self.backend = reader, values, si, fields, backend
        self.cylinders: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}  # per-cylinder phasors, firing angles

    def affine(self, chosen: dict[str, int], affine: list[str], shared: dict) -> np.ndarray:
        """The total torque of ``chosen`` (key → value number): from the traces at the affine keys' extremes."""
        if not affine:
            return self.total(chosen)
        key = affine[0]  # one affine key at a time (several: nested, each exact)
        si = self.si[key]
        low, high = int(np.argmin(si)), int(np.argmax(si))
        x = si[chosen[key]]
        if si[high] == si[low] or x == si[low]:
            return self.affine({**chosen, key: low}, affine[1:], shared)
        if x == si[high]:
            return self.affine({**chosen, key: high}, affine[1:], shared)
        ends = []
        for end in (low, high):
            memo = tuple(sorted({**chosen, key: end}.items()))
            if memo not in shared:
                shared[memo] = self.affine({**chosen, key: end}, affine[1:], shared)
            ends.append(shared[memo])
        t = (x - si[low]) / (si[high] - si[low])
        return ends[0] + t * (ends[1] - ends[0])

    def total(self, chosen: dict[str, int]) -> np.ndarray:
        """Σ over the cylinders of the gas torque phasors of one combination."""
        order_key = chosen.get(FIRING_ORDER)
        rest = {k: i for k, i in chosen.items() if k != FIRING_ORDER}
        memo = tuple(sorted(rest.items()))
        if memo not in self.cylinders:
            scene = self.scene(rest)
            self.cylinders[memo] = (_cylinder_phasors(scene, self.backend), _firing_angles(scene))
        phasors, angles = self.cylinders[memo]
        if order_key is None:
            return phasors.sum(axis=0)
        scene = self.scene(chosen)  # reads (and validates) the order against this geometry
        shift = _firing_angles(scene) - angles  # whole turns: only the revolution each cylinder fires in moves
        order = np.arange(phasors.shape[-1]) / (scene.cycle // 2)
        return (phasors * np.exp(-1j * np.multiply.outer(shift, order))).sum(axis=0)

    def scene(self, chosen: dict[str, int]) -> Scene:
        """The scene of a combination: gas keys (and geometry keys not on the field path) read through the
        reader, field keys written into its geometry fields."""
        geometry = self.fields.keys if self.fields is not None else ()
        read = {k: reader_value(k, self.values[k][i]) for k, i in chosen.items() if k not in geometry}
        scene = self.reader.read(read) if read else self.reader.scene
        if self.fields is not None and any(k in chosen for k in geometry):
            x = [self.si[k][[chosen[k]]] for k in geometry]
            scene = with_geometry_fields(scene, self.fields.fields(x)[0])
        return scene


def reader_value(key: str, value):
    """A swept value as the scene reader takes it (a firing order as a list of cylinder labels)."""
    if key != FIRING_ORDER:
        return toml_value(value)
    return firing_order_labels(value)


def firing_order_labels(value) -> list[str]:
    """A firing order given as ``"1-3-4-2"`` or a sequence of labels, as a list of labels."""
    if isinstance(value, str):
        return [part.strip() for part in value.split("-")]
    return [str(v) for v in value]


def _cylinder_phasors(scene: Scene, backend: str) -> np.ndarray:
    """Each cylinder's gas torque phasors (cylinder, order) as :func:`harmbal.analyse` makes them."""
    from ..views.evaluation import gas_phasors

    loads = gas_loads(scene, choose_samples(scene, body_decay_rates(scene)))
    return gas_phasors(loads, scene.sampling.max_order, backend)[0]


def _firing_angles(scene: Scene) -> np.ndarray:
    return np.asarray(cylinder_firing(scene.cylinders, scene.cycle, scene.firing_order).angle, dtype=float)


