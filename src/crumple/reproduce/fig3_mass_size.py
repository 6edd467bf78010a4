"""Fig. 3: the mass-size exponent D_M at λ = 1000 over six (k_b, k_s), and D_M against λ.

Runs: ``elastic`` and ``elastic_per_node`` at :data:`crumple.paper.FIG3_POINTS`. Measures,
under each reading of Eq. 1: D_M per point (replica mean,
:func:`~crumple.reproduce.common._combine`) pooled over the six, three alternative readings of
Eq. 3 and of the fit, the wires that cannot be fitted (hollow: no wire within R_G/2 of the
centre of mass) with D_M where the wire has mass, the replica-mean D_M at every stage and its
slope against log10 λ above λ = 100 (saturation). Says: rows ``D_M`` and ``D_M_slope``.
"""

from __future__ import annotations

import math

import numpy as np

from .. import paper
from ..observables import mass_size_exponent, mass_within, r_max
from .common import (
    PER_NODE_VARIANT,
    Context,
    Estimate,
    Record,
    _alt,
    _alt_reason,
    _both_readings_discussion,
    _both_readings_reasons,
    _combine,
    _jsonable,
    _linear_slope,
    _measure_both,
    _num,
    _pool,
    _row,
)
from .experiments import ELASTIC, ELASTIC_PER_NODE
from .series import LAM_FIG3, Series, _dm, _dm_fit

NAME = "fig3_mass_size"
READS = (ELASTIC, ELASTIC_PER_NODE)
NEEDS: tuple[str, ...] = ()
VALUES = tuple(paper.PAPER_VALUES[k] for k in ("D_M", "D_M_slope"))
FIGURES = {
    "fig3_mass_size": "Fig. 3: (a) the mass fraction M(R)/M within R of the centre of mass "
    "at λ = 1000 (replica 0; grey: the fit window R/R_G ∈ [0.5, 1]; dashed: the fitted power "
    "laws, which overshoot M = 1 where M(R) is not a power law); (b) D_M against λ (replica "
    "mean, band ±2σ of the mean). Gaps in (b): stages where D_M cannot be fitted for some "
    "replica, because M(R) = 0 at R = R_G/2 (no wire within half the radius of the centre "
    "of mass: a hollow loop, typical of the first loops). D_M = 1 at the first stages: the "
    "wire is still straight",
    "fig3_mass_size_per_node": "Fig. 3 with confinement λ r² per node (Eq. 1 as printed), "
    "the same points, replicas and stages: (a) M(R)/M at λ = 1000, (b) D_M against λ. A "
    "curve of (a) without a fit ('cannot be fitted'), and the gaps in (b), are hollow rings: "
    "M(R) = 0 over part of the fit window, where D_M cannot be fitted",
}
#: A range where the wire has mass must span at least this factor in R to be fitted.
_MIN_SPAN = 1.25
_QUANTITY = "D_M at λ = 1000, six points"


def _label(key) -> str:
    return f"k_b={key[0]:g}, k_s={key[1]:g}"


#: A wire is a rod (folded flat onto a line, D_M = 1 whatever the fold) when the smaller
#: principal axis of its node cloud is below this fraction of the larger (rms widths).
_ROD_ASPECT = 0.1


def _is_rod(x) -> bool:
    """Whether the wire ``x`` (nodes, shape (n, 2)) lies along a line: the rms width across
    its principal axis under :data:`_ROD_ASPECT` of the rms width along it."""
    x = np.asarray(x, float)
    ev = np.linalg.eigvalsh(np.cov((x - x.mean(axis=0)).T))
    return bool(ev[1] > 0 and math.sqrt(max(ev[0], 0.0) / ev[1]) < _ROD_ASPECT)


def _dm_stages(el: Series, fig3: list[int]) -> np.ndarray:
    """D_M of every wire at every stage, shape (point, replica, λ); NaN where the wire was
    not run or cannot be fitted (hollow)."""
    out = np.full((len(fig3), el.replicas, el.lam.size), np.nan)
    for a, p in enumerate(fig3):
        for r in range(el.replicas):
            for j in range(el.lam.size):
                if el.valid(p, r, j):
                    out[a, r, j] = _dm_fit(el.positions[p, r, j])[0]
    return out


