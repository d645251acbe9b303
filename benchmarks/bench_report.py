"""Time ``harmbal report`` end to end, as a user runs it.

Each figure is a whole process (interpreter start, imports, analysis,
figures, the page written), timed from outside with ``time.perf_counter``
around ``subprocess.run``. The commands are taken in turn (one of each,
``--repeat`` times, after one warm-up each) so that the shared machine's
changing load falls on all of them alike, and the medians are printed:

* ``floor``: ``python -c "import harmbal"``, what any harmbal command costs;
* ``report <scene>``: ``harmbal report <scene> -o <tmp>.html`` for the
  cross-plane V8 and the gas tractor (the two the targets in
  docs/performance.md are set for), and any scene given with ``--scene``.

With ``--stages`` it also prints, in this process, what one report of each
scene spends on importing matplotlib, the analysis, the figures (drawn and
written into the page) and the rest, from one warm call each (imports paid
by the first).

Run from the repository root with harmbal installed:

    python benchmarks/bench_report.py [--repeat 7] [--stages]

docs/performance.md ("Report") records the figures, before and after the
report's rework, and the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"
#: The scenes timed by default: the targets are ≤ 1.5 s and ≤ 2 s end to end.
SCENES = {"v8-cross-plane": 1.5, "tractor-3cyl-gas": 2.0}


def _commands(scenes: list[str], out: Path) -> dict[str, list[str]]:
    """The commands timed: the import floor, then one report per scene."""
    harmbal = [sys.executable, "-m", "harmbal.cli"]
    commands = {"floor (import harmbal)": [sys.executable, "-c", "import harmbal"]}
    for name in scenes:
        scene, page = ENGINES / f"{name}.toml", out / f"{name}.html"
        commands[f"report {name}"] = harmbal + ["report", str(scene), "-o", str(page)]
    return commands


def _run(command: list[str]) -> float:
    """Wall seconds of one run of ``command`` (which must succeed)."""
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
    return time.perf_counter() - start


def whole_process(commands: dict[str, list[str]], repeat: int) -> dict[str, list[float]]:
    """Seconds of ``repeat`` runs of each command, taken in turn after one warm-up each."""
    for command in commands.values():
        _run(command)
    samples = {name: [] for name in commands}
    for _ in range(repeat):
        for name, command in commands.items():
            samples[name].append(_run(command))
    return samples


def stages(name: str) -> dict[str, float]:
    """Seconds one report of scene ``name`` spends per stage, in this process."""
    start = time.perf_counter()
    import matplotlib.figure  # noqa: F401 (what the first figure pays)

    imported = time.perf_counter()
    import harmbal as hb

    scene = hb.load_scene(ENGINES / f"{name}.toml")
    tree = hb.analyse(scene)
    analysed = time.perf_counter()
    hb.report(tree)
    done = time.perf_counter()
    return {"import matplotlib": imported - start, "load + analyse": analysed - imported, "report()": done - analysed}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--scene", action="append", default=[], help="another scene of datasets/engines (no .toml)")
    parser.add_argument("--stages", action="store_true", help="also time the stages of one report in-process")
    args = parser.parse_args(argv)
    scenes = list(SCENES) + [s for s in args.scene if s not in SCENES]
    print(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.python_implementation()} "
          f"{platform.python_version()}; median (min–max) of {args.repeat} whole-process runs, taken in turn")
    with tempfile.TemporaryDirectory() as tmp:
        samples = whole_process(_commands(scenes, Path(tmp)), args.repeat)
    floor = statistics.median(samples["floor (import harmbal)"])
    print(f"{'command':<36}{'median [s]':>11}{'min–max [s]':>16}{'above floor [s]':>17}{'target [s]':>12}")
    for name, times in samples.items():
        median = statistics.median(times)
        scene = name.removeprefix("report ")
        target = f"{SCENES[scene]:g}" if scene in SCENES else ""
        above = "" if name.startswith("floor") else f"{median - floor:.2f}"
        print(f"{name:<36}{median:>11.2f}{f'{min(times):.2f}–{max(times):.2f}':>16}{above:>17}{target:>12}")
    if args.stages:
        print("\nstages of one report, in this process (the first pays the imports):")
        for scene in scenes:
            parts = stages(scene)
            print(f"{scene:<24}" + "  ".join(f"{k} {v:.2f} s" for k, v in parts.items()))


if __name__ == "__main__":
    main()
