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
    b.set_ylabel("feed force F [energy/length]")
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
    """What the numbers say, row by row, from the record's own numbers."""
    out = {}
    for label, ex in rec.extra["cavity"].items():
        w = label.split()[0]
        c, r = ex["cavity"], ex["ramp"]
        dm_c, dm_r = c["D_M"]["value"], r["D_M"]["value"]
        out[f"cavity_D_M_{w}"] = (
            "The cavity's packing is hollow about its centre of mass (M = 0 at R = r_max/2), "
            "so D_M is undefined on the reproduction's range there."
            if dm_c is None else
            f"D_M {dm_c:.3g} in the cavity against {dm_r if dm_r is None else round(dm_r, 3)} "
            f"under the potential at φ ≈ {ex['phi_matched']:.3g}: the wall holds the wire on a "
            "circle (wall contacts), so mass sits at large R, which raises the slope of M(R) "
            "over [0.5, 1] r_max."
        )  # fmt: skip
        out[f"cavity_pressure_exponent_{w}"] = (
            f"Pressure against packing over φ ∈ [{ex['pressure_window'][0]:.3g}, "
            f"{ex['pressure_window'][1]:.3g}]: κ = {_v(c['pressure_exponent'])} in the cavity, "
            f"{_v(r['pressure_exponent'])} under the potential; the feed force grows as "
            f"L_in^{_v(ex['feed_force_exponent'])} over the upper half of the injection."
        )
    return out


def _v(e: dict) -> str:
    return "—" if e["value"] is None else f"{e['value']:.3g} ± {(e['sigma'] or 0.0):.2g}"
