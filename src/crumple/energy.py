"""The energy terms of the paper's Eq. (1), each with its analytic gradient and Hessian.

Every term is a plain function of positions ``(n_nodes, 2)`` ``[length]`` returning
``(energy, gradient)`` with the gradient of the same shape ``[energy/length]``; the total is
their explicit sum (:func:`total_energy`). The Numba kernels (``crumple.energy_kernels``)
are compiled once (``cache=True``) and also fill the Hessian triplets used by the Newton
minimiser.

Terms (see ``docs/model.md`` for every modelling decision):

.. math::

    E_b = \\sum_{i=1}^{N-1} f(θ_i), \\quad f(θ) = \\tfrac{k_b}{2} θ^2
          \\text{ (or the softening law of Sec. III.C)}

    E_s = \\sum_{i=0}^{N-1} \\tfrac{k_s}{2} (|x_{i+1} - x_i| - L_0/N)^2

    E_{ext} = λ \\sum_{i=0}^{N} w_i |x_i - c|^2

    E_{hc} = ε \\sum_{(k, j)} b(D_{kj} / d), \\quad b(u) = (1 - u)^2 / u \\ (u < 1),
             \\ 0 \\ (u \\ge 1)

    E_{wall} = ε \\sum_{i=0}^{N} b(δ_i / d), \\quad δ_i = R_c - |x_i|
             \\ \\text{(only with a cavity of radius } R_c\\text{)}

where D_kj is the distance from node k to segment j over the pairs of
:func:`crumple.geometry.node_segment_pairs` (non-adjacent segments), d the hard-core width and
ε its energy scale. b is zero with zero slope at D = d (so the energy is C1), stiff there
(b''(1) = 2: a contact force F sits at a depth 1 - u ≈ F d / (2 ε), so the core is hard) and
diverges as D → 0. A barrier that is C2 at the cutoff, such as IPC's -(1 - u)² ln u, has a
vanishing stiffness there, and Newton's method then converges only linearly on every contact
(measured: ratio 1/2 per iteration); see ``docs/model.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .energy_action import _hessian_action
from .energy_assembly import _csc_pattern_kernel, _pair_blocks_where
from .energy_barrier_kernels import _barrier_rows, _release_rows
from .energy_functions import (
    _plastic_args,
    _rest_angles,
    bending_energy,
    cavity_energy,
    confinement_energy,
    confinement_weights,
    hard_core_energy,
    stretching_energy,
)
from .energy_kernels import (
    _hessian_triplets,
    _hessian_values,
    _in_core,
    _max_displacement,
    _same_pairs,
    _total_eg,
    _triplet_keys,
)
from .energy_line import _line_admissible, _line_energy, _line_prepare
from .geometry._input import _as_positions
from .geometry.distance import _node_segment_pairs
from .linalg import CSC
from .linalg_csc import unsigned_view
from .model import Wire

__all__ = [
    "EnergyTerms",
    "WireEnergy",
    "bending_energy",
    "cavity_energy",
    "confinement_energy",
    "confinement_weights",
    "energy_terms",
    "hard_core_energy",
    "hessian",
    "stretching_energy",
    "total_energy",
]

# Systems with at most this many degrees of freedom get a dense Hessian (LAPACK Cholesky is
# faster than sparse LU there); larger ones a sparse one.
DENSE_LIMIT = 800


@dataclass(frozen=True, slots=True)
class EnergyTerms:
    """Energy of a configuration by term ``[energy]``; ``wall`` is the cavity's (0 without)."""

    bending: float
    stretching: float
    confinement: float
    hard_core: float
    wall: float = 0.0

    @property
    def total(self) -> float:
        return self.bending + self.stretching + self.confinement + self.hard_core + self.wall

    @property
    def gamma(self) -> float:
        """γ = E_s / E_b, the paper's energy allocation (NaN when E_b = 0)."""
        return self.stretching / self.bending if self.bending > 0 else math.nan

    def to_dict(self) -> dict[str, float]:
        return {
            "bending": self.bending,
            "stretching": self.stretching,
            "confinement": self.confinement,
            "hard_core": self.hard_core,
            "wall": self.wall,
            "total": self.total,
        }


