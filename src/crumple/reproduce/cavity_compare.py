"""Cavity study, its one section: injection into a cavity against potential confinement, at
matched packing.

Runs: ``cavity_injection`` and ``cavity_ramp`` (:mod:`.cavity`), the same wire elastic and
plastic. Measures, per replica and then replica mean ± σ (``_combine``):

* at matched packing (the ramp stage whose φ = h L/(π r_max²) is nearest the injection's
  final φ = h L_in/(π R_c²)): D_M (the reproduction's reading: about the centre of mass,
  R/r_max ∈ [0.5, 1]), the elastic energy per length (E_b + E_s)/L, γ = E_s/E_b, contacts per
  length, loops; a verdict each, "same within 2σ" or "differs";
* force against size in the same units: the confining pressure P (the wall's total force
  over 2π R_c; the trap's Σ 2λ w_i |x_i| over 2π r_max) against φ, P ~ φ^κ, over the upper
  decade of φ both reach; and, beside it, F(L_in) ~ L_in^β (the injection force: the
  pusher's work per length) and
  r_max ~ λ^α (the ramp);
* against published numbers: D_M = 1.9 ± 0.1 in tight packing (Donato & Gomes), and the
  loop number's growth with injected length (Stoop et al. PRL 101, 094101), whose exponent
  we state as measured (n_loops ~ L_in^ν).

Says: one row per observable and wire, and the claims.
"""

from __future__ import annotations

import math

import numpy as np

from ..energy import confinement_weights
from ..observables import mass_size_exponent, mass_within
from ..paper import PaperValue
from .cavity import INJECTION, RAMP
from .cavity_draw import discuss, draw
from .common import Context, Estimate, Record, _alt, _combine, _f, _fit_replicas
from .series import Series

__all__ = ["FIGURES", "NAME", "NEEDS", "READS", "VALUES", "discuss", "draw", "measure"]

NAME = "cavity_compare"
READS = (INJECTION, RAMP)
NEEDS: tuple[str, ...] = ()
#: The observables compared at matched packing: key -> (quantity, note).
_COMPARED = {
    "D_M": "D_M about the centre of mass, R/r_max ∈ [0.5, 1]",
    "energy_per_length": "elastic energy per length (E_b + E_s)/L [energy/length]",
    "gamma": "γ = E_s/E_b",
    "contacts_per_length": "contacts per length [1/length]",
    "loops": "loops (closed by wire-wire contacts at 2d)",
    "pressure_exponent": "κ in P ~ φ^κ, confining pressure against packing",
}
_WIRES = {1.0: "elastic", 0.2: "plastic s = 0.2"}


def _quantity(k: str, label: str) -> str:
    """The table row's quantity: the observable and the wire (cavity against potential)."""
    return f"{_COMPARED[k]}, {label}: cavity vs potential"


VALUES = tuple(
    PaperValue(f"cavity_{k}_{w.split()[0]}", _quantity(k, w), math.nan,
               "this study: potential confinement (the 'paper' column is the ramp's value)")
    for k in _COMPARED for w in _WIRES.values()
)  # fmt: skip
FIGURES = {
    "cavity_configurations": "The same wire at matched packing: injected into the cavity "
    "(top; the channel on the right) and confined by the potential (bottom), elastic and "
    "plastic, replica 0",
    "cavity_observables": "Against packing fraction φ, cavity (solid) and potential (dashed), "
    "elastic (blue) and plastic (red), replica means: elastic energy per length, γ, contacts "
    "per length, loops; the matched φ marked",
    "cavity_force": "Force against size in the same units: (left) confining pressure P "
    "against φ, both protocols, with the fitted κ; (right) the injection force F (the "
    "pusher's work per length) against L_in",
    "cavity_mass": "M(R) about the centre of mass at matched packing, against R/r_max: cavity "
    "(solid) and potential (dashed), every replica; the fit range [0.5, 1] shaded",
}
#: Donato & Gomes: the mass dimension of tightly packed injected wires.
DONATO_GOMES = (1.9, 0.1)


def _final(s: Series, p: int, r: int) -> int:
    """The last stage a run reached (-1 if none)."""
    ran = np.flatnonzero(np.isfinite(s.max_force[p, r]))
    return int(ran[-1]) if ran.size else -1


def _length(s: Series) -> float:
    """The wire's contour length L0, from the store's manifest (default 1, as ``Wire``)."""
    return float(s.wire.get("length", 1.0))


