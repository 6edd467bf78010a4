"""Tests of the rigid circular cavity: the wall's barrier (closed forms, gradient, Hessian,
rotations), its continuous collision detection, and minimisations that never leave it.

The wall is the hard core's barrier b(u) = (1 - u)²/u on the node-to-wall distance
δ = R_c - |x|, u = δ/d (``docs/model.md``, "The cavity").
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import crumple.protocol as protocol
import crumple.relax as relax
from crumple.energy import WireEnergy, cavity_energy, confinement_energy, energy_terms
from crumple.geometry import disc_exit_fraction, has_crossings
from crumple.minimize import resolution
from crumple.model import Wire
from crumple.protocol import Ramp, minimize_wire, run_ramp
from crumple.storage import load_ramps, save_ramps
from crumple.sweep.store import run_id


def barrier(u: float) -> float:
    return (1.0 - u) ** 2 / u if u < 1.0 else 0.0


def at_radius(radii, angles) -> np.ndarray:
    radii, angles = np.broadcast_arrays(np.asarray(radii, float), np.asarray(angles, float))
    return np.c_[radii * np.cos(angles), radii * np.sin(angles)]


def wall_chain(seed: int, n_segments: int, radius: float, width: float) -> np.ndarray:
    """An arc of nodes hugging the wall, each at its own depth δ in (0.15 d, 0.9 d) or beyond
    the barrier, so that some nodes are in it and some not (no hard-core contact: the nodes
    are a tenth of the radius apart)."""
    rng = np.random.default_rng(seed)
    delta = width * rng.uniform(0.15, 0.9, n_segments + 1)
    delta[rng.random(n_segments + 1) < 0.3] = 3.0 * width  # away from the wall
    angles = np.cumsum(np.r_[0.0, rng.uniform(0.08, 0.12, n_segments)])
    return at_radius(radius - delta, angles)


# --------------------------------------------------------------------------------------------
# Closed forms
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("u", [0.05, 0.3, 0.5, 0.9, 0.999])
@pytest.mark.parametrize("angle", [0.0, 1.0, -2.5])
def test_one_node_at_depth_u(u, angle):
    """A node at δ = u d from the wall: energy ε b(u), force ε |b'(u)|/d towards the centre."""
    radius, width, eps = 0.7, 1e-3, 2e-3
    x = at_radius([0.0, radius - u * width], [0.0, angle])
    e, g = cavity_energy(x, radius, width, eps)
    assert e == pytest.approx(eps * barrier(u), rel=1e-9)
    db = 1.0 - 1.0 / u**2
    n = x[1] / np.linalg.norm(x[1])
    np.testing.assert_allclose(g[1], -eps * db / width * n, rtol=1e-9)
    assert np.all(g[0] == 0.0)


@pytest.mark.parametrize("n_segments", [3, 12, 100])
@pytest.mark.parametrize("u", [0.2, 0.7])
def test_ring_closed_polygon_has_n_plus_one_times_one_node(n_segments, u):
    """A closed regular polygon of N segments (N + 1 nodes, the first repeated) on the circle
    of radius R_c - δ: (N + 1) ε b(u)."""
    radius, width = 0.3, 1e-4
    t = 2 * np.pi * np.arange(n_segments + 1) / n_segments
    e, _ = cavity_energy(at_radius(radius - u * width, t), radius, width)
    assert e == pytest.approx((n_segments + 1) * barrier(u), rel=1e-9)


def test_arc_through_the_wire_energy_is_the_wall_term():
    """An open arc hugging the wall: the wall term of :class:`WireEnergy` is (N + 1) ε b(u)
    and enters the total."""
    n, radius, width, u = 20, 0.4, 1e-3, 0.4
    wire = Wire(k_b=1, k_s=1e3, n_segments=n, hard_core=width, cavity_radius=radius)
    x = at_radius(radius - u * width, np.linspace(0, 2.5, n + 1))
    terms = energy_terms(wire, x, lam=3.0)
    assert terms.wall == pytest.approx((n + 1) * wire.hard_core_energy * barrier(u), rel=1e-9)
    assert terms.to_dict()["wall"] == terms.wall
    assert WireEnergy(wire, 3.0)(x)[0] == pytest.approx(terms.total, rel=1e-12)
    no_cavity = energy_terms(wire.replace(cavity_radius=None), x, lam=3.0)
    assert no_cavity.wall == 0.0
    assert terms.total - no_cavity.total == pytest.approx(terms.wall, rel=1e-9)


