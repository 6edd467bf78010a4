"""Running: every experiment of a profile into ``DIR/data/<experiment>`` on one Dask cluster."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from .. import paper
from ..storage import atomic_write_text, versions
from . import registry
from .analysis import PROFILE_FILE, _read_profile

__all__ = ["run"]


def _check_profile(out: Path, profile: str, study=None):
    profiles = paper.PROFILES if study is None else study.profiles
    if profile not in profiles:
        raise ValueError(f"unknown profile {profile!r}; choose one of {', '.join(profiles)}")
    stored = out / PROFILE_FILE
    if stored.exists():
        old = _read_profile(out, study)["profile"]["name"]
        if old != profile:
            raise ValueError(
                f"{out} holds the {old!r} profile; use another --out for the {profile!r} profile"
            )
    return profiles[profile]


def run(
    out,
    profile: str = "full",
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[str, Any], None] | None = None,
    sections=None,
    study=None,
) -> dict:
    """Run (or resume) every experiment of ``profile`` into ``out/data``; return a summary.

    The experiments are those the sections read (default: :func:`.registry.sections`). All
    are submitted at once to one Dask cluster (a local one, or ``scheduler``'s), so long
    Powell runs overlap the short ones. Runs already in the stores are not recomputed.
    ``progress(experiment, Progress)`` is called as runs finish. ``study``: a
    :class:`.study.Study` other than the paper's (its profiles and sections).
    """
    from ..sweep import connect, run_sweep

    out = Path(out)
    prof = _check_profile(out, profile, study)  # before anything is created
    out.mkdir(parents=True, exist_ok=True)
    if sections is None and study is not None:
        sections = study.sections()
    secs = registry.sections() if sections is None else tuple(sections)
    sweeps = {e.name: e.build(prof) for e in registry.experiments(secs)}
    atomic_write_text(
        out / PROFILE_FILE,
        json.dumps({"profile": prof.to_dict(), "versions": versions()}, indent=1) + "\n",
    )
    n_runs = sum(len(s) for s in sweeps.values())
    t0 = time.perf_counter()
    # all experiments at once on one cluster (one thread each submits and collects its runs),
    # so that a long Powell run never leaves the other workers idle
    with connect(scheduler=scheduler, workers=workers, max_workers=n_runs) as client:

        def one(name):
            cb = None if progress is None else (lambda p: progress(name, p))
            return run_sweep(
                sweeps[name], out / "data" / name, client=client, progress=cb, refresh=5.0
            )

        with ThreadPoolExecutor(len(sweeps)) as pool:
            reports = dict(zip(sweeps, pool.map(one, sweeps), strict=True))
    return {
        "profile": profile,
        "experiments": {k: v.to_dict() for k, v in reports.items()},
        "seconds": round(time.perf_counter() - t0, 1),
    }
