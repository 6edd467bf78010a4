"""Tests of crumple.protocol: the quasi-static ramp's invariants over the paper's Table 1
ranges (hypothesis), the default ramp, determinism and replicas, buckling of the straight
wire, and convergence of a continuum-parameter ramp with N.

The descent invariant allows a rise of at most ``resolution(E) = 16 ε_mach |E|`` per accepted
Newton step: that is the floating-point resolution of the energy value (below it the solver
decides by the force, Hager & Zhang's approximate Wolfe condition), not a physical tolerance.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import crumple.protocol as protocol
import crumple.relax as relax
from crumple.energy import WireEnergy
from crumple.geometry import find_crossings, has_crossings, max_safe_fraction
from crumple.minimize import MinimizeResult, max_force, resolution
from crumple.model import Plasticity, Wire
from crumple.protocol import (
    PAPER_LAMBDAS,
    Ramp,
    RampResult,
    default_schedule,
    initial_state,
    minimize_wire,
    replica_seeds,
    run_ramp,
    run_replicas,
)

# --------------------------------------------------------------------------------------------
# An audit of every accepted Newton step, wrapped around the solver the protocol calls
# --------------------------------------------------------------------------------------------


class StepAudit:
    """Replaces ``crumple.relax.newton`` by the real solver plus a callback that checks, at
    every accepted step, that the energy did not rise beyond its resolution and that the wire
    does not cross itself (exact test)."""

    def __init__(self):
        self.real = relax.newton
        self.steps = 0
        self.calls = 0
        self.violations: list[str] = []

    def __call__(self, fun, x0, callback=None, **kwargs):
        user = callback  # minimize_wire's own (None unless its caller gave one): still called
        self.calls += 1
        last = [fun(x0)[0]]

        def audit(it, x, e, fmax):
            self.steps += 1
            if e > last[0] + resolution(last[0]):
                self.violations.append(f"call {self.calls} step {it}: E {last[0]!r} -> {e!r}")
            crossings = find_crossings(x)
            if crossings.size:
                self.violations.append(
                    f"call {self.calls} step {it}: crossings {crossings.tolist()}"
                )
            last[0] = e
            if user is not None:
                user(it, x, e, fmax)

        return self.real(fun, x0, callback=audit, **kwargs)


def audited_ramp(wire, ramp, seed):
    audit = StepAudit()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(relax, "newton", audit)
        result = run_ramp(wire, ramp, seed=seed)
    return result, audit


def assert_stage_bookkeeping(result: RampResult):
    """Every stage: crossing-free, its energy record consistent with its positions and with
    the minimiser's result, and an honest convergence flag."""
    wire = result.wire
    for stage in result.stages:
        assert not has_crossings(stage.positions)
        assert stage.positions.shape == (wire.n_nodes, 2)
        terms = WireEnergy(wire, stage.lam).terms(stage.positions)
        assert stage.energy == terms
        assert stage.energy.total == pytest.approx(stage.result.energy, rel=1e-12)
        assert isinstance(stage.result, MinimizeResult)
        if stage.result.converged:  # the documented criterion: ftol, or the force resolution
            # when ftol is below it (a deep contact's stiffness times one ulp), and then said so
            r = stage.result
            assert r.max_force <= r.ftol or (
                r.max_force <= r.force_resolution and "force resolution" in r.message
            )
        else:
            assert stage.result.message
        np.testing.assert_array_equal(stage.result.x, stage.positions)
    failed = {lam for lam, _ in result.failed_stages}
    assert failed == {s.lam for s in result.stages if not s.result.converged}
    assert result.converged == (not failed)
    assert all(msg for _, msg in result.failed_stages)


def assert_quasi_static_descent(result: RampResult):
    """Raising λ from λ_k to λ_{k+1} at fixed shape costs (λ_{k+1} - λ_k) Σ w r^2; the
    minimiser then only lowers the energy: E_{k+1} <= E(x_k; λ_{k+1}) (+ resolution)."""
    previous = result.initial
    for stage in result.stages:
        start = WireEnergy(result.wire, stage.lam)(previous)[0]
        assert stage.energy.total <= start + resolution(start)
        previous = stage.positions


# --------------------------------------------------------------------------------------------
# Invariants over Table 1's ranges (hypothesis)
# --------------------------------------------------------------------------------------------

table_1 = {
    "k_b": st.floats(1.0, 10.0),
    "log_k_s": st.floats(4.0, 7.0),
    "n_segments": st.integers(20, 40),
    "confinement": st.sampled_from(["per-node", "per-length"]),
    "plasticity": st.one_of(
        st.none(),
        st.builds(Plasticity, s=st.floats(0.0, 1.0), theta_p=st.floats(0.05, 1.0)),
    ),
    "n_stages": st.integers(4, 6),
    "stage_noise": st.sampled_from([0.0, 0.0, 0.2]),
    "seed": st.integers(0, 2**32 - 1),
}


@settings(
    max_examples=80,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(**table_1)
def test_ramp_never_crosses_and_no_accepted_step_raises_the_energy(
    k_b, log_k_s, n_segments, confinement, plasticity, n_stages, stage_noise, seed
):
    wire = Wire(
        k_b=k_b, k_s=10.0**log_k_s, n_segments=n_segments, confinement=confinement,
        plasticity=plasticity,
    )  # fmt: skip
    ramp = Ramp(
        lambdas=tuple(np.geomspace(1.0, 2000.0, n_stages)), stage_noise=stage_noise, maxiter=150
    )
    result, audit = audited_ramp(wire, ramp, seed)
    assert audit.calls == n_stages
    assert audit.steps > 0
    assert not audit.violations, audit.violations[:5]
    assert not has_crossings(result.initial)
    assert_stage_bookkeeping(result)
    if stage_noise == 0:
        assert_quasi_static_descent(result)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), amplitude=st.floats(0.1, 3.0))
