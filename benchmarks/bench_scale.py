"""The engine at scale (issue 9): counts and CPU time against N, and against the landed engine.

    python benchmarks/bench_scale.py ramp100         # default ramp N = 100: new vs landed
    python benchmarks/bench_scale.py smooth [N …] [curved=on|off]  # geomspace(1, 30, 12)
    python benchmarks/bench_scale.py scale 100 1000 [seed=0] [curved=on|off] [save=DIR]  # table
    python benchmarks/bench_scale.py stage N K[-K2] DIR [curved=on|off] [save=DIR2] [log=F]
                                  # stages K … K2 in sequence from DIR's K - 1; F: a line per
                                  # Newton iteration (CPU, energy, max force), as it goes
        (scale and stage also take fallback=auto|projected|exact|caps, the ramp's fallback,
         and d=X, the hard core instead of hard_core_for(N); scale takes coarsen=M, the ramp
         predicted by the same wire with N/M segments, Ramp(coarsen=M), and with it
         coarsest=none|K, protocol_coarse.COARSEST, and pairs=on, the coarse wire's ε per pair)
    python benchmarks/bench_scale.py decrease [N …] [trap=X]  # the force-resolution test
    python benchmarks/bench_scale.py bits            # the iterates' fingerprint (bit for bit?)
    python benchmarks/bench_scale.py lbfgs           # one stage: Newton vs SciPy L-BFGS-B
    python benchmarks/bench_scale.py cold            # N = 10⁴, straight wire, λ = 200
    python benchmarks/bench_scale.py compare         # stage energies, new vs landed
    python benchmarks/bench_scale.py contacts [N …]  # contact stages: springs on vs off
    python benchmarks/bench_scale.py gauge [N …]     # the rotation's gauge in the step: on vs off
    python benchmarks/bench_scale.py accurate [N …]  # default ramp, relax.ACCURATE_STABILITY on/off
    python benchmarks/bench_scale.py curved [N …] [seeds=0,1]  # default ramps, curved steps off/on
    python benchmarks/bench_scale.py crawl [N] [seed=] [stage=]  # one stage: what limits its steps
    python benchmarks/bench_scale.py fallback [N …] [seeds=0,1]  # projected / exact fallback

CPU time is ``time.process_time`` (one BLAS thread, as the ramps run), deterministic counts are
printed next to it. The landed engine is the frozen copy ``benchmarks/legacy_newton.py``.
Results are recorded in docs/performance.md.
"""

from __future__ import annotations

import contextlib
import os
import resource
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(__file__))

import legacy_newton
import numpy as np
from scipy.optimize import minimize as scipy_minimize
from threadpoolctl import threadpool_limits

from crumple.energy import WireEnergy
from crumple.geometry import has_crossings, node_segment_pairs
from crumple.minimize import max_force
from crumple.model import Wire
from crumple.protocol import Ramp, default_schedule, initial_state, minimize_wire, run_ramp

CONTINUUM = {"bending": 0.05, "stretching": 5000.0}


def _coarse_flags(flags):
    """``coarsest=none|K`` and ``pairs=on`` of ``scale``: the predictor's levels
    (``protocol_coarse.COARSEST``) and its coarse wire's ε per node–segment pair
    (``protocol_coarse.CONTACT_PER_LENGTH = False``), both the twenty-eighth stop's
    predictor."""
    from crumple import protocol_coarse

    if "coarsest" in flags:
        v = flags["coarsest"]
        protocol_coarse.COARSEST = None if v == "none" else int(v)
    if flags.get("pairs") == "on":
        protocol_coarse.CONTACT_PER_LENGTH = False


def hard_core_for(n: int) -> float:
    """The hard-core rule of the scaling runs: d = min(10⁻⁵, L0 / (10 N)), so that d stays
    below a tenth of the segment length (at N = 10⁵ the segment is 10⁻⁵ long)."""
    return min(1e-5, 0.1 / n)


def continuum_wire(n: int, hard_core: float | None = None) -> Wire:
    """The continuum wire of N = ``n`` segments, its hard core ``hard_core`` (None:
    :func:`hard_core_for`)."""
    d = hard_core_for(n) if hard_core is None else hard_core
    return Wire.from_continuum(**CONTINUUM, n_segments=n, hard_core=d)


def cpu(fn):
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def bench_ramp100(repeat: int = 3):
    print("== default ramp, N = 100 (k_b = 5, k_s = 5e5, 44 stages, seed 0): new vs landed ==")
    wire = Wire(k_b=5, k_s=5e5)
    run_ramp(wire, Ramp(lambdas=(1.0, 100.0, 1000.0)), seed=0)  # compile
    with threadpool_limits(limits=1, user_api="blas"):
        legacy_newton.legacy_run_ramp(wire, (1.0, 100.0), seed=0)
        new_t, old_t = [], []
        for _ in range(repeat):
            r, t = cpu(lambda: run_ramp(wire, seed=0))
            new_t.append(t)
            legacy_newton.FACTORIZATIONS[0] = 0
            old, t = cpu(lambda: legacy_newton.legacy_run_ramp(wire, default_schedule(), seed=0))
            old_t.append(t)
    its = sum(s.result.iterations for s in r.stages)
    fac = sum(s.result.factorizations for s in r.stages)
    old_its = sum(s.iterations for s in old)
    old_fac = legacy_newton.FACTORIZATIONS[0]
    tn, to = float(np.median(new_t)), float(np.median(old_t))
    print(f"  new   : {tn:.3f} s CPU, {its} iterations, {fac / its:.2f} factorisations each, "
          f"{tn / its * 1e3:.3f} ms per iteration, all converged: {r.converged}, "
          f"E_final = {r.stages[-1].energy.total:.10f}")  # fmt: skip
    print(f"  landed: {to:.3f} s CPU, {old_its} iterations, {old_fac / old_its:.2f} "
          f"factorisations each, {to / old_its * 1e3:.3f} ms per iteration, all converged: "
          f"{all(s.converged for s in old)}, E_final = {old[-1].energy:.10f}")  # fmt: skip
    print(f"  speed-up (CPU, median of {repeat}): {to / tn:.2f}x")


