"""The stage-level results of one experiment's store (:class:`Series`) and the measures that
every section applies to them: α (R_g ~ λ^α), D_M at one stage, local slopes, convergence.

:func:`_series` reads a store (:func:`crumple.sweep.load`) with the observables the sweep
stored at every stage of every run (:mod:`crumple.stage_observables`): ``r_max``, the RMS
radius, contacts, the largest turning angle, the contour length, the loops, and γ = E_s/E_b
(NaN at straight stages, the convention ``load`` applies). Nothing here simulates.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import paper
from ..fit import fit_power_law
from ..observables import mass_size_exponent
from ..stage_observables import CONTACT_FACTOR, END_FRACTION, OBSERVABLES, STRAIGHT, is_straight
from .common import Estimate, _combine, _f

__all__ = ["CONTACT_FACTOR", "END_FRACTION", "LAM_FIG3", "STRAIGHT", "Series"]

#: Older names under which the sections read three of the stored observables (``Series.obs``
#: holds every entry of :data:`crumple.stage_observables.OBSERVABLES` under its own name too).
_ALIASES = {
    "rms": "radius_of_gyration",
    "max_angle": "max_turning_angle",
    "length": "contour_length",
}
#: The stage of Fig. 3 (and of the D_M rows).
LAM_FIG3 = 1000.0


def _load(store: Path):
    from ..sweep import IncompleteSweepWarning, load

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", IncompleteSweepWarning)
        ds = load(store, positions=True)
    incomplete = [str(w.message) for w in caught if issubclass(w.category, IncompleteSweepWarning)]
    return ds, incomplete


def _label(v):
    """A point coordinate: a float, or a string label as stored (a list-valued parameter such
    as ``lambdas``, whose label is its JSON, when points set their own λ schedule)."""
    return v if isinstance(v, str) else float(v)


def _point_keys(ds, levels) -> list[tuple]:
    if "point" not in ds.dims:
        return [()]
    idx = ds.indexes["point"]
    return (
        [tuple(_label(v) for v in t) for t in idx]
        if len(levels) > 1
        else [(_label(v),) for v in idx]
    )


@dataclass
class Series:
    """Stage-level results of one experiment: arrays (point, replica, lam)."""

    keys: list[tuple]
    lam: np.ndarray
    positions: np.ndarray  # (point, replica, lam, node, 2)
    energies: dict[str, np.ndarray]
    converged: np.ndarray
    max_force: np.ndarray
    done: np.ndarray  # (point, replica)
    incomplete: list[str]
    hard_core: float
    obs: dict[str, np.ndarray] = field(default_factory=dict)
    iterations: np.ndarray | None = None  # (point, replica, lam): Newton iterations, Powell sweeps
    confinement: str = paper.CONFINEMENT
    wire: dict = field(default_factory=dict)  # the sweep manifest's wire table (as given)

    def index(self, key) -> int:
        return self.keys.index(tuple(float(k) for k in key))

    @property
    def per_node(self) -> bool:
        """Confinement λ r² per node (Eq. 1 as printed)."""
        return self.confinement == paper.PER_NODE

    @property
    def lam_discrete(self) -> np.ndarray:
        """λ in Eq. (1)'s discrete moduli (per node) ``[energy/length²]``: the stage λ for a
        per-node wire, λ Δs for a per-length one (their trap energies agree then)."""
        return self.lam if self.per_node else self.lam * self.ds

    def reindex(self, keys: list[tuple]) -> Series:
        """This series over ``keys`` (those of another experiment): the points it lacks are
        NaN (never run: ``done`` false), so a measure over a missing point is "not measured"."""
        keys = [tuple(float(v) for v in k) for k in keys]
        if keys == self.keys:
            return self
        at = [self.keys.index(k) if k in self.keys else -1 for k in keys]

        def take(a: np.ndarray) -> np.ndarray:
            fill = False if a.dtype == bool else np.nan
            out = np.full((len(keys), *a.shape[1:]), fill, dtype=a.dtype)
            for i, j in enumerate(at):
                if j >= 0:
                    out[i] = a[j]
            return out

        return Series(
            keys=keys,
            lam=self.lam,
            positions=take(self.positions),
            energies={k: take(v) for k, v in self.energies.items()},
            converged=take(self.converged),
            max_force=take(self.max_force),
            done=take(self.done),
            incomplete=self.incomplete,
            hard_core=self.hard_core,
            obs={k: take(v) for k, v in self.obs.items()},
            confinement=self.confinement,
            wire=self.wire,
        )

    @property
    def ds(self) -> float:
        """Rest length of a segment (L0 = 1)."""
        return 1.0 / (self.positions.shape[3] - 1)

    def j(self, lam: float) -> int:
        return int(np.argmin(np.abs(self.lam - lam)))

    @property
    def replicas(self) -> int:
        return self.positions.shape[1]

    def valid(self, p: int, r: int, j: int) -> bool:
        return bool(np.isfinite(self.positions[p, r, j]).all())


def _series(store: Path, levels: tuple[str, ...]) -> Series:
    ds, incomplete = _load(store)
    keys = _point_keys(ds, levels)
    if "point" not in ds.dims:
        ds = ds.expand_dims("point")
    m = json.loads(ds.attrs["sweep"])
    hard_core = float(m.get("wire", {}).get("hard_core", 1e-5))
    if ds.attrs.get("protocol") == "injection":
        return _injection_series(ds, keys, incomplete, hard_core, m.get("wire", {}))
    s = Series(
        keys=keys,
        lam=ds["lam"].values.astype(float),
        positions=ds["positions"].values,
        energies={
            t: ds[f"E_{t}"].values
            for t in ("bending", "stretching", "confinement", "hard_core", "total")
        },
        converged=ds["converged"].values,
        max_force=ds["max_force"].values,
        done=ds["done"].values,
        incomplete=incomplete,
        hard_core=hard_core,
        iterations=ds["iterations"].values if "iterations" in ds else None,
        confinement=str(m.get("wire", {}).get("confinement", paper.CONFINEMENT)),
        wire=dict(m.get("wire", {})),
    )
    s.obs.update({k: ds[k].values for k in OBSERVABLES})
    s.obs.update({k: s.obs[v] for k, v in _ALIASES.items()})
    # γ = E_s/E_b is the energy split of a *bent* wire; on a straight wire (every joint
    # straighter than STRAIGHT rad: the start of a ramp, or a soft wire that collapses into a
    # compressed rod) E_b is round-off and γ is undefined: NaN (load's ``gamma``), counted in
    # the report.
    s.obs["straight"] = is_straight(s.obs["max_angle"])
    s.obs["gamma"] = ds["gamma"].values
    return s


def _injection_series(ds, keys, incomplete, hard_core, wire: dict) -> Series:
    """An injection store as a :class:`Series`: ``lam`` holds the injected lengths L_in (not
    a λ: the name is the ramp's axis), the
    energies are the injection's (``wall`` added, ``confinement`` zero), ``obs`` the
    injection's observables (:data:`crumple.injection_observables.INJECTION_OBSERVABLES`)
    and ``gamma``."""
    from ..injection_observables import INJECTION_OBSERVABLES

    energies = {t: ds[f"E_{t}"].values for t in ("bending", "stretching", "hard_core", "wall",
                                                   "total")}  # fmt: skip
    energies["confinement"] = np.zeros_like(energies["total"])
    s = Series(
        keys=keys,
        lam=ds["L_in"].values.astype(float),
        positions=ds["positions"].values,
        energies=energies,
        converged=ds["converged"].values,
        max_force=ds["max_force"].values,
        done=ds["done"].values,
        incomplete=incomplete,
        hard_core=hard_core,
        wire=dict(wire),
    )
    s.obs.update({k: ds[k].values for k in INJECTION_OBSERVABLES})
    s.obs["gamma"] = ds["gamma"].values
    s.obs["stop_reason"] = ds["stop_reason"].values
    return s


def _dm_fit(x, *, rg="r_max", method="exact", fit_range=paper.DM_RANGE):
    """D_M and its regression error; NaN where M(R) = 0 somewhere in the range (no wire
    near the centre of mass: the log-log fit is undefined there)."""
    try:
        f = mass_size_exponent(x, rg=rg, method=method, fit_range=fit_range)
    except ValueError:
        return math.nan, math.nan
    return f.exponent, f.stderr


def _alpha(s: Series, p: int, which: str = "r_max", lam_range=paper.ALPHA_RANGE) -> Estimate:
    vals, errs, used = [], [], None
    for r in range(s.replicas):
        y = s.obs[which][p, r]
        ok = np.isfinite(y) & (s.lam >= lam_range[0]) & (s.lam <= lam_range[1])
        if ok.sum() < 3:
            continue
        f = fit_power_law(s.lam[ok], y[ok])
        vals.append(f.exponent)
        errs.append(f.stderr)
        used = f.fit_range
    return _combine(vals, errs, used)


def _dm(s: Series, p: int, lam: float = LAM_FIG3, **kw) -> Estimate:
    j = s.j(lam)
    vals, errs = [], []
    for r in range(s.replicas):
        if s.valid(p, r, j):
            v, e = _dm_fit(s.positions[p, r, j], **kw)
            vals.append(v)
            errs.append(e)
    return _combine(vals, errs, tuple(kw.get("fit_range", paper.DM_RANGE)))


def _local_slopes(lam, y):
    """d ln y / d ln λ between successive stages, at the geometric midpoints."""
    ok = np.isfinite(y) & (y > 0)
    lx, ly = np.log(lam[ok]), np.log(y[ok])
    return np.exp(0.5 * (lx[1:] + lx[:-1])), np.diff(ly) / np.diff(lx)


def _convergence(s: Series) -> dict:
    ran = np.isfinite(s.max_force)
    return {
        "runs": int(s.done.size),
        "runs_done": int(s.done.sum()),
        "stages": int(ran.sum()),
        "stages_converged": int((s.converged & ran).sum()),
        "largest_force": _f(float(np.nanmax(s.max_force))) if ran.any() else None,
        "incomplete": s.incomplete,
    }
