"""The bad-input corpus (issue 32): scenes and arguments an attacker or a
careless user would give, each with what harmbal must answer.

Every case builds its files in a folder of its own (``Case.build``) and names
the text its refusal must hold: the key path (``key``) and the scene file.
``tests/test_corpus.py`` runs every case through every command that reads a
scene, in a subprocess under a memory limit and a time limit per case
(``python tests/corpus.py COMMAND CASES.json RESULTS.json`` is that
subprocess: it calls :func:`harmbal.cli.main` once per case and records the
exit code, stderr, any exception that escaped, and the time).
"""

from __future__ import annotations

import json
import os
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"

#: The commands that read a scene, and how each is called on ``scene`` writing into ``out``.
COMMANDS: dict[str, Callable[[Path, Path], list[str]]] = {
    "run": lambda scene, out: ["run", str(scene), "-o", str(out / "run.nc")],
    "stars": lambda scene, out: ["stars", str(scene), "--plot", str(out / "stars.svg")],
    "design": lambda scene, out: ["design", str(scene), "-o", str(out / "designed.toml")],
    "verify": lambda scene, out: ["verify", str(scene), "--orders", "1,2"],
    "loads": lambda scene, out: ["loads", str(scene), "-o", str(out / "loads.nc")],
    "report": lambda scene, out: ["report", str(scene), "-o", str(out / "report.html")],
    "sweep": lambda scene, out: ["sweep", str(scene), "--set", "piston.mass=0.3:0.5:3", "-o", str(out / "sweep.nc")],
}
#: Seconds one case may take in one command, and the address-space limit of the process running them.
CASE_SECONDS = 30
MEMORY_LIMIT = 3 << 30


@dataclass(frozen=True)
class Case:
    """One bad input: ``build(folder)`` writes it and returns the scene path;
    the refusal (exit ``exit``) must name ``key`` (and the scene file, unless
    ``names_file`` is False). ``commands`` limits the commands it is run
    through; ``args`` gives a command's arguments other than the default."""

    name: str
    category: str
    build: Callable[[Path], Path]
    key: str
    exit: int = 2
    commands: tuple[str, ...] = tuple(COMMANDS)
    args: dict[str, Callable[[Path, Path], list[str]]] = field(default_factory=dict)
    names_file: bool = True

    def argv(self, command: str, scene: Path, out: Path) -> list[str]:
        return self.args.get(command, COMMANDS[command])(scene, out)


# -- building scenes -------------------------------------------------------------------------------

def _toml(data: dict) -> str:
    import tomli_w

    return tomli_w.dumps(data)


def _base(name: str) -> dict:
    return tomllib.loads((ENGINES / f"{name}.toml").read_text(encoding="utf-8"))


def _set(data: dict, path: str, value: Any) -> dict:
    """``data`` with the key ``path`` (dots, and ``[i]`` 1-based for arrays of
    tables) set to ``value`` (``_DELETE`` removes it)."""
    node = data
    parts = path.split(".")
    for part in parts[:-1]:
        name, _, index = part.partition("[")
        node = node.setdefault(name, {})
        if index:
            node = node[int(index.rstrip("]")) - 1]
    last = parts[-1]
    if value is _DELETE:
        node.pop(last, None)
    else:
        node[last] = value
    return data


_DELETE = object()


def edited(base: str, **edits: Any) -> Callable[[Path], Path]:
    """A builder: the bundled scene ``base`` with keys set (``__`` in a
    keyword stands for ``.``, ``_1_`` for ``[1]``)."""
    def build(folder: Path) -> Path:
        data = _base(base)
        for key, value in edits.items():
            _set(data, _key(key), value)
        path = folder / "scene.toml"
        path.write_text(_toml(data), encoding="utf-8")
        return path
    return build


def _key(keyword: str) -> str:
    import re

    return re.sub(r"_(\d+)_", r"[\1]", keyword).replace("__", ".")


def raw(content: bytes | str, name: str = "scene.toml") -> Callable[[Path], Path]:
    """A builder writing ``content`` as it is."""
    def build(folder: Path) -> Path:
        path = folder / name
        path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
        return path
    return build


def text_of(base: str) -> str:
    return (ENGINES / f"{base}.toml").read_text(encoding="utf-8")


