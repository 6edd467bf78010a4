"""Tests of crumple.energy in three layers (conventions, item 8):

1. closed forms: a regular polygon's bending energy, a uniformly stretched chain, a straight
   wire and a ring in the trap for both normalisations, the plastic law of Sec. III.C, the
   hard core of a hairpin;
2. finite-difference checks of every gradient (and of the Hessians used by Newton) on random
   seeded configurations, including the plastic branch and the hard core in contact;
3. invariants as hypothesis properties: rigid motions, scale invariance of bending, zero net
   force and torque of the internal terms.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from crumple.energy import (
    WireEnergy,
    bending_energy,
    confinement_energy,
    confinement_weights,
    energy_terms,
    hard_core_energy,
    hessian,
    stretching_energy,
    total_energy,
)
from crumple.geometry import has_crossings, node_segment_pairs, turning_angles
from crumple.model import Plasticity, Wire

# --------------------------------------------------------------------------------------------
# Configurations and finite differences
# --------------------------------------------------------------------------------------------


def barrier(u: float) -> float:
    """The documented hard-core profile b(u) = (1 - u)^2 / u for u < 1, else 0."""
    return (1 - u) ** 2 / u if u < 1 else 0.0


def paper_bending(theta, k_b, s, theta_p):
    """Sec. III.C exactly as printed for theta > theta_p, elastic below; even in theta."""
    a = abs(theta)
    if a <= theta_p:
        return 0.5 * k_b * theta**2
    return (
        k_b * theta_p**2 / 2
        + s * k_b * (a**2 - theta_p**2) / 2
        + k_b * theta_p * (1 - s) * (a - theta_p)
    )


def regular_arc(n_sides: int, n_nodes: int, radius: float = 1.0, center=(0.0, 0.0), phase=0.0):
    """``n_nodes`` consecutive vertices of a regular ``n_sides``-gon, counter-clockwise."""
    phi = phase + 2 * np.pi * np.arange(n_nodes) / n_sides
    return np.c_[radius * np.cos(phi), radius * np.sin(phi)] + np.asarray(center)


def random_chain(seed: int, n_segments: int, seg=1.0, max_turn=2.5, stretch=0.2):
    """A random chain: segment lengths seg * [1 - stretch, 1 + stretch], turning angles
    uniform in (-max_turn, max_turn) (kept away from ±π, where θ jumps)."""
    rng = np.random.default_rng(seed)
    lengths = seg * rng.uniform(1 - stretch, 1 + stretch, n_segments)
    heading = rng.uniform(0, 2 * np.pi) + np.concatenate(
        [[0.0], np.cumsum(rng.uniform(-max_turn, max_turn, n_segments - 1))]
    )
    steps = np.c_[lengths * np.cos(heading), lengths * np.sin(heading)]
    return np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)]) + rng.uniform(-1, 1, 2) * seg


def free_chain(seed: int, n_segments: int, seg=1.0, **kwargs):
    """A random chain (as :func:`random_chain`) that neither crosses itself nor comes within
    0.1 seg of itself: no hard-core pair for any d below that."""
    for attempt in range(1000):
        pos = random_chain(seed + 7919 * attempt, n_segments, seg, **kwargs)
        if not has_crossings(pos) and node_segment_pairs(pos, 0.1 * seg)[0].size == 0:
            return pos
    raise RuntimeError("no free chain found")


def staggered_hairpin(m: int, seg: float, gap: float) -> np.ndarray:
    """Two parallel strands at distance ``gap`` joined by a short fold, the upper strand's
    nodes half a segment off the lower one's: every node facing the other strand projects on
    the *middle* (t = 1/2) of a segment. Strand A: (i seg, 0), i = 0..m; strand B:
    ((m - 1/2 - j) seg, gap), j = 0..m-1. 2m segments; 2m - 1 node-segment pairs at distance
    ``gap`` when gap < d < seg / 2."""
    a = np.c_[np.arange(m + 1) * seg, np.zeros(m + 1)]
    b = np.c_[(m - 0.5 - np.arange(m)) * seg, np.full(m, gap)]
    return np.vstack([a, b])


def end_contact(m: int, seg: float, gap: float) -> np.ndarray:
    """A wire whose last node sits at distance ``gap`` from its first node, off the end of
    the first segment (unclamped projection t = -0.6 gap / seg < 0), coming down a vertical
    last segment: both contact pairs have their closest point strictly at a segment end."""
    a = np.c_[np.arange(m + 1) * seg, np.zeros(m + 1)]
    top = np.c_[(m - np.arange(m + 1)) * seg, np.full(m + 1, 2 * seg)]
    tail = np.array([[-0.6 * gap, 0.8 * gap + seg], [-0.6 * gap, 0.8 * gap]])
    return np.vstack([a, top, tail])


def contact_geometry(pos, width):
    """(u, t_unclamped) of every hard-core pair: u = D/d, t the projection parameter."""
    ks, js = node_segment_pairs(pos, width)
    out = []
    for k, j in zip(ks.tolist(), js.tolist(), strict=True):
        a, b, p = pos[j], pos[j + 1], pos[k]
        e = b - a
        t = float((p - a) @ e / (e @ e))
        c = a + min(1.0, max(0.0, t)) * e
        out.append((float(np.hypot(*(p - c))) / width, t))
    return out


def assert_smooth_contacts(pos, width, margin=0.05):
    """Every pair strictly inside the core, away from its kinks: u in (0.2, 0.9), closest
    point strictly interior or strictly at an end (not near t = 0 or 1)."""
    geo = contact_geometry(pos, width)
    assert geo, "the configuration must have contacts"
    for u, t in geo:
        assert 0.2 < u < 0.9, u
        assert min(abs(t), abs(t - 1)) > margin, t
    return geo


def fd_gradient(fun, x, h):
    """Central differences of a scalar function of an (n, 2) array."""
    g = np.zeros_like(x)
    for idx in np.ndindex(x.shape):
        xp, xm = x.copy(), x.copy()
        xp[idx] += h
        xm[idx] -= h
        g[idx] = (fun(xp) - fun(xm)) / (2 * h)
    return g


def fd_hessian(grad, x, h):
    """Central differences of the gradient, over the flattened coordinates 2 * node + axis."""
    n = x.size
    hm = np.zeros((n, n))
    for i in range(n):
        xp, xm = x.copy().ravel(), x.copy().ravel()
        xp[i] += h
        xm[i] -= h
        hm[:, i] = (grad(xp.reshape(x.shape)) - grad(xm.reshape(x.shape))).ravel() / (2 * h)
    return hm


def assert_gradient(fun_eg, x, h, rtol=1e-6):
    e, g = fun_eg(x)
    assert math.isfinite(e)
    fd = fd_gradient(lambda y: fun_eg(y)[0], x, h)
    scale = float(np.max(np.abs(g)))
    assert scale > 0
    np.testing.assert_allclose(g, fd, rtol=rtol, atol=rtol * scale)


# --------------------------------------------------------------------------------------------
# Closed forms: bending
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("n_sides", "n_nodes"), [(3, 4), (6, 7), (12, 9), (100, 101), (40, 120)])
@pytest.mark.parametrize("radius", [0.01, 1.0, 37.0])
def test_regular_polygon_bending_energy(n_sides, n_nodes, radius):
    """Every turning angle of a regular n-gon is 2π/n: E = (n_nodes - 2) k_b/2 (2π/n)^2,
    whichever way round (counter-clockwise θ = +2π/n, clockwise -2π/n) and whatever its size."""
    k_b = 3.7
    pos = regular_arc(n_sides, n_nodes, radius, center=(0.3, -2.0), phase=0.4)
    want = (n_nodes - 2) * k_b / 2 * (2 * np.pi / n_sides) ** 2
    e, _ = bending_energy(pos, k_b)
    assert e == pytest.approx(want, rel=1e-12)
    e_cw, _ = bending_energy(pos[::-1], k_b)
    assert e_cw == pytest.approx(want, rel=1e-12)
    np.testing.assert_allclose(turning_angles(pos), 2 * np.pi / n_sides, rtol=1e-10)
    np.testing.assert_allclose(turning_angles(pos[::-1]), -2 * np.pi / n_sides, rtol=1e-10)


def test_bending_gradient_sign_on_a_single_joint():
    """Sign convention: for a CCW turn θ > 0 the energy decreases when the last node moves
    clockwise about the joint (towards straight), i.e. dE/dθ = k_b θ > 0."""
    k_b, theta = 2.0, 0.7
    pos = np.array([[-1.0, 0.0], [0.0, 0.0], [np.cos(theta), np.sin(theta)]])
    _, g = bending_energy(pos, k_b)
    tangent = np.array([-np.sin(theta), np.cos(theta)])  # d x_2 / dθ
    assert g[2] @ tangent == pytest.approx(k_b * theta, rel=1e-12)
    assert g[2] @ pos[2] == pytest.approx(0.0, abs=1e-14)  # no radial component


def test_straight_wire_has_no_bending():
    pos = np.c_[np.linspace(0, 1, 11), np.zeros(11)]
    e, g = bending_energy(pos, 5.0)
    assert e == 0.0
    assert np.all(g == 0.0)


# --------------------------------------------------------------------------------------------
# Closed forms: the plastic law (Sec. III.C)
# --------------------------------------------------------------------------------------------


def joint(theta: float) -> np.ndarray:
    """Three nodes turning by θ at the middle one (unit segments)."""
    return np.array([[-1.0, 0.0], [0.0, 0.0], [np.cos(theta), np.sin(theta)]])


def joint_energy_and_slope(theta, k_b, plasticity):
    """f(θ) and f'(θ), the latter from the analytic gradient (x_2 moves on the unit circle)."""
    e, g = bending_energy(joint(theta), k_b, plasticity)
    return e, float(g[2] @ np.array([-np.sin(theta), np.cos(theta)]))


