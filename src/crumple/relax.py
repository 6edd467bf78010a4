"""Minimising one wire at one trap strength: the solver, its hooks and the wire's metric.

:func:`minimize_wire` is what every protocol calls for one equilibrium (the λ ramp of
:mod:`crumple.protocol`, the injection of :mod:`crumple.injection`): Newton (default) or the
paper's Powell on the wire's energy, with continuous collision detection as the step limit, the
crossing test as the feasibility check, and stability judged per unit length.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

import numpy as np
from numba import njit

from .energy import WireEnergy, confinement_weights
from .geometry import disc_exit_fraction, has_crossings
from .geometry.ccd import _approach, _safe_fraction
from .geometry.crossings import _has_crossings
from .geometry.curved import _curved_step, _largest_turn
from .minimize import MinimizeResult, newton, powell
from .model import Wire
from .relax_polish import _needs_polish, _polished

__all__ = ["CURVED_STEPS", "POWELL_RTOL", "STABILITY_TOL", "minimize_wire", "node_lengths"]

#: Stability tolerance τ ``[energy/length³]``: an equilibrium is accepted as a minimum when no
#: eigenvalue of the Hessian per unit length (the pencil (H, M), M the length of wire each node
#: stands for, :func:`node_lengths`) lies below -τ. Per unit length, the eigenvalues are those
#: of the continuum wire: the confinement alone contributes 2λ (λ >= 1 in the paper), the
#: straight wire just above its Euler load has -4 to -27 (N = 10⁴, λ = 7 to 12.6). τ is far
#: below both and far above round-off (docs/model.md, "Minimisation to equilibrium").
STABILITY_TOL = 1e-3
#: Decide stability with the element-form Hessian product
#: (:meth:`crumple.energy.WireEnergy.hessian_action`) where the assembled Hessian's float64
#: resolution exceeds τ and its inertia count found negative curvature (``minimize_accurate``).
#: On: it fixes the straight wire's stages at N = 10⁵ (stages 0–9 of the default ramp converged
#: and stable, where every one stopped before), and on every whole ramp measured with it (N =
#: 2000 and 10⁴ default ramps, the continuum study's stiff N = 1000 wire to Λ = 10⁶, its quick
#: profile) it never overruled the count and the iterates are those without it
#: (docs/performance.md, "Stability where float64 cannot assemble it"). False: the count alone
#: decides.
ACCURATE_STABILITY = True

#: Opt-in (False: straight steps only, the default engine): Newton's line search also tries
#: the curved point of each step, the chain with its segments turned
#: (:func:`crumple.geometry.curved_step`), and keeps the lower energy; only where no contact
#: acts (``WireEnergy.touching``). Measured (docs/performance.md, "Curved steps"): the default
#: N = 100 ramp 2954 → 2105 iterations over seeds 0–3 (CPU −2 %; the twenty-fourth stop, seeds
#: 0–5 with the other core busy: 29 % fewer iterations, CPU +26 %), per node 16 866 → 8348 (CPU
#: −41 %), the smooth stages 137 → 38, the buckling stage 51 → 9, the N = 10⁴ ramp of the
#: continuum wire (seed 0) 6224 → 5409 with every stage converged; off until the full
#: reproduction and several seeds at N = 10³–10⁴ have been run with it (an earlier form lost
#: a converged stage at N = 10⁴).
CURVED_STEPS = False
#: The curved point is offered only where no segment turns by more than this (radians, the
#: linearised rotation δφ = e × δe/|e|² of :func:`crumple.geometry.curved_step`): beyond
#: ~1 rad the linearised turn of a segment is no approximation of the step's (a step whose
#: neighbouring nodes move apart by more than a segment turns it by many radians). Measured
#: (eleventh stop): the first stage of the smooth ramp from the noisy straight wire at
#: N = 5 × 10⁴ took 1246 iterations with curved points of up to hundreds of radians, 58 with
#: this bound.
CURVED_MAX_TURN = 1.0

#: Newton's step where the exact Hessian H is indefinite (``minimize_wire(fallback=...)``):
#: "projected", the Hessian with its contact blocks projected on their positive part, shifted
#: by σM; "exact", H itself shifted by σM, with σ then searched downwards while the step stays
#: inside the trust radius (``minimize.newton(shift_descents=EXACT_SHIFT_DESCENTS)``); "auto",
#: "exact" for wires of more than :data:`EXACT_FALLBACK_ABOVE` segments, else "projected".
#: The projected Hessian is too stiff along a slide of pressed turns, and that costs more as
#: contacts multiply with N. Measured on the default ramp of the continuum wire (seed 0;
#: docs/performance.md, "The fallback by size"): iterations 725 → 765 (N = 100), 1197 → 977
#: (300), 1862 → 1143 (1000), 2544 → 1402 (2000), 6490 → 1893 (10⁴), every stage converged
#: and stable; CPU about equal at N ≤ 1000 and 1.2–4× less above. The threshold keeps every
#: ramp of the reproduction and of the continuum study (N ≤ 1000) on the branches it has
#: always reached, bit for bit: both fallbacks reach true minima, only which snap-through
#: branch differs. "caps" (opt-in) is "exact" with the blocks of the contacts at a joint's
#: cap (the closest point a segment's end) projected on their positive part: their eigenvalue,
#: about -2F/D, is the polyline's corner at the scale d, and it set the fallback's largest
#: shifts. Measured (docs/performance.md, "The joint caps' curvature"): it removes most of
#: those shifts, and the default ramp's contact stages take 11 % fewer iterations at N = 10⁴
#: (eight seeds, 7 % less CPU), as many at N ≤ 5000. Not the default: N = 10⁵ is unmeasured.
FALLBACK = "auto"
EXACT_FALLBACK_ABOVE = 1000
EXACT_SHIFT_DESCENTS = 4
FALLBACKS = ("auto", "projected", "exact", "caps")
#: Wires of more than this many segments take Newton's accurate steps
#: (``newton(accurate_steps=True)``: truncated CG on the element-form product where the
#: assembled Hessian cannot resolve τ) and the polish of a stage stopped at the force
#: resolution (``relax_polish``). Measured (docs/performance.md, "Accurate steps"): the
#: smooth stages of the continuum wire buckle on time and converge at N = 5 × 10⁴ and 10⁵,
#: where they could not. Like the exact fallback's threshold, it keeps every ramp of the
#: reproduction and of the continuum study (N ≤ 1000) on the branches it has reached.
ACCURATE_STEPS_ABOVE = 1000
#: Above this many segments (None: never) the contact springs of the Newton model also
#: release: a pair in the core that a step takes out of it loses the curvature its barrier
#: gives the Hessian (``WireEnergy.barriers(releasing=True)``). Why: at N = 10⁵, λ = 192.9
#: (twelfth stop, docs/performance.md "Contact stages at N = 10⁵") the ~200 pairs in the
#: core sit within 3 × 10⁻⁵ d of its edge, where the barrier's curvature jumps from 2ε/d² to
#: 0. Measured: with it that stage converged in 59 iterations (without it, not in 860 s of
#: CPU); the N = 10⁴ ramps 44/44 either way, curved 1429 iterations instead of 2037 (313 s
#: against 272 s CPU, more jobs beside it), straight 309 s against 302 s. Not below:
#: the default N = 100 ramp took 3–10 % fewer iterations but ~50 % more CPU (seeds 0–2), and
#: the reproduction keeps its iterates.
RELEASE_ABOVE: int | None = 1000
#: Above this many segments (None: never) the refactorised springs' step starts from the least
#: point of its model on the segment to the point where the solve with the factor ran out of
#: rounds (``newton(springs_from_segment=True)``). Measured (docs/performance.md, "The
#: refactorised springs' step from the segment's least point"): on 40 calls of an N = 10⁵
#: contact stage replayed both ways (``benchmarks/bench_springs.py``), 255 rounds
#: (factorisations) against 671; in N = 10⁵ stage 29 the step's rounds 661 against 4410 (18 s
#: CPU against 119 s). Not below: the reproduction keeps its iterates (with it, its per-node
#: runs move by round-off, ~10⁻⁹ relative).
SEGMENT_START_ABOVE: int | None = 1000
#: Above this many segments (None: never) a springs' step that lists more than
#: ``SPRINGS_SOLVE_LIMIT`` springs skips the solve with the factor and is the refactorised step
#: at once, a relisting's started from the listing before's step
#: (``newton(springs_solve_limit=...)``). Why: at N = 10⁵ the listings run to thousands of
#: springs, the solve (two joining a round, one solve each) ran out of rounds in most of
#: them and took as much CPU as the refactorised step that then finished the job. Measured in
#: docs/performance.md, "Straight to the refactorised springs' step". Not below: the
#: reproduction keeps its iterates.
SOLVE_LIMIT_ABOVE: int | None = 1000
SPRINGS_SOLVE_LIMIT = 1000
#: Above this many segments (None: never) a step that collision detection cuts stops where
#: the pairs that would touch are ``d + APPROACH_SKIN × skin`` apart (inside the barriers'
#: listing, outside the core: :func:`crumple.geometry.approach_fraction`), where that is
#: further than 0.8 of the contact (``newton(cut=...)``). Why: the listing holds the pairs of
#: the Verlet list (d + a tenth of a segment), so a step of hundreds of segments meets pairs
#: it did not list, and 0.8 of the contact leaves such a pair at a fifth of its gap, outside
#: the listing again: at N = 10⁵ a contact half a segment to ten segments away cost two to
#: four cut steps. Measured (docs/performance.md, "The last stages of the N = 10⁵ schedule"):
#: N = 10⁴ default ramps 6 % and 11 % fewer contact iterations (seeds 0, 1), 3 % and 7 % less
#: CPU; at N = 10⁵ stage 31 equal, stages 40 and 41 2.4× and 1.8× slower (more pairs listed,
#: more springs' solves, the late stages' cost). Off: opt-in until a better springs' step.
APPROACH_ABOVE: int | None = None
APPROACH_SKIN = 0.5
#: Above this many segments (None: never) the sparse factorisation's fill-reducing order is
#: also sought by a nested dissection of the nodes' positions (``newton(order_by_points=True)``)
#: and kept where its factor is the smallest. Why: a packed wire's Hessian couples nodes far
#: apart along the chain, and reverse Cuthill–McKee's band then fills. Measured in
#: docs/performance.md, "Nested dissection". Not below: the reproduction keeps its iterates
#: (another order changes them by round-off).
ORDER_BY_POINTS_ABOVE: int | None = 1000
#: Above this many segments (None: never) a round of the refactorised springs' step modifies
#: the last round's factor, a rank-one update or downdate per spring that joined or left,
#: where that is cheaper than a factorisation (``newton(springs_updates=True)``,
#: :mod:`crumple.linalg_update`). Why: a round changes some springs of thousands listed, and
#: refactorised the whole matrix for them. Measured in docs/performance.md, "Rank-one
#: modifications". Not below: the reproduction keeps its iterates.
UPDATES_ABOVE: int | None = 1000

Method = Literal["newton", "powell"]

#: Powell: the longest move of a node in one line search, in segment lengths (the interval its
#: continuous collision detection and its neighbour list cover).
POWELL_REACH = 0.25
#: Powell: the first trial step of each line search, in segment lengths (then twice the last).
POWELL_STEP = 1e-3
#: Powell: NR's stopping rule by default, a sweep lowering the energy by less than this fraction
#: ends the stage (Numerical Recipes' example uses 1e-6; ours lets ``maxiter`` decide).
POWELL_RTOL = 1e-12


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
    curved_steps: bool | None = None,
    fallback: str | None = None,
    callback: Callable[[int, np.ndarray, float, float], None] | None = None,
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
    curved_steps : bool, optional
        Newton: try each step also along the curve that turns the segments instead of moving
        their ends in straight lines (:func:`crumple.geometry.curved_step`), and take the lower
        energy of the two (``newton(retract=...)``): a turn then costs no spurious stretch.
        Only at points where no contact acts. Default :data:`CURVED_STEPS` (off); never with
        fixed nodes. Like ``anticipate_contacts`` it
        changes the path, not the criteria (docs/performance.md, "Curved steps").
    fallback : {"auto", "projected", "exact", "caps"}, optional
        Newton: the step where the exact Hessian is indefinite (:data:`FALLBACK`, the default,
        says what each is and what was measured). Like ``curved_steps``, it changes the path,
        not the criteria.
    callback : callable, optional
        Newton: ``callback(iteration, positions, energy, max_force)`` after every accepted
        step, for progress on stages that take minutes to hours at large N. ``positions``
        (wire.n_nodes, 2) is the solver's own point, read-only (each step makes a new one, so
        a reference stays valid). A saddle escape is reported under the number of the
        iteration before it. Above ``ACCURATE_STEPS_ABOVE`` segments, a stage ended at its
        force resolution goes on in a polish (``crumple.relax_polish``: steps in the
        displacement from the end, then possibly a retry in the positions), reported too, its
        iterations counted on from the passes before; the polish's positions are the end's
        plus the displacement, rounded, and its ``max_force`` that of the unrounded sum
        (recomputed at the rounded positions it is at the first pass's resolution). The
        stage's result is the polish's end where it converged below the first pass's largest
        force, else the retry's where that converged, else the first pass's end: the last
        point reported is the result only where its pass is.

    Examples
    --------
    >>> from crumple.protocol import initial_state
    >>> w = Wire(k_b=5, k_s=5e5, n_segments=20)
    >>> r = minimize_wire(w, initial_state(w, seed=0), lam=1.0)
    >>> r.converged
    True
    """
    fallback = resolve_fallback(fallback, wire)
    energy = WireEnergy(wire, lam, rest_angles=rest_angles)
    x0, fixed = _checked_start(wire, positions, fixed, method)
    radius = wire.cavity_radius

    def feasible(x):  # x: the minimiser's own finite (n_nodes, 2) array, checked no further
        return (radius is None or _inside(x, radius)) and not _has_crossings(x)

    if method == "powell":
        if callback is not None:
            raise ValueError("callback needs method='newton'")
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
    if method != "newton":
        raise ValueError(f"method must be 'newton' or 'powell', got {method!r}")
    kw = _newton_options(wire, energy, fixed, fallback, curved_steps, anticipate_contacts)
    kw.update(ftol=ftol, maxiter=maxiter, max_step=max_step, feasible=feasible)
    report = None if callback is None else _read_only(callback)
    res = newton(energy, x0, **kw, callback=report)
    # a stage that stopped at the force resolution of its positions: Newton again in the
    # displacement from its end, the elastic forces from the segments' sums (relax_polish)
    large = wire.n_segments > ACCURATE_STEPS_ABOVE
    if large and _needs_polish(res, ftol):
        return _polished(energy, res, kw, ftol, report)
    return res


