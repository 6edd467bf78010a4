"""Tests of crumple.protocol_coarse: the ramp whose stages start where a coarser wire predicts
(``Ramp(coarsen=m)``).

The prolongation is the same curve; the coarse wire is the same continuum wire; the predicted
start never crosses; every stage of such a ramp is the wire's own equilibrium (converged,
stable by dense LAPACK, uncrossed, no energy rise across an accepted step); what cannot be
predicted is refused; and the plain ramp and its run ids are untouched.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import crumple.protocol as protocol
from crumple.energy import WireEnergy
from crumple.geometry import has_crossings, max_safe_fraction
from crumple.model import Plasticity, Wire
from crumple.protocol import Ramp, initial_state, minimize_wire, run_ramp
from crumple.protocol_coarse import (
    CoarsePath,
    CoarseSummary,
    check_coarsen,
    coarse_path,
    coarse_wire,
    prolong,
)
from crumple.sweep.store import run_id
from test_protocol import _lowest_curvature_per_length, assert_stage_bookkeeping, audited_ramp

CONTINUUM = {"bending": 0.05, "stretching": 5000.0}


def _point_on_segment(p, a, b) -> float:
    """Distance from p to the segment ab."""
    ab = b - a
    t = np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * ab)))


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 12), m=st.integers(1, 6), seed=st.integers(0, 2**32 - 1))
def test_prolong_is_the_same_curve(n, m, seed):
    """Every new point lies on its coarse segment, evenly spaced; the coarse nodes are kept;
    the length is unchanged (to round-off)."""
    x = np.random.default_rng(seed).normal(size=(n, 2))
    p = prolong(x, m)
    assert p.shape == ((n - 1) * m + 1, 2)
    np.testing.assert_array_equal(p[::m], x)
    for k in range(n - 1):
        a, b = x[k], x[k + 1]
        for j in range(1, m):
            q = p[k * m + j]
            assert _point_on_segment(q, a, b) < 1e-12 * (1 + np.abs(x).max())
            assert np.linalg.norm(q - a) == pytest.approx(j / m * np.linalg.norm(b - a))
    length = lambda y: np.linalg.norm(np.diff(y, axis=0), axis=1).sum()  # noqa: E731
    assert length(p) == pytest.approx(length(x), rel=1e-12)


def test_prolong_refuses_what_is_not_a_polyline_or_a_factor():
    with pytest.raises(ValueError, match="polyline"):
        prolong([1.0, 2.0], 2)
    with pytest.raises(ValueError, match="polyline"):
        prolong([[1.0, 2.0]], 2)
    for bad in (0, 2.5, True, "2"):
        with pytest.raises(ValueError, match="integer >= 1"):
            prolong([[0.0, 0.0], [1.0, 0.0]], bad)
        with pytest.raises(ValueError, match="integer >= 1"):
            check_coarsen(Wire(k_b=5, k_s=5e5), bad)
    np.testing.assert_array_equal(
        prolong([[0.0, 0.0], [1.0, 0.0]], 2.0), [[0, 0], [0.5, 0], [1, 0]]
    )


def test_coarse_wire_is_the_same_continuum_wire():
    """B, S, L0, d and the trap are the fine wire's; k_b, k_s and ε scale with the segment."""
    w = Wire.from_continuum(**CONTINUUM, n_segments=600, length=2.0, hard_core=3e-5,
                            hard_core_energy=0.5, trap_center=(0.1, -0.2))  # fmt: skip
    c = coarse_wire(w, 6)
    assert c.n_segments == 100 and c.length == 2.0
    assert c.bending_stiffness == pytest.approx(0.05, rel=1e-14)
    assert c.stretching_stiffness == pytest.approx(5000.0, rel=1e-14)
    assert c.k_b == pytest.approx(w.k_b / 6, rel=1e-14)
    assert c.k_s == pytest.approx(w.k_s / 6, rel=1e-14)
    assert (c.hard_core, c.trap_center) == (3e-5, (0.1, -0.2))
    assert c.hard_core_energy == pytest.approx(0.5 * 6, rel=1e-14)
    assert c.confinement == "per-length"


