"""Writing the report: figures, ``results.json``, ``report.md`` and ``report.html``, and the
check that it is complete. Iterates over the sections; knows none of them."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

from .. import paper
from ..storage import atomic_write_text
from . import registry
from .analysis import Analysis, _read_profile, analyse
from .common import _jsonable
from .document import blocks
from .render import to_html, to_markdown

__all__ = ["check_report", "make_figures", "write_report"]


def make_figures(an: Analysis, log: Callable[[str], None] | None = None) -> dict:
    """Every section's figures (stem -> matplotlib Figure), each drawn from its record.
    ``log(message)`` before each section."""
    out = {}
    for i, s in enumerate(an.sections, 1):
        if log:
            log(f"drawing figures: {', '.join(s.FIGURES) or s.NAME} ({i}/{len(an.sections)})")
        figs = s.draw(an.records[s.NAME])
        if set(figs) != set(s.FIGURES):
            raise ValueError(
                f"section {s.NAME!r} drew {sorted(figs)} but declares {sorted(s.FIGURES)}"
            )
        out.update(figs)
    return out


def _save(figs: dict, figdir: Path, log: Callable[[str], None] | None = None) -> None:
    figdir.mkdir(parents=True, exist_ok=True)
    for i, (stem, fig) in enumerate(figs.items(), 1):
        if log:
            log(f"drawing figures: saving {stem}.png and .svg ({i}/{len(figs)})")
        for ext in ("png", "svg"):
            tmp = figdir / f".{stem}.tmp.{ext}"
            fig.savefig(tmp, dpi=110)
            tmp.replace(figdir / f"{stem}.{ext}")


def write_report(
    out, *, log: Callable[[str], None] | None = None, sections=None, study=None
) -> dict:
    """Analyse the stores in ``out`` and write figures, ``results.json``, ``report.md`` and
    ``report.html``. Returns the paths written and what :func:`check_report` found missing.
    ``sections``: default :func:`crumple.reproduce.registry.sections` (or ``study``'s);
    ``study``: a :class:`.study.Study` other than the paper's (its title and conventions)."""
    out = Path(out)
    meta = _read_profile(out, study)
    t0 = time.perf_counter()
    an = analyse(out, sections=sections, log=log, study=study)
    if log:
        log(f"measured in {time.perf_counter() - t0:.1f} s")
    figdir = out / "figures"
    figs = make_figures(an, log)
    _save(figs, figdir, log)
    if log:
        log("writing report: results.json, report.md, report.html")
    doc = blocks(an, meta) if study is None else blocks(an, meta, **study.text())
    results = _jsonable({**an.to_json(), "versions": meta.get("versions", {})})
    atomic_write_text(out / "results.json", json.dumps(results, indent=1, allow_nan=False) + "\n")
    atomic_write_text(out / "report.md", to_markdown(doc))
    html = to_html(doc, figdir) if study is None else to_html(doc, figdir, study.title)
    atomic_write_text(out / "report.html", html)
    return {
        "report": str(out / "report.html"),
        "markdown": str(out / "report.md"),
        "results": str(out / "results.json"),
        "missing": check_report(out, sections=an.sections),
        "rows": len(an.rows),
        "figures": len(figs),
    }


def check_report(out, *, sections=None) -> list[str]:
    """What a complete report lacks: figure files, table rows (one per value the sections
    declare) with a number and a verdict, and for each of the paper's numbers a verdict per
    node (issue 14). Empty when complete."""
    out = Path(out)
    secs = registry.sections() if sections is None else tuple(sections)
    values = [v for s in secs for v in s.VALUES]
    missing = []
    for stem in registry.figures(secs):
        for ext in ("png", "svg"):
            if not (out / "figures" / f"{stem}.{ext}").is_file():
                missing.append(f"figures/{stem}.{ext}")
    for name in ("report.md", "report.html", "results.json"):
        if not (out / name).is_file():
            missing.append(name)
    if (out / "results.json").is_file():
        res = json.loads((out / "results.json").read_text())
        got = {r["key"]: r for r in res.get("rows", [])}
        for v in values:
            r = got.get(v.key)
            if r is None:
                missing.append(f"table row {v.key}")
            elif r.get("verdict") in (None, "not measured"):
                missing.append(f"table row {v.key} has no value")
            elif v.key in paper.PAPER_VALUES and not (r.get("per_node") or {}).get("verdict"):
                missing.append(f"table row {v.key} has no per-node verdict")
    if (out / "report.md").is_file():
        md = (out / "report.md").read_text()
        for v in values:
            if f"| {v.quantity.replace('|', chr(92) + '|')} |" not in md:
                missing.append(f"report.md row {v.key}")
    return missing