def _read_only(callback):
    """``newton``'s callback with the point it is given made read-only: the solver's own."""

    def report(it, x, e, fmax):
        view = x.view()
        view.flags.writeable = False
        callback(it, view, e, fmax)

    return report


def _checked_start(wire: Wire, positions, fixed, method):
    """The start as a float array and ``fixed`` as a boolean mask (or None), checked: the
    shape, no crossing, inside the cavity, and fixed nodes only with Newton."""
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
    if fixed is not None:
        fixed = np.asarray(fixed)
        if fixed.dtype != np.bool_ or fixed.shape != (wire.n_nodes,):
            raise ValueError(f"fixed must be a boolean array of shape ({wire.n_nodes},)")
        if method != "newton":
            raise ValueError("fixed nodes need method='newton'")
    return x0, fixed


def _newton_options(wire, energy, fixed, fallback, curved_steps, anticipate_contacts) -> dict:
    """:func:`crumple.minimize.newton`'s keywords for this wire and energy (``fallback``: as
    :func:`resolve_fallback` gives it), but the stopping rule, the step cap and the feasibility test
    (:func:`minimize_wire` adds them)."""
    free_rotation = fixed is None or not fixed.any()  # with any node fixed, no rigid motion
    curved = (CURVED_STEPS if curved_steps is None else bool(curved_steps)) and free_rotation
    hess = energy.hessian_csc  # one bound method: the fallback below is this very object
    cut = (
        _approach_cut(wire, energy)
        if anticipate_contacts and _above(wire, APPROACH_ABOVE)
        else None
    )
    return dict(
        hess=hess,
        hess_fallback=_fallback_hessian(energy, fallback, hess),
        shift_descents=0 if fallback == "projected" else EXACT_SHIFT_DESCENTS,
        step_limit=_step_limit(wire.cavity_radius),
        curvature_tol=STABILITY_TOL,
        metric=node_lengths(wire),
        zero_modes=(lambda x: _symmetry_modes(x, wire, energy.lam)) if free_rotation else None,
        fixed=fixed,
        barriers=_barriers(energy, wire) if anticipate_contacts else None,
        # the stability test where the assembled H cannot resolve τ (N ~ 10⁵): the
        # element-form product (crumple.energy_action); on unless ACCURATE_STABILITY is off
        hess_action=energy.hessian_action if ACCURATE_STABILITY else None,
        retract=_curved_retraction(energy) if curved else None,
        accurate_steps=wire.n_segments > ACCURATE_STEPS_ABOVE,
        springs_from_segment=_above(wire, SEGMENT_START_ABOVE),
        springs_updates=_above(wire, UPDATES_ABOVE),
        springs_solve_limit=SPRINGS_SOLVE_LIMIT if _above(wire, SOLVE_LIMIT_ABOVE) else None,
        cut=cut,
        order_by_points=_above(wire, ORDER_BY_POINTS_ABOVE),
    )