def bench_smooth(ns=(100, 1000, 2000, 10_000), curved=None):
    """The acceptance's smooth stages: iterations per stage and the buckling stage at each N.
    ``curved``: the ramp's ``curved_steps`` (None: the default)."""
    ramp = Ramp(lambdas=tuple(np.geomspace(1.0, 30.0, 12)), curved_steps=curved)
    print("== smooth stages: geomspace(1, 30, 12), continuum B = 0.05, S = 5000, seed 0, "
          f"curved steps {'on' if ramp.curved_steps else 'off'} ==")  # fmt: skip
    for n in ns:
        progress = _stage_line(n) if n >= 10_000 else None
        r, t = cpu(lambda n=n, p=progress: run_ramp(continuum_wire(n), ramp, seed=0, progress=p))
        its = [s.result.iterations for s in r.stages]
        bent = next((i for i, s in enumerate(r.stages) if s.energy.bending > 1e-3), None)
        where = "never" if bent is None else f"at stage {bent} (λ = {ramp.lambdas[bent]:.3g})"
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
        cg = sum(s.result.krylov_iterations for s in r.stages)
        print(f"  N = {n:6d}: {sum(its):4d} iterations {its}, buckled {where}, {t:.2f} s CPU, "
              f"max RSS {rss:.2f} GiB, converged {sum(s.result.converged for s in r.stages)}/"
              f"{len(r.stages)}, {cg} CG iterations of accurate steps", flush=True)  # fmt: skip
        for s in r.stages:
            if not s.result.converged:
                print(f"    λ = {s.lam:.4g}: {s.result.message}", flush=True)


def _stage_line(n):
    """A progress line per stage on stderr (large N: a stage can take minutes)."""
    t0 = time.process_time()

    def line(i, total, st):
        res = st.result
        print(f"    N = {n}, stage {i + 1}/{total}, λ = {st.lam:.4g}: {res.iterations} "
              f"iterations, converged {res.converged}, max force {res.max_force:.2g}, "
              f"bending {st.energy.bending:.3g}, {time.process_time() - t0:.0f} s CPU"
              f"{_passes(res.message)}", file=sys.stderr, flush=True)  # fmt: skip
        if not res.converged:
            print(f"      {res.message}", file=sys.stderr, flush=True)

    return line


def _passes(message: str) -> str:
    """The passes after the first that a stage's message reports (``relax_polish``): the
    polish in the displacement, and the retry in the coordinates from its end, with their
    iterations."""
    import re

    labels = {
        "polished in the displacement": "polished",
        "not polished": "polish failed",
        "from the end of a polish": "polish failed",
        "retried in the coordinates": "retry",
    }
    found = re.findall(rf"({'|'.join(labels)}) \((\d+) iterations", message)
    return "".join(f"; {labels[what]} {its} its" for what, its in found)


def bench_decrease(ns=(10_000,), trap=0.0):
    """The smooth ramp's stages, curved steps off and on: the decrease a Newton step predicts
    at each accepted point against that of a one-ulp move
    (``minimize_resolution._newton_decrease``, the force-resolution test of the fourth stop),
    and the energy. ``trap``: the trap's x."""
    from types import SimpleNamespace

    from crumple.linalg import LDLT
    from crumple.minimize_modes import _modes
    from crumple.minimize_resolution import _newton_decrease
    from crumple.relax import STABILITY_TOL, _symmetry_modes, node_lengths

    ramp = tuple(np.geomspace(1.0, 30.0, 12))
    print(f"== smooth stages geomspace(1, 30, 12), trap at x = {trap:g}: Newton's predicted "
          "decrease at each accepted point, and that of round-off alone ==")  # fmt: skip
    for n in ns:
        wire = Wire.from_continuum(**CONTINUUM, n_segments=n, hard_core=hard_core_for(n),
                                   trap_center=(trap, 0.0))  # fmt: skip
        m = np.repeat(node_lengths(wire), 2)
        for on in (False, True):
            r = run_ramp(wire, Ramp(lambdas=ramp, curved_steps=on), seed=0)
            for s in r.stages:
                energy = WireEnergy(wire, s.lam)
                e, g = energy(s.positions)
                h = energy.hessian_csc(s.positions)
                f = LDLT().factorize(h, shift=STABILITY_TOL * m)
                zero = lambda x, w=wire, lam=s.lam: _symmetry_modes(x, w, lam)  # noqa: E731
                modes = _modes(zero, s.positions, m)
                st = SimpleNamespace(x=s.positions, g=g, mask=None)
                dec, noise = _newton_decrease(st, h, f, modes)
                print(f"  N = {n} curved {'on ' if on else 'off'} λ = {s.lam:7.3f}: "
                      f"{s.result.iterations:4d} its, E = {e:.8f}, max force "
                      f"{s.result.max_force:.1e} (floor {s.result.force_resolution:.1e}), "
                      f"decrease {dec:.2e} = {dec / noise:.1e} × a one-ulp move's",
                      flush=True)  # fmt: skip


