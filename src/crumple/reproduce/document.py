"""The report's structure: an :class:`~.analysis.Analysis` -> a list of blocks for
:mod:`.render`.

Header and conventions, the runs (with each experiment's and section's notes), the main table
with the discussion of each row, the claims, the alternatives and the figures, all gathered
from the sections in registry order. Nothing here names a figure or a paper value.
"""

from __future__ import annotations

from . import registry
from .analysis import Analysis
from .common import _num, _range
from .summary import summary_blocks

__all__ = ["blocks"]

_CONVENTIONS = (
    "Conventions: each exponent is fitted per replica; the value is the replica "
    "mean and σ combines the standard error of the mean and the rms regression "
    "error in quadrature (the replicas of a perfect wire at equilibrium are "
    "near copies, docs/model.md). Values pooled over (k_b, k_s) points: the "
    "mean over points, σ² = (between-point variance + mean σ²)/n. Verdict: "
    "agrees when |ours − paper| ≤ 2σ. Error bars and bands in every figure are ±2σ with this σ "
    "(for a replica mean: the standard error of the mean), unless a caption says otherwise. "
    "The λ-onset of contacts is a bracket of two successive stages, not a value with a σ. "
    "α is fitted over λ ∈ [100, 2000] everywhere. Every number of Figs. 2-6 is measured "
    "under both readings of Eq. 1, at the same λ values, points, replicas and stages: "
    "confinement λ r² per unit length (Eq. 2, crumple's default) and per node (Eq. 1 as "
    "printed; its λ corresponds to a per-length λ/Δs, Δs = 0.01). Newton "
    "to max force ≤ 1e-6 at every stage, unless a row says otherwise; R_G = "
    "r_max (the paper's reading, Sec. III.C); M(R) exact (fractional segments)."
)
_ALTERNATIVES = (
    "Where the paper leaves a choice open, each alternative that matters, at "
    "the same parameters (not picked to match); a variant 'per node: …' is the same "
    "measure under per-node confinement. A D_M that 'cannot be fitted' has M(R) = 0 "
    "somewhere in the fit range (a hollow configuration, no wire near the centre of mass; "
    "the per-node wire coils into a ring); 'where the wire has mass' fits it on "
    "[max(0.5, 1.1 ρ_in), 1], ρ_in the R/R_G where the mass starts."
)


_CLAIMS = (
    "Each claim judged under both readings of Eq. 1 where the report ran it under both: "
    "confinement λ r² per unit length and per node (the same points, replicas and stages). "
    "A claim about the paper's minimiser or the Fig. 2 wire alone is judged once."
)


_CLAIM_HEAD = [
    *("claim", "criterion", "per length: measured", "verdict"),
    *("per node: measured", "verdict"),
]


_TITLE = "crumple: reproduction of Lin, Lin & Hong, Crumpling wires in two dimensions"
_ORIGIN = (
    "Every parameter comes from the paper or is stated as ours in `crumple.paper` (with the "
    "reason); nothing was tuned to match."
)


def _head(an: Analysis, meta: dict, title: str, origin: str, conventions: str) -> list[tuple]:
    prof = an.profile
    b: list[tuple] = [("h1", title)]
    if prof["name"] != "full":
        b.append(("warn", prof["description"]))
    if any("per_node" in r for r in an.rows):  # a study without per-node twins has none
        b += summary_blocks(an)
    b.append(
        (
            "p",
            f"Profile **{prof['name']}**: {prof['description']}. crumple "
            f"{meta['versions'].get('crumple', '?')}. {origin}",
        )
    )
    b.append(("p", conventions))
    return b


def _runs(an: Analysis) -> list[tuple]:
    lines = []
    for name, c in an.extra["convergence"].items():
        lines.append(
            f"{name}: {c['runs_done']}/{c['runs']} runs, {c['stages_converged']}/"
            f"{c['stages']} stages at equilibrium"
            + (f" — {'; '.join(c['incomplete'])}" if c["incomplete"] else "")
        )
    b: list[tuple] = [("h2", "Runs"), ("list", lines)]
    for e in registry.experiments(an.sections):
        if e.note is not None:
            b.append(("p", e.note(an.profile)))
    for s in an.sections:
        if hasattr(s, "notes"):
            b += [("p", text) for text in s.notes(an.records[s.NAME])]
    return b


def _discussion(an: Analysis) -> dict[str, str]:
    out: dict[str, str] = {}
    for s in an.sections:
        if hasattr(s, "discuss"):
            out.update(s.discuss(an.records[s.NAME], an.records))
    return out


def _deviation(r: dict) -> str:
    """|ours − paper| / σ, or why there is none."""
    if r.get("bracket"):
        return "— (a bracket, no σ)"
    d = r.get("deviation_sigma")
    return "—" if d is None else f"{d:.1f}"


def _ours(r: dict) -> str:
    if r.get("bracket") and r["ours"] is not None:
        return f"{r['ours']:g} (bracket {_range(r['fit_range'], True)})"
    hollow = r.get("hollow")
    rods = f"; {hollow['rods']}/{hollow['of']} wires rods" if hollow and hollow.get("rods") else ""
    if hollow and hollow["wires"]:
        inner = hollow["inner"]
        where = (
            f"; where the wire has mass, {hollow.get('inner_range', '—')}: "
            f"{_num(inner['value'], inner['sigma'])}"
            if inner["value"] is not None
            else ""
        )
        what = _num(r["ours"], r["sigma"]) if r["ours"] is not None else "cannot be fitted"
        return f"{what} ({hollow['wires']}/{hollow['of']} wires hollow rings{where}{rods})"
    return _num(r["ours"], r["sigma"]) + (f" ({rods[2:]})" if rods else "")


