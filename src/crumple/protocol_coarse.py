"""The ramp predicted by a coarser wire (``Ramp(coarsen=m)``, opt-in).

The continuum wire (fixed B, S; :meth:`crumple.model.Wire.from_continuum`) follows the same
physical path at every N once N resolves its loops: the default schedule's ramps at N = 10⁴ and
10⁵ have the same radius of gyration to three or four digits at every stage compared (19–31),
and their stages move the nodes by the same distances, ten times as many segments at 10⁵.
Newton's steps do not lengthen in proportion: the same stages (19–31) took 1.2–8.3 times the
iterations at 10⁵ (docs/performance.md, "The ramp predicted by a coarser wire"). A wire of N/m
segments travels the path in m times fewer segments, and so in fewer iterations, each cheaper.

So the ramp is first run on the same continuum wire with N/m segments (:func:`coarse_wire`),
and each stage of the wire itself starts from its previous stage's equilibrium moved as the
coarse wire moved over that stage (:func:`prolong`: the coarse polyline's nodes with m - 1
points inserted evenly on each segment, the same curve): x_k⁰ = x_{k-1} + P(c_k) - P(c_{k-1}).
Where that start crosses the wire with itself, it is the coarse equilibrium itself, P(c_k),
which is the coarse wire's uncrossed curve. From there the stage is minimised as in the plain
ramp, to a converged and stable equilibrium of the wire of N segments, or reported
unconverged. The coarse ramp predicts where each stage starts; it decides nothing that is
reported. The coarse wire is the same continuum wire (B, S, L0, the hard core d, the trap),
its barrier's ε scaled by m so that a contact costs the same energy per unit length on both
(the barrier is a sum over node–segment pairs; :data:`CONTACT_PER_LENGTH`).

What it changes, and why it is a parameter (default off): a stage starts from a point that is
not the previous equilibrium, so where a stage snaps through to another branch, the branch is
the one the coarse wire took, with the wire's own details. The plain ramp's branch at a
snap-through turns on round-off (docs/performance.md), so neither is privileged. Supported for
the perfect elastic wire with per-length confinement and no cavity (the wire whose continuum
limit is defined at fixed B and S), and Newton without stage noise; anything else is refused.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from .geometry import has_crossings
from .model import Wire

__all__ = [
    "CoarsePath",
    "CoarseSummary",
    "check_coarsen",
    "coarse_levels",
    "coarse_path",
    "coarse_wire",
    "prolong",
]


#: The coarse wire's barrier ε scaled by the coarsening factor, so that its contacts cost the
#: same energy per unit length as the wire's (False: ε per pair, the twenty-eighth stop's
#: predictor, whose coarse contacts were ``coarsen`` times softer per length). Measured over
#: seeds 0–3 at N = 10⁴ (coarsen = 10): 24–43 % fewer Newton iterations of the wire
#: (docs/performance.md, "The coarse wire's contacts per length").
CONTACT_PER_LENGTH = True


#: Opt-in: the coarse ramp itself predicted by a wire ``coarsen`` times coarser (and so on)
#: while that wire keeps at least this many segments (say 1000: at N = 10⁵ with coarsen = 10
#: the N = 10⁴ ramp is then predicted by N = 10³, whose 10³ segments put 70 on the loop length
#: (B/λ)^¼ at λ = 2000). None (default): one level. Measured at N = 10⁵ over seeds 0–3
#: (docs/performance.md, "The coarse wire's contacts per length"): the coarse ramp's cost fell
#: from 278–448 s to 190–229 s, but the wire's ramps took 1140–1706 s against 976–1007 s for
#: one level (seeds 0 and 1), and two of the four stopped one stage each unconverged.
COARSEST = None


def coarsen_factor(coarsen) -> int:
    """``coarsen`` as an int >= 1 (a whole float accepted: a sweep's numbers are floats)."""
    if isinstance(coarsen, (bool, np.bool_)):
        raise ValueError(f"coarsen must be an integer >= 1, got {coarsen!r}")
    if isinstance(coarsen, (float, np.floating)) and float(coarsen).is_integer():
        coarsen = int(coarsen)
    if not isinstance(coarsen, (int, np.integer)) or coarsen < 1:
        raise ValueError(f"coarsen must be an integer >= 1, got {coarsen!r}")
    return int(coarsen)


def check_coarsen(wire: Wire, coarsen: int) -> None:
    """Refuse a wire whose ramp a coarser wire cannot predict with ``coarsen`` (ValueError)."""
    coarsen = coarsen_factor(coarsen)
    if coarsen == 1:
        return
    reasons = []
    if wire.n_segments % coarsen:
        reasons.append(f"n_segments = {wire.n_segments} is not a multiple of coarsen = {coarsen}")
    elif wire.n_segments // coarsen < 3:
        reasons.append(f"the coarse wire would have {wire.n_segments // coarsen} segments (< 3)")
    if wire.confinement != "per-length":
        reasons.append("the confinement is per node (the coarse wire has no continuum match)")
    if wire.plasticity is not None:
        reasons.append("the wire is plastic (its rest angles carry the path's history)")
    if wire.rest_angle_sd:
        reasons.append("the wire has random rest angles (quenched at the wire's own joints)")
    if wire.cavity_radius is not None:
        reasons.append("the wire is in a cavity")
    if reasons:
        raise ValueError("coarsen > 1 cannot predict this ramp: " + "; ".join(reasons))


def coarse_wire(wire: Wire, coarsen: int) -> Wire:
    """The same continuum wire (B, S, L0, hard core d, trap) with ``n_segments / coarsen``
    segments. The barrier is a sum over node–segment pairs, and the coarse wire has
    ``coarsen`` times fewer of them per unit length of contact, so its ε is ``coarsen`` times
    the wire's: a contact then costs the same energy per unit length on both wires
    (:data:`CONTACT_PER_LENGTH`; docs/model.md, "The ramp predicted by a coarser wire").

    >>> w = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=1000)
    >>> c = coarse_wire(w, 10)
    >>> c.n_segments, round(c.bending_stiffness, 12), round(c.stretching_stiffness, 9)
    (100, 0.05, 5000.0)
    >>> round(c.hard_core_energy / w.hard_core_energy, 12)
    10.0
    """
    check_coarsen(wire, coarsen)
    coarsen = coarsen_factor(coarsen)
    return Wire.from_continuum(
        bending=wire.bending_stiffness,
        stretching=wire.stretching_stiffness,
        n_segments=wire.n_segments // coarsen,
        length=wire.length,
        hard_core=wire.hard_core,
        hard_core_energy=wire.hard_core_energy * (coarsen if CONTACT_PER_LENGTH else 1),
        trap_center=wire.trap_center,
    )


def prolong(positions, coarsen: int) -> np.ndarray:
    """The polyline ``positions`` with ``coarsen - 1`` points inserted evenly on each segment:
    the same curve, with ``coarsen`` times the segments.

    >>> prolong([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]], 2).tolist()
    [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [2.0, 2.0]]
    """
    coarsen = coarsen_factor(coarsen)
    x = np.asarray(positions, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"positions must be an (n, d) polyline, n >= 2; got shape {x.shape}")
    t = np.arange(coarsen) / coarsen
    inner = x[:-1, None, :] + t[None, :, None] * (x[1:] - x[:-1])[:, None, :]
    return np.ascontiguousarray(np.vstack([inner.reshape(-1, x.shape[1]), x[-1:]]))


@dataclass(frozen=True, slots=True)
class CoarseSummary:
    """What the coarse ramp of ``Ramp(coarsen=m)`` did (``RampResult.coarse``; not stored in
    a ramp's file): its wire's segments, its stages and how many converged, its Newton
    iterations and wall seconds, and how the wire's stages started: ``moved`` (the last
    equilibrium moved as the coarse wire moved) or ``from_coarse`` (the coarse curve, where the
    moved start would have crossed)."""

    n_segments: int
    stages: int
    converged: int
    iterations: int
    seconds: float
    moved: int = 0
    from_coarse: int = 0
    #: What the coarse ramp's own coarse ramp did, where one predicted it (:data:`COARSEST`).
    inner: CoarseSummary | None = None

    def __str__(self) -> str:
        text = (f"coarse ramp of {self.n_segments} segments: {self.converged}/{self.stages} "
                f"stages converged, {self.iterations} Newton iterations, {self.seconds:.1f} s; "
                f"stages started moved {self.moved}, from the coarse curve "
                f"{self.from_coarse}")  # fmt: skip
        return text if self.inner is None else f"{text}; itself predicted by the {self.inner}"


class CoarsePath:
    """The coarse ramp's equilibria, prolonged, as the predictor of each stage's start.

    ``coarse`` is the coarse ramp's positions: its initial state, then one per stage.
    ``starts`` counts how each stage started: "moved" (x_{k-1} + P(c_k) - P(c_{k-1})) or
    "coarse" (P(c_k), where the moved start crossed).
    """

    def __init__(
        self, coarse: list[np.ndarray], coarsen: int, summary: CoarseSummary | None = None
    ):
        self.coarsen = coarsen_factor(coarsen)
        self._coarse = [np.asarray(c, dtype=np.float64) for c in coarse]
        self.starts = {"moved": 0, "coarse": 0}
        self._summary = summary

    def summary(self) -> CoarseSummary | None:
        """The coarse ramp's :class:`CoarseSummary`, with the starts counted so far (None:
        built without one)."""
        if self._summary is None:
            return None
        return replace(self._summary, moved=self.starts["moved"],
                       from_coarse=self.starts["coarse"])  # fmt: skip

    @property
    def initial(self) -> np.ndarray:
        """The wire's initial state: the coarse ramp's, prolonged."""
        return prolong(self._coarse[0], self.coarsen)

    def candidates(self, stage: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The two starts of stage ``stage`` (0-based) from the last equilibrium ``x``: the
        moved start x + P(c_k) - P(c_{k-1}) and the coarse curve P(c_k) (k = ``stage`` + 1
        counts the coarse ramp's states, its initial state first)."""
        now = prolong(self._coarse[stage + 1], self.coarsen)
        return x + (now - prolong(self._coarse[stage], self.coarsen)), now

    def start(self, stage: int, x: np.ndarray) -> np.ndarray:
        """Where stage ``stage`` (0-based) starts, from the last equilibrium ``x``: the moved
        start, or the coarse curve where that crosses (:meth:`candidates`)."""
        moved, now = self.candidates(stage, x)
        if np.all(np.isfinite(moved)) and not has_crossings(moved):
            self.starts["moved"] += 1
            return moved
        self.starts["coarse"] += 1
        return now


def coarse_levels(n_segments: int, coarsen: int) -> list[int]:
    """The segments of each coarse wire that predicts a ramp of ``n_segments`` with
    ``coarsen``, the nearest first: a level is predicted by the next while that one keeps at
    least :data:`COARSEST` segments (and ``coarsen`` divides it).

    >>> coarse_levels(100_000, 10), coarse_levels(10_000, 1)  # COARSEST = None: one level
    ([10000], [])
    """
    coarsen = coarsen_factor(coarsen)
    if coarsen == 1:
        return []
    levels = [n_segments // coarsen]
    while (COARSEST is not None and levels[-1] % coarsen == 0
           and levels[-1] // coarsen >= COARSEST):  # fmt: skip
        levels.append(levels[-1] // coarsen)
    return levels


def coarse_path(wire: Wire, ramp, rng, run: Callable) -> CoarsePath:
    """Run ``ramp`` on the coarse wire (``run(wire, ramp, rng)``) and keep its equilibria as a
    :class:`CoarsePath`. The coarse ramp runs every stage (no ``stop_tol``): the wire's own
    stages decide where to stop. It is itself predicted by a wire ``coarsen`` times coarser
    where :func:`coarse_levels` says so, and is the plain ramp otherwise."""
    inner = ramp.coarsen if len(coarse_levels(wire.n_segments, ramp.coarsen)) > 1 else 1
    coarse = run(coarse_wire(wire, ramp.coarsen), replace(ramp, coarsen=inner, stop_tol=None),
                 rng)  # fmt: skip
    summary = CoarseSummary(
        n_segments=coarse.wire.n_segments,
        stages=len(coarse.stages),
        converged=sum(s.result.converged for s in coarse.stages),
        iterations=sum(s.result.iterations for s in coarse.stages),
        seconds=coarse.seconds,
        inner=coarse.coarse,
    )
    positions = [coarse.initial] + [s.positions for s in coarse.stages]
    return CoarsePath(positions, ramp.coarsen, summary)
