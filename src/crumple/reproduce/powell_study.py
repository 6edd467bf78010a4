"""The paper's minimiser given a fair chance (issue 14, item 3): ``crumple reproduce --profile
powell`` (also ``crumple study powell``).

Runs (:func:`crumple.paper.build_powell_sweeps`): the Fig. 2 wire ramped through the full λ
schedule with Numerical Recipes' Powell from random directions (:func:`crumple.minimize.powell`,
compiled), at most NR's ITMAX = 200 sweeps per stage, under two stopping rules (NR's
``ftol`` = 1e-6, and none: all 200 sweeps at every stage), and the same replicas (same seeds,
same initial wire) with Newton to equilibrium. Measures, with the reproduction's own functions
(:func:`.series._dm`, :func:`.series._alpha`, :func:`.common._fit_replicas`): D_M at λ = 1000
(the paper's fit range and an inner one), α over λ ∈ [100, 2000], ε_l over λ ∈ [500, 2000],
where the wire buckles, the energy above Newton's and the forces at every stage, and how much
the replicas differ. Says: the alternatives table (one line per minimiser) and two claims.
"""

from __future__ import annotations

import itertools

import numpy as np

from .. import paper
from ..geometry import close_segment_pairs
from .common import Context, Estimate, Record, _alt, _fit_replicas, _jsonable, _row
from .experiments import Experiment
from .fig2_configurations import _count_inflections, _kink_ratio, _onset
from .series import CONTACT_FACTOR, LAM_FIG3, Series, _alpha, _dm
from .study import Study

__all__ = ["NEWTON_FIG2", "POWELL_PAPER", "POWELL_STUDY", "sections"]

NAME = "powell_paper"


def _build(name: str):
    def build(profile: paper.PowellProfile):
        return paper.build_powell_sweeps(profile)[name]

    build.__doc__ = f"The {name!r} sweep of :func:`crumple.paper.build_powell_sweeps`."
    return build


def _powell_note(profile: dict) -> str:
    return (
        f"Powell: at most {profile['sweeps']} sweeps per stage (NR's ITMAX), each sweep a line "
        "minimisation along each of the 202 directions (initially a random orthonormal set, "
        "drawn afresh at every stage), under NR's stopping rule with ftol = "
        + " and ".join(f"{r:g}" for r in profile["rtols"])
        + " (0: the whole budget at every stage). Not expected to reach equilibrium."
    )


#: Powell at the paper's likely budget, one point per stopping rule.
POWELL_PAPER = Experiment(
    name="powell_paper",
    levels=("powell_rtol", "maxiter"),
    build=_build("powell_paper"),
    note=_powell_note,
)
#: Newton, the same wire, schedule, replicas and seeds (the same initial wire).
NEWTON_FIG2 = Experiment(name="newton_fig2", levels=(), build=_build("newton_fig2"))

READS = (NEWTON_FIG2, POWELL_PAPER)
NEEDS: tuple[str, ...] = ()
VALUES = ()
FIGURES = {
    "powell_configurations": "The Fig. 2 wire, (k_b, k_s) = (5, 5e5), at the paper's λ: "
    "Newton (equilibrium, replica 0) and Powell from the same initial wire (replica 0 under "
    "each stopping rule, and replica 1 with the whole budget: Powell's replicas differ). "
    f"Orange: segments closer than {CONTACT_FACTOR:g} hard-core widths",
    "powell_stages": "Powell against Newton at every stage (same replicas): (a) the energy "
    "above Newton's, (b) the largest node force, (c) r_max, (d) the Powell sweeps used per "
    "stage (at most 200; NR's rule stops earlier)",
}
_GAMMA = paper.GAMMA_RANGE


def _label(rtol: float, sweeps: int) -> str:
    if rtol > 0:
        return f"Powell, NR rule ftol = {rtol:g} (≤ {sweeps} sweeps)"
    return f"Powell, {sweeps} sweeps every stage"


def _wires(ctx: Context) -> dict[str, tuple[Series, int]]:
    """Every minimiser's series and point: Newton first, then one per stopping rule."""
    pw = ctx.series["powell_paper"]
    out = {"Newton (equilibrium)": (ctx.series["newton_fig2"], 0)}
    for p, key in enumerate(pw.keys):
        out[_label(float(key[0]), ctx.profile["sweeps"])] = (pw, p)
    return out


