"""Continuum study, section (d): energy partition, contacts and loops along the Λ sweep.

Runs: ``continuum_sweep`` (rest-angle disorder replicas) and ``continuum_perfect`` (the perfect
wire), as :mod:`.continuum_sweep`. Measures, at every Λ of the sweep, in continuum units
(L0 = 1, B = k_b/N):

* the energy partition E_b L/B, E_s L/B, E_conf L/B and E_hc L/B, the total against the
  **coil** of docs/continuum.md ("Strong confinement"): turns of one radius R = (B/2λ)^¼ cost
  E = L (2Bλ)^½, so E L/B = (2Λ)^½, split evenly between bending and the trap
  (E_b/E_conf = 1);
* contacts per segment (contacts/N, the fraction of the wire in contact: a contact is a pair
  of non-adjacent segments closer than 2d);
* the turns, Σ|θ|/2π (the total curvature over 2π), against the coil's L/(2πR) = 2^¼ L/(2πℓ),
  and the net winding Σθ/2π (turns counted with their sense: a coil wound one way has the two
  equal; two halves wound in opposite senses cancel);
* the number of loops (faces of the wire and its contacts at 2d, :mod:`crumple.loops`) against
  L/ℓ = Λ^¼, with a power law n ∝ (L/ℓ)^β fitted per replica where it has at least 2 loops
  (turns stacked at spacing d form a band, not one face per turn: loops need not follow the
  turns);
* the fraction of stages at equilibrium at each Λ.

The coil is an argument, not the paper's: the claims say so. Says: a table of these at every
decade of Λ (the table of variants) and two claims (the energy and the turns against the
coil).
"""

from __future__ import annotations

import math

import numpy as np

from ..fit import fit_power_law
from ..geometry import turning_angles
from .common import Context, Estimate, Record, _alt, _combine, nan_quiet
from .continuum import PERFECT, SWEEP
from .continuum_sweep import _confinements
from .series import Series

NAME = "continuum_partition"
READS = (SWEEP, PERFECT)
NEEDS: tuple[str, ...] = ()
VALUES: tuple = ()
FIGURES = {
    "continuum_partition": "Along the Λ sweep (disorder replicas: thin; their mean: thick; the "
    "perfect wire: dots): (left) the energy by term in units of B/L over (2Λ)^1/2, the coil's "
    "total (dashed at 1; the coil puts 1/2 in bending and 1/2 in the trap); (middle) contacts "
    "per segment; (right) loops against L/ℓ = Λ^1/4 with the coil's 2^1/4 L/(2πℓ) (dashed) "
    "and the fitted power law (solid, over its range); crosses: the turns Σ|θ|/2π (mean)",
}
TERMS = ("bending", "stretching", "confinement", "hard_core")
#: Turns per L/ℓ of the coil: n = L/(2πR) with R = 2^-1/4 ℓ.
COIL_LOOPS = 2**0.25 / (2 * math.pi)
#: Fewest loops for a stage to enter the loop fit (one loop is the first contact, not a law).
MIN_LOOPS = 2


def _scaled(s: Series, lam_c, kb: float, n: float) -> dict[str, np.ndarray]:
    """Energy by term in units of B/L over (2Λ)^½, (replica, Λ)."""
    coil = np.sqrt(2.0 * lam_c)
    out = {t: s.energies[t][0] * (n / kb) / coil for t in (*TERMS, "total")}
    return out


def _loop_fit(lam_c, loops) -> Estimate:
    """β in n_loops ∝ (L/ℓ)^β per replica, over its stages with at least MIN_LOOPS loops."""
    x = lam_c**0.25
    vals, errs, lo, hi = [], [], math.inf, -math.inf
    for y in np.atleast_2d(loops):
        ok = np.isfinite(y) & (y >= MIN_LOOPS)
        if ok.sum() < 3:
            continue
        f = fit_power_law(x[ok], y[ok])
        vals.append(f.exponent)
        errs.append(f.stderr)
        lo, hi = min(lo, float(x[ok].min())), max(hi, float(x[ok].max()))
    return _combine(vals, errs, (lo, hi) if vals else None)


def turns(x) -> float:
    """Σ|θ|/2π: the total curvature over 2π (a coil's number of turns, whatever their sense);
    NaN if x is not a whole stage."""
    x = np.asarray(x, float)
    if not np.isfinite(x).all():
        return math.nan
    return float(np.sum(np.abs(turning_angles(x)))) / (2 * math.pi)


def net_winding(x) -> float:
    """Σθ/2π: how many times the tangent winds from one end to the other, with its sense
    (positive counter-clockwise); NaN if x is not a whole stage."""
    x = np.asarray(x, float)
    if not np.isfinite(x).all():
        return math.nan
    return float(np.sum(turning_angles(x))) / (2 * math.pi)