def with_trace(file: str | None = None, content: bytes | None = None,
               make: Callable[[Path], None] | None = None, **trace: Any) -> Callable[[Path], Path]:
    """The measured-trace tractor with ``[gas.trace] file = file``; ``content``
    written to ``folder/trace.csv`` first, or ``make(folder)`` run first."""
    def build(folder: Path) -> Path:
        if content is not None:
            (folder / "trace.csv").write_bytes(content)
        if make is not None:
            make(folder)
        data = _base("tractor-3cyl-measured-gas")
        table = data["gas"]["trace"]
        table.update({"file": file} if file is not None else {})
        table.update(trace)
        path = folder / "scene.toml"
        path.write_text(_toml(data), encoding="utf-8")
        return path
    return build


def _good_trace() -> bytes:
    return (ENGINES / "traces" / "tractor-full-load.csv").read_bytes()


def _fifo(name: str) -> Callable[[Path], None]:
    return lambda folder: os.mkfifo(folder / name)


def _symlink(name: str, target: str) -> Callable[[Path], None]:
    return lambda folder: os.symlink(target, folder / name)


def _outside(folder: Path) -> None:
    (folder.parent / f"{folder.name}-outside.csv").write_bytes(_good_trace())


def _escaping_link(folder: Path) -> None:
    outside = folder.parent / f"{folder.name}-elsewhere.csv"
    outside.write_bytes(_good_trace())
    os.symlink(outside, folder / "trace.csv")


def scene_fifo(folder: Path) -> Path:
    path = folder / "scene.toml"
    os.mkfifo(path)
    return path


def scene_link(target: str) -> Callable[[Path], Path]:
    def build(folder: Path) -> Path:
        path = folder / "scene.toml"
        os.symlink(target, path)
        return path
    return build


def directory(folder: Path) -> Path:
    path = folder / "scene.toml"
    path.mkdir()
    return path


def missing(folder: Path) -> Path:
    return folder / "no-such-scene.toml"


def many_cylinders(count: int) -> Callable[[Path], Path]:
    def build(folder: Path) -> Path:
        data = _base("inline-4")
        data["cylinder"] = [{"label": str(i + 1), "throw": f"{(i * 137) % 360} deg",
                             "axial_position": f"{100 * i} mm"} for i in range(count)]
        data["engine"].pop("firing_order", None)
        data.pop("design", None)
        path = folder / "scene.toml"
        path.write_text(_toml(data), encoding="utf-8")
        return path
    return build


def sweep_args(*sets: str) -> dict:
    return {"sweep": lambda scene, out: ["sweep", str(scene), *[a for s in sets for a in ("--set", s)],
                                         "-o", str(out / "sweep.nc")]}


HUGE = 1e300
DENORMAL = 5e-324
NAN, INF = float("nan"), float("inf")


# -- the corpus ------------------------------------------------------------------------------------

def cases() -> list[Case]:
    """Every case, in categories: files, strings, structure, ranges, firing,
    gas, traces, balancers and requests, work bounds, sweep arguments, mounts."""
    return [*_files(), *_strings(), *_structure(), *_ranges(), *_firing(), *_gas(), *_traces(), *_balancers(),
            *_work(), *_sweeps(), *_mounts()]


def _files() -> list[Case]:
    tractor = text_of("tractor-3cyl")
    return [
        Case("binary", "file", raw(bytes(range(256)) * 8), "(file)"),
        Case("latin-1", "file", raw(tractor.replace("tractor", "tractør").encode("latin-1", "replace")), "UTF-8"),
        Case("utf-16", "file", raw(tractor.encode("utf-16")), "UTF-8"),
        Case("directory", "file", directory, "directory"),
        Case("fifo", "file", scene_fifo, "regular file"),
        Case("dev-zero", "file", scene_link("/dev/zero"), "regular file"),
        Case("oversize", "file", raw(tractor + "#" * (1 << 20)), "larger than"),
        Case("toml-syntax", "file", raw(tractor.replace("[engine]", "[engine")), "TOML"),
        Case("empty", "file", raw(""), "engine"),
        Case("missing", "file", missing, "no-such-scene.toml"),
        Case("nul-byte-text", "file", raw(tractor.replace("[engine]", "[engine]\n# \x00")), "(file)"),
    ]