def _eps_l(s: Series, p: int) -> Estimate:
    """ε_l of γ(λ) ~ λ^ε_l over λ ∈ [500, 2000], per replica then combined (Fig. 4's rows)."""
    sel = (s.lam >= _GAMMA[0]) & (s.lam <= _GAMMA[1])
    return _fit_replicas(s.lam[sel], s.obs["gamma"][p][:, sel])


#: A wire counts as buckled once its bending energy exceeds this ``[energy]``: the initial
#: noise leaves at most ~1e-4 (k_b = 5), a wire just past its Euler load bent into one arc
#: ~0.2 (θ ≈ π/N at each of the N joints).
BENT_ENERGY = 0.01


def _buckling(s: Series, p: int) -> list[float]:
    """Per replica, the first λ at which E_b > :data:`BENT_ENERGY` (NaN: never)."""
    out = []
    for r in range(s.replicas):
        bent = np.flatnonzero(np.nan_to_num(s.energies["bending"][p, r]) > BENT_ENERGY)
        out.append(float(s.lam[bent[0]]) if bent.size else float("nan"))
    return out


def _stages(s: Series, p: int, newton: np.ndarray | None) -> dict:
    """Per-stage curves of one minimiser: energy above Newton's, force, r_max, sweeps."""
    with np.errstate(invalid="ignore"):
        e = np.nanmean(s.energies["total"][p], axis=0)
        out = {
            "lam": s.lam,
            "excess": None if newton is None else e / newton - 1.0,
            "force": np.nanmax(s.max_force[p], axis=0),
            "r_max": np.nanmean(s.obs["r_max"][p], axis=0),
            "sweeps": None,
        }
    if newton is not None and s.iterations is not None:
        out["sweeps"] = np.nanmean(s.iterations[p], axis=0)
    return out


def _spread(s: Series, p: int, lam: float) -> float:
    """Relative standard deviation of the total energy over the replicas at ``lam``."""
    e = s.energies["total"][p, :, s.j(lam)]
    return float(np.nanstd(e) / np.nanmean(e))


def _measures(label: str, s: Series, p: int, nrep: int) -> list[dict]:
    """The alternatives-table lines of one minimiser: D_M (two ranges), α, ε_l."""
    inner = _dm(s, p, fit_range=(0.1, 0.5))
    return [
        _alt("D_M at λ = 1000 (R/R_G ∈ [0.5, 1])", label, _dm(s, p), nrep, 1.33),
        _alt("D_M at λ = 1000 (R/R_G ∈ [0.1, 0.5])", label, inner, nrep, 1.33),
        _alt("α (R_g = r_max ~ λ^α)", label, _alpha(s, p), nrep, -0.25),
        _alt("ε_l (γ ~ λ^ε_l)", label, _eps_l(s, p), nrep, 0.55),
    ]


def _shape(s: Series, p: int) -> dict:
    """The Fig. 2 caption's observables: first interior contact (bracket per replica),
    inflection points at the paper's λ (replica mean), the largest kink ratio."""
    onset = _onset(s.lam, s.obs["contacts_interior"][p])
    infl, kink = [], 1.0
    for lm in paper.PAPER_LAMBDAS:
        j = s.j(lm)
        # a straight wire's "inflections" are its noise: counted on buckled replicas only
        xs = [
            s.positions[p, r, j]
            for r in range(s.replicas)
            if s.valid(p, r, j) and s.energies["bending"][p, r, j] > BENT_ENERGY
        ]
        infl.append(float(np.mean([_count_inflections(x) for x in xs])) if xs else np.nan)
        kink = max([kink, *(_kink_ratio(x) for x in xs)])
    return {
        "contact_onset": onset,
        "contact_onset_range": [min(a for a, _ in onset), max(b for _, b in onset)]
        if onset
        else None,
        "inflections": dict(zip(paper.PAPER_LAMBDAS, infl, strict=True)),
        "kink_ratio": kink,
    }


def _verdicts(summary: dict, ok) -> str:
    yes = [k for k, v in summary.items() if ok(v)]
    no = [k for k in summary if k not in yes]
    return (
        "consistent for: " + ("; ".join(yes) or "none") + "; not for: " + ("; ".join(no) or "none")
    )


