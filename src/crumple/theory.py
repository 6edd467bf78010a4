"""The paper's analytic predictions, as functions to draw next to measured data.

* :func:`loop_size`: the loop size ``ℓ ~ (k_b/λ)^(1/4)`` of Sec. III.B;
* :func:`gamma_prediction`: the energy-allocation formula of Sec. III.B (Eq. 5), and
  :func:`gamma_exponents`, its local exponents to set against the fit of Eq. (4);
* :func:`alpha_prediction`: the size exponent ``α = -1/4`` of ``R_g ~ λ^α`` (Sec. III.C);
* :func:`loop_shape`: the continuum loop of Sec. III.A, read as ``r^2 = ℓ^2 sin 2θ``.

These are scaling arguments: every prefactor is set to 1 unless stated, so compare exponents
and shapes, not absolute magnitudes. Units are the paper's: see each function for how its
moduli are to be read (continuum Eq. 2 or discrete Eq. 1). The derivations are in
``docs/observables.md``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import ellipj, ellipk

__all__ = [
    "LEMNISCATE_CONSTANT",
    "alpha_prediction",
    "gamma_exponents",
    "gamma_prediction",
    "loop_shape",
    "loop_size",
]

#: ϖ = 2 ∫_0^1 dt / sqrt(1 - t^4) = 2.6220575..., the arc length of one loop of
#: r^2 = ℓ^2 sin 2θ in units of ℓ (the lemniscate constant).
LEMNISCATE_CONSTANT = math.sqrt(2.0) * float(ellipk(0.5))


def _positive(name: str, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} must be a positive number, got {value!r}") from err
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return arr


def _out(arr: np.ndarray):
    return float(arr) if arr.ndim == 0 else arr


def loop_size(k_b, lam, *, segment_length=None):
    """Characteristic loop size ``ℓ = (k_b / λ)^(1/4)`` ``[length]`` (Sec. III.B).

    Balancing the bending energy of a loop, ``k_b/ℓ``, against its energy in the field,
    ``λ ℓ^3`` (both from the continuum energy Eq. 2) gives ``ℓ ~ (k_b/λ)^(1/4)``. The paper
    gives no prefactor; this function uses 1. The loop of :func:`loop_shape` reaches
    distance ``ℓ`` from its base and has arc length ``ϖ ℓ ≈ 2.62 ℓ``.

    ``k_b`` and ``lam`` are the continuum moduli of Eq. (2), ``[energy·length]`` and
    ``[energy/length^3]``. The discrete parameters of Eq. (1), ``[energy]`` and
    ``[energy/length^2]`` (the values of the paper's Table I), map to them through the
    segment length ``Δs = L0/N``: ``k_b Δs`` and ``λ / Δs``. Pass ``segment_length=Δs`` to
    do that conversion, which gives ``ℓ = (k_b/λ)^(1/4) Δs^(1/2)``. (A wire whose field is
    normalised per length, ``λ ∫ r^2 ds``, already has the continuum λ: then pass its
    continuum ``k_b Δs`` and λ, without ``segment_length``.)

    Parameters
    ----------
    k_b : float or array_like
        Bending rigidity, > 0.
    lam : float or array_like
        Strength λ of the confining field, > 0 (broadcast against ``k_b``).
    segment_length : float, optional
        ``Δs = L0/N`` ``[length]``: read ``k_b`` and ``lam`` as Eq. (1)'s discrete parameters.

    Returns
    -------
    float or ndarray
        ``ℓ`` ``[length]``.

    Examples
    --------
    >>> loop_size(16.0, 1.0)
    2.0
    >>> round(loop_size(5.0, 1000.0, segment_length=0.01), 6)     # Table I values, N = 100
    0.026591
    """
    kb = _positive("k_b", k_b)
    lm = _positive("lam", lam)
    ell = (kb / lm) ** 0.25
    if segment_length is not None:
        ds = float(_positive("segment_length", segment_length))
        ell = ell * math.sqrt(ds)
    return _out(np.asarray(ell))


def _gamma_x(k_b, k_s, lam, L0):
    """x = sqrt(k_b λ) / (k_s L0), the variable of the γ formula, from validated inputs."""
    kb = _positive("k_b", k_b)
    ks = _positive("k_s", k_s)
    lm = _positive("lam", lam)
    l0 = _positive("L0", L0)
    return np.sqrt(kb * lm) / (ks * l0)


def gamma_prediction(k_b, k_s, lam, L0=1.0):
    """The paper's prediction for γ = E_s/E_b (Sec. III.B, Eq. 5).

    .. math::

        γ = \\frac{\\sqrt{k_b λ}}{k_s \\left[L_0 - \\sqrt{k_b λ}/k_s\\right]}
          = \\frac{x}{1 - x}, \\qquad x = \\frac{\\sqrt{k_b λ}}{k_s L_0}

    from ``E_b ~ k_b L / ℓ^2 = L sqrt(k_b λ)`` (``L/ℓ`` loops of energy ``k_b/ℓ`` each) and
    ``E_s ~ k_s (L - L0)^2``, minimised over the wire length ``L``. Exactly as printed: keeping
    the factors of that minimisation would give ``x / (2 (2 - x))`` instead, and neither
    carries the unknown prefactors of the two estimates, so only the exponents (see
    :func:`gamma_exponents`) are predictions. ``sqrt(k_b λ)/k_s`` is a length when the
    moduli are Eq. (1)'s discrete ones (``[energy]``, ``[energy/length^2]``,
    ``[energy/length^2]``), as in the paper.

    The formula is positive and finite only for ``x < 1``, i.e. ``k_b λ < (k_s L0)^2`` (the
    estimated length ``L = L0 - sqrt(k_b λ)/k_s`` stays positive); outside this domain
    the result is NaN.

    Parameters
    ----------
    k_b, k_s, lam : float or array_like
        Bending rigidity, stretching modulus and field strength, > 0 (broadcast together).
    L0 : float
        Rest length of the wire ``[length]`` (1 in the paper).

    Returns
    -------
    float or ndarray
        γ (dimensionless), NaN where ``x >= 1``.

    Examples
    --------
    >>> gamma_prediction(1.0, 2.0, 1.0)          # x = 1/2
    1.0
    >>> round(gamma_prediction(5.0, 5e5, 1000.0), 8)
    0.00014144
    >>> gamma_prediction(1.0, 1.0, 4.0)          # x = 2: outside the domain
    nan
    """
    x = _gamma_x(k_b, k_s, lam, L0)
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma = np.where(x < 1.0, x / (1.0 - x), np.nan)
    return _out(gamma)


def gamma_exponents(k_b, k_s, lam, L0=1.0) -> dict:
    """Local exponents of :func:`gamma_prediction`, to compare with the fit of Eq. (4).

    With ``γ = x/(1 - x)`` and ``x = sqrt(k_b λ)/(k_s L0)``, ``d ln γ / d ln x = 1/(1 - x)``, so

    .. math::

        ε_l = ε_b = \\frac{1}{2(1 - x)}, \\qquad ε_s = -\\frac{1}{1 - x},

    tending to ``(1/2, 1/2, -1)`` for ``x → 0``. The paper measures
    ``(0.55, 2.6, -3.3)``: ε_l agrees, but the formula ties ``ε_b = ε_l`` and
    ``ε_s = -2 ε_l`` at every ``x``, which the measured values do not satisfy.

    Parameters
    ----------
    k_b, k_s, lam : float or array_like
        As in :func:`gamma_prediction`.
    L0 : float
        Rest length ``[length]``.

    Returns
    -------
    dict
        ``{"lam": ε_l, "k_b": ε_b, "k_s": ε_s}`` (floats or arrays; NaN outside the domain).

    Examples
    --------
    >>> gamma_exponents(1e-6, 1.0, 1e-6)         # x = 1e-6: the small-x limit
    {'lam': 0.5000005000005, 'k_b': 0.5000005000005, 'k_s': -1.000001000001}
    """
    x = _gamma_x(k_b, k_s, lam, L0)
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.where(x < 1.0, 1.0 / (1.0 - x), np.nan)
    return {"lam": _out(0.5 * slope), "k_b": _out(0.5 * slope), "k_s": _out(-slope)}


def alpha_prediction() -> float:
    """The size exponent α of ``R_g ~ λ^α``: -1/4 (Sec. III.C, Fig. 5).

    The paper's argument: a wire of length ``L0`` packed in a disc of radius ``R`` has
    monomer density ``L0/R^2``. Its energy in the field is ``λ R^2 L0`` and its hard-core
    repulsion, a two-body term, ``β (L0/R^2)^2 R^2`` (density squared times the area; ``β``
    measures the hard core). Minimising

    .. math::

        E(R) = λ L_0 R^2 + β L_0^2 R^{-2}, \\qquad
        \\frac{dE}{dR} = 0 \\Rightarrow R^4 = \\frac{β L_0}{λ},

    gives ``R ~ λ^(-1/4)``, independent of ``k_b`` and ``k_s`` (the bending energy is left
    out). The paper measures α = -0.25 with ``R_g = r_max`` and notes the same exponent for
    thin elastic sheets.

    Returns
    -------
    float
        -0.25

    Examples
    --------
    >>> alpha_prediction()
    -0.25
    """
    return -0.25


def loop_shape(k_b, lam, *, n_points: int = 101, segment_length=None):
    """One loop of the continuum wire, ``r^2 = ℓ^2 sin 2θ`` (Sec. III.A), as an (x, y) curve.

    The paper prints the Euler-Lagrange solution of Eq. (2) as
    ``r^2 sqrt(k_b/λ) = sin 2θ``. In Eq. (2) ``[k_b] = energy·length`` and
    ``[λ] = energy/length^3``, so ``sqrt(k_b/λ)`` is an area and the left side has dimension
    length^4 while ``sin 2θ`` is a number (with Eq. 1's discrete moduli it would be
    length^3): the equation cannot hold as printed. The one reading consistent with the
    loop size ``ℓ = (k_b/λ)^(1/4)`` of Sec. III.B is

    .. math::

        r^2 = \\sqrt{k_b/λ}\\, \\sin 2θ = ℓ^2 \\sin 2θ, \\qquad 0 \\le θ \\le π/2,

    i.e. ``r^2 / sqrt(k_b/λ) = sin 2θ``: one lobe of a lemniscate of Bernoulli, in polar
    coordinates about the centre of the field, leaving and re-entering the centre along the
    two axes (a right angle: the "water drop" of Figs. 1-2). It reaches ``r = ℓ`` at
    ``θ = π/4``, has arc length ``ϖ ℓ ≈ 2.622 ℓ`` and curvature ``κ = 3 r/ℓ^2``.

    The points are equally spaced in arc length (``r = ℓ sl(s/ℓ)``, with ``sl`` the
    lemniscate sine), like the nodes of a discretised wire, from the centre (``s = 0``) out
    and back (``s = ϖ ℓ``).

    Where it compares with a simulated wire: only in the early stage of crumpling, before
    loops touch (the derivation neglects the hard core and the stretching, ``k_b << k_s``), for
    a loop whose base sits at the centre of the field, after rotating it onto the axes, and
    only as a shape: the scale ``ℓ`` carries an unknown prefactor, and a loop made of a fixed
    length of wire has ``ϖ ℓ`` equal to that length rather than set by ``k_b/λ``. Compare the
    shape rescaled by the loop's own largest distance from the centre. It does not describe
    loops squeezed by contacts, loops away from the centre, or a whole wire of several
    loops; and the paper's claim that this curve solves Eq. (2) is not checked here.

    Parameters
    ----------
    k_b, lam : float
        Moduli as in :func:`loop_size` (continuum, or discrete with ``segment_length``).
    n_points : int
        Number of points, >= 3.
    segment_length : float, optional
        See :func:`loop_size`.

    Returns
    -------
    x, y : ndarray, shape (n_points,)
        Coordinates ``[length]``, starting and ending at the origin.

    Examples
    --------
    >>> import numpy as np
    >>> x, y = loop_shape(1.0, 1.0, n_points=5)
    >>> np.hypot(x, y).round(6).tolist()           # sl(varpi/4) = sqrt(sqrt(2) - 1)
    [0.0, 0.643594, 1.0, 0.643594, 0.0]
    >>> bool(np.allclose(x[2], y[2]))
    True
    """
    if not isinstance(n_points, int | np.integer) or n_points < 3:
        raise ValueError(f"n_points must be an integer >= 3, got {n_points!r}")
    kb = _positive("k_b", k_b)
    lm = _positive("lam", lam)
    if kb.ndim or lm.ndim:
        raise ValueError(f"k_b and lam must be single numbers for one loop, got {k_b!r}, {lam!r}")
    ell = loop_size(float(kb), float(lm), segment_length=segment_length)
    s = np.linspace(0.0, LEMNISCATE_CONSTANT, int(n_points))
    # s is the arc length in units of ell. With the Jacobi functions of sqrt(2) s at parameter
    # m = 1/2: r / ell = sl(s) = sn / (sqrt(2) dn),
    # sin 2θ = (r / ell)^2 = sn^2 / (2 - sn^2) and cos 2θ = 2 cn / (2 - sn^2), so
    # 2θ = atan2(sn^2, 2 cn): well conditioned at the tip (cn = 0) and valid on the way back.
    sn, cn, dn, _ = ellipj(math.sqrt(2.0) * s, 0.5)
    r = ell * sn / (math.sqrt(2.0) * dn)
    theta = 0.5 * np.arctan2(sn * sn, 2.0 * cn)
    x = r * np.cos(theta)
    y = r * np.sin(theta)
    x[[0, -1]] = 0.0
    y[[0, -1]] = 0.0
    return x, y
