"""The ramp predicted by a coarser wire (``Ramp(coarsen=m)``) against the plain ramp.

    python benchmarks/bench_coarsen.py compare N DIR_PLAIN DIR_COARSENED [K-K2]
    python benchmarks/bench_coarsen.py ramps N [coarsen=10] [seeds=0] [d=X] [plain=on|off]
                                                [pairs=off|on] [cut=off|on]

``compare``: two saved ramps of the continuum wire at N (``bench_scale.py scale N curved=on
save=DIR_PLAIN`` and ``… coarsen=M save=DIR_COARSENED``), stage by stage: λ, each one's energy
(recomputed from the saved positions), their relative difference, each one's radius of
gyration, and how far apart the two configurations are (the largest node distance in segments
after the rigid motion, reflections included, that fits them best, with the nodes of one
taken in either order: the two ramps draw their initial noise at different nodes, so one may
have buckled to the mirror image of the other, or folded end for end).
The same energy to many digits and a distance far below a segment: the same minimum.

``ramps``: whole default ramps of the continuum wire (curved steps), plain and coarsened, in one
process: the wire's Newton iterations (the coarse ramp's not counted) and per contact stage,
CPU (the coarse ramp's included), converged stages, and the coarse ramp's own iterations and
wall time. ``plain=off`` leaves the plain ramp out; ``pairs=on`` adds the coarsened ramp with
the coarse wire's barrier ε per node–segment pair (``protocol_coarse.CONTACT_PER_LENGTH =
False``, the twenty-eighth stop's predictor) as the baseline; ``cut=on`` adds the coarsened
ramp whose starts keep the hard core on the straight path from the last equilibrium
(:func:`uncrossed_start`: a candidate start whose path touches is refused, and where both
do, the moved start is cut halfway to its first touch). The last two columns look at the
path from each equilibrium to the next, for every ramp (the plain ramp's equilibria are joined
by the minimiser's steps, which never cross), and from the last equilibrium to the predicted
start, for the coarsened ones: the stages whose straight path (chord) has a node touch a
segment (continuous collision detection), and, of the node–segment pairs within 3d at both
ends, how many have the node on the other side of the segment at the far end
(:func:`side_flips`: a strand passed through the other where they touch).
Results: docs/performance.md, "The ramp predicted by a coarser wire", "The coarse wire's
contacts per length" and "The predictor's straight path".
"""

from __future__ import annotations

import itertools
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

from bench_collapse import radius_of_gyration, saved_pairs, stage_file
from bench_scale import continuum_wire

from crumple import protocol_coarse
from crumple.energy import WireEnergy
from crumple.geometry import max_safe_fraction, node_segment_pairs
from crumple.protocol import Ramp, run_ramp


def apart(a: np.ndarray, b: np.ndarray) -> float:
    """The largest node distance between ``a`` and ``b`` after the best rigid motion of ``a``,
    a reflection allowed (Kabsch without the determinant's correction), and with ``b``'s
    nodes in either order (the wire's two ends are alike: a ramp may fold it end for end)."""

    def fitted(b):
        ca, cb = a - a.mean(axis=0), b - b.mean(axis=0)
        u, _, vt = np.linalg.svd(ca.T @ cb)
        return float(np.linalg.norm(ca @ (u @ vt) - cb, axis=1).max())

    return min(fitted(b), fitted(b[::-1]))


def compare(n: int, plain: str, coarsened: str, first: int = 1, last: int | None = None):
    wire = continuum_wire(n)
    print(f"== N = {n}: the plain ramp ({plain}) against the coarsened one ({coarsened}) ==")
    print("  stage | λ | E plain | E coarsened | relative difference | R_g plain | R_g "
          "coarsened | apart (segments)")  # fmt: skip
    both = lambda k: (stage_file(plain, n, k), stage_file(coarsened, n, k))  # noqa: E731
    for k, lam, saved in saved_pairs(first, last, both):
        if saved is None:
            continue
        a, b = saved
        energy = WireEnergy(wire, lam)
        ea, eb = energy(a)[0], energy(b)[0]
        print(f"  {k} | {lam:.4g} | {ea:.10f} | {eb:.10f} | {(eb - ea) / ea:.1e} | "
              f"{radius_of_gyration(a):.4f} | {radius_of_gyration(b):.4f} | "
              f"{apart(a, b) * n:.2g}")  # fmt: skip


