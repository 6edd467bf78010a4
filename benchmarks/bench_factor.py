"""The Newton matrix of a packed wire: crumple's own LDLᵀ against the wheels of issue 9, item 4.

    python benchmarks/bench_factor.py [N …] [state=FILE.npy] [repeat=R]

Issue 9 names the sparse solvers that install with pip alone (wheels for Python 3.11 on
Linux x86-64): qdldl, cholespy, pypardiso and pyamg, beside SciPy. None is a dependency of
crumple; this benchmark measures them where they are installed and says which are not::

    pip install qdldl cholespy pyamg pypardiso     # pypardiso brings MKL (0.72 GB)

The matrix is the one Newton's step factorises at an equilibrium: the exact Hessian of the
continuum wire (B = 0.05, S = 5000, per-length trap, d = ``bench_scale.hard_core_for(N)``) at
the last stage of the default schedule (λ = 2000), plus the rotation's gauge pin, which makes
it positive definite where the stage is stable. N ≤ 2 × 10⁴ is ramped first (the default
schedule with curved steps, seed 0: up to ~6 min); other N need ``state=`` the positions of a
``bench_scale.py scale N … save=DIR`` run (``DIR/N{N}_stage44.npy``).

Each solver is timed (CPU, one thread: ``time.process_time`` with OpenBLAS and MKL limited to
one thread; the median of ``repeat`` timings, each of as many calls as fill 20 ms) for what a
Newton iteration does with it: the analysis of a pattern (once per neighbour list), the
numeric factorisation of a new matrix in that pattern, and a solve; the residual
|Ax - b| / |b| says whether the solve is usable. What the step needs besides a solve is
listed: the inertia (the stability test and the fallback's trial factorisations count
negative pivots) and the direction Lᵀ⁻¹e_k of the first bad pivot (the fallback's negative
curvature). "crumple, AMD order" is crumple's factorisation in qdldl's order: the order's
share of a difference, apart from the code's. pyamg is iterative: its "analysis" is the
smoothed-aggregation hierarchy, its "factorisation" nothing, its solve preconditioned CG to a
relative residual of 10⁻¹⁰. Results: docs/performance.md, "Sparse solvers from wheels".
"""

from __future__ import annotations

import os
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(__file__))

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from bench_scale import continuum_wire
from threadpoolctl import threadpool_limits

from crumple import relax
from crumple.energy import WireEnergy
from crumple.linalg import LDLT
from crumple.minimize_modes import _gauge_pin
from crumple.protocol import Ramp, run_ramp
from crumple.relax import _symmetry_modes

LAST = 2000.0  # the default schedule's last λ


def newton_matrix(n: int, state: str | None):
    """(A, x): the gauge-pinned exact Hessian (SciPy CSC, both triangles) at the last stage."""
    wire = continuum_wire(n)
    if state is None:
        if n > 20_000:
            raise SystemExit(f"N = {n}: give state=FILE.npy (bench_scale.py scale {n} save=DIR)")
        r = run_ramp(wire, Ramp(curved_steps=True), seed=0)
        x = r.stages[-1].positions
    else:
        x = np.load(state)
        if x.shape != (n + 1, 2):
            raise SystemExit(f"{state} holds {x.shape[0] - 1} segments, not {n}")
    energy = WireEnergy(wire, lam=LAST)
    h = energy.hessian_csc(x)
    pin = _gauge_pin(h, _symmetry_modes(x, wire, LAST))
    a = sp.csc_matrix((h.data, h.indices, h.indptr), shape=(x.size, x.size))
    return (a + sp.diags(pin)).tocsc() if pin is not None else a, x


def _cpu(fn, repeat, least=0.02):
    """(result of the last call, CPU seconds per call): the median of ``repeat`` timings, each
    of enough calls to take ``least`` seconds (a factorisation at N = 100 takes ~40 µs)."""
    t0 = time.process_time()
    out = fn()
    calls = max(1, int(least / max(time.process_time() - t0, 1e-9)))
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        for _ in range(calls):
            out = fn()
        times.append((time.process_time() - t0) / calls)
    return out, float(np.median(times))


