"""Benchmark of sweeps on Dask: speed-up from 1 to 2 local workers and the cost per run.

    python benchmarks/bench_sweep.py            # 40 ramps, N = 100, the default 44-stage λ ramp
    python benchmarks/bench_sweep.py --quick    # 8 ramps, N = 60, 12 stages (a smoke test)

Measured, in this order, each on a fresh store:

* **serial**: the same runs one after the other in this process, no Dask, no files (baseline);
* **1 worker**, **2 workers**: ``run_sweep`` on a ``LocalCluster`` started and warmed up (one
  tiny ramp per worker, to load numba's cache) outside the timing: the steady state of a
  large sweep;
* **cold**: ``run_sweep(workers=2)`` as ``crumple sweep`` does it, cluster start included.

Overhead per run = (wall time x workers - sum of the runs' own ``seconds``) / runs: scheduling,
transfers, writing the HDF5 file, and workers idle at the end of the sweep. A Dask round trip
is also timed alone (200 no-op tasks). Run on an otherwise idle machine; ``uptime`` is printed
because another job on the cores changes everything. Results go in docs/performance.md.
"""

from __future__ import annotations

import argparse
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import h5py
import numpy as np

from crumple.sweep import Sweep, run_sweep


def _noop(x):
    return x


def _warm(_=None):
    from crumple.model import Wire
    from crumple.protocol import Ramp, run_ramp

    run_ramp(Wire(k_b=5, k_s=5e5, n_segments=20), Ramp(lambdas=(1, 10, 100)), seed=0)
    return os.getpid()


def run_seconds(out: Path) -> float:
    total = 0.0
    for p in (out / "runs").glob("*.h5"):
        with h5py.File(p, "r") as f:
            total += float(f["seconds"][0])
    return total


def timed_sweep(sweep: Sweep, n_workers: int, root: Path) -> dict:
    from distributed import Client, LocalCluster

    out = Path(tempfile.mkdtemp(dir=root))
    with (
        LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                     dashboard_address=":0", silence_logs=logging.ERROR) as cluster,
        Client(cluster) as client,
    ):  # fmt: skip
        client.run(_warm)
        t0 = time.perf_counter()
        fs = client.map(_noop, range(200), pure=False)
        client.gather(fs)
        roundtrip = (time.perf_counter() - t0) / 200
        t0 = time.perf_counter()
        report = run_sweep(sweep, out, client=client)
        wall = time.perf_counter() - t0
    assert report.complete and len(report.computed) == len(sweep), report
    busy = run_seconds(out)
    return {
        "wall": wall,
        "busy": busy,
        "overhead": (wall * n_workers - busy) / len(sweep),
        "roundtrip": roundtrip,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="8 short ramps (smoke test)")
    args = ap.parse_args(argv)
    if args.quick:
        sweep = Sweep(wire={"n_segments": 60, "k_b": [2.0, 5.0]},
                      ramp={"schedule": {"n": 8}}, replicas=4)  # fmt: skip
    else:  # 4 bending rigidities x 10 replicas = 40 ramps, N = 100, the default schedule
        sweep = Sweep(wire={"n_segments": 100, "k_b": [2.0, 5.0, 8.0, 12.0], "k_s": 5e5},
                      replicas=10, seed=1)  # fmt: skip
    n_stages = len(sweep.runs()[0].ramp.lambdas)
    print(f"{len(sweep)} ramps, N = {sweep.runs()[0].wire.n_segments}, {n_stages} stages each")
    print("load before:", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())

    _warm()
    t0 = time.perf_counter()
    for run in sweep.runs():
        run.compute()
    serial = time.perf_counter() - t0
    print(f"serial (no Dask, no files) : {serial:7.2f} s   {serial / len(sweep):.3f} s/run")

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        res = {n: timed_sweep(sweep, n, root) for n in (1, 2)}
        for n, r in res.items():
            print(
                f"{n} worker(s), warm         : {r['wall']:7.2f} s   "
                f"speed-up vs serial {serial / r['wall']:.2f}x   "
                f"overhead/run {1e3 * r['overhead']:6.1f} ms   "
                f"Dask round trip {1e3 * r['roundtrip']:.1f} ms"
            )
        print(f"speed-up 2 vs 1 worker     : {res[1]['wall'] / res[2]['wall']:.2f}x")
        t0 = time.perf_counter()
        report = run_sweep(sweep, root / "cold", workers=2)
        cold = time.perf_counter() - t0
        assert report.complete
        print(f"2 workers, cold (cluster start included): {cold:7.2f} s "
              f"(+{cold - res[2]['wall']:.1f} s)")  # fmt: skip
    print("load after: ", subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, {os.cpu_count()} CPUs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
