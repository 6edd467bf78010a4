"""The energy terms of Eq. (1) one by one, as plain functions of the positions.

Each returns ``(energy, gradient)`` of one term through the same Numba kernels as
:class:`crumple.energy.WireEnergy` (the fused elastic kernel with the other coefficients set to
zero, or the term's own). :mod:`crumple.energy` re-exports them; the model's decisions are in
``docs/model.md``.
"""

from __future__ import annotations

import math

import numpy as np

from .energy_kernels import _elastic_eg, _hard_core_eg, _wall_eg
from .geometry._input import _as_positions
from .geometry.distance import _node_segment_pairs
from .model import Plasticity


def _one_term(pos, index, *, k_b=0.0, s=1.0, theta_p=math.inf, rest=None, k_s=0.0, l0=1.0,
              lam=0.0, weights=None, cx=0.0, cy=0.0):  # fmt: skip
    """One elastic term through the fused kernel, the other coefficients set to zero."""
    grad = np.zeros_like(pos)
    terms = np.zeros(4)
    w = np.zeros(pos.shape[0]) if weights is None else weights
    rest = _rest_angles(rest, pos.shape[0])
    _elastic_eg(pos, k_b, s, theta_p, rest, k_s, l0, lam, w, cx, cy, grad, terms)
    return float(terms[index]), grad


def _rest_angles(rest, n_nodes: int) -> np.ndarray:
    """Rest turning angles, shape (n_nodes - 2,): zeros when None."""
    if rest is None:
        return np.zeros(max(n_nodes - 2, 0))
    r = np.ascontiguousarray(rest, dtype=np.float64)
    if r.shape != (n_nodes - 2,):
        raise ValueError(f"rest_angles must have shape ({n_nodes - 2},), got {r.shape}")
    if not np.all(np.isfinite(r)):
        raise ValueError("rest_angles contain NaN or infinite values")
    return r


def _plastic_args(plasticity: Plasticity | None) -> tuple[float, float]:
    if plasticity is None:
        return 1.0, math.inf
    return plasticity.s, plasticity.theta_p


def bending_energy(positions, k_b: float, plasticity: Plasticity | None = None, rest_angles=None):
    """Bending energy Σ f(θ_i - θ⁰_i) over the N - 1 joints and its gradient (Eq. 1, Sec. III.C).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    k_b : float
        Bending rigidity ``[energy]``.
    plasticity : Plasticity, optional
        Elastic-softening law beyond θ_p (applied to θ - θ⁰).
    rest_angles : array_like, shape (n_nodes - 2,), optional
        Rest turning angles θ⁰ ``[rad]`` of an imperfect wire; zeros by default (the paper).

    Returns
    -------
    energy : float
        ``[energy]``
    gradient : ndarray, shape (n_nodes, 2)
        ``[energy/length]``

    Examples
    --------
    A regular polygon of n sides turns by 2π/n at every joint:

    >>> n = 6; t = 2 * np.pi * np.arange(n + 1) / n
    >>> e, g = bending_energy(np.c_[np.cos(t), np.sin(t)], k_b=2.0)
    >>> bool(np.isclose(e, (n - 1) * (2 * np.pi / n) ** 2))
    True
    """
    pos = _as_positions(positions)
    s, tp = _plastic_args(plasticity)
    return _one_term(pos, 0, k_b=float(k_b), s=s, theta_p=tp, rest=rest_angles)


def stretching_energy(positions, k_s: float, rest_length: float):
    """Stretching energy Σ k_s/2 (|segment| - rest_length)² and its gradient (Eq. 1).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    k_s : float
        Stretching modulus ``[energy/length²]``.
    rest_length : float
        Rest length of one segment, L0/N ``[length]``.

    Examples
    --------
    >>> e, g = stretching_energy([[0, 0], [1.1, 0], [2.2, 0]], k_s=10.0, rest_length=1.0)
    >>> round(e, 12)
    0.1
    """
    pos = _as_positions(positions)
    return _one_term(pos, 1, k_s=float(k_s), l0=float(rest_length))