def _strands(n: int, gap: float, length: float) -> np.ndarray:
    """Two straight strands of n segments of ``length``, ``gap`` apart, joined by a segment of
    length ``gap``: 2 n + 1 segments, every node of one strand facing a node of the other."""
    out = np.c_[np.arange(n + 1) * length, np.zeros(n + 1)]
    return np.vstack([out, np.c_[out[::-1, 0], np.full(n + 1, gap)]])


@pytest.mark.parametrize("per_length", [True, False])
def test_the_coarse_contact_costs_the_fine_energy_per_length(monkeypatch, per_length):
    """Two strands pressed together within the core (the gap 0.4 d, d far below the fine
    segment), at two strand lengths so that the ends and the turn cancel in the difference:
    the fine wire lists m times the coarse wire's node–segment pairs per length, so with ε
    scaled by m (the default) the two wires' hard-core energies per length agree; with ε per
    pair (``CONTACT_PER_LENGTH = False``) the coarse one is m times lower."""
    import crumple.protocol_coarse as pc

    monkeypatch.setattr(pc, "CONTACT_PER_LENGTH", per_length)
    m, d, h = 5, 2e-5, 2e-3  # the coarse segment h, the fine one h / m = 20 d

    def energies(n):
        w = Wire.from_continuum(**CONTINUUM, n_segments=m * (2 * n + 1), hard_core=d)
        coarse = _strands(n, 0.4 * d, h)
        e_fine = WireEnergy(w, 1.0).terms(prolong(coarse, m)).hard_core
        return e_fine, WireEnergy(coarse_wire(w, m), 1.0).terms(coarse).hard_core

    (f1, c1), (f2, c2) = energies(40), energies(100)
    assert f2 - f1 > 0
    ratio = (c2 - c1) / (f2 - f1)
    assert ratio == pytest.approx(1.0 if per_length else 1.0 / m, rel=1e-9)


def test_the_coarse_energy_of_a_smooth_curve_is_the_fine_one():
    """On an arc (constant curvature κ, unstretched), both wires give the continuum energy
    B κ² L / 2 + λ ∫ r² ds up to their discretisation errors: the coarse wire is the same
    physical model."""
    w = Wire.from_continuum(**CONTINUUM, n_segments=400)
    c = coarse_wire(w, 4)
    kappa, lam = 3.0, 50.0
    s = np.linspace(-0.5, 0.5, 401)
    fine = np.c_[np.sin(kappa * s), 1 - np.cos(kappa * s)] / kappa
    coarse = fine[::4]
    exact = 0.05 * kappa**2 / 2 + lam * np.trapezoid((fine**2).sum(axis=1), s)
    e_fine = WireEnergy(w, lam).terms(fine)
    e_coarse = WireEnergy(c, lam).terms(coarse)
    for e in (e_fine, e_coarse):
        assert e.bending + e.confinement == pytest.approx(exact, rel=1e-3)
        assert e.stretching < 1e-6 * exact  # chords of an arc are a little shorter


def test_check_coarsen_refuses_what_it_cannot_predict():
    ok = Wire.from_continuum(**CONTINUUM, n_segments=100)
    check_coarsen(ok, 1)
    check_coarsen(ok, 10)
    check_coarsen(Wire(k_b=5, k_s=5e5, confinement="per-node"), 1)  # the plain ramp: anything
    cases = [
        (ok, 7, "not a multiple"),
        (ok, 50, "2 segments"),
        (ok.replace(confinement="per-node"), 10, "per node"),
        (ok.replace(plasticity=Plasticity(s=0.5, theta_p=0.2)), 10, "plastic"),
        (ok.replace(rest_angle_sd=0.01), 10, "rest angles"),
        (ok.replace(cavity_radius=0.3), 10, "cavity"),
    ]
    for wire, m, why in cases:
        with pytest.raises(ValueError, match=why):
            check_coarsen(wire, m)
        with pytest.raises(ValueError, match=why):
            run_ramp(wire, Ramp(lambdas=(1.0,), coarsen=m), seed=0)