def crumple_ldlt(a, x, b, repeat):
    """crumple.linalg.LDLT: RCM, the natural order or (above ``relax.ORDER_BY_POINTS_ABOVE``
    segments, as the ramps) a nested dissection of the nodes, whichever fills least; the
    inertia and the bad pivot's direction."""
    by_points = relax.ORDER_BY_POINTS_ABOVE is not None and len(x) - 1 > relax.ORDER_BY_POINTS_ABOVE
    pts = (lambda: x) if by_points else None
    ldl, t_an = _cpu(lambda: _analysed(a, pts), repeat)
    f, t_fac = _cpu(lambda: ldl.factorize(a), repeat)
    s, t_sol = _cpu(lambda: f.solve(b), repeat)
    return dict(analysis=t_an, factor=t_fac, solve=t_sol, x=s, inertia="yes", direction="yes",
                fill=ldl.symbolic(a).l_nnz)  # fmt: skip


def _analysed(a, pts):
    ldl = LDLT(points=pts)
    ldl.symbolic(a)
    return ldl


class _GivenOrder(LDLT):
    """crumple's LDLᵀ with a given fill-reducing order as the candidate of its analysis (which
    keeps it where it fills least, as against RCM and the natural order)."""

    def __init__(self, order):
        super().__init__()
        self._order = order

    def _candidate(self, a):
        return self._order


def crumple_in_amd_order(a, x, b, repeat):
    """crumple.linalg.LDLT given qdldl's AMD order as its candidate: what the order does, apart
    from the factorisation's code. Needs qdldl (its ``factors()`` gives the order)."""
    import qdldl

    order = np.asarray(qdldl.Solver(sp.triu(a, format="csc"), upper=True).factors()[2])
    ldl = _GivenOrder(order)
    sym = ldl.symbolic(a)
    f, t_fac = _cpu(lambda: ldl.factorize(a), repeat)
    s, t_sol = _cpu(lambda: f.solve(b), repeat)
    chosen = "AMD's" if np.array_equal(sym.perm, order) else "not AMD's"
    return dict(analysis=None, factor=t_fac, solve=t_sol, x=s, inertia="yes", direction="yes",
                note=f"order kept: {chosen}", fill=sym.l_nnz)  # fmt: skip


def qdldl_solver(a, x, b, repeat):
    """qdldl (OSQP's LDLᵀ, AMD order): ``Solver(A)`` analyses and factorises, ``update(A)``
    refactorises in the known pattern. It gives no inertia or pivots to Python."""
    import qdldl

    upper = sp.triu(a, format="csc")  # given as the upper triangle: not cut again in the timing
    f, t_both = _cpu(lambda: qdldl.Solver(upper, upper=True), repeat)
    _, t_fac = _cpu(lambda: f.update(upper, upper=True), repeat)
    s, t_sol = _cpu(lambda: f.solve(b), repeat)
    return dict(analysis=max(t_both - t_fac, 0.0), factor=t_fac, solve=t_sol, x=s,
                inertia="no", direction="no")  # fmt: skip


def cholespy_solver(a, x, b, repeat):
    """cholespy (CHOLMOD's supernodal Cholesky on the CPU): the constructor analyses and
    factorises; no refactorisation in a known pattern, and a matrix that is not positive
    definite fails (no inertia, no direction)."""
    from cholespy import CholeskySolverD, MatrixType

    n = a.shape[0]
    coo = a.tocoo()
    rows, cols = coo.row.astype(np.int32), coo.col.astype(np.int32)

    def build():
        return CholeskySolverD(n, rows, cols, coo.data.copy(), MatrixType.COO)

    f, t_both = _cpu(build, repeat)

    def solve():
        out = np.zeros(n)
        f.solve(b.copy(), out)
        return out

    s, t_sol = _cpu(solve, repeat)
    return dict(analysis=None, factor=t_both, solve=t_sol, x=s, inertia="no (fails)",
                direction="no", note="analysis + factorisation together")  # fmt: skip


def pardiso_solver(a, x, b, repeat):
    """pypardiso (MKL PARDISO, real symmetric indefinite, mtype -2): phase 11 analyses, 22
    factorises, 33 solves; the inertia is MKL's iparm(22), iparm(23). Through pypardiso's
    ``_call_pardiso``, which copies the index arrays to 1-based int32 at every phase (an
    O(nnz) cost counted against it)."""
    import pypardiso

    upper = sp.triu(a, format="csr")
    upper.sort_indices()
    p = pypardiso.PyPardisoSolver(mtype=-2)  # one thread: MKL_NUM_THREADS=1, set above

    def phase(k, rhs):
        p.set_phase(k)
        return p._call_pardiso(upper, rhs)

    b2 = np.asfortranarray(b.reshape(-1, 1))
    _, t_an = _cpu(lambda: phase(11, b2), repeat)
    _, t_fac = _cpu(lambda: phase(22, b2), repeat)
    s, t_sol = _cpu(lambda: phase(33, b2).ravel(), repeat)
    neg = p.get_iparm(23)  # iparm(23): the negative pivots of the last factorisation
    phase(-1, b2)  # free PARDISO's memory
    return dict(analysis=t_an, factor=t_fac, solve=t_sol, x=s, inertia=f"yes ({neg} negative)",
                direction="no")  # fmt: skip