def test_stage_noise_kick_never_crosses(seed, amplitude):
    """The protocol's random kick, cut by continuous collision detection, on a folded wire
    (the final stage of a short ramp) where a blind kick would often cross."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=24, confinement="per-node")
    x = _folded_wire()
    rng = np.random.default_rng(seed)
    kick = amplitude * wire.rest_length * rng.standard_normal(x.shape)
    safe = max_safe_fraction(x, kick)
    moved = x + (kick if safe >= 1.0 else 0.5 * safe * kick)  # as run_ramp does
    assert not has_crossings(moved)
    assert WireEnergy(wire, 1000.0)(moved)[0] < math.inf


_FOLDED: list[np.ndarray] = []


def _folded_wire() -> np.ndarray:
    if not _FOLDED:
        wire = Wire(k_b=5, k_s=5e5, n_segments=24, confinement="per-node")
        _FOLDED.append(
            run_ramp(wire, Ramp(lambdas=(1, 30, 300, 1000)), seed=3).stages[-1].positions
        )
    return _FOLDED[0]


# --------------------------------------------------------------------------------------------
# The default ramp (N = 100, k_b = 5, k_s = 5e5, 44 stages)
# --------------------------------------------------------------------------------------------


def test_default_ramp_converges_at_every_stage():
    wire = Wire(k_b=5, k_s=5e5)
    result = run_ramp(wire, seed=0)
    assert len(result.stages) == 44
    np.testing.assert_array_equal(result.lambdas, default_schedule())
    assert result.converged, result.failed_stages
    assert result.failed_stages == []
    for stage in result.stages:
        assert stage.result.max_force <= 1e-6
    assert_stage_bookkeeping(result)
    assert_quasi_static_descent(result)
    for lam in PAPER_LAMBDAS:
        assert result.at(lam).lam == lam
    energies = result.energies()
    assert set(energies) == {"bending", "stretching", "confinement", "hard_core", "total"}
    assert all(v.shape == (44,) for v in energies.values())
    # the wire did crumple: it bent and shrank far below its length
    final = result.stages[-1].positions
    assert energies["bending"][-1] > 1.0
    assert np.max(np.hypot(*(final - final.mean(axis=0)).T)) < 0.3


def test_curved_steps_keep_a_contact_ramp_at_true_equilibria(monkeypatch):
    """With curved trial points a contact ramp ends every stage converged and stable, never
    crossing, no accepted step raising the energy, and some accepted steps are curved (before
    contacts act); with them off none are. With fixed nodes they are never used."""
    wire, lams = Wire(k_b=5, k_s=5e5), (1.0, 7.0, 100.0, 300.0, 1000.0, 2000.0)
    on, audit = audited_ramp(wire, Ramp(lambdas=lams, curved_steps=True), seed=2)
    assert on.converged and not audit.violations, audit.violations[:5]
    assert sum(s.result.curved_steps for s in on.stages) > 0
    assert on.stages[-1].energy.hard_core > 0
    assert_stage_bookkeeping(on)
    off = run_ramp(wire, Ramp(lambdas=lams, curved_steps=False), seed=2)
    assert off.converged and all(s.result.curved_steps == 0 for s in off.stages)
    monkeypatch.setattr(relax, "CURVED_STEPS", True)
    fixed = np.zeros(wire.n_nodes, dtype=bool)
    fixed[0] = True
    r = relax.minimize_wire(wire, on.stages[1].positions, 30.0, fixed=fixed)
    assert r.converged and r.curved_steps == 0


def test_approach_cut_keeps_a_contact_ramp_at_true_equilibria(monkeypatch):
    """The approach cut (``relax.APPROACH_ABOVE``, off by default) at N = 100: a contact ramp
    still ends every stage converged and stable, never crossing, no accepted step raising
    the energy; and cut steps are taken past 0.8 of their contact."""
    monkeypatch.setattr(relax, "APPROACH_ABOVE", 0)
    further = []
    approach = relax._approach

    def counted(x, p, safe, gap):
        s = approach(x, p, safe, gap)
        further.append(s > 0.8 * safe)
        return s

    monkeypatch.setattr(relax, "_approach", counted)
    wire, lams = Wire(k_b=5, k_s=5e5), (1.0, 7.0, 100.0, 300.0, 1000.0, 2000.0)
    on, audit = audited_ramp(wire, Ramp(lambdas=lams), seed=2)
    assert on.converged and not audit.violations, audit.violations[:5]
    assert on.stages[-1].energy.hard_core > 0
    assert sum(further) > 0


def test_approach_cut_leaves_a_cut_by_the_wall_alone():
    """In a cavity, a step that the wall cuts (node 2 leaves the disc at t = 0.46) while a
    pair closes in (node 4 reaches segment 0 at 0.5, and is within the gap at 0.46) keeps the
    default cut: the approach is a pair's, not the wall's. Without the wall, the same pair
    gives the approach fraction (node 4 at d + skin / 2 = 0.1125 above segment 0)."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=4, cavity_radius=1.5, hard_core=0.1)
    x = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.5, 1.0], [0.5, 0.5]])
    p = np.zeros_like(x)
    p[4] = [0.0, -1.0]
    p[2] = [0.1319, 0.1319]
    safe = relax._step_limit(1.5)(x, p)
    assert safe == pytest.approx(0.46, abs=1e-3)
    energy = WireEnergy(wire, 1.0)
    assert relax._approach_cut(wire, energy)(x, p, safe) == 0.0
    free = dataclasses.replace(wire, cavity_radius=None)
    assert relax._approach_cut(free, WireEnergy(free, 1.0))(x, p, safe) == pytest.approx(0.3875)


def test_exact_fallback_keeps_a_contact_ramp_at_true_equilibria():
    """The exact fallback with the σ search (``Ramp(fallback="exact")``, the default above
    ``relax.EXACT_FALLBACK_ABOVE`` segments) at N = 100: a contact ramp still ends every stage
    converged and stable, never crossing, no accepted step raising the energy, and it does
    factorise more (the σ search) than the projected fallback, N = 100's default."""
    wire, lams = Wire(k_b=5, k_s=5e5), (1.0, 7.0, 100.0, 300.0, 1000.0, 2000.0)
    off = run_ramp(wire, Ramp(lambdas=lams), seed=2)
    assert Ramp(lambdas=lams).fallback == "auto"
    assert [s.result.iterations for s in off.stages] == [
        s.result.iterations for s in run_ramp(wire, Ramp(lambdas=lams, fallback="projected"),
                                              seed=2).stages
    ]  # fmt: skip
    on, audit = audited_ramp(wire, Ramp(lambdas=lams, fallback="exact"), seed=2)
    assert on.converged and not audit.violations, audit.violations[:5]
    assert on.stages[-1].energy.hard_core > 0
    assert_stage_bookkeeping(on)
    per_it = [sum(s.result.factorizations for s in r.stages)
              / sum(s.result.iterations for s in r.stages) for r in (off, on)]  # fmt: skip
    assert per_it[1] > per_it[0]


def test_caps_fallback_keeps_a_contact_ramp_at_true_equilibria():
    """The fallback "caps" (the exact Hessian with the blocks of the pairs at a segment's end
    projected, shifted by σM and searched down like "exact") at N = 100: a contact ramp ends
    every stage converged and stable, never crossing, no accepted step raising the energy, on
    a path of its own (the exact fallback's stages take other iteration counts)."""
    wire, lams = Wire(k_b=5, k_s=5e5), (1.0, 7.0, 100.0, 300.0, 1000.0, 2000.0)
    on, audit = audited_ramp(wire, Ramp(lambdas=lams, fallback="caps"), seed=2)
    assert on.converged and not audit.violations, audit.violations[:5]
    assert on.stages[-1].energy.hard_core > 0
    assert_stage_bookkeeping(on)
    exact = run_ramp(wire, Ramp(lambdas=lams, fallback="exact"), seed=2)
    assert [s.result.iterations for s in on.stages] != [s.result.iterations for s in exact.stages]


def test_each_fallback_gives_newton_its_own_hessian_and_shift_search():
    """``minimize_wire(fallback=...)``'s wiring (``relax._newton_options``): "exact" hands
    Newton H itself (the very object, so that it is not assembled twice) with the σ search,
    "caps" the Hessian with the caps projected with the σ search, "projected" every contact
    projected without it; on a wire in contact at both kinds of pair the three differ."""
    import crumple.relax as rx

    m = 7
    seg = 1.0 / (2 * m)
    wire = Wire(k_b=1, k_s=1e3, n_segments=2 * m, hard_core=0.3 * seg, hard_core_energy=1.0)
    # a hairpin, its upper strand 0.12 segments above the lower one and a tenth of a segment
    # off its nodes: each upper node faces a segment's middle and a joint's cap
    lower = np.c_[np.arange(m + 1) * seg, np.zeros(m + 1)]
    upper = np.c_[(m - 0.1 - np.arange(m)) * seg, np.full(m, 0.12 * seg)]
    x = np.vstack([lower, upper])
    energy = WireEnergy(wire, 10.0)
    kw = {f: rx._newton_options(wire, energy, None, f, False, True)
          for f in ("exact", "caps", "projected")}  # fmt: skip
    assert kw["exact"]["hess_fallback"] is kw["exact"]["hess"]
    assert kw["caps"]["hess_fallback"] is not kw["caps"]["hess"]
    assert kw["exact"]["shift_descents"] == kw["caps"]["shift_descents"] == rx.EXACT_SHIFT_DESCENTS
    assert kw["projected"]["shift_descents"] == 0
    data = {f: kw[f]["hess_fallback"](x).data for f in kw}
    expect = {"exact": False, "caps": "caps", "projected": True}
    for f, p in expect.items():
        np.testing.assert_array_equal(data[f], energy.hessian_csc(x, project_contacts=p).data)
    assert not np.array_equal(data["caps"], data["exact"])
    assert not np.array_equal(data["caps"], data["projected"])
    with pytest.raises(ValueError, match="fallback"):
        rx._newton_options(wire, energy, None, "auto", False, True)


def test_default_schedule():
    s = default_schedule()
    assert len(s) == 44
    assert s[0] == 1.0 and s[-1] == 2000.0
    assert all(b > a for a, b in itertools.pairwise(s))
    assert set(PAPER_LAMBDAS) <= set(s)
    assert default_schedule(1, 10, 5, include=()) == pytest.approx(tuple(np.geomspace(1, 10, 5)))
    with pytest.raises(ValueError):
        default_schedule(10, 1)