def _phi_ramp(ramp: Series, p: int, r: int) -> np.ndarray:
    return ramp.hard_core * _length(ramp) / (np.pi * ramp.obs["r_max"][p, r] ** 2)


def _trap_pressure(ramp: Series, p: int, r: int) -> np.ndarray:
    """P = Σ 2λ w_i |x_i| / (2π r_max) at every stage ``[energy/length²]``."""
    x = ramp.positions[p, r]
    w = confinement_weights(x.shape[1], ramp.confinement, _length(ramp))
    force = 2.0 * ramp.lam * np.einsum("i,si->s", w, np.hypot(x[..., 0], x[..., 1]))
    return force / (2.0 * np.pi * ramp.obs["r_max"][p, r])


def _stage_values(s: Series, p: int, r: int, j: int, length: float) -> dict[str, float]:
    """The compared observables of one stage (``length``: the wire in the packing)."""
    e = s.energies
    eb, es = e["bending"][p, r, j], e["stretching"][p, r, j]
    x = s.positions[p, r, j]
    if "injected_length" in s.obs:
        x = x[np.hypot(x[:, 0], x[:, 1]) < _radius(s)]
        dm = s.obs["D_M_com"][p, r, j]
    else:
        dm = _dm(x)
    return {
        "D_M": dm,
        "energy_per_length": (eb + es) / length,
        "gamma": es / eb if eb > 0 else math.nan,
        "contacts_per_length": s.obs["contacts"][p, r, j] / length,
        "loops": s.obs["n_loops"][p, r, j],
    }


def _dm(x) -> float:
    try:
        return float(mass_size_exponent(x).exponent)
    except ValueError:  # M = 0 at R = r_max/2: a hollow packing
        return math.nan


def _radius(inj: Series) -> float:
    """R_c, from the store's manifest."""
    radius = inj.wire.get("cavity_radius")
    if radius is None:
        raise ValueError("the injection store's manifest names no cavity_radius")
    return float(radius)


def _matched(inj: Series, ramp: Series, p: int) -> dict:
    """Per replica: the injection's final stage, the ramp's stage at the same φ, and the
    observables of both there."""
    out = {"cavity": [], "ramp": [], "phi": [], "phi_ramp": [], "stages": []}
    for r in range(inj.replicas):
        j = _final(inj, p, r)
        if j < 0 or _final(ramp, p, r) < 0:
            continue
        phi = inj.obs["packing_fraction"][p, r, j]
        pr = _phi_ramp(ramp, p, r)
        with np.errstate(invalid="ignore", divide="ignore"):
            k = int(np.nanargmin(np.abs(np.log(pr / phi))))
        out["cavity"].append(_stage_values(inj, p, r, j, inj.lam[j]))
        out["ramp"].append(_stage_values(ramp, p, r, k, _length(ramp)))
        out["phi"].append(float(phi))
        out["phi_ramp"].append(float(pr[k]))
        out["stages"].append((r, j, k))  # the replica with them: one may be skipped
    return out


def _est(values: list[float]) -> Estimate:
    """Replica mean, σ = standard error (0 errors per replica: a direct measurement)."""
    v = [x for x in values if np.isfinite(x)]
    return _combine(v, [0.0] * len(v))


def _pressure_fits(inj: Series, ramp: Series, p: int) -> tuple[Estimate, Estimate, tuple]:
    """κ in P ~ φ^κ for both protocols over the upper decade of the φ range both reach."""
    phi_c = inj.obs["packing_fraction"][p]
    hi = float(min(np.nanmax(phi_c), np.nanmax([np.nanmax(_phi_ramp(ramp, p, r))
                                               for r in range(ramp.replicas)])))  # fmt: skip
    win = (hi / 10.0, hi)
    pc = inj.obs["wall_force"][p] / (2.0 * np.pi * _radius(inj))
    cav = _fit_window(phi_c, pc, win)
    ys, xs = [], []
    for r in range(ramp.replicas):
        xs.append(_phi_ramp(ramp, p, r))
        ys.append(_trap_pressure(ramp, p, r))
    vals, errs = [], []
    for x, y in zip(xs, ys, strict=True):
        e = _fit_window(x[None, :], y[None, :], win)
        vals.append(e.value)
        errs.append(e.sigma)
    return cav, _combine(vals, errs, win), win


