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
