"""Fig. 2: the configurations at λ = 70, 200, 300, 1000, and what its caption says of them.

Runs: ``elastic`` and ``elastic_per_node`` at :data:`crumple.paper.FIG2`, and the ``powell``
wire beside them. Measures, under each reading of Eq. 1: the onset of contacts between loops
(the bracket of stages), the first contact, contacts against λ, the sharpest kink, the number
of turning points and γ at (5, 5e5). Says: row ``lambda_contact`` and three claims.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from .. import paper
from ..geometry import close_segment_pairs, turning_angles
from .common import (
    Context,
    Estimate,
    Record,
    _both_readings_discussion,
    _both_readings_reasons,
    _missing_points_ok,
    _row,
    _twin,
    nan_quiet,
)
from .experiments import ELASTIC, ELASTIC_PER_NODE, POWELL
from .series import CONTACT_FACTOR, Series

NAME = "fig2_configurations"
READS = (ELASTIC, ELASTIC_PER_NODE, POWELL)
NEEDS: tuple[str, ...] = ()
VALUES = (paper.PAPER_VALUES["lambda_contact"],)
FIGURES = {
    "fig2_configurations": "Fig. 2: configurations at λ = 70, 200, 300, 1000 (replica 0; x "
    "and y in units of L0; the panels of a row share one scale, with a scale bar; blue circle "
    "and red square: the wire's first and last node; grey cross: the trap centre; orange: "
    f"segments in contact, closer than {CONTACT_FACTOR:g} hard-core widths, as counted in "
    "the table's contact row)"
}


def _count_inflections(x, rel: float = 0.02) -> int:
    th = turning_angles(x)
    big = th[np.abs(th) > rel * np.abs(th).max()]
    return int(np.sum(np.sign(big[1:]) != np.sign(big[:-1])))


def _kink_ratio(x) -> float:
    """Largest |θ_i| / max(|θ_{i-1}|, |θ_{i+1}|) over the joints that turn by at least a
    quarter of the largest turn (near an inflection every ratio is noise): about 1 on a smooth
    wire, >> 1 at a kink."""
    th = np.abs(turning_angles(x))
    mid, nb = th[1:-1], np.maximum(th[:-2], th[2:])
    big = mid >= 0.25 * th.max()
    if not big.any():
        return 1.0
    return float(np.max(mid[big] / np.maximum(nb[big], 1e-12)))


def _onset(lam, counts) -> list[tuple[float, float]]:
    """(last stage without, first stage with) a contact, per replica; NaN stages skipped."""
    out = []
    for r in range(counts.shape[0]):
        fin = np.flatnonzero(np.isfinite(counts[r]))
        hit = fin[counts[r, fin] > 0]
        if hit.size:
            before = fin[fin < hit[0]]
            out.append((float(lam[before[-1]]) if before.size else 0.0, float(lam[hit[0]])))
    return out


def _contact_row(first, first_any, nrep: int) -> dict:
    any_txt = (
        f"; the first contact of any kind (the wire's ends closing the first loop) is at "
        f"λ = {np.median([b for _, b in first_any]):g}"
        if first_any
        else ""
    )
    if not first:
        row = _row(
            "lambda_contact",
            Estimate(math.inf, math.nan, 0),
            str(nrep),
            "no interior contact at any stage up to the last" + any_txt,
        )
        row["ours"], row["verdict"] = None, "differs (no contact)"
        return row
    lo_c = min(a for a, _ in first)
    hi_c = max(b for _, b in first)
    val = float(np.median([b for _, b in first]))
    row = _row(
        "lambda_contact",
        Estimate(val, math.nan, len(first), (lo_c, hi_c)),
        str(nrep),
        "first stage where two segments at least a tenth of the wire away from both ends "
        f"are closer than {CONTACT_FACTOR:g} hard-core widths (median over replicas); the "
        f"onset lies between stages, in ({lo_c:g}, {hi_c:g}] (the 'fit range' column)" + any_txt,
    )
    row["bracket"] = True
    inside = lo_c < 1000.0 <= hi_c
    row["verdict"] = "agrees (1000 in the bracket)" if inside else "differs"
    row["deviation_sigma"] = None
    return row


def _shape_claims(wires: dict[str, tuple[Series, int]], judged: str) -> list[dict]:
    """No sharp edge, and more turning points as λ grows (the caption's two sentences), judged
    on the wire ``judged`` (replica 0 for the turning points)."""
    infl, kinks = {}, {}
    for name, (s, p) in wires.items():
        infl[name] = [
            _count_inflections(s.positions[p, 0, s.j(lm)]) if s.valid(p, 0, s.j(lm)) else None
            for lm in paper.PAPER_LAMBDAS
        ]
        kinks[name] = max(
            _kink_ratio(s.positions[p, r, s.j(lm)])
            for r in range(s.replicas)
            for lm in paper.PAPER_LAMBDAS
            if s.valid(p, r, s.j(lm))
        )
    nl = infl[judged]
    # "more are formed": never fewer from one Fig. 2 stage to the next, and more at the last
    # than at the first (a wire that has none at every stage forms none)
    ok_infl = (
        all(v is not None for v in nl)
        and all(b >= a for a, b in itertools.pairwise(nl))
        and nl[-1] > nl[0]
    )
    return [
        {
            "claim": "no sharp edge: the wire stays smooth as λ grows",
            "source": "Fig. 2 caption: 'no sharp edge occurs and the shape of CW remains smooth'",
            "measured": "largest |θ_i| / max(|θ_i-1|, |θ_i+1|) over the Fig. 2 stages: "
            + ", ".join(f"{k}: {v:.2f}" for k, v in kinks.items()),
            "criterion": "smooth if no joint turns more than twice as much as both its neighbours "
            "(ratio <= 2); judged on the Newton wire of each reading",
            "verdict": "consistent" if kinks[judged] <= 2 else "not consistent",
        },
        {
            "claim": "more turning points as λ grows",
            "source": "Fig. 2 caption: 'More turning points are formed if the external field "
            "increases'",
            "measured": "inflection points (sign changes of θ) at λ = 70, 200, 300, 1000: "
            + "; ".join(f"{k}: {v}" for k, v in infl.items()),
            "criterion": "non-decreasing, and more at λ = 1000 than at 70, on the Newton wire "
            "of each reading (replica 0)",
            "verdict": "consistent" if ok_infl else "not consistent",
        },
    ]


def _stretching_claim(el: Series, fig2: int) -> dict:
    """γ = E_s/E_b at λ = 1000, judged on its largest value over every point with
    k_s/k_b ≥ 1e4 (the claim is about all such wires, not the Fig. 2 one alone)."""
    kb = np.array([k[0] for k in el.keys])
    ks = np.array([k[1] for k in el.keys])
    j = el.j(1000.0)
    g2 = nan_quiet(np.nanmean, el.obs["gamma"][fig2, :, j])
    gmax = nan_quiet(np.nanmax, el.obs["gamma"][(ks / kb) >= 1e4][:, :, j])
    if not np.isfinite(gmax):
        verdict = "not measured"
    else:
        verdict = "consistent" if gmax < 0.1 else "not consistent"
    return {
        "claim": "stretching energy is insignificant when k_b << k_s",
        "source": "Sec. III.A: 'the stretching energy is found to be insignificant when "
        "k_b << k_s'",
        "measured": f"largest γ = E_s/E_b over all points with k_s/k_b >= 1e4 at λ = 1000: "
        f"{gmax:.3g}; at (5, 5e5): {g2:.3g}",
        "criterion": "largest γ over the points with k_s/k_b ≥ 1e4 < 0.1 at λ = 1000",
        "verdict": verdict,
    }


def _configurations(wires: dict[str, tuple[Series, int]]) -> dict:
    """Replica 0 at the paper's λ values, per wire (the panels of Fig. 2), with the segment
    pairs in contact."""
    rows = {}
    for label, (s, p) in wires.items():
        shown = [
            s.positions[p, 0, s.j(lm)]
            for lm in paper.PAPER_LAMBDAS
            if s.valid(p, 0, s.j(lm)) and np.isclose(s.lam[s.j(lm)], lm)
        ]
        lams = [
            lm
            for lm in paper.PAPER_LAMBDAS
            if s.valid(p, 0, s.j(lm)) and np.isclose(s.lam[s.j(lm)], lm)
        ]
        # the contacts the table's row counts, highlighted (computed here: a figure computes
        # no physics)
        rows[label] = [
            (x, lm, close_segment_pairs(x, CONTACT_FACTOR * s.hard_core)[0])
            for x, lm in zip(shown, lams, strict=True)
        ]
    return rows


def measure(ctx: Context) -> Record:
    """Contacts, smoothness and turning points at the Fig. 2 point, per length and per node."""
    el = ctx.series["elastic"]
    pn = ctx.series["elastic_per_node"].reindex(el.keys)
    pl_rec = _measure(el, ctx, ctx.replicas, "Newton, per length")
    with _missing_points_ok():
        pn_rec = _measure(pn, ctx, ctx.profile["per_node_replicas"], "Newton, per node")
    return _twin(NAME, pl_rec, pn_rec)


def _measure(s: Series, ctx: Context, nrep: int, judged: str) -> Record:
    """The row and claims from the series ``s`` (the wire ``judged`` of the claims); the
    configurations of every wire."""
    el = s
    fig2 = el.index(paper.FIG2)
    first = _onset(el.lam, el.obs["contacts_interior"][fig2])
    first_any = _onset(el.lam, el.obs["contacts"][fig2])
    extra: dict = {"contact_onset": {"interior": first, "any": first_any}}
    c0 = el.obs["contacts"][fig2, 0]
    hit0 = np.flatnonzero(np.nan_to_num(c0) > 0)
    if hit0.size:
        x = el.positions[fig2, 0, hit0[0]]
        pairs, _ = close_segment_pairs(x, CONTACT_FACTOR * el.hard_core)
        extra["first_contact"] = {"lam": float(el.lam[hit0[0]]), "segment_pairs": pairs.tolist()}
    extra["contacts_fig2"] = {
        "lam": el.lam,
        "mean": np.nanmean(el.obs["contacts"][fig2], axis=0),
    }
    per_node = ctx.series["elastic_per_node"]
    wires = {
        "Newton, per length": (ctx.series["elastic"], fig2),
        "Newton, per node": (per_node, per_node.index(paper.FIG2)),
        "Powell, per length": (ctx.series["powell"], 0),
    }
    panels = dict(
        zip(
            ("Newton, λ r² per length", "Newton, λ r² per node", "Powell (paper's method)"),
            wires.values(),
            strict=True,
        )
    )
    return Record(
        rows=(_contact_row(first, first_any, nrep),),
        claims=(*_shape_claims(wires, judged), _stretching_claim(el, fig2)),
        extra=extra,
        detail={"configurations": _configurations(panels), "n_segments": el.positions.shape[3] - 1},
    )


def draw(rec: Record) -> dict:
    """Fig. 2: the configurations, one row per wire."""
    from ..figures import plot_configuration_rows

    fig = plot_configuration_rows(
        rec.detail["configurations"],
        title="(k_b, k_s) = (5, 5e5), replica 0 (paper's Fig. 2)",
        contact_label=f"in contact (closer than {CONTACT_FACTOR:g} hard-core widths)",
    )
    return {"fig2_configurations": fig}


def discuss(rec: Record, records) -> dict[str, str]:
    """Where the first contact is, and what we count as a contact; per length and per node."""
    return _both_readings_discussion(_discuss, rec)


def _discuss(rec: Record) -> dict[str, str]:
    ex = rec.extra
    fc = ex.get("first_contact")
    if not fc:
        return {}
    n_seg = rec.detail["n_segments"]
    ends = all(max(min(i, j), n_seg - 1 - max(i, j)) <= 2 for i, j in fc["segment_pairs"])
    what = (
        "the wire's two ends, closing the first loop (the 'water drop' of Fig. 2 and "
        "of the loop-shape figure)"
        if ends
        else "segments " + ", ".join(f"{i}-{j}" for i, j in fc["segment_pairs"][:5])
    )
    cf = ex["contacts_fig2"]
    n1000 = float(np.interp(1000.0, cf["lam"], cf["mean"]))
    return {
        "lambda_contact": (
            f"Replica 0 first touches at λ = {fc['lam']:g}, between {what}; at λ = 1000 the "
            f"replicas have {n1000:.0f} segment pairs in contact on average (results.json: "
            "contacts_fig2). The paper does not define a contact; we count pairs of "
            f"non-adjacent segments closer than {CONTACT_FACTOR:g} hard-core widths, and for "
            "this row only pairs away from the wire's ends (loops touching loops, not the ends "
            "closing a loop or the two tails running side by side)."
        )
    }


def _reason(rec: Record) -> dict[str, str]:
    """Why the contact onset differs under one reading, from its record."""
    row = rec.rows[0]
    if row["ours"] is None:
        return {"lambda_contact": "definition: no interior contact up to the last stage"}
    return {
        "lambda_contact": "definition: the paper defines no contact; ours begins in "
        f"{row['fit_range'][0]:.4g} < λ ≤ {row['fit_range'][1]:.4g}"
    }


def summarise(rec: Record, records) -> dict[str, dict[str, str]]:
    """The summary's reason for the row, per reading (``per-length``, ``per-node``)."""
    return _both_readings_reasons(_reason, rec)