def _touches(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether a node touches a segment on the straight path from ``a`` to ``b``."""
    return max_safe_fraction(a, b - a) < 1.0


def side_flips(a: np.ndarray, b: np.ndarray, cutoff: float) -> tuple[int, int]:
    """Of the node–segment pairs closer than ``cutoff`` in both ``a`` and ``b`` whose node
    projects inside the segment in both, how many have the node on the other side of the
    segment in ``b`` than in ``a`` (a strand passed through the other where they touch), and
    how many such pairs there are."""
    ka, ja = node_segment_pairs(a, cutoff)
    kb, jb = node_segment_pairs(b, cutoff)
    pairs = lambda k, j: set(zip(k.tolist(), j.tolist(), strict=True))  # noqa: E731
    both = sorted(pairs(ka, ja) & pairs(kb, jb))
    if not both:
        return 0, 0
    k, j = np.array(both).T

    def side(x):
        e, r = x[j + 1] - x[j], x[k] - x[j]
        t = np.einsum("ij,ij->i", r, e) / np.einsum("ij,ij->i", e, e)
        return np.sign(e[:, 0] * r[:, 1] - e[:, 1] * r[:, 0]), (t > 0) & (t < 1)

    (sa, ina), (sb, inb) = side(a), side(b)
    inside = ina & inb
    return int(np.sum(inside & (sa != sb))), int(inside.sum())


def _recording(start, moves: list):
    """``CoarsePath.start`` ``start``, appending (last equilibrium, start) to ``moves``."""

    def recorded(path, stage, x):
        out = start(path, stage, x)
        moves.append((x, out))
        return out

    return recorded


def _paths(moves: list, cutoff: float) -> str:
    """The chords that touch, and the side flips at contacts, over the pairs ``moves``."""
    flips = [side_flips(a, b, cutoff) for a, b in moves]
    return (f"{sum(_touches(a, b) for a, b in moves)}, {sum(f for f, _ in flips)} of "
            f"{sum(c for _, c in flips)}")  # fmt: skip


def uncrossed_start(path, stage: int, x: np.ndarray) -> np.ndarray:
    """``CoarsePath.start`` that keeps the hard core on the way to the start: the moved start,
    else the coarse curve, where the straight path from ``x`` to it touches nothing; else the
    moved start cut halfway to its first touch (as the stage noise is cut)."""
    moved, now = path.candidates(stage, x)
    for kind, start in (("moved", moved), ("coarse", now)):
        if max_safe_fraction(x, start - x) >= 1.0:
            path.starts[kind] += 1
            return start
    path.starts["cut"] = path.starts.get("cut", 0) + 1
    return x + 0.5 * max_safe_fraction(x, moved - x) * (moved - x)


def ramps(n: int, coarsen: int = 10, seeds=(0,), hard_core=None, plain=True, pairs=False,
          cut=False):  # fmt: skip
    wire = continuum_wire(n, hard_core)
    print(f"== N = {n}, d = {wire.hard_core:g}, default schedule, curved steps: plain against "
          f"coarsen = {coarsen} ==")  # fmt: skip
    print("  seed | ramp | iterations | per contact stage | CPU s | converged | the coarse ramp "
          "| from each equilibrium to the next, to the start: chords that touch, side flips of "
          "the pairs within 3d in both")  # fmt: skip
    runs = [("plain", 1, True, False)] if plain else []
    runs.append((f"coarsen {coarsen}", coarsen, True, False))
    if pairs:  # the baseline: the coarse wire's ε per pair (the twenty-eighth stop's)
        runs.append((f"coarsen {coarsen}, ε per pair", coarsen, False, False))
    if cut:
        runs.append((f"coarsen {coarsen}, starts cut at the first touch", coarsen, True, True))
    saved = protocol_coarse.CONTACT_PER_LENGTH, protocol_coarse.CoarsePath.start
    for seed in seeds:
        for name, m, per_length, cut_starts in runs:
            protocol_coarse.CONTACT_PER_LENGTH = per_length
            starts: list[tuple] = []
            protocol_coarse.CoarsePath.start = _recording(
                uncrossed_start if cut_starts else saved[1], starts
            )
            try:
                t0 = time.process_time()
                r = run_ramp(wire, Ramp(curved_steps=True, coarsen=m), seed=seed)
                t = time.process_time() - t0
            finally:
                protocol_coarse.CONTACT_PER_LENGTH, protocol_coarse.CoarsePath.start = saved
            its = [s.result.iterations for s in r.stages]
            contact = [s.result.iterations for s in r.stages if s.energy.hard_core > 0]
            c = "" if r.coarse is None else (
                f"{r.coarse.iterations} iterations, {r.coarse.seconds:.1f} s wall, starts "
                f"moved {r.coarse.moved}, coarse {r.coarse.from_coarse}, cut "
                f"{len(r.stages) - r.coarse.moved - r.coarse.from_coarse}")  # fmt: skip
            xs = [r.initial] + [s.positions for s in r.stages]
            to_start = _paths(starts, 3 * wire.hard_core) if starts else "-"
            print(f"  {seed} | {name} | {sum(its)} | {np.mean(contact):.1f} ({len(contact)}) | "
                  f"{t:.1f} | {sum(s.result.converged for s in r.stages)}/{len(r.stages)} | "
                  f"{c} | {_paths(list(itertools.pairwise(xs)), 3 * wire.hard_core)} | "
                  f"{to_start}", flush=True)  # fmt: skip


def main(argv):
    flags = dict(a.split("=", 1) for a in argv if "=" in a)
    args = [a for a in argv if "=" not in a]
    if args[:1] == ["compare"] and len(args) in (4, 5):
        first, last = 1, None
        if len(args) == 5:
            a, _, b = args[4].partition("-")
            first, last = int(a), int(b or a)
        compare(int(args[1]), args[2], args[3], first, last)
    elif args[:1] == ["ramps"] and len(args) == 2:
        seeds = tuple(int(s) for s in flags.get("seeds", "0").split(","))
        d = float(flags["d"]) if "d" in flags else None
        ramps(
            int(args[1]),
            int(flags.get("coarsen", 10)),
            seeds,
            d,
            plain=flags.get("plain", "on") == "on",
            pairs=flags.get("pairs", "off") == "on",
            cut=flags.get("cut", "off") == "on",
        )
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv[1:])
