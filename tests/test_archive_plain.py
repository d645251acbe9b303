"""Archives any netCDF reader gets right, and speeds selectable in rpm (issue 33).

Oracles: the values of :func:`harmbal.analyse` at each speed, read back by
plain ``xarray.open_dataset`` and netCDF4-python, which know nothing of
harmbal; pint and UDUNITS-2 (through cf_units) for the units strings; xarray's
own exact-match selection for ``sel(rpm=...)``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import harmbal as hb
from harmbal.io.archive import PER_SPEED_LIMIT, per_speed_bytes
from harmbal.labelled import EAGER_VALUES, rpm_values, unit_speed_values

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
#: Round-off allowed relative to the load scale at each speed (two paths multiply by ω² in other orders).
RTOL = 1e-12


@pytest.fixture(scope="module")
def v8():
    return hb.load_scene(ENGINES / "v8-cross-plane.toml")  # 3 000 and 6 000 rpm


def _at_rpm(scene, rpm):
    return scene.with_speeds(np.asarray(rpm, dtype=float) * np.pi / 30)


def _sweep(v8, count: int):
    return {1: _at_rpm(v8, [3000]), 2: v8, 10_000: _at_rpm(v8, np.linspace(600, 8000, 10_000))}[count]


def _joined(real, imag):
    return np.asarray(real) + 1j * np.asarray(imag)


def _assert_close(got, want, scale):
    """|got − want| ≤ RTOL × the moment scale at each speed (leading axis, if any)."""
    scale = np.asarray(scale, dtype=float).reshape(np.shape(scale) + (1,) * (np.ndim(want) - np.ndim(scale)))
    assert np.shape(got) == np.shape(want)
    assert np.all(np.abs(got - want) <= RTOL * scale)


@pytest.mark.parametrize("count", [1, 2, 10_000])
def test_plain_readers_get_the_moment_at_every_speed(v8, tmp_path, count):
    scene = _sweep(v8, count)
    tree = hb.analyse(scene)
    assert per_speed_bytes(tree) <= PER_SPEED_LIMIT
    path = hb.save(tree, tmp_path / "v8.nc")
    orders = tree["orders"].ds
    want, scale = orders.moment.sel(order=1).values, orders.moment_scale.values
    with xr.open_dataset(path, group="orders") as plain:
        moment = plain.moment.sel(order=1)
        assert moment.attrs["units"] == "N m" and "speed_scaling" not in moment.attrs
        _assert_close(_joined(moment.sel(part="real"), moment.sel(part="imag")), want, scale)
        if count > 1:
            assert moment.dims[0] == "speed"
            np.testing.assert_array_equal(plain.speed.values, scene.speeds)  # in the group itself
            assert plain.speed.attrs["units"] == "rad/s" and plain.rpm.attrs["units"] == "rpm"
    netCDF4 = pytest.importorskip("netCDF4")
    with netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        group = nc["orders"]
        stored = group["moment"]
        k = list(group["order"][:]).index(1)
        values = np.take(stored[:], k, axis=stored.dimensions.index("order"))
        _assert_close(_joined(values[..., 0], values[..., 1]), want, scale)
        if count > 1:
            assert stored.dimensions == ("speed", "order", "axis", "part")
            np.testing.assert_array_equal(group["speed"][:], scene.speeds)
        assert "speed" not in nc.variables and "speed_storage" not in nc.ncattrs()


def test_the_bundled_v8_reads_as_harmbal_prints_it(v8, tmp_path):
    # The report of issue 33: 0.0184 and 0.0061 (the 1 rad/s values) where harmbal gives 1 918 and 7 673 N m.
    path = hb.save(hb.analyse(v8), tmp_path / "v8.nc")
    with xr.open_dataset(path, group="orders") as plain:
        moment = plain.moment.sel(order=1)
        amplitude = np.abs(_joined(moment.sel(part="real"), moment.sel(part="imag"))).max(axis=-1)
    np.testing.assert_allclose(amplitude, [1918, 7673], rtol=5e-4)  # as the issue quotes them, to 4 digits


def test_beyond_the_limit_the_unit_speed_form_has_names_no_one_misreads(v8, tmp_path):
    rpm = np.linspace(600, 8000, 1_000_000)
    tree = hb.analyse(_at_rpm(v8, rpm))
    assert per_speed_bytes(tree) > PER_SPEED_LIMIT
    path = hb.save(tree, tmp_path / "sweep.nc")
    some = [0, 123_456, 999_999]
    orders = tree["orders"].ds.isel(speed=some)
    netCDF4 = pytest.importorskip("netCDF4")
    with netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        assert nc.getncattr("speed_storage").startswith("unit speed")
        group = nc["orders"]
        assert not {"force", "moment", "moment_scale"} & set(group.variables)  # no per-speed name, no misreading
        stored = group["moment_per_speed_squared"]
        assert stored.getncattr("units") == "N m s^2/rad^2" and stored.getncattr("per_speed_units") == "N m"
        assert stored.getncattr("per_speed_name") == "moment"
        assert stored.getncattr("formula") == "moment = moment_per_speed_squared * speed**2"
        assert stored.dimensions == ("order", "axis", "part")
        k = list(group["order"][:]).index(1)
        unit = _joined(stored[k, :, 0], stored[k, :, 1])
        speed = nc["speed"][:][some]  # the root group's, which every group sees
        _assert_close(speed[:, None] ** 2 * unit, orders.moment.sel(order=1).values, orders.moment_scale.values)
    back = hb.open_archive(path)
    for name in ("time", "orders", "stars"):
        got, want = back[name].to_dataset(inherit=False), tree[name].to_dataset(inherit=False)
        xr.testing.assert_identical(got.isel(speed=some), want.isel(speed=some))
        xr.testing.assert_identical(got.speed, want.speed)
        for var in want.data_vars:  # the same lazy ω² products, not multiplied out
            unit = unit_speed_values(want[var].variable)
            assert (unit is None) == (unit_speed_values(got[var].variable) is None), var
            if unit is not None:
                np.testing.assert_array_equal(unit_speed_values(got[var].variable), unit)


def test_gas_part_of_the_unit_speed_form(tmp_path):
    tree = hb.analyse(hb.load_scene(ENGINES / "v8-cross-plane-gas.toml"))
    path = hb.save(tree, tmp_path / "gas.nc", per_speed_limit=0)  # the large-sweep form, forced
    with xr.open_datatree(path) as plain:
        orders = plain["orders"].ds
        stored, part = orders.moment_per_speed_squared, orders.moment_speed_independent_part
        assert stored.attrs["formula"] == "moment = moment_per_speed_squared * speed**2 + moment_speed_independent_part"
        assert stored.attrs["ancillary_variables"] == "moment_speed_independent_part"
        assert part.attrs["units"] == "N m" and "moment_speed_independent" not in orders
        rebuilt = orders.speed**2 * stored + part
        want = tree["orders"].ds.moment
        got = _joined(rebuilt.sel(part="real"), rebuilt.sel(part="imag"))
        _assert_close(got, want.transpose(*rebuilt.sel(part="real").dims).values, tree["orders"].ds.moment_scale.values)


@pytest.mark.parametrize("stem", ["v8-cross-plane", "v8-cross-plane-gas", "tractor-3cyl-loads-gas"])
def test_open_archive_reads_both_forms_to_the_same_tree(stem, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = hb.load_scene(ENGINES / f"{stem}.toml")
        tree = hb.analyse(scene.with_speeds([150.0, 400.0, 700.0]), per_cylinder=True)
    per_speed = hb.open_archive(hb.save(tree, tmp_path / "a.nc"))
    unit_speed = hb.open_archive(hb.save(tree, tmp_path / "b.nc", per_speed_limit=0))
    for node in tree.subtree:
        want = node.to_dataset(inherit=False)
        for back in (per_speed, unit_speed):
            xr.testing.assert_identical(back[node.path].to_dataset(inherit=False), want)
            assert set(back[node.path].to_dataset(inherit=False).xindexes) == set(want.xindexes)
    assert per_speed.attrs == unit_speed.attrs == tree.attrs


def test_cf_conventions_and_no_lowercase_conventions(v8, tmp_path):
    netCDF4 = pytest.importorskip("netCDF4")
    path = hb.save(hb.analyse(v8), tmp_path / "v8.nc")
    with netCDF4.Dataset(path) as nc:
        assert nc.getncattr("Conventions") == "CF-1.10"
        assert "crank axis" in nc.getncattr("harmbal_conventions")
        # one attribute that a case-blind reader could take for CF's: none other than the root's Conventions
        for group in [nc, *nc.groups.values()]:
            conventions = [a for a in group.ncattrs() if a.lower() == "conventions"]
            assert conventions == (["Conventions"] if group is nc else [])


# ---------------------------------------------------------------------------------------------------------------
# units strings: pint and UDUNITS-2 (cf_units, in the test extra) parse each, to the same SI value


def _units_in(path) -> dict:
    """Every ``units`` attribute of the archive, as netCDF4-python reads it: units → a variable that has it."""
    netCDF4 = pytest.importorskip("netCDF4")
    found = {}

    def walk(group, where):
        for name, var in group.variables.items():
            if "units" in var.ncattrs():
                found.setdefault(var.getncattr("units"), f"{where}/{name}")
        for name, child in group.groups.items():
            walk(child, f"{where}/{name}")

    with netCDF4.Dataset(path) as nc:
        walk(nc, "")
    return found


def _units_of(tree) -> dict:
    """Every ``units`` attribute of an analysis tree in memory: units → a variable that has it."""
    return {var.attrs["units"]: f"{node.path}/{name}" for node in tree.subtree
            for name, var in node.to_dataset(inherit=False).variables.items() if "units" in var.attrs}


#: Scenes whose archives have every kind of group: /torque, /loads, /joints, /verify, /clearance.
EVERY_GROUP = ("v8-cross-plane-gas", "tractor-3cyl-loads-gas", "lever-single", "inline-3-balanced")


def _archives(tmp_path):
    """Archives of both forms with every kind of group, a design sweep's, a Monte Carlo run's and a loads
    archive as the command line writes them."""
    from harmbal.analysis import scene_dataset
    from harmbal.labelled import tree
    from harmbal.views.loads import loads

    scenes = [ENGINES / f"{stem}.toml" for stem in EVERY_GROUP] + [ROOT / "datasets" / "examples" /
                                                                    "test-single-shapes.toml"]
    for i, path in enumerate(scenes):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            swept = hb.analyse(hb.load_scene(path).with_speeds([100.0, 300.0]), per_cylinder=True)
        yield hb.save(swept, tmp_path / f"{i}.nc")
        yield hb.save(swept, tmp_path / f"{i}-0.nc", per_speed_limit=0)
    single = hb.load_scene(ENGINES / "test-single.toml")
    ds = hb.sweep(single, {"piston.mass": ["300 g", "450 g"], "geometry.rod_length": [0.1, 0.11]}, design=True,
                  peaks=True)
    yield hb.save(tree({}, {"scene": scene_dataset(single), "sweep": ds}), tmp_path / "sweep.nc")
    mc = hb.monte_carlo(single.with_speeds([100.0, 300.0]), {"piston.mass": hb.Normal(0.002)}, 20, seed=1,
                        force_limit=10.0)
    yield hb.save(tree({}, {"sweep": mc}), tmp_path / "mc.nc")
    loaded = hb.load_scene(ENGINES / "tractor-3cyl-loads-gas.toml")
    yield hb.save(tree({}, {"scene": scene_dataset(loaded), "loads": loads(loaded)}), tmp_path / "loads.nc")


def _si(ureg, units: str) -> tuple[float, str]:
    """pint's reading of ``units``: its SI value and the SI units as a UDUNITS-2 string."""
    q = ureg.Quantity(1.0, units).to_base_units()
    terms = [f"{ureg.get_symbol(name)}^{int(power) if float(power).is_integer() else power}"
             for name, power in q.unit_items()]
    return q.magnitude, " ".join(terms) or "1"