@pytest.mark.parametrize(("s", "theta_p"), [(0.05, 0.1), (0.4, 0.5), (0.8, 1.0), (0.0, 0.3)])
def test_plastic_branch_is_the_papers_formula(s, theta_p):
    k_b = 5.0
    plast = Plasticity(s=s, theta_p=theta_p)
    for theta in np.linspace(-3.0, 3.0, 61):
        e, slope = joint_energy_and_slope(theta, k_b, plast)
        assert e == pytest.approx(paper_bending(theta, k_b, s, theta_p), rel=1e-12, abs=1e-15)
        a = abs(theta)
        want = (
            k_b * theta
            if a <= theta_p
            else np.sign(theta) * (s * k_b * a + k_b * theta_p * (1 - s))
        )
        assert slope == pytest.approx(want, rel=1e-9, abs=1e-12)


def test_plastic_polygon_closed_form():
    """A regular 8-gon turns by π/4 > θ_p at every joint."""
    k_b, s, theta_p = 5.0, 0.2, 0.3
    pos = regular_arc(8, 9, radius=0.2)
    want = 7 * (
        k_b * theta_p**2 / 2
        + s * k_b * ((np.pi / 4) ** 2 - theta_p**2) / 2
        + k_b * theta_p * (1 - s) * (np.pi / 4 - theta_p)
    )
    e, _ = bending_energy(pos, k_b, Plasticity(s=s, theta_p=theta_p))
    assert e == pytest.approx(want, rel=1e-12)
    e_cw, _ = bending_energy(pos[::-1], k_b, Plasticity(s=s, theta_p=theta_p))
    assert e_cw == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize(("s", "theta_p"), [(0.05, 0.2), (0.4, 0.5), (0.8, 1.2)])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_plastic_law_is_c1_with_a_jump_in_curvature_at_theta_p(s, theta_p, sign):
    """Value and slope are continuous at θ_p; the second derivative jumps from k_b (inside)
    to s k_b (beyond)."""
    k_b = 4.0
    plast = Plasticity(s=s, theta_p=theta_p)
    delta = 1e-7
    e_in, f_in = joint_energy_and_slope(sign * (theta_p - delta), k_b, plast)
    e_out, f_out = joint_energy_and_slope(sign * (theta_p + delta), k_b, plast)
    assert e_in == pytest.approx(paper_bending(theta_p - delta, k_b, s, theta_p), rel=1e-9)
    assert e_out == pytest.approx(paper_bending(theta_p + delta, k_b, s, theta_p), rel=1e-9)
    # no jump: across 2δ the energy changes by the slope k_b θ_p times 2δ, to O(δ²)
    assert e_out - e_in == pytest.approx(2 * delta * k_b * theta_p, rel=1e-5)
    assert f_in == pytest.approx(sign * k_b * theta_p, rel=1e-5)
    assert f_out == pytest.approx(sign * k_b * theta_p, rel=1e-5)
    h = 1e-3 * theta_p
    inside = (
        joint_energy_and_slope(sign * (theta_p - h), k_b, plast)[1]
        - joint_energy_and_slope(sign * (theta_p - 2 * h), k_b, plast)[1]
    ) / h
    beyond = (
        joint_energy_and_slope(sign * (theta_p + 2 * h), k_b, plast)[1]
        - joint_energy_and_slope(sign * (theta_p + h), k_b, plast)[1]
    ) / h
    assert sign * inside == pytest.approx(k_b, rel=1e-6)
    assert sign * beyond == pytest.approx(s * k_b, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_plasticity_with_s_one_is_elastic(seed):
    pos = random_chain(seed, 30)
    e0, g0 = bending_energy(pos, 2.5)
    e1, g1 = bending_energy(pos, 2.5, Plasticity(s=1.0, theta_p=0.1))
    assert e1 == pytest.approx(e0, rel=1e-13)
    np.testing.assert_allclose(g1, g0, rtol=1e-12, atol=1e-12 * np.max(np.abs(g0)))


def test_plasticity_softens_only_beyond_theta_p():
    pos = random_chain(11, 40, max_turn=1.5)
    theta = turning_angles(pos)
    plast = Plasticity(s=0.3, theta_p=0.6)
    e_el, _ = bending_energy(pos, 2.0)
    e_pl, _ = bending_energy(pos, 2.0, plast)
    assert np.any(np.abs(theta) > 0.6) and np.any(np.abs(theta) < 0.6)
    assert e_pl < e_el
    assert e_pl == pytest.approx(sum(paper_bending(t, 2.0, 0.3, 0.6) for t in theta), rel=1e-12)


# --------------------------------------------------------------------------------------------
# Closed forms: stretching
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("strain", [-0.3, -1e-4, 1e-6, 0.05, 1.0])
@pytest.mark.parametrize("n", [3, 10, 101])
def test_uniformly_stretched_chain(strain, n):
    """N segments of length l0 (1 + ε): E = N k_s/2 (l0 ε)^2; the tension k_s l0 ε pulls on the
    two ends only (interior forces cancel), along the chain."""
    k_s, l0 = 5e5, 1.0 / n
    direction = np.array([np.cos(0.3), np.sin(0.3)])
    pos = np.outer(np.arange(n + 1) * l0 * (1 + strain), direction) + np.array([0.2, -0.1])
    e, g = stretching_energy(pos, k_s, l0)
    assert e == pytest.approx(n * k_s / 2 * (l0 * strain) ** 2, rel=1e-6)
    tension = k_s * l0 * strain
    # round-off: segment lengths ~ l0 carry errors ~ ε_mach, i.e. relative ~ 1e-16 / strain
    np.testing.assert_allclose(g[0], -tension * direction, rtol=1e-6, atol=1e-6 * abs(tension))
    np.testing.assert_allclose(g[-1], tension * direction, rtol=1e-6, atol=1e-6 * abs(tension))
    np.testing.assert_allclose(g[1:-1], 0.0, atol=1e-6 * abs(tension))


def test_stretching_is_zero_at_rest_length_whatever_the_shape():
    pos = regular_arc(7, 20, radius=1.0)
    l0 = 2 * np.sin(np.pi / 7)
    e, g = stretching_energy(pos, 1e7, l0)
    assert e == pytest.approx(0.0, abs=1e-18)
    assert np.max(np.abs(g)) < 1e-7


# --------------------------------------------------------------------------------------------
# Closed forms: confinement, both normalisations
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [3, 4, 10, 100])
@pytest.mark.parametrize("length", [1.0, 2.5])
def test_confinement_weights(n, length):
    w = confinement_weights(n + 1, "per-length", length)
    np.testing.assert_allclose(w[1:-1], length / n, rtol=1e-15)
    assert w[0] == pytest.approx(length / (2 * n), rel=1e-15)
    assert w[-1] == pytest.approx(length / (2 * n), rel=1e-15)
    assert w.sum() == pytest.approx(length, rel=1e-14)
    assert np.all(confinement_weights(n + 1, "per-node", length) == 1.0)
    with pytest.raises(ValueError, match="confinement"):
        confinement_weights(n + 1, "per-segment")


@pytest.mark.parametrize("n", [4, 10, 100, 1000])
def test_straight_centred_wire_in_the_trap(n):
    """Nodes at x_i = L (i/N - 1/2): per node Σ x_i^2 = L^2 (N+1)(N+2)/(12 N); per length
    (trapezoid) Σ w_i x_i^2 = L^3 (N^2 + 2)/(12 N^2) → L^3/12, the continuum ∫ x^2 ds."""
    lam, length = 7.0, 2.0
    x = np.linspace(-length / 2, length / 2, n + 1)
    pos = np.c_[x, np.zeros_like(x)] + [0.3, -0.4]
    per_node, _ = confinement_energy(pos, lam, confinement_weights(n + 1, "per-node"), (0.3, -0.4))
    per_len, _ = confinement_energy(
        pos, lam, confinement_weights(n + 1, "per-length", length), (0.3, -0.4)
    )
    assert per_node == pytest.approx(lam * length**2 * (n + 1) * (n + 2) / (12 * n), rel=1e-12)
    assert per_len == pytest.approx(lam * length**3 * (n**2 + 2) / (12 * n**2), rel=1e-12)


