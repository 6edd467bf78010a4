"""The paper's open choices side by side at the Fig. 2 point, and the figure of every
alternative of the report.

Runs: ``elastic`` at :data:`crumple.paper.FIG2` and the three variants of that wire:
``elastic_per_node`` (Eq. 1 as printed), ``disorder`` (quenched rest-angle disorder) and
``powell``.
Measures: α, D_M and γ of each, and the relative spread of the energy over replicas (are the
replicas different foldings?). Says: alternatives and one claim. Draws every alternative of
the sections it names in ``NEEDS`` (and its own) in one figure.
"""

from __future__ import annotations

import math

import numpy as np

from .. import paper
from .common import Context, Estimate, Record, _alt, _combine
from .experiments import DISORDER, ELASTIC, ELASTIC_PER_NODE, POWELL
from .series import _alpha, _dm

NAME = "alternatives"
READS = (ELASTIC, ELASTIC_PER_NODE, DISORDER, POWELL)
NEEDS = ("fig3_mass_size", "fig4_gamma", "fig5_radius")
VALUES = ()
FIGURES = {
    "fig_alternatives": "The paper's open choices side by side (error bars ±2σ, as in every "
    "figure; a missing point could not be measured, see the table; a quantity spanning "
    "decades, such as γ, on a log axis)",
}
_SPREAD = "relative replica spread of E at λ = 1000"


def _variant(label: str, s, p: int) -> list[dict]:
    """α, D_M, γ and the energy spread of one wire at (5, 5e5)."""
    gj = s.obs["gamma"][p, :, s.j(1000.0)]
    e = s.energies["total"][p, :, s.j(1000.0)]
    e = e[np.isfinite(e)]
    spread = float(np.std(e) / np.mean(e)) if e.size > 1 else math.nan
    return [
        {
            **_alt("α at (5, 5e5)", label, _alpha(s, p), s.replicas, -0.25),
            "fit_window": list(paper.ALPHA_RANGE),
        },
        _alt("D_M at (5, 5e5), λ = 1000", label, _dm(s, p), s.replicas, 1.33),
        _alt("γ at (5, 5e5), λ = 1000", label, _combine(gj, np.zeros_like(gj)), s.replicas),
        _alt(_SPREAD, label, Estimate(spread, 0.0, e.size), s.replicas),
    ]


def _metastable_claim(alts: list[dict]) -> dict:
    sp = [a for a in alts if a["quantity"].startswith("relative replica spread")]
    return {
        "claim": "the model has many metastable foldings: replicas started from different "
        "random shapes end in different ones",
        "source": "Sec. II: 'Most of the time, CW are randomly folded rather than forming a "
        "perfect spiral ... those folded configurations are metastable states'",
        "measured": "relative spread of E_total over replicas at λ = 1000: "
        + "; ".join(
            f"{a['variant']}: {a['value']:.2g} ({a['replicas']} replicas)"
            for a in sp
            if a["value"] is not None
        ),
        "criterion": "spread above 1e-3 for the paper's model at equilibrium (Newton, "
        "per length; each replica starts from its own random transverse noise)",
        "verdict": "consistent" if (sp[0]["value"] or 0) > 1e-3 else "not consistent",
    }


def measure(ctx: Context) -> Record:
    """The four wires at (5, 5e5); the groups of the alternatives figure."""
    el = ctx.series["elastic"]
    pn = ctx.series["elastic_per_node"]
    variants = (
        ("per-length, Newton (default)", el, el.index(paper.FIG2)),
        ("per-node (Eq. 1 as printed)", pn, pn.index(paper.FIG2)),
        ("rest-angle disorder 0.01 rad", ctx.series["disorder"], 0),
        ("Powell (paper's method, reduced)", ctx.series["powell"], 0),
    )
    alts = [a for label, s, p in variants for a in _variant(label, s, p)]
    groups: dict[str, list] = {}
    every = [a for name in NEEDS for a in ctx.records[name].alternatives] + alts
    for a in every:
        if a["quantity"].startswith("relative replica spread"):
            continue
        groups.setdefault(a["quantity"], []).append(
            (a["variant"], a["value"], a["sigma"], a["paper"])
        )
    return Record(
        alternatives=tuple(alts),
        claims=(_metastable_claim(alts),),
        detail={"groups": groups},
    )


def draw(rec: Record) -> dict:
    """Every alternative, one panel per quantity."""
    from ..figures import plot_alternatives

    return {"fig_alternatives": plot_alternatives(rec.detail["groups"])}
