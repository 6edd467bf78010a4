"""Tests of crumple.observables: exact answers, invariants (hypothesis) and input checks."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import crumple.observables as obs
from crumple.fit import MeanEstimate, PowerLawFit
from crumple.geometry import find_crossings
from crumple.observables import (
    center_of_mass,
    count_contacts,
    energy_ratio,
    ensemble_mass_size_exponent,
    mass_size_exponent,
    mass_within,
    measure,
    r_max,
    radius_of_gyration,
)

# --------------------------------------------------------------------------------------------
# Test wires
# --------------------------------------------------------------------------------------------


def straight(n_segments: int, length: float = 1.0) -> np.ndarray:
    """Straight wire of the given length centred on the origin, along x."""
    x = np.linspace(-0.5 * length, 0.5 * length, n_segments + 1)
    return np.c_[x, np.zeros_like(x)]


def polygon(n_sides: int, radius: float, phase: float = 0.0) -> np.ndarray:
    """Closed regular polygon inscribed in a circle about the origin (first node repeated)."""
    phi = phase + np.linspace(0.0, 2.0 * np.pi, n_sides + 1)
    pts = radius * np.c_[np.cos(phi), np.sin(phi)]
    pts[-1] = pts[0]
    return pts


def polygon_mass(big_r, n_sides: int, radius: float) -> np.ndarray:
    """Exact length of a regular polygon inside a disc about its centre: each side (length
    2 rho sin(pi/n), apothem h = rho cos(pi/n)) holds the chord 2 sqrt(R^2 - h^2)."""
    big_r = np.asarray(big_r, dtype=float)
    side = 2 * radius * np.sin(np.pi / n_sides)
    h = radius * np.cos(np.pi / n_sides)
    chord = np.where(big_r >= radius, side, 2 * np.sqrt(np.clip(big_r**2 - h**2, 0, None)))
    return n_sides * np.minimum(chord, side)


def archimedean_spiral(turns: float, step: float = 1.0) -> np.ndarray:
    """r = theta (in units of the spacing / 2 pi) sampled every ``step`` of arc length, scaled
    to total length 1: a wire filling a disc uniformly."""
    th_max = 2 * np.pi * turns
    total = 0.5 * (th_max * np.sqrt(1 + th_max**2) + np.arcsinh(th_max))
    s = np.linspace(0.0, total, int(total / step) + 1)
    th = np.sqrt(2 * s)
    for _ in range(40):  # Newton on the exact arc length of r = theta
        f = 0.5 * (th * np.sqrt(1 + th**2) + np.arcsinh(th)) - s
        th -= f / np.sqrt(1 + th**2)
    return np.c_[th * np.cos(th), th * np.sin(th)] / total


def random_walk(seed: int, n_segments: int) -> np.ndarray:
    """Random planar walk with segment lengths in [0.5, 1.5] / n (total length ~ 1)."""
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.5, 1.5, n_segments) / n_segments
    angles = np.cumsum(rng.uniform(-2.0, 2.0, n_segments))
    pts = np.vstack(
        [[0.0, 0.0], np.cumsum(np.c_[steps * np.cos(angles), steps * np.sin(angles)], 0)]
    )
    return pts


def rigid_motion(pos: np.ndarray, angle: float, shift) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return pos @ np.array([[c, s], [-s, c]]) + np.asarray(shift)


# --------------------------------------------------------------------------------------------
# Centre, radii, contacts
# --------------------------------------------------------------------------------------------


def test_center_of_mass_weightings():
    pos = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 3.0]])
    assert center_of_mass(pos).tolist() == [0.875, 1.125]
    assert center_of_mass(pos, weighting="segments").tolist() == [0.75, 0.75]
    assert center_of_mass(pos, weighting="nodes") == pytest.approx([2 / 3, 1.0])
    # the length-weighted centre does not depend on how a straight wire is subdivided
    coarse = np.array([[0.0, 0.0], [4.0, 0.0]])
    fine = np.array([[0.0, 0.0], [0.1, 0.0], [4.0, 0.0]])
    assert center_of_mass(fine) == pytest.approx(center_of_mass(coarse))
    assert center_of_mass(fine, weighting="nodes")[0] == pytest.approx(4.1 / 3)


def test_r_max_and_rms_of_a_straight_wire():
    for n in (1, 7, 100):
        wire = straight(n)
        assert r_max(wire) == pytest.approx(0.5)
        # exact integral: L^2 / 12 whatever the subdivision (node sampling would give more)
        assert radius_of_gyration(wire) ** 2 == pytest.approx(1 / 12, rel=1e-12)
    assert radius_of_gyration(straight(4), center=[0.5, 0.0]) ** 2 == pytest.approx(1 / 3)


def test_rms_of_a_regular_polygon_is_exact():
    n, rho = 12, 2.0
    pts = polygon(n, rho)
    delta = 2 * np.pi / n
    assert radius_of_gyration(pts) ** 2 == pytest.approx(rho**2 * (2 + np.cos(delta)) / 3)
    assert radius_of_gyration(pts, weighting="segments") == pytest.approx(radius_of_gyration(pts))
    assert r_max(pts) == pytest.approx(rho)


def test_count_contacts():
    hairpin = np.array([[0, 0], [1, 0], [1, 0.1], [0, 0.1]], dtype=float)
    assert count_contacts(hairpin, 0.2) == 1
    assert count_contacts(hairpin, 0.1) == 0  # strict: distance 0.1 is not < 0.1
    crossing = np.array([[0, 0], [1, 0], [1, 1], [0.5, -1]], dtype=float)
    assert count_contacts(crossing, 1e-9) == 1
    # adjacent segments are never contacts, but segments i and i + 2 are once the contact
    # distance exceeds a segment length (0.1 here): all 36 pairs j >= i + 2 of a straight wire
    assert count_contacts(straight(10), 0.05) == 0
    assert count_contacts(straight(10), 1.0) == 36
    for bad in (0.0, -1.0, np.nan, "x"):
        with pytest.raises(ValueError, match="distance"):
            count_contacts(hairpin, bad)


# --------------------------------------------------------------------------------------------
# M(R) against exact answers
# --------------------------------------------------------------------------------------------

RADII = np.array([0.0, 0.001, 0.0037, 0.05, 0.1234, 0.25, 0.3333, 0.4999, 0.5, 0.7, 5.0])


@pytest.mark.parametrize("method", ["exact", "eq3"])
def test_straight_wire_through_the_centre(method):
    """M = 2R/L0 for R < L0/2, then 1 (a node at the centre: Eq. 3 is exact too)."""
    m = mass_within(straight(100), RADII, method=method)
    assert m == pytest.approx(np.minimum(2 * RADII, 1.0), abs=1e-13)


def test_straight_wire_centre_inside_a_segment():
    """Odd N: the centre is mid-segment; Eq. 3 misses that segment while both ends are out."""
    wire = straight(101)
    half = 0.5 / 101  # half a segment
    exact = mass_within(wire, RADII)
    assert exact == pytest.approx(np.minimum(2 * RADII, 1.0), abs=1e-13)
    eq3 = mass_within(wire, RADII, method="eq3")
    small = RADII < half
    assert np.all(eq3[small] == 0.0)
    assert eq3[~small] == pytest.approx(exact[~small], abs=1e-13)
    # a longer wire, off-centre centre: M = (min(R, a) + min(R, b)) / L
    assert mass_within(straight(10, 2.0), 0.3, center=[0.8, 0.0]) == pytest.approx(0.5 / 2)


@pytest.mark.parametrize("n_sides", [8, 100, 1000])
def test_circle(n_sides):
    rho = 0.4
    pts = polygon(n_sides, rho, phase=0.3)
    total = 2 * n_sides * rho * np.sin(np.pi / n_sides)
    h = rho * np.cos(np.pi / n_sides)
    # (not R = h itself: at tangency M has a square-root singularity, and a round-off of
    # 1e-16 in h moves it by ~1e-8 per side)
    r_near = [h * (1 - 1e-6), h * (1 + 1e-6)]
    radii = np.array(
        [0.0, 0.5 * h, *r_near, 0.5 * (h + rho), rho * (1 - 1e-9), rho * (1 + 1e-9), 2 * rho]
    )
    expected = polygon_mass(radii, n_sides, rho) / total
    assert mass_within(pts, radii, center=[0, 0]) == pytest.approx(expected, abs=1e-9)
    assert mass_within(pts, radii) == pytest.approx(expected, abs=1e-9)  # centre of mass = 0
    # every side is cut twice for h < R < rho: Eq. 3 sees nothing until R reaches the nodes
    eq3 = mass_within(pts, radii, center=[0, 0], method="eq3")
    assert eq3.tolist() == [0, 0, 0, 0, 0, 0, 1, 1]


def test_concentric_circles():
    """Two concentric polygons joined by a radial spoke, measured about their common centre."""
    n1, r1, n2, r2 = 200, 0.2, 400, 0.5
    inner = polygon(n1, r1)
    outer = polygon(n2, r2)
    wire = np.vstack([inner, outer])  # inner closes at (r1, 0), spoke to (r2, 0), outer
    p1 = polygon_mass(np.inf, n1, r1)
    p2 = polygon_mass(np.inf, n2, r2)
    total = p1 + (r2 - r1) + p2
    radii = np.array([0.1, 0.199, 0.2, 0.3, 0.45, 0.4999, 0.5, 0.6])
    expected = (
        polygon_mass(radii, n1, r1)
        + np.clip(radii - r1, 0.0, r2 - r1)
        + polygon_mass(radii, n2, r2)
    ) / total
    assert mass_within(wire, radii, center=[0.0, 0.0]) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    ("a", "b", "big_r", "inside"),
    [
        ((-1.0, 0.3), (1.0, 0.3), 0.5, 0.8),  # cut twice: chord 2 sqrt(0.25 - 0.09)
        ((1.0, 0.3), (-1.0, 0.3), 0.5, 0.8),  # either direction
        ((-1.0, 0.3), (1.0, 0.3), 0.3, 0.0),  # tangent
        ((-1.0, 0.3), (1.0, 0.3), 0.29, 0.0),  # misses
        ((0.2, 0.3), (1.0, 0.3), 0.5, 0.2),  # one end inside: from x = 0.2 to 0.4
        ((0.5, 0.3), (1.0, 0.3), 0.5, 0.0),  # both ends out, circle cuts the line elsewhere
        ((-0.3, 0.0), (0.3, 0.0), 0.5, 0.6),  # both inside
    ],
)
def test_single_segment(a, b, big_r, inside):
    seg = np.array([a, b])
    length = float(np.hypot(*np.subtract(b, a)))
    assert mass_within(seg, big_r, center=[0, 0]) == pytest.approx(inside / length, abs=1e-14)
    eq3 = mass_within(seg, big_r, center=[0, 0], method="eq3")
    n_in = int(np.hypot(*a) <= big_r) + int(np.hypot(*b) <= big_r)
    assert eq3 == pytest.approx(inside / length if n_in else 0.0, abs=1e-14)


def test_weighting_segments_gives_each_segment_one_share():
    # a short and a long segment: under "segments" each carries half the mass
    wire = np.array([[0.0, 0.0], [1.0, 0.0], [4.0, 0.0]])
    assert mass_within(wire, 1.0, center=[0, 0]) == pytest.approx(0.25)
    assert mass_within(wire, 1.0, center=[0, 0], weighting="segments") == pytest.approx(0.5)
    assert mass_within(wire, 2.5, center=[0, 0], weighting="segments") == pytest.approx(0.75)
    # unstretched (equal segments): the two weightings agree exactly
    w = random_walk(3, 30)
    w = w[:1] + np.vstack(
        [[0, 0], np.cumsum(np.diff(w, axis=0) / np.hypot(*np.diff(w, axis=0).T)[:, None], 0)]
    )
    radii = np.linspace(0, 10, 17)
    assert mass_within(w, radii, weighting="segments") == pytest.approx(mass_within(w, radii))


def test_blocks_over_radii_agree(monkeypatch):
    wire = random_walk(0, 300)
    radii = np.linspace(0.0, 0.5, 40)
    full = mass_within(wire, radii)
    monkeypatch.setattr(obs.mass, "_BLOCK", 1000)  # 3 radii at a time
    assert np.array_equal(mass_within(wire, radii), full)


def test_mass_within_shapes():
    wire = straight(4)
    assert isinstance(mass_within(wire, 0.1), float)
    assert mass_within(wire, [0.1]).shape == (1,)
    assert mass_within(wire, [0.4, 0.1]).tolist() == pytest.approx([0.8, 0.2])  # any order


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((np.zeros((3, 3)), 0.1), {}, "shape"),
        ((np.zeros((1, 2)), 0.1), {}, "at least 2 nodes"),
        ((np.zeros((3, 2)), 0.1), {}, "zero length"),
        (([[0, 0], [np.nan, 1]], 0.1), {}, "NaN"),
        ((straight(3), -0.1), {}, "radii"),
        ((straight(3), [[0.1]]), {}, "radii"),
        ((straight(3), "a"), {}, "radii"),
        ((straight(3), 0.1), {"method": "paper"}, "method"),
        ((straight(3), 0.1), {"weighting": "mass"}, "weighting"),
        ((straight(3), 0.1), {"center": [0, 0, 0]}, "center"),
        ((straight(3), 0.1), {"center": [0, np.inf]}, "center"),
    ],
)
def test_mass_within_rejects_bad_input(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        mass_within(*args, **kwargs)


# --------------------------------------------------------------------------------------------
# Properties of M(R) and invariants (hypothesis)
# --------------------------------------------------------------------------------------------

seeds = st.integers(0, 2**32 - 1)
sizes = st.integers(3, 60)


@settings(max_examples=60, deadline=None)
@given(seed=seeds, n=sizes, method=st.sampled_from(["exact", "eq3"]))
def test_mass_function_properties(seed, n, method):
    wire = random_walk(seed, n)
    rm = r_max(wire)
    radii = np.sort(np.random.default_rng(seed).uniform(0.0, 1.2 * rm, 50))
    radii = np.concatenate([[0.0], radii, [rm, 1.5 * rm]])
    m = mass_within(wire, radii, method=method)
    assert m[0] == 0.0
    assert m[-1] == 1.0 and m[-2] == 1.0
    assert np.all((m >= 0.0) & (m <= 1.0))
    assert np.all(np.diff(m) >= 0.0)
    if method == "eq3":  # Eq. 3 never counts more than the exact length
        assert np.all(m <= mass_within(wire, radii) + 1e-15)


@settings(max_examples=40, deadline=None)
@given(
    seed=seeds,
    n=sizes,
    angle=st.floats(0.0, 2 * np.pi),
    shift=st.tuples(st.floats(-10, 10), st.floats(-10, 10)),
)
def test_rigid_motions_leave_observables_unchanged(seed, n, angle, shift):
    wire = random_walk(seed, n)
    moved = rigid_motion(wire, angle, shift)
    c0 = center_of_mass(wire)
    rot = np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
    assert center_of_mass(moved) == pytest.approx(c0 @ rot + np.asarray(shift), abs=1e-12)
    assert center_of_mass(moved, weighting="nodes") == pytest.approx(
        center_of_mass(wire, weighting="nodes") @ rot + np.asarray(shift), abs=1e-12
    )
    assert r_max(moved) == pytest.approx(r_max(wire), abs=1e-12)
    assert radius_of_gyration(moved) == pytest.approx(radius_of_gyration(wire), abs=1e-12)
    radii = np.array([0.1, 0.3, 0.5, 0.77, 0.95, 1.2]) * r_max(wire)
    # M(R) is continuous but not Lipschitz (a circle tangent to a segment): round-off of
    # 1e-15 in positions can move it by ~sqrt(1e-15)
    for method in ("exact", "eq3"):
        assert mass_within(moved, radii, method=method) == pytest.approx(
            mass_within(wire, radii, method=method), abs=1e-6
        )
    assert count_contacts(moved, 0.05) == count_contacts(wire, 0.05)
    assert find_crossings(moved).tolist() == find_crossings(wire).tolist()
    for rg in ("r_max", "rms"):
        try:
            expected = mass_size_exponent(wire, rg=rg).exponent
        except ValueError:  # M = 0 at the low end of the fit range: must fail the same way
            with pytest.raises(ValueError, match="M\\(R\\) = 0"):
                mass_size_exponent(moved, rg=rg)
            continue
        assert mass_size_exponent(moved, rg=rg).exponent == pytest.approx(expected, abs=1e-5)


# --------------------------------------------------------------------------------------------
# D_M
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("rg", ["r_max", "rms"])
def test_mass_size_exponent_of_a_straight_wire_is_one(rg):
    fit = mass_size_exponent(straight(101), rg=rg)
    assert isinstance(fit, PowerLawFit)
    assert fit.exponent == pytest.approx(1.0, abs=1e-12)
    assert fit.ci[0] <= 1.0 <= fit.ci[1]
    assert fit.fit_range == (0.5, 1.0)
    assert fit.n_points == obs.DEFAULT_N_RADII


@pytest.mark.parametrize("rg", ["r_max", "rms"])
def test_mass_size_exponent_of_a_disc_filling_spiral_is_two(rg):
    """A tight Archimedean spiral (40 turns, ~3e4 segments) fills a disc uniformly: D_M = 2
    within the reported uncertainty (measured: 2.001 +- 0.007 with r_max, 2.003 +- 0.010
    with the RMS radius)."""
    spiral = archimedean_spiral(40)
    assert spiral.shape[0] > 30_000
    fit = mass_size_exponent(spiral, rg=rg)
    assert fit.ci[0] <= 2.0 <= fit.ci[1]
    assert abs(fit.exponent - 2.0) < 0.02
    assert fit.stderr < 0.02


def test_mass_size_exponent_options():
    spiral = archimedean_spiral(10)
    fit = mass_size_exponent(spiral, fit_range=(0.2, 0.8), n_radii=7, confidence=0.9)
    assert fit.fit_range == pytest.approx((0.2, 0.8))
    assert fit.n_points == 7 and fit.confidence == 0.9
    # the rescaling by R_G does not change the exponent: same radii, different R_G
    rm, rms = r_max(spiral), radius_of_gyration(spiral)
    a = mass_size_exponent(spiral, rg="r_max", fit_range=(0.3, 0.6))
    b = mass_size_exponent(spiral, rg="rms", fit_range=(0.3 * rm / rms, 0.6 * rm / rms))
    assert a.exponent == pytest.approx(b.exponent, abs=1e-10)
    with pytest.raises(ValueError, match="rg"):
        mass_size_exponent(spiral, rg="gyration")
    with pytest.raises(ValueError, match="fit_range"):
        mass_size_exponent(spiral, fit_range=(1.0, 0.5))
    with pytest.raises(ValueError, match="fit_range"):
        mass_size_exponent(spiral, fit_range=0.5)
    with pytest.raises(ValueError, match="n_radii"):
        mass_size_exponent(spiral, n_radii=2)
    with pytest.raises(ValueError, match="M\\(R\\) = 0"):
        mass_size_exponent(polygon(50, 1.0), center=[0, 0], fit_range=(0.1, 1.0))


def test_ensemble_mass_size_exponent():
    replicas = [archimedean_spiral(t) for t in (20, 25, 30, 35)]
    est = ensemble_mass_size_exponent(replicas)
    assert isinstance(est, MeanEstimate)
    assert est.n_samples == 4 and est.method == "t"
    assert est.ci[0] <= 2.0 <= est.ci[1]
    singles = [mass_size_exponent(r).exponent for r in replicas]
    assert est.samples == pytest.approx(singles)
    boot = ensemble_mass_size_exponent(replicas, ci="bootstrap", rng=3)
    assert boot.value == est.value and boot.method == "bootstrap"
    with pytest.raises(ValueError, match="2 replicas"):
        ensemble_mass_size_exponent(replicas[:1])
    with pytest.raises(ValueError, match="sequence of wires"):
        ensemble_mass_size_exponent(replicas[0])


# --------------------------------------------------------------------------------------------
# Energy allocation
# --------------------------------------------------------------------------------------------


def test_energy_ratio():
    assert energy_ratio(2.0, 8.0) == 0.25
    assert isinstance(energy_ratio(2.0, 8.0), float)
    es = np.array([[1.0, 2.0, 0.0], [3.0, 4.0, 0.0]])  # (n_replicas, n_stages)
    eb = np.array([[2.0, 8.0, 0.0], [3.0, 1.0, 0.0]])
    g = energy_ratio(es, eb)
    assert g.shape == (2, 3)
    assert g[:, :2].tolist() == [[0.5, 0.25], [1.0, 4.0]]
    assert np.all(np.isnan(g[:, 2]))
    assert energy_ratio([1.0, 2.0], 2.0).tolist() == [0.5, 1.0]  # broadcasting
    assert np.isnan(energy_ratio(1.0, 0.0))
    assert np.isnan(energy_ratio(np.nan, 1.0))  # NaN propagates
    with pytest.raises(ValueError, match="E_b = 0"):
        energy_ratio(es, eb, on_zero="raise")
    with pytest.raises(ValueError, match="non-negative"):
        energy_ratio(-1.0, 1.0)
    with pytest.raises(ValueError, match="on_zero"):
        energy_ratio(1.0, 1.0, on_zero="inf")
    with pytest.raises(ValueError, match="matching shape"):
        energy_ratio([1.0, 2.0], [1.0, 2.0, 3.0])


# --------------------------------------------------------------------------------------------
# measure: the JSON record of the command line
# --------------------------------------------------------------------------------------------

KEYS = {
    "center",
    "r_max",
    "radius_of_gyration",
    "contacts",
    "crossings",
    "mass_size_exponent",
    "mass_within",
    "loops",
}


def test_measure_matches_the_library():
    wire = random_walk(12, 80)
    out = measure(wire, contact_distance=0.02)
    assert set(out) == KEYS
    assert json.loads(json.dumps(out)) == out
    c = center_of_mass(wire)
    assert out["center"] == c.tolist()
    assert out["r_max"] == r_max(wire)
    assert out["radius_of_gyration"] == radius_of_gyration(wire)
    assert out["contacts"] == count_contacts(wire, 0.02)
    assert out["crossings"] == len(find_crossings(wire))
    fit = mass_size_exponent(wire)
    assert out["mass_size_exponent"] == {
        "value": fit.exponent,
        "stderr": fit.stderr,
        "fit_range": [0.5, 1.0],
        "n_points": fit.n_points,
        "rg": "r_max",
    }
    table = np.array(out["mass_within"])
    assert table.shape == (obs.DEFAULT_N_TABLE, 2)
    assert table[:, 0] == pytest.approx(np.geomspace(0.01, 1.0, obs.DEFAULT_N_TABLE) * r_max(wire))
    assert table[:, 1].tolist() == mass_within(wire, table[:, 0]).tolist()
    assert table[-1, 1] == 1.0
    # loops at twice the contact distance (None for a wire that crosses itself)
    want = None if out["crossings"] else obs.loops(wire, contact_distance=0.04).to_dict()
    assert out["loops"] == want


def test_measure_options():
    wire = random_walk(5, 50)
    c = (center_of_mass(wire) + 0.01).tolist()
    out = measure(wire, center=c, radii=[0.05, 0.2], rg="rms", fit_range=(0.4, 0.9))
    assert out["center"] == c
    assert out["r_max"] == r_max(wire, c)
    assert out["radius_of_gyration"] == radius_of_gyration(wire, c)
    assert [r for r, _ in out["mass_within"]] == [0.05, 0.2]
    assert out["mass_within"][1][1] == mass_within(wire, 0.2, center=c)
    fit = mass_size_exponent(wire, rg="rms", fit_range=(0.4, 0.9), center=c)
    assert out["mass_size_exponent"]["value"] == fit.exponent
    assert out["mass_size_exponent"]["fit_range"] == [0.4, 0.9]


@pytest.mark.parametrize(
    ("positions", "kwargs", "match"),
    [
        (np.zeros((4, 3)), {}, "shape \\(n_nodes, 2\\)"),
        ([[0.0, 0.0]], {}, "at least 2 nodes"),
        ([[0.0, 0.0], [0.0, 0.0]], {}, "zero length"),
        ([[0.0, 0.0], [np.inf, 0.0]], {}, "NaN or infinite"),
        ([["a", "b"], ["c", "d"]], {}, "numbers"),
        (straight(4), {"center": [0.0]}, "center"),
        (straight(4), {"radii": []}, "radii"),
        (straight(4), {"radii": [0.1, -1.0]}, "radii"),
        (straight(4), {"radii": [[0.1]]}, "radii"),
        (straight(4), {"rg": "Rg"}, "rg"),
        (straight(4), {"fit_range": (0.0, 1.0)}, "fit_range"),
        (straight(4), {"fit_range": (1.0,)}, "fit_range"),
        (straight(4), {"contact_distance": 0.0}, "contact_distance"),
        (straight(4), {"contact_distance": "near"}, "contact_distance"),
    ],
)
def test_measure_rejects_bad_input(positions, kwargs, match):
    with pytest.raises(ValueError, match=match):
        measure(positions, **kwargs)