def _twin_cells(r: dict | None) -> list[str]:
    """ours ± σ, deviation and verdict of one reading (None: not run under it)."""
    if r is None:
        return ["—", "—", "not run"]
    return [_ours(r), _deviation(r), r["verdict"]]


def _fit_range_cell(r: dict) -> str:
    """The row's fit range, and the per-node one after it where it differs. A row fitted over
    a window of λ prints the window (the same for every α row); the stages inside it are in
    results.json's fit_range."""
    bracket = r.get("bracket", False)
    pl = _range(r.get("fit_window") or r["fit_range"], bracket)
    pn = r.get("per_node")
    if pn is None or r.get("fit_window"):
        return pl
    other = _range(pn.get("fit_range"), bracket)
    return pl if other in (pl, "—") else f"{pl} (per node {other})"


def _table(an: Analysis) -> list[tuple]:
    head = [
        *("quantity", "paper", "per length: ours ± σ", "|ours − paper|/σ", "verdict"),
        *("per node: ours ± σ", "|ours − paper|/σ", "verdict", "fit range", "replicas"),
    ]
    body = [
        [
            r["quantity"],
            f"{r['paper']:g}",
            *_twin_cells(r),
            *_twin_cells(r.get("per_node")),
            _fit_range_cell(r),
            r["replicas"]
            + (
                f" (per node {r['per_node']['replicas']})"
                if r.get("per_node") and r["per_node"]["replicas"] != r["replicas"]
                else ""
            ),
        ]
        for r in an.rows
    ]
    disc = _discussion(an)
    items = []
    said: dict[str, str] = {}
    for r in an.rows:
        text = (
            f"**{r['quantity']}** — per length: {r['verdict']}. {r['note']}."
            if r["note"]
            else f"**{r['quantity']}** — per length: {r['verdict']}."
        )
        pn = r.get("per_node")
        if pn is not None:
            text += f" Per node: {pn['verdict']}." + (
                f" {pn['note']}." if pn["note"] and pn["note"] != r["note"] else ""
            )
        text += f" Source: {r['source']}."
        if r["key"] in disc:
            d = disc[r["key"]]
            text += f" (Discussion as for: {said[d]}.)" if d in said else " " + d
            said.setdefault(d, r["quantity"])
        items.append(text)
    return [
        ("h2", "The paper's numbers"),
        ("table", head, body),
        ("h3", "Discussion of each row"),
        ("list", items),
    ]


def _comparison_table(an: Analysis, heading: str, a: str, b: str) -> list[tuple]:
    """A study's own main table: two measurements of the same observable (``a`` ± σ, ``b`` ±
    σ, their difference over the combined σ, the verdict), and the discussion of each row."""
    head = ["quantity", f"{a} ± σ", f"{b} ± σ", f"|{a} − {b}|/σ", "verdict", "fit range",
            "replicas"]  # fmt: skip
    body = [
        [
            r["quantity"],
            _num(r["ours"], r.get("ours_sigma")),
            "—"
            if r["paper"] is None or r["paper"] != r["paper"]
            else _num(r["paper"], r.get("paper_sigma")),
            _deviation(r),
            r["verdict"],
            _range(r["fit_range"]),
            r["replicas"],
        ]
        for r in an.rows
    ]
    disc = _discussion(an)
    items = [
        f"**{r['quantity']}** — {r['verdict']}. {r['note']}."
        + (f" {disc[r['key']]}" if r["key"] in disc else "")
        for r in an.rows
    ]
    return [("h2", heading), ("table", head, body), ("h3", "Discussion of each row"),
            ("list", items)]  # fmt: skip


def _claims_and_alternatives(an: Analysis, alternatives: str) -> list[tuple]:
    claims = [
        [
            c["claim"],
            c["criterion"],
            c["measured"],
            c["verdict"],
            c["per_node"]["measured"] if "per_node" in c else "—",
            c["per_node"]["verdict"] if "per_node" in c else "not judged per node",
        ]
        for c in an.claims
    ]
    alts = [
        [
            a["quantity"],
            a["variant"],
            "cannot be fitted (hollow ring)"
            if a["value"] is None and a["quantity"].startswith("D_M")
            else _num(a["value"], a["sigma"]),
            _range(a.get("fit_window") or a["fit_range"]),
            str(a["replicas"]),
            "—" if a["paper"] is None else f"{a['paper']:g}",
        ]
        for a in an.alternatives
    ]
    return [
        ("h2", "The paper's claims"),
        ("p", _CLAIMS),
        ("table", _CLAIM_HEAD, claims),
        ("h2", "Open choices side by side"),
        ("p", alternatives),
        ("table", ["quantity", "variant", "value", "fit range", "replicas", "paper"], alts),
    ]


def blocks(
    an: Analysis,
    meta: dict,
    *,
    title: str = _TITLE,
    origin: str = _ORIGIN,
    conventions: str = _CONVENTIONS,
    alternatives: str = _ALTERNATIVES,
    comparison: tuple[str, str, str] | None = None,
) -> list[tuple]:
    """The whole report as blocks (:mod:`.render`); ``meta`` is ``profile.json``. The texts
    default to the paper's reproduction; another study passes its own
    (:meth:`.study.Study.text`), and ``comparison`` (heading, label a, label b) for a main
    table of two measurements of its own instead of the paper's numbers."""
    figs = [("fig", stem, cap) for stem, cap in registry.figures(an.sections).items()]
    return [
        *_head(an, meta, title, origin, conventions),
        *_runs(an),
        *(_table(an) if comparison is None else _comparison_table(an, *comparison)),
        *_claims_and_alternatives(an, alternatives),
        ("h2", "Figures"),
        *figs,
    ]
