"""Unsigned index arrays in the kernels against the signed ones, in one process, alternated.

    python benchmarks/bench_unsigned.py [N] [ramps] [curved]

The factorisation, the solves, the springs' step, the rank-one modifications and the Hessian's
assembly read their index arrays as unsigned views (``crumple.linalg_symbolic._Symbolic.unsigned``):
Numba checks a signed index for wrap-around at every access, an unsigned one not. Here the
same ramp is run ``ramps`` times each way, alternated: with the views (the engine as it is) and
with the signed arrays (as before, through wrappers that view them back), asserting that the
two ramps of every pair end at the same positions to the bit. N = 100 is the default ramp of
the paper's wire (k_b = 5, k_s = 5 × 10⁵); other N the continuum wire of ``bench_scale.py``;
``curved`` turns curved steps on. CPU (``time.process_time``, one BLAS thread) per ramp,
minimum and median. Results: docs/performance.md, "Unsigned indices".
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(__file__))

import numpy as np
from bench_scale import continuum_wire
from threadpoolctl import threadpool_limits

import crumple.energy as energy_module
import crumple.linalg as linalg_module
from crumple.model import Wire
from crumple.protocol import Ramp, run_ramp

_UNSIGNED = linalg_module._Symbolic.unsigned
_HESSIAN = energy_module._hessian_values
_SPRINGS = linalg_module._spring_solve


def _signed(self):
    """The signed arrays, made once per pattern as the unsigned views are (a dict made at every
    access would cost the signed leg ~2.6 µs each, ~2400 times in the N = 100 ramp)."""
    cached = getattr(self, "_signed_arrays", None)
    if cached is None:
        names = ("src", "perm", "ap", "ai", "rp", "rc", "rpos", "lp", "ai_l")
        cached = {("li" if k == "ai_l" else k): np.ascontiguousarray(getattr(self, k),
                                                                     dtype=np.int64)
                  for k in names}  # fmt: skip
        cached["factor"] = (self.n, cached["ap"], cached["ai"], cached["rp"], cached["rc"],
                            cached["rpos"], cached["lp"], cached["li"])  # fmt: skip
        self._signed_arrays = cached
    return cached


def _hessian_signed(where, *args):
    return _HESSIAN(where.view(np.int64), *args)


def _springs_signed(*args):
    args = list(args)
    args[7] = args[7].view(np.int64)  # the springs' rows
    return _SPRINGS(*args)


def _use(kind: str) -> None:
    """The kernels' index arrays unsigned (the engine) or signed (as before)."""
    unsigned = kind == "unsigned"
    linalg_module._Symbolic.unsigned = _UNSIGNED if unsigned else property(_signed)
    energy_module._hessian_values = _HESSIAN if unsigned else _hessian_signed
    linalg_module._spring_solve = _SPRINGS if unsigned else _springs_signed


def main(argv):
    n = int(float(argv[0])) if argv else 100
    ramps = int(argv[1]) if len(argv) > 1 else 10
    curved = True if len(argv) > 2 and argv[2] == "curved" else None
    wire = Wire(k_b=5, k_s=5e5) if n == 100 else continuum_wire(n)
    ramp = Ramp(curved_steps=curved)
    cpu = {"unsigned": [], "signed": []}
    with threadpool_limits(limits=1, user_api="blas"):
        for kind in cpu:  # compile both
            _use(kind)
            run_ramp(wire, Ramp(lambdas=(1.0, 100.0, 1000.0), curved_steps=curved), seed=0)
        for _ in range(ramps):
            end = None
            for kind in cpu:
                _use(kind)
                t0 = time.process_time()
                r = run_ramp(wire, ramp, seed=0)
                cpu[kind].append(time.process_time() - t0)
                x = r.stages[-1].positions
                assert end is None or np.array_equal(end, x), "the iterates moved"
                end = x
    _use("unsigned")
    its = sum(s.result.iterations for s in r.stages)
    print(f"== N = {n}, default schedule, curved steps {'on' if curved else 'off'}, {its} "
          f"iterations, every pair ending at the same positions ==")  # fmt: skip
    for kind, t in cpu.items():
        print(f"  {kind:8s}: min {min(t):.4f} s, median {np.median(t):.4f} s CPU over {len(t)}")
    print(f"  signed / unsigned: {np.median(cpu['signed']) / np.median(cpu['unsigned']):.3f} "
          f"(medians), {min(cpu['signed']) / min(cpu['unsigned']):.3f} (minima)")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
