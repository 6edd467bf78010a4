"""Per-node against per-length confinement (issue 14): CPU seconds per ramp of the reproduction.

    python benchmarks/bench_pernode.py fig2            # (5, 5e5), full schedule, both readings
    python benchmarks/bench_pernode.py points 16       # every elastic and plastic point of the
                                                       # reproduction, per node, schedule n = 16
                                                       # (the quick profile's; 40: the full's)

CPU time is ``time.process_time`` of one process (the ramps run with one BLAS thread), one
replica (the reproduction's replica 0), after a compilation ramp. Results are recorded in
docs/performance.md, "Both readings of Eq. 1".
"""

from __future__ import annotations

import sys
import time

from crumple import paper
from crumple.model import Plasticity, Wire
from crumple.protocol import Ramp, default_schedule, replica_seeds, run_ramp


def _ramp(wire: Wire, n: int) -> tuple[float, bool, int]:
    """CPU seconds, whether every stage converged, and the Newton iterations of one ramp."""
    seed = replica_seeds(paper.SEED, 1)[0]
    t = time.process_time()
    r = run_ramp(wire, Ramp(lambdas=default_schedule(n=n)), seed=seed)
    return time.process_time() - t, r.converged, sum(s.result.iterations for s in r.stages)


def _points() -> list[dict]:
    kb, ks = paper.FIG2
    pts = [
        dict(p) for p in paper.points(paper.FIG3_POINTS + paper.FIG4A_POINTS + paper.FIG4B_POINTS)
    ]
    pts += [{"k_b": kb, "k_s": ks, "plasticity": Plasticity(s=s, theta_p=paper.PLASTIC_THETA_P)}
            for s in paper.PLASTIC_S]  # fmt: skip
    pts += [{"k_b": kb, "k_s": ks, "plasticity": Plasticity(s=0.4, theta_p=t)}
            for t in paper.PLASTIC_INSET_THETA_P if t != paper.PLASTIC_THETA_P]  # fmt: skip
    return pts


def main(argv: list[str]) -> None:
    _ramp(Wire(k_b=5.0, k_s=5e5), 2)  # compilation
    if argv[:1] == ["fig2"]:
        for conf in ("per-length", "per-node"):
            dt, ok, its = _ramp(Wire(k_b=5.0, k_s=5e5, confinement=conf), 40)
            print(f"{conf:10s} (5, 5e5) 44 stages: {dt:6.2f} s CPU, {its} Newton iterations "
                  f"({dt / its * 1e3:.2f} ms each), converged {ok}")  # fmt: skip
    elif argv[:1] == ["points"]:
        n = int(argv[1]) if len(argv) > 1 else 16
        total = 0.0
        for p in _points():
            dt, ok, its = _ramp(Wire(confinement="per-node", **p), n)
            total += dt
            print(f"per-node {p}: {dt:6.2f} s CPU, {its} Newton iterations, converged {ok}",
                  flush=True)  # fmt: skip
        print(f"total {total:.1f} s CPU")
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
