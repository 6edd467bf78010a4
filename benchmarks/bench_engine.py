"""Benchmarks of the core engine; every timing is printed next to a baseline run in-process.

    python benchmarks/bench_engine.py            # everything (a few minutes)
    python benchmarks/bench_engine.py energy     # energy + gradient per node against N
    python benchmarks/bench_engine.py ramp       # the default ramp, N = 100
    python benchmarks/bench_engine.py solvers    # Newton vs NR Powell, L-BFGS-B, one stage
    python benchmarks/bench_engine.py ramp1000   # a full ramp at N = 1000

Run on an otherwise idle machine; numbers are medians of repeats, after JIT warm-up.
Results are recorded in docs/performance.md.
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from scipy.optimize import minimize as scipy_minimize
from scipy.spatial import cKDTree

from crumple.energy import WireEnergy
from crumple.geometry import has_crossings, node_segment_pairs
from crumple.minimize import max_force
from crumple.model import Wire
from crumple.protocol import Ramp, default_schedule, minimize_wire, run_ramp


def median_time(fn, repeat=7, number=1):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - t0) / number)
    return float(np.median(times))


def spiral(n_segments: int, pitch: float) -> np.ndarray:
    """An Archimedean spiral of length 1, turns ``pitch`` apart, inner radius 5 segments.

    r = a φ with a = pitch / 2π; the arc length from φ0 is ≈ a (φ² - φ0²) / 2.
    """
    a = pitch / (2 * np.pi)
    phi0 = 5.0 / n_segments / a
    s = np.linspace(0.0, 1.0, n_segments + 1)
    phi = np.sqrt(phi0**2 + 2 * s / a)
    r = a * phi
    return np.c_[r * np.cos(phi), r * np.sin(phi)]


def numpy_baseline(wire: Wire, lam: float):
    """Energy + gradient with vectorised NumPy and SciPy's cKDTree for the hard core."""
    w = np.full(wire.n_nodes, wire.rest_length)
    w[[0, -1]] *= 0.5
    d, eps, l0 = wire.hard_core, wire.hard_core_energy, wire.rest_length

    def f(x):
        e = np.diff(x, axis=0)
        length = np.hypot(e[:, 0], e[:, 1])
        g = np.zeros_like(x)
        es = 0.5 * wire.k_s * np.sum((length - l0) ** 2)
        c = (wire.k_s * (length - l0) / length)[:, None] * e
        g[:-1] -= c
        g[1:] += c
        a, b = e[:-1], e[1:]
        th = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.einsum("ij,ij->i", a, b))
        eb = 0.5 * wire.k_b * np.sum(th**2)
        la2, lb2 = np.einsum("ij,ij->i", a, a), np.einsum("ij,ij->i", b, b)
        ga = np.c_[a[:, 1], -a[:, 0]] / la2[:, None]
        gb = np.c_[-b[:, 1], b[:, 0]] / lb2[:, None]
        df = (wire.k_b * th)[:, None]
        g[:-2] -= df * ga
        g[1:-1] += df * (ga - gb)
        g[2:] += df * gb
        ec = lam * np.sum(w * np.einsum("ij,ij->i", x, x))
        g += 2 * lam * w[:, None] * x
        # hard core: nodes near segment midpoints (radius d + half the longest segment)
        mid = 0.5 * (x[:-1] + x[1:])
        tree = cKDTree(mid)
        pairs = tree.query_ball_point(x, d + 0.5 * length.max(), return_sorted=False)
        ehc = 0.0
        for k, js in enumerate(pairs):
            for j in js:
                if j in (k - 1, k) or (k == 0 and j == 1) or (k == len(x) - 1 and j == k - 2):
                    continue
                p, q0, q1 = x[k], x[j], x[j + 1]
                ev = q1 - q0
                t = np.clip(np.dot(p - q0, ev) / np.dot(ev, ev), 0, 1)
                v = p - q0 - t * ev
                dist = np.hypot(*v)
                if dist < d:
                    u = dist / d
                    ehc += eps * (1 - u) ** 2 / u
                    cc = eps * (1 - 1 / u**2) / (d * dist)
                    g[k] += cc * v
                    g[j] -= cc * (1 - t) * v
                    g[j + 1] -= cc * t * v
        return eb + es + ec + ehc, g

    return f