@pytest.mark.parametrize(
    ("kwargs", "why"),
    [
        ({"coarsen": 0}, "integer >= 1"),
        ({"coarsen": 2.5}, "integer >= 1"),
        ({"coarsen": "2"}, "integer >= 1"),
        ({"coarsen": True}, "integer >= 1"),
        ({"coarsen": 2, "method": "powell"}, "method='newton' only"),
        ({"coarsen": 2, "stage_noise": 0.1}, "stage_noise = 0"),
    ],
)
def test_ramp_refuses_a_bad_coarsen(kwargs, why):
    with pytest.raises(ValueError, match=why):
        Ramp(**kwargs)


def test_ramp_takes_any_whole_number_for_coarsen():
    for ok in (1, 3, 3.0, np.int64(3), 10**30, 2**53 + 1):
        assert Ramp(coarsen=ok).coarsen == int(ok) and type(Ramp(coarsen=ok).coarsen) is int


def test_coarsen_round_trips_and_leaves_the_plain_ramps_ids():
    """The parameter is stored with the ramp; at 1 it is left out of the run id (the plain
    ramp's runs keep their ids), and a coarsened ramp is another run."""
    r = Ramp(lambdas=(1.0, 10.0), coarsen=5)
    assert Ramp.from_dict(r.to_dict()) == r and r.to_dict()["coarsen"] == 5
    assert Ramp(coarsen=5.0) == Ramp(coarsen=5)  # a sweep's canonical numbers are floats
    w = Wire.from_continuum(**CONTINUUM, n_segments=100)
    plain = Ramp(lambdas=(1.0, 10.0))
    assert run_id(w, plain, 0, 0) == run_id(w, Ramp(lambdas=(1.0, 10.0), coarsen=1), 0, 0)
    assert run_id(w, plain, 0, 0) != run_id(w, r, 0, 0)


def _hairpin(gap: float) -> np.ndarray:
    """Two parallel strands ``gap`` apart joined by a turn, as a coarse polyline."""
    bottom = np.c_[np.linspace(0.0, 1.0, 6), np.zeros(6)]
    top = np.c_[np.linspace(1.0, 0.0, 6), np.full(6, gap)]
    return np.vstack([bottom, top])


def test_a_start_that_would_cross_is_the_coarse_equilibrium():
    """The fine wire's last equilibrium has a node pushed towards the other strand; the coarse
    wire closes the gap over the stage. Moved as the coarse wire moved, that node would pass
    through the other strand: the stage starts from the coarse curve instead, which does not
    cross. Where the moved start does not cross, it is used."""
    m = 4
    c0, c1 = _hairpin(0.2), _hairpin(0.05)
    path = CoarsePath([c0, c1, c1], m)
    x = path.initial
    assert not has_crossings(x)
    bump = x.copy()
    k = 2 * m + 1  # a node between coarse nodes, on the bottom strand
    assert bump[k, 1] == 0.0
    bump[k, 1] = 0.18  # 0.02 below the top strand, which will come down by 0.15
    assert not has_crossings(bump)
    assert has_crossings(bump + prolong(c1, m) - prolong(c0, m))
    moved, now = path.candidates(0, bump)  # what the start chooses between; counts nothing
    np.testing.assert_array_equal(moved, bump + (prolong(c1, m) - prolong(c0, m)))
    np.testing.assert_array_equal(now, prolong(c1, m))
    assert path.starts == {"moved": 0, "coarse": 0}
    start = path.start(0, bump)
    np.testing.assert_array_equal(start, prolong(c1, m))
    assert path.starts == {"moved": 0, "coarse": 1}
    quiet = path.start(1, start)  # the coarse wire does not move: the start is x itself
    np.testing.assert_array_equal(quiet, start)
    assert path.starts == {"moved": 1, "coarse": 1}


