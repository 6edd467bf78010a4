"""Helpers shared by the figures: scale bars, guide lines, panel letters, log-log curves."""

from __future__ import annotations

import numpy as np


def _scale_bar(ax, span: float) -> None:
    """A bar of a round length (1, 2 or 5 × 10^k, about a fifth of ``span``) in the lower
    right corner, labelled in units of L0."""
    from matplotlib.offsetbox import AnchoredOffsetbox, AuxTransformBox, TextArea, VPacker
    from matplotlib.patches import Rectangle

    target = span / 5.0
    k = np.floor(np.log10(target))
    length = min((m * 10.0**k for m in (1.0, 2.0, 5.0, 10.0)), key=lambda v: abs(v - target))
    bar = AuxTransformBox(ax.transData)
    bar.add_artist(Rectangle((0, 0), length, 0, ec="0.2", lw=1.5))
    box = VPacker(children=[bar, TextArea(f"{length:g} L0", textprops={"fontsize": 7})],
                  align="center", pad=0, sep=2)  # fmt: skip
    ax.add_artist(AnchoredOffsetbox("lower right", child=box, frameon=False, pad=0.3))


_PAPER_STYLE = {"color": "tab:red", "ls": ":", "lw": 1.2}


def _guides(ax, curves, x_range, slopes) -> None:
    """Straight lines of the given log-log ``slopes`` over ``x_range``.

    ``slopes = [(label, exponent, style dict[, ln prefactor])]``: with a ln prefactor (a fit's
    intercept, from the section's record) the line is that fit, ``exp(ln_a) x^exponent``;
    without (the paper's exponent, which has no intercept) it goes through the geometric mean
    of the curves' points inside the range (where the eye compares slopes)."""
    xs, ys = [], []
    for x, y in curves.values():
        x, y = np.asarray(x, float), np.asarray(y, float)
        ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
        ok &= (x >= x_range[0]) & (x <= x_range[1])
        xs.append(x[ok])
        ys.append(y[ok])
    x, y = np.concatenate(xs), np.concatenate(ys)
    if x.size == 0:
        return
    x0, y0 = np.exp(np.mean(np.log(x))), np.exp(np.mean(np.log(y)))
    xg = np.geomspace(*x_range, 20)
    for label, exponent, style, *ln_a in slopes:
        if exponent is None or not np.isfinite(exponent):
            continue
        if ln_a and ln_a[0] is not None and np.isfinite(ln_a[0]):
            ax.plot(xg, np.exp(ln_a[0]) * xg**exponent, label=label, **style)
        else:
            ax.plot(xg, y0 * (xg / x0) ** exponent, label=label, **style)


def _panel_letter(ax, k: int) -> None:
    # above the axes' top left corner: never on the data
    ax.text(0.0, 1.02, f"({'abcdefgh'[k]})", transform=ax.transAxes, va="bottom", fontsize=9)


def _loglog_curves(ax, curves, *, marker="o", errors=None):
    """Each curve ``{label: (x, y)}`` on log axes (its finite positive points); a panel with
    no such point says so and keeps linear axes (a log axis of nothing is an error)."""
    shown = 0
    for label, (x, y) in curves.items():
        x, y = np.asarray(x, float), np.asarray(y, float)
        ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
        shown += int(ok.sum())
        line = ax.plot(x[ok], y[ok], marker=marker, ms=3, lw=1, label=str(label))[0]
        if errors and label in errors:
            e = np.asarray(errors[label], float)[ok]
            ax.fill_between(x[ok], y[ok] - e, y[ok] + e, color=line.get_color(), alpha=0.2, lw=0)
    if not shown:
        ax.text(0.5, 0.5, "no data (not run, or not measurable)", transform=ax.transAxes,
                ha="center", va="center", fontsize=8, color="0.4")  # fmt: skip
        return
    ax.set_xscale("log")
    ax.set_yscale("log")