def _dm_against_lambda(el: Series, fig3: list[int], dm: np.ndarray):
    """Replica mean, sd and count of D_M at every stage of each point, shape (point, λ); the
    mean is NaN where some wire of the stage cannot be fitted (a gap in Fig. 3b)."""
    valid = np.zeros(dm.shape, bool)
    for a, p in enumerate(fig3):
        for r in range(el.replicas):
            valid[a, r] = [el.valid(p, r, j) for j in range(el.lam.size)]
    n = valid.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(valid, dm, 0.0)
        mean = np.where(n > 0, d.sum(axis=1) / n, np.nan)
        sd = np.sqrt(np.where(valid, (d - mean[:, None, :]) ** 2, 0.0).sum(axis=1) / n)
    sd = np.where(n > 0, sd, np.nan)
    return mean, sd, n


def _rods(el: Series, fig3: list[int]) -> list[tuple[int, int]]:
    """Per point, at λ = 1000: how many of its wires are rods (:func:`_is_rod`), of how many."""
    j = el.j(LAM_FIG3)
    out = []
    for p in fig3:
        wires = [el.positions[p, r, j] for r in range(el.replicas) if el.valid(p, r, j)]
        out.append((sum(_is_rod(x) for x in wires), len(wires)))
    return out


def _dm_slope(el: Series, fig3: list[int], dm: np.ndarray) -> tuple[Estimate, dict]:
    """Slope of D_M against log10 λ over λ ∈ DM_SATURATION_RANGE: fitted per wire over the
    stages where it can be fitted (at least 3), combined over the replicas of a point
    (:func:`_combine`) and pooled over the points (:func:`_pool`). A wire that is a rod at
    λ = 1000 is left out (its D_M = 1 says it is folded flat, not how it fills the plane)."""
    lo, hi = paper.DM_SATURATION_RANGE
    sel = (el.lam > lo) & (el.lam <= hi)
    x = np.log10(el.lam[sel])
    j3 = el.j(LAM_FIG3)
    per, rods = [], 0
    for a, p in enumerate(fig3):
        vals, errs = [], []
        for r in range(el.replicas):
            if el.valid(p, r, j3) and _is_rod(el.positions[p, r, j3]):
                rods += 1
                continue
            v, e = _linear_slope(x, dm[a, r, sel])
            vals.append(v)
            errs.append(e)
        per.append(_combine(vals, errs, (float(el.lam[sel][0]), hi) if sel.any() else None))
    est = _pool(per, (float(el.lam[sel][0]), hi) if sel.any() else None)
    info = {
        "points_fitted": int(sum(e.n > 0 and np.isfinite(e.value) for e in per)),
        "points": len(fig3),
        "rod_wires": rods,
        "per_point": {
            f"{el.keys[p][0]:g}, {el.keys[p][1]:g}": e for p, e in zip(fig3, per, strict=True)
        },
    }
    return est, info


def _mass_curves(el: Series) -> dict:
    """M(R) of replica 0 at λ = 1000 with its fitted power law, per Fig. 3 point."""
    j3 = el.j(LAM_FIG3)
    curves = {}
    for k in paper.FIG3_POINTS:
        p = el.index(k)
        if not el.valid(p, 0, j3):
            continue
        x = el.positions[p, 0, j3]
        ratio = np.geomspace(0.05, 1.0, 60)
        m = mass_within(x, ratio * r_max(x))
        try:
            f = mass_size_exponent(x)
            fit = (f.prefactor, f.exponent)
        except ValueError:  # M(R) = 0 somewhere in the fit window: hollow, no fit
            fit = (math.nan, math.nan)
        curves[_label(k)] = (ratio, m, fit)
    return curves


def _inner_start(x) -> float:
    """The smallest R/R_G (R_G = r_max) at which M(R) > 0: where the wire starts, seen from
    its centre of mass (0.01 resolution in ln R)."""
    ratio = np.geomspace(0.01, 1.0, 461)
    m = mass_within(x, ratio * r_max(x))
    return float(ratio[np.argmax(m > 0)])