def _saving(line, n, save):
    """``line`` that also writes each stage's positions to ``save``/N<n>_stage<k>.npy (a
    long ramp's checkpoints: a later stage can be re-minimised from them)."""
    if save is None:
        return line
    os.makedirs(save, exist_ok=True)

    def both(i, total, st):
        np.save(os.path.join(save, f"N{n}_stage{i + 1:02d}.npy"), st.positions)
        if line is not None:
            line(i, total, st)

    return both


def bench_scale(ns, seed=0, curved=None, save=None, fallback=None, hard_core=None, coarsen=1):
    """The scaling table's rows: the default schedule at each N of ``ns`` (``curved``: the
    ramp's ``curved_steps``, None: the default; ``save``: a folder for each stage's
    positions, None: none; ``fallback``: the ramp's, None: the default; ``hard_core``: d,
    None: :func:`hard_core_for`; ``coarsen``: the ramp's, 1: the plain ramp)."""
    ramp = Ramp(curved_steps=curved, fallback=fallback, coarsen=coarsen)
    print(f"== default schedule (44 stages), continuum B = 0.05, S = 5000, seed {seed}, curved "
          f"steps {'on' if ramp.curved_steps else 'off'}, fallback {ramp.fallback}, coarsen "
          f"{ramp.coarsen} ==")  # fmt: skip
    print(
        "  N | d | smooth its/stage | contact its/stage | ms CPU/iteration | factorisations/it "
        "| max RSS GiB | ramp CPU s | converged | contacts at the last stage"
    )
    for n in ns:
        wire = continuum_wire(n, hard_core)
        progress = _saving(_stage_line(n) if n >= 10_000 else None, n, save)
        r, t = cpu(lambda wire=wire, p=progress: run_ramp(wire, ramp, seed=seed, progress=p))
        smooth = [s.result.iterations for s in r.stages if s.energy.hard_core == 0]
        contact = [s.result.iterations for s in r.stages if s.energy.hard_core > 0]
        its = sum(s.result.iterations for s in r.stages)
        fac = sum(s.result.factorizations for s in r.stages)
        last = r.stages[-1].positions
        pairs = len(node_segment_pairs(last, wire.hard_core)[0])
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
        print(f"  {n} | {wire.hard_core:.0e} | {np.mean(smooth) if smooth else 0:.1f} "
              f"({len(smooth)} stages) | {np.mean(contact) if contact else 0:.1f} "
              f"({len(contact)} stages) | {t / its * 1e3:.2f} | {fac / its:.2f} | {rss:.2f} | "
              f"{t:.1f} | {sum(s.result.converged for s in r.stages)}/{len(r.stages)} | "
              f"{pairs}", flush=True)  # fmt: skip
        if r.coarse is not None:  # the row's CPU includes it; its iterations are not counted
            print(f"    {r.coarse}", flush=True)


def bench_stage(
    n: int,
    first: int,
    last: int,
    save: str,
    curved=None,
    out=None,
    log=None,
    fallback=None,
    hard_core=None,
):
    """Stages ``first`` … ``last`` (1-based) of the default schedule at N = ``n``, in sequence,
    the first re-minimised from the positions of stage first - 1 that ``scale … save=DIR``
    wrote (the ramp adds no noise between stages by default, so a single stage is the ramp's
    own stage from that start), each next one from the last's minimum: per stage its
    iterations, passes, CPU, and the springs' solves (with the factor, and refactorised) with
    their CPU and how many found their active set; at the end the pairs in contact at the last
    stage and the process's peak memory. ``out``: a folder for each stage's
    positions (None: none). ``log``: a file to which each Newton iteration appends a line
    (stage, iteration, CPU since the stage began, energy, max force), flushed: the progress
    of a stage that takes hours (None: none). A saddle escape repeats the iteration number
    before it; a closing polish is not logged (``minimize_wire``'s callback). ``fallback`` and
    ``hard_core``: as :func:`bench_scale`'s."""
    from crumple.relax import minimize_wire

    ramp = Ramp(curved_steps=curved, fallback=fallback)
    if not 2 <= first <= last <= len(ramp.lambdas):
        raise SystemExit(f"stages must be 2 … {len(ramp.lambdas)}, got {first} … {last}")
    x = np.load(os.path.join(save, f"N{n}_stage{first - 1:02d}.npy"))
    print(f"== N = {n}, stages {first} … {last} from {save}'s stage {first - 1}, curved steps "
          f"{'on' if ramp.curved_steps else 'off'}, fallback {ramp.fallback} ==")  # fmt: skip
    wire, total = continuum_wire(n, hard_core), 0.0
    for k in range(first, last + 1):
        lam = ramp.lambdas[k - 1]
        report = None if log is None else _iteration_line(log, k)
        with _springs_counted() as counts, threadpool_limits(limits=1, user_api="blas"):
            res, t = cpu(lambda x=x, lam=lam, report=report: minimize_wire(
                wire, x, lam, method="newton", ftol=ramp.ftol, maxiter=ramp.maxiter,
                max_step=ramp.max_step, curved_steps=ramp.curved_steps,
                fallback=ramp.fallback, callback=report))  # fmt: skip
        x, total = res.x.reshape(x.shape), total + t
        if out is not None:
            os.makedirs(out, exist_ok=True)
            np.save(os.path.join(out, f"N{n}_stage{k:02d}.npy"), x)
        print(f"  stage {k} (λ = {lam:.4g}): {res.iterations} iterations"
              f"{_passes(res.message)}, converged {res.converged}, max force "
              f"{res.max_force:.3g}, energy {res.energy:.12g}, {t:.1f} s CPU ({total:.0f} s "
              "in all)")  # fmt: skip
        for key, (calls, found, secs) in counts.items():
            print(f"    springs' solves {key}: {calls}, active set found in {found}, "
                  f"{secs:.1f} s CPU")  # fmt: skip
        print(f"    {res.message}", flush=True)
    pairs = len(node_segment_pairs(x, wire.hard_core)[0])
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    print(f"  pairs in contact at stage {last}: {pairs} (d = {wire.hard_core:.0e}), max RSS "
          f"{rss:.2f} GiB", flush=True)  # fmt: skip