# --------------------------------------------------------------------------------------------
# Buckling: the straight wire is a saddle above the threshold
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n_segments", [100, 400])  # dense Hessian, then sparse (> 800 dof)
def test_straight_wire_buckles_above_threshold_and_not_below(n_segments):
    """B = 0.05, S = 5000, per length. A perfectly straight wire is an equilibrium at every λ
    (forces along the wire only); it must stay straight at λ = 2 and buckle at λ = 20, where
    straight is a saddle. This exercises the solver's escape along negative curvature."""
    wire = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=n_segments)
    straight = initial_state(wire, noise=0.0)
    low = minimize_wire(wire, straight, 2.0)
    assert low.converged, low.message
    assert WireEnergy(wire, 2.0).terms(low.x).bending == pytest.approx(0.0, abs=1e-20)
    high = minimize_wire(wire, straight, 20.0)
    assert high.converged, high.message
    terms = WireEnergy(wire, 20.0).terms(high.x)
    assert terms.bending > 0.1
    assert high.energy < WireEnergy(wire, 20.0)(straight)[0]
    assert not has_crossings(high.x)


# --------------------------------------------------------------------------------------------
# Continuum limit: refining N at fixed (B, S) converges
# --------------------------------------------------------------------------------------------


def test_continuum_ramp_converges_with_n():
    """B = 0.05, S = 5000, per-length confinement, λ up to 20 (buckled, no contacts yet).
    Final equilibrium energy at N = 200 and 400 must agree within 1%. Measured when this test
    was written: relative change 2.8e-5 from 200 to 400 and 1.1e-4 from 100 to 200, a ratio
    of 4 (second order, as the trapezoid and the discrete curvature are). Check that too."""
    ramp = Ramp(lambdas=tuple(np.geomspace(1.0, 20.0, 8)))
    energies = {}
    for n in (100, 200, 400):
        wire = Wire.from_continuum(
            bending=0.05, stretching=5000.0, n_segments=n, confinement="per-length"
        )
        result = run_ramp(wire, ramp, seed=0)
        assert result.converged, result.failed_stages
        final = result.stages[-1].energy
        assert final.hard_core == 0.0  # before contacts
        assert final.bending > 0.1  # after buckling
        energies[n] = final.total
    change = abs(energies[400] - energies[200]) / energies[400]
    assert change < 0.01
    ratio = abs(energies[200] - energies[100]) / abs(energies[400] - energies[200])
    assert 3.0 < ratio < 5.0, (energies, ratio)


# --------------------------------------------------------------------------------------------
# Determinism and replicas
# --------------------------------------------------------------------------------------------

SMALL = Wire(k_b=5, k_s=5e5, n_segments=24)
SHORT = Ramp(lambdas=(1.0, 10.0, 100.0, 1000.0))


def test_same_seed_same_result():
    a = run_ramp(SMALL, SHORT, seed=11)
    b = run_ramp(SMALL, SHORT, seed=11)
    np.testing.assert_array_equal(a.initial, b.initial)
    for sa, sb in zip(a.stages, b.stages, strict=True):
        np.testing.assert_array_equal(sa.positions, sb.positions)
    c = run_ramp(SMALL, SHORT, seed=np.random.default_rng(11))
    np.testing.assert_array_equal(c.stages[-1].positions, a.stages[-1].positions)


def test_same_seed_same_result_with_stage_noise():
    ramp = dataclasses.replace(SHORT, stage_noise=0.3)
    a = run_ramp(SMALL, ramp, seed=5)
    b = run_ramp(SMALL, ramp, seed=5)
    for sa, sb in zip(a.stages, b.stages, strict=True):
        np.testing.assert_array_equal(sa.positions, sb.positions)


def test_replicas_do_not_depend_on_the_number_of_workers():
    serial = run_replicas(SMALL, SHORT, n_replicas=3, seed=4, workers=1)
    parallel = run_replicas(SMALL, SHORT, n_replicas=3, seed=4, workers=2)
    assert len(serial) == len(parallel) == 3
    for a, b in zip(serial, parallel, strict=True):
        np.testing.assert_array_equal(a.initial, b.initial)
        for sa, sb in zip(a.stages, b.stages, strict=True):
            np.testing.assert_array_equal(sa.positions, sb.positions)
    # replica r is run_ramp seeded with SeedSequence(seed).spawn(n)[r]
    seeds = replica_seeds(4, 3)
    alone = run_ramp(SMALL, SHORT, seed=np.random.default_rng(seeds[1]))
    np.testing.assert_array_equal(alone.stages[-1].positions, serial[1].stages[-1].positions)


def test_replicas_with_different_seeds_differ():
    reps = run_replicas(SMALL, SHORT, n_replicas=3, seed=4, workers=1)
    for i in range(3):
        for j in range(i + 1, 3):
            assert not np.allclose(reps[i].initial, reps[j].initial)
            assert (
                np.max(np.abs(reps[i].stages[-1].positions - reps[j].stages[-1].positions)) > 1e-3
            )
    other = run_replicas(SMALL, SHORT, n_replicas=1, seed=5, workers=1)[0]
    assert not np.allclose(other.initial, reps[0].initial)


def test_replica_seeds_are_independent_streams():
    seeds = replica_seeds(7, 4)
    assert [s.spawn_key for s in seeds] == [(0,), (1,), (2,), (3,)]
    draws = [np.random.default_rng(s).random(5) for s in seeds]
    assert len({tuple(d) for d in draws}) == 4
    with pytest.raises(ValueError):
        replica_seeds(7, 0)


# --------------------------------------------------------------------------------------------
# Ramp options, the initial state, and input checks
# --------------------------------------------------------------------------------------------


def test_initial_state_is_a_straight_centred_wire_with_transverse_noise():
    wire = Wire(k_b=5, k_s=5e5, n_segments=50, trap_center=(0.3, -0.2))
    x0 = initial_state(wire, noise=0.0)
    np.testing.assert_allclose(x0[:, 0], np.linspace(-0.5, 0.5, 51) + 0.3, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(x0[:, 1], -0.2)
    x = initial_state(wire, noise=0.1, seed=3)
    np.testing.assert_array_equal(x[:, 0], x0[:, 0])  # transverse only
    dy = x[:, 1] + 0.2
    assert 0.03 * wire.rest_length < dy.std() < 0.3 * wire.rest_length
    np.testing.assert_array_equal(x, initial_state(wire, noise=0.1, seed=3))
    assert not has_crossings(initial_state(wire, noise=0.49, seed=1))
    for bad in (-0.1, 0.5, math.nan):
        with pytest.raises(ValueError, match="noise"):
            initial_state(wire, noise=bad)


def test_stop_when_the_structure_no_longer_changes():
    result = run_ramp(SMALL, dataclasses.replace(SHORT, stop_tol=10.0), seed=1)
    assert len(result.stages) == 2  # the second stage moved less than 10: stop there
    full = run_ramp(SMALL, dataclasses.replace(SHORT, stop_tol=1e-12), seed=1)
    assert len(full.stages) == 4


def test_progress_is_reported_for_every_stage():
    seen = []
    run_ramp(SMALL, SHORT, seed=2, progress=lambda i, n, stage: seen.append((i, n, stage.lam)))
    assert seen == [(i, 4, lam) for i, lam in enumerate(SHORT.lambdas)]


def test_at_unknown_lambda_raises():
    result = run_ramp(SMALL, Ramp(lambdas=(1.0, 2.0)), seed=0)
    with pytest.raises(KeyError):
        result.at(3.0)


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"lambdas": (10, 1)}, "increasing"),
        ({"lambdas": (1, 1)}, "increasing"),
        ({"lambdas": ()}, "empty"),
        ({"lambdas": (-1, 1)}, "lambdas"),
        ({"lambdas": (1, math.inf)}, "lambdas"),
        ({"lambdas": ("a",)}, "lambdas"),
        ({"initial_noise": -0.1}, "initial_noise"),
        ({"stage_noise": math.nan}, "stage_noise"),
        ({"stop_tol": 0.0}, "stop_tol"),
        ({"method": "lbfgs"}, "method"),
        ({"ftol": 0.0}, "ftol"),
        ({"maxiter": 0}, "maxiter"),
        ({"max_step": -1.0}, "max_step"),
        ({"curved_steps": "yes"}, "curved_steps"),
        ({"curved_steps": True, "method": "powell"}, "curved_steps"),
        ({"fallback": "modified"}, "fallback"),
        ({"fallback": "exact", "method": "powell"}, "fallback"),
    ],
)
def test_ramp_validation(kwargs, word):
    with pytest.raises(ValueError, match=word):
        Ramp(**kwargs)


