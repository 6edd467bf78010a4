"""Continuum study, section (a): the collapse onto the confinement number Λ.

Runs: ``continuum_collapse`` ((k_b, N) pairs ramped through one Λ schedule, k_s stiff) and
``continuum_fig5`` (the paper's six Fig. 5 (k_b, k_s) at N = 100, ramped in λ). Measures, at
each Λ of the schedule, the relative spread (max − min)/mean of R_g/L, r_max/L and E_b L/B over
all points, over points at equal N (an exact rescaling of the discrete energy, up to the hard
core), and the discretisation error |y(N) − y(2N)|/y(2N) of the coarsest N; and the scatter of
ln r_max of the Fig. 5 curves against λ and against Λ. Says: one row (the spread, with the
discretisation error as its σ), one claim (do the paper's curves collapse against Λ).
"""

from __future__ import annotations

import math

import numpy as np

from ..paper import PaperValue
from .common import Context, Estimate, Record, _alt, _row, nan_quiet
from .continuum import COLLAPSE, FIG5
from .lambda_collapse import collapses, draw_lambda_collapse, fig5_curves, log_scatter
from .series import Series

NAME = "continuum_collapse"
READS = (COLLAPSE, FIG5)
NEEDS: tuple[str, ...] = ()
VALUE = PaperValue(
    "continuum_collapse",
    "largest relative spread of R_g/L over (k_b, λ, N) at equal Λ (σ: discretisation error)",
    0.0,
    "issue 12: one control parameter Λ = λL⁴/B once N resolves ℓ and k_s is stiff",
)
VALUES = (VALUE,)
FIGURES = {
    "continuum_collapse": "Continuum units against Λ = λL⁴/B for every (k_b, N) of the "
    "collapse experiment (k_s stiff): R_g/L (RMS radius), r_max/L, E_b L/B, γ = E_s/E_b, "
    "contacts per segment and loops. Points at equal N coincide (an exact rescaling); "
    "different N differ by the discretisation error",
    "continuum_fig5_lambda": "The paper's Fig. 5 points (N = 100, their own k_s): r_max "
    "against λ (left) and against Λ = λN/k_b (right); the scatter of ln r_max over the curves "
    "is in the claims table",
}
#: The observables shown, in continuum units: name -> (label, function of (series, p) -> y).
QUANTITIES = ("R_g/L", "r_max/L", "E_b L/B", "E_conf L/B", "γ", "contacts/N", "loops")


def _n_of(key) -> int:
    return round(float(key[2]))


def point_curves(s: Series, replica: int = 0) -> list[dict]:
    """Per point of a (k_b, k_s, N, λ-list) series: Λ of each stage run and the observables in
    continuum units (L0 = 1). Stages not run are dropped."""
    out = []
    for p, key in enumerate(s.keys):
        kb, ks, n = float(key[0]), float(key[1]), _n_of(key)
        r = s.obs["radius_of_gyration"][p, replica]
        ok = np.isfinite(r)
        b = kb / n
        out.append(
            {
                "k_b": kb,
                "k_s": ks,
                "N": n,
                "Lambda": s.lam[ok] * n / kb,
                "converged": s.converged[p, replica][ok],
                "y": {
                    "R_g/L": r[ok],
                    "r_max/L": s.obs["r_max"][p, replica][ok],
                    # straight stages: E_b is round-off (NaN, as γ; stage_observables.STRAIGHT)
                    "E_b L/B": np.where(
                        s.obs["straight"][p, replica], np.nan, s.energies["bending"][p, replica]
                    )[ok]
                    / b,
                    "E_conf L/B": s.energies["confinement"][p, replica][ok] / b,
                    "γ": s.obs["gamma"][p, replica][ok],
                    "contacts/N": s.obs["contacts"][p, replica][ok] / n,
                    "loops": s.obs["n_loops"][p, replica][ok],
                },
            }
        )
    return out


def on_grid(curves: list[dict], grid, name: str) -> np.ndarray:
    """(point, Λ of ``grid``) values of observable ``name``; NaN where a point has no stage
    within 1e-6 (relative) of that Λ."""
    grid = np.asarray(grid, float)
    out = np.full((len(curves), grid.size), np.nan)
    for i, c in enumerate(curves):
        for j, g in enumerate(grid):
            k = np.flatnonzero(np.isclose(c["Lambda"], g, rtol=1e-6, atol=0))
            if k.size:
                out[i, j] = c["y"][name][k[0]]
    return out


