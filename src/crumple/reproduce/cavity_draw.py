"""Cavity study: the figures and the discussion of :mod:`.cavity_compare`, from its record
alone (no physics computed here)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["discuss", "draw"]

_COLORS = {"elastic": "tab:blue", "plastic s = 0.2": "tab:red"}


def _mean(a):
    a = np.asarray(a, float)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(a).any(axis=0)
        out = np.full(a.shape[1:], np.nan)
        out[ok] = np.nanmean(a[:, ok], axis=0)
    return out


def _configurations(rec):
    from matplotlib.figure import Figure

    wires = rec.detail["wires"]
    fig = Figure(figsize=(3.4 * max(1, len(wires)), 6.6))
    axes = fig.subplots(2, max(1, len(wires)), squeeze=False)
    t = np.linspace(0, 2 * np.pi, 400)
    for c, (label, d) in enumerate(wires.items()):
        if not d["configs"]:
            axes[0, c].set_axis_off()
            axes[1, c].set_axis_off()
            continue
        xc, xr, lin, lam = d["configs"]
        rc = d["radius"]
        a = axes[0, c]
        a.plot(rc * np.cos(t), rc * np.sin(t), "k-", lw=1)
        a.plot(xc[:, 0], xc[:, 1], "-", color=_COLORS.get(label, "k"), lw=0.8)
        a.set_xlim(-1.3 * rc, 1.3 * rc)
        a.set_ylim(-1.3 * rc, 1.3 * rc)
        a.set_title(f"cavity, {label}\nL_in = {lin:.3g}, φ = {d['phi']:.3g}", fontsize=8)
        b = axes[1, c]
        ctr = xr.mean(axis=0)
        b.plot(xr[:, 0] - ctr[0], xr[:, 1] - ctr[1], "-", color=_COLORS.get(label, "k"), lw=0.8)
        span = 1.3 * float(np.max(np.abs(xr - ctr)))
        b.set_xlim(-span, span)
        b.set_ylim(-span, span)
        b.set_title(f"potential, {label}\nλ = {lam:.3g}", fontsize=8)
        for ax in (a, b):
            ax.set_aspect("equal")
            ax.tick_params(labelsize=6)
    fig.tight_layout()
    return fig


def _observables(rec):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 7.5))
    axes = fig.subplots(2, 2).ravel()
    names = (("energy_per_length", "(E_b + E_s)/L"), ("gamma", "γ = E_s/E_b"),
             ("contacts_per_length", "contacts / L"), ("loops", "loops"))  # fmt: skip
    for label, d in rec.detail["wires"].items():
        col = _COLORS.get(label, "k")
        for ax, (k, ylab) in zip(axes, names, strict=True):
            for proto, ls in (("cavity", "-"), ("ramp", "--")):
                cv = d["curves"][proto]
                x, y = _mean(cv["phi"]), _mean(cv[k])
                ok = np.isfinite(x) & np.isfinite(y)
                if ok.any():
                    ax.plot(x[ok], y[ok], ls, color=col, lw=1, label=f"{proto}, {label}")
            if math.isfinite(d["phi"]):
                ax.axvline(d["phi"], color=col, lw=0.5, ls=":")
            ax.set_xscale("log")
            ax.set_xlabel("φ")
            ax.set_ylabel(ylab)
    axes[0].set_yscale("log")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def _force(rec):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4.4))
    a, b = fig.subplots(1, 2)
    for label, d in rec.detail["wires"].items():
        col = _COLORS.get(label, "k")
        for proto, ls in (("cavity", "-"), ("ramp", "--")):
            cv = d["curves"][proto]
            for x, y in zip(cv["phi"], cv["pressure"], strict=True):
                ok = np.isfinite(x) & np.isfinite(y) & (y > 0)
                a.loglog(x[ok], y[ok], ls, color=col, lw=0.7, alpha=0.7)
        kc, kr = d["kappa"]
        a.plot([], [], "-", color=col, label=f"{label}: κ cavity {kc:.2f}, potential {kr:.2f}")
        a.axvspan(*d["window"], color="0.93")
        for y in np.atleast_2d(d["feed_force"]):
            ok = np.isfinite(y)
            b.plot(d["L_in"][ok], y[ok], "-", color=col, lw=0.7)
        b.plot([], [], "-", color=col, label=label)
    a.set_xlabel("φ")
    a.set_ylabel("P = confining force / 2πR [energy/length²]")
    a.legend(fontsize=7)
    b.set_xlabel("L_in [L0]")
    b.set_ylabel("injection force F (work per length) [energy/length]")
    b.legend(fontsize=7)
    fig.tight_layout()
    return fig


def _mass(rec):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.5, 4.5))
    ax = fig.subplots()
    for label, d in rec.detail["wires"].items():
        col = _COLORS.get(label, "k")
        for tag, rr, mm in d["m_curves"]:
            ok = mm > 0
            ax.loglog(rr[ok], mm[ok], "-" if tag == "cavity" else "--", color=col, lw=0.8)
        ax.plot([], [], "-", color=col, label=f"{label} (solid: cavity, dashed: potential)")
    ax.axvspan(0.5, 1.0, color="0.93")
    ax.set_xlabel("R / r_max")
    ax.set_ylabel("M(R) [length]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def draw(rec) -> dict:
    """The section's four figures (:data:`.cavity_compare.FIGURES`)."""
    return {
        "cavity_configurations": _configurations(rec),
        "cavity_observables": _observables(rec),
        "cavity_force": _force(rec),
        "cavity_mass": _mass(rec),
    }


