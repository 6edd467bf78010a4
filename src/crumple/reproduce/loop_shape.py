"""Sec. III.A: the early-stage loop against the lemniscate lobe r² = ℓ² sin 2θ.

Runs: ``elastic`` at :data:`crumple.paper.FIG2`. Measures: at every stage up to λ = 300, the
loop closed at the wire's narrowest neck (:func:`loop_comparison`), its rms deviation from the
lobe and from a circle through the neck, its size against (k_b/λ)^¼. Says: one claim.
"""

from __future__ import annotations

import math

import numpy as np

from .. import paper
from ..theory import loop_size
from .common import Context, Record
from .experiments import ELASTIC

NAME = "loop_shape"
READS = (ELASTIC,)
NEEDS: tuple[str, ...] = ()
VALUES = ()
FIGURES = {
    "fig_loop_shape": "Sec. III.A: the early-stage loop against r² = ℓ² sin 2θ. (a) r and θ "
    "are polar coordinates about the midpoint of the loop's neck (its two closest nodes at "
    "least N/4 apart along the wire), θ measured so that the loop's farthest node lies on the "
    "lobe's bisector θ = 45°, r rescaled by that node's distance r_max; solid: the lemniscate "
    "lobe, dotted: a circle through the neck; (b) the wire (x, y in units of L0) of the first "
    "loop shown in (a), the loop compared in orange, the neck's midpoint (the origin of r) "
    "marked ×, the trap centre +"
}
#: Largest rms deviation of r/r_max from the lemniscate lobe still called a match.
LOOP_RMS = 0.05


def loop_comparison(x, min_separation: int | None = None) -> dict | None:
    """Compare the loop closed at the wire's narrowest neck with ``r = r_max sqrt(sin 2θ)``.

    The neck is the closest pair of nodes ``i < j`` at least ``min_separation`` apart along
    the wire (default N/4). Polar coordinates are taken about the neck's midpoint, with the
    loop's farthest node on the bisector θ = π/4 of the lemniscate lobe and r rescaled by
    that node's distance: the shape reading of :func:`crumple.theory.loop_shape`. Returns
    the rms deviation of r/r_max from ``sqrt(max(sin 2θ, 0))`` over the loop's nodes, the
    same for a circle through the neck (``cos(θ - π/4)``) as a yardstick, the loop's size
    and where the neck sits.
    """
    x = np.asarray(x, float)
    n = x.shape[0]
    sep = max(3, n // 4) if min_separation is None else int(min_separation)
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1)
    i_idx, j_idx = np.triu_indices(n, k=sep)
    if i_idx.size == 0:
        return None
    k = int(np.argmin(d[i_idx, j_idx]))
    i, j = int(i_idx[k]), int(j_idx[k])
    base = 0.5 * (x[i] + x[j])
    loop = x[i : j + 1] - base
    rr = np.hypot(loop[:, 0], loop[:, 1])
    far = int(np.argmax(rr))
    rmax = float(rr[far])
    phi = np.arctan2(loop[:, 1], loop[:, 0]) - math.atan2(loop[far, 1], loop[far, 0])
    theta = (phi + math.pi / 4 + math.pi) % (2 * math.pi) - math.pi
    # orient so that the loop runs from θ = 0 to π/2 (mirror images are the same shape)
    if np.mean(np.diff(np.unwrap(theta))) < 0:
        theta = math.pi / 2 - theta
    rho = rr / rmax
    keep = rho > 0.02  # at the neck itself the polar angle is undefined
    theta, rho = theta[keep], rho[keep]
    lem = np.sqrt(np.clip(np.sin(2 * theta), 0, None))
    circ = np.clip(np.cos(theta - math.pi / 4), 0, None)
    length = float(np.sum(np.linalg.norm(np.diff(x[i : j + 1], axis=0), axis=1)))
    return {
        "neck": [i, j],
        "neck_gap": float(d[i, j]),
        "neck_distance_from_trap": float(np.hypot(*base)),
        "r_max": rmax,
        "loop_length": length,
        "rms_lemniscate": float(np.sqrt(np.mean((rho - lem) ** 2))),
        "rms_circle": float(np.sqrt(np.mean((rho - circ) ** 2))),
        "theta": theta,
        "rho": rho,
    }


