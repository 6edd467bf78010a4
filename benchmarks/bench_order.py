"""The sparse factor's fill-reducing order on saved stages: reverse Cuthill–McKee (or the
natural order) against the order kept when a nested dissection of the nodes' positions is
also tried (``LDLT(points=...)``, the default above 10³ segments).

    python benchmarks/bench_order.py N DIR K [K …] [leaf=16] [repeat=5]
    python benchmarks/bench_order.py path N K DIR [maxiter=M]

builds the exact Hessian of the continuum wire at N segments (``bench_scale.continuum_wire``)
at the positions of stage K of the default schedule that ``bench_scale.py scale N save=DIR``
(or ``stage … save=DIR``) wrote, at that stage's λ, and analyses and factorises it in each
order: nonzeros of L, the factorisation's multiply-adds (Σ_j nnz(L_{:j})², the up-looking
LDLᵀ's work), and the CPU of the symbolic analysis (with the order's own computation), of a
factorisation and of a solve (the least of ``repeat``). Counts are deterministic; the CPU is
this machine's, both orders measured in the same process.

``path`` re-minimises stage K from DIR's stage K - 1 in RCM's order (the nested dissection
and the rank-one modifications off), and does every factorisation and solve a second time
in the order kept with the nodes' positions: the CPU of both along the same path (a
different order would change the path by round-off, and a late stage's path at N = 10⁵ is
chaotic). Results in docs/performance.md,
"Nested dissection".
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(__file__))

import numpy as np
from bench_scale import continuum_wire

from crumple.energy import WireEnergy
from crumple.linalg import LDLT
from crumple.linalg_order import nested_dissection
from crumple.protocol import Ramp


def least(fn, repeat):
    """(the least CPU of ``repeat`` calls of fn, its last result)."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def measure(h, points, repeat):
    """nnz(L), multiply-adds, and the CPU of analysis, factorisation and solve in one order."""
    ldl = LDLT(points=None if points is None else (lambda: points))
    t_sym, sym = least(lambda: LDLT(points=ldl._points).symbolic(h), 1)
    ldl._sym = sym
    lnz = np.diff(sym.lp).astype(float)
    shift = np.full(h.indptr.shape[0] - 1, 1e3)  # positive definite, as a fallback's factor
    t_fac, f = least(lambda: ldl.factorize(h, shift=shift), repeat)
    b = np.ones(shift.shape[0])
    t_sol, _ = least(lambda: f.solve(b), repeat)
    kept = points is not None and np.array_equal(sym.perm, nested_dissection(points, h))
    return sym.l_nnz, float(np.sum(lnz * lnz)), t_sym, t_fac, t_sol, kept


def main(n, save, stages, leaf, repeat):
    from crumple import linalg_order

    linalg_order.ND_LEAF = leaf
    ramp, wire = Ramp(), continuum_wire(n)
    print(f"== N = {n}, nested-dissection leaf {leaf}, {repeat} repeats, from {save} ==")
    print("stage   λ        order     nnz(L)      mult-adds   analysis  factor    solve     "
          "dissection kept")  # fmt: skip
    for k in stages:
        x = np.load(os.path.join(save, f"N{n}_stage{k:02d}.npy"))
        h = WireEnergy(wire, ramp.lambdas[k - 1]).hessian_csc(x)
        rows = {name: measure(h, pts, repeat) for name, pts in (("RCM", None), ("points", x))}
        for name, (nnz, work, t_sym, t_fac, t_sol, kept) in rows.items():
            print(f"{k:5d}  {ramp.lambdas[k - 1]:8.4g}  {name:8s} {nnz:10d}  {work:11.3e}  "
                  f"{t_sym * 1e3:7.1f} ms {t_fac * 1e3:7.2f} ms {t_sol * 1e3:6.2f} ms  "
                  f"{'yes' if kept else ''}")  # fmt: skip
        (n0, w0, _, f0, s0, _), (n1, w1, _, f1, s1, _) = rows["RCM"], rows["points"]
        print(f"       RCM / by points: nnz(L) {n0 / n1:.2f}×, mult-adds {w0 / w1:.2f}×, factor "
              f"{f0 / f1:.2f}×, solve {s0 / s1:.2f}×", flush=True)  # fmt: skip