def _iteration_line(path, stage):
    """``minimize_wire``'s callback appending one line per iteration to ``path``."""
    t0 = time.process_time()

    def report(it, x, e, fmax):
        with open(path, "a") as f:
            f.write(f"stage {stage} it {it} cpu {time.process_time() - t0:.1f} energy {e:.15g} "
                    f"max_force {fmax:.3e}\n")  # fmt: skip

    return report


@contextlib.contextmanager
def _springs_counted():
    """The springs' solves (with the factor, refactorised) counted while inside: calls, active
    sets found, CPU."""
    from crumple import linalg, minimize_barriers

    counts = {"with the factor": [0, 0, 0.0], "refactorised": [0, 0, 0.0]}

    def counted(fn, key):
        def wrapped(*args, **kwargs):
            t0 = time.process_time()
            out = fn(*args, **kwargs)
            c = counts[key]
            c[0], c[1], c[2] = c[0] + 1, c[1] + bool(out[1]), c[2] + time.process_time() - t0
            return out

        return wrapped

    saved = linalg.Factorization.solve_springs, minimize_barriers.spring_step
    linalg.Factorization.solve_springs = counted(saved[0], "with the factor")
    minimize_barriers.spring_step = counted(saved[1], "refactorised")
    try:
        yield counts
    finally:
        linalg.Factorization.solve_springs, minimize_barriers.spring_step = saved


def bench_bits():
    """The fingerprint of the engine's iterates: the SHA-256 of every stage's positions of the
    default N = 100 ramp (seed 0) and of an N = 300 ramp (geomspace(1, 2000, 10), seed 3),
    and their Newton iterations. A change that claims to be bit for bit leaves both unchanged
    (docs/performance.md quotes them)."""
    import hashlib

    h, its = hashlib.sha256(), 0
    ramps = [
        (Wire(k_b=5, k_s=5e5), Ramp(), 0),
        (Wire(k_b=5, k_s=5e5, n_segments=300), Ramp(lambdas=np.geomspace(1, 2000, 10)), 3),
    ]
    with threadpool_limits(limits=1, user_api="blas"):  # the paths depend on the threads
        for wire, ramp, seed in ramps:
            for s in run_ramp(wire, ramp, seed=seed).stages:
                h.update(s.positions.tobytes())
                its += s.result.iterations
    print(f"== bits: default N = 100 ramp (seed 0) + N = 300 ramp (seed 3) ==\n  {its} "
          f"iterations, SHA-256 of the positions {h.hexdigest()[:16]}")  # fmt: skip


def bench_lbfgs():
    print("== one stage (λ = 70 from the λ = 59.9 equilibrium, default wire, N = 100) ==")
    wire = Wire(k_b=5, k_s=5e5)
    lams = default_schedule()
    i = lams.index(70.0)
    prev = run_ramp(wire, Ramp(lambdas=lams[:i]), seed=0).stages[-1].positions
    f = WireEnergy(wire, 70.0)
    rn, tn = cpu(lambda: minimize_wire(wire, prev, 70.0))
    ro, to = cpu(lambda: legacy_newton.legacy_minimize_wire(wire, prev, 70.0))

    def fun(z):
        e, g = f(z.reshape(-1, 2))
        return e, g.ravel()

    opts = {"maxiter": 20000, "maxfun": 40000, "gtol": 1e-6, "ftol": 1e-16}
    rl, tl = cpu(lambda: scipy_minimize(fun, prev.ravel(), jac=True, method="L-BFGS-B",
                                        options=opts))  # fmt: skip
    xl = rl.x.reshape(-1, 2)
    print(f"  newton (new)   : {tn:.4f} s  {rn.iterations:5d} its  E = {rn.energy:.10f}  "
          f"max force {rn.max_force:.1e}")  # fmt: skip
    print(f"  newton (landed): {to:.4f} s  {ro.iterations:5d} its  E = {ro.energy:.10f}  "
          f"max force {ro.max_force:.1e}")  # fmt: skip
    print(f"  L-BFGS-B       : {tl:.4f} s  {rl.nit:5d} its  E = {rl.fun:.10f}  max force "
          f"{max_force(f(xl)[1]):.1e}  ({'crosses itself' if has_crossings(xl) else 'no crossing'};"
          f" {rl.message})  time / new Newton {tl / tn:.0f}x")  # fmt: skip


