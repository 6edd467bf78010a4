"""The alternative to the paper's Fig. 5 collapse: one control parameter Λ = λN/k_b.

Runs: ``elastic`` at :data:`crumple.paper.FIG3_POINTS` (the six Fig. 5 curves, N = 100, the
paper's own k_s). With per-length confinement and k_s ≫ k_b the discrete energy depends on
(k_b, λ, N) through the confinement number Λ = λL⁴/B = λN/k_b only (docs/continuum.md), so
r_max/L should be one curve of Λ whatever k_s, while the paper rescales R_g by
(k_b k_s)^1.2 at fixed λ. Measures: the scatter of ln r_max across the six curves, as the RMS
over their common range of the standard deviation across curves (the continuum study's
measure), against λ as it stands, after the paper's rescaling (its c = 1.2 and the fitted c
of section ``fig5_radius``), and against Λ. Says: alternatives rows and one claim, judged by
the continuum study's criterion; the collapse is stated only if the data show it.
"""

from __future__ import annotations

import math

import numpy as np

from .. import paper
from .common import Context, Estimate, Record, _alt, nan_quiet
from .experiments import ELASTIC
from .series import Series

NAME = "lambda_collapse"
READS = (ELASTIC,)
NEEDS: tuple[str, ...] = ("fig5_radius",)
VALUES: tuple = ()
FIGURES = {
    "lambda_collapse": "The six Fig. 5 curves (replica-mean r_max, N = 100, the paper's own "
    "k_s): against λ (left) and against the confinement number Λ = λN/k_b (right). The "
    "titles give the scatter of ln r_max across the curves (RMS over their common range)",
}
#: The paper's collapse exponent, Fig. 5 caption: R_g ~ (k_b k_s)^1.2.
PAPER_C = 1.2


def log_scatter(curves: dict, n_grid: int = 40) -> float:
    """RMS over a common log grid (the abscissae's overlap) of the standard deviation of
    ln y across the curves; curves: label -> (x, y), x increasing."""
    lo = max(float(np.min(x)) for x, _ in curves.values())
    hi = min(float(np.max(x)) for x, _ in curves.values())
    if not lo < hi:
        return math.nan
    g = np.geomspace(lo, hi, n_grid)
    ly = np.array([np.interp(np.log(g), np.log(x), np.log(y)) for x, y in curves.values()])
    return float(np.sqrt(np.mean(ly.std(axis=0) ** 2)))


def collapses(before: float, after: float) -> bool:
    """The collapse criterion: the scatter ``after`` is at most a third of ``before`` and at
    most 0.05 (in ln)."""
    return bool(np.isfinite(after) and after <= before / 3 and after <= 0.05)


def fig5_curves(s: Series, keys=None) -> dict:
    """(k_b, k_s) -> replica-mean r_max against λ and against Λ = λN/k_b, for the points
    ``keys`` of ``s`` (default: all)."""
    out = {}
    for p, key in enumerate(s.keys):
        if keys is not None and tuple(float(k) for k in key[:2]) not in keys:
            continue
        y = nan_quiet(np.nanmean, s.obs["r_max"][p], axis=0)
        ok = np.isfinite(y) & (s.lam > 0)
        n = s.positions.shape[3] - 1
        out[(float(key[0]), float(key[1]))] = {
            "lam": s.lam[ok],
            "Lambda": s.lam[ok] * n / float(key[0]),
            "r_max": y[ok],
            "N": n,
        }
    return out


def draw_lambda_collapse(f5: dict, before: float, after: float):
    """r_max against λ (left) and against Λ = λN/k_b (right), one curve per (k_b, k_s)."""
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    for k, c in f5.items():
        lab = f"k_b={k[0]:g}, k_s={k[1]:g}"
        a.loglog(c["lam"], c["r_max"], "o-", ms=3, lw=1, label=lab)
        b.loglog(c["Lambda"], c["r_max"], "o-", ms=3, lw=1, label=lab)
    a.set_xlabel("λ")
    b.set_xlabel("Λ = λN/k_b")
    for ax in (a, b):
        ax.set_ylabel("r_max / L")
    a.legend(fontsize=7)
    a.set_title(f"against λ: scatter of ln r_max {before:.3f}")
    b.set_title(f"against Λ: scatter {after:.3f}")
    return fig