def _caption_claims(summary: dict) -> tuple[dict, ...]:
    """The Fig. 2 caption's two sentences, judged for every minimiser."""

    def onset_ok(v):
        r = v["contact_onset_range"]
        return r is not None and r[0] < 1000.0 <= r[1]

    def infl_ok(v):
        vals = list(v["inflections"].values())
        return all(np.isfinite(vals)) and all(b >= a for a, b in itertools.pairwise(vals))

    return (
        {
            "claim": "local structures start to contact each other when λ ≥ 1000",
            "source": "Fig. 2 caption",
            "measured": "first interior contact (both segments ≥ 10 % of the wire from the "
            "ends), bracket over replicas: "
            + "; ".join(
                f"{k}: ({v['contact_onset_range'][0]:.4g}, {v['contact_onset_range'][1]:.4g}]"
                if v["contact_onset_range"]
                else f"{k}: none"
                for k, v in summary.items()
            ),
            "criterion": "1000 inside the bracket (as the reproduction's lambda_contact row)",
            "verdict": _verdicts(summary, onset_ok),
        },
        {
            "claim": "more turning points as λ grows; no sharp edge",
            "source": "Fig. 2 caption",
            "measured": "inflection points at λ = 70, 200, 300, 1000 (replica mean): "
            + "; ".join(
                f"{k}: "
                + ", ".join(f"{x:.3g}" for x in v["inflections"].values())
                + f" (largest kink ratio {v['kink_ratio']:.2f})"
                for k, v in summary.items()
            ),
            "criterion": "non-decreasing over buckled replicas (NaN: all straight), and smooth "
            "(kink ratio ≤ 2), as the reproduction's claims",
            "verdict": _verdicts(summary, lambda v: infl_ok(v) and v["kink_ratio"] <= 2),
        },
    )


def _rows(wires: dict, nrep: int) -> list[dict]:
    """The paper's D_M, α and ε_l against every Powell variant (one row each, with verdict).

    Not declared in ``VALUES``: a budget too small to buckle the wire (the smoke profile)
    leaves ε_l unmeasured, and the report is complete without it."""
    rows = []
    for label, (s, p) in wires.items():
        if not label.startswith("Powell"):
            continue
        for key, est, what in (
            ("D_M", _dm(s, p), "D_M at λ = 1000 of the Fig. 2 wire"),
            ("alpha", _alpha(s, p), "α of the Fig. 2 wire"),
            ("eps_l", _eps_l(s, p), "ε_l of the Fig. 2 wire"),
        ):
            row = _row(key, est, str(nrep), f"{label}; Newton's and the inner D_M range in the "
                       "alternatives table")  # fmt: skip
            row["quantity"] = f"{what} — {label}"
            rows.append(row)
    return rows


def _claims(wires: dict, summary: dict) -> tuple[dict, ...]:
    powell = {k: v for k, v in summary.items() if k.startswith("Powell")}
    folded = ", ".join(
        f"{k}: replicas' energies at λ = 1000 spread {v['energy_spread_1000']:.2g} (relative), "
        f"buckled (E_b > {BENT_ENERGY:g}) at λ = {v['buckling_lam_min']:.4g}–"
        f"{v['buckling_lam_max']:.4g}"
        for k, v in powell.items()
    )
    newton = summary["Newton (equilibrium)"]
    forces = ", ".join(f"{k}: {v['largest_force']:.2g}" for k, v in powell.items())
    return (
        {
            "claim": "Powell's replicas are 'randomly folded' metastable states, distinct from "
            "one another",
            "source": "Sec. II: 'Most of the time, CW are randomly folded rather than forming a "
            "perfect spiral'",
            "measured": f"{folded}; Newton: spread {newton['energy_spread_1000']:.2g}, buckled "
            f"at λ = {newton['buckling_lam_min']:.4g}",
            "criterion": "consistent if Powell's replicas at λ = 1000 differ (energy spread "
            f"above 1e-6) and every replica has buckled by then (E_b > {BENT_ENERGY:g})",
            "verdict": "consistent"
            if all(
                v["energy_spread_1000"] > 1e-6 and v["buckling_lam_max"] <= LAM_FIG3
                for v in powell.values()
            )
            else "not consistent",
        },
        {
            "claim": "each stage is minimised until 'an equilibrium state has been achieved'",
            "source": "Sec. II",
            "measured": f"largest node force over all Powell stages: {forces} "
            f"(Newton: {newton['largest_force']:.2g})",
            "criterion": "max force ≤ 1e-6 at every stage",
            "verdict": "consistent"
            if all(v["largest_force"] <= 1e-6 for v in powell.values())
            else "not consistent (not at the paper's likely budget)",
        },
    )


