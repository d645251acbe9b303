"""Labelled arrays at the public edge: conventions, the speed axis, and xarray
objects built once from plain arrays.

Every stage below works on plain numpy arrays; the public functions turn their
results into :class:`xarray.Dataset` and :class:`xarray.DataTree` here, in one
step each with the final coordinates and attributes (xarray's general
constructors align, merge and copy, which costs ten times the arithmetic of a
whole analysis; :func:`dataset` and :func:`tree` skip that work for inputs
that are aligned by construction, and fall back to the public constructors
if xarray's internals ever change).

Speeds. Inertial loads at constant speed are the unit-speed loads times ω².
A scene with several speeds therefore keeps only the unit-speed arrays: a
variable over ``speed`` is a lazy product (:func:`speed_scaled`) that is
multiplied out only for the speeds selected or when its values are read, so
a 10⁶-speed sweep holds no per-speed array.
"""

from __future__ import annotations

import functools

import numpy as np

AXES = ("x", "y", "z")

CONVENTIONS = (
    "Engine frame: x along the crank axis towards the front (pulley end), y to the right seen from the "
    "front, z up; right-handed. Crank angle theta in the direction of rotation, 0 when throw 1 points along +z. "
    "force, moment: exerted by the moving parts on the block; moment about the scene's reference point. "
    "See docs/conventions.md."
)

#: Attribute of an archived variable stored at unit speed (see :mod:`harmbal.io.archive`).
SPEED_SCALING = "speed_scaling"
SPEED_SCALING_RULE = "stored at 1 rad/s: the value at crank speed w [rad/s] is the stored value times w**2"
#: Suffix of the archived speed-independent part (gas loads) of a speed-scaled variable.
SPEED_INDEPENDENT = "_speed_independent"


class _SpeedScaled:
    """Lazy ω²-scaled values: ``values[s, ...] = w2[s] * unit[...] + constant[...]``.

    A backend array in xarray's sense (shape, dtype, explicit indexing), so
    that a Variable holding it is indexed lazily and multiplied out only
    where read. ``unit`` holds the inertial values at ω = 1 rad/s,
    ``constant`` (None: zero) the part that does not depend on the speed
    (the gas loads).
    """

    def __init__(self, w2: np.ndarray, unit: np.ndarray, constant: np.ndarray | None = None):
        self.w2 = np.asarray(w2, dtype=float)
        self.unit = np.asarray(unit)
        if constant is not None and np.shape(constant) != self.unit.shape:
            constant = np.broadcast_to(constant, self.unit.shape)
        self.constant = constant
        self.shape = self.w2.shape + self.unit.shape
        self.dtype = np.result_type(self.w2, self.unit, *(() if constant is None else (self.constant,)))

    def __getitem__(self, key):
        from xarray.core import indexing

        return indexing.explicit_indexing_adapter(key, self.shape, indexing.IndexingSupport.OUTER, self._outer)

    def _outer(self, key: tuple):
        w2 = self.w2[key[0]]
        unit, constant = self.unit, self.constant
        for axis in reversed(range(unit.ndim)):  # last axis first: an integer key drops no axis before it
            index = (slice(None),) * axis + (key[axis + 1],)
            unit = unit[index]
            constant = None if constant is None else constant[index]
        values = np.multiply.outer(w2, unit) if np.ndim(w2) else w2 * unit
        return values if constant is None else values + constant


@functools.cache
def _speed_scaled_class():
    # Made on first use: xarray's BackendArray is imported only when a Dataset is built.
    from xarray.backends import BackendArray

    return type("SpeedScaled", (_SpeedScaled, BackendArray), {"__slots__": ()})


def speed_scaled(w2, unit, constant=None):
    """The lazy ``w2`` (speed,) × ``unit`` (...) + ``constant`` (...)."""
    return _speed_scaled_class()(w2, unit, constant)


def _lazy(variable):
    from xarray.core import indexing

    data = getattr(variable, "_data", None)
    if not isinstance(data, indexing.LazilyIndexedArray) or not isinstance(data.array, _SpeedScaled):
        return None
    if any(k != slice(None) for k in data.key.tuple):
        return None
    return data.array


