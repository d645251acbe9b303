"""Time the powertrain on its mounts: modes, the forced response of a V8 over
10 000 speeds, and mount design.

* modes: the six undamped modes, the kinetic-energy distribution and the
  torque roll axis of the tractor on its four mounts (target ≤ 1 ms);
* response: the cross-plane V8 with gas (``v8-cross-plane-gas.toml``) on a
  powertrain of 210 kg and four mounts built here (``V8_MOUNTS``, illustrative),
  over 10 000 speeds from 800 to 6 500 rpm and every order up to 12 with the
  half orders: the response and the mounts' forces by the modal expansion per
  order that ``/mounts`` uses (target ≤ 50 ms) and by one direct solve per
  system, in the same run, and the whole ``/mounts`` Dataset with its statics
  and modes;
* design: ``design_mounts`` of the tractor (``tractor-3cyl-mounts.toml``:
  12 variables in 5 groups) and of the same request with every group split
  (12 independent parameters; target ≤ 10 s), each including the scene's
  loads, the written scene read back and both ``/mounts`` Datasets.

Run from the repository root with harmbal installed (or ``PYTHONPATH=.``):

    python benchmarks/bench_mounts.py [--repeat 5]

Figures are the minimum over ``--repeat`` timeit repeats divided by the loop
count after one warm-up call (designs: the fastest of ``--repeat`` calls);
docs/performance.md records them.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import re
from pathlib import Path

from timing import best_seconds, machine, min_seconds

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
SPEEDS = 10_000

#: A ~4 l V8 with its gearbox on four mounts: ILLUSTRATIVE values for the benchmark, not from a source.
V8_MOUNTS = """
[sampling]
max_order = 12

[powertrain]
mass = "210 kg"
cg = ["-60 mm", "0 mm", "140 mm"]
inertia = { xx = "9 kg m^2", yy = "18 kg m^2", zz = "16 kg m^2", xy = "0 kg m^2", xz = "0.8 kg m^2", yz = "0 kg m^2" }
products = "integral"
idle_speed = "700 rpm"
drive_torque = "400 N m"

[[mount]]
name = "front left"
position = ["250 mm", "300 mm", "0 mm"]
stiffness = ["150 N/mm", "150 N/mm", "300 N/mm"]
loss_factor = 0.15

[[mount]]
name = "front right"
position = ["250 mm", "-300 mm", "0 mm"]
stiffness = ["150 N/mm", "150 N/mm", "300 N/mm"]
loss_factor = 0.15

[[mount]]
name = "rear left"
position = ["-450 mm", "250 mm", "50 mm"]
stiffness = ["120 N/mm", "120 N/mm", "250 N/mm"]
loss_factor = 0.15

[[mount]]
name = "rear right"
position = ["-450 mm", "-250 mm", "50 mm"]
stiffness = ["120 N/mm", "120 N/mm", "250 N/mm"]
loss_factor = 0.15
"""


@functools.cache
def v8_scene():
    """The V8 with gas over ``SPEEDS`` speeds on the four mounts above."""
    from harmbal.scene import scene_from_text

    text = (ENGINES / "v8-cross-plane-gas.toml").read_text()
    text = re.sub(r'(?m)^speed = .*$', f'speed = {{ from = "800 rpm", to = "6500 rpm", points = {SPEEDS} }}', text)
    return scene_from_text(text + V8_MOUNTS, str(ENGINES / "v8-cross-plane-gas.toml"))


@functools.cache
def tractor():
    import harmbal as hb

    return hb.load_scene(ENGINES / "tractor-3cyl-mounts.toml")


def _modes(system):
    from harmbal.model import mounts as rigid

    frequency, shapes = rigid.modes(system.mass_matrix, system.stiffness_matrix)
    energy = rigid.energy_distribution(system.mass_matrix, shapes)
    return rigid.tra_angle(rigid.torque_roll_axis(system.inertia), shapes, energy)


def _response_inputs(scene):
    """What the response needs besides the mounts: the loads about the CG
    at unit speed and their speed-independent part (order, 6), the speeds and
    the circular frequencies (speed, order)."""
    import numpy as np

    from harmbal.views.mounts import mount_loads, mount_system

    loads, _ = mount_loads(scene)
    positive = loads.positive()
    speeds = np.asarray(scene.speeds)
    system = mount_system(scene.powertrain, scene.mounts)
    return system, positive, speeds


def _modal(system, loads, speeds):
    """What /mounts computes for mounts without tables: the modal expansion per order, the mounts' forces."""
    from harmbal.model import mounts as rigid

    q = rigid.order_response(system.mass_matrix, system.stiffness_matrix + 1j * system.loss_matrix,
                             system.damping_matrix, 0.0, loads.orders, speeds, *loads.parts_about(system.cg))
    frequency = speeds[:, None] * loads.orders[None, :]
    return rigid.constant_mount_forces(system.axes, system.transforms, system.stiffness * (1 + 1j * system.loss),
                                       system.damping, frequency, q)