def _strings() -> list[Case]:
    return [
        Case("nul-in-name", "strings", edited("inline-4", engine__name="in\x00line"), "engine.name"),
        Case("nul-in-label", "strings", edited("inline-4", cylinder_1___label="1\x00"), "cylinder[1].label"),
        Case("newline-in-name", "strings", edited("inline-4", engine__name="in\nline"), "engine.name"),
        Case("tab-in-label", "strings", edited("inline-4", cylinder_2___label="2\t"), "cylinder[2].label"),
        Case("long-label", "strings", edited("inline-4", cylinder_1___label="x" * 10_000), "cylinder[1].label"),
        Case("empty-label", "strings", edited("inline-4", cylinder_1___label=""), "cylinder[1].label"),
        Case("blank-name", "strings", edited("inline-4", engine__name="   "), "engine.name"),
        Case("escape-in-description", "strings", edited("inline-4", engine__description="\x1b[31mred"),
             "engine.description"),
        Case("name-not-string", "strings", edited("inline-4", engine__name=4), "engine.name"),
        Case("duplicate-labels", "strings", edited("inline-4", cylinder_2___label="1"), "label"),
    ]


def _structure() -> list[Case]:
    return [
        Case("speed-table", "structure", edited("inline-4", engine__speed={"rpm": 3000}), "engine.speed"),
        Case("mass-boolean", "structure", edited("inline-4", piston__mass=True), "piston.mass"),
        Case("mass-list", "structure", edited("inline-4", piston__mass=[1, 2]), "piston.mass"),
        Case("cylinder-not-array", "structure", edited("inline-4", cylinder={"label": "1"}), "cylinder"),
        Case("unknown-table", "structure", edited("inline-4", pistn={"mass": "1 kg"}), "pistn"),
        Case("no-geometry", "structure", edited("inline-4", geometry=_DELETE), "geometry"),
        Case("no-crank-radius", "structure", edited("inline-4", geometry__crank_radius=_DELETE),
             "geometry.crank_radius"),
        Case("wrong-dimension", "structure", edited("inline-4", piston__mass="5 mm"), "piston.mass"),
        Case("unknown-unit", "structure", edited("inline-4", piston__mass="5 furlongs"), "piston.mass"),
        Case("not-a-quantity", "structure", edited("inline-4", piston__mass="heavy"), "piston.mass"),
        Case("unknown-effect", "structure", edited("inline-4", model={"effects": ["reciprocating", "magic"]}),
             "model.effects"),
        Case("cycle-three", "structure", edited("inline-4", engine__cycle=3), "engine.cycle"),
    ]


