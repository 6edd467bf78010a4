"""The continuum-limit study (issue 12): profiles, experiments and the :class:`.study.Study`.

``crumple study continuum [--quick | --profile P] --out DIR`` runs the experiments below and
writes a report with three sections:

* :mod:`.continuum_collapse`: observables in continuum units against the confinement number
  Λ = λ L⁴/B (:mod:`crumple.continuum`); the paper's Fig. 5 points replotted against Λ; the
  collapse of (k_b, λ, N) at equal Λ, within the discretisation error;
* :mod:`.continuum_convergence`: the same observables against N at fixed Λ, and the rule
  "segments per loop size ℓ" for a given accuracy;
* :mod:`.continuum_sweep`: R(Λ) and its local exponent, D_M with its local slope, γ(Λ)
  against the paper's closed form, with rest-angle disorder replicas and the perfect wire.

Profiles: ``smoke`` (the test suite, seconds), ``quick`` (at most 10 minutes on 2 cores, with
N ≤ 400, Λ ≤ 10⁶) and ``full`` (sized to about 2 hours on 2 cores from the measured cost of
the contact stages: N ≤ 1000, the sweep to Λ = 10¹⁰; run once, 2 h 08 min, docs/continuum.md,
"The full profile"). The hard-core width
is the model's default d = 1e-5 L0 in every profile (d/L is a dimensionless number of its own,
held fixed so that it does not break the collapse).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from types import MappingProxyType

import numpy as np

from ..continuum import wire_point
from ..sweep import Sweep
from .experiments import Experiment
from .study import Study

__all__ = ["CONTINUUM", "PROFILES", "ContinuumProfile", "sections"]

#: Base seed of every sweep of the study.
SEED = 20261129
#: Rest-angle disorder of the replicas [rad] (as the paper's ``disorder`` alternative).
REST_ANGLE_SD = 0.01


def _geom(lo: float, hi: float, n: int) -> tuple[float, ...]:
    return tuple(float(f"{v:.6g}") for v in np.geomspace(lo, hi, n))


@dataclass(frozen=True, slots=True, kw_only=True)
class ContinuumProfile:
    """How much the continuum study runs.

    ``collapse_points``: (k_b, N) pairs ramped through ``confinements`` (Λ, the same for all:
    λ = Λ k_b/N); pairs with the same N and pairs with the same k_b at N and 2N measure
    the collapse and the discretisation error. ``fig5_n`` and ``fig5_lambdas``: the paper's six
    (k_b, k_s) ramped in λ at N = fig5_n. ``sweep_n``, ``sweep_confinements``: the Λ sweep,
    ``replicas`` disorder replicas (rest-angle s.d. :data:`REST_ANGLE_SD`) plus the perfect
    wire.
    """

    name: str
    description: str
    replicas: int
    confinements: tuple[float, ...]
    collapse_points: tuple[tuple[float, int], ...]
    fig5_n: int
    fig5_lambdas: tuple[float, ...]
    sweep_n: int
    sweep_confinements: tuple[float, ...]
    convergence_tolerance: float

    def to_dict(self) -> dict:
        return asdict(self)


PROFILES = MappingProxyType(
    {
        "smoke": ContinuumProfile(
            name="smoke",
            description="SMOKE PROFILE (tests only): N ≤ 100 (the Fig. 5 points at N = 40), "
            "Λ ≤ 10⁴, 2 disorder replicas; the numbers mean nothing",
            replicas=2,
            confinements=_geom(1e2, 1e4, 5),
            collapse_points=((1.0, 25), (4.0, 25), (1.0, 50), (2.0, 50), (1.0, 100)),
            fig5_n=40,
            fig5_lambdas=(1.0, 100.0, 2000.0),
            sweep_n=50,
            sweep_confinements=_geom(1e2, 1e4, 5),
            convergence_tolerance=0.01,
        ),
        "quick": ContinuumProfile(
            name="quick",
            description="QUICK PROFILE: small N (≤ 400), to fit in 10 minutes; Λ ≤ 10⁵ for "
            "the collapse, "
            "≤ 10⁶ for the sweep, 3 disorder replicas; no power-law range is expected at "
            "these sizes",
            replicas=3,
            confinements=_geom(1e2, 1e5, 10),
            collapse_points=(
                (1.0, 50),
                (4.0, 50),
                (1.0, 100),
                (4.0, 100),
                (1.0, 200),
                (3.0, 200),
                (1.0, 400),
            ),
            fig5_n=100,
            fig5_lambdas=_geom(1.0, 2000.0, 12),
            sweep_n=200,
            sweep_confinements=_geom(1e2, 1e6, 13),
            convergence_tolerance=0.01,
        ),
        "full": ContinuumProfile(
            name="full",
            description="FULL PROFILE (issue 12), sized to about 2 hours on 2 cores: the "
            "collapse and N-convergence ramps to Λ = 10⁸ at N = 100 … 1000, the Λ sweep to "
            "10¹⁰ at N = 1000 (ℓ/Δs ≥ 7.3 only to Λ ≈ 3·10⁸), 2 disorder replicas; "
            "docs/continuum.md",
            replicas=2,
            confinements=_geom(1e2, 1e8, 19),
            collapse_points=(
                (1.0, 100),
                (4.0, 100),
                (1.0, 200),
                (1.0, 400),
                (4.0, 400),
                (1.0, 1000),
            ),
            fig5_n=100,
            fig5_lambdas=_geom(1.0, 2000.0, 40),
            sweep_n=1000,
            sweep_confinements=_geom(1e2, 1e10, 25),
            convergence_tolerance=0.01,
        ),
    }
)


def _collapse(profile: ContinuumProfile) -> Sweep:
    """(k_b, N) points ramped through the same Λ, k_s stiff (strain ≤ 1e-3 at Λ_max)."""
    pts = [
        wire_point(profile.confinements, n_segments=n, k_b=kb) for kb, n in profile.collapse_points
    ]
    return Sweep(wire={"confinement": "per-length"}, points=pts, replicas=1, seed=SEED)


def _fig5(profile: ContinuumProfile) -> Sweep:
    from ..paper import FIG3_POINTS, points

    return Sweep(
        wire={"confinement": "per-length", "n_segments": profile.fig5_n},
        ramp={"lambdas": list(profile.fig5_lambdas)},
        points=points(FIG3_POINTS),
        replicas=1,
        seed=SEED,
    )


def _sweep(profile: ContinuumProfile, disorder: bool) -> Sweep:
    p = wire_point(profile.sweep_confinements, n_segments=profile.sweep_n, k_b=1.0)
    wire = {k: p[k] for k in ("k_b", "k_s", "n_segments")}
    wire["confinement"] = "per-length"
    if disorder:
        wire["rest_angle_sd"] = REST_ANGLE_SD
    return Sweep(
        wire=wire,
        ramp={"lambdas": p["lambdas"]},
        replicas=profile.replicas if disorder else 1,
        seed=SEED,
    )


#: (k_b, N) at a common Λ schedule: the collapse and the N-convergence.
COLLAPSE = Experiment(
    name="continuum_collapse",
    levels=("k_b", "k_s", "n_segments", "lambdas"),
    build=_collapse,
)
#: The paper's six Fig. 3/Fig. 5 (k_b, k_s), ramped in λ, to be replotted against Λ.
FIG5 = Experiment(name="continuum_fig5", levels=("k_b", "k_s"), build=_fig5)
#: The Λ sweep: disorder replicas.
SWEEP = Experiment(name="continuum_sweep", levels=(), build=lambda profile: _sweep(profile, True))
#: The Λ sweep: the perfect wire.
PERFECT = Experiment(
    name="continuum_perfect", levels=(), build=lambda profile: _sweep(profile, False)
)


def sections() -> tuple:
    """The study's sections, in report order."""
    from . import continuum_collapse, continuum_convergence, continuum_partition, continuum_sweep

    return (continuum_collapse, continuum_convergence, continuum_sweep, continuum_partition)


