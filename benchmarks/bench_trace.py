"""One stage of a saved ramp, iteration by iteration: what its Newton steps are made of.

    python benchmarks/bench_trace.py N K DIR [maxiter=M] [curved=on|off] [every=W]

Stage K (1-based, the default schedule) at N = ``N`` is re-minimised from the positions of stage
K - 1 that ``bench_scale.py scale … save=DIR`` wrote, with the minimiser's private steps wrapped
(instrumentation only, the iterates unchanged): per iteration, whether the direction is the
exact Hessian's (1) or the fallback's (0) and its shift σ (per unit length), the direction p,
the springs' step q, the accurate springs' refinement kept or not and how its CG stopped, the
step given to the line search, the trust radius R and the accepted move, all as largest row
displacements in segment lengths, and the springs listed. Then a summary per window of W
iterations. The assembled Hessian's resolution at the start (``minimize_accurate``) is printed
beside σ: a shift below it is set by round-off. Results: docs/performance.md, "The accurate
springs' step on its way".
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

import crumple.minimize as mz
import crumple.minimize_krylov as mk
from crumple.energy import WireEnergy
from crumple.minimize_accurate import _assembly_resolution
from crumple.minimize_result import max_force
from crumple.protocol import Ramp
from crumple.relax import minimize_wire, node_lengths


def _wrapped(rows):
    """Wrap the direction, the accurate springs' step, its CG and the line search so that each
    iteration appends one dict to ``rows``; returns the function that undoes it."""
    cur: dict = {}
    saved = mz._direction, mz._line_search, mz._accurate_spring_step, mk._cg

    def direction(st, *args):
        p = saved[0](st, *args)
        cur.update(exact=st.exact, sigma=st.sigma, p=max_force(p))
        return p

    def cg(st, *args):
        out = saved[3](st, *args)
        cur.setdefault("cg", []).append(f"{out[3]}@{out[2]}")
        return out

    def spring_step(st, q, springs, *args):
        s = saved[2](st, q, springs, *args)
        cur.update(q=max_force(q), kept=s is not q, listed=len(springs[2]))
        return s

    def line_search(st, fun, p, *args):
        x0, radius = st.x, st.radius
        out = saved[1](st, fun, p, *args)
        rows.append(dict(cur, it=st.it, radius=radius, step=max_force(p),
                         moved=max_force(st.x - x0)))  # fmt: skip
        cur.clear()
        return out

    mz._direction, mz._line_search, mz._accurate_spring_step = direction, line_search, spring_step
    mk._cg = cg

    def undo():
        mz._direction, mz._line_search, mz._accurate_spring_step, mk._cg = saved

    return undo


def _summary(rows, seg, every):
    """Medians per window of ``every`` iterations."""
    print(f"  per {every} iterations (medians; lengths in segments):")
    for lo in range(0, len(rows), every):
        w = rows[lo : lo + every]

        def med(key, w=w):
            vals = [r[key] for r in w if r.get(key) is not None]
            return float(np.median(vals)) if vals else float("nan")

        kept = [r["kept"] for r in w if "kept" in r]
        print(f"    {lo + 1:5d}+ exact {np.mean([bool(r.get('exact')) for r in w]):.2f} "
              f"σ {med('sigma'):.2e} p {med('p') / seg:8.2f} q {med('q') / seg:7.2f} "
              f"R {med('radius') / seg:8.2f} moved {med('moved') / seg:7.2f} refinement kept "
              f"{sum(kept)}/{len(kept)} listed {med('listed'):.0f}")  # fmt: skip


def main(n, k, folder, maxiter=5000, curved=True, every=50):
    wire, ramp = continuum_wire(n), Ramp(curved_steps=curved)
    lam = ramp.lambdas[k - 1]
    x0 = np.load(os.path.join(folder, f"N{n}_stage{k - 1:02d}.npy"))
    m = np.repeat(node_lengths(wire), 2)
    resolution = _assembly_resolution(WireEnergy(wire, lam).hessian_csc(x0), m)
    rows: list = []
    undo = _wrapped(rows)
    t0 = time.process_time()
    try:
        res = minimize_wire(wire, x0, lam, ftol=ramp.ftol, maxiter=maxiter,
                            max_step=ramp.max_step, curved_steps=curved)  # fmt: skip
    finally:
        undo()
    seg = wire.rest_length
    print(f"== N = {n}, stage {k} (λ = {lam:.4g}) from {folder}'s stage {k - 1}: "
          f"{res.iterations} iterations, converged {res.converged}, energy {res.energy:.12g}, "
          f"max force {res.max_force:.3g}, "
          f"{time.process_time() - t0:.1f} s CPU; the assembled H's resolution at the start "
          f"{resolution:.3g} per unit length ==")  # fmt: skip
    print("   it exact σ p q step R moved kept listed cg")
    for r in rows:
        print(f"  {r['it']:4d} {int(bool(r.get('exact')))} {r.get('sigma', float('nan')):.2e} "
              f"{r.get('p', float('nan')) / seg:8.2f} {r.get('q', float('nan')) / seg:7.2f} "
              f"{r['step'] / seg:8.2f} {r['radius'] / seg:8.2f} {r['moved'] / seg:7.2f} "
              f"{int(r.get('kept', 0))} {r.get('listed', 0)} "
              f"{' '.join(r.get('cg', []))}")  # fmt: skip
    _summary(rows, seg, every)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if "=" not in a]
    flags = dict(a.split("=", 1) for a in sys.argv[1:] if "=" in a)
    if len(args) != 3 or flags.get("curved", "on") not in ("on", "off"):
        raise SystemExit(__doc__)
    main(int(args[0]), int(args[1]), args[2], int(flags.get("maxiter", 5000)),
         flags.get("curved", "on") == "on", int(flags.get("every", 50)))  # fmt: skip