def bench_cold(n: int = 10_000, lam: float = 200.0, maxiter: int = 2000):
    print(f"== cold start: N = {n}, straight wire + noise, λ = {lam}, no ramp ==")
    wire = continuum_wire(n)
    x = initial_state(wire, seed=0)
    r, t = cpu(lambda: minimize_wire(wire, x, lam, maxiter=maxiter))
    print(f"  {t:.1f} s CPU, {r.iterations} iterations, max force {r.max_force:.3g}, "
          f"converged {r.converged}: {r.message}")  # fmt: skip


def _ramp_without_springs(wire, seed=0):
    """``run_ramp`` with ``minimize_wire(anticipate_contacts=False)``: the engine before the
    one-sided contact springs, run in the same process for the comparison."""
    import functools

    import crumple.protocol as protocol

    saved = protocol.minimize_wire
    protocol.minimize_wire = functools.partial(saved, anticipate_contacts=False)
    try:
        return run_ramp(wire, seed=seed)
    finally:
        protocol.minimize_wire = saved


def bench_contacts(ns=()):
    print("== contact stages: the Newton model sees the contacts a step enters (on) or not (off),"
          " default schedule, seed 0 ==")  # fmt: skip
    print("  wire | springs | its / contact stage (stages) | its / smooth stage | total its | "
          "CPU s | ms / it | converged | E_final")  # fmt: skip
    wires = {
        "N = 100, k_b = 5, k_s = 5e5 (default)": Wire(k_b=5, k_s=5e5),
        "N = 100 per-node, k_b = 5, k_s = 5e5": Wire(k_b=5, k_s=5e5, confinement="per-node"),
        "N = 100 per-node, k_b = 1, k_s = 1e4": Wire(k_b=1, k_s=1e4, confinement="per-node"),
    }
    wires.update({f"N = {n} continuum": continuum_wire(n) for n in ns})
    run_ramp(Wire(k_b=5, k_s=5e5), Ramp(lambdas=(1.0, 100.0, 1000.0)), seed=0)  # compile
    with threadpool_limits(limits=1, user_api="blas"):
        for label, wire in wires.items():
            for on in (True, False):
                r, t = cpu(lambda w=wire, on=on: run_ramp(w, seed=0) if on
                           else _ramp_without_springs(w))  # fmt: skip
                contact = [s.result.iterations for s in r.stages if s.energy.hard_core > 0]
                smooth = [s.result.iterations for s in r.stages if s.energy.hard_core == 0]
                its = sum(s.result.iterations for s in r.stages)
                print(f"  {label} | {'on' if on else 'off'} | "
                      f"{np.mean(contact) if contact else 0:.1f} ({len(contact)}) | "
                      f"{np.mean(smooth) if smooth else 0:.1f} | {its} | {t:.2f} | "
                      f"{t / its * 1e3:.2f} | {sum(s.result.converged for s in r.stages)}/"
                      f"{len(r.stages)} | {r.stages[-1].energy.total:.10f}",
                      flush=True)  # fmt: skip


def bench_compare():
    print("== stage energies of default-schedule ramps (N = 100, seed 0): new vs landed ==")
    from crumple.model import Plasticity

    wires = {
        "k_b = 5, k_s = 5e5": Wire(k_b=5, k_s=5e5),
        "k_b = 1, k_s = 1e4": Wire(k_b=1, k_s=1e4),
        "plastic s = 0.2": Wire(k_b=5, k_s=5e5, plasticity=Plasticity(s=0.2, theta_p=0.3)),
    }
    lams = default_schedule()
    with threadpool_limits(limits=1, user_api="blas"):
        for label, wire in wires.items():
            new = np.array([s.energy.total for s in run_ramp(wire, seed=0).stages])
            old = np.array([r.energy for r in legacy_newton.legacy_run_ramp(wire, lams, seed=0)])
            rel = np.abs(new - old) / np.abs(old)
            differ = [(lam, a, b) for lam, a, b, x in zip(lams, new, old, rel, strict=True)
                      if x > 1e-6]  # fmt: skip
            print(f"  {label}: {len(differ)} stages differ by > 1e-6, largest {rel.max():.2g}; "
                  f"new lower at {sum(a < b for _, a, b in differ)} of them")  # fmt: skip


def bench_gauge(ns=()):
    """Default-schedule ramps with the zero modes' gauge in the Newton step (the engine) and
    without it (``minimize_direction._gauge_pin`` returning None: the engine before 4483c13, bit
    for bit), in one process: N = 100 (k_b = 5, k_s = 5e5) seeds 0-2, then the continuum wire
    at each N given (seed 0). And where it matters: the lowest mode of the Hessian in the
    middle of N = 100's λ = 917 stage against the rotation about the trap's centre."""
    import crumple.minimize_direction as minimize_module

    on = minimize_module._gauge_pin
    run_ramp(Wire(k_b=5, k_s=5e5, n_segments=10), seed=0)  # compilation out of the timings
    print("== the rotation's gauge in the Newton step: on (engine) vs off (before 4483c13) ==")
    cases = [(Wire(k_b=5, k_s=5e5), s, "N = 100 default") for s in (0, 1, 2)]
    cases += [(continuum_wire(n), 0, f"N = {n} continuum") for n in ns]
    for wire, seed, label in cases:
        out = []
        for name, pin in (("on", on), ("off", lambda h, modes: None)):
            minimize_module._gauge_pin = pin
            try:
                r, t = cpu(lambda w=wire, s=seed: run_ramp(w, seed=s))
            finally:
                minimize_module._gauge_pin = on
            its = sum(s.result.iterations for s in r.stages)
            fac = sum(s.result.factorizations for s in r.stages)
            ok = sum(s.result.converged for s in r.stages)
            out.append(f"{name}: {its} its, {fac} factorisations, {t:.2f} s, {ok}/{len(r.stages)}")
        print(f"  {label}, seed {seed}: " + " | ".join(out), flush=True)
    _gauge_overlap()