def pyamg_solver(a, x, b, repeat):
    """pyamg: smoothed aggregation on the 2 × 2 blocks of the nodes (BSR; otherwise pyamg's
    defaults), then CG preconditioned by one V-cycle, to a relative residual of 10⁻¹⁰ (at most
    500 iterations)."""
    import pyamg

    blocks = a.tobsr(blocksize=(2, 2))
    ml, t_an = _cpu(lambda: pyamg.smoothed_aggregation_solver(blocks, symmetry="symmetric"),
                    repeat)  # fmt: skip
    its = []

    def solve():
        res = []
        s = ml.solve(b, tol=1e-10, accel="cg", maxiter=500, residuals=res)
        its.append(len(res) - 1)
        return s

    s, t_sol = _cpu(solve, repeat)
    return dict(analysis=t_an, factor=0.0, solve=t_sol, x=s, inertia="no", direction="no",
                note=f"{its[-1]} CG iterations")  # fmt: skip


def scipy_splu(a, x, b, repeat):
    """SciPy's SuperLU as the landed engine called it (``benchmarks/legacy_newton.py``: MMD on
    AᵀA + A, symmetric mode, no off-diagonal pivoting, so that U's diagonal holds the pivots of
    an LDLᵀ and their signs the inertia); no symbolic reuse."""

    def factor():
        return spla.splu(a, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                         options={"SymmetricMode": True})  # fmt: skip

    f, t_fac = _cpu(factor, repeat)
    s, t_sol = _cpu(lambda: f.solve(b), repeat)
    neg = int((f.U.diagonal() < 0).sum())
    return dict(analysis=None, factor=t_fac, solve=t_sol, x=s, inertia=f"yes ({neg} negative)",
                direction="no", note="analysis + factorisation together")  # fmt: skip


SOLVERS = {
    "crumple LDLT": crumple_ldlt,
    "crumple, AMD order": crumple_in_amd_order,
    "qdldl": qdldl_solver,
    "cholespy": cholespy_solver,
    "pypardiso": pardiso_solver,
    "pyamg (SA + CG)": pyamg_solver,
    "scipy splu (landed)": scipy_splu,
}


def _ms(t):
    return "—" if t is None else f"{t * 1e3:9.3f}"


def bench(n: int, state: str | None, repeat: int) -> None:
    a, x = newton_matrix(n, state)
    b = np.random.default_rng(0).standard_normal(a.shape[0])
    print(f"== N = {n}: {a.shape[0]} unknowns, {a.nnz} nonzeros (both triangles), λ = {LAST:g}, "
          f"ms CPU (one thread, median of {repeat}) ==")  # fmt: skip
    print(f"  {'solver':20s} {'analysis':>9s} {'factor':>9s} {'solve':>9s} {'residual':>9s}  "
          "inertia | bad pivot's direction | note")  # fmt: skip
    for name, fn in SOLVERS.items():
        try:
            with threadpool_limits(limits=1):
                r = fn(a, x, b, repeat)
        except ImportError:
            print(f"  {name:20s} not installed")
            continue
        except Exception as exc:  # a solver that fails on this matrix says why
            print(f"  {name:20s} failed: {type(exc).__name__}: {exc}")
            continue
        res = np.linalg.norm(a @ r["x"] - b) / np.linalg.norm(b)
        extra = "; ".join(str(r[k]) for k in ("note", "fill") if k in r)
        print(f"  {name:20s} {_ms(r['analysis'])} {_ms(r['factor'])} {_ms(r['solve'])} "
              f"{res:9.1e}  {r['inertia']} | {r['direction']} | {extra}", flush=True)  # fmt: skip


def main(argv):
    flags = dict(a.split("=", 1) for a in argv if "=" in a)
    ns = [int(float(a)) for a in argv if "=" not in a] or [100, 1000]
    if "state" in flags and len(ns) != 1:
        raise SystemExit("state= goes with one N")
    for n in ns:
        bench(n, flags.get("state"), int(flags.get("repeat", 5)))


if __name__ == "__main__":
    main(sys.argv[1:])
