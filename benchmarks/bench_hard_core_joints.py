"""The hard core along the wire: two parallel strands slid past each other by a phase.

    python benchmarks/bench_hard_core_joints.py [gap=0.2] [n=40]

One wire folded into two straight strands of ``n`` segments (a wide turn joins them, far from
the strands' middle), the second strand at ``gap`` segment lengths from the first and shifted
along it by a phase of 0 … 1 segment. The hard core's energy is printed against the phase,
with its largest over its least: 1 where the core is smooth along the wire. The node–segment
sum counts the cap of a joint from both segments that meet there, so aligned nodes (phase 0)
cost twice what staggered ones do. ``d`` is 0.3 segments so that only facing features
interact. Recorded in docs/model.md ("Hard core") and docs/performance.md (twenty-sixth stop).
"""

from __future__ import annotations

import sys

import numpy as np

from crumple.energy import WireEnergy
from crumple.model import Wire


def strands(wire: Wire, n: int, gap: float, phase: float) -> np.ndarray:
    """Positions: strand A along x, a half-turn of radius 3 segments, strand B back at height
    ``gap`` shifted by ``phase`` (lengths in segments of ``wire``)."""
    seg = wire.rest_length
    a = np.c_[np.arange(n + 1) * seg, np.zeros(n + 1)]
    k = wire.n_segments - 2 * n - 1  # the turn's inner nodes
    th = np.linspace(-np.pi / 2, np.pi / 2, k + 2)[1:-1]
    turn = np.c_[n * seg + 3 * seg * np.cos(th), 0.5 * gap * seg + 3 * seg * np.sin(th)]
    b = np.c_[(phase + np.arange(n, -1, -1)) * seg, np.full(n + 1, gap * seg)]
    return np.vstack([a, turn, b])


def main(gap: float = 0.2, n: int = 40) -> None:
    if not 0.0 < gap < 0.3:
        raise SystemExit(f"gap must be in (0, 0.3) segments (inside the core), got {gap}")
    wire = Wire(k_b=5, k_s=5e5, n_segments=2 * n + 10, hard_core=0.3 / (2 * n + 10))
    energy = WireEnergy(wire, lam=0.0)
    phases = np.linspace(0.0, 1.0, 9)
    e = [energy.terms(strands(wire, n, gap, p)).hard_core for p in phases]
    print(f"== two strands of {n} segments, {gap} segments apart, d = 0.3 segments ==")
    for p, v in zip(phases, e, strict=True):
        print(f"  phase {p:.3f} segments: hard core {v:.6e}")
    print(f"  largest / least over the phase: {max(e) / min(e):.3f}")


if __name__ == "__main__":
    flags = dict(a.split("=") for a in sys.argv[1:] if "=" in a)
    main(float(flags.get("gap", 0.2)), int(flags.get("n", 40)))