def _configurations(wires: dict) -> dict:
    """Panels of the configurations figure: replica 0 of every minimiser, and replica 1 of the
    last Powell (its replicas differ), at the paper's λ."""
    rows = {}
    items = [(lab, s, p, 0) for lab, (s, p) in wires.items()]
    lab, (s, p) = list(wires.items())[-1]
    if s.replicas > 1:
        items.append((f"{lab}, replica 1", s, p, 1))
    for label, s, p, r in items:
        panels = []
        for lm in paper.PAPER_LAMBDAS:
            j = s.j(lm)
            if np.isclose(s.lam[j], lm) and s.valid(p, r, j):
                x = s.positions[p, r, j]
                panels.append((x, lm, close_segment_pairs(x, CONTACT_FACTOR * s.hard_core)[0]))
        rows[label] = panels
    return rows


def measure(ctx: Context) -> Record:
    """Powell's states against Newton's: D_M, α, ε_l, buckling, energy, forces, variety."""
    wires = _wires(ctx)
    nt = ctx.series["newton_fig2"]
    e_newton = np.nanmean(nt.energies["total"][0], axis=0)
    nrep = ctx.replicas
    alts, summary, curves = [], {}, {}
    for label, (s, p) in wires.items():
        alts += _measures(label, s, p, nrep)
        newton_e = None if s is nt else np.interp(s.lam, nt.lam, e_newton)
        curves[label] = _stages(s, p, newton_e)
        buck = _buckling(s, p)
        j = s.j(LAM_FIG3)
        summary[label] = {
            "buckling_lam": buck,
            "buckling_lam_min": float(np.nanmin(buck)) if np.isfinite(buck).any() else np.nan,
            "buckling_lam_max": float(np.nanmax(buck)) if np.isfinite(buck).any() else np.nan,
            "energy_spread_1000": _spread(s, p, LAM_FIG3),
            "energy_excess_1000": None
            if curves[label]["excess"] is None
            else float(curves[label]["excess"][j]),
            "largest_force": float(np.nanmax(s.max_force[p])),
            "r_max_1000": float(np.nanmean(s.obs["r_max"][p, :, j])),
            "n_loops_1000": float(np.nanmean(s.obs["n_loops"][p, :, j])),
            "contacts_1000": float(np.nanmean(s.obs["contacts"][p, :, j])),
            "sweeps_mean": None
            if s is nt or s.iterations is None
            else float(np.nanmean(s.iterations[p])),
            **_shape(s, p),
        }
    return Record(
        rows=tuple(_rows(wires, nrep)),
        alternatives=tuple(alts),
        claims=(*_claims(wires, summary), *_caption_claims(summary)),
        extra={"powell_study": _jsonable({"minimisers": summary, "stages": curves})},
        detail={"configurations": _configurations(wires), "curves": curves},
    )


def draw(rec: Record) -> dict:
    """The configurations, and the stage-by-stage comparison."""
    from ..figures import plot_configuration_rows, plot_powell_study

    conf = plot_configuration_rows(
        rec.detail["configurations"],
        title="(k_b, k_s) = (5, 5e5): Newton against the paper's Powell, same initial wire",
        contact_label=f"in contact (closer than {CONTACT_FACTOR:g} hard-core widths)",
    )
    return {"powell_configurations": conf, "powell_stages": plot_powell_study(rec.detail["curves"])}


def sections() -> tuple:
    """The study's one section (this module)."""
    import sys

    return (sys.modules[__name__],)


_CONVENTIONS = (
    "Conventions as in the paper's reproduction (`crumple reproduce`): each exponent is fitted "
    "per replica, the value is the replica mean, σ combines the standard error of the mean and "
    "the rms regression error. D_M at λ = 1000 with R_G = r_max and the exact M(R); α over "
    "λ ∈ [100, 2000]; ε_l over λ ∈ [500, 2000] (γ = E_s/E_b, undefined on a straight wire). "
    "Confinement λ r² per unit length. Powell and Newton start from the same initial wire "
    "(same seed per replica)."
)

#: The Powell study: ``crumple reproduce --profile powell`` runs its ``full`` profile.
POWELL_STUDY = Study(
    name="powell",
    command="crumple study powell",
    title="crumple: the paper's minimiser (Powell) given a fair chance, Fig. 2 wire",
    origin="Budget and stopping rules argued in docs/reproduction.md ('The paper's minimiser'); "
    "nothing was tuned to match.",
    conventions=_CONVENTIONS,
    alternatives="One line per minimiser, the same measurement each (paper's value in the "
    "last column).",
    sections=sections,
    profiles=paper.POWELL_PROFILES,
    profile_fields=tuple(paper.PowellProfile.__dataclass_fields__),
)
