"""What every section of the report shares: estimates with uncertainties, their arithmetic,
the record a section measures into, and the table entries built from it.

Conventions of every number (stated in the report too):

* an exponent is fitted per replica (:func:`crumple.fit.fit_power_law`, or
  :func:`crumple.observables.mass_size_exponent`); the value is the replica mean and its
  uncertainty σ combines in quadrature the standard error of that mean and the rms of the
  per-replica regression errors (a perfect wire's replicas are near copies, docs/model.md, so
  the replica spread alone would understate the error of a fit): :func:`_combine`;
* a value pooled over parameter points (the paper's "universal" D_M and α) is the mean over the
  points, σ² = (between-point variance + mean σ_p²) / n_points: :func:`_pool`;
* the verdict is "agrees" when ``|ours - paper| <= 2σ``, else "differs": :func:`_row`;
* non-converged stages are counted and reported, never dropped silently.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import paper
from ..fit import fit_power_law

if TYPE_CHECKING:
    from .series import Series


@dataclass(frozen=True, slots=True, kw_only=True)
class Record:
    """What one section measured: its table entries and the numbers behind its figures.

    ``rows`` (one per paper value, :func:`_row`), ``alternatives`` (:func:`_alt`) and
    ``claims`` go into the report's tables in the registry's order; ``extra`` into
    ``results.json`` (``extra``); ``detail`` holds what only the section's figures and
    discussion read (arrays, configurations), never written to ``results.json``.
    """

    rows: tuple[dict, ...] = ()
    alternatives: tuple[dict, ...] = ()
    claims: tuple[dict, ...] = ()
    extra: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    detail: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))


@dataclass(frozen=True, slots=True, kw_only=True)
class Context:
    """What a section's ``measure`` reads: the profile, the stage-level results of the
    experiments it names (``READS``) and the records of the sections it names (``NEEDS``)."""

    profile: Mapping[str, Any]
    series: Mapping[str, Series]
    records: Mapping[str, Record]

    @property
    def replicas(self) -> int:
        """Replicas of the main experiments (the profile's ``replicas``)."""
        return self.profile["replicas"]


@dataclass(frozen=True)
class Estimate:
    """A replica-averaged value with its uncertainty (module docstring)."""

    value: float
    sigma: float
    n: int
    fit_range: tuple[float, float] | None = None
    spread: float = 0.0  # standard deviation over replicas (or points)

    def to_dict(self) -> dict:
        return {
            "value": _f(self.value),
            "sigma": _f(self.sigma),
            "n": self.n,
            "fit_range": None if self.fit_range is None else [_f(v) for v in self.fit_range],
            "spread": _f(self.spread),
        }


def _f(v):
    return None if v is None or not np.isfinite(v) else float(v)


def _combine(values, stderrs, fit_range=None) -> Estimate:
    v = np.asarray(values, float)
    e = np.asarray(stderrs, float)
    ok = np.isfinite(v) & np.isfinite(e)
    v, e = v[ok], e[ok]
    n = int(v.size)
    if n == 0:
        return Estimate(math.nan, math.nan, 0, fit_range)
    sd = float(v.std(ddof=1)) if n > 1 else 0.0
    sigma = math.hypot(sd / math.sqrt(n), float(np.sqrt(np.mean(e**2))))
    return Estimate(float(v.mean()), sigma, n, fit_range, sd)


def _pool(estimates: list[Estimate], fit_range=None) -> Estimate:
    """Mean over points; σ² = (between-point variance + mean σ_p²) / n (conservative: the
    between-point variance already holds part of the per-point noise). ``fit_range`` default:
    the union of the points' ranges."""
    ests = [e for e in estimates if e.n > 0 and np.isfinite(e.value)]
    n = len(ests)
    if fit_range is None:
        rs = [e.fit_range for e in ests if e.fit_range is not None]
        fit_range = (min(r[0] for r in rs), max(r[1] for r in rs)) if rs else None
    if n == 0:
        return Estimate(math.nan, math.nan, 0, fit_range)
    v = np.array([e.value for e in ests])
    s = np.array([e.sigma for e in ests])
    between = float(v.var(ddof=1)) if n > 1 else 0.0
    sigma = math.sqrt((between + float(np.mean(s**2))) / n)
    return Estimate(float(v.mean()), sigma, n, fit_range, math.sqrt(between))


def _fit_replicas(x, y) -> Estimate:
    """Power law of ``y[r]`` against ``x`` for each replica ``r`` (finite, positive points,
    at least 3), combined as in :func:`_combine`."""
    x = np.asarray(x, float)
    vals, errs, lo, hi = [], [], math.inf, -math.inf
    for yr in np.atleast_2d(np.asarray(y, float)):
        ok = np.isfinite(yr) & (yr > 0)
        if ok.sum() < 3:
            continue
        f = fit_power_law(x[ok], yr[ok])
        vals.append(f.exponent)
        errs.append(f.stderr)
        lo, hi = min(lo, f.fit_range[0]), max(hi, f.fit_range[1])
    return _combine(vals, errs, (lo, hi) if vals else None)


def _fit_log_prefactor(x, y) -> float:
    """ln of the prefactor of the same per-replica fits as :func:`_fit_replicas`, averaged
    over the replicas (NaN if none): with the exponent, the fitted line that a figure draws."""
    x = np.asarray(x, float)
    vals = []
    for yr in np.atleast_2d(np.asarray(y, float)):
        ok = np.isfinite(yr) & (yr > 0)
        if ok.sum() >= 3:
            vals.append(math.log(fit_power_law(x[ok], yr[ok]).prefactor))
    return float(np.mean(vals)) if vals else math.nan


def _trend(a: Estimate, b: Estimate) -> Estimate:
    """|a| - |b| with the two uncertainties added in quadrature."""
    return Estimate(abs(a.value) - abs(b.value), math.hypot(a.sigma, b.sigma), min(a.n, b.n))


def _trend_verdict(d: Estimate) -> str:
    if not (np.isfinite(d.value) and np.isfinite(d.sigma)):
        return "not measured"
    if d.value > 2 * d.sigma:
        return "consistent"
    if d.value < -2 * d.sigma:
        return "not consistent"
    return "inconclusive (within 2σ of no trend)"


def _linear_slope(x, y) -> tuple[float, float]:
    ok = np.isfinite(x) & np.isfinite(y)
    x, y = x[ok], y[ok]
    if x.size < 3:
        return math.nan, math.nan
    A = np.c_[np.ones_like(x), x]
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    res = y - A @ coef
    s2 = float(res @ res) / (x.size - 2)
    cov = s2 * np.linalg.inv(A.T @ A)
    return float(coef[1]), float(math.sqrt(cov[1, 1]))


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, Estimate):
        return obj.to_dict()
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, float | np.floating):
        return _f(float(obj))
    if isinstance(obj, np.integer | np.bool_):
        return obj.item()
    return obj


