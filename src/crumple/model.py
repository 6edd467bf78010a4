"""Parameters of the wire model of the paper's Eq. (1): frozen, validated, with factories.

Units: lengths in units of the wire length ``L0`` (``length``, 1 by default), energies in the
paper's units. ``k_b`` is an energy (per joint), ``k_s`` an energy per length squared (per
segment), λ an energy per length squared (``per-node``) or per length cubed (``per-length``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Literal

import numpy as np

__all__ = ["CONFINEMENTS", "Plasticity", "Wire"]

CONFINEMENTS = ("per-length", "per-node")
Confinement = Literal["per-length", "per-node"]


def _check_positive(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return v


def _check_n_segments(n) -> int:
    """An integer >= 3 (Python or NumPy integer, or an integral float such as 100.0)."""
    bad = ValueError(f"n_segments must be an integer >= 3, got {n!r}")
    if isinstance(n, bool | np.bool_) or not isinstance(n, int | float | np.integer | np.floating):
        raise bad
    if not math.isfinite(n) or n != int(n) or n < 3:
        raise bad
    return int(n)


@dataclass(frozen=True, slots=True, kw_only=True)
class Plasticity:
    """The elastic-softening ("plasticity") law of the paper's Section III.C.

    Beyond the yield angle θ_p the bending rigidity drops to ``s k_b``:

    .. math::

        E_b(θ) = \\frac{k_b θ_p^2}{2} + \\frac{s k_b (θ^2 - θ_p^2)}{2}
                 + k_b θ_p (1 - s)(|θ| - θ_p) \\quad (|θ| > θ_p),

    exactly as printed (with ``|θ|`` so that the law is even in θ); ``k_b θ^2 / 2`` below θ_p.
    The law is C1 at θ_p. It is reversible (no memory of past yield), as in the paper.

    Parameters
    ----------
    s : float
        Softening factor, 0 <= s <= 1 (s = 1 is purely elastic).
    theta_p : float
        Yield angle ``[rad]``, > 0.
    """

    s: float
    theta_p: float

    def __post_init__(self):
        s = float(self.s)
        if not (math.isfinite(s) and 0.0 <= s <= 1.0):
            raise ValueError(f"plasticity s must lie in [0, 1], got {self.s!r}")
        object.__setattr__(self, "s", s)
        object.__setattr__(self, "theta_p", _check_positive("plasticity theta_p", self.theta_p))


@dataclass(frozen=True, slots=True, kw_only=True)
class Wire:
    """A discrete elastic wire of length ``length`` cut into ``n_segments`` equal segments.

    ``n_segments + 1`` nodes, ``n_segments - 1`` joints. Energy (paper's Eq. 1, see
    :mod:`crumple.energy` and ``docs/model.md``):

    .. math::

        E = \\sum_{joints} \\frac{k_b}{2} θ_i^2 + \\sum_{segments} \\frac{k_s}{2} (Δl_i)^2
            + λ \\sum_{nodes} w_i |r_i - c|^2 + E_{hc}

    Parameters
    ----------
    k_b : float
        Bending rigidity ``[energy]`` per joint (paper's k_b = Y I / (L0/N)).
    k_s : float
        Stretching modulus ``[energy/length^2]`` per segment (paper's k_s = Y A / (L0/N)).
    n_segments : int
        N, number of segments (>= 3). Default 100 (paper's Table 1).
    length : float
        Rest length L0 of the whole wire ``[length]``. Default 1.
    confinement : {"per-length", "per-node"}
        ``per-node``: w_i = 1, Eq. (1) as printed. ``per-length``: w_i is the node's share of
        rest length (L0/N inside, L0/(2N) at the two ends), the discretisation of Eq. (2).
    hard_core : float
        Hard-core width d ``[length]``: non-adjacent segments closer than d repel. Default 1e-5.
    hard_core_energy : float
        Energy scale ε of the hard-core barrier ``[energy]``. Default 1.
    plasticity : Plasticity or None
        Elastic-softening law; None for a purely elastic wire.
    trap_center : tuple of float
        Centre c of the parabolic confinement ``[length]``. Default the origin.
    rest_angle_sd : float
        Imperfection: standard deviation ``[rad]`` of a random rest turning angle θ⁰_i at every
        joint, so that E_b = Σ f(θ_i - θ⁰_i). Each replica of a ramp draws its own θ⁰ from
        its seed (quenched disorder, like the residual curvature of a real wire). Default 0:
        the paper's perfectly straight wire.
    cavity_radius : float or None
        Radius R_c ``[length]`` of a rigid circular cavity centred at the origin that holds
        every node (a barrier of the hard core's kind on the node-to-wall distance, within
        the same width d; ``docs/model.md``, "The cavity"). Default None: no cavity.

    Examples
    --------
    >>> w = Wire(k_b=5, k_s=5e5)
    >>> w.n_nodes, w.rest_length
    (101, 0.01)
    >>> Wire(k_b=-1, k_s=5e5)
    Traceback (most recent call last):
    ...
    ValueError: k_b must be a positive finite number, got -1
    """

    k_b: float
    k_s: float
    n_segments: int = 100
    length: float = 1.0
    confinement: Confinement = "per-length"
    hard_core: float = 1e-5
    hard_core_energy: float = 1e-3
    plasticity: Plasticity | None = None
    trap_center: tuple[float, float] = field(default=(0.0, 0.0))
    rest_angle_sd: float = 0.0
    cavity_radius: float | None = None

    def __post_init__(self):
        for name in ("k_b", "k_s", "length", "hard_core", "hard_core_energy"):
            object.__setattr__(self, name, _check_positive(name, getattr(self, name)))
        object.__setattr__(self, "n_segments", _check_n_segments(self.n_segments))
        if self.confinement not in CONFINEMENTS:
            raise ValueError(
                f"confinement must be one of {', '.join(CONFINEMENTS)}, got {self.confinement!r}"
            )
        if self.plasticity is not None and not isinstance(self.plasticity, Plasticity):
            raise ValueError(f"plasticity must be a Plasticity or None, got {self.plasticity!r}")
        try:
            cx, cy = (float(c) for c in self.trap_center)
        except (TypeError, ValueError):
            raise ValueError(f"trap_center must be two numbers, got {self.trap_center!r}") from None
        if not (math.isfinite(cx) and math.isfinite(cy)):
            raise ValueError(f"trap_center must be finite, got {self.trap_center!r}")
        object.__setattr__(self, "trap_center", (cx, cy))
        sd = float(self.rest_angle_sd)
        if not (math.isfinite(sd) and sd >= 0):
            raise ValueError(f"rest_angle_sd must be >= 0, got {self.rest_angle_sd!r}")
        object.__setattr__(self, "rest_angle_sd", sd)
        if self.cavity_radius is not None:
            r = _check_positive("cavity_radius", self.cavity_radius)
            if r <= self.hard_core:
                raise ValueError(
                    f"cavity_radius {r} must exceed the hard-core width {self.hard_core}"
                )
            object.__setattr__(self, "cavity_radius", r)
        if self.hard_core >= self.rest_length:
            raise ValueError(
                f"hard_core width {self.hard_core} must be smaller than the segment length "
                f"{self.rest_length}"
            )

    # ---- factories --------------------------------------------------------------------------

    @classmethod
    def from_material(cls, *, young: float, radius: float, n_segments: int = 100, **kwargs):
        """A wire of circular cross-section made of a material.

        I = π r^4 / 4 and A = π r^2, so k_b = Y I / (L0/N) and k_s = Y A / (L0/N) as the paper
        defines them (the paper's k_s/k_b = 4/r^2 for a circular section).

        Parameters
        ----------
        young : float
            Young's modulus Y ``[energy/length^3]`` in the model's units.
        radius : float
            Wire radius r ``[length]``.

        >>> w = Wire.from_material(young=1e9, radius=1e-3, n_segments=100)
        >>> round(w.k_b, 6), round(w.k_s, 3)
        (0.07854, 314159.265)
        """
        young = _check_positive("young", young)
        radius = _check_positive("radius", radius)
        inertia = math.pi * radius**4 / 4.0
        area = math.pi * radius**2
        return cls.from_continuum(
            bending=young * inertia, stretching=young * area, n_segments=n_segments, **kwargs
        )

    @classmethod
    def from_continuum(cls, *, bending: float, stretching: float, n_segments: int = 100, **kwargs):
        """A wire given its continuum stiffnesses B = Y I and S = Y A.

        The continuum energy ∫ [B κ²/2 + S ε²/2] ds is discretised as k_b = B N / L0 and
        k_s = S N / L0, so that refining N at fixed (B, S) converges to the continuum model
        of the paper's Eq. (2).

        >>> Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=200).k_b
        10.0
        """
        bending = _check_positive("bending", bending)
        stretching = _check_positive("stretching", stretching)
        length = _check_positive("length", kwargs.get("length", 1.0))
        n_segments = _check_n_segments(n_segments)
        seg = length / n_segments
        return cls(k_b=bending / seg, k_s=stretching / seg, n_segments=n_segments, **kwargs)

    # ---- derived quantities ------------------------------------------------------------------

    @property
    def n_nodes(self) -> int:
        """Number of nodes, N + 1."""
        return self.n_segments + 1

    @property
    def rest_length(self) -> float:
        """Rest length of one segment, L0 / N ``[length]``."""
        return self.length / self.n_segments

    @property
    def bending_stiffness(self) -> float:
        """Continuum bending stiffness B = k_b L0 / N ``[energy length]``."""
        return self.k_b * self.rest_length

    @property
    def stretching_stiffness(self) -> float:
        """Continuum stretching stiffness S = k_s L0 / N ``[energy/length]``."""
        return self.k_s * self.rest_length

    def replace(self, **changes) -> Wire:
        """A copy with some parameters changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict:
        """Plain, JSON-able parameters (``plasticity`` as a dict or None)."""
        d = asdict(self)
        d["trap_center"] = list(self.trap_center)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Wire:
        """Inverse of :meth:`to_dict`; unknown keys are an error."""
        d = dict(d)
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown wire parameter(s): {', '.join(sorted(unknown))}")
        if d.get("plasticity") is not None and not isinstance(d["plasticity"], Plasticity):
            d["plasticity"] = Plasticity(**d["plasticity"])
        if "trap_center" in d:
            d["trap_center"] = tuple(d["trap_center"])
        return cls(**d)
