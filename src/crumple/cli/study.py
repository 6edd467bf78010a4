"""``crumple study NAME``: a study beyond the paper, run and reported like ``reproduce``.

    crumple study continuum [--quick | --profile P] [--out DIR] [--workers N | --scheduler A]

Same shape as ``crumple reproduce``: resumable sweep stores in ``DIR/data``, then
``report.md``, ``report.html``, figures (PNG, SVG) and ``results.json``. ``--report-only``
redraws the report from the stores, without simulation.
"""

from __future__ import annotations

import sys

from .inputs import CLIError
from .progress import JobProgress
from .sweep_cmds import _add_cluster_flags, _finish_report

__all__ = ["register"]


def _cmd_study(args) -> int:
    from ..reproduce import run
    from ..reproduce.study import get

    study = get(args.name)
    profile = "quick" if args.quick else args.profile
    if profile not in study.profiles:
        raise CLIError(f"unknown profile {profile!r}; choose one of {', '.join(study.profiles)}")
    if args.workers is not None and args.workers < 1:
        raise CLIError(f"--workers must be >= 1, got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise CLIError("--workers starts local workers; with --scheduler the cluster has its own")
    out = args.out or f"crumple-{study.name}-{profile}"
    display = JobProgress(args.quiet)
    summary = None
    if not args.report_only:
        if not args.quiet:
            print(f"{study.command}: profile {profile}, into {out} (resumable: rerun the same "
                  "line to continue)", file=sys.stderr)  # fmt: skip
        try:
            summary = run(out, profile, workers=args.workers, scheduler=args.scheduler,
                          progress=None if args.quiet else display, study=study)  # fmt: skip
        finally:
            display.close()
    return _finish_report(out, args.quiet, summary, display, study=study)


def register(sub) -> None:
    from ..reproduce.study import STUDIES

    p = sub.add_parser("study", help="a study beyond the paper (continuum: the confinement "
                       "number Λ; cavity: injection against potential confinement), run and "
                       "reported like reproduce")  # fmt: skip
    p.add_argument("name", choices=STUDIES, help="which study")
    p.add_argument("--quick", action="store_true", help="the quick profile (≤ 10 min, 2 cores)")
    p.add_argument("--profile", default="full", help="full (default), quick or smoke")
    p.add_argument("--out", help="output directory (default crumple-<study>-<profile>)")
    p.add_argument("--report-only", action="store_true",
                   help="redraw the report from the stores in --out (no simulation)")  # fmt: skip
    _add_cluster_flags(p)
    p.set_defaults(func=_cmd_study)
