"""The joint caps' curvature and the Newton fallback's shift: fallback "exact" against "caps".

    python benchmarks/bench_caps.py stage N K DIR [fallback=exact|caps]
    python benchmarks/bench_caps.py ramps N [N …] [seeds=0,1]

``stage``: stage K (1-based, the default schedule, curved steps) at N = ``N`` re-minimised from
the positions of stage K - 1 that ``bench_scale.py scale … save=DIR`` wrote, with the
minimiser's direction and line search wrapped (instrumentation only, the iterates unchanged).
For every Newton iteration it records whether the exact Hessian's step was taken, the
fallback's shift σ (per unit length: the metric M is the nodes' lengths), the hard-core pairs
in the core split by where their closest point lies (a segment's end, where D is a
point-point distance and the pair's block has an eigenvalue of about -2F/D; or its interior),
each kind's most negative block eigenvalue over M, and the step's largest row displacement in
segments as the direction gives it (p), after the contact springs' model (q) and as accepted.
It prints their summaries; ``fallback=caps`` runs the stage with those blocks projected in the
fallback (``minimize_wire(fallback="caps")``).

``ramps``: the default schedule of the continuum wire at each N, for each seed, with the
fallback "exact" (the default above 10³ segments) and "caps" in turn in one process: Newton
iterations per contact stage, CPU, converged stages, pairs in contact at the last stage.
Results: docs/performance.md, "The joint caps' curvature and the fallback's shift".
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

import crumple.minimize as minimize
from crumple.energy_kernels import _contact_triplets
from crumple.geometry import node_segment_pairs
from crumple.geometry.distance import _point_segment
from crumple.minimize import max_force
from crumple.protocol import Ramp, run_ramp
from crumple.relax import minimize_wire


def _largest_row(v, seg):
    """The largest node displacement of a step, in segments."""
    return max_force(np.reshape(v, (-1, 2))) / seg


def _pairs_curvature(x, wire):
    """(at an end?, the most negative eigenvalue of the pair's exact 6 × 6 block) of every
    node-segment pair inside the core."""
    d, eps = wire.hard_core, wire.hard_core_energy
    ks, js = node_segment_pairs(x, d)
    rows, cols, vals = np.empty(36, np.int64), np.empty(36, np.int64), np.empty(36)
    out = []
    for k, j in zip(ks.tolist(), js.tolist(), strict=True):
        dist, t, _, _ = _point_segment(*x[k], *x[j], *x[j + 1])
        if not 0.0 < dist < d:
            continue
        _contact_triplets(x, np.array([k]), np.array([j]), d, eps, False, rows, cols, vals, 0)
        local = {2 * node + a: 2 * i + a for i, node in enumerate((k, j, j + 1)) for a in (0, 1)}
        block = np.zeros((6, 6))
        for r, c, v in zip(rows, cols, vals, strict=True):
            block[local[int(r)], local[int(c)]] += v
        out.append((not 0.0 < t < 1.0, float(np.linalg.eigvalsh(block)[0])))
    return out


def bench_stage(n: int, k: int, folder: str, fallback: str = "exact"):
    ramp = Ramp(curved_steps=True)
    wire = continuum_wire(n)
    seg, mass = wire.rest_length, wire.length / n  # an inner node's share of length
    x0 = np.load(os.path.join(folder, f"N{n}_stage{k - 1:02d}.npy"))
    rows, now = [], {}
    direction, line_search = minimize._direction, minimize._line_search

    def traced_direction(st, *args):
        p = direction(st, *args)
        pairs = _pairs_curvature(st.x.reshape(-1, 2), wire)
        ends = [lam for end, lam in pairs if end]
        inner = [lam for end, lam in pairs if not end]
        now.update(p=_largest_row(p, seg), exact=st.exact, sigma=st.sigma, ends=len(ends),
                   inner=len(inner), end_curv=-min(ends, default=0.0) / mass,
                   inner_curv=-min(inner, default=0.0) / mass)  # fmt: skip
        return p

    def traced_line_search(st, fun, p, *args):
        x = st.x.copy()
        why = line_search(st, fun, p, *args)
        if now:
            rows.append(dict(now, q=_largest_row(p, seg), taken=_largest_row(st.x - x, seg)))
        now.clear()
        return why

    minimize._direction, minimize._line_search = traced_direction, traced_line_search
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            t0 = time.process_time()
            res = minimize_wire(
                wire, x0, ramp.lambdas[k - 1], method="newton", ftol=ramp.ftol,
                maxiter=ramp.maxiter, max_step=ramp.max_step, curved_steps=True,
                fallback=fallback,
            )  # fmt: skip
            cpu = time.process_time() - t0
    finally:
        minimize._direction, minimize._line_search = direction, line_search
    _print_stage(n, k, fallback, res, cpu, rows)


def _print_stage(n, k, fallback, res, cpu, rows):
    col = {key: np.array([r[key] for r in rows], dtype=float) for key in rows[0]}
    shifted = col["exact"] == 0
    print(f"== N = {n}, stage {k}, fallback {fallback}: {res.iterations} iterations, "
          f"converged {res.converged}, energy {res.energy:.12g}, {cpu:.1f} s CPU (traced) "
          "==")  # fmt: skip
    print(f"  directions: {len(rows)}, the exact Hessian's {int(col['exact'].sum())}, the "
          f"fallback's {int(shifted.sum())}")  # fmt: skip
    sig = col["sigma"][shifted]
    print("  fallback's σ (per length), 10 / 50 / 90 %: "
          + " / ".join(f"{v:.3g}" for v in np.quantile(sig, [0.1, 0.5, 0.9])))  # fmt: skip
    for name, sel in (("σ > 1e6", sig > 1e6), ("σ ≤ 1e6", sig <= 1e6)):
        part = {key: v[shifted][sel] for key, v in col.items()}
        if not sel.any():
            print(f"  {name}: none")
            continue
        print(f"  {name}: {int(sel.sum())} iterations; median pairs in the core at an end "
              f"{np.median(part['ends']):.0f}, in a middle {np.median(part['inner']):.0f}; "
              f"median most negative block / M at an end {np.median(part['end_curv']):.3g}, "
              f"in a middle {np.median(part['inner_curv']):.3g}; median step p "
              f"{np.median(part['p']):.3g}, q {np.median(part['q']):.3g}, taken "
              f"{np.median(part['taken']):.3g} segments")  # fmt: skip
    print(f"  every iteration, median step p {np.median(col['p']):.3g}, q "
          f"{np.median(col['q']):.3g}, taken {np.median(col['taken']):.3g} segments; q < p/10 "
          f"in {np.mean(col['q'] < col['p'] / 10):.0%}, taken < q/10 in "
          f"{np.mean(col['taken'] < col['q'] / 10):.0%}", flush=True)  # fmt: skip


def bench_ramps(ns, seeds=(0, 1)):
    print("== default schedule, continuum wire, curved steps: fallback exact against caps ==")
    print("  N | seed | fallback | contact its/stage | CPU s | converged | contacts at the end")
    for n in ns:
        wire = continuum_wire(n)
        for seed in seeds:
            for fallback in ("exact", "caps"):
                ramp = Ramp(curved_steps=True, fallback=fallback)
                with threadpool_limits(limits=1, user_api="blas"):
                    t0 = time.process_time()
                    r = run_ramp(wire, ramp, seed=seed)
                    cpu = time.process_time() - t0
                contact = [s.result.iterations for s in r.stages if s.energy.hard_core > 0]
                pairs = len(node_segment_pairs(r.stages[-1].positions, wire.hard_core)[0])
                print(f"  {n} | {seed} | {fallback} | {np.mean(contact):.1f} ({len(contact)}) | "
                      f"{cpu:.1f} | {sum(s.result.converged for s in r.stages)}/{len(r.stages)} "
                      f"| {pairs}", flush=True)  # fmt: skip


def main(argv):
    if len(argv) >= 4 and argv[0] == "stage":
        flags = dict(a.split("=", 1) for a in argv[4:])
        bench_stage(int(argv[1]), int(argv[2]), argv[3], flags.get("fallback", "exact"))
    elif len(argv) >= 2 and argv[0] == "ramps":
        flags = dict(a.split("=", 1) for a in argv[1:] if "=" in a)
        seeds = tuple(int(s) for s in flags.get("seeds", "0,1").split(","))
        bench_ramps([int(a) for a in argv[1:] if "=" not in a], seeds)
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
