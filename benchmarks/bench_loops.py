"""Time crumple.observables.loops on packed wires of N = 10^3, 10^4, 10^5 segments.

Two layouts. "wavy": a spiral whose radius wobbles (``wavy_spiral``), so that each turn touches
the previous one at ~20 points per turn and a lens-shaped loop lies between each two touching
points: thousands of loops and contact runs, segments 5 contact distances long (the ratio of the
densest engine runs, d = 10^-6 at N = 10^5). "nested": a spiral whose turns touch once per turn
(``snail``), every turn a loop enclosing all the inner ones (175 turns, depths 0 .. 174 at
N = 10^5): the worst case of the depth computation, whose cost is the sum of the depths. The
baseline in the same process is the contact search alone (``close_segment_pairs``), which any
loop count needs.

    python benchmarks/bench_loops.py            # N = 10^3, 10^4, 10^5
    python benchmarks/bench_loops.py --quick    # N = 10^3, 10^4
    python benchmarks/bench_loops.py --shapely  # also Shapely's node + polygonize (not a
                                                # dependency: pip install shapely)
    python benchmarks/bench_loops.py --fan 4000,16000   # the review's fixed-angle spiral

``--fan`` also runs the crossing search's candidate pairs (``geometry.cells._segment_pairs``)
with the hash in one cell (``crowd=inf``, the hash of before the chunks) and as chosen
(chunked: the spiral's segments crowd it), in the same process: their counts and times.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from crumple.geometry import close_segment_pairs
from crumple.observables import loops


def wavy_spiral(
    n_segments: int,
    *,
    contact: float = 1.0,
    segment: float = 5.0,
    spacing: float = 4.0,
    gap: float = 0.5,
    lobes: float = 20.5,
) -> np.ndarray:
    """A spiral r = r0 + spacing θ/2π + A sin(lobes θ) sampled every ``segment`` of arc length.

    With ``lobes`` a half-integer, the gap between turns m and m + 1 at angle θ is
    ``spacing - 2 A sin(lobes θ)``, smallest (``gap``, below ``contact``) at ~``lobes`` points
    per turn: each turn touches the previous one there and encloses a lens between two such
    points. Turns m and m + 2 stay ``2 spacing`` apart. Lengths in units of ``contact``.
    """
    amp = 0.5 * (spacing - gap)
    total = n_segments * segment
    r0 = 10.0 * spacing
    # turns k: length ~ 2π k (r0 + k spacing / 2)
    k = (-r0 + np.sqrt(r0 * r0 + 2 * spacing * total / (2 * np.pi))) / spacing
    th = np.linspace(0.0, 2 * np.pi * (k + 1.0), int(4000 * (k + 2)))
    r = r0 + spacing * th / (2 * np.pi) + amp * np.sin(lobes * th)
    x, y = r * np.cos(th), r * np.sin(th)
    s = np.r_[0.0, np.cumsum(np.hypot(np.diff(x), np.diff(y)))]
    su = np.arange(n_segments + 1) * segment
    if su[-1] > s[-1]:
        raise ValueError("curve too short")
    return contact * np.c_[np.interp(su, s, x), np.interp(su, s, y)]


def snail(
    n_segments: int, *, contact: float = 1.0, segment: float = 5.0, grow: float = 5.0
) -> np.ndarray:
    """A spiral whose turns touch once each, at (0.4 m contact, 0), sampled every ``segment``:
    point(θ) = (-ρ + 0.4 θ/2π + ρ cos θ, ρ sin θ), ρ = 20 + grow θ/2π (units of ``contact``).
    Both ends touch the neighbouring turn, so every turn closes a loop around the inner ones."""
    total = n_segments * segment
    r0 = 20.0
    k = int((-r0 + np.sqrt(r0 * r0 + grow * total / np.pi)) / grow)  # 2π k (r0 + k grow/2)
    th = np.linspace(0.0, 2 * np.pi * k, 4000 * (k + 1))
    rho = r0 + grow * th / (2 * np.pi)
    x = -rho + 0.4 * th / (2 * np.pi) + rho * np.cos(th)
    y = rho * np.sin(th)
    s = np.r_[0.0, np.cumsum(np.hypot(np.diff(x), np.diff(y)))]
    su = np.linspace(0.0, s[-1], n_segments + 1)  # ends exactly at θ = 0 and 2π k
    return contact * np.c_[np.interp(su, s, x), np.interp(su, s, y)]


def fan(n_segments: int, *, per_turn: int = 40, spacing: float = 1.0) -> np.ndarray:
    """An Archimedean spiral r = spacing θ/2π sampled at a fixed angle, ``per_turn`` segments a
    turn (the review's case): segments grow with r (from ~0 at the centre to 2π r / per_turn
    outside), so the outer turns' segments are many contact distances long while the inner
    ones are far shorter than it. Lengths in units of ``spacing``."""
    th = 2 * np.pi * np.arange(1, n_segments + 2) / per_turn
    r = spacing * th / (2 * np.pi)
    return np.c_[r * np.cos(th), r * np.sin(th)]


def time_fan(sizes, c: float = 1.2) -> None:
    """The review's case, and where its time goes: the exact crossing check
    (``geometry.find_crossings``, geometry's) and the link conflicts (``loops.links``)."""
    from crumple.geometry import find_crossings
    from crumple.loops import links as lk_mod

    calls = {"conflicts": 0.0}
    real = lk_mod._link_conflicts

    def timed(*a):
        t0 = time.perf_counter()
        out = real(*a)
        calls["conflicts"] += time.perf_counter() - t0
        return out

    lk_mod._link_conflicts = timed
    try:
        loops(fan(200), contact_distance=c)  # compile
        print(f"\n{'fan N':>7} {'loops s':>9} {'find_crossings s':>17} {'link conflicts s':>17}")
        for n in sizes:
            x = fan(n)
            calls["conflicts"] = 0.0
            t0 = time.perf_counter()
            loops(x, contact_distance=c)
            t1 = time.perf_counter()
            find_crossings(x)
            t2 = time.perf_counter()
            print(f"{n:>7} {t1 - t0:>9.3f} {t2 - t1:>17.3f} {calls['conflicts']:>17.3f}")
    finally:
        lk_mod._link_conflicts = real
    _fan_candidates(sizes)


def _fan_candidates(sizes, c: float = 1.2) -> None:
    """On the fixed-angle spiral, the one-cell hash against the chunked one in the same
    process: the crossing search's candidate pairs, and the node-segment pairs within c (the
    same pairs either way: checked)."""
    from crumple.geometry.cells import _segment_pairs
    from crumple.geometry.distance import _node_segment_pairs_crowd

    def timed(fn, *args):
        t0 = time.perf_counter()
        out = fn(*args)
        return out, time.perf_counter() - t0

    def candidates(x, crowd):
        a, b = np.ascontiguousarray(x[:-1]), np.ascontiguousarray(x[1:])
        return timed(_segment_pairs, a[:, 0], a[:, 1], b[:, 0], b[:, 1], 0.0, 1, 0, crowd)

    for crowd in (np.inf, 0.0):  # compile
        candidates(fan(200), crowd), _node_segment_pairs_crowd(fan(200), c, crowd)
    print(f"\n{'fan N':>7} {'candidates':>22} {'one-cell s':>10} {'chunked s':>9}"
          f" {'node-segment pairs':>18} {'one-cell s':>10} {'chunked s':>9}")  # fmt: skip
    for n in sizes:
        x = fan(n)
        (one, t1), (chunked, t2) = candidates(x, np.inf), candidates(x, 32.0)
        (k1, j1), t3 = timed(_node_segment_pairs_crowd, x, c, np.inf)
        (k2, j2), t4 = timed(_node_segment_pairs_crowd, x, c, 32.0)
        assert np.array_equal(k1, k2) and np.array_equal(j1, j2)
        print(f"{n:>7} {len(one):>10} / {len(chunked):>9} {t1:>10.3f} {t2:>9.3f} "
              f"{len(k1):>18} {t3:>10.3f} {t4:>9.3f}")  # fmt: skip


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--shapely", action="store_true", help="compare with shapely.polygonize")
    ap.add_argument(
        "--fan",
        default="",
        help="comma-separated N of the review's fixed-angle spiral (40 segments a turn), "
        "e.g. 4000,16000,64000; alone, skips the rest",
    )
    args = ap.parse_args(argv)
    if args.fan:
        time_fan([int(v) for v in args.fan.split(",")])
        return
    sizes = [10**3, 10**4] if args.quick else [10**3, 10**4, 10**5]
    c = 1.0
    loops(wavy_spiral(200), contact_distance=c)  # compile
    close_segment_pairs(wavy_spiral(200), c)
    print(
        f"{'layout':>7} {'N':>7} {'loops':>6} {'depth':>6} {'links':>7} {'slivers':>8} "
        f"{'loops s':>9} {'pairs s':>9} {'ratio':>6} {'us/seg':>7}"
    )
    for layout, make in (("wavy", wavy_spiral), ("nested", snail)):
        prev = None
        for n in sizes:
            x = make(n)
            t_l, t_p = [], []
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                st = loops(x, contact_distance=c)
                t_l.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                close_segment_pairs(x, c)
                t_p.append(time.perf_counter() - t0)
            tl, tp = float(np.median(t_l)), float(np.median(t_p))
            scale = "" if prev is None else f"  x{tl / prev[1]:.1f} for x{n / prev[0]:.0f} N"
            print(
                f"{layout:>7} {n:>7} {st.count:>6} {int(st.depth.max(initial=0)):>6} "
                f"{st.n_links:>7} {st.n_slivers:>8} {tl:>9.4f} {tp:>9.4f} {tl / tp:>6.1f} "
                f"{1e6 * tl / n:>7.2f}" + scale
            )
            prev = (n, tl)
    if args.shapely:
        compare_shapely(sizes, c)


def compare_shapely(sizes, c: float) -> None:
    """Faces by Shapely from the same wire and links: node the segments, polygonize.

    The links' feet are computed points, not exactly on their segments, so the graph must be
    noded first; the loops would then be the polygons with 2A/P >= c (no depth, no runs).
    """
    import shapely

    print(f"\n{'N':>7} {'ours s':>8} {'shapely s':>10} {'faces':>7} {'shapely faces':>14}")
    for n in sizes:
        x = wavy_spiral(n)
        st = loops(x, contact_distance=c, boundaries=True)
        t0 = time.perf_counter()
        st = loops(x, contact_distance=c, boundaries=True)
        t1 = time.perf_counter()
        segs = np.concatenate([np.stack([x[:-1], x[1:]], 1), np.asarray(st.links)])
        t2 = time.perf_counter()
        noded = shapely.node(shapely.multilinestrings(shapely.linestrings(segs)))
        polys = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
        shapely.area(polys), shapely.length(polys)
        t3 = time.perf_counter()
        print(f"{n:>7} {t1 - t0:>8.3f} {t3 - t2:>10.3f} {st.count + st.n_slivers:>7} "
              f"{len(polys):>14}")  # fmt: skip


if __name__ == "__main__":
    main()
