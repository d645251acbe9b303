"""netCDF archives: exact round trip, readable by plain netCDF tools, atomic writes."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import harmbal as hb

ROOT = Path(__file__).resolve().parent.parent

SCENE_TOML = """\
[engine]
name = "archive-test"
description = "two-cylinder V with offsets, two speeds"
speed = ["1500 rpm", "3000 rpm"]
rotation = "clockwise"
reference_point = ["20 mm", 0, 0]

[model]
effects = ["reciprocating", "rotating", "rod_inertia", "mass_torque"]
rod = "rigid"

[geometry]
crank_radius = "45 mm"
rod_length = "150 mm"
pin_offset = "0.5 mm"

[piston]
mass = "0.8 kg"

[rod]
mass = "0.7 kg"
cg_from_big_end = "45 mm"
inertia = "0.0035 kg m^2"

[[cylinder]]
label = "L1"
bank = "-45 deg"

[[cylinder]]
label = "R1"
bank = "45 deg"
axial_position = "22 mm"

[[crankshaft_unbalance]]
unbalance = "0.01 kg m"
angle = "180 deg"
axial_position = "50 mm"
"""


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "v2.toml"
    path.write_text(SCENE_TOML, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def tree(scene_file):
    return hb.analyse(hb.load_scene(scene_file), per_cylinder=True)


@pytest.fixture(scope="module")
def archive(tree, tmp_path_factory):
    path = tmp_path_factory.mktemp("archive") / "result.nc"
    written = hb.save(tree, path)
    assert os.fspath(written) == os.fspath(path)
    return path


def _paths(t):
    return sorted(node.path for node in t.subtree)


def test_round_trip_is_identical(tree, archive):
    back = hb.open_archive(archive)
    assert _paths(back) == _paths(tree) == ["/", "/orders", "/scene", "/stars", "/time"]
    for path in _paths(tree):
        xr.testing.assert_identical(back[path].to_dataset(inherit=False), tree[path].to_dataset(inherit=False))
    # complex phasors come back complex, bit for bit
    assert np.iscomplexobj(back["orders"].ds.force.values)
    np.testing.assert_array_equal(back["orders"].ds.moment_rotating.values, tree["orders"].ds.moment_rotating.values)


def test_round_trip_single_speed(tmp_path):
    scene = hb.load_scene({
        "engine": {"name": "single", "speed": "2000 rpm"},
        "model": {"effects": ["reciprocating", "rotating"], "rod": "two_point"},
        "geometry": {"crank_radius": "30 mm", "rod_length": "100 mm"},
        "piston": {"mass": "0.3 kg"}, "rod": {"mass_big_end": "0.2 kg", "mass_small_end": "0.1 kg"},
        "cylinder": [{}],
    })
    tree = hb.analyse(scene)
    back = hb.open_archive(hb.save(tree, tmp_path / "single.nc"))
    for path in _paths(tree):
        xr.testing.assert_identical(back[path].to_dataset(inherit=False), tree[path].to_dataset(inherit=False))


def test_gas_sweep_round_trip_and_plain_reconstruction(tmp_path):
    # The gas loads do not scale with ω²: the unit-speed form (of large sweeps; forced here) stores them beside
    # the unit-speed inertia as "<name>_speed_independent_part", only for the variables the gas adds to (a pure
    # couple about x: the moment, its tail and scale, the roll's negligible level; no force), and a plain reader
    # rebuilds each speed as stored·ω² + that.
    tree = hb.analyse(hb.load_scene(ROOT / "datasets" / "engines" / "v8-cross-plane-gas.toml"))
    path = hb.save(tree, tmp_path / "v8-gas.nc", per_speed_limit=0)
    back = hb.open_archive(path)
    for group in ("time", "orders", "torque"):
        xr.testing.assert_identical(back[group].to_dataset(inherit=False), tree[group].to_dataset(inherit=False))
    with xr.open_datatree(path) as plain:
        orders = plain["orders"].ds
        companions = sorted(n for n in orders.data_vars if n.endswith("_speed_independent_part"))
        assert companions == ["aliasing_error_moment_speed_independent_part", "moment_scale_speed_independent_part",
                              "moment_speed_independent_part", "roll_negligible_level_speed_independent_part"]
        assert "moment" not in orders.data_vars
        w2 = (orders.speed.values**2)[:, None, None]
        stored = orders.moment_per_speed_squared.isel(part=0).values
        constant = orders.moment_speed_independent_part.isel(part=0).values
        np.testing.assert_array_equal(w2 * stored + constant, tree["orders"].ds.moment.values.real)
        np.testing.assert_array_equal(w2 * orders.force_per_speed_squared.isel(part=0).values,
                                      tree["orders"].ds.force.values.real)


def test_plain_xarray_reads_it(archive, tree):
    with xr.open_datatree(archive) as plain:
        assert set(_paths(plain)) == set(_paths(tree))
        orders = plain["orders"].ds
        # complex values are stored as a trailing real/imag dimension
        assert orders.force.dims[-1] == "part"
        assert list(orders["part"].values) == ["real", "imag"]
        # a modest speed sweep is stored per speed, with the speed coordinates in each group over speed
        assert orders.force.dims[0] == "speed" and "speed" in plain["orders"].to_dataset(inherit=False).coords
        np.testing.assert_array_equal(orders.force.isel(part=0).values, tree["orders"].ds.force.values.real)
        np.testing.assert_array_equal(orders.force.isel(part=1).values, tree["orders"].ds.force.values.imag)
        time = plain["time"].ds
        np.testing.assert_array_equal(time.force.values, tree["time"].ds.force.values)
        for group in ("time", "orders"):
            for name in ("force", "moment"):
                attrs = plain[group].ds[name].attrs
                assert attrs["units"] == ("N" if name == "force" else "N m")
                assert attrs["long_name"]
        assert plain["time"].ds.angle.attrs["units"] == "rad"


def test_netcdf4_library_reads_it(archive, tree, scene_file):
    netCDF4 = pytest.importorskip("netCDF4")
    with netCDF4.Dataset(archive) as nc:
        assert set(nc.groups) == {"scene", "time", "orders", "stars"}
        assert nc["stars"].variables["firing_sequence"][:].tolist() == tree["stars"].ds.firing_sequence.values.tolist()
        assert nc.getncattr("harmbal_version") == hb.__version__
        assert "crank axis" in nc.getncattr("harmbal_conventions") and nc.getncattr("Conventions") == "CF-1.10"
        assert nc["scene"].getncattr("scene_toml") == scene_file.read_text(encoding="utf-8")
        force = nc["time"].variables["force"]
        assert force.getncattr("units") == "N" and force.dimensions[0] == "speed"
        assert force.getncattr("long_name")
        # the speed coordinates are in each group over speed, not in the root
        assert "speed" in nc["time"].variables and "speed" not in nc.variables
        np.testing.assert_array_equal(force[:], tree["time"].ds.force.values)
        moment = nc["orders"].variables["moment"]
        assert moment.getncattr("units") == "N m"
        assert moment.dimensions[-1] == "part"


def test_scene_text_is_kept_for_mappings_too(tmp_path):
    mapping = {
        "engine": {"name": "from-mapping", "speed": 100.0},
        "geometry": {"crank_radius": 0.05, "rod_length": 0.2},
        "piston": {"mass": 1.0}, "rod": {"mass": 1.0, "cg_from_big_end": 0.05, "inertia": 0.01},
        "cylinder": [{}],
    }
    back = hb.open_archive(hb.save(hb.analyse(hb.load_scene(mapping)), tmp_path / "m.nc"))
    import tomllib

    assert tomllib.loads(back["scene"].ds.attrs["scene_toml"]) == mapping


def _leftovers(directory):
    return sorted(p.name for p in directory.iterdir())


def test_failed_write_leaves_nothing(tree, tmp_path, monkeypatch):
    target = tmp_path / "broken.nc"

    def explode(self, filepath, *args, **kwargs):
        filepath.attrs["half"] = "a file"  # half a file (save passes the open HDF5 file), then a crash
        raise OSError("disk full (simulated)")

    monkeypatch.setattr(xr.DataTree, "to_netcdf", explode)
    with pytest.raises(OSError, match="disk full"):
        hb.save(tree, target)
    assert _leftovers(tmp_path) == []


def test_failed_write_keeps_the_old_file(tree, tmp_path):
    target = tmp_path / "keep.nc"
    hb.save(tree, target)
    before = target.read_bytes()
    bad = tree.copy(deep=True)
    bad["time"].attrs["not_serialisable"] = {"a": 1}  # netCDF attributes cannot be dicts
    with pytest.raises((TypeError, ValueError)):
        hb.save(bad, target)
    assert _leftovers(tmp_path) == ["keep.nc"]
    assert target.read_bytes() == before


def test_open_archive_refuses_a_text_file(tmp_path, scene_file):
    with pytest.raises(hb.ArchiveError):
        hb.open_archive(scene_file)
    empty = tmp_path / "empty.nc"
    empty.write_bytes(b"")
    with pytest.raises(hb.ArchiveError):
        hb.open_archive(empty)
    with pytest.raises(FileNotFoundError):
        hb.open_archive(tmp_path / "missing.nc")


@pytest.mark.parametrize("umask", [0o022, 0o077])
def test_written_files_get_the_umask_permissions(tree, tmp_path, umask):
    """Written through a private temporary file, the result still gets the
    permissions of a plainly created file."""
    old = os.umask(umask)
    try:
        hb.save(tree, tmp_path / "a.nc")
        hb.report(tree, tmp_path / "r.html")
    finally:
        os.umask(old)
    for name in ("a.nc", "r.html"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o666 & ~umask
