"""``crumple sweep``, ``status``, ``reproduce`` and ``figures``: many runs, on Dask, resumably.

The command bodies are those of the former ``crumple/cli.py``, moved unchanged.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from .inputs import CLIError
from .progress import JobProgress

__all__ = ["register"]


# --------------------------------------------------------------------------------------------
# crumple sweep / status
# --------------------------------------------------------------------------------------------


def _cmd_sweep(args) -> int:
    from ..sweep import Sweep, run_sweep

    if not Path(args.config).is_file():
        raise CLIError(f"no such sweep file: {args.config}")
    sweep = Sweep.from_toml(args.config)
    if args.workers is not None and args.workers < 1:
        raise CLIError(f"--workers must be >= 1, got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise CLIError("--workers starts local workers; with --scheduler the cluster has its own")
    if not args.quiet:
        dims = ", ".join(f"{k} ({len(v)})" for k, v in sweep.dims.items()) or "one point"
        where = f"scheduler {args.scheduler}" if args.scheduler else "a local cluster"
        print(
            f"crumple sweep: {len(sweep)} runs = {dims} x {sweep.replicas} replica(s), "
            f"on {where}, into {args.out}",
            file=sys.stderr,
        )
    display = JobProgress(args.quiet)
    try:
        report = run_sweep(
            sweep, args.out, workers=args.workers, scheduler=args.scheduler,
            progress=display.sweep,
        )  # fmt: skip
    finally:
        display.close()
    print(json.dumps(report.to_dict(), indent=2))
    return 0 if report.complete else 3


def _cmd_status(args) -> int:
    from ..sweep import sweep_status

    if not Path(args.path).is_dir():
        raise CLIError(f"no such sweep store: {args.path}")
    st = sweep_status(args.path)
    if args.json:
        print(json.dumps(st.to_dict(), indent=2))
        return 0
    print(
        f"{st.path}: {st.total} runs: {len(st.done)} done, {len(st.failed)} failed, "
        f"{len(st.corrupt)} damaged, {len(st.missing)} missing"
        + (f" ({st.stray} run files from other sweeps)" if st.stray else "")
    )
    for rid, msg in st.failed.items():
        print(f"  failed   {rid}  {msg}")
    for rid, msg in st.corrupt.items():
        print(f"  damaged  {rid}  {msg}")
    if not st.complete:
        n = st.total - len(st.done)
        print(f"rerun the same `crumple sweep` line to compute the {n} runs not done")
    return 0


# --------------------------------------------------------------------------------------------
# crumple reproduce / figures
# --------------------------------------------------------------------------------------------


def _finish_report(out, quiet: bool, summary: dict | None = None, display=None, study=None) -> int:
    from ..reproduce import write_report

    display = JobProgress(quiet) if display is None else display
    t0 = time.perf_counter()
    res = write_report(out, log=display.phase, study=study)
    res["report_seconds"] = round(time.perf_counter() - t0, 1)
    if summary is not None:
        res["simulation"] = summary
    print(json.dumps(res, indent=2))
    failed = summary is not None and any(e["failed"] for e in summary["experiments"].values())
    if res["missing"]:
        print(f"crumple: error: the report is incomplete: {', '.join(res['missing'])}",
              file=sys.stderr)  # fmt: skip
    elif not quiet:
        print(f"crumple: report written: {res['report']}", file=sys.stderr)
    return 3 if res["missing"] or failed else 0


def _cmd_reproduce(args) -> int:
    from ..paper import PROFILES, build_sweeps
    from ..reproduce import run

    profile = "quick" if args.quick else args.profile
    if profile == "powell":  # the paper's minimiser given a fair chance: a study of its own
        return _reproduce_powell(args)
    if profile not in PROFILES:
        raise CLIError(f"unknown profile {profile!r}; choose one of "
                       f"{', '.join((*PROFILES, 'powell'))}")  # fmt: skip
    _check_cluster_flags(args)
    out = args.out or ("crumple-report-quick" if profile == "quick" else "crumple-report")
    if not args.quiet:
        n = sum(len(s) for s in build_sweeps(profile).values())
        print(f"crumple reproduce: profile {profile}, {n} ramps, into {out} (resumable: rerun "
              "the same line to continue)", file=sys.stderr)  # fmt: skip
    display = JobProgress(args.quiet)  # one line over every experiment, then the phases
    try:
        summary = run(out, profile, workers=args.workers, scheduler=args.scheduler,
                      progress=None if args.quiet else display)  # fmt: skip
    finally:
        display.close()
    return _finish_report(out, args.quiet, summary, display)


def _check_cluster_flags(args) -> None:
    if args.workers is not None and args.workers < 1:
        raise CLIError(f"--workers must be >= 1, got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise CLIError("--workers starts local workers; with --scheduler the cluster has its own")


def _reproduce_powell(args) -> int:
    """``crumple reproduce --profile powell``: the Powell study's full profile
    (:data:`crumple.reproduce.powell_study.POWELL_STUDY`, also ``crumple study powell``)."""
    from ..reproduce import run
    from ..reproduce.study import get

    _check_cluster_flags(args)
    study = get("powell")
    out = args.out or "crumple-report-powell"
    if not args.quiet:
        print(f"crumple reproduce: profile powell ({study.command}), into {out} (resumable: "
              "rerun the same line to continue)", file=sys.stderr)  # fmt: skip
    display = JobProgress(args.quiet)
    try:
        summary = run(out, "full", workers=args.workers, scheduler=args.scheduler,
                      progress=None if args.quiet else display, study=study)  # fmt: skip
    finally:
        display.close()
    return _finish_report(out, args.quiet, summary, display, study=study)


def _cmd_figures(args) -> int:
    if not Path(args.path).is_dir():
        raise CLIError(f"no such reproduction directory: {args.path}")
    return _finish_report(args.path, args.quiet, study=_stored_study(Path(args.path)))


def _stored_study(path: Path):
    """The Powell study if ``path`` holds its profile (``--profile powell``), else None (the
    paper's reproduction)."""
    import json

    from ..paper import PowellProfile
    from ..reproduce.study import get

    try:
        prof = json.loads((path / "profile.json").read_text(encoding="utf-8"))["profile"]
    except (OSError, ValueError, KeyError, TypeError):
        return None  # the paper's reader says what is wrong
    fields = set(PowellProfile.__dataclass_fields__)
    return get("powell") if isinstance(prof, dict) and fields <= set(prof) else None


def _add_cluster_flags(p) -> None:
    """Where the runs go (a local cluster or a scheduler) and whether to show progress."""
    p.add_argument("--workers", type=int, help="local worker processes (default: cores)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler, tcp://host:8786")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def register(sub) -> None:
    p = sub.add_parser("sweep", help="run a parameter sweep on Dask, resumably (docs/sweeps.md)")
    p.add_argument(
        "config", help="sweep file: [sweep], [wire], [ramp] (or [protocol]) tables, [[point]]s"
    )
    p.add_argument("--out", required=True, help="store directory (rerun to resume)")
    _add_cluster_flags(p)
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("reproduce", help="reproduce the paper: every figure and number, "
                       "side by side with the paper's (report.html)")  # fmt: skip
    p.add_argument(
        "--quick", action="store_true", help="every figure and row, fewer replicas and stages"
    )
    p.add_argument("--profile", default="full", help="full (default), quick, smoke, or powell "
                   "(the paper's Powell minimiser at its likely budget, Fig. 2 wire)")  # fmt: skip
    p.add_argument("--out", help="output directory (default crumple-report[-quick|-powell])")
    _add_cluster_flags(p)
    p.set_defaults(func=_cmd_reproduce)

    p = sub.add_parser("figures", help="redraw the figures and report of `crumple reproduce` "
                       "from its stored results (no simulation)")  # fmt: skip
    p.add_argument("path", help="directory written by crumple reproduce")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=_cmd_figures)

    p = sub.add_parser("status", help="done / failed / missing runs of a sweep store")
    p.add_argument("path", help="store directory written by crumple sweep")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=_cmd_status)
