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
from typing import Literal

import numpy as np
from threadpoolctl import threadpool_limits

from .energy import EnergyTerms, WireEnergy, confinement_weights
from .geometry import disc_exit_fraction, has_crossings, max_safe_fraction
from .minimize import MinimizeResult, newton, powell
from .model import Wire

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

#: Stability tolerance τ ``[energy/length³]``: an equilibrium is accepted as a minimum when no
#: eigenvalue of the Hessian per unit length (the pencil (H, M), M the length of wire each node
#: stands for, :func:`node_lengths`) lies below -τ. Per unit length, the eigenvalues are those
#: of the continuum wire: the confinement alone contributes 2λ (λ >= 1 in the paper), the
#: straight wire just above its Euler load has -4 to -27 (N = 10⁴, λ = 7 to 12.6). τ is far
#: below both and far above round-off (docs/model.md, "Minimisation to equilibrium").
STABILITY_TOL = 1e-3

Method = Literal["newton", "powell"]


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


#: Powell: the longest move of a node in one line search, in segment lengths (the interval its
#: continuous collision detection and its neighbour list cover).
POWELL_REACH = 0.25
#: Powell: the first trial step of each line search, in segment lengths (then twice the last).
POWELL_STEP = 1e-3
#: Powell: NR's stopping rule by default, a sweep lowering the energy by less than this fraction
#: ends the stage (Numerical Recipes' example uses 1e-6; ours lets ``maxiter`` decide).
POWELL_RTOL = 1e-12

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

    def __post_init__(self):
        if self.maxiter is None and self.method in DEFAULT_MAXITER:
            object.__setattr__(self, "maxiter", DEFAULT_MAXITER[self.method])
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
    ``wire.rest_angle_sd == 0``).
    """

    wire: Wire
    ramp: Ramp
    initial: np.ndarray
    stages: tuple[Stage, ...]
    seconds: float
    rest_angles: np.ndarray | None = None

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


def minimize_wire(
    wire: Wire,
    positions,
    lam: float,
    *,
    method: Method = "newton",
    ftol: float = 1e-6,
    maxiter: int = 5000,
    max_step: float = 0.5,
    rng: np.random.Generator | None = None,
    rest_angles=None,
    fixed=None,
    rtol: float | None = None,
    anticipate_contacts: bool = True,
) -> MinimizeResult:
    """Minimise the wire's energy at trap strength ``lam`` from ``positions``, never crossing.

    Newton: every step is limited by continuous collision detection
    (:func:`crumple.geometry.max_safe_fraction`) and every accepted configuration is checked
    by the exact crossing test, so the wire cannot pass through itself. Powell: each line
    search only looks along the part of its line that the same collision detection allows
    (no node moves further than :data:`POWELL_REACH` segments), and the point it ends at is
    taken only if it passes the crossing test; compiled (Numba) without a cavity. With a
    cavity (``wire.cavity_radius``) the steps are also limited so that no node reaches the wall
    (:func:`crumple.geometry.disc_exit_fraction`), and a configuration with a node on or
    outside it is never accepted.

    Parameters
    ----------
    wire : Wire
    positions : array_like, shape (wire.n_nodes, 2)
        Start ``[length]``, must not cross itself.
    lam : float
        Trap strength λ.
    method : {"newton", "powell"}
    ftol : float
        Equilibrium tolerance on the largest node force ``[energy/length]``.
    maxiter : int
    max_step : float
        Newton: largest node displacement per step ``[length]`` (the largest trust radius).
    rng : numpy.random.Generator
        Powell's random directions (required for Powell).
    rest_angles : array_like, shape (wire.n_nodes - 2,), optional
        Rest turning angles of an imperfect wire (see ``Wire.rest_angle_sd``).
    fixed : array_like of bool, shape (wire.n_nodes,), optional
        Nodes held at their starting positions (Newton only): a clamped end is its two end
        nodes. With any node fixed, no rigid motion is a zero mode.
    rtol : float, optional
        Powell: NR's stopping rule (a sweep lowering the energy by less than this fraction
        ends the stage); default :data:`POWELL_RTOL`.
    anticipate_contacts : bool
        Newton: let the model see the hard core of the pairs a step is about to enter (its
        curvature at the edge, as a one-sided spring: :meth:`WireEnergy.barriers`), so that a
        step stops at a contact instead of being cut by collision detection. The energy and
        the equilibrium and stability criteria are the same; only the path changes, and with
        it, after a snap-through, which local minimum a stage reaches (docs/performance.md,
        "Branches"). False: the engine before issue 9's item 3, kept for comparison
        (``benchmarks/bench_scale.py contacts``).

    Examples
    --------
    >>> w = Wire(k_b=5, k_s=5e5, n_segments=20)
    >>> r = minimize_wire(w, initial_state(w, seed=0), lam=1.0)
    >>> r.converged
    True
    """
    energy = WireEnergy(wire, lam, rest_angles=rest_angles)
    x0 = np.array(positions, dtype=np.float64)
    if x0.shape != (wire.n_nodes, 2):
        raise ValueError(f"positions must have shape ({wire.n_nodes}, 2), got {x0.shape}")
    if has_crossings(x0):
        raise ValueError("the starting configuration crosses itself")
    radius = wire.cavity_radius
    if radius is not None and not _inside(x0, radius):
        worst = float(np.max(np.hypot(*x0.T)))
        raise ValueError(
            f"the starting configuration leaves the cavity: a node at |x| = {worst:.6g} >= "
            f"cavity_radius {radius:.6g}"
        )
    free_rotation = True
    if fixed is not None:
        fixed = np.asarray(fixed)
        if fixed.dtype != np.bool_ or fixed.shape != (wire.n_nodes,):
            raise ValueError(f"fixed must be a boolean array of shape ({wire.n_nodes},)")
        if method != "newton":
            raise ValueError("fixed nodes need method='newton'")
        free_rotation = not fixed.any()

    def feasible(x):
        return (radius is None or _inside(x, radius)) and not has_crossings(x)

    if method == "newton":
        return newton(
            energy,
            x0,
            hess=lambda x: energy.hessian(x, dense=False),
            # contacts projected on their positive part; bending and stretching exact (measured:
            # projecting the joints too doubled the iterations of the default ramp)
            hess_fallback=lambda x: energy.hessian(x, dense=False, project_contacts=True),
            ftol=ftol,
            maxiter=maxiter,
            max_step=max_step,
            step_limit=_step_limit(radius),
            feasible=feasible,
            curvature_tol=STABILITY_TOL,
            metric=node_lengths(wire),
            zero_modes=(lambda x: _symmetry_modes(x, wire, lam)) if free_rotation else None,
            fixed=fixed,
            barriers=energy.barriers if anticipate_contacts else None,
        )
    if method == "powell":
        if rng is None:
            raise ValueError("Powell needs a random generator for its directions (rng=...)")
        reach = POWELL_REACH * wire.rest_length
        return powell(
            lambda x: energy(x)[0],
            x0,
            rng=rng,
            gradient=lambda x: energy(x)[1],
            feasible=feasible,
            step_limit=_step_limit(radius),
            compiled=energy.line_kernels(reach) if radius is None else None,
            ftol=ftol,
            rtol=POWELL_RTOL if rtol is None else rtol,
            maxiter=maxiter,
            step=POWELL_STEP * wire.rest_length,
            reach=reach,
        )
    raise ValueError(f"method must be 'newton' or 'powell', got {method!r}")


def node_lengths(wire: Wire) -> np.ndarray:
    """The length of wire each node stands for, shape (n_nodes,) ``[length]``: L0/N inside,
    L0/(2N) at the two ends. The metric of the stability test: with it the eigenvalues of the
    Hessian are those of the continuum wire, independent of N."""
    return confinement_weights(wire.n_nodes, "per-length", wire.length)


def _inside(x, radius) -> bool:
    """Every node strictly inside the cavity (the exact test of an accepted configuration)."""
    return bool(np.all(np.einsum("ij,ij->i", x, x) < radius * radius))


def _step_limit(radius):
    """The safe fraction of a step: no node-segment contact, and no node reaching the wall.

    Testing the nodes against the wall is enough: the disc is convex, so a segment whose ends
    are inside lies inside."""
    if radius is None:
        return max_safe_fraction

    def limit(x, p):
        return min(max_safe_fraction(x, p), disc_exit_fraction(x, p, radius))

    return limit


def _symmetry_modes(x, wire, lam):
    """Rigid motions that leave the energy unchanged: the rotation about the trap's centre
    (the trap is isotropic), and the two translations when there is no trap. A cavity
    (centred at the origin) allows no translation, and the rotation only about the origin."""
    center = np.asarray(wire.trap_center)
    cavity = wire.cavity_radius is not None
    if cavity and lam != 0 and np.any(center != 0):
        return np.zeros((0, x.size))
    r = x - (0.0 if cavity else center)
    modes = [np.column_stack([-r[:, 1], r[:, 0]]).ravel()]
    if lam == 0 and not cavity:
        modes += [np.tile([1.0, 0.0], len(x)), np.tile([0.0, 1.0], len(x))]
    return np.array(modes)


ProgressCallback = Callable[[int, int, Stage], None]


def run_ramp(
    wire: Wire,
    ramp: Ramp | None = None,
    *,
    seed=None,
    progress: ProgressCallback | None = None,
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
    rng = _rng(seed)
    # one BLAS thread: the matrices are small, threads only contend (measured 7x slower with
    # two busy cores) and change the summation order, hence the trajectory, between machines
    with threadpool_limits(limits=1, user_api="blas"):
        return _run_ramp(wire, ramp, rng, progress)


def _run_ramp(wire, ramp, rng, progress):
    t0 = time.perf_counter()
    # drawn first, and only for an imperfect wire, so that perfect wires keep their streams
    rest = rng.normal(0.0, wire.rest_angle_sd, wire.n_nodes - 2) if wire.rest_angle_sd else None
    x = initial_state(wire, ramp.initial_noise, seed=rng)
    initial = x.copy()
    stages: list[Stage] = []
    for i, lam in enumerate(ramp.lambdas):
        if ramp.stage_noise > 0:
            kick = ramp.stage_noise * wire.rest_length * rng.standard_normal(x.shape)
            safe = _step_limit(wire.cavity_radius)(x, kick)
            x = x + (kick if safe >= 1.0 else 0.5 * safe * kick)
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
        )
        moved = float(np.max(np.hypot(*(res.x - x).T)))
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