def test_every_units_string_parses_with_pint_and_udunits_alike(tmp_path):
    import cf_units  # UDUNITS-2 (the test extra installs it)
    import pint

    from harmbal.io.archive import per_speed_squared_units

    ureg = pint.UnitRegistry()
    found = {}
    # Every bundled scene's tree (its archive stores these attributes as they are, and the unit-speed form
    # each ω²-scaled one as per_speed_squared_units), then archives written (0.4 s each) with every group.
    for path in sorted(ENGINES.glob("*.toml")) + sorted((ROOT / "datasets" / "examples").glob("*.toml")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = hb.load_scene(path)
            for tree in (hb.analyse(scene, per_cylinder=True),
                         hb.analyse(scene.with_speeds([100.0, 300.0]), per_cylinder=True)):
                for units, where in _units_of(tree).items():
                    found.setdefault(units, f"{path.name}{where}")
                    found.setdefault(per_speed_squared_units(units), f"{path.name}{where} per speed squared")
    for path in _archives(tmp_path):
        for units, where in _units_in(path).items():
            found.setdefault(units, f"{path.name}{where}")
        path.unlink()
    assert {"N", "N m", "rad", "rad/s", "rpm", "kg m^2", "m^3", "Pa", "N m s^2/rad^2"} <= set(found)  # seen
    for units, where in found.items():
        magnitude, si = _si(ureg, units)  # pint parses it (else raises, naming it)
        assert cf_units.Unit(units).convert(1.0, cf_units.Unit(si)) == pytest.approx(magnitude, rel=1e-12), (
            units, where)


# ---------------------------------------------------------------------------------------------------------------
# rpm: an index along speed, exact match


def _with_speed(tree):
    return {node.path: node.to_dataset(inherit=False) for node in tree.subtree if "speed" in node.dims}


def _assert_selects_by_rpm(ds, rpm, where):
    assert "rpm" in ds.xindexes and ds.xindexes["rpm"].dim == "speed", where
    xr.testing.assert_identical(ds.sel(rpm=rpm[1]), ds.isel(speed=1))
    xr.testing.assert_identical(ds.sel(rpm=list(rpm)), ds)
    with pytest.raises(KeyError):
        ds.sel(rpm=rpm[1] + 1)  # a speed not present: loud, not the nearest
    with pytest.raises(KeyError):
        ds.sel(rpm=rpm[1] * (1 + 1e-9))


def test_every_dataset_over_speed_selects_by_rpm(tmp_path):
    rpm = [1500.0, 2865.0, 6000.0]  # 2865 rpm: speed·30/π alone gives 2864.9999999999995
    cases = {stem: _at_rpm(hb.load_scene(ENGINES / f"{stem}.toml"), rpm)
             for stem in ("v8-cross-plane", "v8-cross-plane-gas", "tractor-3cyl-loads-gas", "inline-3-balanced",
                          "lever-single")}
    for stem, scene in cases.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            trees = {"analyse": hb.analyse(scene)}
        if stem == "v8-cross-plane-gas":  # archives of the other groups: test_open_archive_reads_both_forms_…
            trees["archive"] = hb.open_archive(hb.save(trees["analyse"], tmp_path / "a.nc"))
            trees["unit-speed archive"] = hb.open_archive(hb.save(trees["analyse"], tmp_path / "b.nc",
                                                                  per_speed_limit=0))
        for label, tree in trees.items():
            groups = _with_speed(tree)
            assert set(groups) == set(_with_speed(trees["analyse"])) and groups, (stem, label)
            for path, ds in groups.items():
                np.testing.assert_array_equal(ds.rpm.values, rpm)
                _assert_selects_by_rpm(ds, rpm, f"{stem} {path} {label}")
    v8 = cases["v8-cross-plane"]
    time = hb.simulate(v8)
    for name, ds in {"simulate": time, "order_spectrum": hb.order_spectrum(time), "stars": hb.stars(v8),
                     "verify_orders": hb.verify_orders(v8), "joints": hb.joints(cases["lever-single"]),
                     "verify": hb.verify(cases["inline-3-balanced"]),
                     "sweep": hb.sweep(v8, {"piston.mass": [0.5, 0.6]})}.items():
        _assert_selects_by_rpm(ds, rpm, name)


def test_speeds_given_in_rpm_are_labelled_by_those_numbers():
    from harmbal.scene.units import to_si

    typed = np.concatenate([np.arange(1, 20_001, 7), [2460, 2865, 3000, 6000, 7250.5, 1234.125, 999.9]])
    speeds = np.array([to_si(f"{n} rpm", "speed") for n in typed])
    np.testing.assert_array_equal(rpm_values(speeds), typed)
    np.testing.assert_array_equal(rpm_values(typed * np.pi / 30), typed)
    # any other speed: speed·30/π to the last bit or within a few units in the last place of it
    other = np.linspace(50.0, 800.0, 1001)
    np.testing.assert_allclose(rpm_values(other), other * 30 / np.pi, rtol=1e-13, atol=0)


# ---------------------------------------------------------------------------------------------------------------
# numbers in notebooks


def test_a_modest_sweep_shows_its_numbers(v8):
    orders = hb.analyse(v8)["orders"].ds
    for shown in (repr(orders), repr(orders.moment), orders._repr_html_(), repr(hb.simulate(v8).force)):
        assert "values with dtype" not in shown
    assert "1.81976787e+03" in repr(orders.moment.sel(rpm=3000, order=1))  # −1 819.77 − 606.59j N m, order 1, y


def test_a_huge_sweep_stays_lazy(v8):
    speeds = np.linspace(50.0, 800.0, 10_000)
    orders = hb.analyse(v8.with_speeds(speeds))["orders"].ds
    assert orders.moment.size > EAGER_VALUES and "values with dtype" in repr(orders.moment)
    assert unit_speed_values(orders.moment.variable) is not None
    # small variables of the same sweep hold their values
    assert orders.moment_scale.size <= EAGER_VALUES and isinstance(orders.moment_scale.variable._data, np.ndarray)


def test_multiplied_out_values_keep_their_unit_speed_array_until_changed(v8):
    time = hb.simulate(v8)
    force = time.force.variable
    assert isinstance(force._data, np.ndarray)
    unit = unit_speed_values(force)
    np.testing.assert_array_equal(np.multiply.outer(time.speed.values**2, unit), force.values)
    assert unit_speed_values(time.force.isel(speed=0).variable) is None
    with pytest.raises(ValueError, match="read-only"):
        force.values[0, 0, 0] += 1.0  # as for a lazy product, whose values cannot be assigned to
    force.values.flags.writeable = True
    force.values[0, 0, 0] += 1.0
    assert unit_speed_values(force) is None  # changed in place: no longer the product
