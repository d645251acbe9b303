"""10⁷ sweep variants reduced to the best variant and percentiles: in memory
and on dask's schedulers, with time and peak memory.

The V-twin (datasets/engines/v-twin-90.toml) over 10 rod lengths × 10 crank
radii × 100 piston masses × 1 000 rod masses = 10⁷ variants (100
geometries), order amplitudes of orders 1 and 2 (``phasors=False``), reduced
to the variant with the smallest summed force amplitude and the 5/50/95 %
percentiles of each order's force and moment amplitudes. Each configuration
runs in its own Python process (its peak RSS is its own); BLAS and FFT use
one thread each, so "2 threads" means dask's two workers:

* in memory: ``hb.sweep`` without ``chunks`` (numpy, blocks of 65 536);
* dask ``sync``: chunks of 10⁶ variants, one thread;
* dask ``threads``: the same chunks, two threads;
* dask.distributed ``LocalCluster`` of 2 worker processes × 1 thread, with
  distributed's default ``MALLOC_TRIM_THRESHOLD_`` (65 536, set in each
  worker's environment by the nanny), and with it raised to glibc's default
  (128 kB … 32 MB, dynamic: the variable unset).

Run from the repository root with harmbal[dask] installed:

    python benchmarks/bench_sweep_dask.py [--variants 10000000] [--chunks 1000000]

docs/performance.md and docs/sweeps.md record the figures and the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from timing import machine

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "datasets" / "engines" / "v-twin-90.toml"

CONFIGS = {
    "in memory (numpy, no dask)": {"scheduler": None},
    "dask, sync scheduler (1 thread)": {"scheduler": "sync"},
    "dask, threaded scheduler (2 threads)": {"scheduler": "threads"},
    "dask.distributed LocalCluster, 2 processes × 1 thread, MALLOC_TRIM_THRESHOLD_=65536 (distributed's default)":
        {"scheduler": "cluster", "trim": True},
    "dask.distributed LocalCluster, 2 processes × 1 thread, MALLOC_TRIM_THRESHOLD_ unset (glibc's default)":
        {"scheduler": "cluster", "trim": False},
}

WORKER = r'''
import json, os, resource, sys, time
import numpy as np
config, variants, chunks, scene = json.loads(sys.argv[1])
import dask
import harmbal as hb
rod_masses = variants // 10_000
grid = {"geometry.rod_length": np.linspace(0.120, 0.140, 10), "geometry.crank_radius": np.linspace(0.035, 0.039, 10),
        "piston.mass": np.linspace(0.36, 0.44, 100), "rod.mass": np.linspace(0.34, 0.42, rod_masses)}
client = None
if config["scheduler"] == "cluster":
    from distributed import Client, LocalCluster
    environ = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    if config["trim"]:
        environ["MALLOC_TRIM_THRESHOLD_"] = "65536"
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0")
        client = Client(cluster)
chunked = config["scheduler"] is not None
# Warm-up: the imports harmbal defers (xarray, dask.array) and, on a cluster, harmbal on the workers.
small = {"geometry.rod_length": [0.12, 0.13], "piston.mass": [0.38, 0.40]}
dask.compute(hb.sweep(scene, small, orders=[1, 2], phasors=False, chunks=2 if chunked else None).force_amplitude,
             scheduler=config["scheduler"] if config["scheduler"] in ("sync", "threads") else None)
start = time.perf_counter()
ds = hb.sweep(scene, grid, orders=[1, 2], phasors=False, chunks=chunks if chunked else None)
amplitude = ds[["force_amplitude", "moment_amplitude"]]
best = amplitude.force_amplitude.sum("order").argmin("variant")
quantiles = amplitude.quantile([0.05, 0.5, 0.95], dim="variant")
with dask.config.set(scheduler=config["scheduler"] if config["scheduler"] in ("sync", "threads") else None):
    best, quantiles = dask.compute(best, quantiles) if chunked else (best, quantiles)
seconds = time.perf_counter() - start
workers = 0.0
if client is not None:
    workers = max(client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss).values()) / 2**20
    client.close()
    cluster.close()
print(json.dumps({"seconds": seconds, "best": int(best), "median": float(quantiles.force_amplitude[1, 0]),
                  "main_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20, "worker_gb": workers}))
'''


def run(config: dict, variants: int, chunks: int) -> dict:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    env.pop("MALLOC_TRIM_THRESHOLD_", None)
    out = subprocess.run([sys.executable, "-c", WORKER, json.dumps([config, variants, chunks, str(SCENE)])],
                         capture_output=True, text=True, env=env)
    if out.returncode:
        raise SystemExit(f"{config} failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", type=int, default=10_000_000, help="variants (a multiple of 10 000)")
    parser.add_argument("--chunks", type=int, default=1_000_000, help="variants per dask chunk")
    parser.add_argument("--repeat", type=int, default=1, help="runs per configuration (the fastest is kept)")
    args = parser.parse_args()
    print(machine(args.repeat))
    print()
    print(f"{args.variants:,} variants, chunks of {args.chunks:,}")
    print()
    print("| configuration | time | variants/s | peak RSS, main process | peak RSS, each worker |")
    print("|---|---:|---:|---:|---:|")
    answers = set()
    for label, config in CONFIGS.items():
        result = min((run(config, args.variants, args.chunks) for _ in range(args.repeat)), key=lambda r: r["seconds"])
        answers.add((result["best"], result["median"]))
        worker = f"{result['worker_gb']:.2f} GB" if result["worker_gb"] else "—"
        print(f"| {label} | {result['seconds']:.3g} s | {args.variants / result['seconds']:,.0f} | "
              f"{result['main_gb']:.2f} GB | {worker} |", flush=True)
    print()
    print("every configuration found the same best variant and median" if len(answers) == 1
          else f"configurations disagree: {sorted(answers)}")


if __name__ == "__main__":
    main()
