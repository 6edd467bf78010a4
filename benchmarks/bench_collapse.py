"""Which stages of a saved ramp are collapses: how far each stage moved the wire.

    python benchmarks/bench_collapse.py N DIR [K-K2] [log=F]

DIR holds the stage positions ``N<n>_stage<k>.npy`` that ``bench_scale.py scale N save=DIR``
(or ``stage … save=DIR``) wrote. For each stage k of K … K2 (default: every stage saved from 2
on) it prints λ, the radius of gyration R_g, its change from stage k - 1, and how far the
nodes moved from stage k - 1 in segments (median and largest), after the rigid motion that fits
the two stages best (Kabsch: the ramp's energy does not see a rotation, so a turn of the whole
packing is not a rearrangement). A collapse is a stage whose R_g drops by much more than the
ramp's trend and whose nodes move by many segments. ``log=F``: the output of the runs that wrote
DIR (``bench_scale.py scale`` prints a line per stage at N >= 10⁴, ``stage`` one per stage),
from which each stage's Newton iterations (all its passes) are read and the segments a
node moved per iteration (median) printed beside them. Newton's contact steps move a node by a
fraction of a segment (docs/performance.md), so such a stage costs iterations in proportion to
the distance it moves in segments, and that grows with N at a fixed physical distance.
Results: docs/performance.md, "The ramp predicted by a coarser wire", its part "Where a late
stage's iterations go".
"""

from __future__ import annotations

import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))

from crumple.protocol import default_schedule


def radius_of_gyration(x: np.ndarray) -> float:
    """R_g of the nodes (each node weighted alike)."""
    c = x - x.mean(axis=0)
    return float(np.sqrt((c * c).sum(axis=1).mean()))


def moved(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Each node's displacement from ``a`` to ``b`` after the rotation and translation that
    bring ``a`` closest to ``b`` (least squares, Kabsch)."""
    ca, cb = a - a.mean(axis=0), b - b.mean(axis=0)
    u, _, vt = np.linalg.svd(ca.T @ cb)
    if np.linalg.det(u @ vt) < 0:  # a reflection is not a rigid motion of the plane
        u[:, -1] = -u[:, -1]
    return np.linalg.norm(ca @ (u @ vt) - cb, axis=1)


#: A stage's line in ``bench_scale.py scale``'s output ("stage 31/44, λ = 234.4: 126 iterations,
#: …") and ``stage``'s ("stage 31 (λ = 234.4): 126 iterations; …"); the count is the stage's
#: whole (its polish, which the line names after it, included).
STAGE_LINE = re.compile(r"stage (\d+)(?:/\d+,| \().*?: (\d+) iterations")


def iterations_from(path: str | None) -> dict[int, int]:
    """Each stage's Newton iterations (every pass) from the runs' output at ``path`` (None:
    none); a stage run more than once keeps its last line."""
    if path is None:
        return {}
    out = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            m = STAGE_LINE.search(line)
            if m:
                out[int(m.group(1))] = int(m.group(2))
    return out


def stage_file(folder: str, n: int, k: int) -> str:
    return os.path.join(folder, f"N{n}_stage{k:02d}.npy")


def saved_pairs(first: int, last: int | None, files):
    """(k, λ_k, (a, b)) for each stage k of the default schedule from ``first`` to ``last``
    (None: the last), (a, b) loaded from the two paths ``files(k)``, or None where either is
    not saved."""
    lambdas = default_schedule()
    for k in range(first, (len(lambdas) if last is None else last) + 1):
        paths = files(k)
        saved = all(os.path.exists(p) for p in paths)
        yield k, lambdas[k - 1], tuple(np.load(p) for p in paths) if saved else None


def bench_collapse(n: int, folder: str, first: int = 2, last: int | None = None, log=None):
    segment = 1.0 / n
    its = iterations_from(log)
    print(f"== N = {n}, stages {first} … {last or 'the last'} of {folder}: how far each stage "
          "moved ==")  # fmt: skip
    print("  stage | λ | R_g | R_g / R_g before | moved (segments), median | largest | "
          "iterations | median moved per iteration")  # fmt: skip
    pairs = lambda k: (stage_file(folder, n, k - 1), stage_file(folder, n, k))  # noqa: E731
    for k, lam, saved in saved_pairs(first, last, pairs):
        if saved is None:
            print(f"  {k} | {lam:.4g} | not saved")
            continue
        a, b = saved
        d = moved(a, b) / segment
        rg, med = radius_of_gyration(b), float(np.median(d))
        per = f"{its[k]} | {med / its[k]:.2f}" if its.get(k) else "— | —"
        print(f"  {k} | {lam:.4g} | {rg:.4f} | {rg / radius_of_gyration(a):.3f} | "
              f"{med:.1f} | {d.max():.1f} | {per}")  # fmt: skip


def main(argv: list[str]) -> None:
    flags = dict(a.split("=", 1) for a in argv if "=" in a)
    args = [a for a in argv if "=" not in a]
    if len(args) not in (2, 3) or set(flags) - {"log"}:
        raise SystemExit(__doc__)
    n, folder = int(args[0]), args[1]
    first, last = 2, None
    if len(args) == 3:
        a, _, b = args[2].partition("-")
        first, last = int(a), int(b or a)
    if first < 2:
        raise SystemExit("the first stage must be 2 or more: stage 1 has no stage before it")
    bench_collapse(n, folder, first, last, flags.get("log"))


if __name__ == "__main__":
    main(sys.argv[1:])
