"""What the default N = 100 ramp's kernels cost with no Python between them.

    python benchmarks/bench_replay.py [RUNS]        # e.g. 7

Every Numba kernel bound in a ``crumple`` module is wrapped while one default ramp runs (seed
0), recording each call and a copy of its arguments at the time of the call. The calls are then
replayed back to back, in order, and timed against whole ramps, alternated in one process:
twice, once with every array argument its own copy (cold in the cache, an upper bound) and once
with equal arrays shared, as the engine shares its pattern, its factor and its positions between
calls. The replay still pays Numba's dispatch on every call: the same calls made to kernels
of as many parameters that do nothing measure it (the return values' boxing aside). What is
left estimates the floor of a Newton iteration compiled whole, whose kernels would be these.
CPU time is ``time.process_time``, one BLAS thread.
"""

from __future__ import annotations

import gc
import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from numba import njit
from numba.core.registry import CPUDispatcher
from threadpoolctl import threadpool_limits

from crumple.model import Wire
from crumple.protocol import Ramp, run_ramp


def _copier(shared: bool):
    """A copy of an argument taken at the call; equal arrays one object where ``shared``."""
    seen = {}

    def cp(x):
        if isinstance(x, tuple):
            return tuple(cp(y) for y in x)
        if not isinstance(x, np.ndarray):
            return x
        key = (x.dtype.str, x.shape, x.tobytes()) if shared else None
        if key is not None and key in seen:
            return seen[key]
        c = x.copy()
        if key is not None:
            seen[key] = c
        return c

    return cp


def _nothing(count: int):
    """A kernel of ``count`` parameters that does nothing: a call's dispatch alone. Fixed
    parameters, not ``*args``, which Numba packs into a tuple at every call (measured: 8 ms more
    over a ramp's calls). Its return value is an integer: boxing a kernel's returned arrays is
    not counted (about 0.3 µs more for one array)."""
    names = ", ".join(f"a{i}" for i in range(count))
    scope = {}
    exec(f"def nothing({names}):\n    return 0\n", scope)  # a signature of ``count`` parameters
    return njit(scope["nothing"])


def capture(wire, shared: bool) -> list:
    """Every kernel call of one default ramp of ``wire``, as (kernel, copied arguments)."""
    calls, cp, bound = [], _copier(shared), {}

    def wrap(kernel):
        def recorded(*args):
            calls.append((kernel, tuple(cp(a) for a in args)))
            return kernel(*args)

        return recorded

    for name in [m for m in sys.modules if m.startswith("crumple")]:
        module = sys.modules[name]
        for attr, value in list(vars(module).items()):
            if isinstance(value, CPUDispatcher):
                bound[(name, attr)] = value
                setattr(module, attr, wrap(value))
    try:
        run_ramp(wire, seed=0)
    finally:
        for (name, attr), value in bound.items():
            setattr(sys.modules[name], attr, value)
    return calls


def main(runs: int = 7) -> None:
    wire = Wire(k_b=5, k_s=5e5)
    run_ramp(wire, Ramp(lambdas=(1.0, 100.0, 1000.0)), seed=0)  # compile
    run_ramp(wire, seed=0)
    replays = {"copies": capture(wire, False), "shared": capture(wire, True)}
    times = {"ramp": [], **{k: [] for k in replays}, "dispatch": []}
    empty = {}
    for _, args in replays["shared"]:  # an empty kernel for every count, every signature compiled
        empty.setdefault(len(args), _nothing(len(args)))(*args)
    nothing = [(empty[len(args)], args) for _, args in replays["shared"]]
    with threadpool_limits(limits=1, user_api="blas"):
        for _ in range(runs):
            gc.disable()
            try:
                t = time.process_time()
                run_ramp(wire, seed=0)
                times["ramp"].append(time.process_time() - t)
                for key, calls in [*replays.items(), ("dispatch", nothing)]:
                    t = time.process_time()
                    for kernel, args in calls:
                        kernel(*args)
                    times[key].append(time.process_time() - t)
            finally:
                gc.enable()
    ramp = float(np.median(times["ramp"]))
    n = len(replays["shared"])
    print(f"== default ramp, N = 100, seed 0: its {n} kernel calls replayed, {runs} runs ==")
    print(f"  whole ramp: {ramp:.4f} s CPU (median)")
    dispatch = float(np.median(times["dispatch"]))
    for key in replays:
        t = float(np.median(times[key]))
        print(
            f"  kernels back to back, arguments {key}: {t:.4f} s ({t / ramp:.1%} of the ramp); "
            f"less the dispatch {t - dispatch:.4f} s ({(t - dispatch) / ramp:.1%})"
        )
    print(f"  the same calls to a kernel that does nothing (dispatch): {dispatch:.4f} s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