def confinement_weights(n_nodes: int, kind: str, length: float = 1.0) -> np.ndarray:
    """Weights w_i of the confinement λ Σ w_i r_i² for each normalisation.

    ``per-node``: w_i = 1 (Eq. 1 as printed). ``per-length``: each node's share of the rest
    length, L0/N inside and L0/(2N) at the two ends (trapezoidal rule for ∫ λ r² ds, Eq. 2).

    >>> confinement_weights(5, "per-length").tolist()
    [0.125, 0.25, 0.25, 0.25, 0.125]
    """
    if kind == "per-node":
        return np.ones(n_nodes)
    if kind == "per-length":
        w = np.full(n_nodes, length / (n_nodes - 1))
        w[0] *= 0.5
        w[-1] *= 0.5
        return w
    raise ValueError(f"confinement must be 'per-length' or 'per-node', got {kind!r}")


def confinement_energy(positions, lam: float, weights, center=(0.0, 0.0)):
    """Confinement energy λ Σ w_i |x_i - c|² and its gradient (Eqs. 1 and 2).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    lam : float
        Trap strength λ (>= 0).
    weights : array_like, shape (n_nodes,)
        w_i, see :func:`confinement_weights`.
    center : tuple of float
        Trap centre c ``[length]``.

    Examples
    --------
    A ring of radius R about the centre, per node: λ (n_nodes) R².

    >>> t = np.linspace(0, 2 * np.pi, 9)[:-1]
    >>> e, g = confinement_energy(0.5 * np.c_[np.cos(t), np.sin(t)], 3.0, np.ones(8))
    >>> round(e, 12)
    6.0
    """
    pos = _as_positions(positions)
    w = np.ascontiguousarray(weights, dtype=np.float64)
    if w.shape != (pos.shape[0],):
        raise ValueError(f"weights must have shape ({pos.shape[0]},), got {w.shape}")
    cx, cy = (float(c) for c in center)
    return _one_term(pos, 2, lam=float(lam), weights=w, cx=cx, cy=cy)


def hard_core_energy(positions, width: float, strength: float = 1.0):
    """Hard-core barrier ε Σ b(D/d) between non-adjacent segments and its gradient.

    b(u) = (1 - u)² / u for u < 1, else 0; D runs over node-segment distances
    (:func:`crumple.geometry.node_segment_pairs`). Infinite when a node touches a segment.
    It does not see crossings (a crossed wire may have all its nodes far from other
    segments): the minimisers forbid those by construction (``docs/model.md``).

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    width : float
        Hard-core width d ``[length]``.
    strength : float
        Energy scale ε ``[energy]``.

    Examples
    --------
    >>> hairpin = np.array([[0, 0], [1, 0], [1, 0.5e-5], [0, 0.5e-5]])
    >>> e, g = hard_core_energy(hairpin, width=1e-5)
    >>> round(e, 12)                  # four node-segment pairs at D = d/2, b(1/2) = 1/2
    2.0
    """
    pos = _as_positions(positions)
    grad = np.zeros_like(pos)
    if pos.shape[0] < 4:
        return 0.0, grad
    ks, js = _node_segment_pairs(pos, float(width))
    return float(_hard_core_eg(pos, ks, js, float(width), float(strength), grad)), grad


def cavity_energy(positions, radius: float, width: float, strength: float = 1.0):
    """The wall of a rigid circular cavity centred at the origin, and its gradient.

    .. math::

        E_{wall} = ε \\sum_i b(δ_i / d), \\quad δ_i = R_c - |x_i|,
        \\quad b(u) = (1 - u)^2 / u \\ (u < 1), \\ 0 \\ (u \\ge 1)

    the hard core's barrier on each node's distance to the wall (``docs/model.md``, "The
    cavity"). Infinite when a node is on or outside the wall.

    Parameters
    ----------
    positions : array_like, shape (n_nodes, 2)
        ``[length]``
    radius : float
        Cavity radius R_c ``[length]``.
    width : float
        Barrier width d ``[length]`` (the wire's hard-core width).
    strength : float
        Energy scale ε ``[energy]``.

    Examples
    --------
    >>> e, g = cavity_energy([[0.0, 0.0], [0.5, 0.0], [0.0, 0.99995]], radius=1.0, width=1e-4)
    >>> round(e, 12)                  # one node at δ = d/2, b(1/2) = 1/2
    0.5
    """
    pos = _as_positions(positions)
    grad = np.zeros_like(pos)
    r = _check_radius(radius)
    return float(_wall_eg(pos, r, float(width), float(strength), grad)), grad


def _check_radius(radius) -> float:
    r = float(radius)
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"cavity radius must be a positive finite number, got {radius!r}")
    return r
