"""The variant axis of a sweep: which value of each key every variant takes
(:class:`Variants`), and the scene of a variant, read from the swept scene's
text with the variant's values written in (:class:`SceneVariants`)."""

from __future__ import annotations

import copy
import math
import tomllib
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..orders.linear import geometry_key, slot_values
from ..scene import Scene, SceneError, load_scene
from .keys import key_dimension, key_error, set_key

#: How the keys' values make variants: every combination, or the i-th values together.
MODES = ("grid", "zip")


@dataclass(frozen=True)
class Variants:
    """Which of each key's values every variant takes: ``index(start, stop)``
    gives a block's (variant, key) value numbers, never the whole table (10⁷
    variants of 4 keys would hold 320 MB of it).

    Attributes
    ----------
    lengths : tuple of int
        The number of values of each key.
    mode : {"grid", "zip"}
        ``grid``: every combination, the first key varying slowest; ``zip``:
        the i-th values of all keys together.
    """

    lengths: tuple[int, ...]
    mode: str

    @property
    def count(self) -> int:
        return math.prod(self.lengths) if self.mode == "grid" else self.lengths[0]

    def index(self, start: int, stop: int) -> np.ndarray:
        numbers = np.arange(start, stop)
        if self.mode == "grid":  # the first key varies slowest
            return np.stack(np.unravel_index(numbers, self.lengths), axis=-1)
        return np.repeat(numbers[:, None], len(self.lengths), axis=1)

    def combination(self, index: np.ndarray, columns: list[int]) -> np.ndarray:
        """The number of each variant's combination of the values of the keys
        in ``columns`` (of a grid: its flat index among all combinations; of
        zip: the value number, the same for every key)."""
        if self.mode == "grid":
            return np.ravel_multi_index(tuple(index[:, c] for c in columns), tuple(self.lengths[c] for c in columns))
        return index[:, 0]

    def combinations(self, columns: list[int]) -> np.ndarray:
        """The sorted numbers of the combinations that occur (one, of no keys)."""
        if not columns:
            return np.zeros(1, dtype=int)
        return np.arange(math.prod(self.lengths[c] for c in columns) if self.mode == "grid" else self.count)

    def values_of(self, combination: int, columns: list[int]) -> tuple[int, ...]:
        """The value number of each key in ``columns`` in a combination."""
        if self.mode == "grid":
            return tuple(int(i) for i in np.unravel_index(combination, tuple(self.lengths[c] for c in columns)))
        return (int(combination),) * len(columns)

    def value_numbers(self, combinations: np.ndarray, columns: list[int]) -> np.ndarray:
        """:meth:`values_of` of many combinations at once: (combination, key in ``columns``)."""
        combinations = np.asarray(combinations)
        if self.mode == "grid":
            shape = tuple(self.lengths[c] for c in columns)
            return np.stack(np.unravel_index(combinations, shape), axis=-1).reshape(len(combinations), len(columns))
        return np.repeat(combinations[:, None], len(columns), axis=1)


class SceneVariants:
    """Reads variants of one scene through the scene reader, naming the scene's file in errors.

    The variants keep the given scene's speeds (a scene from ``with_speeds`` sweeps at its own speeds,
    one from ``with_negligible`` is judged by its own level); any other difference between the scene and
    its source text is refused, since the variants are read from that text."""

    def __init__(self, scene: Scene):
        if not scene.source_text:
            raise key_error(scene.source, "(scene)", None, "the scene has no source text to vary: load it with "
                            "harmbal.load_scene")
        self.scene = scene
        self.raw = tomllib.loads(scene.source_text)
        self.cache: dict[tuple, Scene] = {}
        self.file = self._load(self.raw)
        # Neither the speeds nor the negligible level change the loads per unit speed (with_speeds, with_negligible).
        model = replace(self.file.model, negligible=scene.model.negligible)
        if geometry_key(replace(self.file, speeds=scene.speeds, model=model)) != geometry_key(scene) or \
                not np.array_equal(slot_values(self.file)[1], slot_values(scene)[1]):
            raise key_error(scene.source, "(scene)", None, "the scene differs from its source text (changed after "
                            "it was read): write the change into the scene file to sweep it")
        self.cache[()] = scene

    def _load(self, raw: dict) -> Scene:
        try:
            return load_scene(raw)
        except SceneError as exc:
            raise SceneError([replace(p, source=self.scene.source) for p in exc.problems]) from None

    def dimension(self, key: str, value: Any) -> str | None:
        """The dimension the scene reader reads ``key`` in, ``value`` written there (:func:`.keys.key_dimension`)."""
        return key_dimension(self.raw, key, value, dict(self.scene.files))

    def read(self, values: dict[str, Any]) -> Scene:
        """The scene with ``values`` (key path → value as the reader takes it) written in, read once."""
        key = tuple(sorted((k, repr(v)) for k, v in values.items()))
        if key not in self.cache:
            raw = copy.deepcopy(self.raw)
            for k, v in values.items():
                set_key(raw, self.scene.source, k, v)
            scene = self._load(raw)
            if (scene.speeds, scene.sampling.max_order) != (self.file.speeds, self.file.sampling.max_order):
                raise key_error(self.scene.source, ", ".join(values), list(values.values()),
                                "a sweep cannot change the speeds or max_order (every variant is reported at the "
                                "scene's speeds and orders)")
            self.cache[key] = replace(scene, speeds=self.scene.speeds, source=self.scene.source)
        return self.cache[key]