def _rescaled(f5: dict, c: float) -> dict:
    """The paper's collapse: r_max (g_ref / k_b k_s)^c against λ."""
    g_ref = paper.FIG5_REFERENCE[0] * paper.FIG5_REFERENCE[1]
    return {k: (v["lam"], v["r_max"] * (g_ref / (k[0] * k[1])) ** c) for k, v in f5.items()}


def measure(ctx: Context) -> Record:
    """The scatter of ln r_max across the six curves under each choice of variable."""
    el = ctx.series["elastic"]
    f5 = fig5_curves(el, keys=set(paper.FIG3_POINTS))
    c_fit = float(ctx.records["fig5_radius"].extra["collapse"]["exponent"])
    lam_range = (float(el.lam[el.lam > 0].min()), float(el.lam.max()))
    scatter = {
        "raw": log_scatter({k: (v["lam"], v["r_max"]) for k, v in f5.items()}),
        "paper": log_scatter(_rescaled(f5, PAPER_C)),
        "fitted": log_scatter(_rescaled(f5, c_fit)) if math.isfinite(c_fit) else math.nan,
        "Lambda": log_scatter({k: (v["Lambda"], v["r_max"]) for k, v in f5.items()}),
    }
    n = len(f5)
    quantity = "scatter of ln r_max across the six Fig. 5 curves"
    alts = tuple(
        _alt(quantity, variant, Estimate(scatter[key], math.nan, n, lam_range), ctx.replicas)
        for variant, key in (
            ("against λ, not rescaled", "raw"),
            (f"paper: r_max (k_b k_s)^−{PAPER_C:g} against λ", "paper"),
            (f"r_max (k_b k_s)^−c against λ, c = {c_fit:.3f} fitted (fig5_radius)", "fitted"),
            ("against Λ = λN/k_b, not rescaled", "Lambda"),
        )
    )
    ok = collapses(scatter["raw"], scatter["Lambda"])
    claim = {
        "claim": "the Fig. 5 curves collapse against the one control parameter Λ = λN/k_b "
        "(the alternative to the paper's (k_b k_s)^1.2)",
        "source": "issue 12; the paper's Fig. 5 caption: 'All data collapse ... with the "
        "scaling R_g ~ (k_b k_s)^1.2'",
        "measured": f"scatter of ln r_max {scatter['raw']:.3f} against λ, {scatter['Lambda']:.3f} "
        f"against Λ; with the paper's (k_b k_s)^1.2 {scatter['paper']:.3f}, with the fitted "
        f"c = {c_fit:.3f} {scatter['fitted']:.3f}",
        "criterion": "collapse if the scatter against Λ is ≤ 1/3 of that against λ and ≤ 0.05 "
        "(the continuum study's criterion)",
        "verdict": "collapse" if ok else "no collapse",
    }
    extra = {
        "lambda_collapse": {
            "scatter": scatter,
            "c_fitted": c_fit,
            "paper_c": PAPER_C,
            "n_curves": n,
        }
    }
    return Record(alternatives=alts, claims=(claim,), extra=extra, detail={"fig5": f5})


def draw(rec: Record) -> dict:
    """The six curves against λ and against Λ."""
    s = rec.extra["lambda_collapse"]["scatter"]
    return {"lambda_collapse": draw_lambda_collapse(rec.detail["fig5"], s["raw"], s["Lambda"])}


def notes(rec: Record) -> list[str]:
    """What the Λ collapse says about the paper's (k_b k_s)^1.2."""
    s = rec.extra["lambda_collapse"]["scatter"]
    if not np.isfinite(s["Lambda"]):
        return ["Λ collapse: not measured (no common range of Λ across the six curves)."]
    verdict = rec.claims[0]["verdict"]
    return [
        f"Λ collapse (section lambda_collapse): across the six Fig. 5 curves the scatter of "
        f"ln r_max is {s['raw']:.3f} against λ, {s['paper']:.3f} after the paper's "
        f"(k_b k_s)^1.2 rescaling, {s['fitted']:.3f} after the best power of k_b k_s, and "
        f"{s['Lambda']:.3f} against Λ = λN/k_b: {verdict} by the continuum study's criterion. "
        "Λ involves k_b alone: where it collapses the curves, k_s does not enter, as the "
        "continuum limit with stiff k_s says it must (docs/continuum.md)."
    ]
