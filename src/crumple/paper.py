"""The paper's experiments and numbers, declared as data (``crumple reproduce`` runs them).

Everything :mod:`crumple.reproduce` simulates and every value it compares with is listed here,
each with the sentence of the paper it comes from. Where the paper does not give a parameter
(which six ``(k_b, k_s)`` in Fig. 3, which ``k_b`` in Fig. 4a, ``theta_p`` in Fig. 6, the
λ schedule, the seed), the choice is ours, marked ``chosen``, and says why. Nothing here was
adjusted after looking at a result.

Profiles (:data:`PROFILES`) set the effort: ``full`` (the paper's 10 replicas everywhere),
``quick`` (every figure and every table row, fewer replicas and stages: the README and CI) and
``smoke`` (one replica, a handful of stages: the test suite).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from types import MappingProxyType
from typing import Any

from .protocol import PAPER_LAMBDAS, default_schedule
from .sweep import Sweep

__all__ = [
    "EXPERIMENTS",
    "PAPER_LAMBDAS",
    "PAPER_VALUES",
    "PROFILES",
    "PaperValue",
    "Profile",
    "build_sweeps",
    "points",
]

#: The paper's Fig. 2 parameters, also the reference of the alternatives below.
FIG2 = (5.0, 5e5)
#: The master curve of the paper's Fig. 5 collapse.
FIG5_REFERENCE = (8.0, 2.4e5)
#: Fig. 3: "six distinct combinations of k_b and k_s" (not listed): Table 1's corners, plus
#: the two points the paper names (Fig. 2 and the Fig. 5 reference). Also Fig. 5's curves.
FIG3_POINTS = ((1.0, 1e4), (1.0, 1e7), (10.0, 1e4), (10.0, 1e7), FIG2, FIG5_REFERENCE)
#: Fig. 4a: "the stretching modulus is set at 2 × 10^3" (several k_b, not listed: Table 1's).
FIG4A_POINTS = tuple((kb, 2e3) for kb in (1.0, 2.0, 4.0, 6.0, 8.0, 10.0))
#: Fig. 4b: "in (b) the bending rigidity is 6" (several k_s, not listed: one per decade of
#: Table 1, plus 2e3 where (a) and (b) meet).
FIG4B_POINTS = tuple((6.0, ks) for ks in (2e3, 1e4, 1e5, 1e6, 1e7))
#: Fig. 6: "(k_b, k_s) = (5, 5 × 10^5) with plasticity for different s".
PLASTIC_S = (0.05, 0.1, 0.2, 0.4, 0.8)
#: θ_p of Fig. 6's main panel is not given. Chosen: 0.1 rad, below the median turning angle of
#: the elastic wire at λ = 1000 (0.12 rad), so that the plastic branch is reached over the range
#: where α is fitted.
PLASTIC_THETA_P = 0.1
#: The inset's θ_p values ("α decays with θ_p exponentially ... for s = 0.4"), not given:
#: chosen log-spaced over the turning angles the wire has (0.02 to 0.5 rad).
PLASTIC_INSET_THETA_P = (0.02, 0.05, 0.1, 0.2, 0.3, 0.5)
#: λ range of the α fits (R_g ~ λ^α): not given; the paper fits "up to λ = 2000" and says the
#: mass exponent saturates for λ > 100. Chosen: [100, 2000]. Fig. 5b of the report shows the
#: local slope over the whole ramp, so the effect of this choice can be read off.
ALPHA_RANGE = (100.0, 2000.0)
#: "Notice that the power-law can only be found for strong external field (λ ≳ 500)".
GAMMA_RANGE = (500.0, 2000.0)
#: "fitting only from R = 0.5 to R = 1" (Fig. 3 caption), R in units of R_G.
DM_RANGE = (0.5, 1.0)
#: "the growing exponent saturates at D_M = 1.33 for λ > 100".
DM_SATURATION_RANGE = (100.0, 2000.0)
#: Confinement: Eq. (1) prints λ r_i² per node, Eq. (2) λ ∫ r² ds per unit length; the two
#: differ by the segment length Δs = 0.01 (per-node λ = per-length λ × Δs at the same wire).
#: The paper does not say which it ran, and the choice decides verdicts (issue 14), so every
#: experiment of Figs. 2-6 runs under both, at the same λ values, points, replicas and stages:
#: per unit length (crumple's default, :data:`CONFINEMENT`; it reproduces the shapes of Fig. 2
#: at the paper's λ values) and per node (:data:`PER_NODE`, Eq. 1 as printed; it coils the
#: wire into a ring of touching layers already at λ = 70, docs/model.md).
CONFINEMENT = "per-length"
#: The other reading of Eq. (1): λ r_i² per node, as printed.
PER_NODE = "per-node"
#: The points the ``smoke`` profile runs per node (tests only: per-node ramps cost 5-10× the
#: per-length ones): the Fig. 2 wire, the Fig. 5 reference, one Fig. 4b curve; and three
#: plastic wires (s, θ_p), the ends of the s trend and the largest θ_p of the inset.
SMOKE_PER_NODE_POINTS = (FIG2, FIG5_REFERENCE, (6.0, 1e5))
SMOKE_PER_NODE_PLASTIC = ((0.05, 0.1), (0.4, 0.1), (0.4, 0.5))
#: Base seed of every sweep (replica r uses ``SeedSequence(SEED).spawn(n)[r]``).
SEED = 20070101


#: Sweeps per stage at most: Numerical Recipes' ``powell`` (the code the paper's "Powell's
#: algorithm" most likely was, in 2011) stops with an error after ITMAX = 200 iterations, so a
#: stage the paper kept ended within 200 sweeps (docs/reproduction.md, "The paper's minimiser").
POWELL_ITMAX = 200


@dataclass(frozen=True, slots=True)
class PaperValue:
    """One number of the paper: what it is, its value and the sentence it comes from."""

    key: str
    quantity: str
    value: float
    source: str


PAPER_VALUES: MappingProxyType[str, PaperValue] = MappingProxyType(
    {
        v.key: v
        for v in (
            PaperValue(
                "D_M",
                "mass-size exponent D_M at λ = 1000 (six (k_b, k_s))",
                1.33,
                "Fig. 3 caption: 'does not affect the value of exponent D_M = 1.33'",
            ),
            PaperValue(
                "D_M_slope",
                "dD_M/dlog10 λ for λ in (100, 2000] (saturation)",
                0.0,
                "Sec. III.A: 'the growing exponent saturates at D_M = 1.33 for λ > 100'",
            ),
            PaperValue(
                "eps_l",
                "ε_l in γ ~ λ^ε_l k_b^ε_b k_s^ε_s (λ ≥ 500)",
                0.55,
                "Sec. III.B: 'where ε_l = 0.55, ε_b = 2.6, and ε_s = -3.3'",
            ),
            PaperValue(
                "eps_b",
                "ε_b (λ ≥ 500)",
                2.6,
                "Sec. III.B: 'ε_b = 2.6'; Fig. 4 caption: 'determined to be ε_b = 2.6'",
            ),
            PaperValue(
                "eps_s",
                "ε_s (λ ≥ 500)",
                -3.3,
                "Sec. III.B: 'ε_s = -3.3'; Fig. 4 caption: 'and ε_s = -3.3'",
            ),
            PaperValue(
                "eps_l_theory",
                "ε_l of the paper's scaling argument",
                0.5,
                "Sec. III.B: 'The value of ε_l = 0.5 matches the simulation result'",
            ),
            PaperValue(
                "collapse",
                "collapse exponent c in R_g ~ λ^α (k_b k_s)^c",
                1.2,
                "Fig. 5 caption: 'All data collapse ... with the scaling R_g ~ (k_b k_s)^1.2'",
            ),
            PaperValue(
                "alpha",
                "α in R_g = r_max ~ λ^α, elastic (mean over the Fig. 5 curves)",
                -0.25,
                "Fig. 5 caption: 'The solid line is the fitting result R_g ~ λ^-0.25'",
            ),
            PaperValue(
                "alpha_s0.05",
                "α with plasticity s = 0.05",
                -0.29,
                "Fig. 6 caption: 'α are -0.21, -0.24, and -0.29 for s = 0.4, 0.2, and 0.05'",
            ),
            PaperValue(
                "alpha_s0.2",
                "α with plasticity s = 0.2",
                -0.24,
                "Fig. 6 caption (as above)",
            ),
            PaperValue(
                "alpha_s0.4",
                "α with plasticity s = 0.4",
                -0.21,
                "Fig. 6 caption (as above)",
            ),
            PaperValue(
                "alpha_saturation",
                "|α| at the largest θ_p, s = 0.4 (inset saturation)",
                0.26,
                "Fig. 6 caption: 'α decays with θ_p exponentially and eventually saturates at "
                "value of 0.26 for s = 0.4'",
            ),
            PaperValue(
                "lambda_contact",
                "λ of the first interior contact (both segments ≥ 10 % of the wire from the "
                "ends), (k_b, k_s) = (5, 5e5)",
                1000.0,
                "Fig. 2 caption: 'Those local structures start to contact each other when "
                "λ ≥ 1000'",
            ),
        )
    }
)


@dataclass(frozen=True, slots=True, kw_only=True)
class Profile:
    """How much to run: replicas and λ stages of each experiment.

    ``schedule_n`` is the number of geometric stages from 1 to 2000 (the paper's 70, 200, 300
    and 1000 are always added, see :func:`crumple.protocol.default_schedule`). Powell is slow
    (docs/performance.md) and runs a reduced subset: ``powell_replicas`` replicas of the Fig. 2
    wire, ``powell_schedule_n`` stages, ``powell_sweeps`` Powell iterations per stage (the full
    profile: NR's ITMAX = 200, :data:`POWELL_ITMAX`; the Powell study, ``--profile powell``,
    runs more replicas and both stopping rules).

    The per-node twins of the ``elastic`` and ``plastic`` experiments run ``per_node_replicas``
    replicas (the report says so where they are fewer than ``replicas``) at every point, or
    only at ``per_node_points`` ((k_b, k_s)) and ``per_node_plastic`` ((s, θ_p)) where given
    (the smoke profile); the report marks the values a missing point leaves unmeasured.
    """

    name: str
    replicas: int
    schedule_n: int
    plastic_inset_theta_p: tuple[float, ...]
    per_node_replicas: int
    disorder_replicas: int
    powell_replicas: int
    powell_schedule_n: int
    powell_sweeps: int
    description: str
    per_node_points: tuple[tuple[float, float], ...] | None = None
    per_node_plastic: tuple[tuple[float, float], ...] | None = None

    def to_dict(self) -> dict:
        return asdict(self)


PROFILES: MappingProxyType[str, Profile] = MappingProxyType(
    {
        "full": Profile(
            name="full",
            replicas=10,
            schedule_n=40,
            plastic_inset_theta_p=PLASTIC_INSET_THETA_P,
            per_node_replicas=10,
            disorder_replicas=10,
            powell_replicas=2,
            powell_schedule_n=40,
            powell_sweeps=POWELL_ITMAX,
            description="the paper's 10 replicas everywhere (Powell: 2 replicas, 200 sweeps "
            "per stage, NR's ITMAX)",
        ),
        "quick": Profile(
            name="quick",
            replicas=2,
            schedule_n=16,
            plastic_inset_theta_p=(0.02, 0.1, 0.5),
            per_node_replicas=2,
            disorder_replicas=3,
            powell_replicas=1,
            powell_schedule_n=12,
            powell_sweeps=20,
            description="QUICK PROFILE: 2 replicas (3 with rest-angle disorder), 20 λ stages, "
            "3 θ_p values in the Fig. 6 inset, Powell 1 replica × 16 stages × 20 sweeps; "
            "numbers are indicative, run `crumple reproduce` for the full profile",
        ),
        "smoke": Profile(
            name="smoke",
            replicas=1,
            schedule_n=7,
            plastic_inset_theta_p=(0.02, 0.5),
            per_node_replicas=1,
            disorder_replicas=2,
            powell_replicas=1,
            powell_schedule_n=3,
            powell_sweeps=1,
            description="SMOKE PROFILE (tests only): 1 replica, 11 λ stages, per node only at "
            "3 elastic and 3 plastic points; the numbers mean nothing",
            per_node_points=SMOKE_PER_NODE_POINTS,
            per_node_plastic=SMOKE_PER_NODE_PLASTIC,
        ),
    }
)


def points(pairs) -> list[dict[str, float]]:
    """``[(k_b, k_s), ...]`` as sweep points, without repeats, in order."""
    out: list[dict[str, float]] = []
    for kb, ks in pairs:
        p = {"k_b": float(kb), "k_s": float(ks)}
        if p not in out:
            out.append(p)
    return out


def _key(point: dict, levels: tuple[str, str]) -> tuple[float, float]:
    """A sweep point's coordinates ``levels`` (``plasticity``'s ``s`` and ``theta_p``)."""
    src = point.get("plasticity", point)
    return tuple(float(src[k]) for k in levels)


def _subset(pts: list[dict], keep, levels: tuple[str, str]) -> list[dict]:
    """``pts`` in order, only those whose ``levels`` are in ``keep`` (None: all)."""
    if keep is None:
        return pts
    want = {tuple(float(v) for v in k) for k in keep}
    out = [p for p in pts if _key(p, levels) in want]
    if len(out) != len(want):
        raise ValueError(f"per-node subset {sorted(want)} names points the experiment lacks")
    return out


#: The experiments: what each sweep is for, which figures use it and where its points come from.
EXPERIMENTS: MappingProxyType[str, str] = MappingProxyType(
    {
        "elastic": "Figs. 2-5: the six Fig. 3 points (also Fig. 5's curves), Fig. 4a (k_s = "
        "2e3, k_b = 1..10) and Fig. 4b (k_b = 6, k_s = 2e3..1e7); per-length confinement, "
        "Newton to equilibrium",
        "plastic": "Fig. 6: (5, 5e5) with s = 0.05..0.8 at θ_p = 0.1, and θ_p scanned at s = 0.4; "
        "per-length confinement",
        "elastic_per_node": "the elastic experiment with confinement λ r² per node (Eq. 1 as "
        "printed): the same points, replicas and λ stages",
        "plastic_per_node": "the plastic experiment with confinement λ r² per node",
        "disorder": "alternative: the Fig. 2 wire with quenched rest-angle disorder 0.01 rad "
        "(replicas that differ physically, see docs/model.md)",
        "powell": "alternative: the Fig. 2 wire minimised with the paper's Powell (reduced subset)",
    }
)


def build_sweeps(profile: Profile | str) -> dict[str, Sweep]:
    """The sweeps of ``profile``, by experiment name (:data:`EXPERIMENTS`)."""
    if isinstance(profile, str):
        try:
            profile = PROFILES[profile]
        except KeyError:
            raise ValueError(
                f"unknown profile {profile!r}; choose one of {', '.join(PROFILES)}"
            ) from None
    sched = list(default_schedule(n=profile.schedule_n))
    base_ramp: dict[str, Any] = {"lambdas": sched}
    elastic = points(FIG3_POINTS + FIG4A_POINTS + FIG4B_POINTS)
    kb, ks = FIG2
    plastic = [{"plasticity": {"s": s, "theta_p": PLASTIC_THETA_P}} for s in PLASTIC_S] + [
        {"plasticity": {"s": 0.4, "theta_p": t}}
        for t in profile.plastic_inset_theta_p
        if t != PLASTIC_THETA_P
    ]
    powell_sched = list(default_schedule(n=profile.powell_schedule_n))
    elastic_pn = _subset(elastic, profile.per_node_points, ("k_b", "k_s"))
    plastic_pn = _subset(plastic, profile.per_node_plastic, ("s", "theta_p"))
    return {
        "elastic": Sweep(
            wire={"confinement": CONFINEMENT},
            ramp=base_ramp,
            points=elastic,
            replicas=profile.replicas,
            seed=SEED,
        ),
        "plastic": Sweep(
            wire={"k_b": kb, "k_s": ks, "confinement": CONFINEMENT},
            ramp=base_ramp,
            points=plastic,
            replicas=profile.replicas,
            seed=SEED,
        ),
        "elastic_per_node": Sweep(
            wire={"confinement": PER_NODE},
            ramp=base_ramp,
            points=elastic_pn,
            replicas=profile.per_node_replicas,
            seed=SEED,
        ),
        "plastic_per_node": Sweep(
            wire={"k_b": kb, "k_s": ks, "confinement": PER_NODE},
            ramp=base_ramp,
            points=plastic_pn,
            replicas=profile.per_node_replicas,
            seed=SEED,
        ),
        "disorder": Sweep(
            wire={"k_b": kb, "k_s": ks, "rest_angle_sd": 0.01, "confinement": CONFINEMENT},
            ramp=base_ramp,
            replicas=profile.disorder_replicas,
            seed=SEED,
        ),
        "powell": Sweep(
            wire={"k_b": kb, "k_s": ks, "confinement": CONFINEMENT},
            ramp={"lambdas": powell_sched, "method": "powell", "maxiter": profile.powell_sweeps},
            replicas=profile.powell_replicas,
            seed=SEED,
        ),
    }


# --------------------------------------------------------------------------------------------
# The paper's minimiser given a fair chance (issue 14, item 3): its own study, `--profile powell`
# --------------------------------------------------------------------------------------------

#: NR's stopping rule ``ftol`` (a sweep lowering E by less than this fraction ends the stage):
#: 1e-6, the value of NR's own example (the paper gives none), and 0 (never: the whole ITMAX
#: budget at every stage, the most the stock code allows).
POWELL_RTOLS = (1e-6, 0.0)


@dataclass(frozen=True, slots=True, kw_only=True)
class PowellProfile:
    """How much the Powell study runs: ``replicas`` ramps of the Fig. 2 wire per stopping rule
    (:data:`POWELL_RTOLS`) with ``sweeps`` Powell sweeps per stage at most, over
    ``schedule_n`` geometric stages (plus the paper's four), and the same replicas with Newton
    (same seeds, so the same initial wire)."""

    name: str
    description: str
    replicas: int
    schedule_n: int
    sweeps: int
    rtols: tuple[float, ...]

    def to_dict(self) -> dict:
        return asdict(self)


POWELL_PROFILES: MappingProxyType[str, PowellProfile] = MappingProxyType(
    {
        "full": PowellProfile(
            name="full",
            description="5 replicas of the Fig. 2 wire (the paper ran 10; 5 fit the time of a "
            f"shared 2-core machine), 44 λ stages, Powell with at most {POWELL_ITMAX} sweeps per "
            "stage (NR's ITMAX) under two stopping rules",
            replicas=5,
            schedule_n=40,
            sweeps=POWELL_ITMAX,
            rtols=POWELL_RTOLS,
        ),
        "smoke": PowellProfile(
            name="smoke",
            description="SMOKE PROFILE (tests only): 2 replicas, 7 λ stages, 2 sweeps per "
            "stage; the numbers mean nothing",
            replicas=2,
            schedule_n=3,
            sweeps=2,
            rtols=POWELL_RTOLS,
        ),
    }
)


def build_powell_sweeps(profile: PowellProfile | str) -> dict[str, Sweep]:
    """The Powell study's sweeps: ``powell_paper`` (Powell, one point per stopping rule) and
    ``newton_fig2`` (Newton, the same wire, schedule, replicas and seed)."""
    if isinstance(profile, str):
        if profile not in POWELL_PROFILES:
            raise ValueError(
                f"unknown profile {profile!r}; choose one of {', '.join(POWELL_PROFILES)}"
            )
        profile = POWELL_PROFILES[profile]
    kb, ks = FIG2
    wire = {"k_b": kb, "k_s": ks, "confinement": CONFINEMENT}
    sched = list(default_schedule(n=profile.schedule_n))
    return {
        "powell_paper": Sweep(
            wire=wire,
            ramp={"lambdas": sched, "method": "powell", "maxiter": profile.sweeps},
            # two keys per point, so the store has a "point" dimension (one key would make
            # powell_rtol the dimension); maxiter is the ramp's own, so run ids do not change
            points=[{"powell_rtol": float(r), "maxiter": profile.sweeps} for r in profile.rtols],
            replicas=profile.replicas,
            seed=SEED,
        ),
        "newton_fig2": Sweep(
            wire=wire, ramp={"lambdas": sched}, replicas=profile.replicas, seed=SEED
        ),
    }