def test_ramp_round_trip():
    ramp = Ramp(lambdas=(1, 10), stage_noise=0.1, method="powell")
    assert Ramp.from_dict(ramp.to_dict()) == ramp
    with pytest.raises(ValueError, match="unknown"):
        Ramp.from_dict({"lambda": (1, 2)})


def test_ramp_records_the_curved_steps_switch(monkeypatch):
    """The switch is resolved when the Ramp is made, so that the run id and the sweep
    workers (which rebuild the Ramp from its dict) hold it; Powell never takes curved steps.
    Off is the value of the runs before the switch existed: it leaves their ids unchanged."""
    from crumple.sweep.store import run_id

    wire = Wire(k_b=5, k_s=5e5, n_segments=20)
    monkeypatch.setattr(relax, "CURVED_STEPS", True)
    on = Ramp(lambdas=(1, 10))
    assert on.curved_steps is True and Ramp(method="powell").curved_steps is False
    monkeypatch.setattr(relax, "CURVED_STEPS", False)
    off = Ramp(lambdas=(1, 10))
    assert off.curved_steps is False
    assert Ramp.from_dict(on.to_dict()).curved_steps is True  # not the module's value now
    assert run_id(wire, on, 0, 0) != run_id(wire, off, 0, 0)
    legacy = {k: v for k, v in off.to_dict().items() if k != "curved_steps"}
    assert "curved_steps" not in legacy and Ramp.from_dict(legacy) == off
    assert run_id(wire, Ramp.from_dict(legacy), 0, 0) == run_id(wire, off, 0, 0)
    r = run_ramp(wire, Ramp(lambdas=(1.0, 30.0), curved_steps=True), seed=0)
    assert r.converged and sum(s.result.curved_steps for s in r.stages) > 0


def test_the_curved_point_is_offered_only_for_turns_below_the_bound():
    """A step that turns some segment by more than ``relax.CURVED_MAX_TURN`` (radians, the
    linearised δφ = e × δe/|e|²) gets no curved point: there the linearised turn is no
    approximation of the step (a jagged step of a noisy long wire turned segments by hundreds
    of radians). Below it the point is :func:`crumple.geometry.curved_step`'s."""
    from crumple.geometry import curved_step
    from crumple.geometry.curved import _largest_turn

    wire = Wire(k_b=5, k_s=5e5, n_segments=10)
    x = np.c_[np.linspace(-0.5, 0.5, 11), np.zeros(11)]
    p = np.zeros_like(x)
    p[5, 1] = 0.1  # node 5 moves up by a segment length: its segments turn by 1 rad (± ulp)
    assert _largest_turn(x, p, 1.0) == pytest.approx(1.0)
    assert _largest_turn(x, p, 0.5) == pytest.approx(0.5)
    retract = relax._curved_retraction(WireEnergy(wire, lam=1.0))
    below, above = 0.5 * relax.CURVED_MAX_TURN, 1.5 * relax.CURVED_MAX_TURN
    np.testing.assert_array_equal(retract(x, p, below), curved_step(x, p, below))
    assert retract(x, p, above) is None


def test_minimize_wire_input_checks():
    crossing = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, -1]], dtype=float)
    wire = Wire(k_b=1, k_s=1e4, n_segments=4)
    with pytest.raises(ValueError, match="crosses"):
        minimize_wire(wire, crossing, 1.0)
    with pytest.raises(ValueError, match="shape"):
        minimize_wire(wire, np.zeros((3, 2)), 1.0)
    straight = initial_state(wire, noise=0.0)
    with pytest.raises(ValueError, match="rng"):
        minimize_wire(wire, straight, 1.0, method="powell")
    with pytest.raises(ValueError, match="method"):
        minimize_wire(wire, straight, 1.0, method="fire")


@pytest.mark.parametrize("lam", [0.0, 50.0])
def test_a_clamped_end_stays_clamped(lam):
    """Two end nodes fixed (a clamped end) in a trap whose centre pulls the wire away: they do
    not move by one bit, the rest reaches equilibrium, and the clamp carries the reaction."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=20, trap_center=(0.3, 0.2))
    x0 = initial_state(wire, seed=4) - np.asarray(wire.trap_center)  # the wire off centre
    x0[:, 1] += 0.05 * np.sin(np.pi * np.linspace(0, 1, wire.n_nodes))  # and bent
    fixed = np.zeros(wire.n_nodes, dtype=bool)
    fixed[:2] = True
    r = minimize_wire(wire, x0, lam, fixed=fixed)
    assert r.converged, r.message
    np.testing.assert_array_equal(r.x[:2], x0[:2])
    assert not has_crossings(r.x)
    g = WireEnergy(wire, lam)(r.x)[1]
    assert np.max(np.hypot(*g[2:].T)) <= 1e-6
    if lam > 0:
        assert np.max(np.hypot(*g[:2].T)) > 1e-3  # the clamp holds the wire against the trap
        assert np.max(np.abs(r.x[2:] - x0[2:])) > 0.01
    with pytest.raises(ValueError, match="newton"):
        minimize_wire(wire, x0, lam, fixed=fixed, method="powell", rng=np.random.default_rng(0))


def test_powell_ramp_on_a_small_wire():
    """The paper's method: slow and short of equilibrium, but typed, crossing-free, never
    above the energy it started each stage from. Its infeasible probes (crossings, energy
    +inf) must not spill floating-point warnings (the project turns warnings into errors)."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=10)
    result = run_ramp(wire, Ramp(lambdas=(1.0, 100.0, 2000.0), method="powell", maxiter=5), seed=0)
    assert all(s.result.method == "powell" for s in result.stages)
    assert all(math.isfinite(s.result.max_force) for s in result.stages)
    assert_stage_bookkeeping(result)
    assert_quasi_static_descent(result)


