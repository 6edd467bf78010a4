"""Tests of crumple.loops: shapes whose loops are known, closed-form areas, invariants."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from crumple.geometry import close_segment_pairs, has_crossings
from crumple.observables import LoopStats, loops

C = 0.01  # contact distance of the test shapes [length]


# --------------------------------------------------------------------------------------------
# Shapes
# --------------------------------------------------------------------------------------------


def straight(n: int = 50) -> np.ndarray:
    x = np.linspace(0.0, 1.0, n + 1)
    return np.c_[x, np.zeros_like(x)]


def polygon_ring(n: int, radius: float = 1.0, gap: float = 0.3 * C) -> np.ndarray:
    """A regular n-gon traced once, its last node moved back along the last side by ``gap``:
    the ends touch and the closing link lies on the polygon, so the loop is the polygon."""
    phi = 2 * np.pi * np.arange(n + 1) / n
    x = radius * np.c_[np.cos(phi), np.sin(phi)]
    side = x[0] - x[n - 1]
    x[n] = x[0] - gap * side / np.linalg.norm(side)
    return x


def eight(n: int = 400, size: float = 1.0) -> np.ndarray:
    """Lemniscate of Gerono (x, y) = (sin t, sin t cos t): its ends stop 0.3 C on either side of
    the strand through the waist, which they touch (and which separates them: the link between
    the ends, 0.6 C long, would cross it). Each lobe has area 2/3 size²."""
    eps = 0.3 * C / (np.sqrt(2) * size)
    t = np.linspace(eps, 2 * np.pi - eps, n + 1)
    return size * np.c_[np.sin(t), np.sin(t) * np.cos(t)]


def snail(turns: int, *, per_turn: int = 200, gap: float = 0.4 * C) -> np.ndarray:
    """A spiral whose successive turns touch at one point (x = m gap, y = 0, m = 0..turns):

    point(θ) = (-ρ + gap θ/2π + ρ cos θ, ρ sin θ), ρ = 1 + θ/4π. Both ends touch the next
    turn, so every turn closes a loop: the innermost disc and a crescent between each two
    turns. Turns m and m + 2 are 2 gap = 0.8 C apart at the touching point: their links cross
    turn m + 1 and are dropped.
    """
    th = np.linspace(0.0, 2 * np.pi * turns, per_turn * turns + 1)
    rho = 1.0 + 0.5 * th / (2 * np.pi)
    return np.c_[-rho + gap * th / (2 * np.pi) + rho * np.cos(th), rho * np.sin(th)]


def packed_spiral(
    turns: int, *, r0: float = 0.2, spacing: float = 0.45 * C, step: float = 0.5 * C
) -> np.ndarray:
    """Archimedean spiral whose turns lie against each other all along (spacing < C)."""
    b = spacing / (2 * np.pi)
    th = np.linspace(0.0, 2 * np.pi * turns, 100_000)
    r = r0 + b * th
    x, y = r * np.cos(th), r * np.sin(th)
    s = np.r_[0.0, np.cumsum(np.hypot(np.diff(x), np.diff(y)))]
    su = np.arange(0.0, s[-1], step)
    return np.c_[np.interp(su, s, x), np.interp(su, s, y)]


def drop(
    *,
    arm: float = 0.5,
    radius: float = 0.2,
    gap: float = 0.5 * C,
    n_arm: int = 10,
    n_arm_back: int = 10,
    n_circle: int = 100,
) -> np.ndarray:
    """A water drop: a straight arm, a circle, and the arm back ``gap`` above the first one,
    parallel to it (exactly collinear nodes when the two arms have as many nodes)."""
    a = np.c_[np.linspace(-arm, 0.0, n_arm + 1), np.zeros(n_arm + 1)]
    phi = np.linspace(-np.pi / 2, 1.5 * np.pi, n_circle + 1)[1:-1]
    cy = radius + 0.0
    circ = np.c_[radius * np.cos(phi), cy + radius * np.sin(phi)]
    # the circle goes from (0, 0) round to (0, gap): squeeze its end points apart by gap
    circ[:, 1] += gap * (phi + np.pi / 2) / (2 * np.pi)
    b = np.c_[np.linspace(0.0, -arm, n_arm_back + 1), np.full(n_arm_back + 1, gap)]
    return np.r_[a, circ, b]


def shoelace(x: np.ndarray) -> float:
    return 0.5 * float(np.sum(x[:, 0] * np.roll(x[:, 1], -1) - np.roll(x[:, 0], -1) * x[:, 1]))


def rotate(x: np.ndarray, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return x @ np.array([[c, s], [-s, c]])


# --------------------------------------------------------------------------------------------
# Known shapes
# --------------------------------------------------------------------------------------------


def test_straight_wire_has_no_loop():
    st_ = loops(straight(), contact_distance=C)
    assert isinstance(st_, LoopStats)
    assert st_.count == 0 and st_.counts_by_depth == () and st_.n_links == 0
    assert st_.area.shape == (0,) and st_.centroid.shape == (0, 2)
    summary = st_.area_summary()
    assert summary["count"] == 0 and np.isnan(summary["median"])
    assert st_.to_dict()["area"]["median"] is None


def test_straight_wire_with_a_contact_distance_longer_than_its_segments():
    # neighbours along the wire are within C, but wire + link are shorter than π C: no contact
    st_ = loops(straight(1000), contact_distance=C)
    assert st_.count == 0 and st_.n_links == 0


@pytest.mark.parametrize("n", [3, 4, 7, 64, 501])
def test_polygon_whose_ends_touch_is_one_loop_with_the_polygon_area(n):
    x = polygon_ring(n)
    st_ = loops(x, contact_distance=C)
    assert st_.count == 1 and st_.counts_by_depth == (1,)
    # With an obtuse corner at the first node (n >= 5) the only link joins the two ends and
    # lies on the last side: the loop is the polygon. At a right or acute corner the last node
    # also links to its foot on the first side, cutting a sliver of size ~ gap off the corner.
    gap = 0.3 * C
    tol_a, tol_p = (1e-12, 1e-12) if n >= 5 else (gap**2, gap)
    area = 0.5 * n * np.sin(2 * np.pi / n)
    assert st_.area[0] == pytest.approx(area, rel=1e-12, abs=tol_a)
    wire = np.hypot(*np.diff(x, axis=0).T).sum()
    assert st_.perimeter[0] == pytest.approx(wire, rel=1e-12, abs=tol_p)
    assert st_.n_contacts[0] == 1 and st_.depth[0] == 0
    np.testing.assert_allclose(st_.centroid[0], [0, 0], atol=1e-3)


def test_circle_with_open_ends_has_no_loop():
    assert loops(polygon_ring(100, gap=2 * C), contact_distance=C).count == 0


def test_contact_distance_is_strict():
    x = polygon_ring(4, gap=0.25)
    d = float(np.linalg.norm(x[-1] - x[0]))  # the ends are d apart
    assert loops(x, contact_distance=d).count == 0
    assert loops(x, contact_distance=np.nextafter(d, np.inf)).count == 1


def test_figure_eight_touching_at_its_waist_has_two_loops():
    st_ = loops(eight(), contact_distance=C)
    assert st_.count == 2 and st_.counts_by_depth == (2,)
    np.testing.assert_allclose(st_.area, 2 / 3, rtol=2e-4)
    assert st_.area[0] == pytest.approx(st_.area[1], rel=1e-9)  # the two lobes are congruent
    assert list(st_.n_contacts) == [1, 1]


@pytest.mark.parametrize("turns", [1, 2, 3, 5, 8])
def test_spiral_whose_turns_touch_once_has_one_nested_loop_per_turn(turns):
    st_ = loops(snail(turns), contact_distance=C)
    assert st_.count == turns
    assert st_.counts_by_depth == (1,) * turns  # one loop at each depth 0 .. turns - 1
    # the innermost disc is the most deeply nested, closed by one contact
    inner = int(np.argmax(st_.depth))
    assert st_.depth[inner] == turns - 1 and st_.n_contacts[inner] == 1
    # the loops tile the region enclosed by the outermost turn
    total = shoelace(snail(turns)[-201:])  # the outermost turn, closed
    assert st_.area.sum() == pytest.approx(total, rel=1e-3)


def test_spiral_whose_turns_lie_against_each_other_has_one_loop_its_centre():
    x = packed_spiral(4)
    st_ = loops(x, contact_distance=C)
    assert st_.count == 1 and st_.depth[0] == 0
    assert st_.n_slivers > 100  # the bands between the turns are inside the contact
    first_turn = x[: int(np.searchsorted(np.unwrap(np.arctan2(x[:, 1], x[:, 0])), 2 * np.pi))]
    assert st_.area[0] == pytest.approx(shoelace(first_turn), rel=1e-3)


def test_loop_inside_a_touching_spiral_inside_a_loop_is_nested():
    # a packed spiral (one loop, its centre, ringed by the contact between its turns) inside
    # the innermost disc of a two-turn snail, joined to the snail's start by a straight bridge
    inner = packed_spiral(3, r0=0.1) + np.array([-1.0, 0.0])
    bridge = np.linspace(inner[-1], [0.0, 0.0], 60)[1:-1]
    x = np.r_[inner, bridge, snail(2)]
    assert not has_crossings(x)
    st_ = loops(x, contact_distance=C)
    assert st_.count == 3 and st_.counts_by_depth == (1, 1, 1)
    centre = int(np.argmin(st_.area))
    assert st_.depth[centre] == 2
    np.testing.assert_allclose(st_.centroid[centre], [-1.0, 0.0], atol=0.02)


def test_drop_with_parallel_arms():
    for n_back in (10, 7, 13):  # collinear nodes, then nodes staggered along the arms
        st_ = loops(drop(n_arm_back=n_back), contact_distance=C)
        assert st_.count == 1, n_back
        assert st_.area[0] == pytest.approx(np.pi * 0.2**2, rel=0.02)
        assert st_.n_contacts[0] == 1
        assert st_.n_slivers >= 1  # the gap between the arms


def pressed_strands(k: int = 10, radius: float = 2.0, dphi: float = 0.2) -> np.ndarray:
    """Two concentric polygonal arcs, the outer one's nodes staggered by half a segment and
    its chords 0.3 C outside the inner nodes: each inner node touches an outer chord, and
    between two such contacts the chords leave a gap of ~ s dphi / 4 = 0.02 > C (a hairpin
    joins the two arcs)."""
    a = radius * np.c_[np.cos(np.arange(k + 1) * dphi), np.sin(np.arange(k + 1) * dphi)]
    ang = (np.arange(k)[::-1] + 0.5) * dphi
    b = (radius + 0.3 * C) / np.cos(dphi / 2) * np.c_[np.cos(ang), np.sin(ang)]
    return np.r_[a, b]


def test_gaps_between_the_nodes_of_pressed_strands_are_not_loops():
    x = pressed_strands()
    assert not has_crossings(x)
    st_ = loops(x, contact_distance=C)
    seg = np.hypot(*np.diff(x, axis=0).T).mean()
    assert st_.min_width == pytest.approx(0.25 * seg)  # a quarter segment (0.1) > C
    assert st_.count == 0 and st_.n_links == 9 and st_.n_slivers == 9
    # at min_width = C each gap (mean width 0.013) would be a loop
    assert loops(x, contact_distance=C, min_width=C).count == 9


def two_rings(*, touch: bool = True, n: int = 120) -> np.ndarray:
    """Two rings side by side, each closed by an end of the wire touching where the wire enters
    it, joined by a bridge below them; with ``touch`` they touch each other at the origin
    (0.5 C apart), which also closes a third loop between them and the bridge."""
    r = 1.0 - (0.25 * C if touch else 0.2)

    def ring(cx: float) -> np.ndarray:
        phi = -np.pi / 2 + 2 * np.pi * np.arange(n + 1) / n
        x = np.c_[cx + r * np.cos(phi), r * np.sin(phi)]
        side = x[0] - x[n - 1]
        x[n] = x[0] - 0.3 * C * side / np.linalg.norm(side)  # stops 0.3 C before its start
        return x

    a, b = ring(-1.0), ring(1.0)
    return np.r_[a, [[a[-1, 0], -1.3], [0.0, -1.3], [1.0, -1.3]], b]


def test_loops_touching_loops_are_the_contacts_between_two_different_loops():
    apart = loops(two_rings(touch=False), contact_distance=C)
    assert apart.count == 2 and apart.n_loop_contacts == 0  # two necks, each within one loop
    x = two_rings()
    assert not has_crossings(x)
    st_ = loops(x, contact_distance=C)
    assert st_.count == 3 and st_.counts_by_depth == (3,)
    assert st_.n_loop_contacts >= 1  # the links at the origin, between the two rings
    for y in (x[::-1], rotate(x, 0.7) + 5.0):
        assert loops(y, contact_distance=C).n_loop_contacts == st_.n_loop_contacts
    # a lone loop, a water drop, a spiral's turns (each contact borders one loop and the
    # outside, or the same loop on both sides): no loop touches another
    for y in (polygon_ring(40), drop(), snail(2), packed_spiral(2)):
        assert loops(y, contact_distance=C).n_loop_contacts == 0
    assert st_.to_dict()["loop_contacts"] == st_.n_loop_contacts


def test_random_self_avoiding_wire_without_contacts_has_no_loop():
    rng = np.random.default_rng(7)
    found = 0
    for _ in range(10):
        # the graph of a random function: self-avoiding, with steep stretches close together
        x = np.c_[np.cumsum(rng.uniform(0.0, 0.01, 400)), np.cumsum(rng.normal(0, 0.01, 400))]
        _, dist = close_segment_pairs(x, 0.05)
        c = 0.5 * dist.min() if dist.size else 0.05
        st_ = loops(x, contact_distance=c)
        assert st_.count == 0 and st_.n_links == 0
        assert loops(x[::-1], contact_distance=c).count == 0
        found += 1
    assert found >= 5


# --------------------------------------------------------------------------------------------
# Invariance
# --------------------------------------------------------------------------------------------

SHAPES = {
    "ring": lambda: polygon_ring(60),
    "eight": lambda: eight(),
    "snail3": lambda: snail(3, per_turn=90),
    "packed": lambda: packed_spiral(2),
    "drop": lambda: drop(n_arm_back=7),
}


def same(a: LoopStats, b: LoopStats, rel: float = 1e-6) -> None:
    assert a.count == b.count
    assert a.counts_by_depth == b.counts_by_depth
    np.testing.assert_allclose(np.sort(a.area), np.sort(b.area), rtol=rel)
    np.testing.assert_allclose(np.sort(a.perimeter), np.sort(b.perimeter), rtol=rel)
    assert sorted(a.n_contacts.tolist()) == sorted(b.n_contacts.tolist())


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_reversed_or_rotated_wire_gives_the_same_loops(name):
    x = SHAPES[name]()
    ref = loops(x, contact_distance=C)
    same(loops(x[::-1], contact_distance=C), ref)
    same(loops(rotate(x, 0.7), contact_distance=C), ref)
    same(loops(rotate(x, np.pi / 2)[::-1] + np.array([3.0, -2.0]), contact_distance=C), ref)


@settings(max_examples=40, deadline=None)
@given(
    name=st.sampled_from(sorted(SHAPES)),
    angle=st.floats(-np.pi, np.pi),
    shift=st.tuples(st.floats(-10, 10), st.floats(-10, 10)),
    scale=st.floats(1e-3, 1e3),
    reverse=st.booleans(),
)
def test_loops_are_invariant_under_rigid_motions_scaling_and_reversal(
    name, angle, shift, scale, reverse
):
    x = SHAPES[name]()
    ref = loops(x, contact_distance=C)
    y = scale * (rotate(x, angle) + np.asarray(shift))
    if reverse:
        y = y[::-1]
    got = loops(y, contact_distance=scale * C)
    assert got.count == ref.count
    assert got.counts_by_depth == ref.counts_by_depth
    assert sorted(got.n_contacts.tolist()) == sorted(ref.n_contacts.tolist())
    np.testing.assert_allclose(np.sort(got.area), scale**2 * np.sort(ref.area), rtol=1e-6)


@settings(max_examples=30, deadline=None)
@given(name=st.sampled_from(sorted(SHAPES)), where=st.lists(st.floats(0, 1), max_size=5),
       frac=st.floats(0.05, 0.95))  # fmt: skip
def test_splitting_segments_does_not_change_the_loops(name, where, frac):
    x = SHAPES[name]()
    ref = loops(x, contact_distance=C)
    for u in where:
        i = min(int(u * (x.shape[0] - 1)), x.shape[0] - 2)
        x = np.insert(x, i + 1, x[i] + frac * (x[i + 1] - x[i]), axis=0)
    got = loops(x, contact_distance=C)
    assert got.count == ref.count and got.counts_by_depth == ref.counts_by_depth
    np.testing.assert_allclose(np.sort(got.area), np.sort(ref.area), rtol=1e-3)


# --------------------------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------------------------


def test_crossing_wire_is_refused():
    z = np.array([[0, 0], [1, 0], [1, 1], [0.5, -1]])
    with pytest.raises(ValueError, match="segments 0 and 2 intersect"):
        loops(z, contact_distance=C)


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf, "x", None])
def test_bad_contact_distance(bad):
    with pytest.raises(ValueError, match="contact_distance"):
        loops(straight(), contact_distance=bad)


def test_bad_positions():
    with pytest.raises(ValueError, match="shape"):
        loops(np.zeros((5, 3)), contact_distance=C)
    with pytest.raises(ValueError, match="NaN"):
        loops([[0, 0], [np.nan, 1]], contact_distance=C)
    with pytest.raises(ValueError, match="min_width"):
        loops(straight(), contact_distance=C, min_width=0)


def test_repeated_nodes_are_merged():
    x = polygon_ring(40)
    y = np.insert(x, [5, 5, 20], x[[5, 5, 20]], axis=0)
    same(loops(y, contact_distance=C), loops(x, contact_distance=C), rel=1e-12)


def test_min_width_sets_the_smallest_loop():
    x = polygon_ring(40, radius=1.0)
    assert loops(x, contact_distance=C, min_width=0.9).count == 1  # 2A/P ~ r cos(π/n)
    assert loops(x, contact_distance=C, min_width=1.1).count == 0
    st_ = loops(x, contact_distance=C, min_width=0.9)
    assert st_.min_width == 0.9 and st_.contact_distance == C


def test_boundaries_are_the_loop_polygons():
    x = polygon_ring(30)
    st_ = loops(x, contact_distance=C, boundaries=True)
    (b,) = st_.boundaries
    assert shoelace(b) == pytest.approx(st_.area[0], rel=1e-12)
    assert loops(x, contact_distance=C).boundaries is None


def test_result_is_frozen():
    st_ = loops(polygon_ring(10), contact_distance=C)
    with pytest.raises(AttributeError):
        st_.area = np.zeros(1)  # type: ignore[misc]
    with pytest.raises(ValueError):
        st_.area[0] = 0.0


@pytest.mark.parametrize("turns", [2, 3, 5])
def test_spiral_with_free_ends_loses_the_loops_they_closed(turns):
    x = snail(turns)  # 200 segments per turn: cut 30 off an end to free it of the next turn
    assert loops(x[30:], contact_distance=C).count == turns - 1  # the innermost disc opens
    assert loops(x[:-30], contact_distance=C).count == turns - 1  # the outermost crescent opens
    st_ = loops(x[30:-30], contact_distance=C)
    assert st_.count == turns - 2 and st_.counts_by_depth == (1,) * (turns - 2)