def test_a_coarsened_contact_ramp_reaches_the_wires_own_equilibria():
    """N = 60 predicted by N = 12, into contact (λ up to 2000): every Newton step audited (no
    energy rise beyond resolution, never crossed), every stage converged, uncrossed, and
    stable by dense LAPACK; the stages are the fine wire's (its energy, its number of
    nodes), and contacts were reached."""
    wire = Wire.from_continuum(**CONTINUUM, n_segments=60)
    ramp = Ramp(lambdas=tuple(np.geomspace(1.0, 2000.0, 8)), coarsen=5)
    result, audit = audited_ramp(wire, ramp, seed=3)
    assert audit.violations == [] and audit.steps > 0
    assert result.converged, result.failed_stages
    assert_stage_bookkeeping(result)
    for stage in result.stages:
        assert _lowest_curvature_per_length(wire, stage) >= -protocol.STABILITY_TOL
    assert result.stages[-1].energy.hard_core > 0
    # the coarse ramp ran on 12 segments and drew the initial noise there: the initial state
    # is its prolongation (every fifth node noisy, the others on the segments between)
    x0 = result.initial
    np.testing.assert_array_equal(x0, prolong(x0[::5], 5))
    assert np.abs(x0[::5, 1]).min() > 0


def _plain_reference(wire, ramp, seed):
    """The plain ramp as docs/model.md states it, written out independently of
    ``protocol._run_ramp``: the initial state, then per stage the stage noise (scaled down by
    collision detection), the minimisation, and the early stop measured from the stage's start."""
    rng = np.random.default_rng(seed)
    x = initial_state(wire, ramp.initial_noise, seed=rng)
    out = []
    for i, lam in enumerate(ramp.lambdas):
        if ramp.stage_noise > 0:
            kick = ramp.stage_noise * wire.rest_length * rng.standard_normal(x.shape)
            safe = max_safe_fraction(x, kick)
            x = x + (kick if safe >= 1.0 else 0.5 * safe * kick)
        res = minimize_wire(wire, x, lam, method=ramp.method, ftol=ramp.ftol,
                            maxiter=ramp.maxiter, max_step=ramp.max_step, rng=rng,
                            rtol=ramp.powell_rtol, curved_steps=ramp.curved_steps,
                            fallback=ramp.fallback)  # fmt: skip
        moved = float(np.max(np.hypot(*(res.x - x).T)))
        x = res.x
        out.append(x)
        if ramp.stop_tol is not None and i > 0 and moved < ramp.stop_tol and res.converged:
            break
    return out


