"""Per-stage measurements of an injection: what is stored beside each equilibrium.

Every function here is a pure function of positions (and the wire and stage records); none
runs a simulation. The *injected part* of a configuration is its nodes strictly inside the
cavity: a prefix of the wire, numbered from the tip (:func:`inside`). Geometric observables
(contacts, M(R), loops, sizes) are measured on it; the straight feed in the channel outside
is not part of the packing.

Lengths in units of L0; forces ``[energy/length]``.
"""

from __future__ import annotations

import math

import numpy as np

from .feed import wall_blocks
from .geometry import close_segment_pairs
from .injection import InjectionResult, packing_fraction
from .model import Wire
from .observables import mass_size_exponent, r_max
from .stage_observables import CONTACT_FACTOR, loops_or_none

__all__ = ["INJECTION_OBSERVABLES", "inside", "measure_injection", "measure_stage"]

#: name -> (units, one-line meaning): every per-stage value :func:`measure_injection` returns.
INJECTION_OBSERVABLES = {
    "injected_length": ("length", "L_in, the length pushed into the cavity"),
    "packing_fraction": ("1", "φ = h L_in / (π R_c²), h the hard-core width"),
    "feed_force": ("energy/length", "injection force: the pusher's work per injected length over "
                   "the stage (∫F dL_in is the energy stored, plus what snap-throughs dissipate)"),
    "clamp_reaction": ("energy/length", "reaction of the rigid clamp along the channel at the "
                       "equilibrium, Σ_fixed ∂E/∂x · u (not the injection force: releases)"),
    "release_drop": ("energy", "energy the wire gave up relaxing after the stage's releases"),
    "wall_force": ("energy/length", "total force of the wall on the wire, Σ_free |∂E_wall/∂x_i| "
                   "(the confining pressure times 2π R_c)"),
    "contacts": ("1", "pairs of non-adjacent segments of the injected part closer than 2 d"),
    "wall_contacts": ("1", "nodes of the injected part closer than 2 d to the wall"),
    "n_loops": ("1", "loops of the injected part at contact distance 2 d (closed by wire-wire "
                "contacts; NaN where undefined)"),
    "D_M_center": ("1", "mass-size exponent about the cavity's centre, R in [0.5, 1] of the "
                   "largest |x|"),
    "D_M_com": ("1", "mass-size exponent about the centre of mass, R/r_max in [0.5, 1] (the "
                "reproduction's reading)"),
    "r_max": ("length", "largest distance of a node of the injected part from its centre of "
              "mass"),
}  # fmt: skip


def inside(positions, wire: Wire) -> np.ndarray:
    """The injected part: the leading nodes strictly inside the cavity, shape (m, 2).

    >>> w = Wire(k_b=1, k_s=1e4, n_segments=4, cavity_radius=1.0)
    >>> inside([[0, 0], [0.5, 0], [0.99, 0], [1.5, 0], [2, 0]], w).shape
    (3, 2)
    """
    x = np.asarray(positions, dtype=float)
    r2 = np.einsum("ij,ij->i", x, x)
    out = r2 < wire.cavity_radius**2
    m = int(np.argmin(out)) if not out.all() else x.shape[0]
    return x[:m]


def _dm(x, center, fit_range=(0.5, 1.0)) -> float:
    try:
        return float(mass_size_exponent(x, center=center, fit_range=fit_range).exponent)
    except ValueError:  # no wire within the fit range (a straight start): undefined
        return math.nan


def measure_stage(positions, wire: Wire) -> dict[str, float]:
    """The geometric observables of one stage (not L_in, φ, F: those come from the run)."""
    x = inside(positions, wire)
    d = CONTACT_FACTOR * wire.hard_core
    out = dict.fromkeys(("contacts", "wall_contacts", "n_loops", "D_M_center", "D_M_com",
                         "r_max"), math.nan)  # fmt: skip
    if x.shape[0] < 2:
        return out
    out["contacts"] = float(close_segment_pairs(x, d)[0].shape[0])
    out["wall_contacts"] = float(
        np.count_nonzero(wire.cavity_radius - np.hypot(x[:, 0], x[:, 1]) < d)
    )
    st = loops_or_none(x, d)
    out["n_loops"] = math.nan if st is None else float(st.count)
    out["D_M_center"] = _dm(x, (0.0, 0.0)) if x.shape[0] > 3 else math.nan
    out["D_M_com"] = _dm(x, None) if x.shape[0] > 3 else math.nan
    out["r_max"] = float(r_max(x))
    return out


def measure_injection(result: InjectionResult) -> dict[str, np.ndarray]:
    """Every entry of :data:`INJECTION_OBSERVABLES` at every stage, arrays of shape (S,)."""
    n = len(result.stages)
    out = {k: np.full(n, np.nan) for k in INJECTION_OBSERVABLES}
    out["injected_length"] = result.injected_lengths
    out["packing_fraction"] = packing_fraction(result.wire, result.injected_lengths)
    out["feed_force"] = result.feed_forces
    out["clamp_reaction"] = result.clamp_reactions
    out["release_drop"] = np.array([s.release_drop for s in result.stages])
    w = result.wire
    for s, st in enumerate(result.stages):
        for k, v in measure_stage(st.positions, w).items():
            out[k][s] = v
        g = wall_blocks(st.positions[st.free], w.cavity_radius, w.hard_core,
                        w.hard_core_energy)[1]  # fmt: skip
        out["wall_force"][s] = float(np.hypot(g[:, 0], g[:, 1]).sum())
    return out
