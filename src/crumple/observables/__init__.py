"""Measurements on a wire: centre of mass, radii, contacts, the mass-size function and D_M.

Everything here is a pure function of node positions (and, for :func:`energy_ratio`, of
energies already computed); nothing runs a simulation, so the functions apply equally to a
digitised experimental wire.

Conventions
-----------
* ``positions`` has shape ``(n_nodes, 2)`` ``[length]``; segment ``i`` joins nodes ``i`` and
  ``i + 1``. Lengths are in units of the rest length ``L0`` of the wire (normally 1); nothing
  here depends on that choice.
* The wire is a *uniform* polygonal curve: its mass is spread evenly along its length
  (``weighting="length"``, the default everywhere). For a stretched discrete wire the paper's
  Eq. (3) instead gives every segment the same mass ``1/N``; ``weighting="segments"``
  reproduces that (the two agree for an unstretched wire).
* The centre defaults to the centre of mass of that uniform wire (the paper's choice for
  M(R), Sec. III.A); every function accepts an explicit ``center`` ``[length]``, shape (2,).

See ``docs/observables.md`` for the derivations.

The package has one module per concept: ``shape`` (centre, radii, contacts), ``mass`` (M(R) and
D_M), ``summary`` (γ and :func:`measure`); loops come from :mod:`crumple.loops`. Everything is
imported from here.
"""

from crumple.loops import LoopStats, loops

from ._common import DEFAULT_N_RADII, DEFAULT_N_TABLE, DEFAULT_TABLE_MIN
from .mass import ensemble_mass_size_exponent, mass_size_exponent, mass_within
from .shape import center_of_mass, count_contacts, r_max, radius_of_gyration
from .summary import energy_ratio, measure

__all__ = [
    "DEFAULT_N_RADII",
    "DEFAULT_N_TABLE",
    "DEFAULT_TABLE_MIN",
    "LoopStats",
    "center_of_mass",
    "count_contacts",
    "energy_ratio",
    "ensemble_mass_size_exponent",
    "loops",
    "mass_size_exponent",
    "mass_within",
    "measure",
    "r_max",
    "radius_of_gyration",
]
