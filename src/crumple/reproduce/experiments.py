"""What runs: the experiments of the reproduction, each one sweep store under ``DIR/data``.

An :class:`Experiment` names a store, says how its points are labelled and builds its sweep
from a profile. The paper's six are declared here, from :mod:`crumple.paper` (the points and
the reasons for them live there); several sections of the report read the same experiment
(``ELASTIC`` feeds Figs. 2 to 5). A new study that needs a sweep of its own declares its
``Experiment`` in its own module and lists it in its ``READS``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

from .. import paper
from ..sweep import Sweep

__all__ = [
    "DISORDER",
    "ELASTIC",
    "ELASTIC_PER_NODE",
    "PAPER",
    "PLASTIC",
    "PLASTIC_PER_NODE",
    "POWELL",
    "Experiment",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class Experiment:
    """One sweep of the reproduction.

    Parameters
    ----------
    name : str
        The store's directory under ``DIR/data`` and the key of its results.
    levels : tuple of str
        The names of the point coordinates (``("k_b", "k_s")``); empty for one point.
    build : callable
        ``build(profile) -> Sweep`` for a :class:`crumple.paper.Profile`.
    note : callable, optional
        ``note(profile_dict) -> str``: a paragraph for the report's "Runs" section.
    """

    name: str
    levels: tuple[str, ...]
    build: Callable[[paper.Profile], Sweep]
    note: Callable[[dict], str] | None = None


@functools.lru_cache(maxsize=4)
def _paper_sweeps(profile: paper.Profile) -> dict[str, Sweep]:
    return paper.build_sweeps(profile)


def _paper(name: str) -> Callable[[paper.Profile], Sweep]:
    def build(profile: paper.Profile) -> Sweep:
        return _paper_sweeps(profile)[name]

    build.__doc__ = f"The {name!r} sweep of :func:`crumple.paper.build_sweeps`."
    return build


def _powell_note(profile: dict) -> str:
    return (
        "Non-converged stages are kept and counted here. Powell (Numerical Recipes' method, "
        f"compiled) runs a fixed budget of {profile['powell_sweeps']} sweeps per stage (the "
        "paper states none; NR's code stops at 200) and is not expected to reach equilibrium "
        "within it (docs/reproduction.md, 'The paper's minimiser')."
    )


#: Figs. 2-5 (:data:`crumple.paper.EXPERIMENTS` says which points and why).
ELASTIC = Experiment(name="elastic", levels=("k_b", "k_s"), build=_paper("elastic"))
#: Fig. 6: plasticity s and θ_p at the Fig. 2 point.
PLASTIC = Experiment(name="plastic", levels=("s", "theta_p"), build=_paper("plastic"))
#: Figs. 2-5 again with confinement λ r² per node (Eq. 1 as printed).
ELASTIC_PER_NODE = Experiment(
    name="elastic_per_node", levels=("k_b", "k_s"), build=_paper("elastic_per_node")
)
#: Fig. 6 again with confinement λ r² per node.
PLASTIC_PER_NODE = Experiment(
    name="plastic_per_node", levels=("s", "theta_p"), build=_paper("plastic_per_node")
)
#: Alternative: quenched rest-angle disorder.
DISORDER = Experiment(name="disorder", levels=(), build=_paper("disorder"))
#: Alternative: the paper's Powell minimiser, reduced.
POWELL = Experiment(name="powell", levels=(), build=_paper("powell"), note=_powell_note)

#: The paper's experiments in the order of :data:`crumple.paper.EXPERIMENTS` (the order of the
#: report's "Runs" list; experiments of added studies follow).
PAPER = (ELASTIC, PLASTIC, ELASTIC_PER_NODE, PLASTIC_PER_NODE, DISORDER, POWELL)