def _dm_hollow(el: Series, p: int) -> tuple[int, int, Estimate]:
    """At λ = 1000: how many of the wires of point ``p`` cannot be fitted on the paper's
    range (M(R) = 0 somewhere in it: hollow), of how many, and D_M on the range where each
    wire has mass, [max(0.5, 1.1 ρ), 1] with ρ the R/R_G where its mass starts (a range
    narrower than a factor 1.25 in R is not fitted). The estimate's range starts at the
    smallest start used (each wire is fitted from its own)."""
    j = el.j(LAM_FIG3)
    hollow, total, vals, errs, starts = 0, 0, [], [], []
    for r in range(el.replicas):
        if not el.valid(p, r, j):
            continue
        x = el.positions[p, r, j]
        total += 1
        hollow += int(not np.isfinite(_dm_fit(x)[0]))
        start = max(paper.DM_RANGE[0], 1.1 * _inner_start(x))
        if start * _MIN_SPAN <= 1.0:
            v, e = _dm_fit(x, fit_range=(start, 1.0))
            vals.append(v)
            errs.append(e)
            starts.append(start)
    return hollow, total, _combine(vals, errs, (min(starts), 1.0) if vals else None)


def _hollow_info(el: Series, fig3: list[int]) -> dict:
    """Hollow wires over the six points at λ = 1000, and D_M where the wire has mass."""
    per = [_dm_hollow(el, p) for p in fig3]
    inner = _pool([e for _, _, e in per])
    out = {
        "wires": sum(h for h, _, _ in per),
        "rods": sum(n for n, _ in _rods(el, fig3)),
        "of": sum(t for _, t, _ in per),
        "inner": inner.to_dict(),
        "inner_points": {
            f"{el.keys[p][0]:g}, {el.keys[p][1]:g}": {"hollow": h, "of": t, **e.to_dict()}
            for p, (h, t, e) in zip(fig3, per, strict=True)
        },
    }
    out["inner_range"] = _inner_range(_jsonable(out))
    return out


def _inner_range(h: dict) -> str:
    """The ranges "where the wire has mass" actually fitted: [a, 1], or [a-b, 1] when the
    wires start at different R/R_G."""
    starts = [e["fit_range"][0] for e in h["inner_points"].values() if e["fit_range"]]
    if not starts:
        return "—"
    lo, hi = min(starts), max(starts)
    return f"[{lo:.2f}, 1]" if round(lo, 2) == round(hi, 2) else f"[{lo:.2f}…{hi:.2f}, 1]"


def _hollow_note(h: dict) -> str:
    inner = h["inner"]
    where = (
        f"; where the wire has mass, R/R_G ∈ {_inner_range(h)}: D_M = "
        f"{_num(inner['value'], inner['sigma'])}"
        if inner["value"] is not None
        else "; no range of R where the wire has mass spans a factor 1.25"
    )
    return (
        f"{h['wires']} of {h['of']} wires at λ = 1000 cannot be fitted on R/R_G ∈ [0.5, 1]: "
        f"hollow rings, M(R) = 0 over part of the range{where}"
    )


def _measure(el: Series, nrep: int) -> Record:
    """D_M, its alternatives and its saturation, from one elastic series."""
    fig3 = [el.index(k) for k in paper.FIG3_POINTS]
    dm_points = {tuple(el.keys[p]): _dm(el, p) for p in fig3}
    dm = _pool(list(dm_points.values()), paper.DM_RANGE)
    hollow = _hollow_info(el, fig3)
    note = f"mean over {dm.n} of the {len(fig3)} (k_b, k_s) that can be fitted"
    if hollow["wires"]:
        note += "; " + _hollow_note(hollow)
    if hollow["rods"]:
        note += (f"; rods at λ = 1000 (folded flat onto a line: D_M = 1 whatever the folding): "
                 f"{hollow['rods']} of {hollow['of']} wires")  # fmt: skip
    rows = [{**_row("D_M", dm, f"{nrep} × {dm.n} of {len(fig3)} points", note),
             "hollow": hollow}]  # fmt: skip
    if not np.isfinite(dm.value) and hollow["wires"]:
        rows[0]["verdict"] = "cannot be fitted (hollow ring)"
    alts = [_alt(_QUANTITY, "default: R_G = r_max, exact M(R), [0.5, 1]", dm, nrep, 1.33)]
    for variant, kw in (
        ("R_G = RMS radius", {"rg": "rms"}),
        ("M(R) as Eq. 3 prints it", {"method": "eq3"}),
        ("fit on R/R_G in [0.1, 0.5]", {"fit_range": (0.1, 0.5)}),
    ):
        est = _pool([_dm(el, p, **kw) for p in fig3], kw.get("fit_range", paper.DM_RANGE))
        alts.append(_alt(_QUANTITY, variant, est, nrep, 1.33))
    inner = Estimate(hollow["inner"]["value"] or math.nan, hollow["inner"]["sigma"] or math.nan,
                     hollow["of"], hollow["inner"]["fit_range"])  # fmt: skip
    alts.append(_alt(_QUANTITY, "where the wire has mass: [max(0.5, 1.1 ρ_in), 1]", inner,
                     nrep, 1.33))  # fmt: skip
    j3 = el.j(LAM_FIG3)
    m_half = [
        float(mass_within(el.positions[p, r, j3], [0.5 * r_max(el.positions[p, r, j3])])[0])
        for p in fig3
        for r in range(el.replicas)
        if el.valid(p, r, j3)
    ]
    dm_all = _dm_stages(el, fig3)
    dm_lam, dm_lam_sd, dm_lam_n = _dm_against_lambda(el, fig3, dm_all)
    extra = {
        "D_M_points": {f"{k[0]:g}, {k[1]:g}": v for k, v in dm_points.items()},
        "D_M_hollow": hollow,
        "M_at_half_RG": [min(m_half), max(m_half)] if m_half else None,
        "r_max_1000": _nanmean(el.obs["r_max"][fig3][:, :, j3]),
        "D_M_lambda": {
            "points": [list(el.keys[p]) for p in fig3],
            "lam": el.lam,
            "mean": dm_lam,
            "sd": dm_lam_sd,
            "n": dm_lam_n,
        },
    }
    rows.append(_slope_row(el, fig3, dm_all, nrep, extra))
    return Record(
        rows=tuple(rows),
        alternatives=tuple(alts),
        extra=extra,
        detail={"curves": _mass_curves(el)},
    )


