"""Loading protocols: the quasi-static confinement ramp of the paper's Section II.

The trap strength λ is raised stage by stage; at every stage the energy is minimised to
equilibrium starting from the previous stage's equilibrium. The wire starts straight, centred
on the trap, with a seeded small transverse perturbation. Replicas draw independent random
streams from one seed (:meth:`numpy.random.SeedSequence.spawn`), so results do not depend on
the number of worker processes.

Replica-to-replica variety: the paper's comes from random Powell directions. A minimiser that
reaches equilibrium is deterministic, so here it comes from (i) the initial transverse noise,
which picks the buckling direction and the folding sequence, and optionally (ii) a random
displacement of every node at each stage (``stage_noise``), scaled down by continuous collision
detection so that it can never make the wire cross itself.
"""

from __future__ import annotations

import itertools
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field

import numpy as np
from threadpoolctl import ThreadpoolController

from . import relax
from .energy import EnergyTerms, WireEnergy
from .minimize import MinimizeResult
from .model import Wire
from .protocol_coarse import CoarseSummary, check_coarsen, coarse_path, coarsen_factor
from .relax import (
    POWELL_RTOL,
    STABILITY_TOL,
    Method,
    _step_limit,
    minimize_wire,
    node_lengths,
)

__all__ = [
    "DEFAULT_MAXITER",
    "PAPER_LAMBDAS",
    "STABILITY_TOL",
    "Ramp",
    "RampResult",
    "Stage",
    "default_schedule",
    "initial_state",
    "minimize_wire",
    "node_lengths",
    "replica_seeds",
    "run_ramp",
    "run_replicas",
]

#: The trap strengths shown in the paper's Fig. 2.
PAPER_LAMBDAS = (70.0, 200.0, 300.0, 1000.0)


def default_schedule(
    lam_min: float = 1.0,
    lam_max: float = 2000.0,
    n: int = 40,
    include: Sequence[float] = PAPER_LAMBDAS,
) -> tuple[float, ...]:
    """Geometric λ schedule from ``lam_min`` to ``lam_max`` with ``include`` merged in.

    The default (1 to 2000, 40 geometric steps, plus the paper's 70, 200, 300 and 1000) has 44
    stages: the paper's Table 1 range.

    >>> s = default_schedule()
    >>> len(s), s[0], s[-1], 1000.0 in s
    (44, 1.0, 2000.0, True)
    """
    if not (0 < lam_min < lam_max) or not (math.isfinite(lam_max)):
        raise ValueError(f"need 0 < lam_min < lam_max, got {lam_min}, {lam_max}")
    if n < 2:
        raise ValueError(f"n must be >= 2, got {n}")
    values = set(np.geomspace(lam_min, lam_max, n).round(10).tolist())
    values.update(float(v) for v in include if lam_min <= v <= lam_max)
    return tuple(sorted(values))


#: ``Ramp.maxiter``'s default per method: Newton iterations, Powell sweeps per stage.
DEFAULT_MAXITER = {"newton": 5000, "powell": 20}


