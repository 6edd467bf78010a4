"""Studies: a report made of registered sections, with its own profiles, title and texts.

The paper's reproduction (``crumple reproduce``) is one study, :data:`PAPER`, whose sections are
:func:`.registry.sections`; ``crumple study NAME`` runs another (:data:`STUDIES`), through the
same machinery (:func:`.running.run`, :func:`.report.write_report`): resumable stores under
``DIR/data``, ``report.md``, ``report.html``, figures and ``results.json``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from .. import paper
from . import document, registry

__all__ = ["PAPER", "STUDIES", "Study", "get"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Study:
    """A report: its sections, its profiles and the texts of its header.

    ``profiles`` maps a name to a frozen profile with ``name``, ``description``, ``replicas``
    and ``to_dict()``; ``profile_fields`` are the keys ``profile.json`` must hold;
    ``sections()`` returns the sections in report order (modules with the interface of
    :mod:`.registry`).
    """

    name: str
    command: str
    title: str
    origin: str
    conventions: str
    alternatives: str
    sections: Callable[[], tuple[Any, ...]]
    profiles: Mapping[str, Any]
    profile_fields: tuple[str, ...]
    #: Main table: None, the paper's numbers (paper against ours, both readings of Eq. 1);
    #: (heading, label a, label b), a comparison of two measurements of this study.
    comparison: tuple[str, str, str] | None = None
    #: Whether a report can be drawn while one of its experiments has no finished run (its
    #: sections then say "not measured", as the paper's do); False: :func:`.analysis.analyse`
    #: stops with one line naming the experiment (the continuum study's fits need every one).
    partial: bool = True

    def text(self) -> dict:
        """The keyword texts of :func:`.document.blocks`."""
        return {
            "title": self.title,
            "origin": self.origin,
            "conventions": self.conventions,
            "alternatives": self.alternatives,
            "comparison": self.comparison,
        }


#: The paper's reproduction (``crumple reproduce``).
PAPER = Study(
    name="paper",
    command="crumple reproduce",
    title=document._TITLE,
    origin=document._ORIGIN,
    conventions=document._CONVENTIONS,
    alternatives=document._ALTERNATIVES,
    sections=registry.sections,
    profiles=paper.PROFILES,
    profile_fields=tuple(paper.Profile.__dataclass_fields__),
)


def _studies() -> dict[str, Study]:
    from .cavity import CAVITY
    from .continuum import CONTINUUM
    from .powell_study import POWELL_STUDY

    return {"continuum": CONTINUUM, "cavity": CAVITY, "powell": POWELL_STUDY}


def get(name: str) -> Study:
    """The study named ``name`` (``crumple study NAME``)."""
    studies = _studies()
    if name not in studies:
        raise ValueError(f"unknown study {name!r}; choose one of {', '.join(studies)}")
    return studies[name]


#: The names of the studies ``crumple study`` runs (the paper's is ``crumple reproduce``).
STUDIES = ("continuum", "cavity", "powell")
