"""Figures drawn from stored configurations: no physics is computed here.

Every function returns a :class:`matplotlib.figure.Figure` built without pyplot (no global
state, no display needed); save it with ``fig.savefig(path)``.

Modules, by concept: :mod:`~crumple.figures.configurations` (wires drawn as they are),
:mod:`~crumple.figures.curves` (the report's curves and fits), :mod:`~crumple.figures.loops`
(loops), :mod:`~crumple.figures.injection` (a wire in its cavity); every figure is importable
from here, as ``crumple.figures.<name>``.
"""

from __future__ import annotations

from .configurations import plot_configuration_rows, plot_configurations, ramp_animation
from .curves import (
    plot_alternatives,
    plot_gamma,
    plot_mass_size,
    plot_minimizer,
    plot_plasticity,
    plot_radius,
)
from .injection import plot_injection
from .loops import plot_loop_count, plot_loop_shape
from .powell import plot_powell_study

__all__ = [
    "plot_alternatives",
    "plot_configuration_rows",
    "plot_configurations",
    "plot_gamma",
    "plot_injection",
    "plot_loop_count",
    "plot_loop_shape",
    "plot_mass_size",
    "plot_minimizer",
    "plot_plasticity",
    "plot_powell_study",
    "plot_radius",
    "ramp_animation",
]
