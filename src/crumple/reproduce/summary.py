"""The report's one-minute summary: one line per paper number under both readings of Eq. 1,
the reason for each difference, and what the reproduction concludes.

Everything here is generated from the rows of the sections (their verdicts and values), the
sentences their optional ``summarise(record, records) -> {row key: {reading: sentence}}``
returns, and the convergence counts of the experiments: nothing is written by hand, so the
summary changes with the numbers below it.
"""

from __future__ import annotations

from .analysis import Analysis
from .common import _num

__all__ = ["summary_blocks", "tally"]

#: The readings of Eq. (1), as the rows store them: the row itself, and ``row["per_node"]``.
READINGS = ("per-length", "per-node")
#: Short names of the paper's numbers for the summary, ``{v}`` the paper's value as its row
#: states it (a row of an added study falls back to its quantity).
_SHORT = {
    "D_M": "D_M = {v:g} (Fig. 3)",
    "D_M_slope": "D_M saturates above λ = 100",
    "eps_l": "ε_l = {v:g} (Fig. 4)",
    "eps_l_theory": "ε_l = {v:g} (the paper's argument)",
    "eps_b": "ε_b = {v:g}",
    "eps_s": "ε_s = {v:g}",
    "collapse": "collapse R_g ~ (k_b k_s)^{v:g}",
    "alpha": "α = {v:g} (Fig. 5)",
    "alpha_s0.05": "α = {v:g} at s = 0.05 (Fig. 6)",
    "alpha_s0.2": "α = {v:g} at s = 0.2",
    "alpha_s0.4": "α = {v:g} at s = 0.4",
    "alpha_saturation": "|α| saturates at {v:g}",
    "lambda_contact": "contacts begin at λ ≈ {v:g} (Fig. 2)",
}


def _short(r: dict) -> str:
    """The summary's name of row ``r``, with the paper's value from the row."""
    fmt = _SHORT.get(r["key"])
    return r["quantity"] if fmt is None else fmt.format(v=r["paper"])


#: The experiments of each reading (their convergence is the "unconverged minimiser" check).
_EXPERIMENTS = {
    "per-length": ("elastic", "plastic"),
    "per-node": ("elastic_per_node", "plastic_per_node"),
}


def _state(r: dict | None) -> str:
    """ "agrees", "differs", or why there is no verdict."""
    if r is None:
        return "not run"
    v = r["verdict"]
    if v.startswith("agrees"):
        return "agrees"
    if v.startswith("differs"):
        return "differs"
    return v


def _cell(r: dict | None) -> str:
    state = _state(r)
    if r is None or r["ours"] is None:
        return state
    if r.get("bracket"):
        return f"{state}: ({r['fit_range'][0]:.4g}, {r['fit_range'][1]:.4g}]"
    return f"{state}: {_num(r['ours'], r['sigma'])}"


def _reasons(an: Analysis) -> dict[str, dict[str, str]]:
    out: dict[str, dict[str, str]] = {}
    for s in an.sections:
        if hasattr(s, "summarise"):
            out.update(s.summarise(an.records[s.NAME], an.records))
    return out


def _why(r: dict, reasons: dict[str, str]) -> str:
    """One sentence per reading that does not agree: the section's reason, or, where the
    other reading agrees, the normalisation."""
    states = {"per-length": _state(r), "per-node": _state(r.get("per_node"))}

    parts = []
    for reading in READINGS:
        if states[reading] == "agrees" or states[reading] == "not run":
            continue
        if states[reading] != "differs":  # no value: say so, and why where a section knows
            text = reasons.get(reading, "")
            parts.append(f"{reading.replace('-', ' ')}: {states[reading]}"
                         + (f" ({text})" if text else ""))  # fmt: skip
            continue
        other = READINGS[1 - READINGS.index(reading)]
        text = reasons.get(reading, "")
        if states[other] == "agrees":  # the reading is the cause; the section's detail below
            text = f"normalisation: it agrees {other.replace('-', ' ')}"
        parts.append(f"{reading.replace('-', ' ')}: {text or states[reading]}")
    return "; ".join(parts) + "." if parts else "—"


def _converged(an: Analysis, reading: str) -> tuple[int, int]:
    conv = an.extra["convergence"]
    names = [n for n in _EXPERIMENTS[reading] if n in conv]
    return (
        sum(conv[n]["stages_converged"] for n in names),
        sum(conv[n]["stages"] for n in names),
    )


