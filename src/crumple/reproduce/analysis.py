"""Measuring: every section's record from the stores in ``DIR/data`` (no simulation).

:func:`analyse` reads each experiment the sections name once (:func:`.series._series`), then
measures the sections in registry order, each from the series it ``READS`` and the records it
``NEEDS``, and gathers the records into an :class:`Analysis`.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..paper import Profile
from . import registry
from .common import Context, Record, _jsonable
from .series import Series, _convergence, _series

__all__ = ["PROFILE_FILE", "Analysis", "analyse"]

PROFILE_FILE = "profile.json"


@dataclass(frozen=True, slots=True, kw_only=True)
class Analysis:
    """Everything the report shows: the series, and each section's record (in order)."""

    profile: dict
    series: dict[str, Series]
    sections: tuple[Any, ...]
    records: dict[str, Record]

    def _gather(self, what: str) -> list:
        return [x for s in self.sections for x in getattr(self.records[s.NAME], what)]

    @property
    def rows(self) -> list[dict]:
        """The main table's rows, section by section."""
        return self._gather("rows")

    @property
    def alternatives(self) -> list[dict]:
        return self._gather("alternatives")

    @property
    def claims(self) -> list[dict]:
        return self._gather("claims")

    @property
    def extra(self) -> dict:
        """Convergence of every experiment and every section's ``extra``."""
        out: dict[str, Any] = {"convergence": {k: _convergence(v) for k, v in self.series.items()}}
        for s in self.sections:
            for k, v in self.records[s.NAME].extra.items():
                if k in out:
                    raise ValueError(f"section {s.NAME!r} writes extra[{k!r}] a second time")
                out[k] = v
        return out

    def to_json(self) -> dict:
        """The numbers of the report (``results.json``)."""
        return {
            "profile": self.profile,
            "rows": self.rows,
            "alternatives": self.alternatives,
            "claims": self.claims,
            "extra": _jsonable(self.extra),
        }


def _read_profile(out: Path, study=None) -> dict:
    """``profile.json`` of ``out``, checked against the profile fields of ``study`` (default:
    the paper's reproduction, :data:`.study.PAPER`)."""
    # the paper's profile fields without a default (one added later, with a default, is not
    # required of a store made before it: that store resumes)
    fields = (
        [k for k, f in Profile.__dataclass_fields__.items() if f.default is dataclasses.MISSING]
        if study is None
        else study.profile_fields
    )
    command = "crumple reproduce" if study is None else study.command
    what = "reproduction" if study is None else f"{study.name} study"
    path = out / PROFILE_FILE
    if not path.exists():
        raise ValueError(
            f"{out} holds no {what} ({PROFILE_FILE} missing); run `{command} --out {out}` first"
        )
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path} is not valid JSON ({exc})") from None
    prof = meta.get("profile") if isinstance(meta, dict) else None
    lacks = (
        ["profile"] if not isinstance(prof, dict)
        else [f"profile.{k}" for k in fields if k not in prof]
    )  # fmt: skip
    if lacks:
        raise ValueError(
            f"{path} is damaged (no {', '.join(lacks)}); rerun `{command} --out {out}` "
            "with the profile it was made with, which rewrites it"
        )
    return meta


def command(study=None) -> str:
    """The command that runs ``study``'s experiments (the paper's: ``crumple reproduce``)."""
    return "crumple reproduce" if study is None else study.command


def analyse(
    out, *, sections=None, log: Callable[[str], None] | None = None, study=None
) -> Analysis:
    """Measure every section (default: :func:`.registry.sections`, or ``study``'s) from
    ``out/data``. ``log(message)`` before each experiment read and each section measured."""
    out = Path(out)
    prof = _read_profile(out, study)["profile"]
    if sections is None and study is not None:
        sections = study.sections()
    secs = registry.sections() if sections is None else tuple(sections)
    exps = registry.experiments(secs)
    series = {}
    for i, e in enumerate(exps, 1):
        if log:
            log(f"measuring: reading the {e.name} runs ({i}/{len(exps)})")
        store = out / "data" / e.name
        if not store.exists():  # a reproduction made before the experiment existed
            raise ValueError(
                f"{out} holds no {e.name!r} runs (made before that experiment existed?); run "
                f"`{command(study)} --out {out}` with its profile to add them"
            )
        series[e.name] = _series(store, e.levels)
        if not (study is None or study.partial or np.asarray(series[e.name].done).any()):
            raise ValueError(
                f"{out} holds no finished {e.name!r} run yet (`crumple status {store}`); let "
                f"`{command(study)} --out {out}` finish it, then redraw the report"
            )
    records: dict[str, Record] = {}
    for i, s in enumerate(secs, 1):
        if log:
            log(f"measuring: {s.NAME} ({i}/{len(secs)})")
        missing = [n for n in s.NEEDS if n not in records]
        if missing:
            raise ValueError(f"section {s.NAME!r} needs {', '.join(missing)}, measured after it")
        ctx = Context(
            profile=prof,
            series={e.name: series[e.name] for e in s.READS},
            records={n: records[n] for n in s.NEEDS},
        )
        records[s.NAME] = s.measure(ctx)
    return Analysis(profile=prof, series=series, sections=secs, records=records)