@pytest.mark.parametrize(
    "kwargs",
    [{"stage_noise": 0.5, "stop_tol": 0.02}, {"stop_tol": 0.05}, {"stage_noise": 0.3}],
)
def test_the_plain_ramp_is_unchanged(kwargs):
    """With ``coarsen = 1`` (the default) the ramp is the plain protocol bit for bit, its stage
    noise and early stop included (an independent reference loop, not the protocol's code)."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=30)
    ramp = Ramp(lambdas=(1.0, 10.0, 100.0, 110.0, 120.0), **kwargs)
    got = run_ramp(wire, ramp, seed=4)
    want = _plain_reference(wire, ramp, 4)
    assert len(got.stages) == len(want) and got.coarse is None
    for stage, x in zip(got.stages, want, strict=True):
        np.testing.assert_array_equal(stage.positions, x)


def test_the_coarse_ramp_is_the_plain_ramp_of_the_coarse_wire():
    """The coarse ramp draws from the ramp's own stream, keeps its other parameters, and runs
    every stage (its early stop is the wire's, not the coarse wire's): the wire's initial state
    is the coarse ramp's, prolonged, and its summary counts every stage."""
    wire = Wire.from_continuum(**CONTINUUM, n_segments=40)
    lams = (1.0, 1.1, 1.2, 1.3)  # straight: the plain ramp would stop at the second stage
    ramp = Ramp(lambdas=lams, coarsen=4, stop_tol=1e-3, curved_steps=True, fallback="exact")
    seen = []

    def run(w, r, g):
        seen.append(r)
        return protocol._run_ramp(w, r, g, None)

    path = coarse_path(wire, ramp, np.random.default_rng(7), run)
    assert seen == [Ramp(lambdas=lams, coarsen=1, curved_steps=True, fallback="exact")]
    c = coarse_wire(wire, 4)
    plain = run_ramp(c, seen[0], seed=7)
    np.testing.assert_array_equal(path.initial, prolong(plain.initial, 4))
    assert path.summary() == CoarseSummary(
        n_segments=10, stages=4, converged=4,
        iterations=sum(s.result.iterations for s in plain.stages),
        seconds=path.summary().seconds,
    )  # fmt: skip
    result = run_ramp(wire, ramp, seed=7)
    np.testing.assert_array_equal(result.initial, prolong(plain.initial, 4))
    assert result.coarse.stages == 4 and result.coarse.moved + result.coarse.from_coarse == 2
    assert len(result.stages) == 2  # the wire's own early stop


def test_the_coarse_ramp_is_itself_predicted_while_its_wire_keeps_coarsest(monkeypatch):
    """With COARSEST = 10, a wire of 80 segments and coarsen = 2 is predicted by 40, 20 and 10
    segments: each coarse ramp is the coarsened ramp of its wire (the same stream), the
    initial state is the coarsest one's prolonged (straight between every eighth node), and
    the summaries nest. With COARSEST = None only one level runs, the plain coarse ramp."""
    import crumple.protocol_coarse as pc

    wire = Wire.from_continuum(**CONTINUUM, n_segments=80)
    ramp = Ramp(lambdas=(1.0, 30.0), coarsen=2, curved_steps=True)
    monkeypatch.setattr(pc, "COARSEST", 10)
    assert pc.coarse_levels(80, 2) == [40, 20, 10]
    seen = []

    def run(w, r, g):
        seen.append((w.n_segments, r.coarsen))
        return protocol._run_ramp(w, r, g, None)

    path = coarse_path(wire, ramp, np.random.default_rng(3), run)
    assert seen == [(40, 2)]  # the inner levels run inside it
    inner = run_ramp(coarse_wire(wire, 2), Ramp(lambdas=(1.0, 30.0), coarsen=2,
                                                 curved_steps=True), seed=3)  # fmt: skip
    np.testing.assert_array_equal(path.initial, prolong(inner.initial, 2))
    x = path.initial
    for k in range(10):  # the initial noise is drawn at the 10 segments' nodes
        group = x[8 * k : 8 * k + 9]
        u = (group[-1] - group[0]) / np.linalg.norm(group[-1] - group[0])
        off = (group - group[0]) @ np.array([-u[1], u[0]])
        assert np.abs(off).max() < 1e-15
    summary = path.summary()
    assert (summary.n_segments, summary.inner.n_segments, summary.inner.inner.n_segments) == (
        40, 20, 10)  # fmt: skip
    assert summary.inner.inner.inner is None
    assert "itself predicted by the coarse ramp of 20 segments" in str(summary)
    result = run_ramp(wire, ramp, seed=3)
    assert all(s.result.converged for s in result.stages)
    monkeypatch.setattr(pc, "COARSEST", None)
    assert pc.coarse_levels(80, 2) == [40]
    assert coarse_path(wire, ramp, np.random.default_rng(3), run).summary().inner is None