def _fit_window(x, y, win) -> Estimate:
    x, y = np.atleast_2d(x), np.atleast_2d(y)
    vals, errs = [], []
    for xr, yr in zip(x, y, strict=True):
        ok = np.isfinite(xr) & np.isfinite(yr) & (yr > 0) & (xr >= win[0]) & (xr <= win[1])
        if ok.sum() >= 3:
            f = _fit_replicas(xr[ok], yr[ok][None, :])
            vals.append(f.value)
            errs.append(f.sigma)
    return _combine(vals, errs, win)


def _compare_row(key: str, quantity: str, cav: Estimate, ramp: Estimate, note: str,
                 replicas: str) -> dict:  # fmt: skip
    """A main-table row: the cavity's value against the ramp's, "same within 2σ" or
    "differs" with σ = (σ_cavity² + σ_ramp²)^1/2."""
    sigma = math.hypot(cav.sigma, ramp.sigma) if cav.n and ramp.n else math.nan
    ok = np.isfinite(cav.value) and np.isfinite(ramp.value) and np.isfinite(sigma)
    diff = cav.value - ramp.value if ok else math.nan
    if not ok and key.startswith("cavity_D_M") and cav.n == 0 and ramp.n:
        verdict = "undefined in the cavity (hollow packing: M = 0 at R = r_max/2)"
    elif not ok:
        verdict = "not measured"
    elif sigma == 0 and min(cav.n, ramp.n) < 2:
        verdict = "σ unknown (1 replica): no verdict"
    elif sigma == 0:
        verdict = "σ = 0 (identical replicas): no verdict"
    elif abs(diff) <= 2 * sigma:
        verdict = "same within 2σ"
    else:
        verdict = "differs"
    return {
        "key": key,
        "quantity": quantity,
        "paper": _f(ramp.value) if np.isfinite(ramp.value) else math.nan,
        "source": "potential confinement (ramp) of the same wire, this study",
        "ours": _f(cav.value),
        "sigma": _f(sigma),
        "ours_sigma": _f(cav.sigma) if cav.n else None,
        "paper_sigma": _f(ramp.sigma) if ramp.n else None,
        "deviation_sigma": _f(abs(diff) / sigma) if ok and sigma > 0 else None,
        "fit_range": None if cav.fit_range is None else [_f(v) for v in cav.fit_range],
        "replicas": replicas,
        "verdict": verdict,
        "note": note,
    }


def measure(ctx: Context) -> Record:
    """Every compared observable, for each wire, with its verdict; forces; published values."""
    inj, ramp = ctx.series["cavity_injection"], ctx.series["cavity_ramp"]
    rows, alts, extra, detail = [], [], {}, {"wires": {}}
    for p, key in enumerate(inj.keys):
        s = float(key[0])
        label = _WIRES.get(s, f"s = {s:g}")
        m = _matched(inj, ramp, p)
        cav = {k: _est([v[k] for v in m["cavity"]]) for k in _COMPARED if k != "pressure_exponent"}
        rmp = {k: _est([v[k] for v in m["ramp"]]) for k in cav}
        kc, kr, win = _pressure_fits(inj, ramp, p)
        cav["pressure_exponent"], rmp["pressure_exponent"] = kc, kr
        n = len(m["phi"])
        phi = float(np.mean(m["phi"])) if n else math.nan
        phir = float(np.mean(m["phi_ramp"])) if n else math.nan
        for k in _COMPARED:
            note = (
                f"matched at φ = {phi:.3g} (cavity) / {phir:.3g} (ramp)"
                if k != "pressure_exponent"
                else f"φ ∈ [{win[0]:.3g}, {win[1]:.3g}]"
            )
            rows.append(_compare_row(f"cavity_{k}_{label.split()[0]}", _quantity(k, label),
                                     cav[k], rmp[k], note, f"{n} per protocol"))  # fmt: skip
        beta = _force_exponent(inj, p)
        nu, nu_note = _loop_growth(inj, p)
        alpha = _alpha(ramp, p)
        alts += [
            _alt(f"F ~ L_in^β (injection force = work per length, from W = ∫F dL_in ~ "
                 f"L_in^(1+β); upper half of L_in: a factor 2 only), {label}", "cavity", beta,
                 inj.replicas),
            _alt(f"r_max ~ λ^α (λ ≥ 100), {label}", "potential", alpha, ramp.replicas, -0.25),
            _alt(f"n_loops ~ L_in^ν (stages with loops; {nu_note}), {label}", "cavity", nu,
                 inj.replicas),
            _alt(f"D_M about the cavity's centre at the final φ, {label}", "cavity",
                 _est([inj.obs["D_M_center"][p, r, j] for r, j, _ in m["stages"]]), n, 1.9),
        ]  # fmt: skip
        extra[label] = {"phi_matched": phi, "phi_ramp_matched": phir,
                        "cavity": {k: v.to_dict() for k, v in cav.items()},
                        "ramp": {k: v.to_dict() for k, v in rmp.items()},
                        "feed_force_exponent": beta.to_dict(), "loop_exponent": nu.to_dict(),
                        "loop_exponent_note": nu_note,
                        "alpha_ramp": alpha.to_dict(), "pressure_window": list(win),
                        "stop_reasons": [str(v) for v in inj.obs["stop_reason"][p]]}  # fmt: skip
        detail["wires"][label] = _detail(inj, ramp, p, m, win, kc, kr)
    claims = _claims(extra)
    return Record(rows=tuple(rows), alternatives=tuple(alts), claims=claims,
                  extra={"cavity": extra}, detail=detail)  # fmt: skip


