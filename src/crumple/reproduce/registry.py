"""The sections of the report, in the order the report shows them, and the hook to add one.

A section is a module (or any object) with these attributes::

    NAME      str: the key of its record (other sections name it in NEEDS)
    READS     tuple of Experiment: the sweeps it reads (experiments.py, or its own)
    NEEDS     tuple of str: the sections whose records it reads (measured before it)
    VALUES    tuple of crumple.paper.PaperValue: the table rows it fills (check_report
              demands one row each)
    FIGURES   dict: file stem -> caption, the figures its draw() returns
    measure(ctx: Context) -> Record            pure: stored results -> numbers
    draw(record: Record) -> dict[str, Figure]  from the record alone

and optionally ``discuss(record, records) -> dict[row key, str]`` (the discussion of its
rows), ``notes(record) -> list[str]`` (paragraphs under "Runs") and
``summarise(record, records) -> dict[row key, dict[reading, str]]`` (the one-minute summary's
reason why a row differs, per reading ``"per-length"`` / ``"per-node"``, :mod:`.summary`).

Adding a study is one module and one line: append it to :data:`SECTIONS`, or, from outside
the package (a plugin, a test), call :func:`register`. The order of :data:`SECTIONS` is the
order of the report's rows, claims, alternatives and figures.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from . import (
    alternatives,
    fig2_configurations,
    fig2_loops,
    fig3_mass_size,
    fig4_gamma,
    fig5_radius,
    fig6_plasticity,
    lambda_collapse,
    loop_shape,
    minimizer,
)
from .experiments import PAPER, Experiment

__all__ = ["SECTIONS", "experiments", "figures", "register", "sections", "unregister"]

#: The paper's sections, in report order.
SECTIONS: tuple[ModuleType, ...] = (
    fig3_mass_size,
    fig4_gamma,
    fig5_radius,
    lambda_collapse,
    fig6_plasticity,
    fig2_configurations,
    fig2_loops,
    loop_shape,
    minimizer,
    alternatives,
)
_ADDED: list[Any] = []
_REQUIRED = ("NAME", "READS", "NEEDS", "VALUES", "FIGURES", "measure", "draw")


def sections() -> tuple[Any, ...]:
    """The paper's sections, then those added with :func:`register`."""
    return (*SECTIONS, *_ADDED)


def register(section):
    """Add ``section`` (a module with the attributes above) to the report; returns it.

    Its ``NEEDS`` must name sections already registered, and its ``NAME``, figure stems and
    row keys must be new. Registering the same module twice is a no-op.
    """
    if section in sections():
        return section
    missing = [a for a in _REQUIRED if not hasattr(section, a)]
    if missing:
        raise ValueError(f"{section!r} is not a report section: it lacks {', '.join(missing)}")
    _check(sections(), section)
    _ADDED.append(section)
    return section


def unregister(section) -> None:
    """Remove a section added with :func:`register` (no-op if it was not)."""
    if section in _ADDED:
        _ADDED.remove(section)


def _check(before, section) -> None:
    names = {s.NAME for s in before}
    if section.NAME in names:
        raise ValueError(f"a section named {section.NAME!r} is already registered")
    unknown = [n for n in section.NEEDS if n not in names]
    if unknown:
        raise ValueError(f"section {section.NAME!r} needs {', '.join(unknown)}, not registered")
    reused = sorted(set(figures(before)) & set(section.FIGURES))
    if reused:
        raise ValueError(f"section {section.NAME!r} reuses the figure {reused[0]!r}")
    keys = {v.key for s in before for v in s.VALUES}
    clash = [v.key for v in section.VALUES if v.key in keys]
    if clash:
        raise ValueError(f"section {section.NAME!r} reuses the row {clash[0]!r}")


def experiments(secs=None) -> tuple[Experiment, ...]:
    """Every experiment the sections read, each once: the paper's first (in the order of
    :data:`.experiments.PAPER`), then the others in order of first use."""
    used: dict[str, Experiment] = {}
    for s in sections() if secs is None else secs:
        for e in s.READS:
            if used.setdefault(e.name, e) is not e:
                raise ValueError(f"two different experiments are named {e.name!r}")
    first = [e for e in PAPER if e.name in used]
    return (*first, *(e for e in used.values() if e not in first))


def figures(secs=None) -> dict[str, str]:
    """Every figure of the sections: file stem -> caption, in report order."""
    return {k: v for s in (sections() if secs is None else secs) for k, v in s.FIGURES.items()}