def _spread(v: np.ndarray) -> np.ndarray:
    """(max − min)/|mean| over axis 0 (NaN-aware; NaN where fewer than 2 values)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.sum(np.isfinite(v), axis=0)
        d = (nan_quiet(np.nanmax, v, axis=0) - nan_quiet(np.nanmin, v, axis=0)) / np.abs(
            nan_quiet(np.nanmean, v, axis=0)
        )
    return np.where(n >= 2, d, np.nan)


def spreads(curves: list[dict], grid, name: str) -> dict:
    """The collapse numbers of one observable at every Λ of ``grid``: the spread over all
    points, over points at equal N (largest over N), and the discretisation error of the
    coarsest N against 2N (k_b of the coarsest point; NaN when 2N was not run)."""
    v = on_grid(curves, grid, name)
    ns = np.array([c["N"] for c in curves])
    same = np.full(len(grid), np.nan)
    for n in np.unique(ns):
        if (ns == n).sum() > 1:
            same = np.fmax(same, _spread(v[ns == n]))
    n0 = int(ns.min())
    disc = np.full(len(grid), np.nan)
    if (ns == 2 * n0).any():
        a = nan_quiet(np.nanmean, v[ns == n0], axis=0)
        b = nan_quiet(np.nanmean, v[ns == 2 * n0], axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            disc = np.abs(a - b) / np.abs(b)
    return {"all": _spread(v), "same_n": same, "discretisation": disc, "n_coarse": n0}


def _max(a) -> float:
    a = np.asarray(a, float)
    return float(np.nanmax(a)) if np.isfinite(a).any() else math.nan


def _by_lambda(rg: dict, grid) -> dict:
    """The collapse Λ by Λ: R_g/L's spread over every (k_b, N) against 2 × the discretisation
    error at the same Λ (the row compares the two largest over Λ, which may sit at different
    Λ)."""
    with np.errstate(invalid="ignore"):
        holds = rg["all"] <= 2.0 * rg["discretisation"]
    ok = np.isfinite(rg["all"]) & np.isfinite(rg["discretisation"])
    return {"Lambda": np.asarray(grid, float), "spread": rg["all"],
            "discretisation": rg["discretisation"], "holds": np.where(ok, holds, False),
            "measured": ok}  # fmt: skip


def _by_lambda_claim(b: dict) -> dict:
    lam, holds, ok = b["Lambda"], b["holds"], b["measured"]
    fails = lam[ok & ~holds]
    listed = ", ".join(f"{v:.3g}" for v in fails) if fails.size else "none"
    verdict = (
        "not measured" if not ok.any() else "collapse at every Λ" if not fails.size
        else f"collapse at {int((ok & holds).sum())} of {int(ok.sum())} Λ"
    )  # fmt: skip
    return {
        "claim": "R_g/L collapses onto Λ at each Λ, not only in the largest spread",
        "source": "issue 12: 'two parameter sets with the same Λ give the same R_g to within "
        "the discretisation error'",
        "measured": f"Λ where the spread over all (k_b, N) exceeds 2 × the discretisation error "
        f"at that Λ: {listed}",
        "criterion": "spread(Λ) ≤ 2 |R_g(N) − R_g(2N)|/R_g(2N) (coarsest N) at the same Λ",
        "verdict": verdict,
    }


def measure(ctx: Context) -> Record:
    """The spreads at equal Λ, the discretisation error, and the Fig. 5 scatter."""
    s = ctx.series["continuum_collapse"]
    curves = point_curves(s)
    grid = np.asarray(ctx.profile["confinements"], float)
    sp = {q: spreads(curves, grid, q) for q in ("R_g/L", "r_max/L", "E_b L/B")}
    rg = sp["R_g/L"]
    spread_rg, disc_rg = _max(rg["all"]), _max(rg["discretisation"])
    row = _row(
        VALUE.key,
        Estimate(spread_rg, disc_rg, len(curves), (float(grid[0]), float(grid[-1]))),
        f"1 × {len(curves)} (k_b, N)",
        f"σ = |R_g(N) − R_g(2N)|/R_g(2N) at N = {rg['n_coarse']}, the coarsest N; spread at "
        f"equal N {_max(rg['same_n']):.1e} (an exact rescaling of the energy: more than "
        "~1e-5 means the ramps reached different states)",
        reference=VALUE,
    )
    row["fit_window"] = [float(grid[0]), float(grid[-1])]
    alts = []
    for q, v in sp.items():
        for variant, key in (
            ("spread over all (k_b, N)", "all"),
            ("spread at equal N", "same_n"),
            (f"discretisation error, N = {v['n_coarse']} vs {2 * v['n_coarse']}", "discretisation"),
        ):
            alts.append(
                _alt(
                    f"collapse of {q}, largest over Λ",
                    variant,
                    Estimate(
                        _max(v[key]), math.nan, len(curves), (float(grid[0]), float(grid[-1]))
                    ),
                    1,
                )
            )
    f5 = fig5_curves(ctx.series["continuum_fig5"])
    before = log_scatter({k: (c["lam"], c["r_max"]) for k, c in f5.items()})
    after = log_scatter({k: (c["Lambda"], c["r_max"]) for k, c in f5.items()})
    claim = {
        "claim": "the paper's Fig. 5 curves (six (k_b, k_s), N = 100) collapse against Λ = λN/k_b",
        "source": "issue 12: 'The curves in Fig. 5a for k_b = 1 (two values of k_s) lie on "
        "top of each other'",
        "measured": f"scatter of ln r_max across the six curves {before:.3f} against λ, "
        f"{after:.3f} against Λ (RMS over the common range)",
        "criterion": "collapse if the scatter against Λ is ≤ 1/3 of that against λ and ≤ 0.05",
        "verdict": "collapse" if collapses(before, after) else "no collapse",
    }
    by_lam = _by_lambda(rg, grid)
    extra = {
        "continuum_collapse": {
            "by_Lambda": by_lam,
            "confinements": grid,
            "spreads": {
                q: {k: v[k] for k in ("all", "same_n", "discretisation")} for q, v in sp.items()
            },
            "n_coarse": rg["n_coarse"],
            "fig5_scatter_lambda": before,
            "fig5_scatter_Lambda": after,
        }
    }
    return Record(
        rows=(row,),
        alternatives=tuple(alts),
        claims=(claim, _by_lambda_claim(by_lam)),
        extra=extra,
        detail={"curves": curves, "fig5": f5},
    )


def draw(rec: Record) -> dict:
    """The collapse panels, and the Fig. 5 curves against λ and against Λ."""
    import matplotlib.pyplot as plt

    curves = rec.detail["curves"]
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), constrained_layout=True)
    for ax, q in zip(axes.flat, ("R_g/L", "r_max/L", "E_b L/B", "γ", "contacts/N", "loops"),
                     strict=True):  # fmt: skip
        for c in curves:
            y = c["y"][q]
            ok = np.isfinite(y) & (y > 0)
            ax.plot(c["Lambda"][ok], y[ok], "o-", ms=3, lw=1,
                    label=f"k_b={c['k_b']:g}, N={c['N']}")  # fmt: skip
        ax.set_xscale("log")
        if q not in ("loops",):
            ax.set_yscale("log")
        ax.set_xlabel("Λ = λL⁴/B")
        ax.set_ylabel(q)
    axes.flat[0].legend(fontsize=7)
    ex = rec.extra["continuum_collapse"]
    fig2 = draw_lambda_collapse(
        rec.detail["fig5"], ex["fig5_scatter_lambda"], ex["fig5_scatter_Lambda"]
    )
    return {"continuum_collapse": fig, "continuum_fig5_lambda": fig2}


def discuss(rec: Record, records) -> dict[str, str]:
    """What the spread means."""
    r = rec.rows[0]
    return {
        VALUE.key: (
            "At equal N, (k_b, λ, k_s) → (a k_b, a λ, a k_s) multiplies the discrete energy by "
            "a (except the hard core, whose energy scale is fixed), so those points coincide to "
            "the solver's tolerance unless the ramp snaps into different metastable states; "
            "across N the spread is the discretisation error, which is the tolerance of the "
            f"collapse (σ = {r['sigma']:.2g} here), unless the states differ (then the number "
            "of loops differs between points: collapse figure). The collapse is stated only "
            "where the spread is within 2σ."
        )
    }
