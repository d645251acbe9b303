"""harmbal.labelled: the direct construction of xarray objects and its public fallback.

The direct path (private slots, ``Dataset._construct_direct``, ``DataTree._set_node_data``) is used
only while ``labelled.fast_path()`` holds. Oracles: xarray's public constructors. The fallback is
forced here (``fast_path`` monkeypatched to False) and every output of every bundled scene, a sweep,
a Monte Carlo run and a 10⁴-speed (lazy) analysis must be the same to the bit, with the same
variables in the same order, the same indexes and attributes; and the first-use check must refuse a
direct path that differs from the public one in any slot, or that raises.
"""

import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import harmbal as hb
from harmbal import labelled

ROOT = Path(__file__).resolve().parent.parent
SCENES = (sorted((ROOT / "datasets" / "engines").glob("*.toml"))
          + sorted((ROOT / "datasets" / "examples").glob("*.toml")))


@pytest.fixture
def public(monkeypatch):
    """Within the test, every xarray object is built through xarray's public constructors."""
    monkeypatch.setattr(labelled, "fast_path", lambda: False)


def _both(make):
    """``make()`` by the direct path, then by the public constructors."""
    assert labelled.fast_path()
    direct = make()
    saved = labelled.fast_path
    labelled.fast_path = lambda: False
    try:
        return direct, make()
    finally:
        labelled.fast_path = saved


def _assert_same_dataset(a: xr.Dataset, b: xr.Dataset, where: str):
    """Same to the bit through the public API: variables in order, their types, dims, dtypes, values'
    bytes, attributes and encodings; coordinates; indexes (names, order, type, equal); attributes."""
    assert list(a.variables) == list(b.variables), where
    assert list(a.coords) == list(b.coords) and list(a.xindexes) == list(b.xindexes), where
    for name, index in a.xindexes.items():
        assert type(index) is type(b.xindexes[name]) and index.equals(b.xindexes[name]), f"{where} index {name}"
    assert _same_mapping(a.attrs, b.attrs) and _same_mapping(a.encoding, b.encoding), where
    for name, var in a.variables.items():
        other = b.variables[name]
        assert type(var) is type(other) and var.dims == other.dims and var.dtype == other.dtype, f"{where}/{name}"
        assert _same_mapping(var.attrs, other.attrs) and _same_mapping(var.encoding, other.encoding), f"{where}/{name}"
        assert var.values.tobytes() == other.values.tobytes(), f"{where}/{name}"
    assert a.identical(b), where


def _same_mapping(a: dict, b: dict) -> bool:
    """Same keys in the same order, values of the same type and bits (attributes may hold arrays)."""
    return list(a) == list(b) and all(
        type(a[k]) is type(b[k]) and np.asarray(a[k]).dtype == np.asarray(b[k]).dtype
        and np.asarray(a[k]).tobytes() == np.asarray(b[k]).tobytes() for k in a)


def _assert_same_tree(a: xr.DataTree, b: xr.DataTree, name: str):
    assert [n.path for n in a.subtree] == [n.path for n in b.subtree], name
    for node, other in zip(a.subtree, b.subtree):
        _assert_same_dataset(node.to_dataset(inherit=False), other.to_dataset(inherit=False), f"{name}:{node.path}")
    assert a.identical(b), name
    assert labelled._same_state(a, b), name


def test_the_fast_path_holds_on_the_xarray_pyproject_pins():
    # Fails on an xarray whose internals moved: harmbal is then right but slower; widen the pin only
    # once the direct path is fixed for it.
    assert labelled.fast_path.__wrapped__() is True


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.name)
def test_every_bundled_scene_is_the_same_to_the_bit_through_the_public_constructors(path):
    try:
        scene = hb.load_scene(path)
    except hb.SceneError:
        pytest.skip("a scene that is refused on purpose")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        direct, public = _both(lambda: hb.analyse(scene))
    _assert_same_tree(direct, public, path.name)


