"""The continuum limit of the wire model: one control parameter, the confinement number Λ.

With confinement per unit length (Eq. 2 of the paper) and a wire stiff in stretching, the
continuum energy ``∫ [B κ²/2 + λ r²] ds`` of a wire of length ``L`` has one dimensionless
parameter. Measuring lengths in ``L`` and energies in ``B/L``,

.. math::

    Λ = \\frac{λ L^4}{B}, \\qquad B = \\frac{k_b L}{N}
    \\quad (Λ = λ N / k_b \\text{ for } L = 1),

and the loop size ``ℓ = (B/λ)^{1/4}`` is ``L Λ^{-1/4}``: ``L/ℓ = Λ^{1/4}``. At fixed Λ,
every observable in continuum units (``R_g/L``, ``r_max/L``, ``E_b L/B``, ``E_conf L/B``,
γ = E_s/E_b, contacts per unit length, loops) is the same for every (k_b, λ, N), once

* N resolves ℓ (:func:`segments_per_loop` large enough: the N-convergence rule, measured by
  ``crumple study continuum``), and
* the wire is stiff in stretching (:func:`stretch_number` large, :func:`stiff_k_s`), and
* the hard core's width ``d/L`` and energy ``ε L/B`` are the same (they matter once loops
  touch; they are the model's two other dimensionless numbers).

Pure formulas; ``docs/continuum.md`` has the derivations and what has been measured. Lengths
in units of L0 unless ``length`` is given, energies in the paper's units.
"""

from __future__ import annotations

import math

__all__ = [
    "STRAIN_BOUND",
    "bending_stiffness",
    "confinement_number",
    "lam_for",
    "loop_length",
    "segments_per_loop",
    "stiff_k_s",
    "strain_estimate",
    "stretch_number",
    "wire_point",
]

#: Default bound on the estimated stretching strain ``ε ≈ B/(S ℓ²)`` (:func:`strain_estimate`)
#: at the largest Λ of a sweep: k_s is chosen so that the wire is inextensible to this
#: precision (:func:`stiff_k_s`). Then the continuum observables depend on k_s only at
#: relative order 1e-3, below the discretisation error at the N the study runs.
STRAIN_BOUND = 1e-3


def _pos(name: str, v) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {v!r}") from None
    if not math.isfinite(x) or x <= 0:
        raise ValueError(f"{name} must be a positive finite number, got {v!r}")
    return x


def _n(n) -> int:
    if isinstance(n, bool) or int(n) != n or n < 3:
        raise ValueError(f"n_segments must be an integer >= 3, got {n!r}")
    return int(n)


def bending_stiffness(k_b, n_segments, length=1.0) -> float:
    """Continuum bending stiffness ``B = k_b L / N`` ``[energy·length]``.

    >>> bending_stiffness(5.0, 100)
    0.05
    """
    return _pos("k_b", k_b) * _pos("length", length) / _n(n_segments)


def confinement_number(*, k_b, lam, n_segments, length=1.0) -> float:
    """The confinement number ``Λ = λ L⁴ / B`` (dimensionless), ``B = k_b L/N``.

    ``lam`` is the per-length trap strength ``[energy/length³]`` of
    ``Wire(confinement="per-length")``.

    >>> confinement_number(k_b=5.0, lam=1000.0, n_segments=100)   # the paper's Fig. 2 stage
    20000.0
    >>> confinement_number(k_b=1.0, lam=2000.0, n_segments=100)   # the paper's largest Λ
    200000.0
    """
    return (
        _pos("lam", lam) * _pos("length", length) ** 4 / bending_stiffness(k_b, n_segments, length)
    )


def lam_for(confinement, *, k_b, n_segments, length=1.0) -> float:
    """The per-length trap strength λ of confinement number Λ: ``λ = Λ B / L⁴``.

    >>> lam_for(20000.0, k_b=5.0, n_segments=100)
    1000.0
    """
    return (
        _pos("Λ", confinement)
        * bending_stiffness(k_b, n_segments, length)
        / _pos("length", length) ** 4
    )