@pytest.mark.parametrize("kind", ["per-node", "per-length"])
@pytest.mark.parametrize("center", [(0.0, 0.0), (0.7, -1.3)])
def test_ring_in_the_trap_through_the_wire(kind, center):
    """All nodes on a circle of radius R about the trap centre: per node λ (N + 1) R^2, per
    length λ L0 R^2; the force on node i is -2 λ w_i (r_i - c)."""
    n, radius, lam = 24, 0.15, 300.0
    wire = Wire(k_b=5, k_s=5e5, n_segments=n, confinement=kind, trap_center=center)
    phi = (
        np.linspace(0, 2 * np.pi, n + 1) ** 1.1
    )  # uneven spacing: the nodes' radius is what counts
    pos = radius * np.c_[np.cos(phi), np.sin(phi)] + center
    terms = energy_terms(wire, pos, lam)
    want = lam * radius**2 * ((n + 1) if kind == "per-node" else 1.0)
    assert terms.confinement == pytest.approx(want, rel=1e-12)
    weights = confinement_weights(n + 1, kind)
    _, g = confinement_energy(pos, lam, weights, center)
    np.testing.assert_allclose(g, 2 * lam * weights[:, None] * (pos - center), rtol=1e-14)


def test_per_node_and_per_length_differ_by_n_inside():
    n = 50
    pos = random_chain(3, n, seg=1 / n)
    e_node, _ = confinement_energy(pos, 1.0, confinement_weights(n + 1, "per-node"))
    e_len, _ = confinement_energy(pos, 1.0, confinement_weights(n + 1, "per-length"))
    end_terms = 0.5 * (pos[0] @ pos[0] + pos[-1] @ pos[-1])
    assert e_len == pytest.approx((e_node - end_terms) / n, rel=1e-12)


def test_confinement_validation():
    with pytest.raises(ValueError, match="weights"):
        confinement_energy(np.zeros((5, 2)), 1.0, np.ones(4))
    with pytest.raises(ValueError, match="lambda"):
        WireEnergy(Wire(k_b=1, k_s=1e4, n_segments=4), lam=-1.0)
    with pytest.raises(ValueError, match="lambda"):
        WireEnergy(Wire(k_b=1, k_s=1e4, n_segments=4), lam=math.nan)


# --------------------------------------------------------------------------------------------
# Closed forms: hard core
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("u", [0.05, 0.3, 0.5, 0.9, 0.999])
def test_hard_core_hairpin_closed_form(u):
    """Docstring hairpin: four node-segment pairs at distance D = u d, E = 4 ε b(u)."""
    d, eps = 1e-5, 2.0
    pos = np.array([[0, 0], [1, 0], [1, u * d], [0, u * d]])
    e, _ = hard_core_energy(pos, d, eps)
    assert e == pytest.approx(4 * eps * barrier(u), rel=1e-9)


@pytest.mark.parametrize("u", [0.2, 0.5, 0.8])
@pytest.mark.parametrize("m", [2, 5, 12])
def test_hard_core_staggered_hairpin_closed_form_and_force(u, m):
    """2m - 1 pairs at D = u d: E = (2m - 1) ε b(u); lifting strand B by δ changes E at the
    rate (2m - 1) ε b'(u) / d, b'(u) = 1 - 1/u^2, so strand B is pushed up (repulsion)."""
    seg, d, eps = 0.01, 3e-3, 1e-3
    pos = staggered_hairpin(m, seg, u * d)
    e, g = hard_core_energy(pos, d, eps)
    assert e == pytest.approx((2 * m - 1) * eps * barrier(u), rel=1e-10)
    lift = g[m + 1 :, 1].sum()  # dE/dδ for strand B moved up rigidly
    assert lift == pytest.approx((2 * m - 1) * eps * (1 - 1 / u**2) / d, rel=1e-9)
    assert lift < 0
    np.testing.assert_allclose(g.sum(axis=0), 0.0, atol=1e-9 * np.max(np.abs(g)))


def test_hard_core_zero_beyond_the_core_and_c1_at_its_edge():
    d, eps = 1e-5, 1e-3
    for gap in (d, 1.0001 * d, 3 * d, 0.1):
        e, g = hard_core_energy(np.array([[0, 0], [1, 0], [1, gap], [0, gap]]), d, eps)
        assert e == 0.0
        assert np.all(g == 0.0)
    # approaching d from inside, energy and force go to 0 continuously (b(1) = b'(1) = 0)
    forces = [
        np.max(
            np.abs(hard_core_energy(np.array([[0, 0], [1, 0], [1, v * d], [0, v * d]]), d, eps)[1])
        )
        for v in (0.99, 0.999, 0.9999)
    ]
    assert forces[0] > forces[1] > forces[2]
    # b'(u) = 1 - 1/u^2 ≈ -2 (1 - u): the force vanishes linearly at the edge
    assert forces[2] == pytest.approx(1e-2 * forces[0], rel=0.05)


def test_hard_core_monotone_and_infinite_at_contact():
    d = 1e-3
    gaps = np.linspace(0.01, 0.99, 50) * d
    energies = [hard_core_energy(np.array([[0, 0], [1, 0], [1, h], [0, h]]), d)[0] for h in gaps]
    assert np.all(np.diff(energies) < 0)
    touching = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 0]])  # node 4 on segment 0
    assert hard_core_energy(touching, d)[0] == math.inf
    wire = Wire(k_b=1, k_s=1e4, n_segments=4, hard_core=0.1)
    assert WireEnergy(wire, 1.0)(touching)[0] == math.inf


def test_hard_core_ignores_adjacent_segments_but_sees_a_sharp_fold():
    d = 1e-5
    # adjacent segments share a node (distance 0) and must not repel: a zigzag of segments
    # 1.5 d long with right-angle turns has no non-adjacent pair within d
    zigzag = np.cumsum(np.r_[[[0.0, 0.0]], 1.5 * d * np.tile([[1, 0], [0, 1]], (5, 1))], axis=0)
    e, g = hard_core_energy(zigzag, d)
    assert e == 0.0 and np.all(g == 0)
    # a fold of nearly π: node 2 comes within 0.01 d of segment 0 (it also belongs to segment
    # 2, which is not adjacent to 0), and node 0 within 0.01 d of segment 2
    fold = np.array([[0, 0], [1, 0], [0, 1e-7], [-1, 1e-7]])
    ks, js = node_segment_pairs(fold, d)
    assert set(zip(ks.tolist(), js.tolist(), strict=True)) == {(0, 2), (2, 0)}
    e, _ = hard_core_energy(fold, d)
    assert e == pytest.approx(2 * barrier(0.01), rel=1e-9)


# --------------------------------------------------------------------------------------------
# Composition: WireEnergy is the explicit sum of the plain functions
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["per-node", "per-length"])
@pytest.mark.parametrize("plastic", [None, Plasticity(s=0.2, theta_p=0.3)])
def test_wire_energy_is_the_sum_of_the_terms(kind, plastic):
    m = 6
    seg = 1.0 / (2 * m)
    wire = Wire(
        k_b=3, k_s=2e4, n_segments=2 * m, confinement=kind, plasticity=plastic,
        hard_core=0.3 * seg, hard_core_energy=0.5, trap_center=(0.1, 0.2),
    )  # fmt: skip
    pos = staggered_hairpin(m, seg, 0.15 * seg) + np.random.default_rng(0).normal(
        0, 1e-4 * seg, (2 * m + 1, 2)
    )
    lam = 40.0
    parts = [
        bending_energy(pos, wire.k_b, plastic),
        stretching_energy(pos, wire.k_s, wire.rest_length),
        confinement_energy(pos, lam, confinement_weights(wire.n_nodes, kind), wire.trap_center),
        hard_core_energy(pos, wire.hard_core, wire.hard_core_energy),
    ]
    e, g = WireEnergy(wire, lam)(pos)
    assert all(p[0] > 0 for p in parts)
    assert e == pytest.approx(sum(p[0] for p in parts), rel=1e-13)
    np.testing.assert_allclose(
        g, sum(p[1] for p in parts), rtol=1e-12, atol=1e-12 * np.max(np.abs(g))
    )
    terms = WireEnergy(wire, lam).terms(pos)
    assert [terms.bending, terms.stretching, terms.confinement, terms.hard_core] == pytest.approx(
        [p[0] for p in parts], rel=1e-13
    )
    assert terms.total == pytest.approx(e, rel=1e-14)
    assert terms.to_dict()["total"] == terms.total
    assert terms.gamma == pytest.approx(terms.stretching / terms.bending)
    assert total_energy(wire, pos, lam)[0] == e


def test_wire_energy_rejects_wrong_node_count():
    wire = Wire(k_b=1, k_s=1e4, n_segments=10)
    with pytest.raises(ValueError, match="nodes"):
        total_energy(wire, np.zeros((5, 2)), 1.0)
    with pytest.raises(ValueError, match="nodes"):
        WireEnergy(wire, 1.0).terms(np.zeros((5, 2)))


# --------------------------------------------------------------------------------------------
# Finite-difference gradients of every term and of the total
# --------------------------------------------------------------------------------------------

SEEDS = range(4)


@pytest.mark.parametrize("seed", SEEDS)
def test_bending_gradient_elastic(seed):
    pos = random_chain(seed, 25, seg=0.04)
    assert_gradient(lambda x: bending_energy(x, 3.3), pos, h=1e-7)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize(("s", "theta_p"), [(0.0, 0.2), (0.3, 0.5), (0.8, 1.5)])
