"""The injection into a cavity (issue 13's protocol) at the engine's speed: CPU and counts.

    python benchmarks/bench_injection.py compare [repeat=1]  # the study's injection, N = 100:
                                                           # new vs landed, in one process
    python benchmarks/bench_injection.py scale 100 200 400 [stop=L] [landed=on]  # against N
    python benchmarks/bench_injection.py bits      # fingerprints of four injections

The wire is the cavity study's (``crumple.reproduce.cavity``: k_b = 5, k_s = 5 × 10⁵, rest-angle
disorder 0.01, h = R_c/50, R_c = 0.05, seed 0): ``scale`` keeps R_c and h, so a larger N is
the same packing, finer (h < L0/N up to N = 1000). CPU is ``time.process_time`` on one BLAS
thread; Newton iterations and relaxations are counted over every sub-push. The landed code
is the frozen copy ``benchmarks/legacy_feed.py``. Results are in docs/performance.md.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import resource
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, os.path.dirname(__file__))

import legacy_feed
import numpy as np

import crumple.injection as injection
from crumple.model import Plasticity, Wire
from crumple.reproduce.cavity import K_B, K_S, REST_ANGLE_SD, THICKNESS

RADIUS = 0.05


def study_wire(n: int, radius: float = RADIUS, **kw) -> Wire:
    return Wire(k_b=K_B, k_s=K_S, n_segments=n, hard_core=THICKNESS * radius,
                cavity_radius=radius, rest_angle_sd=REST_ANGLE_SD, **kw)  # fmt: skip


@contextlib.contextmanager
def counted():
    """Newton iterations and relaxations over every sub-push, in ``counts``."""
    counts = {"iterations": 0, "relaxations": 0}
    original = injection.newton

    def newton(*args, **kwargs):
        res = original(*args, **kwargs)
        counts["iterations"] += res.iterations
        counts["relaxations"] += 1
        return res

    injection.newton = newton
    try:
        yield counts
    finally:
        injection.newton = original


def run(wire, inj, seed=0):
    with counted() as counts:
        t0 = time.process_time()
        r = injection.run_injection(wire, inj, seed=seed)
        t = time.process_time() - t0
    return r, t, counts


def fingerprint(r) -> str:
    """SHA-256 of the iterates: every stage's positions, energy and clamp reaction (the feed
    force apart: its round-off moved with the clamp's sparse branch stiffness)."""
    h = hashlib.sha256()
    for s in r.stages:
        h.update(np.ascontiguousarray(s.positions).tobytes())
        h.update(np.float64([s.energy.total, s.clamp_reaction]).tobytes())
    return h.hexdigest()[:16]


def force_change(r, ref) -> float:
    """max |ΔF| / max |F| over the feed forces of two runs of the same stages (a stage's own F
    can be ~0, where a relative difference means nothing)."""
    a, b = np.asarray(r.feed_forces), np.asarray(ref.feed_forces)
    if a.shape != b.shape:
        return np.inf
    return float(np.nanmax(np.abs(a - b), initial=0.0) / np.nanmax(np.abs(b), initial=1e-300))


def bench_compare(repeat: int = 1):
    print("== the cavity study's injection, N = 100, R_c = 0.05, h = R_c/50, seed 0: "
          "new vs landed ==")  # fmt: skip
    wire, inj = study_wire(100), injection.Injection()
    run(wire, injection.Injection(stop_length=0.1))  # compile, and load both paths' kernels
    with legacy_feed.patched():
        run(wire, injection.Injection(stop_length=0.1))
    new_t, old_t = [], []
    for _ in range(repeat):
        r, t, c = run(wire, inj)
        new_t.append(t)
        with legacy_feed.patched():
            ro, t, co = run(wire, inj)
        old_t.append(t)
    tn, to = float(np.median(new_t)), float(np.median(old_t))
    same = fingerprint(r) == fingerprint(ro)
    for name, res, t, cnt in (("new", r, tn, c), ("landed", ro, to, co)):
        print(f"  {name:6s}: {t:.2f} s CPU, {cnt['iterations']} Newton iterations in "
              f"{cnt['relaxations']} relaxations, {t / cnt['iterations'] * 1e3:.3f} ms per "
              f"iteration, {len(res.stages)} stages, converged {res.converged}, "
              f"fingerprint {fingerprint(res)}")  # fmt: skip
    print(
        f"  speed-up (CPU, median of {repeat}): {to / tn:.2f}x; the same iterates bit for "
        f"bit: {same}; feed forces within {force_change(r, ro):.1e} of their largest"
    )


def bench_scale(ns, stop=None, landed=False):
    """Per N: CPU, Newton iterations and relaxations; ``landed``: the landed code's too."""
    inj = injection.Injection(stop_length=stop)
    print(f"== injection against N: R_c = {RADIUS}, h = {THICKNESS * RADIUS:g}, stop length "
          f"{'L0 less a segment' if stop is None else stop}, seed 0 ==")  # fmt: skip
    run(study_wire(100), injection.Injection(stop_length=0.1))  # compile
    for n in ns:
        for name in ("new", "landed") if landed else ("new",):
            with legacy_feed.patched() if name == "landed" else contextlib.nullcontext():
                r, t, c = run(study_wire(n), inj)
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
            its = c["iterations"]
            print(f"  N = {n:5d} {name:6s}: {t:8.2f} s CPU, {its:6d} Newton iterations in "
                  f"{c['relaxations']:5d} relaxations ({its / c['relaxations']:.1f} each), "
                  f"{t / its * 1e3:.3f} ms per iteration, {len(r.stages)} stages, converged "
                  f"{r.converged} ({r.stop_reason}), fingerprint {fingerprint(r)}, max RSS "
                  f"{rss:.2f} GiB", flush=True)  # fmt: skip


CASES = {
    "study N=100": (study_wire(100), injection.Injection(), 0),
    "plastic N=100": (
        study_wire(100, plasticity=Plasticity(s=0.2, theta_p=0.1)),
        injection.Injection(stop_length=0.6),
        1,
    ),
    "angled N=30": (
        Wire(k_b=K_B, k_s=K_S, n_segments=30, hard_core=0.002, cavity_radius=0.1),
        injection.Injection(angle=0.3, stop_length=0.7),
        2,
    ),
    "sparse N=500": (study_wire(500, radius=0.03), injection.Injection(stop_length=0.15), 0),
}


def bench_bits():
    """Whether the iterates moved: a change that keeps them prints the same fingerprints."""
    print("== fingerprints of the iterates (positions, energies, clamp reactions) ==")
    for name, (wire, inj, seed) in CASES.items():
        r, t, c = run(wire, inj, seed)
        print(f"  {name:14s}: {fingerprint(r)}, {c['iterations']} iterations, {t:.2f} s CPU",
              flush=True)  # fmt: skip


def main(argv):
    what = argv[0] if argv else "compare"
    opts = dict(a.split("=", 1) for a in argv[1:] if "=" in a)
    args = [a for a in argv[1:] if "=" not in a]
    if what == "compare":
        bench_compare(int(opts.get("repeat", 1)))
    elif what == "scale":
        stop = opts.get("stop")
        bench_scale([int(a) for a in args] or [100, 200, 400],
                    None if stop is None else float(stop), opts.get("landed") == "on")  # fmt: skip
    elif what == "bits":
        bench_bits()
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
