"""Figures render without a display and reject inconsistent input."""

import numpy as np
import pytest

from crumple.figures import plot_configurations


def test_configurations_png(tmp_path):
    t = np.linspace(0, 2 * np.pi, 40)
    confs = [r * np.c_[np.cos(t), np.sin(t)] for r in (0.3, 0.2, 0.1)]
    fig = plot_configurations(confs, [1, 10, 100], title="rings")
    assert len([ax for ax in fig.axes if ax.get_visible()]) == 3
    out = tmp_path / "c.png"
    fig.savefig(out)
    assert out.stat().st_size > 1000


def test_mismatch_is_an_error():
    with pytest.raises(ValueError, match="2 configurations but 1"):
        plot_configurations([np.zeros((3, 2))] * 2, [1.0])


def test_the_pooled_fit_line_is_the_fit_not_an_anchor_at_the_data():
    """'ours (pooled fit)' is drawn as exp(ln a) λ^α from the record, wherever the data lie."""
    from crumple.figures import plot_radius

    lam = np.geomspace(100, 2000, 12)
    curves = {"a": (lam, 3.0 * lam**-0.3)}  # data far above the fitted line below
    slopes = {"a": (lam, np.full(12, -0.3))}
    fig = plot_radius(curves, slopes, curves, fit_range=(100, 2000), paper_alpha=-0.25,
                      alpha=(-0.3, 0.01, np.log(0.5)))  # fmt: skip
    (line,) = [ln for ln in fig.axes[0].lines if "pooled fit" in str(ln.get_label())]
    x, y = line.get_data()
    np.testing.assert_allclose(y, 0.5 * np.asarray(x) ** -0.3, rtol=1e-12)