def _per_stage(s: Series, f) -> np.ndarray:
    """(replica, Λ) values of ``f(positions)`` at every stage of a one-point series."""
    pos = s.positions[0]
    return np.array([[f(pos[r, j]) for j in range(pos.shape[1])] for r in range(pos.shape[0])])


def _mean(a) -> Estimate:
    """Replica mean of the finite values, σ = standard error (0 for one value)."""
    v = np.asarray(a, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return Estimate(math.nan, math.nan, 0)
    sd = float(v.std(ddof=1)) if v.size > 1 else 0.0
    return Estimate(float(v.mean()), sd / math.sqrt(v.size), int(v.size), None, sd)


def _decades(lam_c) -> list[int]:
    """Indices of the stages nearest each integer decade of Λ run (each once)."""
    lx = np.log10(lam_c)
    out = []
    for k in range(math.ceil(lx.min() - 0.01), math.floor(lx.max() + 0.01) + 1):
        j = int(np.argmin(np.abs(lx - k)))
        if abs(lx[j] - k) < 0.2 and j not in out:
            out.append(j)
    return out


def _table(lam_c, e, contacts, loops, wind, net, eq, nrep) -> list[dict]:
    rows = []
    for j in _decades(lam_c):
        at = f"Λ = {lam_c[j]:.3g}"
        ratio = e["bending"][:, j] / e["confinement"][:, j]
        rows += [
            _alt(at, "E L/B over (2Λ)^1/2 (coil: 1)", _mean(e["total"][:, j]), nrep),
            _alt(at, "E_b/E_conf (coil: 1)", _mean(ratio), nrep),
            _alt(at, "contacts per segment", _mean(contacts[:, j]), nrep),
            _alt(at, "loops", _mean(loops[:, j]), nrep),
            _alt(
                at,
                f"turns Σ|θ|/2π (coil: {COIL_LOOPS * lam_c[j] ** 0.25:.3g})",
                _mean(wind[:, j]),
                nrep,
            ),
            _alt(at, "net winding Σθ/2π", _mean(net[:, j]), nrep),
            _alt(at, "stages at equilibrium (fraction)", _mean(eq[:, j]), nrep),
        ]
    return rows


def _coil_claim(claim, measured, criterion, value, verdict) -> dict:
    """A claim of the coil argument (ours, not the paper's); "not measured" without a value."""
    return {
        "claim": f"{claim} (ours, docs/continuum.md, an argument)",
        "source": "docs/continuum.md, 'Strong confinement' (not the paper)",
        "measured": measured,
        "criterion": criterion,
        "verdict": verdict if np.isfinite(value) else "not measured",
    }


def _claims(e, wind, lam_c, frac) -> tuple[dict, ...]:
    m = _mean(e["total"][:, -1])
    w = _mean(wind[:, -1] / (COIL_LOOPS * lam_c[-1] ** 0.25))
    top = f"Λ = {lam_c[-1]:.3g}"
    coil_ok = np.isfinite(m.value) and abs(m.value - 1.0) <= 0.2
    wind_ok = np.isfinite(w.value) and abs(w.value - 1.0) <= 0.2
    return (
        _coil_claim(
            "the packed wire is a coil: E L/B = (2Λ)^1/2",
            f"E L/B/(2Λ)^1/2 = {m.value:.3g} ± {m.sigma:.2g} at {top}; fraction of stages at "
            f"equilibrium {frac:.3f}",
            "within 20 % of 1 (the coil's ends and its inner S add a few %)",
            m.value,
            "agrees (within 20 %)" if coil_ok else "differs",
        ),
        _coil_claim(
            "the wire winds as a coil: Σ|θ|/2π = 2^1/4 L/(2πℓ) turns",
            f"turns / (2^1/4 L/(2πℓ)) = {w.value:.3g} ± {w.sigma:.2g} at {top}",
            "within 20 % of 1 (the ends and the S-shaped middle are not on the coil)",
            w.value,
            "agrees (within 20 %)" if wind_ok else "differs",
        ),
    )


def measure(ctx: Context) -> Record:
    """The energy partition, contacts per segment and loops at every Λ, and the loops' β."""
    s, pf = ctx.series["continuum_sweep"], ctx.series["continuum_perfect"]
    lam_c, kb, n = _confinements(s)
    e, e_pf = _scaled(s, lam_c, kb, n), _scaled(pf, lam_c, kb, n)
    contacts = s.obs["contacts"][0] / n
    loops = s.obs["n_loops"][0]
    ran = np.isfinite(s.max_force[0])
    eq = np.where(ran, s.converged[0].astype(float), np.nan)
    frac = float(np.nansum(eq) / max(1, ran.sum()))
    wind, net = _per_stage(s, turns), _per_stage(s, net_winding)
    beta = _loop_fit(lam_c, loops)
    beta_pf = _loop_fit(lam_c, pf.obs["n_loops"][0])
    alts = _table(lam_c, e, contacts, loops, wind, net, eq, s.replicas)
    alts += [
        _alt("loops β in n ∝ (L/ℓ)^β", "disorder replicas", beta, s.replicas),
        _alt("loops β in n ∝ (L/ℓ)^β", "perfect wire", beta_pf, 1),
    ]
    extra = {
        "continuum_partition": {
            "confinements": lam_c,
            "energy_over_coil": {t: nan_quiet(np.nanmean, v, axis=0) for t, v in e.items()},
            "contacts_per_segment": nan_quiet(np.nanmean, contacts, axis=0),
            "loops": nan_quiet(np.nanmean, loops, axis=0),
            "turns": nan_quiet(np.nanmean, wind, axis=0),
            "net_winding": nan_quiet(np.nanmean, net, axis=0),
            "loops_beta": beta.to_dict(),
            "loops_beta_perfect": beta_pf.to_dict(),
            "coil_loops_per_L_over_ell": COIL_LOOPS,
            "fraction_at_equilibrium": frac,
        }
    }
    detail = {"Lambda": lam_c, "e": e, "e_pf": e_pf, "contacts": contacts,
              "contacts_pf": pf.obs["contacts"][0, 0] / n, "loops": loops,
              "loops_pf": pf.obs["n_loops"][0, 0], "beta": beta, "turns": wind}  # fmt: skip
    return Record(
        alternatives=tuple(alts), claims=_claims(e, wind, lam_c, frac), extra=extra,
        detail=detail,
    )  # fmt: skip


def _positive(y):
    return np.where(y > 0, y, np.nan)


def _replicas_loglog(ax, x, ys, perfect) -> None:
    """Replicas (grey), their mean (black) and the perfect wire (red) on log axes."""
    for y in ys:
        ax.loglog(x, _positive(y), "-", color="0.7", lw=1)
    ax.loglog(x, _positive(perfect), "r.", ms=4, label="perfect wire")
    ax.loglog(x, _positive(nan_quiet(np.nanmean, ys, axis=0)), "ko-", ms=3,
              label="disorder, mean")  # fmt: skip


def draw(rec: Record) -> dict:
    """Energy by term over the coil's, contacts per segment, loops against L/ℓ."""
    import matplotlib.pyplot as plt

    d = rec.detail
    x = d["Lambda"]
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(15, 4.3), constrained_layout=True)
    colours = {"total": "k", "bending": "C0", "confinement": "C1", "stretching": "C2",
               "hard_core": "C3"}  # fmt: skip
    for t, col in colours.items():
        v = d["e"][t]
        for y in v:
            a.semilogx(x, y, "-", color=col, lw=0.6, alpha=0.5)
        a.semilogx(x, nan_quiet(np.nanmean, v, axis=0), "-", color=col, lw=2, label=t)
        a.semilogx(x, d["e_pf"][t][0], ".", color=col, ms=4)
    a.axhline(1.0, ls="--", color="k", lw=0.8)
    a.axhline(0.5, ls=":", color="0.5", lw=0.8)
    a.set_xlabel("Λ")
    a.set_ylabel("E L/B / (2Λ)^1/2")
    a.legend(fontsize=7)
    _replicas_loglog(b, x, d["contacts"], d["contacts_pf"])
    b.set_xlabel("Λ")
    b.set_ylabel("contacts per segment")
    b.legend(fontsize=7)
    xl = x**0.25
    _replicas_loglog(c, xl, d["loops"], d["loops_pf"])
    c.loglog(xl, COIL_LOOPS * xl, "b--", label="coil turns 2^1/4 L/(2πℓ)")
    c.loglog(xl, _positive(nan_quiet(np.nanmean, d["turns"], axis=0)), "bx", ms=5,
             label="turns Σ|θ|/2π")  # fmt: skip
    beta = d["beta"]
    if beta.fit_range is not None and np.isfinite(beta.value):
        lo, hi = beta.fit_range
        xf = np.geomspace(lo, hi, 20)
        ml = nan_quiet(np.nanmean, d["loops"], axis=0)
        ok = np.isfinite(ml) & (xl >= lo) & (xl <= hi) & (ml > 0)
        if ok.any():
            k = float(np.exp(np.mean(np.log(ml[ok]) - beta.value * np.log(xl[ok]))))
            c.loglog(xf, k * xf**beta.value, "k-", label=f"β = {beta.value:.2f} ± "
                     f"{beta.sigma:.2f}")  # fmt: skip
    c.set_xlabel("L/ℓ = Λ^1/4")
    c.set_ylabel("loops, turns")
    c.legend(fontsize=7)
    return {"continuum_partition": fig}