def _ranges() -> list[Case]:
    q = "inline-4"
    return [
        Case("speed-huge", "ranges", edited(q, engine__speed=f"{HUGE} rpm"), "engine.speed"),
        Case("speed-nan", "ranges", edited(q, engine__speed=NAN), "engine.speed"),
        Case("speed-inf", "ranges", edited(q, engine__speed=INF), "engine.speed"),
        Case("speed-negative", "ranges", edited(q, engine__speed="-3000 rpm"), "engine.speed"),
        Case("speed-denormal", "ranges", edited(q, engine__speed=DENORMAL), "engine.speed"),
        Case("piston-mass-huge", "ranges", edited(q, piston__mass=HUGE), "piston.mass"),
        Case("piston-mass-nan", "ranges", edited(q, piston__mass=NAN), "piston.mass"),
        Case("piston-mass-negative", "ranges", edited(q, piston__mass=-1.0), "piston.mass"),
        Case("piston-mass-denormal", "ranges", edited(q, piston__mass=DENORMAL), "piston.mass"),
        Case("rod-mass-inf", "ranges", edited(q, rod__mass=INF), "rod.mass"),
        Case("rod-inertia-huge", "ranges", edited(q, rod__inertia=HUGE), "rod.inertia"),
        Case("rod-cg-huge", "ranges", edited(q, rod__cg_from_big_end=HUGE), "rod.cg_from_big_end"),
        Case("rod-cg-offset-denormal", "ranges", edited(q, rod__cg_offset=DENORMAL), "rod.cg_offset"),
        Case("rod-cg-offset-huge", "ranges", edited(q, rod__cg_offset=f"{HUGE} mm"), "rod.cg_offset"),
        Case("crank-radius-huge", "ranges", edited(q, geometry__crank_radius=HUGE), "geometry.crank_radius"),
        Case("crank-radius-zero", "ranges", edited(q, geometry__crank_radius=0), "geometry.crank_radius"),
        Case("rod-length-tiny", "ranges", edited(q, geometry__rod_length="1e-300 mm"), "geometry.rod_length"),
        Case("rod-shorter-than-crank", "ranges", edited(q, geometry__rod_length="10 mm"), "geometry.rod_length"),
        Case("pin-offset-huge", "ranges", edited(q, geometry__pin_offset=f"{HUGE} mm"), "geometry.pin_offset"),
        Case("axial-position-huge", "ranges", edited(q, cylinder_1___axial_position=f"{HUGE} mm"),
             "cylinder[1].axial_position"),
        Case("axial-position-nan", "ranges", edited(q, cylinder_1___axial_position=NAN), "cylinder[1].axial_position"),
        Case("throw-nan", "ranges", edited(q, cylinder_2___throw=NAN), "cylinder[2].throw"),
        Case("throw-huge-degrees", "ranges", edited(q, cylinder_2___throw=f"{HUGE} deg"), "cylinder[2].throw"),
        Case("bank-inf", "ranges", edited(q, cylinder_2___bank=INF), "cylinder[2].bank"),
        Case("reference-tiny", "ranges", edited(q, engine__reference_point=["1e-300 mm", "0 mm", "0 mm"]),
             "engine.reference_point"),
        Case("reference-huge", "ranges", edited(q, engine__reference_point=[f"{HUGE} mm", "0 mm", "0 mm"]),
             "engine.reference_point"),
        Case("throw-unbalance-huge", "ranges",
             edited(q, throw_unbalance=[{"unbalance": f"{HUGE} kg m", "angle": "180 deg"}]), "unbalance"),
        Case("crankshaft-unbalance-huge", "ranges",
             edited(q, crankshaft_unbalance=[{"mass": HUGE, "radius": "50 mm"}]), "crankshaft_unbalance"),
        Case("samples-huge", "ranges", edited(q, sampling={"samples_per_rev": 10_000_000}), "sampling.samples_per_rev"),
        Case("samples-few", "ranges", edited(q, sampling={"samples_per_rev": 3}), "sampling.samples_per_rev"),
        Case("max-order-huge", "ranges", edited(q, sampling={"max_order": 100_000}), "sampling.max_order"),
        Case("max-order-zero", "ranges", edited(q, sampling={"max_order": 0}), "sampling.max_order"),
        Case("accuracy-one", "ranges", edited(q, sampling={"accuracy": 1.0}), "sampling.accuracy"),
        Case("negligible-five", "ranges", edited(q, model={"negligible": 5.0}), "model.negligible"),
        Case("speed-points-huge", "ranges",
             edited(q, engine__speed={"from": "1000 rpm", "to": "6000 rpm", "points": 10_000_000}), "engine.speed"),
    ]


def _firing() -> list[Case]:
    return [
        Case("firing-short", "firing", edited("inline-4", engine__firing_order=[1, 3, 4]), "engine.firing_order"),
        Case("firing-repeat", "firing", edited("inline-4", engine__firing_order=[1, 3, 3, 2]), "engine.firing_order"),
        Case("firing-unknown-label", "firing", edited("inline-4", engine__firing_order=[1, 3, 9, 2]),
             "engine.firing_order"),
        Case("firing-impossible", "firing", edited("inline-twin-360", engine__firing_order=[1, 2, 1]),
             "engine.firing_order"),
        Case("firing-not-list", "firing", edited("inline-4", engine__firing_order="1-3-4-2"), "engine.firing_order"),
    ]


