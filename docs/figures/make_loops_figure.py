"""Draw docs/figures/loops.png, the figure of the loop definition in docs/observables.md.

    python docs/figures/make_loops_figure.py

Black: the wire. Red: the contact links (a node closer than the contact distance c to a
segment, joined to the nearest point of that segment). Coloured: the loops, by depth (number of
loops enclosing them). White gaps between consecutive links: slivers narrower than c, inside a
contact, not loops.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.patches import Polygon

from crumple.observables import loops

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "benchmarks"))
from bench_loops import wavy_spiral  # noqa: E402

C = 0.01


def snail(turns: int, per_turn: int = 200, gap: float = 0.4 * C) -> np.ndarray:
    th = np.linspace(0.0, 2 * np.pi * turns, per_turn * turns + 1)
    rho = 1.0 + 0.5 * th / (2 * np.pi)
    return np.c_[-rho + gap * th / (2 * np.pi) + rho * np.cos(th), rho * np.sin(th)]


def eight(n: int = 400) -> np.ndarray:
    eps = 0.3 * C / np.sqrt(2)
    t = np.linspace(eps, 2 * np.pi - eps, n + 1)
    return np.c_[np.sin(t), np.sin(t) * np.cos(t)]


def packed_spiral(turns: int, r0: float = 0.2, spacing: float = 0.45 * C) -> np.ndarray:
    b = spacing / (2 * np.pi)
    th = np.linspace(0.0, 2 * np.pi * turns, 100_000)
    r = r0 + b * th
    x, y = r * np.cos(th), r * np.sin(th)
    s = np.r_[0.0, np.cumsum(np.hypot(np.diff(x), np.diff(y)))]
    su = np.arange(0.0, s[-1], 2 * C)
    return np.c_[np.interp(su, s, x), np.interp(su, s, y)]


def draw(ax, x, c, title, *, zoom=None, lw=1.0, cmap="viridis", by="depth"):
    st = loops(x, contact_distance=c, boundaries=True)
    values = st.depth if by == "depth" else np.log10(st.area)
    vmax = max(1, values.max(initial=0)) if by == "depth" else values.max(initial=1)
    vmin = 0 if by == "depth" else values.min(initial=0)
    cm = plt.get_cmap(cmap)
    for b, v in zip(st.boundaries, values, strict=True):
        ax.add_patch(Polygon(b, closed=True, fc=cm((v - vmin) / max(vmax - vmin, 1e-12)),
                             ec="none", alpha=0.55))  # fmt: skip
    ax.plot(x[:, 0], x[:, 1], "k-", lw=lw)
    ax.add_collection(LineCollection(st.links, colors="red", lw=1.2 * lw))
    ax.plot(*x[[0, -1]].T, "ko", ms=2.5)
    ax.set_aspect("equal" if zoom is None else "auto")
    if zoom is not None:
        ax.set_xlim(zoom[0], zoom[1])
        ax.set_ylim(zoom[2], zoom[3])
    else:
        ax.autoscale_view()
    depth = ", ".join(f"{n}@{d}" for d, n in enumerate(st.counts_by_depth))
    ax.set_title(f"{title}\n{st.count} loops (count@depth: {depth})", fontsize=8)
    ax.set_xticks([])
    ax.set_yticks([])
    return st


def main() -> None:
    fig, axes = plt.subplots(2, 3, figsize=(11, 7.4))
    draw(axes[0, 0], snail(3), C, "spiral of 3 turns touching once per turn")
    draw(axes[0, 1], snail(3), C, "its touching point (zoom, x stretched)",
         zoom=(-0.03, 0.045, -0.2, 0.2))  # fmt: skip
    draw(axes[0, 2], eight(), C, "figure eight touching at its waist")
    draw(axes[1, 0], packed_spiral(4), C, "spiral whose turns lie against each other")
    draw(axes[1, 1], packed_spiral(4), C, "(zoom): the bands are contact, not loops",
         zoom=(0.15, 0.26, -0.055, 0.055))  # fmt: skip
    w = wavy_spiral(3000) * 0.01
    draw(axes[1, 2], w, 0.01, "wavy spiral, N = 3000 (colour: log area)", lw=0.5,
         by="area", cmap="plasma")  # fmt: skip
    fig.suptitle("Loops: bounded faces of wire (black) + contact links (red) "
                 "with mean width 2A/P >= c; colour = depth", fontsize=10)  # fmt: skip
    fig.tight_layout()
    out = HERE / "loops.png"
    fig.savefig(out, dpi=90)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