def _early(loops: list[dict]) -> list[dict]:
    """The closed loops (neck narrower than 0.05) at λ <= 200."""
    return [lc for lc in loops if lc["neck_gap"] < 0.05 and lc["lam"] <= 200]


def _claim(early: list[dict]) -> dict:
    if not early:
        return {
            "claim": "early-stage loops follow r² √(k_b/λ) = sin 2θ (read: r² = ℓ² sin 2θ)",
            "source": "Sec. III.A",
            "measured": "no closed loop (neck narrower than 0.05) at λ <= 200",
            "criterion": "a closed early loop to compare",
            "verdict": "not measured",
        }
    rms_l = np.array([lc["rms_lemniscate"] for lc in early])
    rms_c = np.array([lc["rms_circle"] for lc in early])
    return {
        "claim": "early-stage loops follow r² √(k_b/λ) = sin 2θ (read: r² = ℓ² sin 2θ)",
        "source": "Sec. III.A: 'This matches the pattern in the initial stage of the "
        "crumpling ... as well as in our simulations'",
        "measured": f"closed loops at {len(early)} stages, λ = {early[0]['lam']:g} to "
        f"{early[-1]['lam']:g}: rms deviation of r/r_max from √sin 2θ "
        f"{rms_l.min():.3f} to {rms_l.max():.3f} (a circle through the neck: "
        f"{rms_c.min():.3f} to {rms_c.max():.3f}); loop size r_max "
        f"{early[0]['r_max']:.3f} to {early[-1]['r_max']:.3f} vs (k_b/λ)^¼ "
        f"{early[0]['ell']:.3f} to {early[-1]['ell']:.3f}; the neck sits "
        f"{min(lc['neck_distance_from_trap'] for lc in early):.2f} to "
        f"{max(lc['neck_distance_from_trap'] for lc in early):.2f} from the trap centre "
        "(the derivation puts it at the centre)",
        "criterion": f"the lobe matches the loop: rms <= {LOOP_RMS} (of r_max) and better "
        "than a circle through the neck, at every such stage",
        "verdict": "consistent"
        if np.all((rms_l <= LOOP_RMS) & (rms_l < rms_c))
        else "not consistent",
    }


def measure(ctx: Context) -> Record:
    """The loops of replica 0 at the Fig. 2 point, λ <= 300."""
    el = ctx.series["elastic"]
    fig2 = el.index(paper.FIG2)
    loops = []
    for j, lm in enumerate(el.lam):
        if lm > 300 or not el.valid(fig2, 0, j):
            continue
        lc = loop_comparison(el.positions[fig2, 0, j])
        if lc is None:
            continue
        lc["lam"] = float(lm)
        # per-length confinement: λ is the continuum one; the continuum bending modulus is
        # k_b Δs (crumple.theory.loop_size)
        lc["ell"] = float(loop_size(paper.FIG2[0] * el.ds, lm))
        loops.append(lc)
    early = _early(loops)
    show = early[:: max(1, len(early) // 4)] or loops[:1]
    # panel (b): the wire of the first loop shown in (a)
    jb = el.j(show[0]["lam"]) if show else el.j(70.0)
    cfg = el.positions[fig2, 0, jb] if el.valid(fig2, 0, jb) else None
    lcb = loop_comparison(cfg) if cfg is not None else None
    return Record(
        claims=(_claim(early),),
        extra={
            "loops": [{k: v for k, v in lc.items() if k not in ("theta", "rho")} for lc in loops]
        },
        detail={
            "shown": [(lc["theta"], lc["rho"], f"λ = {lc['lam']:.3g}") for lc in show],
            "configuration": cfg,
            "neck": None if lcb is None else lcb["neck"],
            "lam": float(el.lam[jb]),
        },
    )


def draw(rec: Record) -> dict:
    """(a) the early loops against the lobe, (b) the wire of the first one."""
    from ..figures import plot_loop_shape

    d = rec.detail
    fig = plot_loop_shape(
        d["shown"],
        configuration=d["configuration"],
        neck=d["neck"],
        title=f"(b): the wire at λ = {d['lam']:.3g}",
    )
    return {"fig_loop_shape": fig}
