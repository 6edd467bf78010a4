"""Continuous collision detection: the spatial hash against the chain's tree, in one process.

    python benchmarks/bench_ccd.py [N …]      # default N = 100, 1000, 10⁴, 5 × 10⁴

For each N and each step (smooth, random, rigid, on a wavy wire and on a packed spiral of pitch
3 segments), the time of one call of the hash (``geometry.ccd._max_safe_fraction``), of the tree
(``_max_safe_fraction_tree``) with leaves of 1, 2, 4 and 8 segments, and of what
``max_safe_fraction`` does (the hash below ``TREE_ABOVE`` mean segment lengths of largest
displacement, the tree above); each must return the same fraction (checked), and the ratio
hash / chosen is printed. Minimum of 3 calls after a warm-up. Results in docs/performance.md.
"""

from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))

import numpy as np
from bench_engine import spiral

from crumple.geometry.ccd import (
    TREE_LEAF,
    _max_safe_fraction,
    _max_safe_fraction_tree,
    _safe_fraction,
)


def best_time(fn, *args, repeat=3):
    out = fn(*args)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(*args)
        times.append(time.perf_counter() - t0)
    return min(times), out


def steps(n: int):
    """(name, positions, step) of the cases: l0 = 1/N, displacements in segment lengths."""
    s = np.linspace(0.0, 1.0, n + 1)
    l0 = 1.0 / n
    wavy = np.c_[s - 0.5, 0.02 * np.sin(3 * np.pi * s)]
    bend = np.c_[0.001 * np.cos(np.pi * s), 0.01 * np.sin(2 * np.pi * s)]
    packed = spiral(n, 3 * l0)
    rng = np.random.default_rng(0)
    yield "wavy, smooth step 0.01 (a buckling mode)", wavy, bend
    yield "wavy, smooth step 10⁻⁴", wavy, 1e-2 * bend
    yield "spiral, random step 0.1 l0", packed, rng.normal(0.0, 0.1 * l0, packed.shape)
    yield "spiral, smooth step l0", packed, l0 * np.c_[np.cos(5 * s), np.sin(7 * s)]
    yield "spiral, rigid step 100 l0", packed, np.tile([100 * l0, 30 * l0], (n + 1, 1))


def main(ns):
    print("== one CCD call, ms: hash | tree, leaves 1 / 2 / 4 / 8 | max_safe_fraction "
          f"(TREE_LEAF = {TREE_LEAF}) | hash / max_safe_fraction ==")  # fmt: skip
    for n in ns:
        for name, pos, step in steps(n):
            pos, step = np.ascontiguousarray(pos), np.ascontiguousarray(step)
            th, t = best_time(_max_safe_fraction, pos, step)
            tree = []
            for leaf in (1, 2, 4, 8):
                tt, tl = best_time(_max_safe_fraction_tree, pos, step, leaf)
                if tl != t:
                    raise SystemExit(f"the tree (leaf {leaf}) gave {tl!r}, the hash {t!r}")
                tree.append(tt)
            ta, tc = best_time(_safe_fraction, pos, step)
            assert tc == t
            print(f"  N = {n:6d} {name:42s} {th * 1e3:10.3f} | "
                  f"{' / '.join(f'{v * 1e3:.3f}' for v in tree)} | {ta * 1e3:.3f} | "
                  f"{th / ta:7.1f}x   (fraction {t:.3g})", flush=True)  # fmt: skip


if __name__ == "__main__":
    main([int(v) for v in sys.argv[1:]] or [100, 1000, 10_000, 50_000])