def _gauge_overlap():
    """The lowest eigenvectors (per length, dense) of the exact and contacts-projected Hessians
    halfway through the N = 100 λ = 917 stage, without the gauge, against the rotation."""
    import crumple.minimize_direction as minimize_module
    from crumple.protocol import node_lengths

    wire = Wire(k_b=5, k_s=5e5)
    stages = run_ramp(wire, Ramp(lambdas=default_schedule()[:38]), seed=0).stages
    lam = default_schedule()[38]
    on = minimize_module._gauge_pin
    minimize_module._gauge_pin = lambda h, modes: None
    try:
        x = minimize_wire(wire, stages[-1].positions, lam, maxiter=50).x
    finally:
        minimize_module._gauge_pin = on
    m = np.repeat(node_lengths(wire), 2)
    e = WireEnergy(wire, lam)
    rot = np.column_stack([-x[:, 1], x[:, 0]]).ravel()
    for name, kw in (("exact", {}), ("contacts projected", {"project_contacts": True})):
        h = e.hessian_csc(x, **kw).tocsc().toarray() / np.sqrt(np.outer(m, m))
        vals, vecs = np.linalg.eigh(0.5 * (h + h.T))
        v = vecs[:, 0] / np.sqrt(m)
        overlap = abs(v @ (m * rot)) / np.sqrt((v @ (m * v)) * (rot @ (m * rot)))
        print(
            f"  λ = {lam:.4g}, after 50 iterations without the gauge, {name} Hessian: lowest "
            f"eigenvalue {vals[0]:.3g} per length, overlap with the rotation {overlap:.3f}"
        )


def bench_accurate(ns=(), modes=("off", "on")):
    """The default ramp of the continuum wire with the element-form stability test
    (``relax.ACCURATE_STABILITY``) off and on: per stage, iterations, whether the stage is at
    equilibrium, and whether the accurate product decided its stability."""
    from crumple import relax

    print("== default schedule, continuum B = 0.05, S = 5000, seed 0: ACCURATE_STABILITY ==")
    default = relax.ACCURATE_STABILITY
    try:
        _accurate_ramps(ns or (2000,), modes, relax)
    finally:
        relax.ACCURATE_STABILITY = default


def _accurate_ramps(ns, modes, relax):
    for n in ns:
        wire = continuum_wire(n)
        for mode in modes:
            relax.ACCURATE_STABILITY = mode == "on"
            t0 = time.process_time()

            def line(i, total, st, t0=t0, n=n, mode=mode):
                res = st.result
                print(f"  N = {n} {mode} stage {i:2d} λ = {st.lam:8.4g}: {res.iterations:5d} "
                      f"its, converged {res.converged}, accurate "
                      f"{'accurate' in res.message}, E = {st.energy.total:.10g}, "
                      f"{time.process_time() - t0:7.1f} s", flush=True)  # fmt: skip
                if not res.converged:
                    print(f"    {res.message}", flush=True)

            r = run_ramp(wire, seed=0, progress=line)
            its = sum(s.result.iterations for s in r.stages)
            acc = sum("accurate" in s.result.message for s in r.stages)
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
            print(f"  N = {n} {mode}: {time.process_time() - t0:.1f} s CPU, {its} iterations, "
                  f"{sum(s.result.converged for s in r.stages)}/{len(r.stages)} converged, "
                  f"{acc} stages decided by the accurate product, max RSS {rss:.2f} GiB",
                  flush=True)  # fmt: skip


def bench_curved(ns=(), seeds=(0, 1, 2, 3), big_seeds=(0,)):
    """Curved trial points (``Ramp.curved_steps``) off and on, default ramp, same process:
    the paper's wire (N = 100, per length and per node) over ``seeds``, the plastic per-node
    wire of the reproduction at three (s, θ_p) over seeds 0–1, then the continuum wire at
    each N of ``ns`` over ``big_seeds``. Per ramp: iterations, evaluations, curved steps
    taken, stages converged, CPU, the final energy (which branch the ramp ended on)."""
    from crumple.model import Plasticity

    cases = [
        ("N = 100 per length", Wire(k_b=5, k_s=5e5), seeds),
        ("N = 100 per node", Wire(k_b=5, k_s=5e5, confinement="per-node"), seeds),
    ]
    for s_, tp in ((0.05, 0.1), (0.4, 0.1), (0.4, 0.5)):
        wire = Wire(k_b=5, k_s=5e5, confinement="per-node", plasticity=Plasticity(s=s_, theta_p=tp))
        cases.append((f"N = 100 per node, plastic s = {s_}, θ_p = {tp}", wire, (0, 1)))
    cases += [(f"N = {n} continuum", continuum_wire(n), big_seeds) for n in ns]  # fmt: skip
    run_ramp(Wire(k_b=5, k_s=5e5), Ramp(lambdas=(1.0, 100.0, 1000.0)), seed=0)  # compile
    with threadpool_limits(limits=1, user_api="blas"):
        for label, wire, ss in cases:
            print(f"== {label}, default schedule, seeds {list(ss)}: curved steps off / on ==")
            for mode in (False, True):
                _curved_ramps(wire, ss, mode)