def _approach_cut(wire: Wire, energy: WireEnergy):
    """``newton(cut=...)``: the fraction of a cut step at which the pairs that would touch
    are ``d + APPROACH_SKIN × skin`` apart (:data:`APPROACH_ABOVE`); 0 (the default cut)
    where the cavity's wall is what cuts it."""
    gap = wire.hard_core + APPROACH_SKIN * energy.skin
    radius = wire.cavity_radius

    def cut(x, p, safe):
        p = p.reshape(x.shape)
        if radius is not None and disc_exit_fraction(x, p, radius) <= safe:
            return 0.0
        return _approach(x, p, safe, gap)

    return cut


def _above(wire: Wire, threshold: int | None) -> bool:
    """Whether ``wire`` has more segments than ``threshold`` (None: never)."""
    return threshold is not None and wire.n_segments > threshold


def _fallback_hessian(energy: WireEnergy, fallback: str, hess):
    """``newton(hess_fallback=...)`` of a resolved ``fallback``. "projected": every contact
    projected on its positive part, bending and stretching exact (measured: projecting the
    bending blocks too doubled the iterations of the default ramp); "caps": only the contacts
    at a joint's cap (the closest point a segment's end) projected; "exact": ``hess`` itself,
    the very object the minimiser calls for H, so that it reuses the H it has just
    evaluated."""
    if fallback == "exact":
        return hess
    if fallback == "projected":
        return lambda x: energy.hessian_csc(x, project_contacts=True)
    if fallback == "caps":
        return lambda x: energy.hessian_csc(x, project_contacts="caps")
    raise ValueError(f"fallback must be 'projected', 'exact' or 'caps' here, got {fallback!r}")