def _gas() -> list[Case]:
    g = "single-gas"
    return [
        Case("compression-huge", "gas", edited(g, gas__combustion__compression_ratio=1e10),
             "gas.combustion.compression_ratio"),
        Case("compression-below-one", "gas", edited(g, gas__combustion__compression_ratio=0.5),
             "gas.combustion.compression_ratio"),
        Case("compression-nan", "gas", edited(g, gas__combustion__compression_ratio=NAN),
             "gas.combustion.compression_ratio"),
        Case("intake-huge", "gas", edited(g, gas__combustion__intake_pressure=f"{HUGE} bar"),
             "gas.combustion.intake_pressure"),
        Case("peak-absurd", "gas", edited(g, gas__combustion__peak_pressure="1e6 bar"),
             "gas.combustion.peak_pressure"),
        Case("imep-and-peak", "gas", edited(g, gas__combustion__imep="10 bar"), "gas.combustion"),
        Case("bore-zero", "gas", edited(g, gas__bore=0), "gas.bore"),
        Case("bore-huge", "gas", edited(g, gas__bore=f"{HUGE} mm"), "gas.bore"),
        Case("duration-zero", "gas", edited(g, gas__combustion__duration="0 deg"), "gas.combustion.duration"),
        Case("start-nan", "gas", edited(g, gas__combustion__start=NAN), "gas.combustion.start"),
        Case("exponent-huge", "gas", edited(g, gas__combustion__compression_exponent=1e300),
             "gas.combustion.compression_exponent"),
        Case("crankcase-huge", "gas", edited(g, gas__crankcase_pressure=f"{HUGE} Pa"), "gas.crankcase_pressure"),
        Case("gas-two-stroke-combustion", "gas", edited(g, engine__cycle=2), "gas.combustion"),
    ]


def _traces() -> list[Case]:
    good = _good_trace()
    return [
        Case("trace-dev-zero", "traces", with_trace("/dev/zero"), "gas.trace.file"),
        Case("trace-fifo", "traces", with_trace("trace.csv", make=_fifo("trace.csv")), "gas.trace.file"),
        Case("trace-etc-passwd", "traces", with_trace("/etc/passwd"), "gas.trace.file"),
        Case("trace-dotdot", "traces", with_trace("../outside.csv", make=lambda f: (f.parent / "outside.csv")
                                                  .write_bytes(good)), "gas.trace.file"),
        Case("trace-link-out", "traces", with_trace("trace.csv", make=_escaping_link), "gas.trace.file"),
        Case("trace-link-dev-zero", "traces", with_trace("trace.csv", make=_symlink("trace.csv", "/dev/zero")),
             "gas.trace.file"),
        Case("trace-directory", "traces", with_trace(".", ), "gas.trace.file"),
        Case("trace-missing", "traces", with_trace("nowhere.csv"), "gas.trace.file"),
        Case("trace-binary", "traces", with_trace("trace.csv", content=bytes(range(256)) * 64), "gas.trace"),
        Case("trace-huge", "traces", with_trace("trace.csv", content=good * 400), "gas.trace"),
        Case("trace-inf", "traces", with_trace("trace.csv", content=good.replace(b"\n1", b"\ninf", 3)), "gas.trace"),
        Case("trace-nan", "traces", with_trace("trace.csv", content=good.replace(b"\n1", b"\nnan", 3)), "gas.trace"),
        Case("trace-units-pa", "traces", with_trace("trace.csv", content=good.replace(b"[bar]", b"[Pa]")),
             "gas.trace"),
        Case("trace-empty", "traces", with_trace("trace.csv", content=b""), "gas.trace"),
    ]


