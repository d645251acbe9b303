"""The scene reader's problem collector: the primitives every table's
``read_*`` function reads keys with (a table and its unknown keys, a
quantity converted to SI and checked against its range, an integer, a
choice, a string, lists and arrays of tables), collecting every problem
found instead of stopping at the first, and the warnings to give once the
scene is valid; and the state that tables read in different places share
(:class:`SceneContext`: trace files read and gas tables made).

Each ``read_*`` function of the ``read_*.py`` modules takes a
:class:`Collector` (and what else it needs, explicitly) and returns its
part of the scene; :mod:`.reader` composes them.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, overload

from .ranges import KEY_RANGES, key_problem, magnitude_problem
from .schema import MISSING, Gas, Problem, closest_match, key_path
from .source_files import trace_roots
from .units import QuantityError, to_si


class Collector:
    """Reads keys of the raw scene and collects the problems found.

    Parameters
    ----------
    source : str
        The scene's source, named in every problem and warning.
    dimensions : bool, default False
        Record the dimension of every key read as a quantity in
        :attr:`dimensions` (:func:`~.reader.quantity_dimensions`).

    Attributes
    ----------
    problems : list of Problem
        Every problem found, in the order found, each once.
    warnings : list
        Warnings (texts or Warning instances) to give if the scene is valid.
    dimensions : dict of str to str or None
        Key path -> dimension of every quantity read; None unless asked for.
    """

    def __init__(self, source: str, dimensions: bool = False):
        self.source = source
        self.problems: list[Problem] = []
        self.warnings: list = []
        self.dimensions: dict[str, str] | None = {} if dimensions else None

    def fail(self, key: str, value: Any, rule: str) -> None:
        """Collect the problem that ``value`` at the key path ``key`` breaks ``rule``."""
        problem = Problem(self.source, key, value, rule)
        if problem not in self.problems:  # a shared key is checked once per cylinder
            self.problems.append(problem)

    def table(self, parent: Mapping, key: str, path: str, allowed: set[str], required: bool = False) -> dict:
        """The table ``parent[key]`` (at ``path``) with its unknown keys
        reported; {} if it is missing or not a table."""
        value = parent.get(key, MISSING)
        if value is MISSING:
            if required:
                self.fail(path, MISSING, "missing required table")
            return {}
        if not isinstance(value, Mapping):
            self.fail(path, value, "must be a table")
            return {}
        self.unknown(value, path, allowed)
        return dict(value)

    def unknown(self, table: Mapping, path: str, allowed: set[str]) -> None:
        """Report every key of ``table`` not in ``allowed``, with the closest allowed one."""
        for key in table:
            if key not in allowed:
                hint = closest_match(key, allowed)
                self.fail(key_path(path, key), table[key],
                          "unknown key" + (f" (did you mean {hint!r}?)" if hint else "")
                          + f"; allowed: {', '.join(sorted(allowed))}")

    def quantity(self, table: Mapping, key: str, path: str, dimension: str, default: Any = MISSING,
                 positive: bool = False, nonnegative: bool = False) -> float:
        """``table[key]`` in SI units of ``dimension``, within its range
        (:mod:`.ranges`); nan after a problem."""
        value = table.get(key, default)
        where = key_path(path, key)
        if self.dimensions is not None:
            self.dimensions[where] = dimension
        if value is MISSING:
            self.fail(where, MISSING, "missing required key")
            return math.nan
        try:
            si = to_si(value, dimension)
        except QuantityError as exc:
            self.fail(where, value, str(exc))
            return math.nan
        if dimension == "angle" and not isinstance(value, str) and abs(si) > 2 * math.pi:
            self.fail(where, value, "plain numbers are radians; this looks like degrees, write e.g. "
                      f"\"{value} deg\"")
            return math.nan
        name = key.split("[", 1)[0]
        if dimension == "dimensionless" and name not in KEY_RANGES:
            raise KeyError(f"{where}: a dimensionless key needs its range in harmbal.scene.ranges.KEY_RANGES")
        rule: str | None
        if positive and not si > 0:
            rule = "must be positive"
        elif nonnegative and not si >= 0:
            rule = "must not be negative"
        else:
            rule = key_problem(name, si) or magnitude_problem(dimension, si, positive)  # the narrower first
        if rule:
            # nan, not the value: a value 300 decades off would overflow the reader's own arithmetic (r², a blank's
            # area); every check downstream skips a nan, whose problem is this one.
            self.fail(where, value, rule)
            return math.nan
        return si

    def choice(self, table: Mapping, key: str, path: str, options: tuple, default: Any) -> Any:
        """``table[key]``, one of ``options``; ``default`` if missing or after a problem."""
        value = table.get(key, default)
        if value not in options:
            self.fail(key_path(path, key), value, f"must be one of {', '.join(map(repr, options))}")
            return default
        return value

    @overload
    def integer(self, table: Mapping, key: str, path: str, default: int, minimum: int,
                maximum: int | None = None) -> int: ...

    @overload
    def integer(self, table: Mapping, key: str, path: str, default: None, minimum: int,
                maximum: int | None = None) -> int | None: ...

    def integer(self, table: Mapping, key: str, path: str, default: int | None, minimum: int,
                maximum: int | None = None) -> int | None:
        """An integer from ``minimum`` to ``maximum`` (default: the top of the
        key's range in :data:`~.ranges.KEY_RANGES`, which every integer key has)."""
        bounds = KEY_RANGES[key]
        value = table.get(key, default)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key_path(path, key), value, "must be an integer")
            return default
        if value < minimum:
            self.fail(key_path(path, key), value, f"must be at least {minimum}")
            return default
        top = int(bounds.high) if maximum is None else maximum
        if value > top:
            self.fail(key_path(path, key), value, f"must be at most {top}: {bounds.why}")
            return default
        return value

    def string(self, table: Mapping, key: str, path: str, default: Any = MISSING) -> str:
        """``table[key]`` as a string; "" after a problem."""
        value = table.get(key, default)
        if value is MISSING:
            self.fail(key_path(path, key), MISSING, "missing required key")
            return ""
        if not isinstance(value, str):
            self.fail(key_path(path, key), value, "must be a string")
            return ""
        return value

    def quantity_list(self, table: Mapping, key: str, path: str, dimension: str, length: int,
                      default: Any) -> tuple[float, ...]:
        """A list of ``length`` quantities of ``dimension``; nans after a problem."""
        value = table.get(key, default)
        if not isinstance(value, list) or len(value) != length:
            self.fail(key_path(path, key), value, f"must be a list of {length} quantities")
            return (math.nan,) * length
        items = {f"{key}[{i + 1}]": v for i, v in enumerate(value)}
        return tuple(self.quantity(items, k, path, dimension) for k in items)

    def pair(self, table: Mapping, key: str, path: str, dimension: str, default: Any) -> tuple[float, float]:
        """A list of two quantities of ``dimension`` (:meth:`quantity_list`) as a pair."""
        first, second = self.quantity_list(table, key, path, dimension, 2, default)
        return first, second

    def array(self, raw: Any, path: str) -> list[tuple[str, Mapping]]:
        """Entries of an array of tables with their key paths."""
        if not isinstance(raw, list) or not all(isinstance(e, Mapping) for e in raw):
            self.fail(path, raw, "must be an array of tables ([[...]])")
            return []
        return [(f"{path}[{i + 1}]", e) for i, e in enumerate(raw)]

    def position(self, table: Mapping, key: str, path: str) -> tuple[float, float]:
        """A transverse position [y, z]."""
        return self.pair(table, key, path, "length", [0, 0])

    # -- the scene ---------------------------------------------------------

    def warn(self, warning: Warning) -> None:
        """Keep a warning for when the scene is valid, once (a shared trace is read per cylinder).
        A Warning instance keeps its own category when the reader passes it to ``warnings.warn``."""
        if str(warning) not in map(str, self.warnings):
            self.warnings.append(warning)

    def problems_at(self, path: str) -> bool:
        """Whether a problem was found at ``path`` or inside it."""
        return any(p.key == path or p.key.startswith((path + ".", path + "[")) for p in self.problems)


