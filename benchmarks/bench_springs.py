"""The refactorised springs' step replayed on the calls of one contact stage, each way.

    python benchmarks/bench_springs.py N K DIR [every=2] [calls=40] [curved=on|off]
                                       [compare=segment|updates|ends] [keep=CALLS]
    python benchmarks/bench_springs.py replay CALLS [compare=segment|updates|ends]

re-minimises stage K (1-based) of the default schedule at N segments from the positions of
stage K - 1 that ``bench_scale.py scale N save=DIR`` wrote, keeps the inputs of every
``every``-th call of :func:`crumple.linalg_springs.spring_step` (at most ``calls`` of them),
then solves each kept call again from its own start with ``from_segment`` off and on (the
rounds started from the start as given, or from the least point of q on the segment from 0 to
it). The stage's path sets which calls are met; the replay compares the two ways on the same
calls: rounds (one factorisation each), minimisers found, q reached, CPU. Counts are
deterministic; the CPU is this machine's.

With ``compare=updates`` each kept call is solved from the segment (the default) in the
factor's order the engine used, without and with the rank-one modifications of the last
round's factor (``spring_step(updates=...)``, :mod:`crumple.linalg_update`): rounds,
factorisations, modifications, minimisers found, q reached, CPU.

With ``compare=ends`` each kept call is solved once as the engine solves it above 10³ segments
(from the segment, with the modifications) and the way it ended is counted: the minimiser
found, the rounds run out (``spring_step``'s default), or stopped before (a round's matrix with
a negative pivot, which releasing springs can give, or a line search that does not move).

``keep=CALLS`` also writes the kept calls to the folder CALLS (which must hold no calls yet),
one ``call<i>.npz`` each (NumPy's open format, no pickle), and ``replay CALLS`` replays them
without re-running the stage (``every``, ``calls`` and ``curved`` are then those the calls were
kept with, and are not read): a stage at N = 10⁵ takes minutes, its 40 calls' replay half a
minute. The kept calls are every ``every``-th of the first ``every`` × ``calls`` the stage
makes.
"""

from __future__ import annotations

import inspect
import os
import sys
import time

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, os.path.dirname(__file__))
from bench_scale import continuum_wire

from crumple import linalg_springs, minimize_barriers
from crumple.linalg import CSC, LDLT
from crumple.linalg_csc import _csc_matvec
from crumple.protocol import Ramp
from crumple.relax import minimize_wire


def kept_calls(n, k, save, every, limit, curved):
    """Stage k from stage k - 1's positions; the inputs of every ``every``-th spring_step call."""
    ramp = Ramp(curved_steps=curved)
    x = np.load(os.path.join(save, f"N{n}_stage{k - 1:02d}.npy"))
    kept, seen = [], [0]
    step = minimize_barriers.spring_step

    def keeping(ldl, a, shift, g, index, value, offset, stiff, start, **kw):
        if seen[0] % every == 0 and len(kept) < limit:
            kept.append(tuple(np.array(v, copy=True) if v is not None else None
                              for v in (a.data, a.indices, a.indptr, shift, g, index, value,
                                        offset, stiff, start, ldl._sym.perm)))  # fmt: skip
        seen[0] += 1
        return step(ldl, a, shift, g, index, value, offset, stiff, start, **kw)

    minimize_barriers.spring_step = keeping
    try:
        t0 = time.process_time()
        res = minimize_wire(continuum_wire(n), x, ramp.lambdas[k - 1], method="newton",
                            ftol=ramp.ftol, maxiter=ramp.maxiter, max_step=ramp.max_step,
                            curved_steps=ramp.curved_steps, fallback=ramp.fallback)  # fmt: skip
    finally:
        minimize_barriers.spring_step = step
    print(f"== N = {n}, stage {k} (λ = {ramp.lambdas[k - 1]:.4g}) from {save}'s stage {k - 1}: "
          f"{res.iterations} iterations, converged {res.converged}, "
          f"{time.process_time() - t0:.1f} s CPU; {seen[0]} refactorised steps, "
          f"{len(kept)} kept (every {every}) ==")  # fmt: skip
    return kept


_FIELDS = "data indices indptr shift g index value offset stiff start perm".split()


def _call_files(folder):
    """The ``call<i>.npz`` files of ``folder``, by i."""
    names = [f for f in os.listdir(folder) if f.startswith("call") and f.endswith(".npz")]
    return sorted(names, key=lambda f: int(f[4:-4]) if f[4:-4].isdigit() else -1)


def write_calls(calls, folder):
    """The kept calls as ``folder/call<i>.npz`` (a missing shift stored as an empty array);
    a folder that already holds calls is refused (a replay would read them too)."""
    os.makedirs(folder, exist_ok=True)
    if _call_files(folder):
        raise SystemExit(f"{folder} already holds calls: keep= needs an empty folder")
    for i, call in enumerate(calls):
        arrays = {f: np.empty(0) if v is None else v for f, v in zip(_FIELDS, call, strict=True)}
        np.savez(os.path.join(folder, f"call{i:03d}.npz"), has_shift=call[3] is not None, **arrays)


def read_calls(folder):
    """The calls :func:`write_calls` wrote, in order."""
    calls = []
    for name in _call_files(folder):
        with np.load(os.path.join(folder, name), allow_pickle=False) as z:
            call = [z[f] for f in _FIELDS]
            if not bool(z["has_shift"]):
                call[3] = None
        calls.append(tuple(call))
    print(f"== {len(calls)} calls read from {folder} ==")
    return calls