def _balancers() -> list[Case]:
    return [
        Case("shaft-ratio-huge", "balancers",
             edited("inline-4", balance_shaft=[{"ratio": 1_000_000_000,
                                                "unbalance": [{"unbalance": "1 kg mm"}]}]), "balance_shaft[1].ratio"),
        Case("shaft-ratio-zero", "balancers",
             edited("inline-4", balance_shaft=[{"ratio": 0, "unbalance": [{"unbalance": "1 kg mm"}]}]),
             "balance_shaft[1].ratio"),
        Case("counterweight-huge", "balancers",
             edited("inline-4", counterweight=[{"unbalance": f"{HUGE} kg m"}]), "counterweight[1].unbalance"),
        Case("lanchester-nan-height", "balancers",
             edited("inline-4-lanchester", lanchester_pair_1___heights=[NAN, "-110 mm"]), "lanchester_pair[1]"),
        Case("design-order-beyond", "requests", edited("inline-4", design__orders=[99]), "design.orders"),
        Case("design-unknown-component", "requests", edited("inline-4", design__cancel=["torque"]), "design.cancel"),
        Case("design-pair-order-zero", "requests", edited("inline-4", design__lanchester_pair_1___order=0),
             "design.lanchester_pair[1].order"),
        Case("design-planes-coincide", "requests",
             edited("test-single", design__cancel=["roll"], design__lanchester_pair_1___lateral=["0 mm", "0 mm"],
                    design__lanchester_pair_1___heights=["0.001 mm", "0 mm"]),
             "design.lanchester_pair", exit=2, commands=("design",)),
        Case("verify-tolerance-negative", "requests", edited("inline-4", verify={"orders": [2], "tolerance": -1.0}),
             "verify.tolerance"),
        Case("flywheel-zero", "balancers",
             edited("single-gas", flywheel={"inertia": "0 kg m^2"}, model={"effects": [
                 "reciprocating", "rotating", "rod_inertia", "mass_torque", "gas", "speed_fluctuation"]}),
             "flywheel.inertia"),
        Case("flywheel-missing", "balancers",
             edited("single-gas", model={"effects": ["reciprocating", "gas", "speed_fluctuation"]}), "model.effects"),
    ]


_POWERTRAIN = {"mass": "480 kg", "cg": ["-40 mm", "0 mm", "180 mm"], "products": "tensor",
               "inertia": {"xx": "18 kg m^2", "yy": "42 kg m^2", "zz": "38 kg m^2", "xz": "-2.1 kg m^2"}}


def mounted(count: int = 3, **edits: Any) -> Callable[[Path], Path]:
    """inline-4 on ``count`` of three mounts ([powertrain] and [[mount]] tables), with keys set as
    :func:`edited` sets them."""
    mounts = [{"name": name, "position": [x, y, "0 mm"], "stiffness": ["300 N/mm", "300 N/mm", "900 N/mm"]}
              for name, x, y in (("front left", "300 mm", "250 mm"), ("front right", "300 mm", "-250 mm"),
                                 ("rear", "-400 mm", "0 mm"))]
    return edited("inline-4", **{"powertrain": json.loads(json.dumps(_POWERTRAIN)), "mount": mounts[:count], **edits})


def _mounts() -> list[Case]:
    variable = {"mount": "rear", "stiffness": "w", "bounds": ["100 N/mm", "1000 N/mm"]}
    return [
        Case("mount-without-powertrain", "mounts", mounted(powertrain=_DELETE), "powertrain"),
        Case("mount-two", "mounts", mounted(2), "mount"),
        Case("mount-unknown-key", "mounts", mounted(mount_1___stifness=["1 N/mm"] * 3), "mount[1].stifness"),
        Case("mount-inertia-triangle", "mounts", mounted(powertrain__inertia__xx="90 kg m^2"),
             "powertrain.inertia.xx"),
        Case("mount-products-unnamed", "mounts", mounted(powertrain__products=_DELETE), "powertrain.products"),
        Case("mount-axes-parallel", "mounts", mounted(mount_1___axes={"u": [1, 0, 0], "w": [-2, 0, 0]}),
             "mount[1].axes"),
        Case("mount-stiffness-huge", "mounts", mounted(mount_1___stiffness=["1 N/mm", "1 N/mm", f"{HUGE} N/mm"]),
             "mount[1].stiffness[3]"),
        Case("mount-table-decreasing", "mounts",
             mounted(mount_1___table={"frequency": ["50 Hz", "5 Hz"], "stiffness": [[1e5, 1e5, 1e5]] * 2}),
             "mount[1].table.frequency"),
        Case("mount-frequency-rpm", "mounts",
             mounted(mount_1___table={"frequency": ["5 Hz", "800 rpm"], "stiffness": [[1e5, 1e5, 1e5]] * 2}),
             "mount[1].table.frequency[2]"),
        Case("mount-design-unknown-mount", "mounts",
             mounted(mount_design={"variable": [{**variable, "mount": "raer"}]}), "mount_design.variable[1].mount"),
        Case("mount-design-outside-bounds", "mounts",
             mounted(mount_design={"variable": [{**variable, "bounds": ["1 N/mm", "10 N/mm"]}]}),
             "mount_design.variable[1].bounds"),
    ]


