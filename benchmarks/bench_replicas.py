"""Replica-to-replica variety of the default ramp for each source of randomness.

    python benchmarks/bench_replicas.py          # ~2 minutes on 2 cores

Prints, for each source, the relative spread (standard deviation / mean over replicas) of the
total energy at λ = 70, 300, 1000 and 2000. The table in docs/model.md.
"""

import numpy as np

from crumple.model import Wire
from crumple.protocol import Ramp, run_replicas

LAMS = (70.0, 300.0, 1000.0, 2000.0)

if __name__ == "__main__":
    cases = [
        ("initial noise 0.01 (default)", Wire(k_b=5, k_s=5e5), Ramp()),
        ("initial noise 0.4", Wire(k_b=5, k_s=5e5), Ramp(initial_noise=0.4)),
        ("stage kick 3 segments", Wire(k_b=5, k_s=5e5), Ramp(stage_noise=3.0)),
        ("rest-angle disorder 0.01 rad", Wire(k_b=5, k_s=5e5, rest_angle_sd=0.01), Ramp()),
        ("rest-angle disorder 0.05 rad", Wire(k_b=5, k_s=5e5, rest_angle_sd=0.05), Ramp()),
    ]
    print(f"{'source':>30} " + " ".join(f"{'λ=' + format(v, 'g'):>9}" for v in LAMS))
    for name, wire, ramp in cases:
        reps = run_replicas(wire, ramp, n_replicas=6, seed=0, workers=None)
        e = np.array([[r.at(v).energy.total for v in LAMS] for r in reps])
        spread = e.std(axis=0, ddof=1) / e.mean(axis=0)
        bad = sum(not r.converged for r in reps)
        note = "" if not bad else f"  ({bad} replicas with unconverged stages)"
        print(f"{name:>30} " + " ".join(f"{v:>9.2g}" for v in spread) + note)