def count_ends(calls):
    """Each call as the engine solves it above 10³ segments: how it ended."""
    rounds = inspect.signature(linalg_springs.spring_step).parameters["rounds"].default
    ends = {"found": 0, "rounds run out": 0, "stopped before": 0}
    total, cpu = 0, 0.0
    for call in calls:
        used, ok, _, t, _, _ = replay(call, True, True)
        total, cpu = total + used, cpu + t
        ends["found" if ok else "rounds run out" if used >= rounds else "stopped before"] += 1
    with_releasing = sum(bool((call[8] < 0).any()) for call in calls)
    print(f"  {len(calls)} calls ({with_releasing} with releasing springs), {total} rounds, "
          f"{cpu:.1f} s CPU: " + ", ".join(f"{k} {v}" for k, v in ends.items()))  # fmt: skip


def model_value(call, s):
    """q(s) of a kept call."""
    data, indices, indptr, shift, g, index, value, offset, stiff, _, _ = call
    a_s = _csc_matvec(indptr, indices, data, s) + (0.0 if shift is None else shift * s)
    gap = np.maximum(0.0, offset - linalg_springs._rows_dot(index, value, s))
    return float(g @ s + 0.5 * s @ a_s + 0.5 * np.sum(stiff * gap**2))


def replay(call, from_segment, updates=False):
    """One kept call solved again, in the factor's order the engine used: (rounds, converged,
    q(s) - q(start), CPU s, factorisations, rank-one modifications)."""
    data, indices, indptr, shift, g, index, value, offset, stiff, start, perm = call
    ldl = LDLT()
    ldl._candidate = lambda a: perm  # the engine's order, whatever chose it
    t0 = time.process_time()
    s, ok, used = linalg_springs.spring_step(ldl, CSC(data, indices, indptr), shift, g, index,
                                             value, offset, stiff, start,
                                             from_segment=from_segment,
                                             updates=updates)  # fmt: skip
    t = time.process_time() - t0
    dq = np.nan if s is None else model_value(call, s) - model_value(call, start)
    return used, bool(ok), dq, t, ldl.factorizations, ldl.modifications


def compare_updates(calls):
    """Each call from the segment, without and with the modifications of the last round's
    factor: the totals."""
    print("  call | springs | without: rounds, factorisations, found | with: rounds, "
          "factorisations, modifications, found")  # fmt: skip
    total = {False: np.zeros(6), True: np.zeros(6)}
    for i, call in enumerate(calls):
        got = {way: replay(call, True, way) for way in (False, True)}
        low = min(got[w][2] for w in got)
        for way, (used, ok, dq, t, nf, nm) in got.items():
            total[way] += (used, ok, dq <= low + 1e-10 * max(1.0, abs(low)), t, nf, nm)
        print(f"  {i} | {len(call[7])} | {got[False][0]}, {got[False][4]}, {got[False][1]} | "
              f"{got[True][0]}, {got[True][4]}, {got[True][5]}, {got[True][1]}")  # fmt: skip
    for way, (rounds, found, lowest, t, nf, nm) in total.items():
        print(f"  updates={way}: {rounds:.0f} rounds, {nf:.0f} factorisations, {nm:.0f} "
              f"modifications, active set found in {found:.0f}/{len(calls)}, q lowest (to "
              f"1e-10) in {lowest:.0f}, {t:.1f} s CPU")  # fmt: skip


def main(argv):
    flags = dict(a.split("=") for a in argv if "=" in a)
    args = [v for v in argv if "=" not in v]
    curved = {"on": True, "off": False, None: None}[flags.get("curved")]
    with threadpool_limits(limits=1, user_api="blas"):
        if args[0] == "replay":
            calls = read_calls(args[1])
        else:
            n, k, save = args
            calls = kept_calls(int(n), int(k), save, int(flags.get("every", 2)),
                               int(flags.get("calls", 40)), curved)  # fmt: skip
            if "keep" in flags:
                write_calls(calls, flags["keep"])
        compare = flags.get("compare", "segment")
        if compare == "updates":
            compare_updates(calls)
        elif compare == "ends":
            count_ends(calls)
        else:
            compare_segment(calls)


def compare_segment(calls):
    """Each call with ``from_segment`` off and on: the totals."""
    print("  call | springs | off: rounds, found, q - q(start) | on: rounds, found, "
          "q - q(start)")  # fmt: skip
    total = {False: [0, 0, 0.0, 0], True: [0, 0, 0.0, 0]}
    for i, call in enumerate(calls):
        got = {way: replay(call, way) for way in (False, True)}
        low = min(got[w][2] for w in got)
        for way, (used, ok, dq, t, _, _) in got.items():
            c = total[way]
            c[0], c[1], c[2] = c[0] + used, c[1] + ok, c[2] + t
            c[3] += dq <= low + 1e-12 * max(1.0, abs(low))
        print(
            f"  {i} | {len(call[7])} | {got[False][0]}, {got[False][1]}, "
            f"{got[False][2]:.3e} | {got[True][0]}, {got[True][1]}, {got[True][2]:.3e}"
        )
    for way, (rounds, found, t, lowest) in total.items():
        print(f"  from_segment={way}: {rounds} rounds, active set found in {found}/{len(calls)}, "
              f"q lowest (to 1e-12) in {lowest}, {t:.1f} s CPU")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
