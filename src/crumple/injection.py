"""Injection into a cavity: the quasi-static protocol of the experiments (Donato et al.,
Stoop et al.), beside the paper's confinement ramp (:mod:`crumple.protocol`).

The wire is pushed, a length δ per stage, through a straight channel (:class:`crumple.feed.
Channel`) into a rigid circular cavity. The part not yet in lies straight in the channel,
its nodes prescribed; the free part is minimised to equilibrium at every stage from the
previous stage's equilibrium, with the Newton minimiser and the stability test of the ramp
(:data:`crumple.protocol.STABILITY_TOL`). A stage's push is applied in sub-pushes of at most
``max_push``: the channel's nodes move by the sub-push (continuous collision detection
checks that this never makes the wire cross itself at the mouth), the nodes that have come
far enough in are released, and the free nodes relax. The run stops at ``stop_length`` or
when the feed force exceeds ``jam_force`` (jamming); :class:`InjectionResult` says which.

The feed force F stored per stage is the injection force of a frictionless feed: the
pusher's work per injected length over the stage, which is all stored, so that
∫F dL_in = E(L_in) - E(0). It is measured, not differenced: the trapezoidal integral of the
clamp's reaction (:func:`clamp_reaction`, ``Σ_prescribed ∂E/∂x_i · u``, dE/dL_in by the
envelope theorem while the prescribed set does not change) minus the energy the wire gives
up when a node is released and it relaxes (``release_drop``). The clamp's reaction alone
overstates the injection force 2-7 times. See ``docs/injection.md``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from .energy import DENSE_LIMIT, EnergyTerms
from .feed import Channel, FedWireEnergy
from .geometry import disc_exit_fraction, has_crossings, max_safe_fraction
from .linalg import CSC, LDLT, pin_rows
from .minimize import MinimizeResult, newton
from .model import Wire
from .protocol import DEFAULT_MAXITER, STABILITY_TOL, node_lengths, one_blas_thread

__all__ = [
    "Injection",
    "InjectionResult",
    "InjectionStage",
    "clamp_reaction",
    "packing_fraction",
    "run_injection",
]


@dataclass(frozen=True, slots=True, kw_only=True)
class Injection:
    """A quasi-static injection into the wire's cavity (``Wire.cavity_radius``).

    Parameters
    ----------
    push : float or None
        δ, the length pushed in per stage ``[length]``. None: one segment, L0/N.
    stop_length : float or None
        Stop when this length is in ``[length]``. None: all of the wire but one segment (the
        last segment stays in the channel, so that the feed is still clamped).
    angle : float
        Entry angle α ``[rad]`` from the inward radial, ``|α| < π/2``. Default 0 (radial).
    jam_force : float or None
        Jamming: stop when the feed force exceeds this ``[energy/length]``. None: never.
    max_push : float or None
        Largest displacement of the channel's nodes per minimisation ``[length]`` (a stage's
        push is split into equal sub-pushes no longer than this). None: an eighth of a
        segment (a quarter throws the wire into spurious snap-throughs: the pusher's work
        then exceeds the energy stored by up to 30 % at N = 60).
    noise : float
        Standard deviation of a transverse displacement given to every node when it is
        released, in units of the segment rest length (breaks the symmetry of a radial
        injection; clipped to a tenth of the hard-core width, and scaled down by collision
        detection if needed). Default 0.01.
    ftol, maxiter, max_step :
        As for :class:`crumple.protocol.Ramp` (Newton only: the channel is a fixed mask).

    Examples
    --------
    >>> Injection(push=0.01, stop_length=0.5).stop_length
    0.5
    >>> Injection(angle=2.0)
    Traceback (most recent call last):
    ...
    ValueError: angle must lie in (-pi/2, pi/2) rad (the channel points in), got 2.0
    """

    push: float | None = None
    stop_length: float | None = None
    angle: float = 0.0
    jam_force: float | None = None
    max_push: float | None = None
    noise: float = 0.01
    ftol: float = 1e-6
    maxiter: int = field(default=DEFAULT_MAXITER["newton"])
    max_step: float = 0.5

    def __post_init__(self):
        for name in ("push", "stop_length", "jam_force", "max_push"):
            v = getattr(self, name)
            if v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, int | float) or not v > 0:
                raise ValueError(f"{name} must be a positive number or None, got {v!r}")
            if not math.isfinite(v):
                raise ValueError(f"{name} must be finite, got {v!r}")
            object.__setattr__(self, name, float(v))
        a = float(self.angle)
        if not (math.isfinite(a) and abs(a) < 0.5 * math.pi):
            raise ValueError(
                f"angle must lie in (-pi/2, pi/2) rad (the channel points in), got {self.angle!r}"
            )
        object.__setattr__(self, "angle", a)
        if not (math.isfinite(self.noise) and 0 <= self.noise < 0.5):
            raise ValueError(f"noise must lie in [0, 0.5), got {self.noise!r}")
        object.__setattr__(self, "noise", float(self.noise))
        if not (math.isfinite(self.ftol) and self.ftol > 0):
            raise ValueError(f"ftol must be positive, got {self.ftol!r}")
        if isinstance(self.maxiter, bool) or int(self.maxiter) != self.maxiter or self.maxiter < 1:
            raise ValueError(f"maxiter must be an integer >= 1, got {self.maxiter!r}")
        object.__setattr__(self, "maxiter", int(self.maxiter))
        if not (math.isfinite(self.max_step) and self.max_step > 0):
            raise ValueError(f"max_step must be positive, got {self.max_step!r}")

    # ---- resolved against a wire ------------------------------------------------------------

    def resolve(self, wire: Wire) -> tuple[float, float, float]:
        """(δ, stop length, largest sub-push) for ``wire``, checked against it."""
        if wire.cavity_radius is None:
            raise ValueError("injection needs a wire with a cavity (Wire(cavity_radius=...))")
        a = wire.rest_length
        push = a if self.push is None else self.push
        stop = wire.length - a if self.stop_length is None else self.stop_length
        if stop > wire.length - a * (1 - 1e-12):
            raise ValueError(
                f"stop_length {stop} leaves less than one segment ({a}) in the channel: the "
                f"feed would no longer be clamped; at most {wire.length - a}"
            )
        max_push = 0.125 * a if self.max_push is None else self.max_push
        channel = Channel(wire.cavity_radius, self.angle)
        depth = channel.release_depth(wire.hard_core)
        # a node released at depth t in [depth, depth + sub-push] must lie d inside the wall
        n_sub = max(1, math.ceil(push / max_push - 1e-9))
        if depth + push / n_sub >= channel.chord() - depth:
            raise ValueError(
                f"the channel lies at least the hard-core width {wire.hard_core:g} inside the "
                f"wall over a stretch too short for a sub-push of {push / n_sub:.4g} (entry "
                f"angle {self.angle} rad, cavity radius {wire.cavity_radius:g})"
            )
        return push, stop, max_push

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> Injection:
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown injection parameter(s): {', '.join(sorted(unknown))}")
        return cls(**d)


@dataclass(frozen=True, slots=True)
class InjectionStage:
    """One stage: the injected length, the equilibrium reached, and the forces on the feed.

    ``feed_force`` is the injection force ``[energy/length]``: the pusher's work over the
    stage per injected length (the clamp's reaction integrated over the sub-pushes, minus
    ``release_drop``), so that Σ F ΔL_in is the energy stored. ``clamp_reaction`` is the
    rigid clamp's reaction along the channel at the stage's equilibrium ``[energy/length]``
    (dE/dL_in only while no node is released). ``release_drop`` is the energy the wire gave
    up relaxing after this stage's releases ``[energy]``. ``free`` marks the nodes not held
    by the channel; ``released`` counts those released during this stage's push.
    """

    injected_length: float
    positions: np.ndarray
    energy: EnergyTerms
    result: MinimizeResult
    feed_force: float
    free: np.ndarray
    released: int
    clamp_reaction: float = math.nan
    release_drop: float = math.nan


@dataclass(frozen=True, slots=True)
class InjectionResult:
    """The stages of one injection, in order, and why it stopped.

    ``stop_reason`` is ``"length"`` (the stop length is in) or ``"jammed"`` (the feed force
    exceeded ``jam_force``, or the push was blocked at the mouth); ``stop_message`` says more.
    """

    wire: Wire
    injection: Injection
    initial: np.ndarray
    stages: tuple[InjectionStage, ...]
    seconds: float
    stop_reason: str
    stop_message: str
    rest_angles: np.ndarray | None = None

    @property
    def injected_lengths(self) -> np.ndarray:
        """L_in of every stage, shape (n_stages,) ``[length]``."""
        return np.array([s.injected_length for s in self.stages])

    @property
    def feed_forces(self) -> np.ndarray:
        """F, the injection force (work per length) of every stage, shape (n_stages,)
        ``[energy/length]``."""
        return np.array([s.feed_force for s in self.stages])

    @property
    def clamp_reactions(self) -> np.ndarray:
        """The clamp's reaction at every stage's equilibrium, shape (n_stages,)
        ``[energy/length]``: not the injection force (see :class:`InjectionStage`)."""
        return np.array([s.clamp_reaction for s in self.stages])

    @property
    def packing_fractions(self) -> np.ndarray:
        """φ = h L_in / (π R_c²) of every stage (h the hard-core width)."""
        return packing_fraction(self.wire, self.injected_lengths)

    @property
    def converged(self) -> bool:
        """Every stage reached a stable equilibrium."""
        return all(s.result.converged for s in self.stages)

    @property
    def failed_stages(self) -> list[tuple[float, str]]:
        """(L_in, why) of every stage that did not reach equilibrium."""
        return [(s.injected_length, s.result.message) for s in self.stages
                if not s.result.converged]  # fmt: skip

    def energies(self) -> dict[str, np.ndarray]:
        """Energy by term at every stage (no ``confinement``: there is no trap)."""
        keys = ("bending", "stretching", "hard_core", "wall", "total")
        return {k: np.array([s.energy.to_dict()[k] for s in self.stages]) for k in keys}


def packing_fraction(wire: Wire, injected_length) -> np.ndarray:
    """φ = h L_in / (π R_c²): the area of a wire of thickness h = ``wire.hard_core`` over the
    cavity's.

    >>> float(packing_fraction(Wire(k_b=1, k_s=1e4, hard_core=0.002, cavity_radius=0.1), 0.5))
    0.03183098861837907
    """
    if wire.cavity_radius is None:
        raise ValueError("packing fraction needs a cavity")
    return (
        wire.hard_core
        * np.asarray(injected_length, dtype=float)
        / (math.pi * wire.cavity_radius**2)
    )


def clamp_reaction(gradient, fixed, channel: Channel) -> float:
    """The reaction of the clamp along the channel ``[energy/length]``: Σ over the
    prescribed nodes of ∂E/∂x_i · u (positive: pushing in costs energy).

    dE/dL_in while the prescribed set is fixed (the envelope theorem), not the injection
    force: every release drops the energy (see :class:`InjectionStage`)."""
    g = np.asarray(gradient)[np.asarray(fixed, dtype=bool)]
    return float(np.sum(g @ channel.direction))


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------

ProgressCallback = Callable[[int, int, InjectionStage], None]

#: The release kick's largest amplitude, in hard-core widths.
KICK_CAP = 0.1

#: Partial pushes (each followed by a relaxation) allowed in one sub-push before the mouth
#: counts as blocked, the wire inside pressed against the channel's end.
MAX_BLOCKED = 40


def run_injection(
    wire: Wire,
    injection: Injection | None = None,
    *,
    seed=None,
    progress: ProgressCallback | None = None,
) -> InjectionResult:
    """Inject ``wire`` into its cavity stage by stage, minimising at each.

    Parameters
    ----------
    wire : Wire
        With ``cavity_radius``; its hard-core width is the wire's thickness h.
    injection : Injection, optional
        Default :class:`Injection` ().
    seed : int, SeedSequence or Generator, optional
        Source of the rest-angle disorder and the release noise.
    progress : callable, optional
        ``progress(i, n_stages_planned, stage)`` after every stage.

    Returns
    -------
    InjectionResult
        Check ``converged``, ``failed_stages`` and ``stop_reason``.

    Examples
    --------
    >>> w = Wire(k_b=1, k_s=1e4, n_segments=20, hard_core=0.002, cavity_radius=0.1)
    >>> r = run_injection(w, Injection(stop_length=0.3), seed=0)
    >>> r.converged, r.stop_reason, round(float(r.injected_lengths[-1]), 12)
    (True, 'length', 0.3)
    """
    injection = Injection() if injection is None else injection
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    with one_blas_thread():
        return _Injector(wire, injection, rng).run(progress)


class _Injector:
    """The state of one injection: positions, free mask, injected length."""

    def __init__(self, wire: Wire, injection: Injection, rng: np.random.Generator):
        self.wire, self.inj, self.rng = wire, injection, rng
        self.push, self.stop, self.max_push = injection.resolve(wire)
        self.channel = Channel(wire.cavity_radius, injection.angle)
        self.depth = self.channel.release_depth(wire.hard_core)
        # drawn first, and only for an imperfect wire, as in the ramp
        self.rest = (rng.normal(0.0, wire.rest_angle_sd, wire.n_nodes - 2)
                     if wire.rest_angle_sd else None)  # fmt: skip
        self.sigma = np.arange(wire.n_nodes) * wire.rest_length
        self.injected = 0.0
        self.x = self.channel.positions(self.sigma, 0.0)
        self.free = np.zeros(wire.n_nodes, dtype=bool)

    def run(self, progress) -> InjectionResult:
        t0 = time.perf_counter()
        initial = self.x.copy()
        n_planned = max(1, math.ceil(self.stop / self.push - 1e-9))
        stages: list[InjectionStage] = []
        reason, message = "length", f"injected length {self.stop:g} reached"
        for i in range(n_planned):
            target = min(self.stop, (i + 1) * self.push)
            stage, blocked = self._stage(target)
            if blocked:
                reason, message = "jammed", blocked
                break
            stages.append(stage)
            if progress is not None:
                progress(i, n_planned, stage)
            jam = self.inj.jam_force
            if jam is not None and stage.feed_force > jam:
                reason = "jammed"
                message = (f"feed force {stage.feed_force:.4g} > jam_force {jam:g} at L_in = "
                           f"{stage.injected_length:.6g}")  # fmt: skip
                break
        return InjectionResult(
            wire=self.wire, injection=self.inj, initial=initial, stages=tuple(stages),
            seconds=time.perf_counter() - t0, stop_reason=reason, stop_message=message,
            rest_angles=self.rest,
        )  # fmt: skip

    def _stage(self, target: float) -> tuple[InjectionStage | None, str]:
        """Push to ``target`` in sub-pushes; returns (stage, "") or (None, why blocked).

        The pusher's work over a sub-push is the trapezoidal integral of the clamp's reaction
        with the prescribed set fixed (the envelope theorem); a release then lets the wire
        relax from a constraint the pusher did no work against, and the energy drop is
        subtracted: what is left, per injected length, is the injection force."""
        start = self.injected
        n_sub = max(1, math.ceil((target - self.injected) / self.max_push - 1e-9))
        eta = (target - self.injected) / n_sub
        released, failures, res = 0, [], None
        work = drop = 0.0
        for k in range(n_sub):
            blocked, w, res, bad = self._advance(eta)
            if blocked:
                return None, blocked
            work += w
            failures += [f"sub-push {k + 1}/{n_sub}: {m}" for m in bad]
            before = self._energy().terms(self.x).total
            n_rel = self._release()
            if n_rel:
                released += n_rel
                res = self._relax()
                if not res.converged:
                    failures.append(f"sub-push {k + 1}/{n_sub}, release: {res.message}")
                drop += before - self._energy().terms(self.x).total
        self.injected = target
        energy = self._energy()
        terms = energy.terms(self.x)
        if failures:
            res = replace(res, converged=False, message="; ".join(failures))
        stage = InjectionStage(
            injected_length=target, positions=self.x.copy(), energy=terms, result=res,
            feed_force=(work - drop) / (target - start), free=self.free.copy(),
            released=released, clamp_reaction=self._clamp()[0], release_drop=drop,
        )  # fmt: skip
        return stage, ""

    def _energy(self) -> FedWireEnergy:
        return FedWireEnergy(self.wire, self.free, rest_angles=self.rest)

    def _clamp(self) -> tuple[float, float]:
        """The clamp's reaction F along the channel at the current equilibrium, and its
        derivative dF/dL_in along the equilibrium branch with the prescribed set fixed (NaN
        where the free nodes' Hessian is not positive definite)."""
        energy = self._energy()
        force = clamp_reaction(energy(self.x)[1], ~self.free, self.channel)
        h = energy.hessian_csc(self.x)  # H_ff⁻¹ by the sparse LDLᵀ at every N
        return force, _branch_stiffness(h, self.free, self.channel.direction)

    def _advance(self, eta: float) -> tuple[str, float, MinimizeResult | None, list[str]]:
        """Move the channel's nodes in by ``eta``, relaxing the free nodes after every move.

        Returns (why blocked or "", the pusher's work, the last relaxation, the messages of
        relaxations that failed). Where collision detection finds that the channel's nodes
        would touch the wire inside before the end of the move, they go half of the safe way,
        the free nodes relax (the hard core pushes the wire inside aside), and the move goes
        on: at most :data:`MAX_BLOCKED` such partial moves before the mouth counts as
        blocked. The work of each move is the trapezoidal integral of the clamp's reaction
        between the equilibria before and after it."""
        fixed = ~self.free
        left, work, bad = eta, 0.0, []
        f0, k0 = self._clamp()
        for _ in range(MAX_BLOCKED):
            step = np.zeros_like(self.x)
            step[fixed] = left * self.channel.direction
            safe = max_safe_fraction(self.x, step)
            taken = left if safe >= 1.0 else 0.5 * safe * left
            self.x = self.x + (taken / left) * step
            self.injected += taken
            left -= taken
            res = self._relax()
            if not res.converged:
                bad.append(res.message)
            f1, k1 = self._clamp()
            work += _hermite_work(f0, k0, f1, k1, taken)
            f0, k0 = f1, k1
            if left <= 0.0:
                return "", work, res, bad
        return (
            (
                f"the push is blocked at the mouth at L_in = {self.injected:.6g}: the channel's "
                f"nodes kept touching the wire inside ({MAX_BLOCKED} partial pushes)"
            ),
            work,
            None,
            bad,
        )

    def _release(self) -> int:
        """Free the prescribed nodes that are at least the release depth in; kick them."""
        t = self.injected - self.sigma
        new = ~self.free & (t >= self.depth)
        idx = np.flatnonzero(new)
        if idx.size == 0:
            return 0
        self.free |= new
        if self.inj.noise > 0:
            n = np.array([-self.channel.direction[1], self.channel.direction[0]])
            kick = np.zeros_like(self.x)
            amp = self.inj.noise * self.wire.rest_length * self.rng.standard_normal(idx.size)
            # at most a tenth of the hard-core width: a larger kick, radial where the entry is
            # near-tangential, throws the node into the wall's barrier (referee's S10)
            cap = KICK_CAP * self.wire.hard_core
            amp = np.clip(amp, -cap, cap)
            kick[idx] = amp[:, None] * n
            safe = min(max_safe_fraction(self.x, kick),
                       disc_exit_fraction(self.x[self.free], kick[self.free],
                                          self.wire.cavity_radius))  # fmt: skip
            self.x = self.x + (kick if safe >= 1.0 else 0.5 * safe * kick)
        return int(idx.size)

    def _relax(self) -> MinimizeResult:
        """Minimise over the free nodes, the channel's held."""
        energy = FedWireEnergy(self.wire, self.free, rest_angles=self.rest)
        if not self.free.any():
            e = energy(self.x)[0]
            return MinimizeResult(
                x=self.x.copy(), energy=e, max_force=0.0, iterations=0, evaluations=1,
                hessian_evaluations=0, converged=True, ftol=self.inj.ftol,
                message="no free node: nothing to minimise", method="newton",
            )  # fmt: skip
        # the raw CSC arrays, no SciPy matrix per iteration; up to DENSE_LIMIT degrees of
        # freedom the nonzeros alone, with the prescribed rows pinned: the pattern the dense
        # Hessian of before gave the factorisation, so the iterates are the same bit for bit
        pinned = self.x.size <= DENSE_LIMIT
        res = newton(
            energy, self.x,
            hess=lambda x: energy.hessian_csc(x, pinned=pinned),
            hess_fallback=lambda x: energy.hessian_csc(x, project_contacts=True, pinned=pinned),
            ftol=self.inj.ftol, maxiter=self.inj.maxiter, max_step=self.inj.max_step,
            step_limit=self._step_limit, feasible=self._feasible,
            curvature_tol=STABILITY_TOL, metric=node_lengths(self.wire), fixed=~self.free,
        )  # fmt: skip
        self.x = res.x
        return res

    def _step_limit(self, x, p) -> float:
        f = self.free
        return min(max_safe_fraction(x, p), disc_exit_fraction(x[f], p[f], self.wire.cavity_radius))

    def _feasible(self, x) -> bool:
        xf = x[self.free]
        r2 = self.wire.cavity_radius**2
        return bool(np.all(np.einsum("ij,ij->i", xf, xf) < r2)) and not has_crossings(x)


def _branch_stiffness(hessian, free, direction) -> float:
    """dF/dL_in of the clamp's reaction along an equilibrium branch ``[energy/length²]``:
    vᵀHv - (Hv)_fᵀ H_ff⁻¹ (Hv)_f, v moving every prescribed node along ``direction``, the
    free nodes following at equilibrium. NaN where H_ff is not positive definite."""
    free = np.asarray(free, dtype=bool)
    n = free.size
    v = np.zeros((n, 2))
    v[~free] = direction
    v = v.ravel()
    hv = np.asarray(hessian @ v).ravel()
    fd = np.repeat(free, 2)
    if not fd.any():
        return float(v @ hv)
    if isinstance(hessian, CSC):  # sparse: H_ff⁻¹ by the sparse LDLᵀ, not a dense Cholesky
        return _branch_stiffness_sparse(hessian, fd, v, hv)
    return _branch_stiffness_dense(hessian, fd, v, hv)


def _branch_stiffness_dense(hessian, fd, v, hv) -> float:
    """:func:`_branch_stiffness` with H_ff⁻¹ from the dense Cholesky of H_ff."""
    h = hessian.toarray() if sp.issparse(hessian) else np.asarray(hessian)
    try:
        c = np.linalg.cholesky(h[np.ix_(fd, fd)])
    except np.linalg.LinAlgError:
        return math.nan
    z = np.linalg.solve(c, hv[fd])
    return float(v @ hv - z @ z)


def _branch_stiffness_sparse(hessian: CSC, fd, v, hv) -> float:
    """:func:`_branch_stiffness` with H_ff⁻¹ from the sparse LDLᵀ of H with the prescribed
    rows and columns made the identity's (positive definite exactly where H_ff is): the
    chain's fill, where the dense Cholesky is O(N³). The same number to round-off."""
    pinned = pin_rows(hessian, ~fd)
    if pinned is None:  # a prescribed row's diagonal not stored: the dense way
        return _branch_stiffness_dense(hessian.tocsc(), fd, v, hv)
    f = LDLT().factorize(pinned)
    if not f.positive_definite:
        return math.nan
    b = np.where(fd, hv, 0.0)
    y = f.solve(b)
    if not np.isfinite(y).all():
        return math.nan
    return float(v @ hv - b[fd] @ y[fd])


def _hermite_work(f0: float, k0: float, f1: float, k1: float, eta: float) -> float:
    """∫F dL over a move of ``eta`` from the reaction and its slope at both ends: the
    trapezoidal rule with its end correction (fourth order; the trapezoidal rule alone where
    a slope is unknown)."""
    work = 0.5 * (f0 + f1) * eta
    if math.isfinite(k0) and math.isfinite(k1):
        work += eta**2 * (k0 - k1) / 12.0
    return work