def _slope_row(el: Series, fig3: list[int], dm_all: np.ndarray, nrep: int, extra: dict):
    """The row ``D_M_slope`` (:func:`_dm_slope`); its per-point slopes go to ``extra``."""
    slope, info = _dm_slope(el, fig3, dm_all)
    extra["D_M_slope"] = info
    rods = (
        f"; {info['rod_wires']} wire(s) left out: rods at λ = 1000 (folded flat, D_M = 1)"
        if info["rod_wires"]
        else ""
    )
    row = _row(
        "D_M_slope",
        slope,
        f"{nrep} × {info['points_fitted']} of {info['points']} points",
        "slope of D_M against log10 λ, fitted per wire over the stages where it can be fitted, "
        f"pooled over {info['points_fitted']} of {info['points']} points (0 = saturated){rods}",
    )
    return {**row, "points_fitted": [info["points_fitted"], info["points"]]}


def _nanmean(a, axis=None):
    """np.nanmean without the warning of an all-NaN slice (NaN there: nothing measured)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        out = np.nanmean(a, axis=axis)
    return float(out) if axis is None else out


def measure(ctx: Context) -> Record:
    """D_M, its alternatives and its saturation, per length and per node."""
    return _measure_both(ctx, NAME, _measure)


def _draw(rec: Record):
    from ..figures import plot_mass_size

    d = rec.extra["D_M_lambda"]
    # σ of a replica mean: sd / sqrt(n) (the band is ±2σ, as everywhere in the report)
    sem = np.asarray(d["sd"], float) / np.sqrt(np.maximum(np.asarray(d["n"], float), 1.0))
    dml = {_label(k): (d["lam"], d["mean"][i], sem[i]) for i, k in enumerate(d["points"])}
    return plot_mass_size(rec.detail["curves"], dml, fit_range=paper.DM_RANGE, paper_value=1.33)


def draw(rec: Record) -> dict:
    """Fig. 3: M(R) with its fits, and D_M against λ; per length, then per node."""
    return {
        "fig3_mass_size": _draw(rec),
        "fig3_mass_size_per_node": _draw(rec.detail["per_node"]),
    }


def _point_dm(e: dict, h: dict | None) -> str:
    """D_M of one point for the per-point list, or why there is none (``h``: its hollow
    count at λ = 1000)."""
    if e["value"] is not None:
        return f"{e['value']:.2f}"
    if h is None or h["of"] == 0:
        return "not run"
    return "cannot be fitted (hollow ring)" if h["hollow"] else "cannot be fitted"


def _discuss(rec: Record) -> dict[str, str]:
    """Why D_M differs (or not) under one reading, from the numbers of its record."""
    ex = rec.extra
    hp = _jsonable(ex["D_M_hollow"])["inner_points"]
    pts = ", ".join(
        f"({k}) {_point_dm(e, hp.get(k))}" for k, e in _jsonable(ex["D_M_points"]).items()
    )
    dm_alts = [
        a
        for a in rec.alternatives
        if a["quantity"] == _QUANTITY and not a["variant"].startswith("default")
    ]
    agree = [
        a["variant"]
        for a in dm_alts
        if a["value"] is not None and a["sigma"] and abs(a["value"] - 1.33) <= 2 * a["sigma"]
    ]
    mh = ex.get("M_at_half_RG") or [math.nan, math.nan]
    h = ex["D_M_hollow"]
    dm = (
        f"Per point: {pts}. The paper's own fit range R/R_G ∈ [0.5, 1] with R_G = r_max sits "
        f"where the disc reaches the wire's outer loops: M(R_G/2) is only {mh[0]:.2f} to "
        f"{mh[1]:.2f} of the mass and M(R_G) = 1, so over this factor 2 in R the log-slope "
        "is large (Fig. 3a shows M(R) and the range). "
        + (_hollow_note(h) + ". " if h["wires"] else "")
        + "The alternatives: "
        + "; ".join(f"{a['variant']}: {_num(a['value'], a['sigma'])}" for a in dm_alts)
        + ". "
        + (
            "Within 2σ of 1.33: " + ", ".join(agree) + " — a different range or reading "
            "than the paper states, shown, not adopted."
            if agree
            else "None of them gives 1.33 within 2σ."
        )
        + f" A wire of N = 100 segments (segment 0.01) crumpled to r_max ≈ "
        f"{ex['r_max_1000']:.2f} has barely a decade between its segment length and its size "
        "in which a fractal dimension could be measured."
    )
    row = next(r for r in rec.rows if r["key"] == "D_M_slope")
    return {"D_M": dm, "D_M_slope": _slope_text(row, _jsonable(ex["D_M_slope"]))}


def discuss(rec: Record, records) -> dict[str, str]:
    """Why D_M differs (or not), per length and per node, from the numbers of the record."""
    return _both_readings_discussion(_discuss, rec)


def _slope_text(row: dict, info: dict) -> str:
    """What the slope of D_M(λ) says, from its verdict (the discussion's sentence)."""
    n = f"{info['points_fitted']} of {info['points']} points"
    per = ", ".join(f"({k}) {_num(e['value'], e['sigma'])}" for k, e in info["per_point"].items())
    rods = f"; {info['rod_wires']} rod wire(s) left out" if info["rod_wires"] else ""
    head = (
        f"Slope of D_M against log10 λ above λ = 100, fitted per wire and pooled over {n}{rods}: "
        f"{_num(row['ours'], row['sigma'])} per decade (per point: {per}). "
    )
    if row["ours"] is None:
        return head + "No wire has three stages where D_M can be fitted: saturation not measured."
    if row["verdict"].startswith("agrees"):
        return head + "Within 2σ of 0: D_M(λ) is constant within the noise above λ = 100."
    return head + (
        "Not within 2σ of 0: D_M(λ) still changes above λ = 100 (Fig. 3b), as loops form and zip."
    )


def _reason(rec: Record) -> dict[str, str]:
    """Why D_M and its saturation differ under one reading: a cause and one number each,
    from its record (the details are in :func:`_discuss`)."""
    ex = _jsonable(rec.extra)
    h = ex["D_M_hollow"]
    if h["wires"] and h["wires"] == h["of"]:
        dm = f"shape: all {h['of']} wires are hollow rings, D_M cannot be fitted"
    elif ex["D_M_points"] and all(v["value"] is None for v in ex["D_M_points"].values()):
        dm = "not fitted: no wire of this profile's points can be fitted"
    else:
        alts = [
            a
            for a in rec.alternatives
            if a["quantity"] == _QUANTITY
            and not a["variant"].startswith(("default", PER_NODE_VARIANT))
        ]
        dm = _alt_reason(alts, 1.33, "range or reading")
    row = next(r for r in rec.rows if r["key"] == "D_M_slope")
    info = ex["D_M_slope"]
    sat = (
        f"not saturated: D_M changes by {_num(row['ours'], row['sigma'])} per decade of λ "
        f"({info['points_fitted']} of {info['points']} points)"
    )
    return {"D_M": dm, "D_M_slope": sat}


def summarise(rec: Record, records) -> dict[str, dict[str, str]]:
    """The summary's reason for each row, per reading (``per-length``, ``per-node``)."""
    return _both_readings_reasons(_reason, rec)