def test_zero_beyond_the_width_c1_at_its_edge_infinite_at_the_wall():
    radius, width = 1.0, 1e-3
    for delta in (width, 2 * width, 0.5):
        e, g = cavity_energy([[radius - delta, 0.0]], radius, width)
        assert e == 0.0 and np.all(g == 0.0)
    e, g = cavity_energy([[radius - width * (1 - 1e-7), 0.0]], radius, width)
    assert 0 < e < 1e-13 and abs(g[0, 0]) < 1e-3  # value and slope vanish at δ = d
    for r in (radius, radius + 1e-9, 2.0):
        assert cavity_energy([[0.0, r]], radius, width)[0] == math.inf
    es = [cavity_energy([[radius - u * width, 0.0]], radius, width)[0] for u in (0.9, 0.5, 0.1)]
    assert es[0] < es[1] < es[2]


def test_rigid_rotations_about_the_centre_leave_the_wall_energy_unchanged():
    x = wall_chain(3, 30, 0.5, 1e-2)
    e0 = cavity_energy(x, 0.5, 1e-2)[0]
    assert e0 > 0
    for phi in np.linspace(0.1, 2 * np.pi, 7):
        c, s = math.cos(phi), math.sin(phi)
        y = x @ np.array([[c, s], [-s, c]])
        assert cavity_energy(y, 0.5, 1e-2)[0] == pytest.approx(e0, rel=1e-9)


# --------------------------------------------------------------------------------------------
# Gradient and Hessian of the total with the wall active
# --------------------------------------------------------------------------------------------


def wire_at_the_wall(seed):
    n, radius, width = 12, 0.5, 1e-2
    wire = Wire(k_b=0.5, k_s=50.0, n_segments=n, hard_core=width, cavity_radius=radius,
                hard_core_energy=1e-3)  # fmt: skip
    return wire, wall_chain(seed, n, radius, width)


@pytest.mark.parametrize("seed", range(4))
def test_gradient_of_the_total_with_the_wall_active(seed):
    wire, x = wire_at_the_wall(seed)
    energy = WireEnergy(wire, lam=2.0)
    assert energy.terms(x).wall > 0
    _, g = energy(x)
    h = 1e-7
    fd = np.zeros_like(x)
    for idx in np.ndindex(x.shape):
        xp, xm = x.copy(), x.copy()
        xp[idx] += h
        xm[idx] -= h
        fd[idx] = (energy(xp)[0] - energy(xm)[0]) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-5 * np.max(np.abs(g)))


@pytest.mark.parametrize("seed", range(4))
def test_hessian_of_the_total_with_the_wall_active(seed):
    wire, x = wire_at_the_wall(seed)
    energy = WireEnergy(wire, lam=2.0)
    hess = energy.hessian(x, dense=True)
    h = 1e-8
    fd = np.zeros_like(hess)
    for i in range(x.size):
        xp, xm = x.copy().ravel(), x.copy().ravel()
        xp[i] += h
        xm[i] -= h
        gp, gm = energy(xp.reshape(x.shape))[1], energy(xm.reshape(x.shape))[1]
        fd[:, i] = (gp - gm).ravel() / (2 * h)
    np.testing.assert_allclose(hess, fd, rtol=1e-5, atol=1e-5 * np.max(np.abs(hess)))
    np.testing.assert_allclose(hess, hess.T, rtol=1e-13, atol=1e-13 * np.max(np.abs(hess)))
    sparse = energy.hessian(x, dense=False).toarray()
    np.testing.assert_allclose(sparse, hess, rtol=1e-12, atol=1e-12 * np.max(np.abs(hess)))