def resolve_fallback(fallback: str | None, wire: Wire) -> str:
    """``fallback`` (None: :data:`FALLBACK`) as "projected", "exact" or "caps" for ``wire``.

    >>> resolve_fallback("auto", Wire(k_b=5, k_s=5e5, n_segments=100))
    'projected'
    >>> resolve_fallback(None, Wire(k_b=5, k_s=5e5, n_segments=2000))
    'exact'
    """
    fallback = FALLBACK if fallback is None else fallback
    if fallback not in FALLBACKS:
        raise ValueError(f"fallback must be one of {', '.join(FALLBACKS)}; got {fallback!r}")
    if fallback == "auto":
        return "exact" if wire.n_segments > EXACT_FALLBACK_ABOVE else "projected"
    return fallback


def _barriers(energy, wire):
    """The contact springs of the Newton model (:meth:`WireEnergy.barriers`), releasing above
    :data:`RELEASE_ABOVE` segments."""
    if _above(wire, RELEASE_ABOVE):
        return lambda x, step: energy.barriers(x, step, releasing=True)
    return energy.barriers


def _curved_retraction(energy: WireEnergy):
    """Newton's curved trial point (:func:`crumple.geometry.curved_step`), offered only where
    no contact acts at x (``energy.touching``): measured, in contact stages the curved steps
    lengthened the fallback's steps into more contacts and cost CPU (docs/performance.md,
    "Curved steps"); None tells the line search there is no curved point."""

    last = [None, False]  # the point asked about, and whether a contact acts there

    def retract(x, p, alpha):
        if x is not last[0]:  # once per line search (its trials all start from x)
            last[0], last[1] = x, energy.touching(x)
        if last[1] or _largest_turn(x, p, alpha) > CURVED_MAX_TURN:
            return None
        return _curved_step(x, p, alpha)

    return retract


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
    are inside lies inside. ``x`` and ``p`` are the callers' own finite float arrays of shape
    (n_nodes, 2) (:func:`crumple.geometry.max_safe_fraction` without its input checks)."""
    if radius is None:
        return _safe_fraction

    def limit(x, p):
        return min(_safe_fraction(x, p), disc_exit_fraction(x, p, radius))

    return limit


def _symmetry_modes(x, wire, lam):
    """Rigid motions that leave the energy unchanged: the rotation about the trap's centre
    (the trap is isotropic), and the two translations when there is no trap. A cavity
    (centred at the origin) allows no translation, and the rotation only about the origin."""
    cavity = wire.cavity_radius is not None
    cx, cy = (float(c) for c in wire.trap_center)
    if cavity and lam != 0 and (cx != 0 or cy != 0):
        return np.zeros((0, x.size))
    if cavity:
        cx = cy = 0.0
    free = lam == 0 and not cavity
    return _rigid_modes(np.ascontiguousarray(x, dtype=np.float64), cx, cy, free)


@njit(cache=True)
def _rigid_modes(x, cx, cy, free):
    """The rotation about (cx, cy), -(y - cy), x - cx at each node, and with ``free`` the two
    translations, as the rows of a (1 or 3, x.size) array."""
    n = x.shape[0]
    modes = np.zeros((3 if free else 1, 2 * n))
    for i in range(n):
        modes[0, 2 * i] = -(x[i, 1] - cy)
        modes[0, 2 * i + 1] = x[i, 0] - cx
        if free:
            modes[1, 2 * i] = 1.0
            modes[2, 2 * i + 1] = 1.0
    return modes
