"""The iterate and the bookkeeping of :func:`crumple.minimize.newton`. Private, model-blind.

Split from :mod:`crumple.minimize` so that the minimiser's loop and its state each stay one
concept; the steps' modules (:mod:`crumple.minimize_barriers`, :mod:`crumple.minimize_krylov`,
...) read and write its fields.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(slots=True)
class _State:
    """The iterate and the bookkeeping of :func:`newton`."""

    x: np.ndarray
    e: float
    g: np.ndarray
    fmax: float
    radius: float = math.inf
    it: int = 0
    nfev: int = 1
    nhev: int = 0
    fres: float = 0.0
    skip: int = 0
    skip_left: int = 0
    sigma: float = 0.0
    mask: np.ndarray | None = None  # the fixed entries of x.ravel(); never moved
    factor: object = None  # the factor the last direction was solved with
    model: tuple | None = None  # (matrix, shift) it is the factor of; None: not known
    zero_modes: Callable | None = None
    hess_action: Callable | None = None  # the accurate H v, or None
    exact: bool = True  # the last direction is the exact Hessian's Newton step
    escapes: int = 0  # saddle escapes taken
    accurate_escapes: int = 0  # of them, along the accurate mode (the assembled one's failed)
    refusals: int = 0  # points the accurate product found stable that the decrease test refused
    unstable: bool = False  # stopped at an equilibrium that is not a minimum
    refine: bool = False  # forces below their resolution but a Newton step still pays: go on
    refine_note: str = ""
    curved: int = 0  # accepted steps that were the retracted (curved) point
    descents: int = 0  # the fallback's σ search: divisions of σ at most (0: none)
    krylov: int = 0  # conjugate-gradient iterations of the accurate steps (minimize_krylov)
    accurate_steps: bool = False  # newton(accurate_steps=...)
    springs_from_segment: bool = False  # newton(springs_from_segment=...)
    springs_updates: bool = False  # newton(springs_updates=...)
    springs_solve_limit: int | None = None  # newton(springs_solve_limit=...)
    cut: Callable | None = None  # newton(cut=...)
    springs: tuple | None = None  # the rows of the last springs' step (minimize_barriers)
    entered: np.ndarray | None = None  # the index rows of the springs that step entered
    pending: np.ndarray | None = None  # a refused point's step, for the next iteration
    best: float | None = None  # the lowest energy by more than its resolution (``patience``)
    best_it: int = 0  # the iteration that reached it