def unit_speed_values(variable):
    """The unit-speed (inertial) array behind a variable built by
    :meth:`Speeds.variable` over several speeds (None if it is not such a
    variable or has been indexed since)."""
    lazy = _lazy(variable)
    return None if lazy is None else lazy.unit


def speed_independent_values(variable):
    """The speed-independent part (gas loads) of such a variable, None if it has none."""
    lazy = _lazy(variable)
    return None if lazy is None else lazy.constant


class Speeds:
    """The scene's speeds [rad/s] as the leading dimension of speed-dependent
    variables: none for one speed (values at that speed), ``speed`` for
    several (lazy ω² products of the unit-speed values)."""

    def __init__(self, speeds):
        speeds = np.atleast_1d(np.asarray(speeds, dtype=float))
        self.several = speeds.size > 1
        self.lead = ("speed",) if self.several else ()
        self.values = speeds if self.several else speeds[0]
        self.w2 = self.values**2

    def coords(self) -> dict:
        """The ``speed`` [rad/s] and ``rpm`` coordinates."""
        return {
            "speed": variable(self.lead, self.values, {"units": "rad/s", "long_name": "crank speed ω"}),
            "rpm": variable(self.lead, self.values * 30 / np.pi, {"units": "rpm", "long_name": "crank speed"}),
        }

    def scaled(self, unit, constant=None):
        """Values ``unit`` [at ω = 1 rad/s] times ω² (plus ``constant``, the
        speed-independent part), multiplied out, with a leading speed axis if
        several (for small arrays)."""
        values = np.multiply.outer(self.w2, unit) if self.several else self.w2 * np.asarray(unit)
        return values if constant is None else values + constant

    def variable(self, dims: tuple, unit, attrs: dict, constant=None):
        """A variable of values ``unit`` [at ω = 1 rad/s] times ω², plus
        ``constant`` (the speed-independent gas loads) if given."""
        import xarray as xr
        from xarray.core import indexing

        if not self.several:
            return variable(dims, self.scaled(unit, constant), attrs)
        lazy = speed_scaled(self.w2, unit, None if constant is None else np.asarray(constant))
        data = indexing.LazilyIndexedArray(lazy, _whole(lazy.ndim))
        if not _direct_variables():  # pragma: no cover - an xarray that changed
            return xr.Variable(self.lead + dims, data, attrs)
        var = object.__new__(xr.Variable)
        var._dims, var._data, var._attrs, var._encoding = self.lead + tuple(dims), data, dict(attrs), None
        return var


@functools.cache
def _whole(ndim: int):
    """The key that selects a whole array of ``ndim`` dimensions (immutable, shared)."""
    from xarray.core import indexing

    return indexing.BasicIndexer((slice(None),) * ndim)


def dataset(data: dict, coords: dict, attrs: dict):
    """A Dataset from Variables (or ``(dims, values, attrs)`` tuples) that
    are aligned by construction: dimension coordinates are indexed, nothing
    is merged or copied. Falls back to ``xarray.Dataset`` if xarray's
    internals differ from what this expects."""
    import xarray as xr

    data = {name: _as_variable(v) for name, v in data.items()}
    coords = {name: _as_variable(v) for name, v in coords.items()}
    try:
        return _dataset_direct(data, coords, attrs)
    except (AttributeError, TypeError, ValueError, ImportError):  # pragma: no cover - an xarray that changed
        return xr.Dataset(data, coords, attrs)


def _as_variable(value):
    import xarray as xr

    return value if isinstance(value, xr.Variable) else variable(*value)


def variable(dims, values, attrs: dict | None = None):
    """``xarray.Variable(dims, values, attrs)``, built directly for plain
    numeric, boolean and string arrays (the constructor's checks and
    conversions cost fifteen times the assignment; they change nothing for
    these), through the constructor for anything else."""
    import xarray as xr

    dims = (dims,) if isinstance(dims, str) else tuple(dims)
    if type(values) is not np.ndarray:
        if not isinstance(values, (list, tuple, float, int, bool, complex, np.generic)):
            return xr.Variable(dims, values, attrs)
        values = np.asarray(values)
    if values.dtype.kind not in _PLAIN_KINDS or values.ndim != len(dims) or not _direct_variables():
        return xr.Variable(dims, values, attrs)
    var = object.__new__(xr.Variable)
    var._dims, var._data, var._attrs, var._encoding = dims, values, dict(attrs) if attrs else None, None
    return var


