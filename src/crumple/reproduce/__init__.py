"""Reproduce the paper: run its experiments (:mod:`crumple.paper`) as sweeps, measure, report.

``crumple reproduce --out DIR`` = :func:`run` then :func:`write_report`; ``crumple figures
DIR`` = :func:`write_report` alone (no simulation). Layout of ``DIR``::

    DIR/profile.json            the profile the stores were made with
    DIR/data/<experiment>/      one sweep store per experiment (crumple.sweep; resumable)
    DIR/figures/*.png, *.svg    every figure
    DIR/results.json            every number of the report, machine-readable
    DIR/report.md, report.html  the report (the HTML embeds its figures)

One module per section of the report (a figure of the paper, or a study), each declaring what
it runs, how it measures, how it draws and what it says; :mod:`.registry` lists them and
explains the interface. The conventions of every number are in :mod:`.common`::

    experiments   what runs: the sweeps (Experiment), from crumple.paper
    series        a store -> stage-level observables (Series) and the shared measures
    common        Estimate and its arithmetic, Record, Context, table entries
    fig2_configurations, fig3_mass_size, fig4_gamma, fig5_radius, fig6_plasticity,
    loop_shape, minimizer, alternatives
                  the sections
    registry      the sections in report order; register() adds one
    running       run(): every experiment on one Dask cluster
    analysis      analyse(): every section's record
    summary       the one-minute summary at the top (from the rows, both readings)
    document      the report's structure (blocks)
    render        blocks -> Markdown, HTML (knows no figure)
    report        write_report(), check_report()
    study         Study: a report of its own sections and profiles (PAPER: this one;
                  ``crumple study continuum``: continuum, continuum_collapse,
                  continuum_convergence, continuum_sweep, docs/continuum.md)
"""

from __future__ import annotations

from . import registry
from .analysis import Analysis, analyse
from .common import Estimate, Record
from .common import _combine as _combine  # the helpers below are checked by the tests
from .common import _pool as _pool
from .common import _row as _row
from .common import _trend as _trend
from .common import _trend_verdict as _trend_verdict
from .fig2_configurations import _kink_ratio as _kink_ratio
from .loop_shape import loop_comparison
from .report import check_report, make_figures, write_report
from .running import run

#: Every figure of the paper's report (file stem -> caption), in report order.
FIGURES = registry.figures(registry.SECTIONS)

__all__ = [
    "FIGURES",
    "Analysis",
    "Estimate",
    "Record",
    "analyse",
    "check_report",
    "loop_comparison",
    "make_figures",
    "registry",
    "run",
    "write_report",
]