def _row(
    key: str,
    est: Estimate,
    replicas: str,
    note: str = "",
    *,
    reference: paper.PaperValue | None = None,
) -> dict:
    """A row of the report's main table: ``est`` against the paper's value ``key`` (or against
    ``reference``, a value that is not the paper's, e.g. a closed form)."""
    pv = paper.PAPER_VALUES[key] if reference is None else reference
    ok = np.isfinite(est.value) and np.isfinite(est.sigma)
    dev = abs(est.value - pv.value) / est.sigma if ok and est.sigma > 0 else math.inf
    if not ok:
        verdict = "not measured"
    elif abs(est.value - pv.value) <= 2 * est.sigma:
        verdict = "agrees (within 2σ)"
    else:
        verdict = "differs"
    return {
        "key": key,
        "quantity": pv.quantity,
        "paper": pv.value,
        "source": pv.source,
        "ours": _f(est.value),
        "sigma": _f(est.sigma),
        "deviation_sigma": _f(dev) if math.isfinite(dev) else None,
        "fit_range": None if est.fit_range is None else [_f(v) for v in est.fit_range],
        "replicas": replicas,
        "verdict": verdict,
        "note": note,
    }


def _alt(quantity: str, variant: str, est: Estimate, replicas: int | str, paper_value=None):
    return {
        "quantity": quantity,
        "variant": variant,
        "value": _f(est.value),
        "sigma": _f(est.sigma),
        "fit_range": None if est.fit_range is None else [_f(v) for v in est.fit_range],
        "replicas": replicas,
        "paper": paper_value,
    }


def _alt_reason(alts: list[dict], paper_value: float, what: str = "range") -> str:
    """The summary's reason for a value that differs, from its alternatives (``_alt`` dicts):
    "fit range: <the first that agrees within 2σ> gives …" when one does and it is a fit
    range ("fit on …"), "choice: …" when it is another reading, else "no <what> tried
    reproduces it (best: <the one nearest in σ> …)"."""
    fitted = [a for a in alts if a["value"] is not None and a["sigma"]]
    if not fitted:
        return f"no {what} tried can be fitted"
    dev = [abs(a["value"] - paper_value) / a["sigma"] for a in fitted]
    ok = [a for a, d in zip(fitted, dev, strict=True) if d <= 2]
    if ok:
        label = "fit range" if ok[0]["variant"].startswith("fit on") else "choice"
        return f"{label}: {ok[0]['variant']} gives {_num(ok[0]['value'], ok[0]['sigma'])}"
    best = fitted[int(np.argmin(dev))]
    return (
        f"no {what} tried reproduces it (best: {best['variant']}, "
        f"{_num(best['value'], best['sigma'])})"
    )