def test_the_wall_keeps_the_sparse_pattern():
    """Nodes entering and leaving the barrier do not change the Hessian's index arrays."""
    wire, x = wire_at_the_wall(0)
    energy = WireEnergy(wire, lam=0.0)
    a = energy.hessian(x, dense=False)
    b = energy.hessian(0.97 * x, dense=False)  # every node away from the wall
    assert energy.terms(0.97 * x).wall == 0.0
    np.testing.assert_array_equal(a.indptr, b.indptr)
    np.testing.assert_array_equal(a.indices, b.indices)


# --------------------------------------------------------------------------------------------
# Collision detection against the wall
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(5))
def test_disc_exit_fraction_puts_the_first_node_on_the_circle(seed):
    rng = np.random.default_rng(seed)
    radius = 0.8
    x = at_radius(radius * np.sqrt(rng.random(30)), 2 * np.pi * rng.random(30))
    p = rng.normal(0.0, 1.0, x.shape)
    t = disc_exit_fraction(x, p, radius)
    assert 0 < t < 1
    r = np.hypot(*(x + t * p).T)
    assert np.max(r) == pytest.approx(radius, rel=1e-12)
    assert np.all(np.hypot(*(x + 0.999 * t * p).T) < radius)
    assert disc_exit_fraction(x, 1e-3 * t * p, radius) == 1.0
    assert disc_exit_fraction(x, np.zeros_like(x), radius) == 1.0


# --------------------------------------------------------------------------------------------
# Parameters and run ids
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [0.0, -1.0, math.inf, math.nan, "a", 1e-6])
def test_cavity_radius_is_validated(bad):
    with pytest.raises(ValueError, match="cavity_radius"):
        Wire(k_b=1, k_s=1e3, cavity_radius=bad)


def test_a_cavity_changes_the_run_id_and_none_does_not():
    wire, ramp = Wire(k_b=5, k_s=5e5, n_segments=20), Ramp(lambdas=(1, 10))
    assert wire.cavity_radius is None
    assert run_id(wire.replace(cavity_radius=None), ramp, 0, 0) == run_id(wire, ramp, 0, 0)
    assert run_id(wire.replace(cavity_radius=0.6), ramp, 0, 0) != run_id(wire, ramp, 0, 0)
    assert Wire.from_dict(wire.replace(cavity_radius=0.6).to_dict()).cavity_radius == 0.6


def test_the_start_must_be_inside():
    wire = Wire(k_b=5, k_s=5e5, n_segments=20, cavity_radius=0.5)
    x = protocol.initial_state(wire, noise=0.0)  # a straight wire of length 1: ends on the wall
    with pytest.raises(ValueError, match="leaves the cavity"):
        minimize_wire(wire, x, lam=1.0)
    with pytest.raises(ValueError, match="leaves the cavity"):
        minimize_wire(wire, 1.2 * x, lam=1.0)


def test_a_ramp_in_a_cavity_is_stored_with_its_wall_energy(tmp_path):
    wire = Wire(k_b=5, k_s=5e5, n_segments=20, cavity_radius=0.55)
    res = run_ramp(wire, Ramp(lambdas=(0.0, 1.0)), seed=2)
    assert res.converged
    save_ramps(tmp_path / "r.h5", [res], seed=2)
    (back,) = load_ramps(tmp_path / "r.h5")
    for a, b in zip(res.stages, back.stages, strict=True):
        assert a.energy == b.energy


# --------------------------------------------------------------------------------------------
# Minimisation inside the cavity: never out, never crossed (hypothesis)
# --------------------------------------------------------------------------------------------


