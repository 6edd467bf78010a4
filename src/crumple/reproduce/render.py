"""Rendering the report: a list of blocks -> Markdown, or self-contained HTML.

A block is a tuple: ``("h1" | "h2" | "h3", text)``, ``("p", text)``, ``("warn", text)``,
``("list", [text, ...])``, ``("table", header, rows)`` or ``("fig", stem, caption)`` (the
figure ``figures/<stem>.png``, embedded in the HTML). Text may hold ``**bold**``. This module
knows nothing of any figure or experiment: :mod:`.document` builds the blocks.
"""

from __future__ import annotations

import base64
import html
from pathlib import Path

__all__ = ["to_html", "to_markdown"]


def to_markdown(blocks) -> str:
    """The blocks as Markdown (figures as links to ``figures/<stem>.png`` and ``.svg``)."""
    out = []
    for blk in blocks:
        kind = blk[0]
        if kind in ("h1", "h2", "h3"):
            out.append("#" * int(kind[1]) + " " + blk[1])
        elif kind == "p":
            out.append(blk[1])
        elif kind == "warn":
            out.append(f"> **{blk[1]}**")
        elif kind == "list":
            out.append("\n".join(f"- {x}" for x in blk[1]))
        elif kind == "table":
            head, body = blk[1], blk[2]
            rows = ["| " + " | ".join(h.replace("|", "\\|") for h in head) + " |",
                    "|" + "---|" * len(head)]  # fmt: skip
            rows += ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |" for r in body]
            out.append("\n".join(rows))
        elif kind == "fig":
            out.append(
                f"![{blk[2]}](figures/{blk[1]}.png)\n\n*{blk[2]}* ([SVG](figures/{blk[1]}.svg))"
            )
    return "\n\n".join(out) + "\n"


def _inline(text: str) -> str:
    t = html.escape(text)
    parts = t.split("**")
    return "".join(f"<b>{p}</b>" if i % 2 else p for i, p in enumerate(parts)).replace("`", "")


def to_html(blocks, figdir: Path, title: str = "crumple reproduction") -> str:
    """The blocks as one HTML page, the PNG figures of ``figdir`` embedded (base64)."""
    out = [
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
        "</title><style>body{font-family:sans-serif;max-width:1100px;margin:auto;"
        "line-height:1.4}table{border-collapse:collapse;font-size:13px}td,th{border:1px "
        "solid #bbb;padding:3px 6px;vertical-align:top}.warn{background:#fff3cd;padding:"
        "8px}img{max-width:100%}</style></head><body>"
    ]
    for blk in blocks:
        kind = blk[0]
        if kind in ("h1", "h2", "h3"):
            out.append(f"<{kind}>{html.escape(blk[1])}</{kind}>")
        elif kind == "p":
            out.append(f"<p>{_inline(blk[1])}</p>")
        elif kind == "warn":
            out.append(f"<p class='warn'><b>{html.escape(blk[1])}</b></p>")
        elif kind == "list":
            out.append("<ul>" + "".join(f"<li>{_inline(x)}</li>" for x in blk[1]) + "</ul>")
        elif kind == "table":
            h = "".join(f"<th>{html.escape(c)}</th>" for c in blk[1])
            rows = "".join(
                "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                for r in blk[2]
            )
            out.append(f"<table><tr>{h}</tr>{rows}</table>")
        elif kind == "fig":
            data = base64.b64encode((figdir / f"{blk[1]}.png").read_bytes()).decode()
            out.append(
                f"<figure><img alt='{html.escape(blk[2])}' src='data:image/png;base64,"
                f"{data}'><figcaption>{html.escape(blk[2])}</figcaption></figure>"
            )
    out.append("</body></html>")
    return "\n".join(out)