def _force_exponent(inj: Series, p: int) -> Estimate:
    """β in F ~ L_in^β over the upper half of L_in, from the pusher's work
    W(L_in) = ∫F dL_in ~ L_in^(1+β): W is positive and smooth where the per-stage F
    oscillates and may be negative (a log fit of F would drop those stages)."""
    lengths = inj.lam
    steps = np.diff(np.concatenate([[0.0], lengths]))
    work = np.cumsum(np.nan_to_num(inj.obs["feed_force"][p]) * steps, axis=-1)
    work = np.where(np.isfinite(inj.obs["feed_force"][p]), work, np.nan)
    top = float(np.nanmax(lengths))
    w = _fit_window(lengths[None, :].repeat(inj.replicas, 0), work, (0.5 * top, top))
    return Estimate(w.value - 1.0, w.sigma, w.n, w.fit_range, w.spread)


def _alpha(ramp: Series, p: int) -> Estimate:
    ok = ramp.lam >= 100.0
    return _fit_replicas(ramp.lam[ok], ramp.obs["r_max"][p][:, ok])


#: ν is fitted only over a factor this large in n_loops (or a decade in L_in): a staircase of
#: one or two loops is not a power law.
LOOP_RANGE = 4.0


def _loop_growth(inj: Series, p: int) -> tuple[Estimate, str]:
    """ν in n_loops ~ L_in^ν over the stages with at least one loop, and a note; NaN with
    "too few loops" where no replica spans :data:`LOOP_RANGE` in n_loops nor a decade in
    L_in."""
    y = np.where(inj.obs["n_loops"][p] >= 1, inj.obs["n_loops"][p], np.nan)
    spans = []
    for yr in y:
        ok = np.isfinite(yr)
        if ok.sum() >= 3:
            spans.append((np.nanmax(yr) / np.nanmin(yr), inj.lam[ok].max() / inj.lam[ok].min()))
    if not any(n >= LOOP_RANGE or lr >= 10.0 for n, lr in spans):
        top = max((n for n, _ in spans), default=math.nan)
        return Estimate(math.nan, math.nan, 0), (
            f"too few loops: n_loops spans a factor {top:.3g} at most (needs {LOOP_RANGE:g} or a "
            f"decade in L_in)"
        )
    return _fit_replicas(inj.lam, y), "fitted"


