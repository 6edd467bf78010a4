"""λ sub-steps within one stage: does a late stage crawl because λ jumps between stages?

    python benchmarks/bench_substeps.py N K DIR [m=1,2,4]

Stage K of the default schedule at N (the continuum wire of ``bench_scale.py``, curved steps)
from the positions of stage K - 1 that ``bench_scale.py scale N curved=on save=DIR`` wrote,
with the jump λ_{K-1} → λ_K split into m geometric sub-stages, each minimised to the ramp's
ftol like a stage (m = 1: the stage itself). Prints each sub-stage's Newton iterations, their
sum, the CPU, and where it ended. Recorded in docs/performance.md ("λ sub-steps within a late
stage").
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(__file__))

import numpy as np
from bench_scale import continuum_wire
from threadpoolctl import threadpool_limits

from crumple.protocol import Ramp
from crumple.relax import minimize_wire


def substeps(n: int, k: int, save: str, ms=(1, 2, 4)) -> None:
    ramp = Ramp(curved_steps=True)
    if not 2 <= k <= len(ramp.lambdas):
        raise SystemExit(f"K must be 2 … {len(ramp.lambdas)}, got {k}")
    wire = continuum_wire(n)
    x0 = np.load(os.path.join(save, f"N{n}_stage{k - 1:02d}.npy"))
    lam0, lam1 = ramp.lambdas[k - 2], ramp.lambdas[k - 1]
    print(f"== N = {n}, stage {k} (λ {lam0:.5g} → {lam1:.5g}) from {save}'s stage {k - 1} ==")
    for m in ms:
        x, its, ok, t0 = x0, [], True, time.process_time()
        for lam in np.geomspace(lam0, lam1, m + 1)[1:]:
            with threadpool_limits(limits=1, user_api="blas"):
                r = minimize_wire(wire, x, float(lam), method="newton", ftol=ramp.ftol,
                                  maxiter=ramp.maxiter, max_step=ramp.max_step,
                                  curved_steps=True, fallback=ramp.fallback)  # fmt: skip
            x, ok = r.x.reshape(x.shape), ok and r.converged
            its.append(r.iterations)
        print(f"  m = {m}: iterations {its}, {sum(its)} in all, "
              f"{time.process_time() - t0:.1f} s CPU, every sub-stage converged: {ok}, "
              f"energy {r.energy:.10g}, max force {r.max_force:.3g}", flush=True)  # fmt: skip


if __name__ == "__main__":
    flags = dict(a.split("=") for a in sys.argv[1:] if "=" in a)
    args = [v for v in sys.argv[1:] if "=" not in v]
    if len(args) != 3:
        raise SystemExit(__doc__)
    ms = tuple(int(v) for v in flags.get("m", "1,2,4").split(","))
    substeps(int(args[0]), int(args[1]), args[2], ms)
