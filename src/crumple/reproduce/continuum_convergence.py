"""Continuum study, section (b): convergence in N at fixed Λ, and the rule "segments per ℓ".

Runs: ``continuum_collapse`` (its points at several N; at equal N the smallest k_b is used, the
others being an exact rescaling). Measures, at each Λ of the schedule and each N, R_g/L and
its relative error against the finest N run, ``|R_g(N) − R_g(N_max)|/R_g(N_max)``, with
``ℓ/Δs = N Λ^{-1/4}`` segments per loop size. The rule: the smallest ℓ/Δs above which every
(Λ, N < N_max) has an error below the profile's tolerance. Says: the N-convergence table (in
the table of variants) and one claim (the rule).
"""

from __future__ import annotations

import math

import numpy as np

from ..continuum import segments_per_loop
from .common import Context, Estimate, Record, _alt
from .continuum import COLLAPSE
from .continuum_collapse import on_grid, point_curves

NAME = "continuum_convergence"
READS = (COLLAPSE,)
NEEDS: tuple[str, ...] = ()
VALUES: tuple = ()
FIGURES = {
    "continuum_convergence": "Convergence in N: relative error of R_g/L against the finest N "
    "run, |R_g(N) − R_g(N_max)|/R_g(N_max), against the segments per loop size ℓ/Δs = NΛ^-1/4, "
    "one colour per Λ; dotted: the profile's tolerance",
}


def convergence_rule(seg_per_loop, errors, tolerance: float) -> float:
    """The smallest ``ℓ/Δs`` such that every case with at least that many segments per loop
    has an error below ``tolerance``; NaN if even the best-resolved case fails, or if no case
    is resolved. Cases are paired arrays (NaN errors are ignored).

    >>> convergence_rule([2, 4, 8, 16], [0.05, 0.02, 0.004, 0.001], 0.01)
    8.0
    >>> convergence_rule([2, 4], [0.05, 0.02], 0.01)
    nan
    """
    s = np.asarray(seg_per_loop, float)
    e = np.asarray(errors, float)
    ok = np.isfinite(s) & np.isfinite(e)
    s, e = s[ok], e[ok]
    if s.size == 0:
        return math.nan
    order = np.argsort(s)
    s, e = s[order], e[order]
    bad = np.flatnonzero(e >= tolerance)
    if bad.size == 0:
        return float(s[0])
    if bad[-1] == s.size - 1:
        return math.nan
    return float(s[bad[-1] + 1])


def measure(ctx: Context) -> Record:
    """R_g/L against N at every Λ, the errors, and the rule."""
    curves = point_curves(ctx.series["continuum_collapse"])
    grid = np.asarray(ctx.profile["confinements"], float)
    tol = float(ctx.profile["convergence_tolerance"])
    by_n: dict[int, dict] = {}
    for c in sorted(curves, key=lambda c: c["k_b"]):
        by_n.setdefault(c["N"], c)
    ns = sorted(by_n)
    v = on_grid([by_n[n] for n in ns], grid, "R_g/L")  # (N, Λ)
    n_max = ns[-1]
    with np.errstate(invalid="ignore", divide="ignore"):
        err = np.abs(v - v[-1]) / np.abs(v[-1])
    spl = np.array([[segments_per_loop(g, n) for g in grid] for n in ns])
    rule = convergence_rule(spl[:-1].ravel(), err[:-1].ravel(), tol)
    alts = []
    for j, g in enumerate(grid):
        for i, n in enumerate(ns):
            e = "reference" if n == n_max else f"error {100 * err[i, j]:.2g}%"
            alts.append(
                _alt(
                    f"R_g/L at Λ = {g:.3g}",
                    f"N = {n}, ℓ/Δs = {spl[i, j]:.3g} ({e})",
                    Estimate(float(v[i, j]), math.nan, 1),
                    1,
                )
            )
    claim = {
        "claim": f"N-convergence rule: segments per loop size ℓ/Δs = NΛ^-1/4 for a relative "
        f"R_g error below {100 * tol:g}%",
        "source": "issue 12: 'state the N needed per Λ, as a rule: segments per ℓ'",
        "measured": (f"ℓ/Δs ≥ {rule:.3g}" if math.isfinite(rule) else "not reached at the N run")
        + f" (N = {', '.join(map(str, ns))} against N = {n_max}; Λ = {grid[0]:.3g} … "
        f"{grid[-1]:.3g})",
        "criterion": f"every (Λ, N < {n_max}) with at least that ℓ/Δs has an error below "
        f"{100 * tol:g}% (against the finest N, which understates the error by its own)",
        "verdict": "rule measured" if math.isfinite(rule) else "not measured",
    }
    extra = {
        "continuum_convergence": {
            "N": ns,
            "confinements": grid,
            "R_g": v,
            "relative_error": err,
            "segments_per_loop": spl,
            "tolerance": tol,
            "rule_segments_per_loop": rule,
        }
    }
    return Record(
        alternatives=tuple(alts),
        claims=(claim,),
        extra=extra,
        detail={"N": ns, "grid": grid, "err": err, "spl": spl, "tol": tol},
    )


def draw(rec: Record) -> dict:
    """The relative error against ℓ/Δs."""
    import matplotlib.pyplot as plt

    d = rec.detail
    fig, ax = plt.subplots(figsize=(6.5, 4.5), constrained_layout=True)
    for j, g in enumerate(d["grid"]):
        e = d["err"][:-1, j]
        x = d["spl"][:-1, j]
        ok = np.isfinite(e) & (e > 0)
        if ok.any():
            ax.loglog(x[ok], e[ok], "o-", label=f"Λ = {g:.3g}")
    ax.axhline(d["tol"], ls=":", color="k")
    ax.set_xlabel("segments per loop size ℓ/Δs = NΛ^-1/4")
    ax.set_ylabel(f"|R_g(N) − R_g({d['N'][-1]})| / R_g({d['N'][-1]})")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    return {"continuum_convergence": fig}