class WireEnergy:
    """The total energy of a wire at one trap strength, as a minimiser's callable.

    ``energy(x) -> (E, grad)`` for positions ``x`` of shape (n_nodes, 2); ``energy.hessian(x)``
    gives the Hessian over the flattened coordinates (dense up to ``DENSE_LIMIT`` degrees of
    freedom, else sparse CSC); ``energy.terms(x)`` the :class:`EnergyTerms`.

    Examples
    --------
    >>> w = Wire(k_b=5, k_s=5e5, n_segments=10)
    >>> x = np.c_[np.linspace(-0.5, 0.5, 11), np.zeros(11)]
    >>> e, g = WireEnergy(w, lam=1.0)(x)
    >>> bool(np.isclose(e, WireEnergy(w, lam=1.0).terms(x).confinement))
    True
    """

    def __init__(self, wire: Wire, lam: float, *, rest_angles=None, skin: float | None = None):
        if not isinstance(wire, Wire):
            raise TypeError(f"wire must be a Wire, got {type(wire).__name__}")
        lam = float(lam)
        if not (math.isfinite(lam) and lam >= 0):
            raise ValueError(f"lambda must be a non-negative finite number, got {lam}")
        self.wire = wire
        self.lam = lam
        self.weights = confinement_weights(wire.n_nodes, wire.confinement, wire.length)
        self._s, self._tp = _plastic_args(wire.plasticity)
        self.rest_angles = _rest_angles(rest_angles, wire.n_nodes)
        self._terms = np.zeros(5)
        self._radius = math.inf if wire.cavity_radius is None else wire.cavity_radius
        # Verlet list: candidate pairs within d + skin of a reference configuration stay valid
        # while no node has moved more than skin / 2 from it (a pair's distance changes by at
        # most the sum of its nodes' displacements). Candidates come out in (node, segment)
        # order as from a fresh search, so the energy is the same function of x to the bit.
        self.skin = 0.1 * wire.rest_length if skin is None else float(skin)
        self._ref = None
        self._ks = self._js = None
        self._pattern = None
        self.rebuilds = 0

    def _pairs(self, x):
        if self._ref is None or _max_displacement(x, self._ref) > 0.5 * self.skin:
            ks, js = _node_segment_pairs(x, self.wire.hard_core + self.skin)
            # the same pairs as before: keep the arrays themselves, so that the Hessian keeps
            # its pattern (and the factorisation its analysis) without looking them up again
            if self._ks is None or not _same_pairs(ks, js, self._ks, self._js):
                self._ks, self._js = ks, js
            self._ref = x.copy()
            self.rebuilds += 1
        return self._ks, self._js

    def _eg(self, x, disp=None):
        w = self.wire
        ks, js = self._pairs(x if disp is None else x + disp)
        return _total_eg(
            x, w.k_b, self._s, self._tp, self.rest_angles, w.k_s, w.rest_length, self.lam,
            self.weights,
            w.trap_center[0], w.trap_center[1], ks, js, w.hard_core, w.hard_core_energy,
            self._radius, self._terms, disp,
        )  # fmt: skip

    def displaced(self, reference):
        """The energy of ``reference + u`` as a function of the displacement u.

        ``fun(u) -> (E, grad)``, u of the shape of the positions. The elastic terms take each
        segment vector as (ref_{i+1} - ref_i) + (u_{i+1} - u_i), with a round-off of ε times
        the segment's length where that of the float64 sum ref + u is ε |x|: the bending
        forces of a wire of N segments then resolve ε B N² instead of ε B N³ |x| (N = 5 × 10⁴:
        10⁻⁷ against 10⁻³ per node). The hard core and the cavity's wall are evaluated at the
        float64 sum. :func:`crumple.relax.minimize_wire`'s polish minimises in u.

        >>> w = Wire(k_b=5, k_s=5e5, n_segments=10)
        >>> x = np.c_[np.linspace(-0.5, 0.5, 11), 0.01 * np.sin(np.arange(11.0))]
        >>> e0, g0 = WireEnergy(w, lam=1.0)(x)
        >>> e1, g1 = WireEnergy(w, lam=1.0).displaced(x)(np.zeros_like(x))
        >>> bool(e0 == e1 and np.array_equal(g0, g1))
        True
        """
        ref = np.array(reference, dtype=np.float64, order="C")  # a copy: it must not change
        if ref.shape != (self.wire.n_nodes, 2):
            raise ValueError(f"reference must have shape ({self.wire.n_nodes}, 2)")

        def fun(u):
            e, g = self._eg(ref, np.ascontiguousarray(u, dtype=np.float64))
            return float(e), g

        return fun

    def __call__(self, x):
        x = np.ascontiguousarray(x, dtype=np.float64)
        e, g = self._eg(x)
        return float(e), g

    def terms(self, x) -> EnergyTerms:
        x = _as_positions(x)
        if x.shape[0] != self.wire.n_nodes:
            raise ValueError(f"positions must have {self.wire.n_nodes} nodes, got {x.shape[0]}")
        self._eg(x)
        return EnergyTerms(*(float(v) for v in self._terms))

    def line_kernels(self, reach: float) -> tuple:
        """The compiled energy along a line, for :func:`crumple.minimize.powell` (``compiled=``).

        Returns ``(prepare, evaluate, admissible, params)``: Numba functions with the protocol
        of :mod:`crumple.powell` and their parameters. ``evaluate(x, d, t, ...)`` is
        this energy at ``x + t d`` (flat coordinates), equal to ``self(x)[0]``; ``prepare``
        bounds t so that no node moves further than ``reach`` ``[length]`` and no node touches
        a segment on the way (continuous collision detection); ``admissible`` is the exact
        crossing test (conservative where floating point cannot decide). No cavity.
        """
        w = self.wire
        if w.cavity_radius is not None:
            raise ValueError("the compiled line energy has no cavity wall; use the Python path")
        if not (math.isfinite(reach) and reach > 0):
            raise ValueError(f"reach must be a positive length, got {reach!r}")
        params = (
            float(w.k_b), float(self._s), float(self._tp), self.rest_angles, float(w.k_s),
            float(w.rest_length), self.lam, self.weights, float(w.trap_center[0]),
            float(w.trap_center[1]), float(w.hard_core), float(w.hard_core_energy), float(reach),
        )  # fmt: skip
        return _line_prepare, _line_energy, _line_admissible, params

    def hessian(self, x, *, dense: bool | None = None, project_contacts: bool | str = False,
                project_bending: bool = False):  # fmt: skip
        """Hessian over ``x.ravel()``: dense (2n, 2n) or sparse CSC holding both triangles.

        The sparse one is assembled into a fixed pattern (chain + every candidate pair of the
        neighbour list, inactive pairs as explicit zeros), rebuilt only with the list: no
        COO to CSC conversion per call, and its index arrays are equal from call to call, so a
        factorisation can reuse its symbolic analysis (:class:`crumple.linalg.LDLT`).

        ``project_contacts`` / ``project_bending`` replace every contact's / every joint's block
        by its positive part: the Newton minimiser's fallback where the exact Hessian is
        indefinite. The stretching blocks stay exact: their negative transverse stiffness
        under compression is what makes a straight wire buckle, and the fallback must keep it.
        ``project_contacts="caps"`` projects only the contacts at a joint's cap, the pairs
        whose closest point is a segment's end: there D is a point-point distance, whose
        transverse curvature 1/D (the polyline's corner, at the scale d) gives the block a
        negative eigenvalue of about -2F/D, F the pair's force; pairs on a segment's interior
        keep their exact block (docs/model.md). Any other value is a ``ValueError``.
        """
        x = np.ascontiguousarray(x, dtype=np.float64)
        ndof = x.size
        if dense is None:
            dense = ndof <= DENSE_LIMIT
        if dense:
            rows, cols, vals = self._triplets(x, _projection(project_contacts), project_bending)
            h = np.bincount(rows * ndof + cols, weights=vals, minlength=ndof * ndof)
            return h.reshape(ndof, ndof)
        return self.hessian_csc(x, project_contacts=project_contacts,
                                project_bending=project_bending).tocsc()  # fmt: skip

    def hessian_csc(self, x, *, project_contacts: bool | str = False,
                    project_bending: bool = False):  # fmt: skip
        """The sparse Hessian of :meth:`hessian` as a :class:`crumple.linalg.CSC`: the same
        arrays, without building a SciPy matrix (the Newton minimiser's hot path; ``x`` is
        trusted to be a float array of shape (n_nodes, 2))."""
        project_contacts = _projection(project_contacts)
        x = np.ascontiguousarray(x, dtype=np.float64)
        ks, js = self._pairs(x)
        if self._pattern is not None and self._pattern[0] is not ks:
            self._pattern = self._kept_pattern(ks, js)
        if self._pattern is None:  # the pattern of these pairs: their triplets' keys sorted
            rows, cols = _triplet_keys(x.shape[0], ks, js, math.isfinite(self._radius))
            self._pattern = (ks, js, *_csc_pattern(rows, cols, x.size))
        _, _, indptr, indices, where, unsigned = self._pattern
        w = self.wire
        data = _hessian_values(  # the triplets scattered, bit for bit; where unsigned
            where, indices.shape[0], x, w.k_b, self._s, self._tp, self.rest_angles,
            w.k_s, w.rest_length, self.lam, self.weights, ks, js, w.hard_core,
            w.hard_core_energy, project_contacts, project_bending, self._radius,
        )  # fmt: skip
        return CSC(data, indices, indptr, unsigned=unsigned)

    def hessian_action(self, x, v) -> np.ndarray:
        """The exact Hessian times ``v`` (over ``x.ravel()``), in element form: flat (x.size,).

        The matrix of :meth:`hessian`, applied joint by joint and segment by segment to the
        differences of v along the wire, never through assembled node-coordinate entries
        (:mod:`crumple.energy_action`): for a smooth v at large N it keeps the curvature that
        the assembled entries' round-off hides (``x`` trusted as in :meth:`hessian_csc`).
        """
        x = np.ascontiguousarray(x, dtype=np.float64)
        v = np.ascontiguousarray(v, dtype=np.float64).reshape(x.shape)
        w = self.wire
        ks, js = self._pairs(x)
        return _hessian_action(
            x, w.k_b, self._s, self._tp, self.rest_angles, w.k_s, w.rest_length, self.lam,
            self.weights, ks, js, w.hard_core, w.hard_core_energy, self._radius, v,
        )  # fmt: skip

    def _triplets(self, x, project_contacts, project_bending):
        w = self.wire
        ks, js = self._pairs(x)
        return _hessian_triplets(
            x, w.k_b, self._s, self._tp, self.rest_angles, w.k_s, w.rest_length, self.lam,
            self.weights, ks, js, w.hard_core, w.hard_core_energy, project_contacts,
            project_bending, self._radius,
        )  # fmt: skip

    def _kept_pattern(self, ks, js):
        """The current pattern for a rebuilt neighbour list, or None. A rebuilt list often
        holds the same pairs, or fewer: the current pattern (the same index arrays, so that the
        factorisation keeps its symbolic analysis) is kept whenever it holds every entry of
        the new one, the entries of pairs that left it staying explicit zeros. The chain's
        triplets add to the entries they did; only the pairs' blocks are looked up."""
        ks0, _, indptr, indices, where, unsigned = self._pattern
        head = where[: where.shape[0] - 36 * ks0.shape[0]]
        new, held = _pair_blocks_where(*unsigned, head, ks, js)
        return (ks, js, indptr, indices, new, unsigned) if held else None

    def touching(self, x) -> bool:
        """Whether some node is inside the hard core of a segment at ``x`` (a contact acts):
        the hard-core energy is nonzero. Over the current neighbour list, which it does not
        rebuild (a hint for the minimiser, not an energy: a list made at a point more than
        half a skin away can miss a pair). ``x`` trusted as in :meth:`hessian_csc`."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        ks, js = (self._ks, self._js) if self._ks is not None else self._pairs(x)
        return bool(_in_core(x, ks, js, self.wire.hard_core))

    def barriers(self, x, step, *, releasing: bool = False):
        """The hard-core barriers that ``step`` may enter from ``x``, for the Newton model.

        Returns ``(index, value, offset, stiffness)`` as :func:`crumple.minimize.newton`'s
        ``barriers`` wants them: one row per candidate pair now outside the core (D >= d)
        that the step, linearised, brings to within d + ``BARRIER_MARGIN`` (D - d): a = ∇D,
        r = d - D, and the barrier's curvature at its edge, k = ε b''(1)/d² = 2ε/d². The model
        then sees a contact before the step reaches it; the energy itself is unchanged.

        ``releasing``: also the pairs now inside the core that the step, linearised, takes to
        beyond d - ``BARRIER_MARGIN`` (d - D): a row -a, offset -(d - D) < 0 and the stiffness
        -ε b''(u)/d², the curvature along a that the pair's block gives the Hessian. The model
        then loses that curvature where the step takes the pair out of the core, where the
        energy has none (the barrier's second derivative jumps from 2ε/d² to 0 at D = d).
        The model is then not convex in general: removing that curvature can leave H + Σ k_i
        a_i a_iᵀ indefinite where the contacts are what made H positive definite (a review
        found one on a compressed hairpin). The springs' solvers refuse an active set whose
        model has no minimiser (the solve by the inertia of its small Woodbury system, the
        refactorised and the accurate spring steps by a negative pivot) and keep the last one
        that has; every step is still checked to be a descent direction, and the line search
        to lower the energy, so only the step's quality is at stake.
        """
        w = self.wire
        x = np.ascontiguousarray(x, dtype=np.float64)
        ks, js = self._pairs(x)
        index, value, offset = _barrier_rows(
            x, np.ascontiguousarray(step, dtype=np.float64).reshape(x.shape), ks, js, w.hard_core,
            BARRIER_MARGIN,
        )  # fmt: skip
        stiffness = np.empty(offset.shape[0])
        stiffness.fill(2.0 * w.hard_core_energy / w.hard_core**2)
        if not releasing:
            return index, value, offset, stiffness
        out, more, less, u = _release_rows(
            x, np.ascontiguousarray(step, dtype=np.float64).reshape(x.shape), ks, js, w.hard_core,
            BARRIER_MARGIN,
        )  # fmt: skip
        # the curvature the pair's block has along a: ε b''(u)/d², b''(u) = 2/u³, removed
        soft = -2.0 * w.hard_core_energy / (w.hard_core**2 * u**3)
        return (np.concatenate([index, out]), np.concatenate([value, more]),
                np.concatenate([offset, less]), np.concatenate([stiffness, soft]))  # fmt: skip


#: The pairs :meth:`WireEnergy.barriers` lists: those the step brings, linearised, to within
#: d + BARRIER_MARGIN (D - d) (so at least halfway from where they are to the core). Measured:
#: the same iterations as listing every pair the step could reach at all, 10 % less CPU at
#: N = 1000 (fewer springs tried and dropped).
BARRIER_MARGIN = 0.5


def _projection(project_contacts) -> int:
    """``project_contacts`` (:meth:`WireEnergy.hessian`) as the kernels' code: 0 exact (False),
    1 every contact (True), 2 the caps ("caps")."""
    if isinstance(project_contacts, (bool, np.bool_)):
        return int(project_contacts)
    if isinstance(project_contacts, str) and project_contacts == "caps":
        return 2
    raise ValueError(f"project_contacts must be False, True or 'caps', got {project_contacts!r}")


def _csc_pattern(rows, cols, ndof):
    """CSC pattern (indptr, indices) of the triplets, the entry each triplet adds to, and
    (indptr, indices) as the unsigned views the kernels read (:attr:`crumple.linalg.CSC.unsigned`).
    """
    indptr, indices, where = _csc_pattern_kernel(unsigned_view(rows), unsigned_view(cols), ndof)
    index = np.int32 if indices.shape[0] < 2**31 - 1 else np.int64
    indptr, indices = indptr.astype(index), indices.astype(index)
    return indptr, indices, unsigned_view(where), (unsigned_view(indptr), unsigned_view(indices))


def energy_terms(wire: Wire, positions, lam: float, *, rest_angles=None) -> EnergyTerms:
    """Energy of a configuration by term (paper's Eq. 1).

    Parameters
    ----------
    wire : Wire
    positions : array_like, shape (wire.n_nodes, 2)
        ``[length]``
    lam : float
        Trap strength λ.

    Examples
    --------
    >>> w = Wire(k_b=5, k_s=5e5, n_segments=4, confinement="per-node")
    >>> x = np.c_[np.linspace(-0.5, 0.5, 5), np.zeros(5)]     # straight, unstretched
    >>> energy_terms(w, x, lam=2.0).to_dict()["confinement"]   # 2 (2 * 0.25 + 2 * 0.0625)
    1.25
    """
    return WireEnergy(wire, lam, rest_angles=rest_angles).terms(positions)


def total_energy(wire: Wire, positions, lam: float):
    """Total energy ``[energy]`` and its gradient ``(n_nodes, 2)`` ``[energy/length]``.

    >>> w = Wire(k_b=5, k_s=5e5, n_segments=4)
    >>> e, g = total_energy(w, np.c_[np.linspace(-0.5, 0.5, 5), np.zeros(5)], lam=2.0)
    >>> e, g.shape
    (0.1875, (5, 2))
    """
    pos = _as_positions(positions)
    if pos.shape[0] != wire.n_nodes:
        raise ValueError(f"positions must have {wire.n_nodes} nodes, got {pos.shape[0]}")
    return WireEnergy(wire, lam)(pos)


def hessian(wire: Wire, positions, lam: float, *, dense: bool | None = None):
    """Hessian of the total energy over the flattened coordinates ``2 * node + axis``.

    Exact for every term (the hard core's includes the geometric stiffness ε b'/d ∇²D of each
    contact; it is C1 only, so its Hessian jumps where a pair enters the hard core). Dense
    ``(2n, 2n)`` ndarray up to ``DENSE_LIMIT`` degrees of freedom, else sparse CSC.

    >>> w = Wire(k_b=5, k_s=5e5, n_segments=4)
    >>> hessian(w, np.c_[np.linspace(-0.5, 0.5, 5), np.zeros(5)], lam=1.0).shape
    (10, 10)
    """
    pos = _as_positions(positions)
    return WireEnergy(wire, lam).hessian(pos, dense=dense)