def _num(v, sig=None) -> str:
    if v is None:
        return "—"
    if sig is None or not np.isfinite(sig) or sig == 0:
        return f"{v:.4g}"
    if v != 0 and sig < 1e-4 * abs(v):
        return f"{v:.4g} ± {sig:.1g}"
    digits = max(0, 1 - math.floor(math.log10(abs(sig))))
    return f"{v:.{digits}f} ± {sig:.{digits}f}"


def _range(r, half_open: bool = False) -> str:
    if not r:
        return "—"
    return f"({r[0]:.4g}, {r[1]:.4g}]" if half_open else f"[{r[0]:.4g}, {r[1]:.4g}]"


def nan_quiet(f, *args, **kw):
    """``f(*args, **kw)`` (a NaN-aware NumPy reduction) without the warning of an all-NaN
    slice: a stage no point reached, or a straight stage's E_b, is NaN by design."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "All-NaN slice|Mean of empty slice", RuntimeWarning)
        return f(*args, **kw)


# ---- the two readings of Eq. (1): per length (the default) and per node ---------------------

#: The fields of a row that its per-node twin fills (``row["per_node"]``).
_TWIN_FIELDS = (
    "ours",
    "sigma",
    "deviation_sigma",
    "fit_range",
    "replicas",
    "verdict",
    "note",
    "bracket",
    "hollow",
)
#: The prefix of a per-node alternative's variant.
PER_NODE_VARIANT = "per node: "


def _twin(name: str, pl: Record, pn: Record) -> Record:
    """One record of a section measured under both readings of Eq. (1): ``pl`` per length
    (its rows, claims, extra and detail stay where they were) and ``pn`` per node: each row
    and claim gets ``["per_node"]`` (the twin's fields, matched by key or claim), the
    alternatives the twin's with their variant prefixed, ``extra[name + "_per_node"]`` the
    twin's extra, and ``detail["per_node"]`` the twin's whole record (its figures)."""
    by_key = {r["key"]: r for r in pn.rows}
    rows = tuple(
        {**r, "per_node": {k: by_key[r["key"]][k] for k in _TWIN_FIELDS if k in by_key[r["key"]]}}
        if r["key"] in by_key
        else r
        for r in pl.rows
    )
    by_claim = {c["claim"]: c for c in pn.claims}
    claims = tuple(
        {**c, "per_node": {k: by_claim[c["claim"]][k] for k in ("measured", "verdict")}}
        if c["claim"] in by_claim
        else c
        for c in pl.claims
    )
    alts = pl.alternatives + tuple(
        {**a, "variant": PER_NODE_VARIANT + a["variant"]} for a in pn.alternatives
    )
    return Record(
        rows=rows,
        alternatives=alts,
        claims=claims,
        extra={**pl.extra, f"{name}_per_node": pn.extra},
        detail={**pl.detail, "per_node": pn},
    )


def _measure_both(ctx: Context, name: str, measure_one) -> Record:
    """:func:`_twin` of ``measure_one(series, replicas)`` on the ``elastic`` series (per length)
    and on ``elastic_per_node`` (per node, reindexed to the same points)."""
    el = ctx.series["elastic"]
    pn = ctx.series["elastic_per_node"].reindex(el.keys)
    with _missing_points_ok():
        twin = measure_one(pn, ctx.profile["per_node_replicas"])
    return _twin(name, measure_one(el, ctx.replicas), twin)


def _per_node_records(records: Mapping[str, Record]) -> dict[str, Record]:
    """The per-node twin of every record that has one (:func:`_twin`), else the record."""
    return {k: r.detail.get("per_node", r) for k, r in records.items()}


@contextlib.contextmanager
def _missing_points_ok() -> Iterator[None]:
    """Around the measures of a per-node series: the points a profile did not run per node
    (the smoke profile's subset, :meth:`.series.Series.reindex`) are NaN, and means over them
    are NaN without a warning (the report says "not measured")."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


def _both_readings_discussion(one, rec: Record, records=None) -> dict[str, str]:
    """A section's discussion under both readings: ``one(record)`` (or ``one(record,
    records)`` when ``records`` is given) per length, then per node after "**Per node:**"
    (only the per-length text where the per-node one is empty)."""
    if records is None:
        pl, pn = one(rec), one(rec.detail["per_node"])
    else:
        pl, pn = one(rec, records), one(rec.detail["per_node"], _per_node_records(records))
    if not pn:
        return pl
    return {k: f"{pl[k]} **Per node:** {pn[k]}" for k in pl}


def _both_readings_reasons(one, rec: Record) -> dict[str, dict[str, str]]:
    """The summary's reasons of a section, ``one(record) -> {row key: sentence}``, per
    reading: ``{row key: {"per-length": …, "per-node": …}}``."""
    pl, pn = one(rec), one(rec.detail["per_node"])
    return {k: {"per-length": pl[k], "per-node": pn.get(k, "")} for k in pl}