def test_a_long_speed_sweep_is_lazy_and_the_same_on_both_paths():
    scene = hb.load_scene(ROOT / "datasets" / "engines" / "v8-cross-plane.toml")
    sweep = scene.with_speeds(np.linspace(600, 8000, 10_000) * np.pi / 30)
    direct, public = _both(lambda: hb.analyse(sweep))
    _assert_same_tree(direct, public, "10⁴ speeds")
    for tree in (direct, public):
        force = tree["time"].dataset.variables["force"]
        assert force.size > labelled.EAGER_VALUES
        assert labelled.unit_speed_values(force) is not None  # the lazy product, recognised on both paths


def test_sweeps_and_monte_carlo_are_the_same_on_both_paths():
    scene = hb.load_scene(ROOT / "datasets" / "engines" / "v-twin-90.toml")
    direct, public = _both(lambda: hb.sweep(scene, {"geometry.rod_length": np.linspace(0.12, 0.14, 3),
                                                   "piston.mass": np.linspace(0.38, 0.42, 2)}))
    _assert_same_dataset(direct, public, "sweep")
    direct, public = _both(lambda: hb.monte_carlo(scene, {"piston.mass": hb.Normal(0.002)}, 50, seed=1))
    _assert_same_dataset(direct, public, "monte carlo")


def test_the_unit_speed_values_are_found_on_both_paths(public):
    speeds = labelled.Speeds([10.0, 20.0])
    unit = np.array([1.0, -2.0, 0.5])
    var = speeds.variable(("axis",), unit, {"units": "N"})
    assert labelled.unit_speed_values(var) is unit
    np.testing.assert_array_equal(var.values, np.outer(speeds.w2, unit))


def test_the_public_datasets_are_what_xarray_dataset_makes():
    speeds = labelled.Speeds([10.0, 20.0, 30.0])
    data = {"force": (("speed", "axis"), np.ones((3, 3)), {"units": "N"})}
    coords = {**speeds.coords(), "axis": labelled.variable("axis", np.array(labelled.AXES))}
    made = labelled._dataset_public({k: labelled._as_variable(v) for k, v in data.items()}, coords, {"t": 1})
    plain = labelled.with_speed_indexes(xr.Dataset(data, coords, {"t": 1}))
    assert made.identical(plain)
    assert {k: type(v) for k, v in made.xindexes.items()} == {k: type(v) for k, v in plain.xindexes.items()}
    assert all(made.xindexes[k].equals(plain.xindexes[k]) for k in plain.xindexes)
    assert made.sel(rpm=float(speeds.rpm[1])).identical(plain.sel(rpm=float(speeds.rpm[1])))


def test_the_check_refuses_a_direct_path_that_differs_or_fails(monkeypatch):
    direct_variable = labelled._direct_variable

    def with_encoding(dims, data, attrs):
        var = direct_variable(dims, data, attrs)
        var._encoding = {"dtype": "float32"}  # one slot off: what a changed xarray might make of it
        return var

    monkeypatch.setattr(labelled, "_direct_variable", with_encoding)
    assert labelled.fast_path.__wrapped__() is False
    monkeypatch.setattr(labelled, "_direct_variable", direct_variable)
    assert labelled.fast_path.__wrapped__() is True

    def broken(*args):
        raise AttributeError("'DataTree' object has no attribute '_set_node_data'")

    monkeypatch.setattr(labelled, "_tree_direct", broken)
    assert labelled.fast_path.__wrapped__() is False


def test_the_state_comparison_sees_a_slot_set_on_one_side_only():
    a = xr.Variable(("x",), np.arange(3.0))
    b = xr.Variable(("x",), np.arange(3.0))
    assert labelled._same_state(a, b)
    b._data = np.array([-0.0, 1.0, 2.0])  # equal by ==, not to the bit
    assert not labelled._same_state(a, b)
    c = object.__new__(xr.Variable)
    c._dims, c._data, c._attrs = ("x",), a._data, None  # no _encoding at all
    assert not labelled._same_state(a, c)