def bench_energy():
    print("== energy + gradient with the hard core, ns per node ==")
    print("  cold: neighbour search in every call; warm: Verlet list reused, as in the minimiser")
    print("  baseline: vectorised NumPy elastic terms + SciPy cKDTree hard core, same energy")
    cols = ("N", "layout", "pairs<d", "cold", "warm", "baseline", "cold ratio")
    print("{:>8} {:>16} {:>8} {:>8} {:>8} {:>10} {:>11}".format(*cols))
    for n in (100, 1_000, 10_000, 100_000):
        d = min(1e-5, 0.1 / n)  # the paper's width, or a tenth of a segment for N = 1e5
        layouts = (
            ("loose (4 segs)", 4.0 / n),
            ("packed (2d)", 2 * d),
            ("touching (0.9d)", 0.9 * d),
        )
        for name, pitch in layouts:
            wire = Wire(k_b=5, k_s=5e5, n_segments=n, hard_core=d)
            x = spiral(n, pitch)
            if has_crossings(x):  # segments too long for so tight a spiral: not a wire
                continue
            f = WireEnergy(wire, 100.0)
            base = numpy_baseline(wire, 100.0)
            e1, g1 = f(x)
            e2, g2 = base(x)
            assert np.isclose(e1, e2, rtol=1e-9), (e1, e2)
            assert np.allclose(g1, g2, rtol=1e-6, atol=1e-6 * np.abs(g1).max())
            npairs = len(node_segment_pairs(x, d)[0])

            def cold(f=f, x=x):
                f._ref = None  # forget the list: search again
                f(x)

            number = max(1, 20_000 // n)
            t_cold = median_time(cold, repeat=9, number=number)
            t_warm = median_time(lambda f=f, x=x: f(x), repeat=9, number=number)
            t_b = median_time(lambda b=base, x=x: b(x), repeat=3, number=1)
            per = 1e9 / (n + 1)
            print(
                f"{n:>8} {name:>16} {npairs:>8} {t_cold * per:>8.1f} {t_warm * per:>8.1f} "
                f"{t_b * per:>10.0f} {t_b / t_cold:>10.0f}x"
            )


def bench_ramp():
    print("== default ramp: N = 100, k_b = 5, k_s = 5e5, 44 stages, per-length ==")
    wire = Wire(k_b=5, k_s=5e5)
    run_ramp(wire, Ramp(lambdas=(1, 2, 3)), seed=0)  # JIT warm-up
    times, its = [], []
    for seed in range(5):
        t0 = time.perf_counter()
        r = run_ramp(wire, seed=seed)
        times.append(time.perf_counter() - t0)
        its.append(sum(s.result.iterations for s in r.stages))
        status = "all converged" if r.converged else f"FAILED {r.failed_stages}"
        print(f"  seed {seed}: {times[-1]:.2f} s, {its[-1]} Newton iterations, {status}")
    per_iter = np.median(times) / np.median(its) * 1e3
    print(f"  median {np.median(times):.2f} s, {per_iter:.2f} ms per Newton iteration")


def bench_solvers():
    print("== one stage, same start: Newton vs NR Powell (the paper's, compiled) and L-BFGS-B ==")
    wire = Wire(k_b=5, k_s=5e5)
    lams = default_schedule()
    i = lams.index(70.0)
    prev = run_ramp(wire, Ramp(lambdas=lams[:i]), seed=0).stages[-1].positions
    f = WireEnergy(wire, 70.0)
    t0 = time.perf_counter()
    rn = minimize_wire(wire, prev, 70.0)
    tn = time.perf_counter() - t0
    print(f"  start: E = {f(prev)[0]:.10f}, max force {max_force(f(prev)[1]):.3g}")
    print(f"  newton : {tn:8.3f} s  E = {rn.energy:.10f}  max force {rn.max_force:.2e}  "
          f"converged={rn.converged}")  # fmt: skip
    for maxiter in (5, 20, 200):
        t0 = time.perf_counter()
        rp = minimize_wire(wire, prev, 70.0, method="powell", maxiter=maxiter,
                           rng=np.random.default_rng(1))  # fmt: skip
        tp = time.perf_counter() - t0
        print(
            f"  powell ({maxiter:3d} sweeps): {tp:6.2f} s  E = {rp.energy:.10f}  max force "
            f"{rp.max_force:.2e}  gap to Newton {rp.energy - rn.energy:.2e}  "
            f"time ratio {tp / tn:.0f}x  force ratio {rp.max_force / max(rn.max_force, 1e-300):.1e}"
        )

    def fun(z):  # L-BFGS-B cannot handle +inf: give it the energy, check crossings at the end
        e, g = f(z.reshape(-1, 2))
        return e, g.ravel()

    t0 = time.perf_counter()
    opts = {"maxiter": 20000, "maxfun": 40000, "gtol": 1e-6, "ftol": 1e-16}
    rl = scipy_minimize(fun, prev.ravel(), jac=True, method="L-BFGS-B", options=opts)
    tl = time.perf_counter() - t0
    xl = rl.x.reshape(-1, 2)
    fl = max_force(f(xl)[1])
    crossed = "crosses itself" if has_crossings(xl) else "no crossing"
    print(
        f"  L-BFGS-B: {tl:7.1f} s  E = {rl.fun:.10f}  max force {fl:.2e}  ({rl.nit} iterations, "
        f"{crossed}: {rl.message})  time ratio {tl / tn:.0f}x"
    )


def bench_ramp1000():
    print("== full default ramp at N = 1000 (same continuum wire: B = 0.05, S = 5000) ==")
    wire = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=1000)
    run_ramp(wire, Ramp(lambdas=(1, 2)), seed=0)
    t0 = time.perf_counter()
    r = run_ramp(wire, seed=0)
    dt = time.perf_counter() - t0
    its = sum(s.result.iterations for s in r.stages)
    status = "all converged" if r.converged else f"{len(r.failed_stages)} stages NOT converged"
    print(f"  {dt:.1f} s, {its} Newton iterations ({dt / its * 1e3:.1f} ms/iter), {status}")
    for lam, msg in r.failed_stages:
        print(f"    λ = {lam:g}: {msg}")


if __name__ == "__main__":
    which = sys.argv[1:] or ["energy", "ramp", "solvers", "ramp1000"]
    for w in which:
        {"energy": bench_energy, "ramp": bench_ramp, "solvers": bench_solvers,
         "ramp1000": bench_ramp1000}[w]()  # fmt: skip
        print()
