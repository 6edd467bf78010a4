"""How the hard core's energy scale ε trades hardness against Newton's convergence.

    python benchmarks/bench_hard_core_scale.py

The default ramp (per-length, k_b = 5, k_s = 5e5, N = 100, 44 stages, seed 0) for several ε:
stages converged, Newton iterations, wall time, and the closest approach of two non-adjacent
segments over all stages, in units of the hard-core width d. The table in docs/model.md.
"""

import time

import numpy as np

from crumple.geometry import close_segment_pairs
from crumple.model import Wire
from crumple.protocol import Ramp, run_ramp

if __name__ == "__main__":
    run_ramp(Wire(k_b=5, k_s=5e5), Ramp(lambdas=(1, 2)), seed=0)  # JIT warm-up
    print(f"{'eps':>8} {'converged':>10} {'iterations':>11} {'seconds':>8} {'closest/d':>10}")
    for eps in (1e-2, 1e-3, 1e-4, 1e-5):
        wire = Wire(k_b=5, k_s=5e5, hard_core_energy=eps)
        t0 = time.perf_counter()
        r = run_ramp(wire, seed=0)
        dt = time.perf_counter() - t0
        closest = min(
            (close_segment_pairs(s.positions, 2 * wire.hard_core)[1].min(initial=np.inf)
             for s in r.stages),
            default=np.inf,
        )  # fmt: skip
        its = sum(s.result.iterations for s in r.stages)
        ok = sum(s.result.converged for s in r.stages)
        print(f"{eps:>8g} {ok:>6}/{len(r.stages):<3} {its:>11} {dt:>8.2f} "
              f"{closest / wire.hard_core:>10.2f}")  # fmt: skip