@dataclass
class SceneContext:
    """What the tables of different cylinders share while a scene is read:
    the files they name and the gas tables they make.

    Attributes
    ----------
    base : Path
        The folder trace files are relative to: the scene file's, or for a
        mapping or a text without a file the working folder.
    roots : tuple of Path
        Folders outside ``base``'s tree that trace files may lie in.
    given : dict of str to str or None
        The texts of the trace files given to the reader, by name as written
        (None: read them from the file system).
    read : dict of str to str
        The texts of the trace files read so far, by name as written.
    gases : list of Gas
        The distinct gas tables made so far (cylinders of equal tables share one).
    """

    base: Path
    roots: tuple = ()
    given: dict[str, str] | None = None
    read: dict[str, str] = field(default_factory=dict)
    gases: list[Gas] = field(default_factory=list)

    @classmethod
    def of(cls, source: str, files: Mapping[str, str] | None = None,
           roots: Iterable[str | os.PathLike] | None = None) -> SceneContext:
        """The shared state of reading the scene ``source`` (``files`` and
        ``roots`` as :func:`~.reader.load_scene` takes them)."""
        # Files a scene names (pressure traces) are relative to the scene file; those of a mapping or a text
        # without a file, to the working directory. They must lie in that folder's tree or in ``roots``.
        base = Path(source).parent if not source.startswith("<") else Path.cwd()
        return cls(base, trace_roots(roots) if files is None else (), None if files is None else dict(files))