def shadowed_path(n, k, save, maxiter):
    """Stage k on RCM's path, each factorisation and solve shadowed in the dissection's order."""
    import collections

    from crumple import linalg, relax
    from crumple.relax import minimize_wire

    # the path: RCM's order, every factor a factorisation (a modified one has no shadow)
    relax.ORDER_BY_POINTS_ABOVE = relax.UPDATES_ABOVE = None
    points, cpu, calls = [None], collections.Counter(), collections.Counter()
    shadows = collections.OrderedDict()  # id(factor) -> (factor, its shadow), the last few
    factorize, solves = linalg.LDLT.factorize, {}

    def timed(key, fn, *args, **kwargs):
        t0 = time.process_time()
        out = fn(*args, **kwargs)
        cpu[key] += time.process_time() - t0
        return out

    def both(self, a, **kwargs):
        if getattr(self, "shadow", None) is None:
            self.shadow = LDLT(points=lambda: points[0])
        f = timed("RCM", factorize, self, a, **kwargs)
        shadows[id(f)] = (f, timed("dissection", factorize, self.shadow, a, **kwargs))
        calls["factorisations"] += 1
        while len(shadows) > 8:
            shadows.popitem(last=False)
        return f

    def shadowed(name):
        def run(self, *args, **kwargs):
            out = timed("RCM", solves[name], self, *args, **kwargs)
            pair = shadows.get(id(self))
            if pair is not None and pair[0] is self:
                timed("dissection", solves[name], pair[1], *args, **kwargs)
                calls[name] += 1
            return out

        return run

    ramp, wire = Ramp(curved_steps=True), continuum_wire(n)
    x = np.load(os.path.join(save, f"N{n}_stage{k - 1:02d}.npy"))
    hessian = WireEnergy.hessian_csc

    def at(self, y, **kwargs):
        points[0] = np.array(y, copy=True)
        return hessian(self, y, **kwargs)

    WireEnergy.hessian_csc, linalg.LDLT.factorize = at, both
    for name in ("solve", "solve_springs", "negative_direction"):
        solves[name] = getattr(linalg.Factorization, name)
        setattr(linalg.Factorization, name, shadowed(name))
    t0 = time.process_time()
    res = minimize_wire(wire, x, ramp.lambdas[k - 1], method="newton", ftol=ramp.ftol,
                        maxiter=maxiter or ramp.maxiter, max_step=ramp.max_step,
                        curved_steps=True, fallback=ramp.fallback)  # fmt: skip
    total = time.process_time() - t0
    print(f"== N = {n}, stage {k} (λ = {ramp.lambdas[k - 1]:.4g}) from {save}'s stage {k - 1}, "
          f"RCM's path: {res.iterations} iterations, converged {res.converged}, {total:.1f} s "
          f"CPU with the shadow; {dict(calls)} ==")  # fmt: skip
    print(f"  factorisations and solves: RCM {cpu['RCM']:.1f} s, the dissection's order "
          f"{cpu['dissection']:.1f} s ({cpu['RCM'] / cpu['dissection']:.2f}×); the rest of "
          f"the stage {total - cpu['RCM'] - cpu['dissection']:.1f} s")  # fmt: skip


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if "=" not in a]
    flags = dict(a.split("=", 1) for a in sys.argv[1:] if "=" in a)
    if args[:1] == ["path"] and len(args) == 4:
        shadowed_path(int(args[1]), int(args[2]), args[3], int(flags.get("maxiter", 0)))
        raise SystemExit
    if len(args) < 3:
        raise SystemExit(__doc__)
    main(int(args[0]), args[1], [int(k) for k in args[2:]], int(flags.get("leaf", 16)),
         int(flags.get("repeat", 5)))  # fmt: skip