def test_bending_gradient_plastic(seed, s, theta_p):
    pos = random_chain(seed, 25, seg=0.04)
    theta = np.abs(turning_angles(pos))
    assert np.any(theta > theta_p)  # the plastic branch is exercised
    assert_gradient(lambda x: bending_energy(x, 3.3, Plasticity(s=s, theta_p=theta_p)), pos, h=1e-7)


@pytest.mark.parametrize("seed", SEEDS)
def test_stretching_gradient(seed):
    pos = random_chain(seed, 25, seg=0.04, stretch=0.3)
    assert_gradient(lambda x: stretching_energy(x, 5e5, 0.04), pos, h=1e-7)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("kind", ["per-node", "per-length"])
def test_confinement_gradient(seed, kind):
    pos = random_chain(seed, 25, seg=0.04)
    w = confinement_weights(26, kind)
    assert_gradient(lambda x: confinement_energy(x, 123.0, w, (0.2, -0.1)), pos, h=1e-6)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("u", [0.3, 0.6, 0.85])
def test_hard_core_gradient_in_contact(seed, u):
    seg, d = 0.01, 3e-3
    rng = np.random.default_rng(seed)
    pos = staggered_hairpin(6, seg, u * d) + rng.normal(0, 0.01 * u * d, (13, 2))
    assert_smooth_contacts(pos, d)
    assert_gradient(lambda x: hard_core_energy(x, d, 1e-3), pos, h=1e-9)
    base = end_contact(5, seg, u * d)
    pos = base + rng.normal(0, 0.01 * u * d, base.shape)
    assert_smooth_contacts(pos, d)
    assert_gradient(lambda x: hard_core_energy(x, d, 1e-3), pos, h=1e-9)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("kind", ["per-node", "per-length"])
@pytest.mark.parametrize("plastic", [None, Plasticity(s=0.1, theta_p=0.4)])
def test_total_gradient_random_and_in_contact(seed, kind, plastic):
    m = 7
    seg = 1.0 / (2 * m)
    wire = Wire(
        k_b=4, k_s=1e5, n_segments=2 * m, confinement=kind, plasticity=plastic,
        hard_core=0.3 * seg, hard_core_energy=0.01, trap_center=(0.05, 0.02),
    )  # fmt: skip
    energy = WireEnergy(wire, 500.0)
    rng = np.random.default_rng(seed)
    pos = staggered_hairpin(m, seg, 0.15 * seg) + rng.normal(0, 1e-3 * seg, (2 * m + 1, 2))
    assert_smooth_contacts(pos, wire.hard_core)
    assert energy.terms(pos).hard_core > 0
    assert_gradient(energy, pos, h=1e-8)
    free = free_chain(seed, 2 * m, seg=seg, stretch=0.1)
    assert_gradient(energy, free, h=1e-8)


# --------------------------------------------------------------------------------------------
# Hessians: finite differences of the gradient, dense against sparse
# --------------------------------------------------------------------------------------------


def assert_hessian(energy: WireEnergy, pos, h, rtol=1e-6):
    hm = energy.hessian(pos, dense=True)
    assert hm.shape == (pos.size, pos.size)
    np.testing.assert_allclose(hm, hm.T, rtol=0, atol=1e-12 * np.max(np.abs(hm)))
    fd = fd_hessian(lambda x: energy(x)[1], pos, h)
    np.testing.assert_allclose(hm, fd, rtol=rtol, atol=rtol * np.max(np.abs(hm)))
    hs = energy.hessian(pos, dense=False)
    assert sp.issparse(hs)
    np.testing.assert_allclose(hs.toarray(), hm, rtol=1e-12, atol=1e-13 * np.max(np.abs(hm)))
    return hm


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("plastic", [None, Plasticity(s=0.2, theta_p=0.4)])
@pytest.mark.parametrize("kind", ["per-node", "per-length"])
def test_hessian_elastic_terms(seed, plastic, kind):
    n = 12
    wire = Wire(
        k_b=5, k_s=2e3, n_segments=n, plasticity=plastic, confinement=kind, trap_center=(0.1, 0)
    )
    pos = free_chain(seed, n, seg=1 / n, max_turn=2.0, stretch=0.2)
    if plastic is not None:  # stay off the kink of f'' at θ_p
        assert np.all(np.abs(np.abs(turning_angles(pos)) - 0.4) > 1e-3)
    assert not node_segment_pairs(pos, wire.hard_core)[0].size
    assert_hessian(WireEnergy(wire, 250.0), pos, h=1e-6)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("u", [0.3, 0.5, 0.8])
@pytest.mark.parametrize("shape", ["interior", "end"])
def test_hessian_hard_core_dominated(seed, u, shape):
    """Elastic constants negligible: the Hessian is the hard core's, exact formula for
    interior closest points (with the sliding/rotation coupling) and for ends."""
    m = 5
    seg = 0.1
    if shape == "interior":
        base = staggered_hairpin(m, seg, u * 0.3 * seg)
    else:
        base = end_contact(m, seg, u * 0.3 * seg)
    n_seg = len(base) - 1
    wire = Wire(
        k_b=1e-9,
        k_s=1e-9,
        n_segments=n_seg,
        length=n_seg * seg,
        hard_core=0.3 * seg,
        hard_core_energy=1.0,
    )
    rng = np.random.default_rng(seed)
    pos = base + rng.normal(0, 0.02 * u * wire.hard_core, base.shape)
    geo = assert_smooth_contacts(pos, wire.hard_core)
    if shape == "end":
        assert all(t < 0 or t > 1 for _, t in geo)
    else:
        assert all(0 < t < 1 for _, t in geo)
    energy = WireEnergy(wire, 0.0)
    assert energy.terms(pos).hard_core > 1e3 * (
        energy.terms(pos).bending + energy.terms(pos).stretching
    )
    assert_hessian(energy, pos, h=1e-6 * u * wire.hard_core, rtol=1e-6)


@pytest.mark.parametrize("seed", SEEDS)
def test_hessian_total_in_contact(seed):
    m = 7
    seg = 1.0 / (2 * m)
    wire = Wire(
        k_b=4, k_s=1e3, n_segments=2 * m, plasticity=Plasticity(s=0.3, theta_p=0.2),
        hard_core=0.3 * seg, hard_core_energy=0.05,
    )  # fmt: skip
    rng = np.random.default_rng(seed)
    pos = staggered_hairpin(m, seg, 0.5 * wire.hard_core) + rng.normal(
        0, 1e-3 * wire.hard_core, (2 * m + 1, 2)
    )
    assert_smooth_contacts(pos, wire.hard_core)
    assert_hessian(WireEnergy(wire, 100.0), pos, h=1e-7 * wire.hard_core, rtol=1e-6)


def test_projected_contact_hessian_only_adds_positive_curvature():
    m = 7
    seg = 1.0 / (2 * m)
    wire = Wire(k_b=1, k_s=1e3, n_segments=2 * m, hard_core=0.3 * seg, hard_core_energy=1.0)
    pos = staggered_hairpin(m, seg, 0.4 * wire.hard_core) + np.random.default_rng(5).normal(
        0, 1e-3 * wire.hard_core, (2 * m + 1, 2)
    )
    energy = WireEnergy(wire, 10.0)
    exact = energy.hessian(pos, dense=True)
    proj = energy.hessian(pos, dense=True, project_contacts=True)
    assert not np.allclose(exact, proj)  # the contacts' negative curvature was removed ...
    assert np.linalg.eigvalsh(proj - exact).min() > -1e-9 * np.abs(exact).max()  # ... only that
    free = free_chain(1, 2 * m, seg=seg)
    np.testing.assert_array_equal(energy.hessian(free, project_contacts=True), energy.hessian(free))


def test_caps_projection_projects_only_the_pairs_at_a_segments_end():
    """``project_contacts="caps"`` (the Newton fallback "caps") projects the blocks of the
    pairs whose closest point is a segment's end, where D is a point-point distance, and keeps
    the others exact: on a hairpin whose pairs all face a segment's middle it is the exact
    Hessian (and the full projection is not), on a wire whose pairs all sit off a segment's
    end it is the full projection (and the exact Hessian is not), dense and sparse alike."""
    m = 7
    seg = 1.0 / (2 * m)
    d = 0.3 * seg
    cases = {
        "middle": (staggered_hairpin(m, seg, 0.4 * d), 2 * m),
        "end": (end_contact(m, seg, 0.5 * d), 2 * m + 3),
    }
    for name, (pos, n) in cases.items():
        wire = Wire(k_b=1, k_s=1e3, n_segments=n, length=n * seg, hard_core=d,
                    hard_core_energy=1.0)  # fmt: skip
        ts = [t for _, t in contact_geometry(pos, d)]
        assert ts and all((0 < t < 1) == (name == "middle") for t in ts), ts
        energy = WireEnergy(wire, 10.0)
        h = {p: energy.hessian(pos, dense=True, project_contacts=p) for p in (False, True, "caps")}
        same, other = (False, True) if name == "middle" else (True, False)
        np.testing.assert_array_equal(h["caps"], h[same])
        assert not np.allclose(h["caps"], h[other]), name
        for _ in range(2):  # the triplets' route, then the values' into the kept pattern
            sparse = energy.hessian_csc(pos, project_contacts="caps").tocsc().toarray()
            np.testing.assert_array_equal(sparse, h["caps"])
    for bad in ("ends", None, 2):
        with pytest.raises(ValueError, match="project_contacts"):
            energy.hessian(pos, project_contacts=bad)


