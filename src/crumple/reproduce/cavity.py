"""The cavity study (issue 13, part 7): injection into a cavity against potential confinement.

``crumple study cavity [--quick | --profile P] --out DIR`` answers the paper's open question
("It is not clear whether [stuffing the wire into a fixed cavity] shares the same properties
as increasing the strength of the confining potential while fixing the wire length") with
measurements. The same wire (k_b, k_s, N, thickness h = hard-core width, rest-angle
disorder), elastic (s = 1) and plastic (s = 0.2, θ_p = 0.1 as the reproduction's Fig. 6), is

* injected into a cavity of radius R_c (the profile's ``cavity_radius``, h = R_c/50) through
  a radial channel (:mod:`crumple.injection`), one segment per stage;
* confined by the paper's parabolic potential, λ ramped from 1 to ``lam_max`` (no cavity).

Section :mod:`.cavity_compare` compares them at matched packing fraction. Profiles: ``smoke``
(the test suite, seconds), ``quick`` (≤ 10 minutes on 2 cores) and ``full`` (≤ 20 minutes,
run once: ``docs/cavity.md``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from types import MappingProxyType

import numpy as np

from ..sweep import Sweep
from .experiments import Experiment
from .study import Study

__all__ = ["CAVITY", "PROFILES", "CavityProfile", "sections"]

#: Base seed of both sweeps.
SEED = 20261130
#: Rest-angle disorder [rad] of every replica (replica variety, as the continuum study's).
REST_ANGLE_SD = 0.01
#: The paper's Fig. 2 wire (Table I's middle), and the reproduction's plastic yield angle.
K_B, K_S, THETA_P = 5.0, 5e5, 0.1
#: The two wires: elastic (s = 1, exactly k_b θ²/2) and plastic s = 0.2.
SOFTENING = (1.0, 0.2)
#: Thickness as a fraction of the cavity radius (the experiments' order, issue 13).
THICKNESS = 1.0 / 50.0


@dataclass(frozen=True, slots=True, kw_only=True)
class CavityProfile:
    """How much the cavity study runs: ``replicas`` per wire, N segments, the cavity radius
    R_c (thickness h = R_c/50), the ramp's schedule (``n_lambdas`` geometric from 1 to
    ``lam_max``), and the injection's stop length (None: the whole wire but one segment)."""

    name: str
    description: str
    replicas: int
    n_segments: int
    cavity_radius: float
    lam_max: float
    n_lambdas: int
    stop_length: float | None

    def to_dict(self) -> dict:
        return asdict(self)


PROFILES = MappingProxyType(
    {
        "smoke": CavityProfile(
            name="smoke",
            description="SMOKE PROFILE (tests only): N = 30, 1 replica, half the wire injected; "
            "the numbers mean nothing",
            replicas=1,
            n_segments=30,
            cavity_radius=0.1,
            lam_max=1e3,
            n_lambdas=8,
            stop_length=0.5,
        ),
        "quick": CavityProfile(
            name="quick",
            description="QUICK PROFILE: N = 80, 2 replicas per wire, R_c = 0.05 L (φ up to "
            "0.13); a sketch of the comparison",
            replicas=2,
            n_segments=80,
            cavity_radius=0.05,
            lam_max=1e5,
            n_lambdas=24,
            stop_length=None,
        ),
        "full": CavityProfile(
            name="full",
            description="FULL PROFILE: N = 100, 6 replicas per wire, R_c = 0.05 L (φ up to "
            "0.13); sized to run in ≤ 20 minutes on 2 cores",
            replicas=6,
            n_segments=100,
            cavity_radius=0.05,
            lam_max=1e5,
            n_lambdas=30,
            stop_length=None,
        ),
    }
)