def _work() -> list[Case]:
    return [
        Case("cylinders-10000", "work", many_cylinders(10_000), "cylinder", commands=("loads", "report")),
        Case("speeds-max-report", "work",
             edited("inline-4", engine__speed={"from": "1000 rpm", "to": "6000 rpm", "points": 1_000_000}),
             "engine.speed", commands=("report",)),
        Case("flywheel-speeds", "work",
             edited("single-gas", engine__speed={"from": "1000 rpm", "to": "7000 rpm", "points": 100_000},
                    flywheel={"inertia": "0.2 kg m^2"}, model={"effects": [
                        "reciprocating", "rotating", "rod_inertia", "mass_torque", "gas", "speed_fluctuation"]}),
             "engine.speed", commands=("run", "stars", "report")),
        Case("samples-max-orders", "work",
             edited("inline-4", sampling={"samples_per_rev": 65536, "max_order": 32000},
                    engine__speed={"from": "1000 rpm", "to": "6000 rpm", "points": 100_000}),
             "sampling", commands=("run", "report", "loads")),
    ]


def _sweeps() -> list[Case]:
    base = edited("inline-4")
    only = ("sweep",)
    return [
        Case("sweep-1e8", "sweep", base, "piston.mass", commands=only,
             args=sweep_args("piston.mass=0.3:0.5:100000000")),
        Case("sweep-grid-1e10", "sweep", base, "piston.mass", commands=only,
             args=sweep_args("piston.mass=0.3:0.5:100000", "rod.mass=0.3:0.5:100000")),
        Case("sweep-unknown-key", "sweep", base, "pistn", commands=only, args=sweep_args("pistn.mass=0.3:0.5:3")),
        Case("sweep-nan", "sweep", base, "piston.mass", commands=only, args=sweep_args("piston.mass=nan:0.5:3"),
             names_file=False),
        Case("sweep-huge-values", "sweep", base, "piston.mass", commands=only,
             args=sweep_args("piston.mass=1e300:1e301:3")),
        Case("sweep-geometry-huge", "sweep", base, "geometry.crank_radius", commands=only,
             args=sweep_args("geometry.crank_radius=1e300:1e301:3")),
        Case("sweep-negative-count", "sweep", base, "--set", commands=only, args=sweep_args("piston.mass=0.3:0.5:-3"),
             names_file=False),
        Case("sweep-monte-carlo-huge", "sweep", base, "--monte-carlo", commands=only,
             args={"sweep": lambda scene, out: ["sweep", str(scene), "--monte-carlo", "100000000000", "--tol",
                                                "piston.mass=normal:0.01", "-o", str(out / "sweep.nc")]}),
    ]


# -- the subprocess that runs them ---------------------------------------------------------------

def _run_all(command: str, jobs: list[dict]):
    import contextlib
    import io
    import signal
    import time
    import traceback

    def alarm(signum, frame):
        raise TimeoutError(f"more than {CASE_SECONDS} s")

    signal.signal(signal.SIGALRM, alarm)
    from harmbal.cli import main

    for job in jobs:
        err, out = io.StringIO(), io.StringIO()
        escaped = None
        start = time.perf_counter()
        signal.alarm(CASE_SECONDS)
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
                code = main(job["argv"])
        except SystemExit as exc:  # argparse
            code = exc.code if isinstance(exc.code, int) else 2
        except BaseException:  # noqa: BLE001 - the point is to see anything that escapes
            code, escaped = None, traceback.format_exc()
        finally:
            signal.alarm(0)
        yield {"name": job["name"], "exit": code, "stderr": err.getvalue(), "stdout": out.getvalue()[-4000:],
               "escaped": escaped, "seconds": time.perf_counter() - start}


if __name__ == "__main__":
    import resource

    command, jobs_file, results_file = sys.argv[1:4]
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    jobs = json.loads(Path(jobs_file).read_text())
    with open(results_file, "a", encoding="utf-8") as results:  # one line per case: a crash loses no earlier case
        for result in _run_all(command, jobs):
            results.write(json.dumps(result) + "\n")
            results.flush()