def _names(rows: list[dict]) -> str:
    return ", ".join(_short(r) for r in rows) or "none"


def tally(rows: list[dict]) -> dict[str, list[dict]]:
    """Every row in exactly one group: ``both`` (agrees under both readings), ``per-length``
    or ``per-node`` (agrees only under that one), ``neither`` (agrees under no reading: it
    differs, or is not measured or not run, under each)."""
    out: dict[str, list[dict]] = {"both": [], "per-length": [], "per-node": [], "neither": []}
    for r in rows:
        pl, pn = _state(r) == "agrees", _state(r.get("per_node")) == "agrees"
        group = "both" if pl and pn else "per-length" if pl else "per-node" if pn else "neither"
        out[group].append(r)
    return out


def _unmeasured(rows: list[dict]) -> str:
    """How many of ``rows`` lack a value under some reading (they count as not agreeing)."""
    n = sum(
        _state(r) not in ("agrees", "differs")
        or _state(r.get("per_node")) not in ("agrees", "differs")
        for r in rows
    )
    return f" ({n} of them not measured under one reading or both)" if n else ""


def _powell(an: Analysis) -> str:
    """What the Powell study found, from its rows when this run has them."""
    rec = an.records.get("powell_paper")
    rows = [r for r in (rec.rows if rec is not None else ()) if r["ours"] is not None]
    if not rows:
        return (
            "Whether the paper's numbers are those of unconverged Powell states is a separate "
            "study (`crumple reproduce --profile powell`, docs/reproduction.md, \"The paper's "
            'minimiser, given a fair chance").'
        )
    ok = [r for r in rows if _state(r) == "agrees"]
    return (
        f"The Powell study (the Fig. 2 wire minimised with Powell, per length only) agrees "
        f"with the paper in {len(ok)} of its {len(rows)} measured values"
        + (f" ({', '.join(r['quantity'] for r in ok)})" if ok else "")
        + "."
    )


def _conclusions(an: Analysis) -> str:
    """Three or four sentences, each from the counts of the table above it."""
    rows = an.rows
    g = tally(rows)
    out = [
        f"Of the paper's {len(rows)} numbers, {len(g['both'])} "
        f"{'is' if len(g['both']) == 1 else 'are'} reproduced under both readings of Eq. 1 "
        f"({_names(g['both'])}), {len(g['per-length'])} only per length "
        f"({_names(g['per-length'])}), {len(g['per-node'])} only per node "
        f"({_names(g['per-node'])}), and {len(g['neither'])} under neither"
        f"{_unmeasured(g['neither'])}: {_names(g['neither'])}."
    ]
    better = (
        "per length reproduces more of them"
        if len(g["per-length"]) > len(g["per-node"])
        else "per node reproduces more of them"
        if len(g["per-node"]) > len(g["per-length"])
        else "neither reading reproduces more of them than the other"
    )
    if g["neither"]:
        out.append(
            "The reading of Eq. 1 alone does not explain the paper's numbers (some agree under "
            f"neither); {better}."
        )
    else:
        out.append(f"Every number agrees under at least one reading; {better}.")
    counts = {k: _converged(an, k) for k in READINGS}
    done = ", ".join(f"{c}/{t} {k.replace('-', ' ')}" for k, (c, t) in counts.items())
    if all(c == t for c, t in counts.values()):
        out.append(
            f"Every Newton stage of both readings reached equilibrium ({done}), so no "
            "difference comes from an unconverged minimiser."
        )
    else:
        out.append(
            f"Not every Newton stage reached equilibrium ({done}): the rows of those "
            "experiments may hold unconverged states (Runs below)."
        )
    out.append(_powell(an))
    return " ".join(out)


def summary_blocks(an: Analysis) -> list[tuple]:
    """The summary: a table, one line per paper number, and the conclusions."""
    reasons = _reasons(an)
    body = [
        [
            _short(r),
            _cell(r),
            _cell(r.get("per_node")),
            _why(r, reasons.get(r["key"], {})),
        ]
        for r in an.rows
    ]
    return [
        ("h2", "Summary"),
        (
            "p",
            "Each number of the paper against ours under both readings of Eq. 1 (confinement "
            "λ r² per unit length, and per node as printed; same points, replicas and stages); "
            "ours ± σ, agreeing when within 2σ. Details, figures and the discussion of each row "
            "below.",
        ),
        ("table", ["paper's number", "per length", "per node", "why they differ"], body),
        ("p", _conclusions(an)),
    ]