def bent_start(wire: Wire, rng) -> np.ndarray:
    """The wire bent along the wall (radius 0.95 R_c, less than a full turn), which its bending
    stiffness pushes outwards against the wall."""
    n, radius = wire.n_nodes, wire.cavity_radius
    arc = 0.95 * radius
    angles = np.linspace(0.0, wire.length / arc, n)
    x = at_radius(arc, angles)
    x += 0.02 * wire.rest_length * rng.standard_normal(x.shape)
    return x


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=st.integers(8, 40),
    rc=st.floats(0.18, 0.3),
    lam=st.sampled_from([0.0, 1.0, 30.0]),
    seed=st.integers(0, 2**16),
)
def test_no_accepted_configuration_leaves_the_cavity_or_crosses(n, rc, lam, seed):
    wire = Wire(k_b=5, k_s=5e4, n_segments=n, hard_core=1e-3, cavity_radius=rc)
    x0 = bent_start(wire, np.random.default_rng(seed))
    if has_crossings(x0) or np.max(np.hypot(*x0.T)) >= rc:
        return
    seen = []
    newton = relax.newton

    def recording(*args, **kwargs):
        kwargs["callback"] = lambda it, x, e, f: seen.append((x.copy(), e))
        return newton(*args, **kwargs)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(relax, "newton", recording)
        res = minimize_wire(wire, x0, lam, maxiter=300)
    assert seen
    energy = WireEnergy(wire, lam)
    e_prev = energy(x0)[0]
    for x, e in seen:
        assert np.all(np.einsum("ij,ij->i", x, x) < rc * rc)  # exact: no node on or past the wall
        assert not has_crossings(x)
        assert e <= e_prev + resolution(e_prev)
        e_prev = e
    assert np.all(np.einsum("ij,ij->i", res.x, res.x) < rc * rc)
    assert energy.terms(res.x).wall > 0  # the wall did hold the wire


@pytest.mark.parametrize("lam", [10.0, 1000.0])
def test_a_trap_outside_presses_the_wire_on_the_wall(lam):
    """A trap centred outside the cavity pulls the whole wire into the wall: the equilibrium
    is inside, every node too, and the wall's net reaction balances the trap's net pull
    (internal forces sum to zero)."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=30, cavity_radius=0.6, trap_center=(3.0, 0.0))
    x0 = protocol.initial_state(wire, seed=1) - np.asarray(wire.trap_center)
    r = minimize_wire(wire, x0, lam)
    assert r.converged, r.message
    assert np.all(np.einsum("ij,ij->i", r.x, r.x) < 0.36)
    assert not has_crossings(r.x)
    energy = WireEnergy(wire, lam)
    assert energy.terms(r.x).wall > 0
    _, g_wall = cavity_energy(r.x, 0.6, wire.hard_core, wire.hard_core_energy)
    _, g_trap = confinement_energy(r.x, lam, energy.weights, wire.trap_center)
    pull = g_trap.sum(axis=0)
    np.testing.assert_allclose(g_wall.sum(axis=0), -pull, atol=1e-5 * np.linalg.norm(pull))


def test_the_wall_energy_reaches_energies_and_load(tmp_path):
    """A cavity's wall term is in RampResult.energies() and in crumple.load (E_wall), and a
    store without a cavity has no E_wall variable."""
    import json

    from crumple.sweep import Sweep, load
    from crumple.sweep.execute import execute_run
    from crumple.sweep.store import _manifest

    wire = Wire(k_b=5, k_s=5e5, n_segments=20, cavity_radius=0.55)
    res = run_ramp(wire, Ramp(lambdas=(0.0, 1.0)), seed=2)
    assert "wall" in res.energies()
    assert (
        "wall"
        not in run_ramp(
            Wire(k_b=5, k_s=5e5, n_segments=20), Ramp(lambdas=(1.0,)), seed=2
        ).energies()
    )
    for radius, has_wall in ((0.55, True), (None, False)):
        out = tmp_path / str(radius)
        (out / "runs").mkdir(parents=True)
        sweep = Sweep(
            wire={"k_b": 5, "k_s": 5e5, "n_segments": 20, "cavity_radius": radius},
            ramp={"lambdas": [0, 1]},
        )
        (out / "sweep.json").write_text(json.dumps(_manifest(sweep)))
        for run in sweep.runs():
            assert execute_run(run.to_task(), str(out))["status"] == "done"
        ds = load(out)
        assert ("E_wall" in ds) is has_wall
        if has_wall:
            assert np.all(np.isfinite(ds["E_wall"].values))
            assert ds["E_wall"].shape == ds["E_total"].shape