def _detail(inj, ramp, p, m, win, kc, kr) -> dict:
    """What the figures draw: curves against φ, configurations and M(R) at matched φ."""
    curves = {}
    for name, s, length in (("cavity", inj, inj.lam), ("ramp", ramp, np.ones_like(ramp.lam))):
        vals = {k: [] for k in ("energy_per_length", "gamma", "contacts_per_length", "loops")}
        phis, press = [], []
        for r in range(s.replicas):
            e = s.energies
            eb, es = e["bending"][p, r], e["stretching"][p, r]
            vals["energy_per_length"].append((eb + es) / length)
            with np.errstate(invalid="ignore", divide="ignore"):
                vals["gamma"].append(np.where(eb > 0, es / eb, np.nan))
            vals["contacts_per_length"].append(s.obs["contacts"][p, r] / length)
            vals["loops"].append(s.obs["n_loops"][p, r])
            if name == "cavity":
                phis.append(s.obs["packing_fraction"][p, r])
                press.append(s.obs["wall_force"][p, r] / (2 * np.pi * _radius(inj)))
            else:
                phis.append(_phi_ramp(ramp, p, r))
                press.append(_trap_pressure(ramp, p, r))
        curves[name] = {"phi": np.array(phis), "pressure": np.array(press),
                        **{k: np.array(v) for k, v in vals.items()}}  # fmt: skip
    configs, mcurves = [], []
    for r, j, k in m["stages"]:
        xc, xr = inj.positions[p, r, j], ramp.positions[p, r, k]
        if not configs:  # the first replica matched
            configs = [xc, xr, float(inj.lam[j]), float(ramp.lam[k])]
        for tag, x in (("cavity", xc[np.hypot(xc[:, 0], xc[:, 1]) < _radius(inj)]),
                       ("ramp", xr)):  # fmt: skip
            c = x.mean(axis=0)
            rm = float(np.max(np.hypot(*(x - c).T)))
            rr = np.geomspace(0.05, 1.0, 50) * rm
            mcurves.append((tag, rr / rm, np.asarray(mass_within(x, rr, center=c))))
    return {"curves": curves, "configs": configs, "m_curves": mcurves, "radius": _radius(inj),
            "phi": float(np.mean(m["phi"])) if m["phi"] else math.nan, "window": win,
            "kappa": (kc.value, kr.value), "L_in": inj.lam,
            "feed_force": inj.obs["feed_force"][p]}  # fmt: skip


def _claims(extra: dict) -> tuple:
    out = []
    for label, ex in extra.items():
        same = [k for k in _COMPARED if _same(ex, k)]
        out.append({
            "claim": "stuffing the wire into a cavity shares the properties of confinement by "
                     f"a potential ({label})",
            "source": "the paper's introduction (open question)",
            "measured": f"same within 2σ: {', '.join(same) or 'none'}; differ, not measured "
                        "or no verdict (σ unknown): "
                        f"{', '.join(k for k in _COMPARED if k not in same) or 'none'}",
            "criterion": "per observable at matched φ, |cavity − ramp| ≤ 2σ",
            "verdict": "shared" if len(same) == len(_COMPARED) else
                       "partly shared" if same else "not shared",
        })  # fmt: skip
        dm = ex["cavity"]["D_M"]
        out.append(_published_dm(label, dm))
        nu = ex["loop_exponent"]
        out.append({
            "claim": "the number of loops grows as a power of the injected length (Stoop et "
                     "al., PRL 101, 094101)",
            "source": "Stoop, Wittel & Herrmann, PRL 101, 094101 (2008)",
            "measured": f"ν = {_fmt(nu)} in n_loops ~ L_in^ν, {label}",
            "criterion": "a power law over the stages with loops (we state our exponent; the "
                         "number is not compared with theirs, which we do not quote)",
            "verdict": "measured" if nu["value"] is not None else
                       f"not measured ({ex.get('loop_exponent_note', 'no loops')})",
        })  # fmt: skip
    return tuple(out)


def _same(ex, k) -> bool:
    c, r = ex["cavity"][k], ex["ramp"][k]
    if c["value"] is None or r["value"] is None:
        return False
    sigma = math.hypot(c["sigma"] or 0.0, r["sigma"] or 0.0)
    return sigma > 0 and abs(c["value"] - r["value"]) <= 2 * sigma


def _published_dm(label: str, dm: dict) -> dict:
    v, s = dm["value"], dm["sigma"] or 0.0
    ref, rs = DONATO_GOMES
    if v is None:
        verdict = "not measured (hollow packing: M = 0 at R = r_max/2)"
    else:
        verdict = (
            "within 2σ"
            if abs(v - ref) <= 2 * math.hypot(s, rs)
            else ("below" if v < ref else "above")
        )
    return {
        "claim": "tightly packed injected wires have D_M = 1.9 ± 0.1 (Donato & Gomes)",
        "source": "Donato & Gomes, 'Condensation of elastic energy in two-dimensional packing "
                  "of wire'",
        "measured": f"cavity D_M = {_fmt(dm)} about the centre of mass, {label}",
        "criterion": "|D_M − 1.9| ≤ 2 (σ² + 0.1²)^1/2; our φ is lower than tight packing",
        "verdict": verdict,
    }  # fmt: skip


def _fmt(e: dict) -> str:
    if e["value"] is None:
        return "—"
    return f"{e['value']:.3g} ± {(e['sigma'] or 0.0):.2g}"
