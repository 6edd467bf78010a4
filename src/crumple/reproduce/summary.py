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

__all__ = ["summary_blocks"]

#: The readings of Eq. (1), as the rows store them: the row itself, and ``row["per_node"]``.
READINGS = ("per-length", "per-node")
#: Short names of the paper's numbers for the summary (a row of an added study falls back to
#: its quantity).
_SHORT = {
    "D_M": "D_M = 1.33 (Fig. 3)",
    "D_M_slope": "D_M saturates above λ = 100",
    "eps_l": "ε_l = 0.55 (Fig. 4)",
    "eps_l_theory": "ε_l = 0.5 (the paper's argument)",
    "eps_b": "ε_b = 2.6",
    "eps_s": "ε_s = -3.3",
    "collapse": "collapse R_g ~ (k_b k_s)^1.2",
    "alpha": "α = -0.25 (Fig. 5)",
    "alpha_s0.05": "α = -0.29 at s = 0.05 (Fig. 6)",
    "alpha_s0.2": "α = -0.24 at s = 0.2",
    "alpha_s0.4": "α = -0.21 at s = 0.4",
    "alpha_saturation": "|α| saturates at 0.26",
    "lambda_contact": "contacts begin at λ ≈ 1000 (Fig. 2)",
}
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
        if states[other] == "agrees":
            text = f"normalisation: it agrees {other.replace('-', ' ')}" + (
                f"; {text}" if text else ""
            )
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
    return ", ".join(_SHORT.get(r["key"], r["quantity"]) for r in rows) or "none"


def _conclusions(an: Analysis) -> str:
    """Three or four sentences, each from the counts of the table above it."""
    rows = an.rows
    st = [(_state(r), _state(r.get("per_node"))) for r in rows]
    n = len(rows)
    a_pl = sum(a == "agrees" for a, _ in st)
    a_pn = sum(b == "agrees" for _, b in st)
    both = [r for r, (a, b) in zip(rows, st, strict=True) if a == b == "agrees"]
    only_pn = [r for r, (a, b) in zip(rows, st, strict=True) if b == "agrees" != a]
    only_pl = [r for r, (a, b) in zip(rows, st, strict=True) if a == "agrees" != b]
    neither = [r for r, (a, b) in zip(rows, st, strict=True) if a == "differs" and b == "differs"]
    out = [
        f"Of the paper's {n} numbers, {a_pl} agree within 2σ under per-length confinement "
        f"and {a_pn} under per-node confinement (Eq. 1 as printed); {len(both)} "
        f"{'agrees' if len(both) == 1 else 'agree'} under both ({_names(both)}) and "
        f"{len(neither)} under neither."
    ]
    out.append(f"Only per node reproduces: {_names(only_pn)}; only per length: {_names(only_pl)}.")
    out.append(f"Neither reading reproduces: {_names(neither)}.")
    counts = {k: _converged(an, k) for k in READINGS}
    if all(c == t for c, t in counts.values()):
        out.append(
            "Every Newton stage of both readings reached equilibrium ("
            + ", ".join(f"{c}/{t} {k.replace('-', ' ')}" for k, (c, t) in counts.items())
            + "), so no difference comes from an unconverged minimiser."
        )
    else:
        out.append(
            "Not every Newton stage reached equilibrium ("
            + ", ".join(f"{c}/{t} {k.replace('-', ' ')}" for k, (c, t) in counts.items())
            + "): the rows of those experiments may hold unconverged states (Runs below)."
        )
    return " ".join(out)


def summary_blocks(an: Analysis) -> list[tuple]:
    """The summary: a table, one line per paper number, and the conclusions."""
    reasons = _reasons(an)
    body = [
        [
            _SHORT.get(r["key"], r["quantity"]),
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
