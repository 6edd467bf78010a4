"""The loops of the Fig. 2 wire: their number n(λ), and when loops first touch loops.

Runs: ``elastic`` at :data:`crumple.paper.FIG2` (every replica, every stage). Measures, from the
observables the sweep stored at every stage (:mod:`crumple.stage_observables`): the number of
loops (:func:`crumple.loops.loops` at contact distance 2 d), the nested ones (depth >= 1) and
the contact links at which two different loops touch (``LoopStats.n_loop_contacts``); the
wire at λ = 1000 with its loops (replica 0, for the picture). Says: one claim, the paper's
"those local structures start to contact each other when λ >= 1000" under the loop definition
(first stage with a loop-loop contact) beside the current one (first interior contact, row
``lambda_contact`` of :mod:`.fig2_configurations`).
"""

from __future__ import annotations

import numpy as np

from .. import paper
from ..stage_observables import loops_or_none
from .common import Context, Record
from .experiments import ELASTIC
from .fig2_configurations import _onset
from .series import CONTACT_FACTOR

NAME = "fig2_loops"
READS = (ELASTIC,)
NEEDS: tuple[str, ...] = ("fig2_configurations",)
VALUES = ()
FIGURES = {
    "fig2_loops": "Loops of the Fig. 2 wire: (a) the number of loops n(λ) and when loops first "
    "touch loops; (b) the wire at λ = 1000 (replica 0), its loops shaded by depth and numbered"
}
#: The stage of the picture.
LAM_PICTURE = 1000.0


def _bracket(onsets) -> tuple[float, float] | None:
    """(last stage without, first stage with) over all replicas: (min of the first, max of the
    second); None when no replica reaches it."""
    if not onsets:
        return None
    return min(a for a, _ in onsets), max(b for _, b in onsets)


def _picture(el, p: int) -> dict | None:
    """Replica 0 at λ = 1000 with its loops (boundaries for the drawing); where its loops are
    undefined (the wire crosses itself, or round-off made its contact graph non-plane), the
    wire alone with ``undefined: True``: one bad stage must not cost the report."""
    j = el.j(LAM_PICTURE)
    if not (el.valid(p, 0, j) and np.isclose(el.lam[j], LAM_PICTURE)):
        return None
    x = el.positions[p, 0, j]
    st = loops_or_none(x, CONTACT_FACTOR * el.hard_core, boundaries=True)
    if st is None:
        return {"lam": float(el.lam[j]), "positions": x, "undefined": True}
    return {
        "lam": float(el.lam[j]),
        "positions": x,
        "boundaries": st.boundaries,
        "depth": st.depth,
        "centroid": st.centroid,
        "links": st.links,
        "count": st.count,
    }


def _mean(n: np.ndarray) -> np.ndarray:
    """Mean over replicas (axis 0) of the finite values; NaN where there is none."""
    ok = np.isfinite(n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok, n, 0.0).sum(axis=0) / ok.sum(axis=0)


def measure(ctx: Context) -> Record:
    """n(λ) per replica, the onsets of loop-loop contacts and of nested loops."""
    el = ctx.series["elastic"]
    p = el.index(paper.FIG2)
    n = el.obs["n_loops"][p]  # (replica, lam)
    touch = _onset(el.lam, el.obs["loop_contacts"][p])
    nested = _onset(el.lam, el.obs["n_loops_nested"][p])
    interior = ctx.records["fig2_configurations"].extra["contact_onset"]["interior"]
    j = el.j(LAM_PICTURE)
    at = n[:, j] if np.isclose(el.lam[j], LAM_PICTURE) else np.full(n.shape[0], np.nan)
    summary = {
        "lam": el.lam,
        "n_loops": n,
        "n_loops_mean": _mean(n),
        "n_loops_at_1000": at,
        "loop_contact_onset": touch,
        "loop_contact_bracket": _bracket(touch),
        "nested_onset": nested,
        "interior_contact_bracket": _bracket(interior),
    }
    return Record(
        claims=(_claim(summary, ctx.replicas),),
        extra={"loops_fig2": summary},
        detail={"summary": summary, "picture": _picture(el, p)},
    )


def _txt(bracket) -> str:
    return "none up to the last stage" if bracket is None else f"({bracket[0]:g}, {bracket[1]:g}]"


def _claim(s: dict, replicas: int) -> dict:
    loop_b, int_b = s["loop_contact_bracket"], s["interior_contact_bracket"]
    n1000 = s["n_loops_at_1000"]
    inside = loop_b is not None and loop_b[0] < 1000.0 <= loop_b[1]
    return {
        "claim": "loops start to touch loops at λ ≈ 1000",
        "source": paper.PAPER_VALUES["lambda_contact"].source,
        "measured": (
            f"first stage with a contact between two different loops (loop definition, "
            f"{replicas} replica(s), bracket over replicas): {_txt(loop_b)}; first interior "
            f"contact (current definition, row lambda_contact): {_txt(int_b)}; first loop "
            f"inside another (depth >= 1): {_txt(_bracket(s['nested_onset']))}; loops at "
            f"λ = 1000: " + ", ".join("—" if not np.isfinite(v) else f"{v:.0f}" for v in n1000)
        ),
        "criterion": (
            "loop definition: a contact link whose two ends each border a loop (contact "
            f"distance {CONTACT_FACTOR:g} d) that does not reach the other end "
            "(LoopStats.n_loop_contacts > 0); consistent if 1000 lies in the bracket "
            "(last stage without, first stage with]"
        ),
        "verdict": "consistent" if inside else "not consistent",
    }


def draw(rec: Record) -> dict:
    """n(λ) and the numbered loops at λ = 1000."""
    from ..figures import plot_loop_count

    s = rec.detail["summary"]
    fig = plot_loop_count(
        s["lam"],
        s["n_loops"],
        brackets={
            "loops touch loops (loop definition)": s["loop_contact_bracket"],
            "first interior contact (row lambda_contact)": s["interior_contact_bracket"],
        },
        picture=rec.detail["picture"],
    )
    return {"fig2_loops": fig}