#: dtype kinds that ``xarray.Variable`` stores as the numpy array it is given.
_PLAIN_KINDS = frozenset("biufcUS")


@functools.cache
def _direct_variables() -> bool:
    """Whether this xarray's Variable is what :func:`variable` assumes (its
    four slots, and a plain array stored as given); checked once per process."""
    import xarray as xr

    values = np.arange(3.0)
    try:
        reference = xr.Variable(("a",), values, {"u": 1})
        direct = object.__new__(xr.Variable)
        direct._dims, direct._data, direct._attrs, direct._encoding = ("a",), values, {"u": 1}, None
        return (set(xr.Variable.__slots__) == {"_dims", "_data", "_attrs", "_encoding"}
                and reference._data is values and direct.identical(reference))
    except (AttributeError, TypeError):  # pragma: no cover - an xarray that changed
        return False


def _dataset_direct(data: dict, coords: dict, attrs: dict):
    import xarray as xr

    variables, indexes, dims = {}, {}, {}
    for name, var in {**coords, **data}.items():
        for dim, size in zip(var.dims, var.shape):
            if dims.setdefault(dim, size) != size:
                raise ValueError(f"{name}: dimension {dim} has sizes {dims[dim]} and {size}")
        variables[name] = var
    for name, var in coords.items():
        if var.dims == (name,):
            indexes[name], variables[name] = _indexed(name, var)
    names = list(coords) + [n for n in data if n not in coords]
    return xr.Dataset._construct_direct({n: variables[n] for n in names}, set(coords), dims, attrs=dict(attrs),
                                        indexes=indexes)


def _indexed(name: str, variable):
    """The pandas index of a dimension coordinate and the coordinate as the
    IndexVariable that wraps it. Indexes are immutable, so one serves every
    Dataset with the same coordinate values (axis, order, rotation, angle …);
    building it is the dearest part of a Dataset."""
    if variable.size > 1 << 13:  # a long sweep's speeds: not worth keeping
        index = _pandas_index(name, variable)
        return index, index.create_variables({name: variable})[name]
    key = (name, variable.dtype.str, variable.shape, variable.values.tobytes())
    cached = _INDEXES.get(key)
    if cached is None:
        if len(_INDEXES) > 256:
            _INDEXES.clear()
        index = _pandas_index(name, variable)
        cached = _INDEXES[key] = (index, index.create_variables({name: variable})[name])
    index, template = cached
    # The template's data (an indexing adapter of the immutable pandas index) is shared; attributes are not.
    coordinate = object.__new__(type(template))
    coordinate._dims, coordinate._data = template._dims, template._data
    coordinate._attrs = dict(variable._attrs) if variable._attrs else None
    coordinate._encoding = dict(variable._encoding) if variable._encoding else None
    return index, coordinate


def _pandas_index(name: str, variable):
    # Built directly: PandasIndex.from_variables checks for unit-aware arrays and so imports pint (60 ms).
    import pandas as pd
    from xarray.core.indexes import PandasIndex

    return PandasIndex(pd.Index(variable.values), name, coord_dtype=variable.dtype)


_INDEXES: dict = {}


def tree(root_attrs: dict, groups: dict):
    """A DataTree of a root node with ``root_attrs`` and one child per
    Dataset in ``groups`` (name → Dataset, no coordinates in the root), the
    Datasets attached as they are instead of copied and re-aligned."""
    import xarray as xr

    try:
        return _tree_direct(root_attrs, groups)
    except (AttributeError, TypeError):  # pragma: no cover - an xarray that changed
        return xr.DataTree.from_dict({"/": xr.Dataset(attrs=root_attrs), **{f"/{k}": v for k, v in groups.items()}})


def _tree_direct(root_attrs: dict, groups: dict):
    import xarray as xr

    root = xr.DataTree(dataset({}, {}, root_attrs))
    for name, ds in groups.items():
        node = xr.DataTree.__new__(xr.DataTree)
        node._set_node_data(ds)
        node._parent = None
        node._children = {}
        node._name = name
        root._children[name] = node
        node._parent = root
    return root
