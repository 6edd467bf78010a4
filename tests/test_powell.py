"""Powell's method (Numerical Recipes, random directions), compiled and in Python; the wire's
compiled energy along a line; the Powell study's smoke report."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import rosen

from crumple.energy import WireEnergy
from crumple.geometry import has_crossings, max_safe_fraction
from crumple.minimize import powell
from crumple.model import Plasticity, Wire
from crumple.protocol import Ramp, run_ramp
from crumple.relax import POWELL_REACH, POWELL_RTOL, _step_limit, minimize_wire


def _crumpled(n=24, seed=3, lam=2000.0):
    """A crumpled, crossing-free wire of n segments (Newton ramp), with contacts at λ = 2000."""
    w = Wire(k_b=5, k_s=5e5, n_segments=n)
    return w, run_ramp(w, Ramp(lambdas=(1, 100, 1000, lam)), seed=seed).stages[-1].positions


def _random_walk(n, seed, step_sd=0.6):
    """A random-turn walk of n segments of length 1/n, redrawn until it does not cross."""
    rng = np.random.default_rng(seed)
    while True:
        ang = np.cumsum(rng.normal(0.0, step_sd, n))
        x = np.zeros((n + 1, 2))
        x[1:] = np.cumsum(np.c_[np.cos(ang), np.sin(ang)] / n * rng.uniform(0.9, 1.1, (n, 1)),
                          axis=0)  # fmt: skip
        if not has_crossings(x):
            return x - x.mean(axis=0)


# ---- the compiled energy along a line --------------------------------------------------------


@pytest.mark.parametrize(
    "wire",
    [
        Wire(k_b=5, k_s=5e5, n_segments=30),
        Wire(k_b=2, k_s=1e4, n_segments=30, confinement="per-node", trap_center=(0.1, -0.05)),
        Wire(k_b=5, k_s=5e5, n_segments=30, plasticity=Plasticity(s=0.2, theta_p=0.1)),
        Wire(k_b=5, k_s=5e5, n_segments=30, rest_angle_sd=0.05, hard_core=0.02),
    ],
)
def test_compiled_line_energy_equals_the_reference_energy(wire):
    """E(x + t d) from the compiled kernels equals WireEnergy at that point, on random
    configurations (random walks, and a wire squeezed at λ = 3e4 with nodes inside the hard
    core of segments), at t = 0 and at random steps inside the admissible interval."""
    rng = np.random.default_rng(7)
    rest = rng.normal(0, wire.rest_angle_sd, wire.n_nodes - 2) if wire.rest_angle_sd else None
    energy = WireEnergy(wire, 37.0, rest_angles=rest)
    prepare, evaluate, _, params = energy.line_kernels(POWELL_REACH * wire.rest_length)
    squeezed = run_ramp(wire, Ramp(lambdas=(1, 300, 3000, 30000)), seed=2).stages[-1].positions
    in_core = 0
    for seed in range(8):
        x = squeezed if seed == 0 else _random_walk(wire.n_segments, seed, 1.2 if seed % 2 else 0.4)
        in_core += energy.terms(x).hard_core > 0
        d = rng.standard_normal(x.size)
        d /= np.linalg.norm(d)
        lo, hi, aux = prepare(x.ravel(), d, params)
        assert lo <= 0.0 <= hi
        for t in (0.0, *rng.uniform(lo, hi, 5)):
            y = x + t * d.reshape(x.shape)
            ref = energy(y)[0]
            got = evaluate(x.ravel(), d, t, params, aux)
            assert got == pytest.approx(ref, rel=1e-13, abs=1e-15), (seed, t)
    assert in_core > 0  # the hard core was exercised


def test_line_interval_stops_at_the_first_contact():
    """A node driven straight at a segment: the interval ends where it touches it (the
    continuous collision detection of the Newton steps), and starts at -reach the other way."""
    w = Wire(k_b=1, k_s=1e4, n_segments=4, hard_core=1e-3)
    x = np.array([[0.0, 0.0], [0.25, 0.0], [0.25, 0.25], [0.1, 0.25], [0.1, 0.05]])
    d = np.zeros_like(x)
    d[4] = [0.0, -1.0]  # the last node moves down onto segment 0 (y = 0), 0.05 away
    prepare, _, admissible, params = WireEnergy(w, 1.0).line_kernels(0.1)
    lo, hi, _ = prepare(x.ravel(), d.ravel(), params)
    assert hi == 0.1 * max_safe_fraction(x, 0.1 * d)
    assert hi == pytest.approx(0.05, rel=1e-9)
    assert lo == pytest.approx(-0.1)  # upwards: the whole reach is free
    assert admissible((x + 0.99 * hi * d).ravel(), params)
    assert not admissible((x + 0.1 * d).ravel(), params)  # through segment 0: crossed


# ---- Powell ----------------------------------------------------------------------------------


def _wire_powell(w, x, lam, sweeps, *, seed=5, compiled=True, rtol=0.0):
    e = WireEnergy(w, lam)
    reach = POWELL_REACH * w.rest_length
    return powell(
        lambda y: e(y)[0], x, rng=np.random.default_rng(seed), gradient=lambda y: e(y)[1],
        feasible=lambda y: not has_crossings(y), step_limit=_step_limit(None),
        compiled=e.line_kernels(reach) if compiled else None, rtol=rtol, maxiter=sweeps,
        step=1e-3 * w.rest_length, reach=reach,
    )  # fmt: skip


def test_powell_lowers_the_energy_monotonically_sweep_by_sweep():
    """The energy after k sweeps never rises with k (the run is deterministic, so k sweeps are
    the first k of k + 1), on a crumpled wire in contact (compiled) and on Rosenbrock's
    function (Python path)."""
    w, x = _crumpled()
    e0 = WireEnergy(w, 3000.0)(x)[0]
    wire_e = [_wire_powell(w, x, 3000.0, k).energy for k in range(1, 6)]
    assert wire_e[0] < e0
    assert all(b <= a for a, b in itertools.pairwise(wire_e)), wire_e
    f = [
        powell(lambda y: float(rosen(y)), -np.ones(5), rng=np.random.default_rng(2),
               maxiter=k).energy
        for k in range(1, 8)
    ]  # fmt: skip
    assert f[0] < rosen(-np.ones(5))
    assert all(b <= a for a, b in itertools.pairwise(f)), f


def test_compiled_and_python_paths_take_the_same_steps():
    """One algorithm, two speeds: on a small wire in contact the compiled run and the Python
    run (SciPy-free, exact crossing test, max_safe_fraction) reach the same point."""
    w, x = _crumpled(n=14, seed=1)
    a = _wire_powell(w, x, 2000.0, 3, compiled=True)
    b = _wire_powell(w, x, 2000.0, 3, compiled=False)
    assert a.evaluations == b.evaluations
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-15)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), lam=st.sampled_from([300.0, 3000.0, 30000.0]))
def test_powell_never_crosses(seed, lam):
    """Squeezed far beyond the ramp (λ up to 3e4), with contacts, Powell's states never cross,
    and neither do the paths between them: every line search moves along a segment of line
    that continuous collision detection cleared."""
    w, x = _crumpled(n=20, seed=seed % 7)
    r = _wire_powell(w, x, lam, 3, seed=seed)
    assert not has_crossings(r.x)
    assert r.energy <= WireEnergy(w, lam)(x)[0]


def test_nr_stopping_rule_and_budgets():
    quad = lambda y: float((y[0] - 1) ** 2 + 3 * (y[1] + 2) ** 2)  # noqa: E731
    r = powell(quad, [0.0, 0.0], rng=np.random.default_rng(0), rtol=1e-6, maxiter=100)
    assert "relative decrease" in r.message and r.iterations < 100
    r = powell(lambda y: float(rosen(y)), -np.ones(5), rng=np.random.default_rng(0), rtol=0.0,
               maxiter=3)  # fmt: skip
    assert "maximum number of sweeps" in r.message and r.iterations == 3
    r = powell(quad, [0.0, 0.0], rng=np.random.default_rng(0), maxiter=50, maxfev=10)
    assert "evaluations" in r.message
    with pytest.raises(ValueError, match="rtol"):
        powell(quad, [0.0, 0.0], rng=np.random.default_rng(0), rtol=-1.0)
    with pytest.raises(ValueError, match="finite reach"):
        powell(quad, [0.0, 0.0], rng=np.random.default_rng(0), step_limit=lambda x, p: 1.0)


def test_ramp_powell_rtol():
    assert Ramp(method="powell").powell_rtol == POWELL_RTOL
    assert Ramp(method="powell", powell_rtol=1e-6).powell_rtol == 1e-6
    assert Ramp().powell_rtol is None
    with pytest.raises(ValueError, match="powell_rtol is a parameter of method='powell'"):
        Ramp(powell_rtol=1e-6)
    with pytest.raises(ValueError, match="powell_rtol must be >= 0"):
        Ramp(method="powell", powell_rtol=-1)
    w = Wire(k_b=5, k_s=5e5, n_segments=12)
    x = run_ramp(w, Ramp(lambdas=(1, 200)), seed=0).stages[-1].positions
    r = minimize_wire(w, x, 300.0, method="powell", maxiter=200, rtol=1e-3,
                      rng=np.random.default_rng(0))  # fmt: skip
    assert "relative decrease" in r.message and r.iterations < 200


# ---- the Powell study (crumple reproduce --profile powell), smoke profile ---------------------


def test_powell_study_smoke_report(tmp_path):
    from crumple.cli import main
    from crumple.reproduce.powell_study import POWELL_STUDY
    from crumple.reproduce.report import check_report

    out = tmp_path / "pw"
    rc = main(["study", "powell", "--profile", "smoke", "--out", str(out), "--workers", "2",
               "--quiet"])  # fmt: skip
    assert rc == 0
    assert check_report(out, sections=POWELL_STUDY.sections()) == []
    res = json.loads((out / "results.json").read_text())
    mins = res["extra"]["powell_study"]["minimisers"]
    assert list(mins) == [
        "Newton (equilibrium)",
        "Powell, NR rule ftol = 1e-06 (≤ 2 sweeps)",
        "Powell, 2 sweeps every stage",
    ]
    assert mins["Powell, 2 sweeps every stage"]["sweeps_mean"] == 2.0
    assert {a["variant"] for a in res["alternatives"]} == set(mins)
    md = (out / "report.md").read_text()
    assert "SMOKE PROFILE" in md and "Powell" in md
    (out / "report.md").unlink()
    assert main(["figures", str(out), "--quiet"]) == 0  # `crumple figures` knows the study
    assert (out / "report.md").read_text() == md


@pytest.mark.parametrize(
    "module",
    [
        "crumple.powell",
        "crumple.minimize",
        "crumple.minimize_result",
        "crumple.minimize_modes",
        "crumple.minimize_barriers",
        "crumple.linalg_springs",
    ],
)
def test_each_solver_module_imports_on_its_own(module):
    # a fresh interpreter: an import cycle between minimize and powell showed only there
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
