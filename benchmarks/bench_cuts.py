"""One stage of a saved ramp: the steps collision detection cuts, and how far their pair was.

    python benchmarks/bench_cuts.py N K DIR [maxiter=M] [approach=on|off]

Stage K (1-based, the default schedule, curved steps) at N = ``N`` is re-minimised from the
positions of stage K - 1 that ``bench_scale.py scale … save=DIR`` wrote, with the wire's
``step_limit`` wrapped (instrumentation only, the iterates unchanged). For every step it cuts
(a safe fraction t < 1), the node-segment pairs within a hundredth of the hard core d at the
contact are found, and the line prints t, the step's largest row displacement, and the
nearest of those pairs' distance before the step and at 0.8 t (the default cut), in segment
lengths. The barriers' listing holds the pairs within d + a tenth of a segment (the Verlet
list), so a pair farther than that was not in the step's model. ``approach=on`` runs the stage
with the approach cut (``relax.APPROACH_ABOVE = 0``). Results: docs/performance.md, "The last
stages of the N = 10⁵ schedule".
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

import crumple.relax as relax
from crumple.geometry import node_segment_pairs, point_segment_distance
from crumple.protocol import Ramp


def _nearest(x, ks, js):
    return min(point_segment_distance(x[k], x[j], x[j + 1]) for k, j in zip(ks, js, strict=True))


def _recording(rows, d):
    """``relax._step_limit`` wrapped: each cut step's (t, |p|, gap before, gap at 0.8 t)."""
    made = relax._step_limit

    def step_limit(radius):
        limit = made(radius)

        def wrapped(x, p):
            t = limit(x, p)
            if t < 1.0:
                ks, js = node_segment_pairs(x + t * p, 0.01 * d)
                far = _nearest(x, ks, js) if len(ks) else np.nan
                cut = _nearest(x + 0.8 * t * p, ks, js) if len(ks) else np.nan
                rows.append((t, float(np.max(np.hypot(*p.T))), far, cut))
            return t

        return wrapped

    return step_limit


def main(n, k, folder, maxiter=5000, approach=False):
    wire, ramp = continuum_wire(n), Ramp(curved_steps=True)
    lam = ramp.lambdas[k - 1]
    x0 = np.load(os.path.join(folder, f"N{n}_stage{k - 1:02d}.npy"))
    rows: list = []
    saved = relax._step_limit, relax.APPROACH_ABOVE
    relax._step_limit = _recording(rows, wire.hard_core)
    relax.APPROACH_ABOVE = 0 if approach else None
    t0 = time.process_time()
    try:
        res = relax.minimize_wire(wire, x0, lam, ftol=ramp.ftol, maxiter=maxiter,
                                  max_step=ramp.max_step, curved_steps=True)  # fmt: skip
    finally:
        relax._step_limit, relax.APPROACH_ABOVE = saved
    seg = wire.rest_length
    print(f"== N = {n}, stage {k} (λ = {lam:.4g}) from {folder}'s stage {k - 1}, approach cut "
          f"{'on' if approach else 'off'}: {res.iterations} iterations, converged "
          f"{res.converged}, energy {res.energy:.12g}, {time.process_time() - t0:.1f} s CPU; "
          f"d = {wire.hard_core / seg:.2g} segments, listed within d + 0.1 ==")  # fmt: skip
    print("   t |p| gap-before gap-at-0.8t (segments)")
    for t, p, far, cut in rows:
        print(f"  {t:9.3g} {p / seg:9.3g} {far / seg:9.3g} {cut / seg:9.3g}")
    far = np.array([r[2] for r in rows]) / seg
    print(f"  {len(rows)} cut steps, {int(np.sum(far > wire.hard_core / seg + 0.1))} with the "
          f"pair outside the listing, median gap {np.nanmedian(far) if len(far) else 0:.3g} "
          "segments")  # fmt: skip


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if "=" not in a]
    flags = dict(a.split("=", 1) for a in sys.argv[1:] if "=" in a)
    if len(args) != 3 or flags.get("approach", "off") not in ("on", "off"):
        raise SystemExit(__doc__)
    main(int(args[0]), int(args[1]), args[2], int(flags.get("maxiter", 5000)),
         flags.get("approach", "off") == "on")  # fmt: skip