def _curved_ramps(wire, seeds, on):
    tot_its = tot_t = 0.0
    mode = "on " if on else "off"
    for seed in seeds:
        r, t = cpu(lambda seed=seed: run_ramp(wire, Ramp(curved_steps=on), seed=seed))
        res = [s.result for s in r.stages]
        its = sum(x.iterations for x in res)
        tot_its += its
        tot_t += t
        print(f"  {mode} seed {seed}: {its:6d} iterations, {sum(x.evaluations for x in res):6d} "
              f"evaluations, {sum(x.curved_steps for x in res):5d} curved, "
              f"{sum(x.converged for x in res)}/{len(res)} converged, {t:7.2f} s CPU, "
              f"E_final = {r.stages[-1].energy.total:.10f}", flush=True)  # fmt: skip
    print(f"  {mode} total: {int(tot_its)} iterations, {tot_t:.2f} s CPU", flush=True)


def bench_exact(ns=(100, 2000), seeds=(0,)):
    """The two fallbacks of Newton's step where the Hessian is indefinite
    (``Ramp(fallback="projected")`` and ``"exact"``, the latter with the σ search;
    ``relax.FALLBACK``), default ramp of the continuum wire (at N = 100 the paper's wire),
    same process. Per ramp: iterations, factorisations and Hessian evaluations per iteration,
    the last stage's iterations, stages converged, CPU (and per iteration), the final energy
    (which branch the ramp ended on). "auto", the default, is the second above
    ``relax.EXACT_FALLBACK_ABOVE`` segments and the first below."""
    from crumple import relax

    run_ramp(Wire(k_b=5, k_s=5e5), Ramp(lambdas=(1.0, 100.0, 1000.0)), seed=0)  # compile
    with threadpool_limits(limits=1, user_api="blas"):
        for n in ns:
            wire = continuum_wire(n)
            auto = relax.resolve_fallback("auto", wire)
            print(f"== N = {n}, default schedule, seeds {list(seeds)}: projected / exact fallback "
                  f"(auto: {auto}) ==")  # fmt: skip
            for fallback in ("projected", "exact"):
                for seed in seeds:
                    ramp = Ramp(fallback=fallback)
                    r, t = cpu(
                        lambda seed=seed, wire=wire, ramp=ramp: run_ramp(wire, ramp, seed=seed)
                    )
                    res = [s.result for s in r.stages]
                    its = sum(x.iterations for x in res)
                    fac = sum(x.factorizations for x in res)
                    hev = sum(x.hessian_evaluations for x in res)
                    print(f"  {fallback:9s} seed {seed}: {its:6d} iterations, {fac / its:.2f} "
                          f"factorisations and {hev / its:.2f} Hessians each, last stage "
                          f"{res[-1].iterations}, {sum(x.converged for x in res)}/{len(res)} "
                          f"converged, {t:7.1f} s CPU ({1e3 * t / its:.2f} ms/it), "
                          f"E_final = {r.stages[-1].energy.total:.10f}", flush=True)  # fmt: skip


def bench_crawl(n: int = 10_000, seed: int = 0, stage: int = 43, curved=None):
    """One stage of the default ramp, step by step: what limits its steps.

    The ramp is run to the stage before (the same iterates as the whole ramp), then the stage
    is minimised with two of the minimiser's private steps wrapped (instrumentation only, the
    iterates unchanged): the Newton or fallback direction p before the contacts' springs and
    the step s after them (``minimize._barrier_step``), and the line search's trust radius R,
    collision cut and evaluations (``minimize._line_search``)."""
    import crumple.minimize as mz

    wire = continuum_wire(n) if n != 100 else Wire(k_b=5, k_s=5e5)
    lams = default_schedule()
    ramp = Ramp(lambdas=lams[:stage], curved_steps=curved)
    before, t_before = cpu(lambda: run_ramp(wire, ramp, seed=seed))
    steps, searches = [], []
    barrier_step, line_search = mz._barrier_step, mz._line_search

    def traced_barrier_step(st, p, barriers, ldl):
        s = barrier_step(st, p, barriers, ldl)
        steps.append((max_force(p), max_force(s)))
        return s

    def traced_line_search(st, fun, p, step_limit, *args):
        cut = []

        def limit(x, q):
            cut.append(step_limit(x, q))
            return cut[-1]

        radius, nfev = st.radius, st.nfev
        out = line_search(st, fun, p, limit if step_limit is not None else None, *args)
        searches.append((st.exact, radius, cut[0] if cut else 1.0, st.nfev - nfev))
        return out

    mz._barrier_step, mz._line_search = traced_barrier_step, traced_line_search
    try:
        res, t = cpu(lambda: minimize_wire(
            wire, before.stages[-1].positions, lams[stage], ftol=ramp.ftol, maxiter=ramp.maxiter,
            max_step=ramp.max_step, curved_steps=ramp.curved_steps))  # fmt: skip
    finally:
        mz._barrier_step, mz._line_search = barrier_step, line_search
    if not steps or not searches:
        print(f"  stage {stage}: {res.iterations} iterations, no spring step to trace")
        return
    p, s = np.array(steps).T
    exact, radius, safe, nfev = np.array(searches).T
    q = s / p
    print(
        f"== N = {n}, seed {seed}, stage {stage} (λ = {lams[stage]:.4g}), curved steps "
        f"{'on' if ramp.curved_steps else 'off'}: {res.iterations} iterations, converged "
        f"{res.converged}, {t:.0f} s CPU ({t_before:.0f} s for the stages before) =="
    )
    print(
        f"  fallback (H indefinite) {1 - exact.mean():.0%}, cut by collision "
        f"{np.mean(safe < 1):.1%}, evaluations per line search {nfev.mean():.2f}"
    )
    print(
        f"  median |p| {np.median(p):.2e}, median |s| {np.median(s):.2e}, median R "
        f"{np.median(radius):.2e} (largest node displacement; d = {wire.hard_core:.1e}, "
        f"segment {wire.rest_length:.1e})"
    )
    print(
        f"  the springs cut the step: median |s|/|p| {np.median(q):.2f}, below 0.5 in "
        f"{np.mean(q < 0.5):.0%}, below 0.1 in {np.mean(q < 0.1):.0%} of {len(q)} steps"
    )
    start = WireEnergy(wire, lams[stage])(before.stages[-1].positions)[0]
    print(f"  energy at λ = {lams[stage]:.4g}: {start:.6f} -> {res.energy:.6f}")