def loop_length(confinement, length=1.0) -> float:
    """The loop size ``ℓ = (B/λ)^{1/4} = L Λ^{-1/4}`` ``[length]`` (prefactor 1, as in
    :func:`crumple.theory.loop_size`).

    >>> loop_length(1e4)
    0.1
    >>> round(loop_length(1e8, length=2.0), 12)
    0.02
    """
    return _pos("length", length) * _pos("Λ", confinement) ** -0.25


def segments_per_loop(confinement, n_segments) -> float:
    """``ℓ / Δs = N Λ^{-1/4}``: how many segments resolve one loop size.

    The N-convergence rule of the study is a minimum of this number for a given accuracy
    (``docs/continuum.md``).

    >>> segments_per_loop(1e4, 100)
    10.0
    """
    return _n(n_segments) * _pos("Λ", confinement) ** -0.25


def stretch_number(confinement, *, k_b, k_s, length=1.0) -> float:
    """``S ℓ² / B = (k_s / k_b) ℓ²`` (dimensionless; ``S = k_s L/N``, ``S/B = k_s/k_b``).

    The tension in a bent wire is of order ``B/ℓ²`` (bending forces over a loop), so its
    strain is ``ε ≈ B/(S ℓ²)``, the inverse of this number (:func:`strain_estimate`). The
    wire is inextensible, and the continuum limit has the single parameter Λ, when it is
    large.

    >>> round(stretch_number(1e4, k_b=1.0, k_s=1e7), 6)
    100000.0
    """
    return _pos("k_s", k_s) / _pos("k_b", k_b) * loop_length(confinement, length) ** 2


def strain_estimate(confinement, *, k_b, k_s, length=1.0) -> float:
    """The estimated stretching strain ``ε ≈ B/(S ℓ²) = 1 / stretch_number`` (a scaling
    estimate with prefactor 1; the study measures the real strain from the contour length).

    >>> f"{strain_estimate(1e4, k_b=1.0, k_s=1e7):.3g}"
    '1e-05'
    """
    return 1.0 / stretch_number(confinement, k_b=k_b, k_s=k_s, length=length)


def stiff_k_s(confinement_max, *, k_b, length=1.0, strain=STRAIN_BOUND) -> float:
    """The smallest k_s whose estimated strain stays below ``strain`` up to ``Λ_max``:
    ``k_s = k_b Λ_max^{1/2} / (strain L²)`` ``[energy/length²]``, i.e. ``S ℓ²/B = 1/strain``.

    >>> stiff_k_s(1e4, k_b=1.0)
    100000.0
    """
    return (
        _pos("k_b", k_b)
        * math.sqrt(_pos("Λ", confinement_max))
        / (_pos("strain", strain) * _pos("length", length) ** 2)
    )


def wire_point(
    confinements, *, n_segments, k_b=1.0, k_s=None, length=1.0, strain=STRAIN_BOUND
) -> dict:
    """A sweep point (``crumple.sweep.Sweep`` keys) that ramps through ``confinements`` (Λ).

    ``k_s`` defaults to :func:`stiff_k_s` at the largest Λ. Returns ``{"k_b", "k_s",
    "n_segments", "lambdas"}`` with ``lambdas`` the per-length λ of each Λ (rounded to 12
    significant digits so that a point's run id does not hang on the last bit).

    >>> p = wire_point([1e2, 1e4], n_segments=200, k_b=2.0)
    >>> p["lambdas"], p["k_s"]
    ([1.0, 100.0], 200000.0)
    """
    lams = sorted(_pos("Λ", c) for c in confinements)
    if not lams:
        raise ValueError("confinements must not be empty")
    ks = stiff_k_s(lams[-1], k_b=k_b, length=length, strain=strain) if k_s is None else k_s
    return {
        "k_b": float(k_b),
        "k_s": float(_pos("k_s", ks)),
        "n_segments": _n(n_segments),
        "lambdas": [
            float(f"{lam_for(c, k_b=k_b, n_segments=n_segments, length=length):.12g}") for c in lams
        ],
    }