def _wire(profile: CavityProfile, cavity: bool) -> dict:
    w = {
        "k_b": K_B,
        "k_s": K_S,
        "n_segments": profile.n_segments,
        "hard_core": THICKNESS * profile.cavity_radius,
        "rest_angle_sd": REST_ANGLE_SD,
    }
    if cavity:
        w["cavity_radius"] = profile.cavity_radius
    return w


def _points() -> list[dict]:
    return [{"plasticity": {"s": s, "theta_p": THETA_P}} for s in SOFTENING]


def _injection(profile: CavityProfile) -> Sweep:
    proto = {"kind": "injection"}
    if profile.stop_length is not None:
        proto["stop_length"] = profile.stop_length
    return Sweep(wire=_wire(profile, True), protocol=proto, points=_points(),
                 replicas=profile.replicas, seed=SEED)  # fmt: skip


def schedule(profile: CavityProfile) -> list[float]:
    """The ramp's λ: geometric from 1 to ``lam_max`` (6 significant digits)."""
    return [float(f"{v:.6g}") for v in np.geomspace(1.0, profile.lam_max, profile.n_lambdas)]


def _ramp(profile: CavityProfile) -> Sweep:
    return Sweep(wire=_wire(profile, False), ramp={"lambdas": schedule(profile)},
                 points=_points(), replicas=profile.replicas, seed=SEED)  # fmt: skip


#: The wire pushed into the cavity (elastic and plastic points).
INJECTION = Experiment(name="cavity_injection", levels=("s", "theta_p"), build=_injection)
#: The same wire, confined by the paper's potential.
RAMP = Experiment(name="cavity_ramp", levels=("s", "theta_p"), build=_ramp)


def sections() -> tuple:
    """The study's sections, in report order."""
    from . import cavity_compare

    return (cavity_compare,)


_CONVENTIONS = (
    "Conventions: the same wire in both protocols (k_b = 5, k_s = 5e5, L = 1, rest-angle "
    "disorder 0.01 rad, thickness h = hard-core width = R_c/50), elastic (s = 1) and plastic "
    "(s = 0.2, θ_p = 0.1). Packing fraction φ = h L_in/(π R_c²) in the cavity and "
    "φ = h L/(π r_max²) under the potential (r_max about the centre of mass: the disc the "
    "packing fills). Matched packing: the ramp stage whose φ is nearest (in log) to the "
    "injection's final φ, per replica. Energies per length are the wire's elastic energy "
    "(E_b + E_s) over the wire's length in the packing (L_in or L). Pressure P = (total "
    "confining force)/(2π R): the wall's force over 2π R_c, the trap's Σ 2λ w_i |x_i| over "
    "2π r_max. Values are replica means; σ combines the standard error of the mean and the "
    "fits' regression errors in quadrature; 'same within 2σ' when |cavity − ramp| ≤ "
    "2 (σ_cavity² + σ_ramp²)^1/2, else 'differs'; no verdict where σ = 0 (one replica, or "
    "identical integer counts). The main table gives each protocol's value with its own σ, "
    "and |cavity − potential| over the combined σ. Loops are the reproduction's (closed by "
    "wire-wire contacts at 2d): regions closed by the wall are not counted."
)
_ORIGIN = (
    "A study beyond the paper (issue 13): the protocol is the experiments' (Donato et al., "
    "Stoop et al.), the parameters are ours, declared in `crumple.reproduce.cavity`; nothing "
    "was tuned to match a published number."
)

#: The cavity study (``crumple study cavity``).
CAVITY = Study(
    name="cavity",
    command="crumple study cavity",
    title="crumple: injection into a cavity against potential confinement",
    origin=_ORIGIN,
    conventions=_CONVENTIONS,
    alternatives="Exponents beside the comparison: the injection force against L_in, the ramp's "
    "r_max against λ, the loops' growth with L_in, and D_M about the cavity's centre.",
    sections=sections,
    profiles=PROFILES,
    profile_fields=tuple(CavityProfile.__dataclass_fields__),
    comparison=("Cavity against potential at matched packing", "cavity", "potential"),
)