@pytest.mark.parametrize("seed", SEEDS)
def test_caps_projection_lies_between_the_exact_and_the_projected_hessian(seed):
    """Projecting some blocks removes only negative curvature: H ≤ H_caps ≤ H_projected in
    the order of symmetric matrices, strictly on both sides, on a hairpin whose upper strand's
    nodes sit a tenth of a segment off the lower one's: each faces one segment near its end
    (a pair in a middle) and the joint beside it (a pair at an end)."""
    m = 7
    seg = 1.0 / (2 * m)
    wire = Wire(k_b=1, k_s=1e3, n_segments=2 * m, hard_core=0.3 * seg, hard_core_energy=1.0)
    pos = staggered_hairpin(m, seg, 0.4 * wire.hard_core)
    pos[m + 1 :, 0] += 0.4 * seg
    pos += np.random.default_rng(seed).normal(0, 1e-3 * wire.hard_core, pos.shape)
    ts = [t for _, t in contact_geometry(pos, wire.hard_core)]
    assert any(0 < t < 1 for t in ts) and any(not 0 < t < 1 for t in ts), ts
    energy = WireEnergy(wire, 10.0)
    h = {p: energy.hessian(pos, dense=True, project_contacts=p) for p in (False, True, "caps")}
    scale = np.abs(h[False]).max()
    for low, high in ((False, "caps"), ("caps", True)):
        gap = np.linalg.eigvalsh(h[high] - h[low])
        assert gap.min() > -1e-9 * scale and gap.max() > 1e-6 * scale, (low, high)


def test_hessian_dense_or_sparse_by_size():
    small = Wire(k_b=1, k_s=1e4, n_segments=20)
    big = Wire(k_b=1, k_s=1e4, n_segments=1000)
    x_small = np.c_[np.linspace(-0.5, 0.5, 21), np.zeros(21)]
    x_big = np.c_[np.linspace(-0.5, 0.5, 1001), np.zeros(1001)]
    assert isinstance(hessian(small, x_small, 1.0), np.ndarray)
    assert sp.issparse(hessian(big, x_big, 1.0))
    assert hessian(big, x_big, 1.0).shape == (2002, 2002)


# --------------------------------------------------------------------------------------------
# The Hessian's product in element form (WireEnergy.hessian_action)
# --------------------------------------------------------------------------------------------


def action_cases():
    """(energy, positions): free chains (elastic, plastic, rest angles, both confinements),
    contacts at interior and end points, and a wire against the cavity's wall."""
    n = 12
    pos = free_chain(0, n, seg=1 / n, max_turn=2.0, stretch=0.2)
    rest = np.random.default_rng(3).normal(0.0, 0.3, n - 1)
    yield WireEnergy(Wire(k_b=5, k_s=2e3, n_segments=n, trap_center=(0.1, 0)), 250.0), pos
    plastic = Wire(k_b=5, k_s=2e3, n_segments=n, plasticity=Plasticity(s=0.2, theta_p=0.4),
                   confinement="per-node")  # fmt: skip
    yield WireEnergy(plastic, 30.0, rest_angles=rest), pos
    m, seg = 7, 1.0 / 14
    contact = Wire(k_b=4, k_s=1e3, n_segments=2 * m, hard_core=0.3 * seg, hard_core_energy=0.05)
    yield WireEnergy(contact, 100.0), staggered_hairpin(m, seg, 0.5 * contact.hard_core)
    end = end_contact(5, 0.1, 0.3 * 0.3 * 0.1)
    n_end = len(end) - 1
    yield WireEnergy(Wire(k_b=1, k_s=1e2, n_segments=n_end, length=n_end * 0.1,
                          hard_core=0.03, hard_core_energy=1.0), 0.0), end  # fmt: skip
    arc = regular_arc(16, 11, radius=1.0 - 0.5e-4)  # every node at δ = d/2 from the wall
    arc[::2] *= 1.0 - 0.2e-4 / np.hypot(*arc[::2].T)[:, None]
    walled = Wire(k_b=1, k_s=1e3, n_segments=10, length=10 * 0.39, cavity_radius=1.0,
                  hard_core=1e-4)  # fmt: skip
    yield WireEnergy(walled, 1.0), arc


@pytest.mark.parametrize("case", range(5))
def test_hessian_action_is_the_assembled_hessian_times_v(case):
    energy, pos = list(action_cases())[case]
    h = energy.hessian(pos, dense=True)
    rng = np.random.default_rng(case)
    for _ in range(3):
        v = rng.standard_normal(pos.size)
        hv = energy.hessian_action(pos, v)
        assert hv.shape == (pos.size,)
        np.testing.assert_allclose(hv, h @ v, rtol=0, atol=1e-10 * np.max(np.abs(h @ v)))


@pytest.mark.parametrize("case", range(5))
def test_hessian_action_is_the_derivative_of_the_gradient(case):
    energy, pos = list(action_cases())[case]
    v = np.random.default_rng(10 + case).standard_normal(pos.shape)
    step = 1e-7 * np.max(np.abs(pos)) / np.max(np.abs(v))
    if energy.wire.hard_core < 1:  # stay inside the hard core's smooth region
        step = min(step, 1e-4 * energy.wire.hard_core)
    fd = (energy(pos + step * v)[1] - energy(pos - step * v)[1]).ravel() / (2 * step)
    hv = energy.hessian_action(pos, v.ravel())
    np.testing.assert_allclose(hv, fd, rtol=0, atol=1e-5 * np.max(np.abs(hv)))


def straight_equilibrium(wire, lam):
    """The straight wire along x in equilibrium in the trap (compressed), by the fixed point of
    its tensions: T_j = Σ_{i <= j} 2 λ w_i x_i, l_j = l0 + T_j / k_s."""
    energy = WireEnergy(wire, lam)
    x = np.linspace(-0.5 * wire.length, 0.5 * wire.length, wire.n_nodes)
    for _ in range(20):
        tension = np.cumsum(2 * lam * energy.weights * x)[:-1]
        x = np.concatenate([[0.0], np.cumsum(wire.rest_length + tension / wire.k_s)])
        x -= 0.5 * x[-1]
    return energy, np.c_[x, np.zeros_like(x)]


def test_hessian_action_keeps_the_continuum_curvature_at_n_1e5():
    """A smooth transverse mode of the straight wire at N = 10⁵ (6 k_b/l² = 3 × 10¹⁴): vᵀHv in
    element form is the continuum's ∫ [B v''² + 2λ v² + T v'²] ds (to the O(1/N) of the ends and
    the 10⁻⁴ compression of the wire), the assembled matrix's product is not."""
    lam, bending, n = 2.0, 0.05, 100_000
    wire = Wire.from_continuum(bending=bending, stretching=5000, n_segments=n, hard_core=1e-6)
    energy, pos = straight_equilibrium(wire, lam)
    assert np.max(np.abs(energy(pos)[1])) < 1e-6
    q = np.pi / wire.length
    s = pos[:, 0] + 0.5 * wire.length
    v = np.c_[np.zeros(n + 1), np.sin(q * s + 0.3)].ravel()
    sf = np.linspace(0.0, wire.length, 200_001)
    vf = np.sin(q * sf + 0.3)
    tension = -lam * (wire.length**2 / 4 - (sf - wire.length / 2) ** 2)
    continuum = np.trapezoid(bending * q**4 * vf**2 + 2 * lam * vf**2
                             + tension * q**2 * np.cos(q * sf + 0.3) ** 2, sf)  # fmt: skip
    element = float(v @ energy.hessian_action(pos, v))
    assembled = float(v @ (energy.hessian_csc(pos) @ v))
    assert element == pytest.approx(continuum, rel=2e-4)
    assert abs(assembled - continuum) > 0.1 * abs(continuum)


# --------------------------------------------------------------------------------------------
# Invariants (hypothesis)
# --------------------------------------------------------------------------------------------