def _curved_flag(flags):
    """``curved=on|off`` as the ramp's ``curved_steps`` (absent: None, the default)."""
    value = flags.get("curved")
    if value not in (None, "on", "off"):
        raise SystemExit(f"curved must be on or off, got {value!r}")
    return None if value is None else value == "on"


def _hard_core_flag(flags):
    """``d=X`` as the wire's hard core (absent: None, :func:`hard_core_for`)."""
    if "d" not in flags:
        return None
    d = float(flags["d"])
    if not d > 0:
        raise SystemExit(f"d must be a positive length, got {flags['d']!r}")
    return d


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "ramp100"
    if what == "ramp100":
        bench_ramp100()
    elif what == "smooth":  # smooth [N …] [curved=on|off]
        flags = dict(a.split("=") for a in sys.argv[2:] if "=" in a)
        ns = [int(v) for v in sys.argv[2:] if "=" not in v] or (100, 1000, 2000, 10_000)
        bench_smooth(ns, _curved_flag(flags))
    elif what == "scale":  # scale [N …] [seed=S] [curved=on|off]
        flags = dict(a.split("=") for a in sys.argv[2:] if "=" in a)
        ns = [int(v) for v in sys.argv[2:] if "=" not in v] or [100, 1000]
        _coarse_flags(flags)
        bench_scale(ns, int(flags.get("seed", 0)), _curved_flag(flags), flags.get("save"),
                    flags.get("fallback"), _hard_core_flag(flags),
                    int(flags.get("coarsen", 1)))  # fmt: skip
    elif what == "stage":  # stage N K[-K2] DIR [curved=on|off] [save=DIR2]
        flags = dict(a.split("=") for a in sys.argv[2:] if "=" in a)
        args = [v for v in sys.argv[2:] if "=" not in v]
        if len(args) != 3:
            raise SystemExit(
                "usage: bench_scale.py stage N K[-K2] DIR [curved=on|off] [save=DIR2] [log=F] "
                "[fallback=…] [d=X]"
            )
        first, _, last = args[1].partition("-")
        bench_stage(int(args[0]), int(first), int(last or first), args[2], _curved_flag(flags),
                    flags.get("save"), flags.get("log"), flags.get("fallback"),
                    _hard_core_flag(flags))  # fmt: skip
    elif what == "decrease":  # decrease [N …] [trap=X]
        flags = dict(a.split("=") for a in sys.argv[2:] if "=" in a)
        ns = [int(v) for v in sys.argv[2:] if "=" not in v] or [10_000]
        bench_decrease(ns, float(flags.get("trap", 0.0)))
    elif what == "bits":
        bench_bits()
    elif what == "lbfgs":
        bench_lbfgs()
    elif what == "cold":
        bench_cold()
    elif what == "compare":
        bench_compare()
    elif what == "contacts":
        bench_contacts([int(v) for v in sys.argv[2:]])
    elif what == "gauge":
        bench_gauge([int(v) for v in sys.argv[2:]])
    elif what == "accurate":
        bench_accurate([int(v) for v in sys.argv[2:]])
    elif what == "curved":  # curved N … [seeds=0,1]: the continuum wire's seeds
        seeds = [a for a in sys.argv[2:] if a.startswith("seeds=")]
        big = tuple(int(v) for v in seeds[0][6:].split(",")) if seeds else (0,)
        bench_curved([int(v) for v in sys.argv[2:] if not v.startswith("seeds=")], big_seeds=big)
    elif what in ("fallback", "exact"):  # fallback [N …] [seeds=0,1]
        seeds = [a for a in sys.argv[2:] if a.startswith("seeds=")]
        ss = tuple(int(v) for v in seeds[0][6:].split(",")) if seeds else (0,)
        bench_exact([int(v) for v in sys.argv[2:] if not v.startswith("seeds=")] or (100, 2000), ss)
    elif what == "crawl":  # crawl [N] [seed=S] [stage=K] [curved=on|off]
        flags = dict(a.split("=") for a in sys.argv[2:] if "=" in a)
        ns = [int(v) for v in sys.argv[2:] if "=" not in v] or [10_000]
        bench_crawl(ns[0], int(flags.get("seed", 0)), int(flags.get("stage", 43)),
                    _curved_flag(flags))  # fmt: skip
    else:
        raise SystemExit(__doc__)