def discuss(rec, records) -> dict[str, str]:
    """What the numbers say, row by row, generated from the record's own numbers (verdicts,
    ratios, signs): no sentence that a number can contradict."""
    out = {}
    rows = {row["key"]: row for row in rec.rows}
    for label, ex in rec.extra["cavity"].items():
        w = label.split()[0]
        c, r = ex["cavity"], ex["ramp"]
        keys = [k for k in rows if k.startswith("cavity_") and k.endswith(f"_{w}")]
        for key in keys:
            k = key[len("cavity_") : -len(f"_{w}")]
            out[key] = _row_sentence(k, c[k], r[k], rows[key]["verdict"], ex)
        counts: dict[str, int] = {}
        for key in keys:
            counts[rows[key]["verdict"]] = counts.get(rows[key]["verdict"], 0) + 1
        summary = "; ".join(f"{n} {v}" for v, n in sorted(counts.items()))
        beta = ex["feed_force_exponent"]
        b, sb = beta["value"], beta["sigma"] or 0.0
        trend = ("is not measured" if b is None else
                 "is flat within 2σ, going" if abs(b) <= 2 * sb else
                 "grows" if b > 0 else "falls")  # fmt: skip
        out[f"cavity_pressure_exponent_{w}"] += (
            f" Of the {len(keys)} comparisons ({label}): {summary}. The injection force (work "
            f"per length) {trend} as L_in^{_v(beta)} over the upper half of the injection "
            "(L_in over a factor 2 only)."
        )  # fmt: skip
    return out


def _row_sentence(k: str, c: dict, r: dict, verdict: str, ex: dict) -> str:
    """One row's sentence: the two values, their ratio and the verdict."""
    cv, rv = c["value"], r["value"]
    if cv is None or rv is None:
        return f"{k}: cavity {_v(c)}, potential {_v(r)}: {verdict}."
    ratio = f"; cavity/potential = {cv / rv:.3g}" if rv != 0 else ""
    where = (f"over φ ∈ [{ex['pressure_window'][0]:.3g}, {ex['pressure_window'][1]:.3g}]"
             if k == "pressure_exponent" else
             f"at φ = {ex['phi_matched']:.3g} (cavity) / {ex['phi_ramp_matched']:.3g} "
             "(potential)")  # fmt: skip
    return (
        f"{k} {where}: cavity {_v(c)}, potential {_v(r)} (the cavity's is "
        f"{'lower' if cv < rv else 'higher' if cv > rv else 'equal'}{ratio}): {verdict}."
    )


def _v(e: dict) -> str:
    return "—" if e["value"] is None else f"{e['value']:.3g} ± {(e['sigma'] or 0.0):.2g}"