def test_imperfect_wires_give_genuinely_different_replicas():
    """A perfect wire's quasi-static path is unique up to mirror images (docs/model.md);
    quenched rest-angle disorder makes replicas differ, reproducibly."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=40, rest_angle_sd=0.02)
    ramp = Ramp(lambdas=(1, 30, 300, 1000))
    a = run_replicas(wire, ramp, n_replicas=3, seed=11)
    b = run_replicas(wire, ramp, n_replicas=3, seed=11)
    for ra, rb in zip(a, b, strict=True):
        assert ra.converged, ra.failed_stages
        np.testing.assert_array_equal(ra.rest_angles, rb.rest_angles)
        np.testing.assert_array_equal(ra.stages[-1].positions, rb.stages[-1].positions)
    energies = [r.stages[-1].energy.total for r in a]
    assert len(set(np.round(energies, 9))) == 3
    assert np.std(energies) / np.mean(energies) > 1e-3
    # the rest angles are the replica's own draw, of the requested spread
    rest = np.concatenate([r.rest_angles for r in a])
    assert 0.01 < rest.std() < 0.03


def test_perfect_wire_draws_no_rest_angles():
    r = run_ramp(Wire(k_b=5, k_s=5e5, n_segments=20), Ramp(lambdas=(1, 10)), seed=0)
    assert r.rest_angles is None


# --------------------------------------------------------------------------------------------
# The engine at scale (issue 9): N-independent iterations, stability in physical units
# --------------------------------------------------------------------------------------------

CONTINUUM = {"bending": 0.05, "stretching": 5000.0}
SMOOTH = Ramp(lambdas=tuple(np.geomspace(1.0, 30.0, 12)))


def test_newton_iterations_do_not_grow_with_n():
    """The same smooth stages at N = 100 and 2000 (before contacts): the trust radius is a
    length, so a finer wire takes about as many steps. Measured: 137 and 158 iterations
    (the landed engine, with its cap of half a segment: 25 / 200 per stage at N = 100 / 1000)."""
    totals = {}
    for n in (100, 2000):
        wire = Wire.from_continuum(**CONTINUUM, n_segments=n)
        result = run_ramp(wire, SMOOTH, seed=0)
        assert result.converged, result.failed_stages
        totals[n] = sum(s.result.iterations for s in result.stages)
    assert totals[2000] <= 2 * totals[100], totals


def _first_buckled_stage(n):
    wire = Wire.from_continuum(**CONTINUUM, n_segments=n)
    result = run_ramp(wire, Ramp(lambdas=SMOOTH.lambdas[:8]), seed=0)
    assert result.converged, result.failed_stages
    bent = [s.energy.bending > 1e-3 for s in result.stages]
    first = bent.index(True)
    assert all(bent[first:])
    assert all(s.energy.bending < 1e-5 for s in result.stages[:first])
    return first


def test_straight_wire_buckles_at_the_same_stage_at_every_n():
    """The Euler load is a property of the continuum wire: the straight wire must be rejected
    as a saddle at the same λ whatever N (the landed engine accepted it up to λ = 40.6 at
    N = 10⁴, whose stability threshold scaled with the largest diagonal entry)."""
    stages = {n: _first_buckled_stage(n) for n in (100, 2000, 10_000)}
    assert len(set(stages.values())) == 1, stages
    assert 0 < stages[100] < 8


@pytest.mark.slow
def test_the_straight_wire_buckles_on_time_where_the_assembled_mode_is_round_off():
    """At N = 2 × 10⁴ (~20 s) the assembled Hessian's lowest mode at the buckling saddle is
    round-off: no step along it lowers the energy, and the engine stopped there with
    "negative curvature that no step lowers" (the wire then buckled a stage late). Now its
    steps are the accurate product's (truncated CG, ``minimize_krylov``), and with the
    factor's steps the escape takes the accurate product's mode where the assembled one's
    fails (the ninth stop's rescue): either way the wire buckles at the stage of every
    smaller N."""
    import crumple.minimize_krylov as mk

    wire = Wire.from_continuum(**CONTINUUM, n_segments=20_000)
    result = run_ramp(wire, Ramp(lambdas=SMOOTH.lambdas[:8]), seed=0)
    assert result.converged, result.failed_stages
    first = [s.energy.bending > 1e-3 for s in result.stages].index(True)
    assert first == _first_buckled_stage(100)
    assert result.stages[first].result.krylov_iterations > 0
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(mk, "ACCURATE_STEPS", False)
        rescued = run_ramp(wire, Ramp(lambdas=SMOOTH.lambdas[: first + 1]), seed=0)
    assert rescued.converged, rescued.failed_stages
    assert rescued.stages[first].energy.bending > 1e-3
    assert "along the accurate Hessian product's mode" in rescued.stages[first].result.message


def test_a_stage_at_the_force_resolution_is_polished_in_the_displacement(monkeypatch):
    """N = 2000, ftol = 10⁻⁹: below what float64 positions resolve (~4 × 10⁻⁶ there), so Newton
    stops "converged to the force resolution" at ~10⁻⁶. The polish, Newton again in the
    displacement from that point with the elastic forces from the segments' sums, reaches
    ftol in one or two iterations; without it (``relax_polish.POLISH`` off) the stage is the
    first pass, and a stage that reaches ftol is never polished."""
    import crumple.relax_polish as rp

    wire = Wire.from_continuum(**CONTINUUM, n_segments=2000)
    x = run_ramp(wire, Ramp(lambdas=SMOOTH.lambdas[:8]), seed=0).stages[-1].positions
    seen = []
    polished = relax.minimize_wire(
        wire, x, 10.0, ftol=1e-9, callback=lambda *a: seen.append((a[0], a[1].copy(), *a[2:]))
    )
    assert polished.converged and polished.max_force <= 1e-9, polished.message
    assert "polished in the displacement" in polished.message
    monkeypatch.setattr(rp, "POLISH", False)
    first = relax.minimize_wire(wire, x, 10.0, ftol=1e-9)
    assert "converged to the force resolution" in first.message
    assert first.max_force > 1e-7 and first.force_resolution > 1e-9
    assert polished.iterations - first.iterations in (1, 2, 3)
    # the callback saw both passes, the polish's iterations counted on, its end the result;
    # without the callback the stage is the same, bit for bit
    monkeypatch.setattr(rp, "POLISH", True)
    silent = relax.minimize_wire(wire, x, 10.0, ftol=1e-9)
    np.testing.assert_array_equal(silent.x, polished.x)
    assert (silent.iterations, silent.energy) == (polished.iterations, polished.energy)
    monkeypatch.setattr(rp, "POLISH", False)
    assert [s[0] for s in seen] == list(range(1, polished.iterations + 1))
    assert seen[first.iterations - 1][2] == first.energy
    np.testing.assert_array_equal(seen[-1][1], polished.x)
    assert seen[-1][2:] == (polished.energy, polished.max_force)
    assert abs(polished.energy - first.energy) <= 1e-12 * abs(first.energy)
    assert float(np.max(np.hypot(*(polished.x - first.x).T))) < 1e-6
    assert not has_crossings(polished.x)
    monkeypatch.setattr(rp, "POLISH", True)
    plain = relax.minimize_wire(wire, x, 10.0, ftol=1e-5)
    assert plain.converged and "polish" not in plain.message
    # the stage's iteration budget holds for both passes, and a stage that ran out of it with
    # forces above their resolution is not polished
    short = relax.minimize_wire(wire, x, 10.0, ftol=1e-9, maxiter=first.iterations - 1)
    assert short.iterations <= first.iterations - 1 and "polish" not in short.message
    assert short.max_force > short.force_resolution
    budget = relax.minimize_wire(wire, x, 10.0, ftol=1e-9, maxiter=first.iterations)
    assert budget.iterations == first.iterations and "polish" not in budget.message


def test_the_polish_stops_where_it_no_longer_makes_progress(monkeypatch):
    """The polish's Newton runs with ``relax_polish.POLISH_PATIENCE`` (it stops once that many
    iterations pass without the energy going lower beyond its resolution) and with what is
    left of the stage's budget; none left, no polish: the first pass stands (N = 2000,
    ftol = 10⁻⁹, as above)."""
    import crumple.relax_polish as rp

    wire = Wire.from_continuum(**CONTINUUM, n_segments=2000)
    x = run_ramp(wire, Ramp(lambdas=SMOOTH.lambdas[:8]), seed=0).stages[-1].positions
    given = []
    real = rp.newton

    def spy(*args, **kw):
        given.append((kw["maxiter"], kw["patience"]))
        return real(*args, **kw)

    monkeypatch.setattr(rp, "newton", spy)
    monkeypatch.setattr(rp, "POLISH", False)
    first = relax.minimize_wire(wire, x, 10.0, ftol=1e-9)
    monkeypatch.setattr(rp, "POLISH", True)
    assert given == []
    none = relax.minimize_wire(wire, x, 10.0, ftol=1e-9, maxiter=first.iterations)
    assert given == [] and none.iterations == first.iterations
    assert "converged to the force resolution" in none.message
    polished = relax.minimize_wire(wire, x, 10.0, ftol=1e-9)
    assert given == [(5000 - first.iterations, rp.POLISH_PATIENCE)]
    assert polished.converged and "polished in the displacement" in polished.message
    short = relax.minimize_wire(wire, x, 10.0, ftol=1e-9, maxiter=first.iterations + 2)
    assert given[-1] == (2, rp.POLISH_PATIENCE)  # the stage's budget, where less is left of it
    assert short.iterations <= first.iterations + 2


def test_the_retry_after_a_polish_reports_its_steps_counted_on():
    """The retry (Newton in the coordinates from a polish's end) reports its accepted steps to
    the stage's callback under the stage's running iteration count, its own points."""
    import crumple.relax_polish as rp

    seen = []
    kw = {"hess": lambda x: 2 * np.eye(3), "maxiter": 50}
    x0 = np.array([1.0, -2.0, 0.5])
    res = rp._retried(lambda x: (float(x @ x), 2 * x), x0, kw, {"iterations": 7},
                      lambda it, x, e, f: seen.append((it, x.copy(), e)))  # fmt: skip
    assert res.converged and [s[0] for s in seen] == list(range(8, 8 + res.iterations))
    np.testing.assert_array_equal(seen[-1][1], res.x)
    assert seen[-1][2] == res.energy
    assert rp._retried(lambda x: (float(x @ x), 2 * x), x0, kw, {"iterations": 50}) is None


def test_no_wire_of_at_most_a_thousand_segments_is_polished(monkeypatch):
    """The polish and its retry act above ``relax.ACCURATE_STEPS_ABOVE`` = 1000 segments only,
    so the reproduction's ramps (N ≤ 1000) keep their iterates: at N = 1000 a stage that stops
    at its force resolution above ftol (the polish's condition) is the first pass alone."""
    import crumple.relax_polish as rp

    def refused(*args, **kw):
        raise AssertionError("polished at N = 1000")

    monkeypatch.setattr(relax, "_polished", refused)
    wire = Wire.from_continuum(**CONTINUUM, n_segments=1000)
    x = run_ramp(wire, Ramp(lambdas=SMOOTH.lambdas[:3]), seed=0).stages[-1].positions
    res = relax.minimize_wire(wire, x, 10.0, ftol=1e-12)
    assert rp._needs_polish(res, 1e-12), res.message
    assert res.converged and "polish" not in res.message


def _result(x, energy, max_force, converged, iterations, message):
    return MinimizeResult(x=x, energy=energy, max_force=max_force, iterations=iterations,
                          evaluations=iterations + 1, hessian_evaluations=iterations,
                          converged=converged, ftol=1e-6, message=message, method="newton",
                          factorizations=2 * iterations, force_resolution=0.2,
                          curved_steps=iterations // 10,
                          krylov_iterations=3 * iterations)  # fmt: skip


@pytest.mark.parametrize(
    "case",
    ["converges", "does not", "no budget", "short budget", "converged first", "higher",
     "more force", "off"],
)  # fmt: skip
def test_a_polish_that_lowers_an_unconverged_stage_is_retried_in_the_coordinates(monkeypatch, case):
    """A first pass refused at its force resolution (unconverged), whose polish lowers the
    energy and the forces without converging by its own test (N = 10⁵, λ = 33.39 on the AMD
    machine, docs/performance.md "The polish's budget"): Newton again in the coordinates from
    the polish's end point, with the first pass's own keywords and criteria. Its result is the
    stage's only if it converged; the counts of the three passes add up, and the stage's
    budget holds for all three. Not where the first pass converged, where the polish went up
    in energy or in force, where no budget is left, or with ``RETRY`` off. The passes are
    scripted; the test is of what ``_polished`` does with them."""
    import crumple.relax_polish as rp

    wire = Wire(k_b=5, k_s=5e5, n_segments=10)
    energy = WireEnergy(wire, lam=1.0)
    x1 = initial_state(wire, 0.01, seed=0)
    u = np.full_like(x1, 1e-9)
    first = _result(x1, 1.5, 0.035, case == "converged first", 30, "first pass")
    polish = _result(u, 1.5 + (1e-6 if case == "higher" else -1e-6),
                     0.05 if case == "more force" else 0.0012, False, 100,
                     "maximum number of iterations reached")  # fmt: skip
    retry = _result(x1 + u, 1.5 - 1e-6, 0.009, case != "does not", 1, "retried point")
    calls = []

    def scripted(fun, x0, **kw):
        calls.append((fun, np.array(x0), kw))
        return polish if len(calls) == 1 else retry

    hess = object()
    budget = {"no budget": 130, "short budget": 135}.get(case, 5000)
    kw = {"maxiter": budget, "hess": hess, "hess_fallback": hess, "retract": object()}
    monkeypatch.setattr(rp, "newton", scripted)
    monkeypatch.setattr(rp, "RETRY", case != "off")
    seen = []
    out = rp._polished(energy, first, kw, 1e-6, lambda *a: seen.append(a))
    calls[0][2]["callback"](1, u, 1.4, 0.1)  # the polish's first step, in the displacement
    assert seen[-1][0] == 31 and np.array_equal(seen[-1][1], x1 + u)
    if case in ("converged first", "higher", "more force", "off", "no budget"):
        assert len(calls) == 1 and out.x is x1 and "retried" not in out.message
        assert out.iterations == 130 and out.curved_steps == 3 + 10
        assert out.message == ("first pass; not polished (100 iterations in the displacement: "
                               "maximum number of iterations reached)")  # fmt: skip
        return
    assert len(calls) == 2
    fun, start, again = calls[1]
    assert fun is energy and np.array_equal(start, x1 + u)
    assert again["hess"] is hess and again["retract"] is kw["retract"]  # the first pass's own
    assert again["maxiter"] == (5 if case == "short budget" else 5000 - 130)
    assert again["patience"] == rp.POLISH_PATIENCE
    again["callback"](1, x1 + u, 1.3, 0.05)  # the retry's first step: after 30 + 100
    assert seen[-1][0] == 131 and np.array_equal(seen[-1][1], x1 + u)
    assert out.iterations == 131 and out.factorizations == 262 and out.evaluations == 134
    assert out.krylov_iterations == 3 * 131 and out.curved_steps == 3 + 10 + 0
    if case == "does not":
        assert not out.converged and out.x is x1 and out.max_force == 0.035
        assert "not polished" in out.message
        assert out.message.endswith("; retried in the coordinates (1 iterations: retried point)")
    else:
        assert out.converged and out.x is retry.x and out.max_force == 0.009
        assert out.message.startswith("retried point; retried in the coordinates (1 iterations)")


def _lowest_curvature_per_length(wire, stage):
    """Lowest eigenvalue of the pencil (H, M) (M: node lengths) by dense LAPACK, an estimate
    independent of the solver's inertia count."""
    import scipy.linalg as sla

    h = WireEnergy(wire, stage.lam).hessian(stage.positions, dense=True)
    m = np.repeat(protocol.node_lengths(wire), 2)
    return float(sla.eigh(h, np.diag(m), eigvals_only=True, subset_by_index=[0, 0])[0])


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(20, 120),
    continuum=st.booleans(),
    lam_max=st.sampled_from([30.0, 300.0, 2000.0]),
)
def test_no_accepted_stage_has_a_negative_eigenvalue(seed, n, continuum, lam_max):
    """Every stage reported converged is a minimum to the documented tolerance: no eigenvalue
    of the Hessian per unit length below -STABILITY_TOL (the rigid rotation is ~0)."""
    if continuum:
        wire = Wire.from_continuum(**CONTINUUM, n_segments=n)
    else:
        wire = Wire(k_b=5, k_s=5e5, n_segments=n)
    result = run_ramp(wire, Ramp(lambdas=tuple(np.geomspace(1.0, lam_max, 6))), seed=seed)
    for stage in result.stages:
        if stage.result.converged:
            lowest = _lowest_curvature_per_length(wire, stage)
            assert lowest >= -protocol.STABILITY_TOL, (stage.lam, lowest)


def test_maxiter_default_depends_on_the_method():
    """Powell's budget is Ramp's, not the CLI's: a sweep or a script gets it too; Newton's
    resolved default, and so every stored Newton run id, is unchanged."""
    from crumple.protocol import Ramp
    from crumple.sweep import Sweep

    assert Ramp().maxiter == 5000 and Ramp().to_dict()["maxiter"] == 5000
    assert Ramp(method="powell").maxiter == 20
    assert Ramp(method="powell", maxiter=3).maxiter == 3
    sweep = Sweep(wire={"n_segments": 8}, ramp={"lambdas": [1, 2], "method": "powell"})
    assert next(iter(sweep.runs())).ramp.maxiter == 20
    assert Ramp.from_dict(Ramp().to_dict()) == Ramp()


def test_per_node_wire_coils_up_at_the_first_stage():
    """The per-node wire collapses from the straight start into a coil at λ = 1. With the
    rotation's gauge fixed once per stage on the entry where the rotation was largest at the
    start, the entry lost its lever arm as the wire coiled and this stage stopped at 5000
    iterations (the full reproduction's seeds; 26 of 8800 per-node stages)."""
    wire = Wire(k_b=5, k_s=5e5, confinement="per-node")
    r = run_ramp(wire, Ramp(lambdas=[1.0]), seed=replica_seeds(20070101, 10)[2])
    assert r.stages[0].result.converged, r.stages[0].result.message
    assert r.stages[0].result.iterations < 1000


@pytest.mark.parametrize("segment_above", [None, 0])
def test_contact_stages_converge_on_the_refactorised_spring_step_alone(monkeypatch,
                                                                       segment_above):  # fmt: skip
    """Where the one-solve-per-spring model runs out of rounds, Newton finishes the spring step
    with a factorisation per active set (crumple.linalg_springs). Forced to run out at once
    (one round), every contact step takes that path: most of those solves find the model's
    exact minimiser (converged), and the default wire still reaches every contact stage's
    equilibrium, stable, without crossing, at the same energy as the normal path to within
    the force tolerance. The same with the rounds started from the segment's least point
    (``relax.SEGMENT_START_ABOVE`` = 0; by default not at 60 segments), which the step is
    told exactly when the threshold says so."""
    import crumple.minimize_barriers as minimize_module
    import crumple.relax as rx
    from crumple.linalg import Factorization

    wire, ramp, normal = _contact_ramp()  # the default: not from the segment at 60 segments
    monkeypatch.setattr(rx, "SEGMENT_START_ABOVE", segment_above)
    calls = []
    smw = Factorization.solve_springs

    def one_round(self, *args, **kwargs):
        return smw(self, *args, **{**kwargs, "rounds": 1, "max_new": 1})

    original = minimize_module.spring_step

    told = set()

    def counted(*args, **kwargs):
        out = original(*args, **kwargs)
        calls.append(out[1])
        told.add(kwargs["from_segment"])
        return out

    monkeypatch.setattr(Factorization, "solve_springs", one_round)
    monkeypatch.setattr(minimize_module, "spring_step", counted)
    forced = run_ramp(wire, ramp, seed=1)
    assert len(calls) > 10 and sum(calls) > 0.8 * len(calls)
    assert told == {segment_above is not None}
    _assert_the_same_contact_equilibria(normal, forced)


def test_contact_stages_converge_with_the_springs_solve_skipped(monkeypatch):
    """Above ``relax.SOLVE_LIMIT_ABOVE`` segments a listing of more than
    ``relax.SPRINGS_SOLVE_LIMIT`` springs skips the solve with the factor. Both set to 0 (by
    default not at 60 segments), every contact step is the refactorised step's, the solve is
    never called, and the default wire reaches the same contact equilibria, stable, without
    crossing."""
    import crumple.minimize_barriers as minimize_module
    import crumple.relax as rx
    from crumple.linalg import Factorization

    wire, ramp, normal = _contact_ramp()
    monkeypatch.setattr(rx, "SOLVE_LIMIT_ABOVE", 0)
    monkeypatch.setattr(rx, "SPRINGS_SOLVE_LIMIT", 0)
    solves, calls = [], []
    smw, original = Factorization.solve_springs, minimize_module.spring_step

    def counted_solve(self, *args, **kwargs):
        solves.append(1)
        return smw(self, *args, **kwargs)

    def counted(*args, **kwargs):
        out = original(*args, **kwargs)
        calls.append(out[1])
        return out

    monkeypatch.setattr(Factorization, "solve_springs", counted_solve)
    monkeypatch.setattr(minimize_module, "spring_step", counted)
    skipped = run_ramp(wire, ramp, seed=1)
    assert not solves and len(calls) > 10 and sum(calls) > 0.8 * len(calls)
    _assert_the_same_contact_equilibria(normal, skipped)


@pytest.mark.parametrize("n_segments", [1000, 1001])
def test_the_large_wire_options_start_above_a_thousand_segments(n_segments):
    """The options relax gives Newton above 10³ segments (accurate steps, the segment's start
    and the skipped solve of the springs' step), and not at 10³: the reproduction and the
    continuum study (N ≤ 1000) keep their iterates."""
    import crumple.relax as rx
    from crumple.energy import WireEnergy

    wire = Wire.from_continuum(bending=0.05, stretching=5000, n_segments=n_segments)
    kw = rx._newton_options(wire, WireEnergy(wire, 1.0), None, "exact", False, True)
    large = n_segments > 1000
    assert kw["accurate_steps"] is large and kw["springs_from_segment"] is large
    assert kw["springs_solve_limit"] == (rx.SPRINGS_SOLVE_LIMIT if large else None)
    assert kw["order_by_points"] is large and kw["springs_updates"] is large


def _contact_ramp():
    """A short ramp of the default wire (N = 60, seed 1) into contact: wire, ramp, result."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=60)
    ramp = Ramp(lambdas=[1.0, 40.0, 200.0, 600.0])
    return wire, ramp, run_ramp(wire, ramp, seed=1)


def _assert_the_same_contact_equilibria(normal, other):
    """Every stage of ``other`` converged (small force and stable), without crossing, at the
    energy of ``normal``'s to within the force tolerance, the last one in contact."""
    for a, b in zip(normal.stages, other.stages, strict=True):
        assert b.result.converged, b.result.message
        assert not has_crossings(b.positions)
        assert b.energy.total == pytest.approx(a.energy.total, rel=1e-6)
    assert other.stages[-1].energy.hard_core > 0


def test_contact_stages_reach_the_same_equilibria_in_the_nested_dissections_order(monkeypatch):
    """Above ``relax.ORDER_BY_POINTS_ABOVE`` segments the factor's order is also sought by a
    nested dissection of the nodes. Set to 0 (by default not at 60 segments), every analysis
    is offered the dissection of the nodes' positions, and the default wire reaches the same
    contact equilibria, stable, without crossing."""
    import crumple.linalg as linalg_module
    import crumple.relax as rx

    wire, ramp, normal = _contact_ramp()
    monkeypatch.setattr(rx, "ORDER_BY_POINTS_ABOVE", 0)
    offered = []
    original = linalg_module._Symbolic.__init__

    def counted(self, a, candidate=None):
        original(self, a, candidate)
        offered.append(candidate is not None)

    monkeypatch.setattr(linalg_module._Symbolic, "__init__", counted)
    ordered = run_ramp(wire, ramp, seed=1)
    assert offered and all(offered)
    _assert_the_same_contact_equilibria(normal, ordered)


def test_contact_stages_reach_the_same_equilibria_with_modified_factors(monkeypatch):
    """Above ``relax.UPDATES_ABOVE`` segments the rounds of the refactorised springs' step
    modify the last round's factor (rank-one updates and downdates). Set to 0 (by default not
    at 60 segments) with every round routed to that step (``SOLVE_LIMIT_ABOVE`` and
    ``SPRINGS_SOLVE_LIMIT`` at 0) and ``UPDATE_COST`` at 0, factors are modified, and the
    default wire reaches the same contact equilibria, stable, without crossing."""
    import crumple.linalg_springs as springs
    import crumple.relax as rx
    from crumple.linalg import LDLT

    wire, ramp, normal = _contact_ramp()
    for name in ("UPDATES_ABOVE", "SOLVE_LIMIT_ABOVE", "SPRINGS_SOLVE_LIMIT"):
        monkeypatch.setattr(rx, name, 0)
    monkeypatch.setattr(springs, "UPDATE_COST", 0.0)
    made = []
    original = LDLT.__init__

    def kept(self, *args, **kwargs):
        original(self, *args, **kwargs)
        made.append(self)

    monkeypatch.setattr(LDLT, "__init__", kept)
    updated = run_ramp(wire, ramp, seed=1)
    assert sum(ldl.modifications for ldl in made) > 0
    _assert_the_same_contact_equilibria(normal, updated)


def test_warm_started_springs_reach_the_same_contact_equilibria(monkeypatch):
    """The opt-in warm start of the springs' solve (minimize_barriers.WARM_START) changes
    which rounds find each step's active set, not the model's minimiser: the default wire's
    contact stages still converge, stable and without crossing, at the default's energies."""
    import crumple.minimize_barriers as minimize_module
    from crumple.linalg import Factorization

    wire, ramp, normal = _contact_ramp()
    starts = []
    smw = Factorization.solve_springs

    def seen(self, *args, **kwargs):
        starts.append(kwargs.get("start") is not None)
        return smw(self, *args, **kwargs)

    monkeypatch.setattr(minimize_module, "WARM_START", True)
    monkeypatch.setattr(Factorization, "solve_springs", seen)
    warm = run_ramp(wire, ramp, seed=1)
    assert sum(starts) > 10  # the warm start was used
    _assert_the_same_contact_equilibria(normal, warm)


def test_accurate_stability_is_unused_where_the_assembled_hessian_resolves_tau(monkeypatch):
    """relax.ACCURATE_STABILITY (on by default) passes the element-form product to Newton; at
    N = 100 the assembled Hessian resolves τ, so the product is never called and the result is
    the same bit for bit with the switch off, at an equilibrium and through a buckling stage
    (an escape)."""
    wire = Wire(k_b=5, k_s=5e5)
    calls = []
    original = WireEnergy.hessian_action

    def counted(self, x, v):
        calls.append(1)
        return original(self, x, v)

    monkeypatch.setattr(WireEnergy, "hessian_action", counted)
    rng = np.random.default_rng(2)
    x0 = np.column_stack([np.linspace(-0.5, 0.5, 101), 1e-4 * rng.standard_normal(101)])
    monkeypatch.setattr(relax, "ACCURATE_STABILITY", False)
    off = [minimize_wire(wire, x0, lam) for lam in (2.0, 60.0)]
    monkeypatch.setattr(relax, "ACCURATE_STABILITY", True)
    on = [minimize_wire(wire, x0, lam) for lam in (2.0, 60.0)]
    assert not calls
    for a, b in zip(off, on, strict=True):
        assert a.converged and b.converged
        assert a.iterations == b.iterations and np.array_equal(a.x, b.x)


def test_the_fallback_enters_the_run_id_as_the_path_the_run_takes(monkeypatch):
    """ "auto" is resolved by the wire's size (``relax.resolve_fallback``): at N <= 1000 it is
    the projected fallback, the runs before the choice existed, so their ids are unchanged
    (a ramp dict without the key means "projected"); above, it is "exact", and the id says so.
    The module default is resolved when the Ramp is made, like ``curved_steps``."""
    from crumple.sweep.store import run_id

    small, big = Wire(k_b=5, k_s=5e5, n_segments=1000), Wire(k_b=5, k_s=5e5, n_segments=1001)
    ramps = {f: Ramp(lambdas=(1, 10), fallback=f) for f in ("auto", "projected", "exact", "caps")}
    legacy = Ramp.from_dict({k: v for k, v in ramps["auto"].to_dict().items()
                             if k != "fallback"})  # fmt: skip
    ids = {f: run_id(small, r, 0, 0) for f, r in ramps.items()}
    assert ids["auto"] == ids["projected"] == run_id(small, legacy, 0, 0) != ids["exact"]
    ids = {f: run_id(big, r, 0, 0) for f, r in ramps.items()}
    assert ids["auto"] == ids["exact"] != ids["projected"]
    assert len({ids["exact"], ids["projected"], ids["caps"]}) == 3
    assert relax.resolve_fallback("auto", small) == "projected"
    assert relax.resolve_fallback("auto", big) == "exact"
    monkeypatch.setattr(relax, "FALLBACK", "exact")
    assert Ramp(lambdas=(1, 10)).fallback == "exact" and Ramp(method="powell").fallback == "auto"
    with pytest.raises(ValueError, match="fallback"):
        relax.minimize_wire(small, np.zeros((small.n_nodes, 2)), 1.0, fallback="modified")


def test_the_releasing_springs_reach_equilibria_without_crossings(monkeypatch):
    """``relax.RELEASE_ABOVE`` (above 10³ segments by default) adds to the Newton model's
    contact springs those of the pairs a step takes out of the core, with the curvature of
    their barrier removed: only the path changes, so a contact ramp still ends every stage
    converged and stable, uncrossed; the model's barriers are the releasing ones exactly above
    the threshold, and releasing rows (negative stiffness) are listed on the way."""
    import crumple.relax as rx
    from crumple.energy import WireEnergy
    from crumple.geometry import has_crossings

    wire = Wire(k_b=5, k_s=5e5, n_segments=40)
    energy = WireEnergy(wire, 1.0)
    assert rx._barriers(energy, wire) == energy.barriers  # not at 40 segments by default
    monkeypatch.setattr(rx, "RELEASE_ABOVE", None)
    assert rx._barriers(energy, wire) == energy.barriers
    monkeypatch.setattr(rx, "RELEASE_ABOVE", 0)
    assert rx._barriers(energy, wire) != energy.barriers
    listed = []
    original = WireEnergy.barriers

    def counting(self, x, step, **kw):  # the releasing rows (negative stiffness) the model got
        rows = original(self, x, step, **kw)
        if kw.get("releasing"):
            listed.append(int(np.sum(rows[3] < 0)))
        return rows

    monkeypatch.setattr(WireEnergy, "barriers", counting)
    r = run_ramp(wire, Ramp(lambdas=(1.0, 100.0, 1000.0, 3000.0)), seed=2)
    assert r.converged, [s.result.message for s in r.stages]
    assert all(not has_crossings(s.positions) for s in r.stages)
    assert r.stages[-1].energy.hard_core > 0  # the last stage is in contact
    assert sum(listed) > 0  # and the model was offered releasing springs on the way


def test_minimize_wire_reports_every_accepted_step_with_its_positions():
    """The callback sees every accepted point, once each and in order, as read-only
    positions (n_nodes, 2) with that point's energy and largest force, the last being the
    result; the energies it reports never rise beyond the energy's resolution."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=30)
    x0 = initial_state(wire, seed=0)
    seen = []
    res = minimize_wire(
        wire, x0, lam=300.0, callback=lambda it, x, e, f: seen.append((it, x.copy(), e, f))
    )
    assert res.converged and len(seen) >= 3
    its = [s[0] for s in seen]
    assert its == list(range(1, res.iterations + 1))  # no escape at this stage
    energy = WireEnergy(wire, 300.0)
    for _, x, e, f in seen:
        assert x.shape == (wire.n_nodes, 2)
        e_x, g_x = energy(x)
        assert e == e_x and f == max_force(np.reshape(g_x, (-1, 2)))
    energies = [s[2] for s in seen]
    tol = resolution(energies[0])
    assert all(b <= a + tol for a, b in itertools.pairwise(energies))
    np.testing.assert_array_equal(seen[-1][1].ravel(), np.ravel(res.x))
    assert seen[-1][2] == res.energy

    def modify(it, x, e, f):
        x[0] += 0.1  # would corrupt the solver's point

    with pytest.raises(ValueError, match="read-only"):
        minimize_wire(wire, x0, lam=300.0, callback=modify)
    with pytest.raises(ValueError, match="callback needs method='newton'"):
        minimize_wire(wire, x0, lam=300.0, method="powell", rng=np.random.default_rng(0),
                      callback=print)  # fmt: skip


def test_a_ramp_reports_the_newton_steps_of_every_stage_without_changing_its_path():
    """``run_ramp(iteration=...)`` sees every accepted step of every stage, tagged with the
    stage's index and λ, the last of each being the stage's result; the path is the same, bit
    for bit, as without it. Powell has no steps to report: asking is an error."""
    wire = Wire(k_b=5, k_s=5e5, n_segments=30, rest_angle_sd=0.02)
    ramp = Ramp(lambdas=(1.0, 30.0, 300.0))
    plain = run_ramp(wire, ramp, seed=3)
    seen = []
    got = run_ramp(wire, ramp, seed=3, iteration=lambda *a: seen.append(a))
    assert {s[0] for s in seen} == {0, 1, 2}
    for i, (a, b) in enumerate(zip(plain.stages, got.stages, strict=True)):
        np.testing.assert_array_equal(a.positions, b.positions)
        mine = [s for s in seen if s[0] == i]
        assert all(s[1] == b.lam for s in mine)
        assert [s[2] for s in mine] == list(range(1, b.result.iterations + 1))
        assert mine[-1][3:] == (b.result.energy, b.result.max_force)
    with pytest.raises(ValueError, match="iteration needs method='newton'"):
        run_ramp(wire, Ramp(lambdas=(1.0,), method="powell"), seed=0, iteration=print)