def rotation(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


motions = {
    "seed": st.integers(0, 2**32 - 1),
    "n": st.integers(3, 60),
    "angle": st.floats(-np.pi, np.pi),
    "shift": st.tuples(st.floats(-5, 5), st.floats(-5, 5)),
}


@settings(max_examples=100, deadline=None)
@given(**motions, plastic=st.booleans())
def test_rigid_motions_leave_bending_and_stretching_unchanged(seed, n, angle, shift, plastic):
    pos = random_chain(seed, n, seg=1 / n, max_turn=2.8)
    rot = rotation(angle)
    moved = pos @ rot.T + np.asarray(shift)
    plast = Plasticity(s=0.3, theta_p=0.5) if plastic else None
    e0, g0 = bending_energy(pos, 4.0, plast)
    e1, g1 = bending_energy(moved, 4.0, plast)
    assert e1 == pytest.approx(e0, rel=1e-9, abs=1e-12)
    np.testing.assert_allclose(g1, g0 @ rot.T, rtol=1e-6, atol=1e-7 * np.max(np.abs(g0)))
    e0, g0 = stretching_energy(pos, 1e6, 1 / n)
    e1, g1 = stretching_energy(moved, 1e6, 1 / n)
    assert e1 == pytest.approx(e0, rel=1e-8)
    np.testing.assert_allclose(g1, g0 @ rot.T, rtol=1e-6, atol=1e-7 * np.max(np.abs(g0)))


@settings(max_examples=100, deadline=None)
@given(**motions, kind=st.sampled_from(["per-node", "per-length"]))
def test_rotation_about_the_trap_centre_leaves_confinement_unchanged(seed, n, angle, shift, kind):
    center = np.asarray(shift)
    pos = random_chain(seed, n, seg=1 / n) + center
    moved = (pos - center) @ rotation(angle).T + center
    w = confinement_weights(n + 1, kind)
    e0, g0 = confinement_energy(pos, 77.0, w, tuple(center))
    e1, g1 = confinement_energy(moved, 77.0, w, tuple(center))
    assert e1 == pytest.approx(e0, rel=1e-10)
    np.testing.assert_allclose(
        g1, g0 @ rotation(angle).T, rtol=1e-8, atol=1e-10 * np.max(np.abs(g0))
    )
    # a translation away from the centre does change it: the trap is not translation invariant
    e2, _ = confinement_energy(pos + np.array([0.5, 0.0]), 77.0, w, tuple(center))
    assert e2 != pytest.approx(e0)


@settings(max_examples=60, deadline=None)
@given(**motions, u=st.floats(0.2, 0.9))
def test_rigid_motions_leave_the_hard_core_unchanged(seed, n, angle, shift, u):
    """The neighbour search uses an axis-aligned grid; the energy must not see the axes."""
    m = 2 + n % 8
    seg, d = 0.01, 3e-3
    pos = staggered_hairpin(m, seg, u * d) + np.random.default_rng(seed).normal(
        0, 1e-3 * d, (2 * m + 1, 2)
    )
    moved = pos @ rotation(angle).T + np.asarray(shift)
    e0, g0 = hard_core_energy(pos, d, 1e-3)
    e1, g1 = hard_core_energy(moved, d, 1e-3)
    assert e0 > 0
    assert e1 == pytest.approx(e0, rel=1e-6)
    np.testing.assert_allclose(
        g1, g0 @ rotation(angle).T, rtol=1e-5, atol=1e-6 * np.max(np.abs(g0))
    )


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 60), scale=st.floats(1e-4, 1e4))
def test_bending_is_scale_invariant(seed, n, scale):
    pos = random_chain(seed, n, max_turn=2.8)
    e0, g0 = bending_energy(pos, 2.0)
    e1, g1 = bending_energy(scale * pos, 2.0)
    assert e1 == pytest.approx(e0, rel=1e-9, abs=1e-12)
    np.testing.assert_allclose(g1 * scale, g0, rtol=1e-6, atol=1e-7 * np.max(np.abs(g0)))


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 60), plastic=st.booleans())
def test_internal_forces_have_no_net_force_or_torque(seed, n, plastic):
    """Translation and rotation invariance of the internal terms, in differential form:
    Σ_i ∇_i E = 0 and Σ_i r_i × ∇_i E = 0."""
    pos = random_chain(seed, n, seg=1 / n, max_turn=2.8) + 3.0
    plast = Plasticity(s=0.2, theta_p=0.3) if plastic else None
    for _, g in (bending_energy(pos, 4.0, plast), stretching_energy(pos, 1e5, 1 / n)):
        scale = np.max(np.abs(g)) * (1 + np.max(np.abs(pos)))
        assert np.all(np.abs(g.sum(axis=0)) <= 1e-10 * scale)
        torque = np.sum(pos[:, 0] * g[:, 1] - pos[:, 1] * g[:, 0])
        assert abs(torque) <= 1e-10 * scale


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), jump=st.sampled_from([0.005, 0.02, 0.3]))
def test_wire_energy_has_no_memory(seed, jump):
    """WireEnergy keeps a neighbour list between calls (a Verlet list). Along a random walk of
    configurations in and out of contact, every evaluation must equal a fresh one: same
    energy by term and same gradient (the docstring promises "to the bit"), whatever the
    history."""
    m = 6
    seg = 1.0 / (2 * m)
    wire = Wire(k_b=2, k_s=1e3, n_segments=2 * m, hard_core=0.3 * seg, hard_core_energy=0.1)
    rng = np.random.default_rng(seed)
    x = staggered_hairpin(m, seg, 0.8 * wire.hard_core)
    reused = WireEnergy(wire, 50.0)
    in_contact = 0
    for _ in range(40):
        x = x + rng.normal(0, jump * wire.hard_core, x.shape)
        x[m + 1 :, 1] = np.clip(x[m + 1 :, 1], 0.3 * wire.hard_core, 1.5 * wire.hard_core)
        fresh = WireEnergy(wire, 50.0)
        e1, g1 = reused(x)
        e2, g2 = fresh(x)
        assert e1 == e2
        np.testing.assert_array_equal(g1, g2)
        assert reused.terms(x) == fresh.terms(x)
        hc, _ = hard_core_energy(x, wire.hard_core, wire.hard_core_energy)
        assert fresh.terms(x).hard_core == pytest.approx(hc, rel=1e-14, abs=0)
        np.testing.assert_array_equal(reused.hessian(x), fresh.hessian(x))
        in_contact += hc > 0
    assert in_contact > 0


def test_test_configurations_are_what_they_claim():
    """The helper geometries used above: crossing-free, with the stated contacts."""
    seg, d = 0.01, 3e-3
    hp = staggered_hairpin(6, seg, 0.5 * d)
    geo = contact_geometry(hp, d)
    assert len(geo) == 11
    assert all(u == pytest.approx(0.5) and t == pytest.approx(0.5) for u, t in geo)
    assert not has_crossings(hp)
    ec = end_contact(5, seg, 0.5 * d)
    geo = contact_geometry(ec, d)
    assert len(geo) == 2 and all(u == pytest.approx(0.5) for u, _ in geo)
    assert not has_crossings(ec)


# --------------------------------------------------------------------------------------------
# Imperfect wires: rest turning angles (Wire.rest_angle_sd)
# --------------------------------------------------------------------------------------------


def _chain_with_angles(angles, l0=0.1):
    phi = np.r_[0.0, np.cumsum(angles)]
    steps = l0 * np.c_[np.cos(phi), np.sin(phi)]
    return np.r_[[[0.0, 0.0]], np.cumsum(steps, axis=0)]


def test_wire_at_its_rest_angles_has_no_bending_energy():
    rest = np.random.default_rng(4).normal(0.0, 0.3, 12)
    x = _chain_with_angles(rest)
    e, g = bending_energy(x, 7.0, rest_angles=rest)
    assert e == pytest.approx(0.0, abs=1e-24)
    np.testing.assert_allclose(g, 0.0, atol=1e-9)
    # and the energy is k_b/2 Σ (θ - θ⁰)² elsewhere
    e0, _ = bending_energy(x, 7.0)
    assert e0 == pytest.approx(0.5 * 7.0 * np.sum(rest**2), rel=1e-12)


def test_rest_angles_gradient_and_hessian_match_finite_differences():
    rng = np.random.default_rng(5)
    n = 10
    wire = Wire(k_b=3, k_s=2e3, n_segments=n, plasticity=Plasticity(s=0.3, theta_p=0.2))
    rest = rng.normal(0.0, 0.4, n - 1)
    x = _chain_with_angles(rng.normal(0.0, 0.5, n - 1), l0=0.1)
    f = WireEnergy(wire, 5.0, rest_angles=rest)
    _, g = f(x)
    h = 1e-7
    num = np.zeros_like(x)
    for i in range(x.shape[0]):
        for a in range(2):
            xp, xm = x.copy(), x.copy()
            xp[i, a] += h
            xm[i, a] -= h
            num[i, a] = (f(xp)[0] - f(xm)[0]) / (2 * h)
    np.testing.assert_allclose(g, num, rtol=1e-6, atol=1e-6 * np.abs(g).max())
    hess = f.hessian(x, dense=True)
    fd = np.zeros_like(hess)
    for c in range(x.size):
        xp, xm = x.ravel().copy(), x.ravel().copy()
        xp[c] += 1e-6
        xm[c] -= 1e-6
        fd[:, c] = (f(xp.reshape(-1, 2))[1].ravel() - f(xm.reshape(-1, 2))[1].ravel()) / 2e-6
    np.testing.assert_allclose(hess, fd, rtol=1e-5, atol=1e-5 * np.abs(hess).max())


def test_rest_angles_are_validated():
    wire = Wire(k_b=1, k_s=1e4, n_segments=5)
    with pytest.raises(ValueError, match="rest_angles must have shape"):
        WireEnergy(wire, 1.0, rest_angles=np.zeros(3))
    with pytest.raises(ValueError, match="NaN"):
        WireEnergy(wire, 1.0, rest_angles=np.full(4, np.nan))
    with pytest.raises(ValueError, match="rest_angle_sd"):
        Wire(k_b=1, k_s=1e4, rest_angle_sd=-0.1)


# --------------------------------------------------------------------------------------------
# The barriers a step may enter (the Newton model's one-sided springs)
# --------------------------------------------------------------------------------------------