def test_the_coarse_ramps_report_their_stages(monkeypatch):
    """``coarse_progress`` sees every stage of every coarse ramp, the coarsest first, with its
    wire's segments, and changes nothing; the plain ramp never calls it."""
    import crumple.protocol_coarse as pc

    wire = Wire.from_continuum(**CONTINUUM, n_segments=80)
    ramp = Ramp(lambdas=(1.0, 30.0), coarsen=2, curved_steps=True)
    monkeypatch.setattr(pc, "COARSEST", 20)  # levels of 40 and 20 segments
    seen = []

    def coarse(n_segments, i, n, stage):
        seen.append((n_segments, i, n, stage.lam, stage.positions.shape[0]))

    got = run_ramp(wire, ramp, seed=5, coarse_progress=coarse)
    assert seen == [(20, 0, 2, 1.0, 21), (20, 1, 2, 30.0, 21),
                    (40, 0, 2, 1.0, 41), (40, 1, 2, 30.0, 41)]  # fmt: skip
    want = run_ramp(wire, ramp, seed=5)
    for a, b in zip(got.stages, want.stages, strict=True):
        np.testing.assert_array_equal(a.positions, b.positions)
    seen.clear()
    run_ramp(wire, Ramp(lambdas=(1.0, 30.0)), seed=5, coarse_progress=coarse)
    assert seen == []


def test_a_sweep_refuses_a_coarsen_its_wire_cannot_take_before_it_runs():
    """A sweep's [ramp] coarsen is checked against its [wire] with the sweep itself."""
    from crumple.sweep import Sweep

    good = Sweep(wire={"n_segments": 60}, ramp={"lambdas": [1, 2], "coarsen": 5})
    assert next(iter(good.runs())).ramp.coarsen == 5
    with pytest.raises(ValueError, match=r"\[ramp\].*not a multiple"):
        Sweep(wire={"n_segments": 61}, ramp={"lambdas": [1, 2], "coarsen": 5})


def test_stop_tol_measures_from_the_last_equilibrium_not_the_predicted_start():
    """``stop_tol`` means "no node moved more than this between two stages": with a predicted
    start the stage itself moves the wire little (~0.01 here) while the wire moved ~0.2 since
    the last equilibrium, so the ramp must not stop."""
    wire = Wire.from_continuum(**CONTINUUM, n_segments=40)
    lams = (7.696136340726079, 15.194870523363546, 30.0)  # buckled from the first stage on
    r = run_ramp(wire, Ramp(lambdas=lams, coarsen=4, stop_tol=0.05), seed=1)
    assert len(r.stages) == 3
    moved = [np.max(np.hypot(*(b.positions - a.positions).T))
             for a, b in itertools.pairwise(r.stages)]  # fmt: skip
    assert min(moved) > 0.05
    short = run_ramp(wire, Ramp(lambdas=lams, coarsen=4, stop_tol=0.3), seed=1)
    assert len(short.stages) == 2  # stops once a stage moved less than 0.3


def test_the_huge_example_builds_a_coarsened_continuum_ramp():
    """examples/huge.toml (N = 10⁵, too long for the suite) is read as ``crumple run`` reads
    it: the continuum wire, a tenth-of-a-segment hard core, and a coarse wire of 10⁴
    segments that the checks accept."""
    import argparse
    from pathlib import Path

    from crumple.cli import run as cli_run

    path = Path(__file__).resolve().parents[1] / "examples" / "huge.toml"
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    cli_run.register(sub)
    args = parser.parse_args(["run", "--config", str(path)])
    built = cli_run.build_run(args)
    wire, ramp = built[0], built[1]
    assert wire.n_segments == 100_000 and wire.hard_core <= 0.1 / wire.n_segments
    assert ramp.coarsen == 10 and ramp.curved_steps
    check_coarsen(wire, ramp.coarsen)
    c = coarse_wire(wire, ramp.coarsen)
    assert c.n_segments == 10_000 and c.hard_core == wire.hard_core
    assert c.bending_stiffness == pytest.approx(0.05, rel=1e-12)