_CONVENTIONS = (
    "Conventions: Λ = λ L⁴/B with B = k_b L0/N the continuum bending stiffness (Λ = λN/k_b "
    "for L0 = 1); loop size ℓ = L Λ^-1/4; confinement per unit length; k_s chosen stiff, "
    "k_s = k_b Λ_max^1/2 / (10⁻³ L²) (estimated strain B/(Sℓ²) ≤ 10⁻³), except for the paper's "
    "Fig. 5 points, which keep their k_s. Observables in continuum units: R_g/L (RMS radius), "
    "r_max/L, E_b L/B, E_conf L/B, γ = E_s/E_b, contacts per segment (contacts/N), loops. "
    "Hard core d = 1e-5 L0 everywhere. Exponents are fitted per replica, value = replica mean, "
    "σ = standard error of the mean and rms regression error in quadrature; verdict 'agrees' "
    "when within 2σ. A local exponent is d ln y/d ln Λ between successive stages."
)
_ORIGIN = (
    "A study beyond the paper (issue 12): the parameters are ours, declared in "
    "`crumple.reproduce.continuum` with the reasons; nothing was tuned to match."
)

#: The continuum study (``crumple study continuum``).
CONTINUUM = Study(
    name="continuum",
    command="crumple study continuum",
    title="crumple: the continuum limit of the crumpled wire (confinement number Λ)",
    origin=_ORIGIN,
    conventions=_CONVENTIONS,
    alternatives="Variants of the same measurement side by side.",
    sections=sections,
    profiles=PROFILES,
    profile_fields=tuple(ContinuumProfile.__dataclass_fields__),
    partial=False,  # every section fits along a series: an empty one has no λ axis
)