def _distance_rows_by_differences(pos, index, value, seed, h, sign):
    """Check that each row is ``sign`` × ∇D of its (node, segment) pair, against central
    differences of the exact distance along a random direction; the pairs' distances."""
    from crumple.geometry import point_segment_distance

    v = np.random.default_rng(seed).standard_normal(pos.shape)
    distances = []
    for row, val in zip(index, value, strict=True):
        k, j = row[0] // 2, row[2] // 2

        def dist(x, k=k, j=j):
            return point_segment_distance(x[k], x[j], x[j + 1])

        fd = (dist(pos + h * v) - dist(pos - h * v)) / (2 * h)
        assert sign * (val @ v.ravel()[row]) == pytest.approx(fd, rel=1e-5, abs=1e-9)
        distances.append(dist(pos))
    return distances


@pytest.mark.parametrize("seed", range(3))
def test_barrier_rows_are_the_distance_gradients_of_the_pairs_a_step_can_reach(seed):
    """Staggered hairpin 3d apart: lowering strand B by 2.5 d could bring each of its 2m - 1
    pairs inside the core, so each gets a row a = ∇D (checked by finite differences of the
    exact node-segment distance), offset d - D = -2d and stiffness ε b''(1)/d² = 2ε/d²;
    a step of 0.5 d reaches none; pairs already inside the core are the Hessian's, not rows."""

    m, seg, d, eps = 5, 0.01, 1e-5, 1e-3
    pos = staggered_hairpin(m, seg, 3 * d)
    w = Wire(k_b=1.0, k_s=1e3, n_segments=2 * m, hard_core=d, hard_core_energy=eps)
    energy = WireEnergy(w, lam=1.0)
    step = np.zeros_like(pos)
    step[m + 1 :, 1] = -2.5 * d
    index, value, offset, stiff = energy.barriers(pos, step)
    assert len(offset) == 2 * m - 1
    np.testing.assert_allclose(offset, -2 * d, rtol=1e-9)
    np.testing.assert_allclose(stiff, 2 * eps / d**2)
    distances = _distance_rows_by_differences(pos, index, value, seed, 1e-9, 1.0)
    for dist, row, val in zip(distances, index, value, strict=True):
        assert dist + val @ step.ravel()[row] == pytest.approx(0.5 * d, rel=1e-6)
    assert len(energy.barriers(pos, 0.2 * step)[2]) == 0
    inside = staggered_hairpin(m, seg, 0.5 * d)
    assert len(energy.barriers(inside, step)[2]) == 0


@pytest.mark.parametrize("seed", range(3))
def test_releasing_rows_take_out_the_curvature_of_the_pairs_a_step_releases(seed):
    """The staggered hairpin 0.9 d apart (every pair inside the core, u = 0.9): raising strand
    B by 0.5 d takes each of its 2m - 1 pairs out of the core, so with ``releasing=True`` each
    gets the row -∇D (finite differences), offset D - d = -0.1 d and stiffness
    -ε b''(u)/d² = -2ε/(u³d²) (b'' by differences of b), minus the ∇D ∇Dᵀ coefficient of the
    pair's Hessian block: once such a spring acts the model has no curvature left for the
    pair, as the energy has none beyond d. A step towards the core releases none; with
    ``releasing`` off none is listed either."""

    m, seg, d, eps = 5, 0.01, 1e-5, 1e-3
    pos = staggered_hairpin(m, seg, 0.9 * d)
    w = Wire(k_b=1.0, k_s=1e3, n_segments=2 * m, hard_core=d, hard_core_energy=eps)
    energy = WireEnergy(w, lam=1.0)
    step = np.zeros_like(pos)
    step[m + 1 :, 1] = 0.5 * d
    assert len(energy.barriers(pos, step)[2]) == 0
    index, value, offset, stiff = energy.barriers(pos, step, releasing=True)
    assert len(offset) == 2 * m - 1
    np.testing.assert_allclose(offset, -0.1 * d, rtol=1e-6)
    np.testing.assert_allclose(stiff, -2 * eps / (0.9**3 * d**2), rtol=1e-6)
    _distance_rows_by_differences(pos, index, value, seed, 1e-10, -1.0)
    for row, val in zip(index, value, strict=True):
        # the linearised distance after the step is beyond d exactly when (-a)ᵀs < D - d
        assert val @ step.ravel()[row] < offset[0]
    # -stiffness is ε/d² times the barrier's second derivative at u (differences of b)
    from crumple.energy_kernels import _barrier

    du = 1e-4
    b2 = (_barrier(0.9 + du)[0] - 2 * _barrier(0.9)[0] + _barrier(0.9 - du)[0]) / du**2
    np.testing.assert_allclose(-stiff, eps * b2 / d**2, rtol=1e-6)
    toward = energy.barriers(pos, -step, releasing=True)
    assert not np.any(toward[3] < 0)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), ndof=st.integers(1, 120), t=st.integers(0, 1500))
def test_hessian_pattern_kernels_match_a_sort_of_the_triplets(seed, ndof, t):
    """The fixed-pattern assembly's kernels: the CSC pattern is the sorted distinct (col, row)
    keys, each triplet's entry is its key's rank, and the scatter adds as np.bincount does,
    bit for bit."""
    from crumple.energy_assembly import _csc_pattern_kernel, _scatter_add

    rng = np.random.default_rng(seed)
    rows, cols = rng.integers(0, ndof, t), rng.integers(0, ndof, t)
    cols[: t // 3] = rng.integers(0, min(ndof, 2), t // 3)  # some crowded columns
    indptr, indices, where = _csc_pattern_kernel(rows, cols, ndof)
    keys, rank = np.unique(cols * ndof + rows, return_inverse=True)
    assert np.array_equal(indices, keys % ndof)
    assert np.array_equal(indptr, np.searchsorted(keys // ndof, np.arange(ndof + 1)))
    assert np.array_equal(where, rank)
    vals = rng.standard_normal(t) * 10.0 ** rng.uniform(-8, 8, t)
    assert np.array_equal(
        _scatter_add(where, vals, len(keys)), np.bincount(where, vals, minlength=len(keys))
    )


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(2, 30), m=st.integers(0, 10),
       cavity=st.booleans())  # fmt: skip
def test_the_triplets_keys_are_those_of_the_triplets(seed, n, m, cavity):
    """A new pattern is built from ``_triplet_keys``: the rows and columns of
    ``_hessian_triplets``, in their order, for any pairs and with or without the wall."""
    from crumple.energy_kernels import _hessian_triplets, _triplet_keys

    rng = np.random.default_rng(seed)
    pos = np.cumsum(rng.uniform(0.5, 1.5, (n, 2)), axis=0)
    ks = rng.integers(0, n, m) if n > 1 else np.zeros(0, dtype=np.int64)
    js = rng.integers(0, n - 1, m) if n > 1 else np.zeros(0, dtype=np.int64)
    radius = 50.0 if cavity else np.inf
    rest = np.zeros(max(n - 2, 0))
    rows, cols, _ = _hessian_triplets(pos, 1.0, 0.0, 0.0, rest, 10.0, 1.0, 2.0, np.ones(n), ks,
                                      js, 0.1, 1.0, 0, False, radius)  # fmt: skip
    keys = _triplet_keys(n, ks, js, cavity)
    assert np.array_equal(keys[0], rows) and np.array_equal(keys[1], cols)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 30), m=st.integers(0, 12),
       keep=st.integers(0, 12), head=st.integers(0, 50))  # fmt: skip
