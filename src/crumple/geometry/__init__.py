"""Geometry of a polygonal chain in the plane: no physics here.

A wire is an array ``positions`` of shape ``(n_nodes, 2)`` ``[length]``; segment ``i`` joins
nodes ``i`` and ``i + 1``. Two segments are *adjacent* when they share a node (``|i - j| == 1``).

The neighbour searches use a uniform grid whose occupied cells are stored in a hash table
(a "spatial hash"), so building and querying cost O(n) expected time whatever the extent of
the wire: a crumpled wire of 10^5 segments of length 10^-5 occupies a few 10^5 cells of a
virtual 10^5 x 10^5 grid, and only those are stored.

The crossing test is *exact*: orientations are evaluated in floating point with Shewchuk's
static error bound, and the rare pairs whose sign the bound cannot certify are decided again
in exact rational arithmetic (the coordinates as integers over a common power of two), so
near-degenerate contacts are never misclassified by round-off.

The package has one module per concept: ``cells`` (the spatial hash), ``crossings`` (the exact
intersection test), ``distance`` (distances, close pairs, the hard core's node-segment
neighbour list, lengths and angles), ``ccd`` (continuous collision detection: the spatial
hash, and for long steps a tree along the chain that culls pairs by their relative motion)
and ``curved`` (a step that turns segments instead of translating their ends). Everything
public is imported from here.
"""

from ._input import as_positions
from .ccd import approach_fraction, disc_exit_fraction, max_safe_fraction
from .crossings import find_crossings, has_crossings
from .curved import curved_step
from .distance import (
    close_segment_pairs,
    node_segment_pairs,
    point_segment_distance,
    segment_distance,
    segment_lengths,
    turning_angles,
)

__all__ = [
    "approach_fraction",
    "as_positions",
    "close_segment_pairs",
    "curved_step",
    "disc_exit_fraction",
    "find_crossings",
    "has_crossings",
    "max_safe_fraction",
    "node_segment_pairs",
    "point_segment_distance",
    "segment_distance",
    "segment_lengths",
    "turning_angles",
]
