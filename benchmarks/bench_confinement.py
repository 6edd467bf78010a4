"""Strong confinement: Newton on the contact stages of the continuum study (issues 9 and 12).

    python benchmarks/bench_confinement.py ramp N LAMBDA_MAX STAGES [d] [eps] [maxiter]
    python benchmarks/bench_confinement.py diagnose N STAGE [d] [eps] [iterations]

``ramp``: the continuum study's wire (k_b = 1, k_s stiff for Λ_max: ``continuum.wire_point``,
per-length trap) ramped through Λ = geomspace(10², Λ_max, STAGES), seed 0; one line per stage
with Newton iterations, convergence, max force, r_max/ℓ (ℓ = L Λ^-1/4), hard-core pairs in
contact (node–segment pairs closer than d), the closest of them over d, and CPU. Defaults
d = 10⁻⁵, ε = 10⁻³ (the model's), maxiter 5000 (the ramp's).

``diagnose``: ramps to stage STAGE - 1 of ``ramp N 1e8 25``, then runs stage STAGE for
``iterations`` Newton iterations and classifies every step's first trial point: accepted,
rejected by Armijo (and which energy term rose most), rejected as infeasible; with the median
trust radius, displacement and collision-detection cut. Results: docs/performance.md,
"Strong confinement".
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

import crumple.minimize as minimize_module
from crumple.continuum import wire_point
from crumple.energy import WireEnergy
from crumple.geometry import node_segment_pairs
from crumple.model import Wire
from crumple.protocol import Ramp, minimize_wire, run_ramp

TERMS = ("bending", "stretching", "confinement", "hard_core")


def study_wire(n, lam_max, stages, d=1e-5, eps=1e-3):
    p = wire_point(list(np.geomspace(1e2, lam_max, stages)), n_segments=n, k_b=1.0)
    wire = Wire(k_b=p["k_b"], k_s=p["k_s"], n_segments=n, confinement="per-length",
                hard_core=d, hard_core_energy=eps)  # fmt: skip
    return wire, p["lambdas"]


def closest(x, ks, js) -> float:
    """The smallest node–segment distance D over the pairs (ks, js); inf if none."""
    if len(ks) == 0:
        return float("inf")
    a, b, p = x[js], x[js + 1], x[ks]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return float(np.min(np.hypot(*(p - a - t[:, None] * ab).T)))


def bench_ramp(n, lam_max, stages, d=1e-5, eps=1e-3, maxiter=5000):
    wire, lams = study_wire(n, lam_max, stages, d, eps)
    print(f"== N = {n}, k_b = 1, k_s = {wire.k_s:.3g}, d = {d:g}, ε = {eps:g}, "
          f"Λ = 1e2 … {lam_max:g} in {stages} stages, maxiter {maxiter}, seed 0 ==")  # fmt: skip
    print("  Λ | iterations | converged | max force | r_max/ℓ | pairs in contact | min D/d | CPU s")
    t0 = time.process_time()

    def line(i, n_stages, s):
        x = s.positions
        big = s.lam * n / wire.k_b
        r_max = float(np.max(np.hypot(*x.T)))
        ks, js = node_segment_pairs(x, d)
        near = closest(x, ks, js) / d
        print(f"  {big:.3g} | {s.result.iterations} | {s.result.converged} | "
              f"{s.result.max_force:.2g} | {r_max * big**0.25:.3f} | {len(ks)} | {near:.3g} | "
              f"{time.process_time() - t0:.1f}", flush=True)  # fmt: skip

    r = run_ramp(wire, Ramp(lambdas=lams, maxiter=maxiter), seed=0, progress=line)
    print(f"  stages converged {sum(s.result.converged for s in r.stages)}/{len(r.stages)}, "
          f"{time.process_time() - t0:.1f} s CPU")  # fmt: skip


def bench_diagnose(n, stage, d=1e-5, eps=1e-3, iterations=800):
    wire, lams = study_wire(n, 1e8, 25, d, eps)
    x = run_ramp(wire, Ramp(lambdas=lams[:stage]), seed=0).stages[-1].positions
    lam = lams[stage]
    energy = WireEnergy(wire, lam)
    rows, kinds = [], {"accepted": 0, "armijo": 0, "infeasible": 0}
    saved = minimize_module._line_search

    def traced(st, fun, p, step_limit, feasible, armijo, max_backtracks, max_step):
        biggest = float(np.max(np.hypot(*p.reshape(-1, 2).T)))
        alpha = min(1.0, st.radius / biggest)
        safe = step_limit(st.x, alpha * p) if step_limit is not None else 1.0
        alpha *= 0.8 * safe if safe < 1.0 else 1.0
        xt = st.x + alpha * p
        et = fun(xt)[0]
        if not et <= st.e + armijo * alpha * float(np.vdot(st.g, p)):
            kinds["armijo"] += 1
            a, b = energy.terms(st.x), energy.terms(xt)
            rise = [getattr(b, t) - getattr(a, t) for t in TERMS]
            rows.append(TERMS[int(np.argmax(rise))])
        elif feasible is not None and not feasible(xt):
            kinds["infeasible"] += 1
        else:
            kinds["accepted"] += 1
        out = saved(st, fun, p, step_limit, feasible, armijo, max_backtracks, max_step)
        traced.radius.append(st.radius)
        traced.safe.append(safe)
        traced.moved.append(float(np.max(np.hypot(*(st.x - traced.last).T))))
        traced.last = st.x.copy()
        return out

    traced.radius, traced.safe, traced.moved, traced.last = [], [], [], x.copy()
    minimize_module._line_search = traced
    try:
        r = minimize_wire(wire, x, lam, maxiter=iterations)
    finally:
        minimize_module._line_search = saved
    big = lam * n / wire.k_b
    print(f"== N = {n}, stage {stage} (Λ = {big:.3g}), d = {d:g}, ε = {eps:g}: {r.iterations} "
          f"iterations, converged {r.converged}, max force {r.max_force:.2g} ==")  # fmt: skip
    print(f"  first trial point: {kinds}; Armijo rejections led by "
          f"{ {t: rows.count(t) for t in TERMS} }")  # fmt: skip
    print(f"  median trust radius {np.median(traced.radius):.2g}, median node displacement "
          f"{np.median(traced.moved):.2g}, steps cut by collision detection "
          f"{np.mean(np.array(traced.safe) < 1):.0%}")  # fmt: skip


if __name__ == "__main__":
    what, args = (sys.argv[1] if len(sys.argv) > 1 else ""), sys.argv[2:]
    if what == "ramp" and len(args) >= 3:
        bench_ramp(int(args[0]), float(args[1]), int(args[2]), *map(float, args[3:5]),
                   *map(int, args[5:6]))  # fmt: skip
    elif what == "diagnose" and len(args) >= 2:
        bench_diagnose(int(args[0]), int(args[1]), *map(float, args[2:4]), *map(int, args[4:5]))
    else:
        raise SystemExit(__doc__)