def _direct(system, loads, speeds):
    """The dynamic stiffness at every speed and order, one LAPACK solve each, the mounts' forces (the path of
    mounts with frequency tables)."""
    from harmbal.model import mounts as rigid

    frequency = speeds[:, None] * loads.orders[None, :]
    return rigid.direct_response(system.mass_matrix, system.axes, system.transforms,
                                 system.local_stiffness(frequency), frequency, loads.about(system.cg, speeds))[1]


def _dataset(scene):
    from harmbal.views.mounts import mounts

    return mounts(scene)


def _design(split: bool):
    from harmbal.balance.mount_design import design_mounts

    scene = tractor()
    request = scene.mount_design
    if split:
        request = dataclasses.replace(request, variables=tuple(dataclasses.replace(v, group=None)
                                                               for v in request.variables))
    return design_mounts(scene, request=request)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="timeit repeats (the minimum is reported)")
    args = parser.parse_args()
    from harmbal.views.mounts import mount_system

    print(machine(args.repeat))
    print("| what | size | time | target |")
    print("|---|---|---|---|")
    system = mount_system(tractor().powertrain, tractor().mounts)
    t = min_seconds(functools.partial(_modes, system), args.repeat)
    print(f"| modes, energy distribution, TRA angle (tractor) | 6 DOF | {t * 1e6:.0f} µs | ≤ 1 ms |")
    system, loads, speeds = _response_inputs(v8_scene())
    size = f"{speeds.size} speeds × {loads.orders.size} orders × 4 mounts"
    modal = min_seconds(functools.partial(_modal, system, loads, speeds), args.repeat)
    direct = min_seconds(functools.partial(_direct, system, loads, speeds), args.repeat)
    print(f"| V8 forced response and mount forces, modal per order (`/mounts`) | {size} | {modal * 1e3:.1f} ms | "
          "≤ 50 ms |")
    print(f"| the same by one direct solve per system (mounts with tables) | {size} | {direct * 1e3:.1f} ms "
          f"({direct / modal:.1f}× the modal) | |")
    t = best_seconds(functools.partial(_dataset, v8_scene()), max(1, args.repeat // 2))
    print(f"| V8 `/mounts` Dataset (loads, statics, modes, response) | {size} | {t * 1e3:.0f} ms | |")
    for split in (False, True):
        design = _design(split)
        t = best_seconds(functools.partial(_design, split), max(1, args.repeat // 2))
        parameters = len({v.group for v in design.variables}) if not split else len(design.variables)
        print(f"| tractor mount design, {'groups split' if split else 'as bundled'} | {parameters} parameters, "
              f"{design.starts} starts; J {design.objective_before:.1f} → {design.objective_after:.1f} N | "
              f"{t:.2f} s | {'≤ 10 s' if split else ''} |")


if __name__ == "__main__":
    main()