def test_pair_blocks_are_looked_up_in_a_pattern_as_by_the_ranks_of_their_keys(
    seed, n, m, keep, head
):
    """``_pair_blocks_where``: the given head, then each pair's 6 × 6 block over the nodes
    (k, j, j + 1) in ``_put_block``'s order, found at its key's rank in a pattern holding it;
    a pair whose block is not all in the pattern is reported."""
    from crumple.energy_assembly import _csc_pattern_kernel, _pair_blocks_where
    from crumple.linalg_csc import unsigned_view

    rng = np.random.default_rng(seed)
    ndof = 2 * n
    ks, js = rng.integers(0, n, m), rng.integers(0, n - 1, m)

    def block_keys(k, j):  # _put_block's order: node a, node b, then u, v
        nodes = (k, j, j + 1)
        rc = [(2 * nodes[a] + u, 2 * nodes[b] + v)
              for a in range(3) for b in range(3) for u in range(2) for v in range(2)]  # fmt: skip
        return np.array(rc).T

    chain = rng.integers(0, ndof, (2, 3 * ndof))
    parts = [block_keys(k, j) for k, j in zip(ks, js, strict=True)]
    rows = np.concatenate([chain[0], *(r for r, _ in parts)]).astype(np.int64)
    cols = np.concatenate([chain[1], *(c for _, c in parts)]).astype(np.int64)
    indptr, indices, where = _csc_pattern_kernel(rows, cols, ndof)
    first = where[: min(head, 3 * ndof)]
    sub = rng.permutation(m)[: min(keep, m)]
    indptr, indices = unsigned_view(indptr), unsigned_view(indices)  # as the engine passes them
    got, held = _pair_blocks_where(indptr, indices, first, ks[sub], js[sub])
    assert held
    want = [first] + [where[3 * ndof + 36 * p : 3 * ndof + 36 * (p + 1)] for p in sub]
    assert np.array_equal(got, np.concatenate(want).astype(np.int64))
    # a pair whose block holds an entry the pattern lacks
    for k in range(n):
        for j in range(n - 1):
            r, c = block_keys(k, j)
            missing = ~np.isin(c * ndof + r, cols * ndof + rows)
            if missing.any():
                _, held = _pair_blocks_where(indptr, indices, first, np.array([k]), np.array([j]))
                assert not held
                return


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), project=st.booleans(), cavity=st.booleans())
def test_hessian_assembled_into_its_pattern_is_its_triplets_scattered_bit_for_bit(
    seed, project, cavity
):
    """``hessian_csc`` once its pattern is known writes the terms straight into the CSC data
    (``_hessian_values``): the same sums, in the same order, as scattering the triplets, for
    pairs in and out of the core, plastic joints, either projection and the cavity's wall."""
    from crumple.energy_assembly import _scatter_add

    rng = np.random.default_rng(seed)
    m, seg, d = 6, 0.08, 0.01
    pos = staggered_hairpin(m, seg, d) + 3e-3 * rng.standard_normal((2 * m + 1, 2))
    w = Wire(k_b=2.0, k_s=1e3, n_segments=2 * m, hard_core=d, hard_core_energy=1e-3,
             plasticity=Plasticity(s=0.3, theta_p=0.2),
             cavity_radius=2.0 if cavity else None)  # fmt: skip
    energy = WireEnergy(w, lam=3.0, rest_angles=0.1 * rng.standard_normal(2 * m - 1))
    from crumple.geometry import has_crossings, point_segment_distance

    assume(not has_crossings(pos))
    ks, js = energy._pairs(pos)
    dist = [point_segment_distance(pos[k], pos[j], pos[j + 1]) for k, j in zip(ks, js, strict=True)]
    assume(min(dist) < d < max(dist))  # pairs in the core and candidates outside it
    first = energy.hessian_csc(pos, project_contacts=project, project_bending=project)
    again = energy.hessian_csc(pos, project_contacts=project, project_bending=project)
    assert again.indices is first.indices  # the pattern kept
    _, _, vals = energy._triplets(pos, project, project)
    where = energy._pattern[4]
    scattered = _scatter_add(where, vals, first.indices.shape[0])
    assert again.data.tobytes() == scattered.tobytes()  # bits, the signs of zeros included
    assert first.data.tobytes() == scattered.tobytes()


@pytest.mark.parametrize("project", [False, True])
def test_a_pattern_kept_for_fewer_pairs_gives_the_hessian_of_a_new_one_bit_for_bit(project):
    """A rebuilt neighbour list with fewer pairs keeps the pattern (its chain entries where
    they were, the pairs' blocks looked up, the pairs that left as explicit zeros): the
    Hessian is that of its triplets scattered into it, and entry for entry that of an energy
    that built its pattern for these pairs alone."""
    from crumple.energy_assembly import _scatter_add

    m, seg, d = 6, 0.08, 0.01
    w = Wire(k_b=2.0, k_s=1e3, n_segments=2 * m, length=2 * m * seg, hard_core=d,
             hard_core_energy=1e-3)  # fmt: skip
    energy = WireEnergy(w, lam=3.0)
    pos = staggered_hairpin(m, seg, 0.5 * d)
    first = energy.hessian_csc(pos, project_contacts=project)
    pairs = len(energy._pattern[0])
    apart = pos.copy()
    apart[m + 1 : m + 4, 1] += 0.05  # three nodes of the upper strand pulled away
    again = energy.hessian_csc(apart, project_contacts=project)
    assert len(energy._pattern[0]) < pairs  # the list was rebuilt, with fewer pairs
    assert again.indices is first.indices and again.indptr is first.indptr  # the pattern kept
    _, _, vals = energy._triplets(apart, int(project), False)
    where = energy._pattern[4]
    scattered = _scatter_add(where, vals, first.indices.shape[0])
    assert again.data.tobytes() == scattered.tobytes()  # bits, the signs of zeros included
    fresh = WireEnergy(w, lam=3.0).hessian_csc(apart, project_contacts=project)
    assert fresh.indices.shape[0] < again.indices.shape[0]  # a pattern of these pairs alone
    assert np.array_equal(fresh.tocsc().toarray(), again.tocsc().toarray())


def test_touching_says_whether_a_contact_acts():
    """``WireEnergy.touching`` is true exactly when the hard-core energy is nonzero."""
    m, seg, d = 6, 0.08, 0.01
    w = Wire(k_b=1.0, k_s=1e3, n_segments=2 * m, hard_core=d, hard_core_energy=1e-3)
    energy = WireEnergy(w, lam=1.0)
    for gap, inside in ((0.5 * d, True), (2.0 * d, False)):
        pos = staggered_hairpin(m, seg, gap)
        assert (energy.terms(pos).hard_core > 0) is inside
        rebuilds = energy.rebuilds
        assert energy.touching(pos) is inside
        assert energy.rebuilds == rebuilds  # it reads the list, never rebuilds it


def _elastic_gradient_longdouble(x, k_b, k_s, l0, lam, weights):
    """Bending, stretching and confinement forces of x (float64 or longdouble) in numpy's
    longdouble (x86-64: a 64-bit mantissa, 2¹¹ times finer than float64)."""
    x = np.asarray(x, dtype=np.longdouble)
    e = np.diff(x, axis=0)
    length = np.sqrt(np.sum(e * e, axis=1))
    g = np.zeros_like(x)
    c = (k_s * (length - l0) / length)[:, None] * e
    g[:-1] -= c
    g[1:] += c
    a, b = e[:-1], e[1:]
    theta = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.sum(a * b, axis=1))
    la2, lb2 = np.sum(a * a, axis=1), np.sum(b * b, axis=1)
    ga = k_b * theta[:, None] * np.c_[a[:, 1] / la2, -a[:, 0] / la2]
    gb = k_b * theta[:, None] * np.c_[-b[:, 1] / lb2, b[:, 0] / lb2]
    g[:-2] -= ga
    g[1:-1] += ga - gb
    g[2:] += gb
    return g + 2 * lam * np.asarray(weights, dtype=np.longdouble)[:, None] * x


@pytest.mark.skipif(np.finfo(np.longdouble).nmant < 60, reason="needs an extended longdouble")
def test_displaced_forces_resolve_what_float64_positions_cannot():
    """At N = 5 × 10⁴ a curved wire's bending forces, from float64 node positions x, carry a
    round-off of ~ε k_b/l0² |x| per node, above the typical force itself; from a reference and
    a small displacement, x = ref + u with each segment (ref_{i+1} − ref_i) + (u_{i+1} − u_i),
    they are the exact configuration's to ~ε k_b/l0 (against an extended-precision evaluation
    of the very same ref + u)."""
    n = 50_000
    w = Wire.from_continuum(bending=0.05, stretching=5000, n_segments=n)
    s = np.linspace(-0.5, 0.5, n + 1)
    ref = np.c_[s, 0.02 * np.cos(np.pi * s)]
    u = 1e-9 * np.c_[np.sin(3 * s), np.cos(5 * s)]
    energy = WireEnergy(w, lam=6.0)
    args = (w.k_b, w.k_s, w.rest_length, 6.0, energy.weights)
    exact = _elastic_gradient_longdouble(ref.astype(np.longdouble) + u, *args)
    typical = float(np.median(np.abs(exact)))
    err_rounded = float(np.max(np.abs(energy(ref + u)[1] - exact)))
    err_precise = float(np.max(np.abs(energy.displaced(ref)(u)[1] - exact)))
    # the float64 sum ref + u is itself the error: the same forces in extended precision
    sum_error = float(np.max(np.abs(_elastic_gradient_longdouble(ref + u, *args) - exact)))
    assert err_rounded > typical and sum_error > 0.9 * err_rounded
    assert err_precise < 1e-2 * typical
    assert err_precise < 100 * np.finfo(float).eps * w.k_b / w.rest_length


def test_the_displaced_energy_is_the_energy_of_the_sum():
    """Away from round-off, displaced(ref)(u) is the energy and gradient at ref + u, with the hard
    core's pairs, and at u = 0 it is the energy itself, bit for bit (the same kernel)."""
    w = Wire(k_b=5, k_s=5e5, n_segments=60, hard_core=0.004)
    ref = staggered_hairpin(30, w.rest_length, 0.003)
    u = 1e-5 * np.random.default_rng(1).standard_normal(ref.shape)
    energy = WireEnergy(w, lam=2.0)
    e, g = energy(ref + u)
    ed, gd = energy.displaced(ref)(u)
    assert energy.terms(ref + u).hard_core > 0
    np.testing.assert_allclose(ed, e, rtol=1e-12)
    np.testing.assert_allclose(gd, g, rtol=1e-7, atol=1e-7 * np.abs(g).max())
    e0, g0 = energy.displaced(ref)(np.zeros_like(ref))
    assert e0 == energy(ref)[0] and np.array_equal(g0, energy(ref)[1])
    with pytest.raises(ValueError, match="shape"):
        energy.displaced(ref[:-1])