@dataclass(frozen=True, slots=True, kw_only=True)
class Ramp:
    """A quasi-static confinement ramp.

    Parameters
    ----------
    lambdas : sequence of float
        Trap strengths, strictly increasing, >= 0. Default :func:`default_schedule`.
    initial_noise : float
        Standard deviation of the transverse displacement of each node of the initial straight
        wire, in units of the segment rest length. Default 0.01.
    stage_noise : float
        Standard deviation of a random displacement of each node before every stage, in units
        of the segment rest length (0: none, the default).
    stop_tol : float or None
        Stop early when no node moved by more than this ``[length]`` between two successive
        stages ("the structure no longer changes"). None: run every stage.
    method : {"newton", "powell"}
        ``newton`` reaches equilibrium (default); ``powell`` is the paper's method.
    ftol : float
        Equilibrium: largest node force ``[energy/length]`` at most ``ftol``. Default 1e-6.
    maxiter : int or None
        Iterations per stage (Newton iterations, or Powell sweeps). Default (None) depends on
        ``method`` (:data:`DEFAULT_MAXITER`) and is resolved here, so ``to_dict`` and the run
        id hold the number: 5000 for Newton (a snap-through of an imperfect wire can take ~1300
        Newton iterations through a region of negative curvature, measured; the perfect
        default ramp needs at most ~350 per stage); 20 for Powell, whose iteration is a sweep
        of line searches along all 2N directions (compiled: ~0.5 s per stage at N = 100;
        Numerical Recipes' code, the paper's likely one, allows at most 200).
    max_step : float
        Largest node displacement per Newton step ``[length]``: the largest trust radius of
        :func:`crumple.minimize.newton`, which adapts below it. A length, independent of N
        (before issue 9 it was in units of the segment length, which made the number of
        steps grow as N). Default 0.5 L0: effectively the adaptive radius alone.
    powell_rtol : float or None
        Powell only: Numerical Recipes' stopping rule, a sweep lowering the energy by less than
        this fraction ends the stage (0: always ``maxiter`` sweeps). Default (None): resolved
        here to :data:`POWELL_RTOL` for Powell; None for Newton (and then not in the run id).
    curved_steps : bool or None
        Newton only: also try the curved trial point of each step (the retraction of
        :mod:`crumple.geometry.curved`, which turns segments without stretching them) where no
        contact acts (:func:`crumple.relax.minimize_wire`). Default (None): resolved here to
        :data:`crumple.relax.CURVED_STEPS` for Newton, so that ``to_dict``, the run id and the
        sweep workers hold the switch; always False for Powell.
    fallback : {"auto", "projected", "exact", "caps"} or None
        Newton only: its step where the exact Hessian is indefinite. Default (None): resolved
        here to :data:`crumple.relax.FALLBACK`, "auto": the exact Hessian shifted for wires of
        more than :data:`crumple.relax.EXACT_FALLBACK_ABOVE` segments, the contact-projected
        one below (measured; docs/performance.md, "The fallback by size"); "auto" for Powell.
        "caps": the exact one with the contacts at a segment's end projected (opt-in).
    coarsen : int
        Newton only: run the ramp first on the same continuum wire with N / ``coarsen``
        segments, and start each stage from the last equilibrium moved as that coarse wire
        moved over the stage (:mod:`crumple.protocol_coarse`; every stage is still minimised
        to the wire's own equilibrium; ``initial_noise`` is then drawn at the coarse wire's
        nodes, in its segment's units; opt-in, the coarse ramp itself predicted in turn:
        :data:`crumple.protocol_coarse.COARSEST`). 1 (default): the plain ramp. For the
        perfect elastic wire with per-length confinement, no cavity and no stage noise.

    Examples
    --------
    >>> Ramp(lambdas=(1, 10, 100)).lambdas
    (1.0, 10.0, 100.0)
    >>> Ramp(lambdas=(10, 1))
    Traceback (most recent call last):
    ...
    ValueError: lambdas must be strictly increasing, got (10, 1)
    """

    lambdas: tuple[float, ...] = field(default_factory=default_schedule)
    initial_noise: float = 0.01
    stage_noise: float = 0.0
    stop_tol: float | None = None
    method: Method = "newton"
    ftol: float = 1e-6
    maxiter: int | None = None
    max_step: float = 0.5
    powell_rtol: float | None = None
    curved_steps: bool | None = None
    fallback: str | None = None
    coarsen: int = 1

    def __post_init__(self):
        if self.maxiter is None and self.method in DEFAULT_MAXITER:
            object.__setattr__(self, "maxiter", DEFAULT_MAXITER[self.method])
        if self.curved_steps is None:
            object.__setattr__(self, "curved_steps", self.method == "newton" and relax.CURVED_STEPS)
        if not isinstance(self.curved_steps, (bool, np.bool_)):
            raise ValueError(f"curved_steps must be True or False, got {self.curved_steps!r}")
        object.__setattr__(self, "curved_steps", bool(self.curved_steps))
        if self.curved_steps and self.method != "newton":
            raise ValueError("curved_steps is a parameter of method='newton' only")
        if self.fallback is None:
            object.__setattr__(
                self, "fallback", relax.FALLBACK if self.method == "newton" else "auto"
            )
        if self.fallback not in relax.FALLBACKS:
            raise ValueError(f"fallback must be one of {', '.join(relax.FALLBACKS)}; got "
                             f"{self.fallback!r}")  # fmt: skip
        if self.fallback != "auto" and self.method != "newton":
            raise ValueError("fallback is a parameter of method='newton' only")
        if self.method == "powell" and self.powell_rtol is None:
            object.__setattr__(self, "powell_rtol", POWELL_RTOL)
        if self.method != "powell" and self.powell_rtol is not None:
            raise ValueError("powell_rtol is a parameter of method='powell' only")
        if self.powell_rtol is not None:
            r = float(self.powell_rtol)
            if not (math.isfinite(r) and r >= 0):
                raise ValueError(f"powell_rtol must be >= 0, got {self.powell_rtol!r}")
            object.__setattr__(self, "powell_rtol", r)
        try:
            lams = tuple(float(v) for v in self.lambdas)
        except (TypeError, ValueError):
            raise ValueError(f"lambdas must be numbers, got {self.lambdas!r}") from None
        if not lams:
            raise ValueError("lambdas must not be empty")
        if not all(math.isfinite(v) and v >= 0 for v in lams):
            raise ValueError(f"lambdas must be finite and >= 0, got {self.lambdas!r}")
        if any(b <= a for a, b in itertools.pairwise(lams)):
            raise ValueError(f"lambdas must be strictly increasing, got {self.lambdas!r}")
        object.__setattr__(self, "lambdas", lams)
        for name in ("initial_noise", "stage_noise"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
            object.__setattr__(self, name, v)
        if self.stop_tol is not None and not (self.stop_tol > 0):
            raise ValueError(f"stop_tol must be positive or None, got {self.stop_tol!r}")
        if self.method not in ("newton", "powell"):
            raise ValueError(f"method must be 'newton' or 'powell', got {self.method!r}")
        if not (math.isfinite(self.ftol) and self.ftol > 0):
            raise ValueError(f"ftol must be positive, got {self.ftol!r}")
        if int(self.maxiter) < 1:
            raise ValueError(f"maxiter must be >= 1, got {self.maxiter!r}")
        if not (math.isfinite(self.max_step) and self.max_step > 0):
            raise ValueError(f"max_step must be positive, got {self.max_step!r}")
        self._check_coarsen()

    def _check_coarsen(self):
        c = coarsen_factor(self.coarsen)  # a whole float too: a sweep's numbers are floats
        object.__setattr__(self, "coarsen", c)
        if c > 1 and self.method != "newton":
            raise ValueError("coarsen is a parameter of method='newton' only")
        if c > 1 and self.stage_noise > 0:
            raise ValueError("coarsen > 1 needs stage_noise = 0 (the coarse ramp predicts "
                             "each stage's start)")  # fmt: skip

    def to_dict(self) -> dict:
        d = asdict(self)
        d["lambdas"] = list(self.lambdas)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Ramp:
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown ramp parameter(s): {', '.join(sorted(unknown))}")
        return cls(**d)


@dataclass(frozen=True, slots=True)
class Stage:
    """One stage of a ramp: the trap strength, the configuration reached and how."""

    lam: float
    positions: np.ndarray
    energy: EnergyTerms
    result: MinimizeResult


@dataclass(frozen=True, slots=True)
class RampResult:
    """The stages of one ramp, in order, with what produced them.

    ``rest_angles`` is the replica's quenched rest turning angles (None for a straight wire,
    ``wire.rest_angle_sd == 0``). ``coarse``: what the coarse ramp of ``Ramp(coarsen=m)`` did
    (:class:`crumple.protocol_coarse.CoarseSummary`; None for the plain ramp, and for a ramp
    read from a file).
    """

    wire: Wire
    ramp: Ramp
    initial: np.ndarray
    stages: tuple[Stage, ...]
    seconds: float
    rest_angles: np.ndarray | None = None
    coarse: CoarseSummary | None = None

    @property
    def lambdas(self) -> np.ndarray:
        return np.array([s.lam for s in self.stages])

    @property
    def converged(self) -> bool:
        """Every stage reached equilibrium."""
        return all(s.result.converged for s in self.stages)

    @property
    def failed_stages(self) -> list[tuple[float, str]]:
        """(λ, the minimiser's message) of every stage that did not reach equilibrium."""
        return [(s.lam, s.result.message) for s in self.stages if not s.result.converged]

    def energies(self) -> dict[str, np.ndarray]:
        """Energy by term at every stage, arrays of shape (n_stages,) (``wall`` with a cavity)."""
        keys = ("bending", "stretching", "confinement", "hard_core", "total")
        if self.wire.cavity_radius is not None:
            keys = (*keys, "wall")
        return {k: np.array([s.energy.to_dict()[k] for s in self.stages]) for k in keys}

    def at(self, lam: float) -> Stage:
        """The stage at trap strength ``lam`` (exactly one of the ramp's values)."""
        for s in self.stages:
            if s.lam == float(lam):
                return s
        raise KeyError(f"no stage at lambda = {lam}; stages: {[s.lam for s in self.stages]}")


def _rng(seed) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(seed)


def initial_state(wire: Wire, noise: float = 0.01, *, seed=None) -> np.ndarray:
    """A straight wire along x, centred on the trap, with a small random transverse kink.

    Node ``i`` sits at ``(-L0/2 + i L0/N, 0) + c`` plus a Gaussian transverse displacement of
    standard deviation ``noise * L0/N``. Never crosses itself for ``noise < 0.5`` (a transverse
    displacement keeps the x order of the nodes).

    Returns
    -------
    ndarray, shape (wire.n_nodes, 2)
        ``[length]``

    >>> x = initial_state(Wire(k_b=5, k_s=5e5, n_segments=4), noise=0.0)
    >>> x.tolist()
    [[-0.5, 0.0], [-0.25, 0.0], [0.0, 0.0], [0.25, 0.0], [0.5, 0.0]]
    """
    if not (math.isfinite(noise) and 0 <= noise < 0.5):
        raise ValueError(f"initial noise must be in [0, 0.5), got {noise}")
    rng = _rng(seed)
    n = wire.n_nodes
    x = np.zeros((n, 2))
    x[:, 0] = np.linspace(-0.5 * wire.length, 0.5 * wire.length, n)
    x[:, 1] = noise * wire.rest_length * rng.standard_normal(n)
    x += np.asarray(wire.trap_center)
    return x


ProgressCallback = Callable[[int, int, Stage], None]
IterationCallback = Callable[[int, float, int, float, float], None]
CoarseProgressCallback = Callable[[int, int, int, Stage], None]


def run_ramp(
    wire: Wire,
    ramp: Ramp | None = None,
    *,
    seed=None,
    progress: ProgressCallback | None = None,
    iteration: IterationCallback | None = None,
    coarse_progress: CoarseProgressCallback | None = None,
) -> RampResult:
    """Run a quasi-static ramp: raise λ stage by stage, minimising at each.

    Parameters
    ----------
    wire : Wire
    ramp : Ramp, optional
        Default :class:`Ramp` ().
    seed : int, SeedSequence or Generator, optional
        Source of the initial noise, the stage noise and Powell's directions.
    progress : callable, optional
        ``progress(i, n_stages, stage)`` after every stage.
    iteration : callable, optional
        ``iteration(i, lam, it, energy, max_force)`` after every accepted Newton step of
        stage ``i`` (:func:`crumple.relax.minimize_wire`'s ``callback``, with its caveats):
        progress within stages that take minutes to hours at large N. It sees no positions
        and cannot change the path. Newton only: with ``ramp.method == "powell"`` it is an
        error.
    coarse_progress : callable, optional
        ``coarse_progress(n_segments, i, n_stages, stage)`` after every stage of the coarse
        ramp that predicts this one (``ramp.coarsen`` > 1; :mod:`crumple.protocol_coarse`),
        ``n_segments`` the segments of the wire that stage ran on. With nested levels
        (:data:`crumple.protocol_coarse.COARSEST`) every level reports, the coarsest first. At
        N = 10⁵ the coarse ramp runs for minutes before the wire's first stage. Never called
        for the plain ramp.

    Returns
    -------
    RampResult
        Check ``result.converged`` and ``result.failed_stages``: a stage that did not reach
        equilibrium is kept and reported, never hidden.

    Examples
    --------
    >>> w = Wire(k_b=5, k_s=5e5, n_segments=30)
    >>> r = run_ramp(w, Ramp(lambdas=(1, 10, 100)), seed=1)
    >>> r.converged, len(r.stages)
    (True, 3)
    """
    ramp = Ramp() if ramp is None else ramp
    if iteration is not None and ramp.method != "newton":
        raise ValueError(f"iteration needs method='newton', got {ramp.method!r}")
    check_coarsen(wire, ramp.coarsen)
    rng = _rng(seed)
    # one BLAS thread: the matrices are small, threads only contend (measured 7x slower with
    # two busy cores) and change the summation order, hence the trajectory, between machines
    with one_blas_thread():
        return _run_ramp(wire, ramp, rng, progress, iteration, coarse_progress)


_BLAS: list[ThreadpoolController] = []  # the controller, made at the first use


def one_blas_thread():
    """A context in which the BLAS libraries use one thread (``threadpoolctl``): those loaded
    when it was first called (NumPy's and SciPy's OpenBLAS are loaded with ``crumple``; a BLAS
    a caller loads later is left alone). The controller is made once per process (a forked
    worker reuses its parent's): making it reads the process's memory map, 0.8 ms, 0.4 % of a
    default N = 100 ramp (13 µs once made)."""
    if not _BLAS:
        _BLAS.append(ThreadpoolController())
    return _BLAS[0].limit(limits=1, user_api="blas")


def _stage_callback(iteration, i, lam):
    """``minimize_wire``'s callback that reports stage ``i``'s steps to ``iteration``."""
    if iteration is None:
        return None
    return lambda it, x, energy, max_force: iteration(i, lam, it, energy, max_force)


def _stage_start(wire, ramp, rng, path, i, x):
    """Where stage ``i`` starts from the last equilibrium ``x``: moved as the coarse wire
    moved (``path``, ``ramp.coarsen`` > 1), or kicked by the stage noise (scaled down by
    collision detection so that it cannot cross), or ``x`` itself."""
    if path is not None:
        return path.start(i, x)
    if ramp.stage_noise > 0:
        kick = ramp.stage_noise * wire.rest_length * rng.standard_normal(x.shape)
        safe = _step_limit(wire.cavity_radius)(x, kick)
        return x + (kick if safe >= 1.0 else 0.5 * safe * kick)
    return x


def _coarse_stages(coarse_progress, wire):
    """``progress`` of the coarse ramp on ``wire``: its stages to ``coarse_progress``."""
    if coarse_progress is None:
        return None
    return lambda i, n, stage: coarse_progress(wire.n_segments, i, n, stage)


def _run_ramp(wire, ramp, rng, progress, iteration=None, coarse_progress=None):
    t0 = time.perf_counter()
    # drawn first, and only for an imperfect wire, so that perfect wires keep their streams
    rest = rng.normal(0.0, wire.rest_angle_sd, wire.n_nodes - 2) if wire.rest_angle_sd else None
    path = None
    if ramp.coarsen > 1:  # the coarse ramp draws the initial noise, at its own nodes

        def run(w, r, g):  # each coarse level reports its stages with its wire's segments
            return _run_ramp(w, r, g, _coarse_stages(coarse_progress, w), None, coarse_progress)

        path = coarse_path(wire, ramp, rng, run)
        x = path.initial
    else:
        x = initial_state(wire, ramp.initial_noise, seed=rng)
    initial = x.copy()
    stages: list[Stage] = []
    for i, lam in enumerate(ramp.lambdas):
        before = x
        x = _stage_start(wire, ramp, rng, path, i, x)
        res = minimize_wire(
            wire,
            x,
            lam,
            method=ramp.method,
            ftol=ramp.ftol,
            maxiter=ramp.maxiter,
            max_step=ramp.max_step,
            rng=rng,
            rest_angles=rest,
            rtol=ramp.powell_rtol,
            curved_steps=ramp.curved_steps,
            fallback=ramp.fallback,
            callback=_stage_callback(iteration, i, lam),
        )
        moved = float(np.max(np.hypot(*(res.x - (x if path is None else before)).T)))
        x = res.x
        terms = WireEnergy(wire, lam, rest_angles=rest).terms(x)
        stage = Stage(lam=lam, positions=x, energy=terms, result=res)
        stages.append(stage)
        if progress is not None:
            progress(i, len(ramp.lambdas), stage)
        if ramp.stop_tol is not None and i > 0 and moved < ramp.stop_tol and res.converged:
            break
    return RampResult(
        wire=wire,
        ramp=ramp,
        initial=initial,
        stages=tuple(stages),
        seconds=time.perf_counter() - t0,
        rest_angles=rest,
        coarse=None if path is None else path.summary(),
    )


def _replica_job(args):
    wire, ramp, seed_seq = args
    return run_ramp(wire, ramp, seed=np.random.default_rng(seed_seq))


def replica_seeds(seed, n_replicas: int) -> list[np.random.SeedSequence]:
    """Independent seed sequences for ``n_replicas`` replicas of one base seed.

    >>> [s.spawn_key for s in replica_seeds(7, 3)]
    [(0,), (1,), (2,)]
    """
    if int(n_replicas) < 1:
        raise ValueError(f"n_replicas must be >= 1, got {n_replicas}")
    base = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return base.spawn(int(n_replicas))


def run_replicas(
    wire: Wire,
    ramp: Ramp | None = None,
    *,
    n_replicas: int = 10,
    seed: int | None = 0,
    workers: int | None = 1,
    progress: Callable[[int, int, RampResult], None] | None = None,
) -> list[RampResult]:
    """Independent replicas of a ramp, optionally in parallel processes.

    Replica ``r`` uses ``SeedSequence(seed).spawn(n_replicas)[r]``, so the results do not depend
    on ``workers``.

    Parameters
    ----------
    workers : int or None
        Processes; 1 runs in this process, None uses every available core.
    progress : callable, optional
        ``progress(done, n_replicas, result)`` as replicas finish.
    """
    ramp = Ramp() if ramp is None else ramp
    seeds = replica_seeds(seed, n_replicas)
    jobs = [(wire, ramp, s) for s in seeds]
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    workers = max(1, min(int(workers), len(jobs)))
    out: list[RampResult] = []
    if workers == 1:
        for i, job in enumerate(jobs):
            out.append(_replica_job(job))
            if progress is not None:
                progress(i + 1, len(jobs), out[-1])
        return out
    # "spawn" avoids forking a process that holds threads (numba, BLAS)
    import multiprocessing as mp

    ctx = mp.get_context("spawn" if sys.platform != "linux" else "forkserver")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        for i, res in enumerate(pool.map(_replica_job, jobs)):
            out.append(res)
            if progress is not None:
                progress(i + 1, len(jobs), res)
    return out
