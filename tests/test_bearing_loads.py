"""Bearing and interface loads (harmbal.loads): Newton–Euler per body with gas,
the block's force balance, the lever rule, the single-cylinder thesis's
interface numbers, and the crank train's loads without gas against joints().

The oracles are written here from the kinematics (crank pin and piston pin in
closed form, derivatives by spectral differentiation), not from the code
under test."""

import tomllib
from pathlib import Path

import numpy as np
import pytest

import harmbal as hb
from harmbal.model.bearings import fastener_load, lever_shares, ramp_torque
from harmbal.scene import SceneError

ENGINES = Path(__file__).resolve().parent.parent / "datasets" / "engines"
N = 256  # samples per revolution: spectral derivatives of the slider-crank to round-off
SINGLE = ENGINES / "test-single-loads-gas.toml"


def spectral(values, order):
    """order-th θ-derivative of samples over one revolution (last axis)."""
    n = values.shape[-1]
    k = np.fft.fftfreq(n, 1.0 / n)
    k[n // 2] = 0
    out = np.fft.ifft(np.fft.fft(values, axis=-1) * (1j * k) ** order, axis=-1)
    return out if np.iscomplexobj(values) else out.real


def cross(p, q):
    return (np.conj(p) * q).imag


def kinematics(cyl, theta):
    """Crank pin A, piston pin B, rod axis u, crank axis and the rod's CG in the w-plane."""
    turn = np.exp(1j * cyl.bank)
    psi = theta + cyl.throw - cyl.bank
    r, l, e = cyl.crank_radius, cyl.rod_length, cyl.pin_offset + cyl.cylinder_offset
    a = r * np.exp(1j * psi) * turn
    b = (r * np.cos(psi) + np.sqrt(l * l - (e - r * np.sin(psi)) ** 2) + 1j * e) * turn
    u = (b - a) / l
    g = a + complex(cyl.rod.cg_from_big_end, cyl.rod.cg_lateral) * u
    return a, b, u, np.exp(1j * (theta + cyl.throw)), g


def unit_motion(values_one_rev, revs):
    """Second derivative over one revolution, tiled over the cycle."""
    return np.tile(spectral(values_one_rev, 2), revs)


def w_of(ds, name, cyl_label, frame_axis):
    """A local-frame vector variable back in the w-plane."""
    v = ds[name].sel(cylinder=cyl_label).values
    return (v[0] + 1j * v[1]) * frame_axis


@pytest.fixture(scope="module", params=["test-single-loads-gas", "tractor-3cyl-gas", "tractor-3cyl",
                                        "v8-cross-plane-gas"])
def case(request):
    scene = hb.load_scene(ENGINES / f"{request.param}.toml")
    scene = scene.with_speeds(scene.speeds[-1:])  # the V8's sweep: its highest speed
    return scene, hb.loads(scene, samples_per_rev=N)


def test_newton_euler_every_body_with_and_without_gas(case):
    scene, ds = case
    revs = int(ds.attrs["revolutions"])
    theta = ds.angle.values
    one = theta[:N]
    w2 = scene.speeds[0] ** 2
    gas = ds["gas_force"].values if "gas_force" in ds else np.zeros((len(scene.cylinders), theta.size))
    scale = max(float(ds.big_end_force_peak.max()), 1.0)
    tol = 1e-9 * scale
    for i, cyl in enumerate(scene.cylinders):
        a, b, u, crank, g = (np.tile(v, revs) for v in kinematics(cyl, one))
        acc_b = w2 * unit_motion(kinematics(cyl, one)[1], revs)
        acc_g = w2 * unit_motion(kinematics(cyl, one)[4], revs)
        # the rod's angle ϑ: u = e^{iϑ}; ϑ'' from the unwrapped angle over one revolution
        rod_angle = np.unwrap(np.angle(kinematics(cyl, one)[2]))
        dd_angle = w2 * np.tile(spectral(rod_angle - rod_angle[0], 2), revs)
        small = w_of(ds, "small_end_force", cyl.label, u)  # piston pin on rod
        big = w_of(ds, "big_end_force", cyl.label, u)  # crank pin on rod
        pin_load = w_of(ds, "crank_pin_force", cyl.label, crank)  # rod on crank pin
        bore = np.exp(1j * cyl.bank)
        wall = -ds["side_thrust"].sel(cylinder=cyl.label).values * 1j * bore  # wall on piston
        gas_on_piston = -gas[i] * bore
        # piston (translates): rod on piston + wall + gas = m·a_B
        np.testing.assert_allclose(-small + wall + gas_on_piston - cyl.piston.mass * acc_b, 0, atol=tol)
        # the wall pushes across the bore only
        np.testing.assert_allclose((np.conj(bore) * wall).real, 0, atol=tol)
        # rod: forces and moment about its CG
        np.testing.assert_allclose(big + small - cyl.rod.mass * acc_g, 0, atol=tol)
        moment = cross(a - g, big) + cross(b - g, small) - cyl.rod.inertia * dd_angle
        np.testing.assert_allclose(moment, 0, atol=tol * cyl.rod_length)
        # the crank pin carries the reaction of the big end
        np.testing.assert_allclose(pin_load + big, 0, atol=tol)
        # piston moment about the pin: wall couple + gas force on the bore axis (pin_offset from the pin)
        couple = ds["wall_couple"].sel(cylinder=cyl.label).values
        gas_moment = cross(-1j * cyl.pin_offset * bore, gas_on_piston)
        np.testing.assert_allclose(couple + gas_moment, 0, atol=tol * cyl.rod_length)


def test_gas_torque_on_the_crank_is_the_virtual_work_torque():
    # tangential crank-pin force × r, gas part = the gas torque of /torque (T = −P·dc_B/dψ)
    scene = hb.load_scene(ENGINES / "tractor-3cyl-gas.toml")
    ds = hb.loads(scene, samples_per_rev=N)
    inertia = hb.loads(scene.with_effects(scene.model.effects - {"gas"}), samples_per_rev=N)
    torque = hb.analyse(scene.with_effects(scene.model.effects))["torque"].ds  # its own sampling
    gas_part = (ds.crank_pin_force.sel(crank_axis="tangential").values
                - np.tile(inertia.crank_pin_force.sel(crank_axis="tangential").values, 2)) * 0.060
    expected = torque.gas_torque.interp(angle=ds.angle.values).values
    scale = np.abs(torque.gas_torque.values).max()
    # /torque is sampled finer; linear interpolation between its samples limits the agreement
    np.testing.assert_allclose(gas_part, expected, atol=2e-3 * scale)
    from harmbal.model.gas import gas_loads

    exact = gas_loads(scene, N).torque
    np.testing.assert_allclose(gas_part, exact, atol=1e-9 * scale)


def test_block_force_balance_with_gas_balancers_and_static_loads():
    # Σ main bearings + Σ shaft bearings + Σ piston on wall + Σ gas on the heads − static loads = shaking force
    scene = hb.load_scene(SINGLE)
    ds = hb.loads(scene, samples_per_rev=N)
    sim = hb.simulate(scene, samples_per_rev=N)
    sense = scene.sense
    total = ds.main_bearing_force.sum("bearing") + ds.shaft_bearing_force.sum(["shaft", "shaft_bearing"])
    total = total.transpose("axis", "angle").values
    for i, cyl in enumerate(scene.cylinders):
        bore = np.exp(1j * cyl.bank)
        w = ds["side_thrust"].isel(cylinder=i).values * 1j * bore + ds["gas_force"].isel(cylinder=i).values * bore
        total = total + np.stack([-sense * w.imag, w.real])
    static = np.zeros(2)
    for load in scene.loads.static_loads:
        static += load.force
    for element in scene.loads.elements:
        for load in element.static_loads:
            static += np.asarray(load.force) * len(element.shafts)
    shaking = sim.force.sel(axis=["y", "z"]).values
    assert shaking.shape[-1] == total.shape[-1]
    scale = float(ds.big_end_force_peak.max())
    np.testing.assert_allclose(total - static[:, None], shaking, atol=1e-9 * scale)


def test_main_bearings_without_gas_sum_to_joints_D_and_split_by_the_lever_rule():
    scene = hb.load_scene(SINGLE)
    scene = scene.with_effects(scene.model.effects - {"gas"})
    ds = hb.loads(scene, samples_per_rev=N)
    js = hb.joints(scene, samples_per_rev=N)
    weight = np.array([0.0, -20 * 9.80665])
    d = js.joint_force.sel(joint="D").transpose("axis", "angle").values
    main = ds.main_bearing_force.transpose("bearing", "axis", "angle").values
    scale = float(js.joint_force_peak.max())
    # the load on the bearings is minus the frame's force on the crankshaft, plus the flywheel's weight
    np.testing.assert_allclose(main.sum(axis=0), -d + weight[:, None], atol=1e-11 * scale)
    # the first moment about bearing 1: only the crank pin (86 mm), the unbalances and the flywheel have arms
    x1, x2 = 0.020, 0.152
    e = js.joint_force.sel(joint="E1").transpose("axis", "angle").values
    arms = -e * (0.086 - x1)
    for u in scene.crankshaft_unbalances + tuple(u for s in scene.shafts if s.on_crank for u in s.unbalances):
        w = u.unbalance * scene.speeds[0] ** 2 * np.exp(1j * (js.angle.values + u.angle))
        arms = arms + np.stack([-scene.sense * w.imag, w.real]) * (u.x - x1)
    arms = arms + weight[:, None] * (-0.040 - x1)
    np.testing.assert_allclose(main[1] * (x2 - x1), arms, atol=1e-11 * scale * x2)


def test_loads_without_gas_equal_joints_for_existing_scenes():
    for name in ("tractor-3cyl", "lever-single", "v8-cross-plane"):
        scene = hb.load_scene(ENGINES / f"{name}.toml")
        ds, js = hb.loads(scene, samples_per_rev=N), hb.joints(scene, samples_per_rev=N)
        if "speed" in js.dims:  # a sweep: compare at its first speed
            ds, js = ds.isel(speed=0), js.isel(speed=0)
        assert ds.attrs["gas"] == "no" and ds.sizes["angle"] == N
        scale = float(js.joint_force_peak.max())
        for cyl in scene.cylinders:
            _, _, u, crank, _ = kinematics(cyl, ds.angle.values)
            for name_, joint, axis, sign in (("big_end_force", "E", u, 1), ("small_end_force", "F", u, -1),
                                             ("crank_pin_force", "E", crank, -1)):
                w = sign * w_of(ds, name_, cyl.label, axis)
                yz = js.joint_force.sel(joint=f"{joint}{cyl.label}").transpose("axis", "angle").values
                np.testing.assert_allclose(np.stack([-scene.sense * w.imag, w.real]), yz, atol=1e-12 * scale)
        # the same peaks
        for cyl in scene.cylinders:
            assert float(ds.big_end_force_peak.sel(cylinder=cyl.label)) == pytest.approx(
                float(js.joint_force_peak.sel(joint=f"E{cyl.label}")), rel=1e-12)


def test_gas_is_affine_over_speeds():
    scene = hb.load_scene(ENGINES / "tractor-3cyl-gas.toml")
    speeds = np.array([1000.0, 2000.0, 2460.0]) * np.pi / 30
    sweep = hb.loads(scene.with_speeds(speeds), samples_per_rev=64)
    for k, w in enumerate(speeds):
        one = hb.loads(scene.with_speeds([w]), samples_per_rev=64)
        for name in ("crank_pin_force", "side_thrust", "crank_pin_force_peak", "big_end_force_mean"):
            np.testing.assert_allclose(sweep[name].isel(speed=k).values, one[name].values, rtol=1e-12,
                                       atol=1e-9 * float(one.crank_pin_force_peak.max()))


def test_lever_rule():
    bearings = [0.0, 0.2095]
    # the thesis's belt pull: 569 N at arms 266 / 56.5 mm over a span of 209.5 mm
    shares = lever_shares(bearings, [0.266])[:, 0] * 569
    assert shares[1] == pytest.approx(569 * 266 / 209.5, abs=1e-9) == pytest.approx(722.45, abs=0.01)
    assert shares[0] == pytest.approx(-569 * 56.5 / 209.5, abs=1e-9) == pytest.approx(-153.45, abs=0.01)
    # several bearings in any order: shares of the two neighbours, sums 1, first moment x
    xs = np.array([0.3, -0.1, 0.1, 0.5])
    loads = np.array([-0.2, -0.1, 0.0, 0.05, 0.1, 0.29, 0.5, 0.7])
    s = lever_shares(xs, loads)
    np.testing.assert_allclose(s.sum(axis=0), 1, atol=1e-15)  # scale: 1 (shares)
    np.testing.assert_allclose(xs @ s, loads, atol=1e-15)  # scale: 0.5 m (positions)
    assert (np.count_nonzero(np.abs(s) > 1e-15, axis=0) <= 2).all()
    np.testing.assert_allclose(s[:, 3], [0, 0.25, 0.75, 0], atol=1e-15)  # scale: 1; 0.05 between -0.1 and 0.1


def test_the_single_cylinder_theses_interface_numbers():
    # reference-engines.md, "B, continued"
    omega = 2300 * np.pi / 30
    f_i = 10944.0
    data = tomllib.loads(SINGLE.read_text())
    data["lanchester_pair"][0]["unbalance"] = f"{f_i / 2 / omega**2!r} kg m"  # each shaft carries F_I/2
    scene = hb.load_scene(data)
    ds = hb.loads(scene.with_effects(scene.model.effects - {"gas"}), samples_per_rev=64)
    np.testing.assert_allclose(ds.shaft_bearing_rotating.values, f_i / 4, rtol=1e-12)  # 2 736 N, centred shaft
    assert f_i / 4 == 2736
    static = ds.shaft_bearing_static.sel(axis="z").values
    np.testing.assert_allclose(static, [[569 * 56.5 / 209.5, -569 * 266 / 209.5]] * 2, rtol=1e-12)
    assert -static[0, 1] == pytest.approx(722.5, abs=0.05) and static[0, 0] == pytest.approx(153.5, abs=0.1)
    # the ramp 750 -> 2200 rpm in 0.5 s: α = 303.7 rad/s², 0.011 kg m² -> 3.34 N m
    assert float(ds.ramp_alpha) == pytest.approx(np.pi * (2200 - 750) / (30 * 0.5), rel=1e-12)
    assert float(ds.ramp_alpha) == pytest.approx(303.7, abs=0.05)
    torque = ds.ramp_torque.values[~np.isnan(ds.ramp_torque.values)]
    np.testing.assert_allclose(torque, 3.34, atol=0.005)
    np.testing.assert_allclose(ds.ramp_power.values[2:], torque * 2200 * np.pi / 30, rtol=1e-12)
    assert ramp_torque(0.011, 303.7, 241)[0] == pytest.approx(3.34, abs=0.005)
    # fasteners: ½·2.174 kg·241²·0.0507 m = 3 201 N; the balance-shaft blank ½·3.399·241²·0.0325 = 3 208 N
    assert fastener_load(2.174 * 0.0507, 241, 2) == pytest.approx(3201, abs=0.5)
    assert fastener_load(3.399 * 0.0325, 241, 2) == pytest.approx(3208, abs=0.5)
    # in the Dataset: U·ω_max²/n of each element
    top = 2300 * np.pi / 30
    expected = [s.unbalances[0].unbalance * top**2 / 2 for s in scene.shafts]
    np.testing.assert_allclose(ds.fastener_load.values, expected, rtol=1e-12)


def _bad(mutate):
    data = tomllib.loads(SINGLE.read_text())
    mutate(data)
    with pytest.raises(SceneError) as info:
        hb.load_scene(data)
    return str(info.value)


def test_bad_loads_tables_name_the_key():
    assert "loads.main_bearings" in _bad(lambda d: d["loads"].update(main_bearings=["20 mm"]))
    assert "distinct" in _bad(lambda d: d["loads"].update(main_bearings=["20 mm", "20 mm"]))
    assert "loads.element[1].label" in _bad(lambda d: d["loads"]["element"][0].update(label="nope"))
    assert "loads.element[1].bearings" in _bad(lambda d: d["loads"]["element"][0].update(bearings=["0 m", "1 m"]))
    assert "loads.static_load[1]" in _bad(lambda d: d["loads"]["static_load"][0].update(force=["0 N", "1 N"]))
    assert "loads.ramp.time" in _bad(lambda d: d["loads"]["ramp"].update(time="0 s"))
    assert "loads.element[3].fasteners" in _bad(lambda d: d["loads"]["element"][2].update(fasteners=0))

    def no_main(d):
        del d["loads"]["main_bearings"]
    assert "needs loads.main_bearings" in _bad(no_main)


def test_cli_loads_prints_tables_writes_an_archive_and_refuses_bad_input(tmp_path, capsys):
    from harmbal.cli import main

    out = tmp_path / "loads.nc"
    assert main(["loads", str(SINGLE), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    for words in ("Crank train", "side thrust", "Main bearings", "Balance-shaft bearings", "Fastener loads",
                  "Drive torque of the speed ramp 750 -> 2200 rpm", "2736.8", "722.45", "3.3406"):
        assert words in text, words
    archived = hb.open_archive(out)["loads"].ds
    fresh = hb.loads(hb.load_scene(SINGLE))
    np.testing.assert_allclose(archived.main_bearing_force.values, fresh.main_bearing_force.values, rtol=1e-15)
    assert main(["show", str(out)]) == 0 and "Main bearings" in capsys.readouterr().out
    # a loads archive holds no analysis to report: exit 2 with the reason, no page
    page = tmp_path / "loads.html"
    assert main(["report", str(out), "-o", str(page)]) == 2
    assert "no analysis" in capsys.readouterr().err and not page.exists()
    # bad input: exit 2, the file and key named, nothing written
    data = SINGLE.read_text().replace('main_bearings = ["20 mm", "152 mm"]', 'main_bearings = ["20 mm"]')
    bad = tmp_path / "bad.toml"
    bad.write_text(data)
    out2 = tmp_path / "bad.nc"
    assert main(["loads", str(bad), "-o", str(out2)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "loads.main_bearings" in err and not out2.exists()
    assert main(["loads", str(SINGLE), "-o", str(tmp_path / "loads.txt")]) == 2
    # a scene without [loads]: the crank train alone
    assert main(["loads", str(ENGINES / "inline-4.toml")]) == 0
    text = capsys.readouterr().out
    assert "Crank train" in text and "Main bearings" not in text


def test_analyse_adds_loads_only_when_the_scene_asks():
    assert "loads" in hb.analyse(hb.load_scene(SINGLE)).children
    assert "loads" not in hb.analyse(hb.load_scene(ENGINES / "tractor-3cyl-gas.toml")).children


def test_report_has_a_loads_section_with_polar_diagrams(tmp_path):
    text = hb.report(hb.analyse(hb.load_scene(SINGLE)))
    section = text[text.index('<section id="loads">'):text.index('<section id="provenance">')]
    for gid in ("crank-pin-1", "crank-pin-peak-1", "big-end-1", "main-bearing-1", "main-bearing-2",
                "main-bearing-peak-2"):
        assert f'id="{gid}"' in section, gid
    for words in ("Main bearings", "Balance-shaft bearings", "Fastener loads at 2300 rpm", "Drive torque", "2736.8 N",
                  "722.45 N", "Orders of the main-bearing force", "<th>0.5 co</th>", "<th>3 counter</th>"):
        assert words in section, words
    # a scene without [loads] has no such section
    assert 'id="loads"' not in hb.report(hb.analyse(hb.load_scene(ENGINES / "tractor-3cyl-gas.toml")))


def _transverse_moment(forces_yz, x):
    """Moment about the origin (M_y, M_z) of forces (y, z) (..., axis, angle) acting in planes x (...)."""
    x = np.asarray(x)[..., None]
    return np.stack([-(x * forces_yz[..., 1, :]).sum(axis=0), (x * forces_yz[..., 0, :]).sum(axis=0)])


def test_block_moment_balance_with_couple_unbalances_and_a_balance_shaft():
    # Every moving body is planar in its own plane x, the crankshaft and the balance shaft carry couple
    # unbalances: the moments of all the block's loads about the transverse axes are the shaking moment.
    data = tomllib.loads((ENGINES / "tractor-3cyl-balanced.toml").read_text())
    data["balance_shaft"][0].update(axis_position=["30 mm", "-90 mm"],
                                    unbalance=[{"unbalance": "0.02 kg m", "angle": "40 deg",
                                                "axial_position": "100 mm"}])
    data["counterweight"] = [{"label": "front web", "unbalance": "0.05 kg m", "angle": "180 deg",
                              "axial_position": "180 mm"}]
    data["loads"] = {"main_bearings": ["204 mm", "68 mm", "-68 mm", "-204 mm"],
                     "element": [{"label": "balance shaft", "bearings": ["150 mm", "-150 mm"]}]}
    scene = hb.load_scene(data)
    ds = hb.loads(scene, samples_per_rev=N)
    sim = hb.simulate(scene, samples_per_rev=N)
    main = ds.main_bearing_force.transpose("bearing", "axis", "angle").values
    shaft = ds.shaft_bearing_force.isel(shaft=0).transpose("shaft_bearing", "axis", "angle").values
    sense = scene.sense
    walls = []
    for cyl in scene.cylinders:
        w = ds["side_thrust"].sel(cylinder=cyl.label).values * 1j * np.exp(1j * cyl.bank)
        walls.append(np.stack([-sense * w.imag, w.real]))
    walls = np.array(walls)
    # forces: the shaking force again (no gas here)
    scale = float(ds.big_end_force_peak.max())
    total = main.sum(axis=0) + shaft.sum(axis=0) + walls.sum(axis=0)
    np.testing.assert_allclose(total, sim.force.sel(axis=["y", "z"]).values, atol=1e-9 * scale)
    moment = (_transverse_moment(main, scene.loads.main_bearings) + _transverse_moment(shaft, [0.150, -0.150])
              + _transverse_moment(walls, [c.x for c in scene.cylinders]))
    np.testing.assert_allclose(moment, sim.moment.sel(axis=["y", "z"]).values, atol=1e-9 * scale * 0.3)


def test_lever_balancer_couplers_load_the_main_bearings():
    data = tomllib.loads((ENGINES / "lever-single.toml").read_text())
    data["loads"] = {"main_bearings": ["-40 mm", "40 mm"]}
    data["lever_balancer"][0]["axial_position"] = "25 mm"  # off the cylinder's plane: the moments tell
    data["cylinder"][0]["axial_position"] = "-10 mm"
    scene = hb.load_scene(data)
    ds, js = hb.loads(scene, samples_per_rev=N), hb.joints(scene, samples_per_rev=N)
    d = js.joint_force.sel(joint="D").transpose("axis", "angle").values
    scale = float(js.joint_force_peak.max())
    main = ds.main_bearing_force.transpose("bearing", "axis", "angle").values
    np.testing.assert_allclose(main.sum(axis=0), -d, atol=1e-11 * scale)
    # moments: main bearings, the walls at the cylinder's plane and the rocker pivot (−A on the block)
    sense = scene.sense
    cyl, lever = scene.cylinders[0], scene.levers[0]
    w = ds["side_thrust"].values[0] * 1j * np.exp(1j * cyl.bank)
    wall = np.stack([-sense * w.imag, w.real])[None]
    pivot = -js.joint_force.sel(joint=f"{lever.label}: A").transpose("axis", "angle").values[None]
    moment = (_transverse_moment(main, scene.loads.main_bearings) + _transverse_moment(wall, [cyl.x])
              + _transverse_moment(pivot, [lever.x]))
    sim = hb.simulate(scene, samples_per_rev=N)
    np.testing.assert_allclose(moment, sim.moment.sel(axis=["y", "z"]).values, atol=1e-9 * scale * 0.3)


def test_a_sweeps_loads_round_trip_through_an_archive(tmp_path):
    scene = hb.load_scene(SINGLE).with_speeds([100.0, 200.0, 250.0])
    tree = hb.analyse(scene)
    hb.save(tree, tmp_path / "sweep.nc")
    back = hb.open_archive(tmp_path / "sweep.nc")["loads"].ds
    for name, values in tree["loads"].ds.data_vars.items():
        np.testing.assert_allclose(back[name].values, values.values, rtol=1e-13, err_msg=name)
