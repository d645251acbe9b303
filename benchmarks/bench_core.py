"""Time the core pipeline: analyse() in-process and `harmbal run` end to end.

Run from the repository root with harmbal installed:

    python benchmarks/bench_core.py [--repeat 200]

Prints a Markdown table; docs/performance.md records the figures and the
machine. In-process timings are the median of many calls after one warm-up
call (imports and pint's registry are paid once); the end-to-end timing is the
median wall time of fresh `harmbal run` processes, imports included.
"""

from __future__ import annotations

import argparse
import contextlib
import platform
import subprocess
import sys
from pathlib import Path

from timing import median_seconds

ROOT = Path(__file__).resolve().parent.parent
ENGINES = ROOT / "datasets" / "engines"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=200, help="calls per in-process timing")
    parser.add_argument("--runs", type=int, default=7, help="processes for the end-to-end timing")
    args = parser.parse_args()

    import harmbal as hb

    import numpy as np

    from harmbal.analysis import scene_dataset
    from harmbal.labelled import tree
    from harmbal.model.evaluate import evaluate
    from harmbal.model.sampling import choose_samples
    from harmbal.orders.phasors import order_phasors
    from harmbal.orders.spectrum import phasors

    v8 = hb.load_scene(ENGINES / "v8-cross-plane.toml").with_speeds([3000 * np.pi / 30])
    time_ds = hb.simulate(v8)
    groups = {"scene": scene_dataset(v8), "time": time_ds, "orders": hb.order_spectrum(time_ds), "stars": hb.stars(v8)}
    n = choose_samples(v8)

    def arrays_only():
        force, moment = evaluate(v8, n).total(v8.reference_point)
        return phasors(np.concatenate([force, moment]))

    floor = median_seconds(arrays_only, args.repeat)
    whole = median_seconds(lambda: hb.analyse(v8), args.repeat)
    balanced = hb.load_scene(ENGINES / "inline-3-balanced.toml")
    rows = [
        ("load_scene(v8-cross-plane.toml)", median_seconds(lambda: hb.load_scene(ENGINES / "v8-cross-plane.toml"), args.repeat)),
        ("analyse(V8)", whole),
        ("  simulate(V8): the exact loads as a Dataset", median_seconds(lambda: hb.simulate(v8), args.repeat)),
        ("  order_spectrum: FFT, co/counter split, aliasing estimate, Dataset",
         median_seconds(lambda: hb.order_spectrum(time_ds), args.repeat)),
        ("  stars(V8): order domain, crank stars, firing, Dataset", median_seconds(lambda: hb.stars(v8), args.repeat)),
        ("  scene Dataset", median_seconds(lambda: scene_dataset(v8), args.repeat)),
        ("  DataTree of the four groups (labelled.tree)", median_seconds(lambda: tree({}, groups), args.repeat)),
        ("arithmetic floor: evaluate + rFFT of the 6 sums (arrays)", floor),
        ("order_phasors(V8) (arrays, order domain)", median_seconds(lambda: order_phasors(evaluate(v8)), args.repeat)),
        ("verify(inline-3-balanced)", median_seconds(lambda: hb.verify(balanced), args.repeat)),
    ]
    for name in ("v12.toml", "tractor-3cyl.toml"):
        scene = hb.load_scene(ENGINES / name)
        rows.append((f"analyse({name.removesuffix('.toml')})", median_seconds(lambda: hb.analyse(scene), args.repeat)))
    tractor = hb.load_scene(ENGINES / "tractor-3cyl.toml")
    with _without_xarray_objects():
        for label, scene in (("tractor-3cyl", tractor), ("V8", v8)):
            rows.append((f"analyse({label}) short of its xarray objects (diagnostic: harmbal.labelled's "
                         "constructors pass the arrays through)", median_seconds(lambda: hb.analyse(scene), args.repeat)))

    sweep = v8.with_speeds(np.linspace(600, 8000, 10_000) * np.pi / 30)
    sweep_repeat = max(3, args.repeat // 20)
    rows += [
        ("sweep, 10 000 speeds: analyse(V8)", median_seconds(lambda: hb.analyse(sweep), sweep_repeat)),
        ("sweep, 10 000 speeds: order_spectrum(simulate(V8))",
         median_seconds(lambda: hb.order_spectrum(hb.simulate(sweep)), sweep_repeat)),
    ]
    million = _million_speeds()

    def run_cli():
        subprocess.run([sys.executable, "-m", "harmbal", "run", str(ENGINES / "tractor-3cyl.toml")],
                       check=True, capture_output=True)

    def import_only():
        subprocess.run([sys.executable, "-c", "import harmbal"], check=True)

    rows.append(("`import harmbal` (fresh process, incl. interpreter start)", median_seconds(import_only, args.runs)))
    rows.append(("`harmbal run tractor-3cyl.toml` end to end", median_seconds(run_cli, args.runs)))

    print(f"machine: {platform.processor() or platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, harmbal {hb.__version__}, samples/rev V8 = {n}")
    print("| operation | median time |\n|---|---|")
    for name, seconds in rows:
        print(f"| {name.replace('  ', '— ', 1) if name.startswith('  ') else name} | {seconds * 1e3:.3f} ms |")
    print(f"\nanalyse(V8) / arithmetic floor: {whole / floor:.1f}×")
    print("10⁶-speed V8 sweep, fresh process: analyse {analyse:.3f} s + save {save:.3f} s, archive {size:.1f} MB, "
          "peak RSS {rss:.0f} MB".format(**million))


@contextlib.contextmanager
def _without_xarray_objects():
    """Within the block, analyse does all its work but build Variables, Datasets and the tree: the
    constructors of :mod:`harmbal.labelled` return what they are given. What analyse costs short of its
    xarray objects (the ≥ 1 000× Exudyn target needs analyse(tractor-3cyl) ≤ 0.45 ms)."""
    from harmbal import labelled

    saved = {name: getattr(labelled, name) for name in ("_dataset_direct", "_tree_direct", "variable", "_as_variable")}
    speed_variable = labelled.Speeds.variable
    labelled._dataset_direct = lambda data, coords, attrs: (data, coords, attrs)
    labelled._tree_direct = lambda attrs, groups: groups
    labelled.variable = lambda dims, values, attrs=None: values
    labelled._as_variable = lambda value: value
    labelled.Speeds.variable = lambda self, dims, unit, attrs, constant=None: unit
    try:
        yield
    finally:
        for name, function in saved.items():
            setattr(labelled, name, function)
        labelled.Speeds.variable = speed_variable


_MILLION = """
import json, os, resource, sys, tempfile, time
import numpy as np
import harmbal as hb
scene = hb.load_scene(sys.argv[1])
sweep = scene.with_speeds(np.linspace(50.0, 800.0, 1_000_000))
start = time.perf_counter()
tree = hb.analyse(sweep)
analysed = time.perf_counter()
path = os.path.join(tempfile.mkdtemp(), "sweep.nc")
hb.save(tree, path)
saved = time.perf_counter()
print(json.dumps({"analyse": analysed - start, "save": saved - analysed, "size": os.path.getsize(path) / 1e6,
                  "rss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
os.remove(path)
"""


def _million_speeds() -> dict:
    """analyse + save of a 10⁶-speed V8 sweep in a fresh process (imports excluded from the times, included in
    the peak resident memory)."""
    import json

    out = subprocess.run([sys.executable, "-c", _MILLION, str(ENGINES / "v8-cross-plane.toml")], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


if __name__ == "__main__":
    main()
