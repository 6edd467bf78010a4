"""The ``crumple`` command line: thin wrappers over the library.

    crumple run      [--config FILE.toml] [flags]   run a confinement ramp, write HDF5 + PNG
    crumple energy   FILE --kb .. --ks .. --lam ..   energy of a configuration by term (JSON)
    crumple measure  FILE [options]                  observables of a configuration (JSON)
    crumple sweep    CONFIG.toml --out PATH [...]    run a parameter sweep on Dask (resumable)
    crumple status   PATH                            done / failed / missing runs of a sweep

Every error is one line on stderr and a non-zero exit status, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

__all__ = ["main"]


class CLIError(Exception):
    """An error to report on one line."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, not usage + message
        raise CLIError(f"{message} (see '{self.prog} --help')")


# --------------------------------------------------------------------------------------------
# Input helpers
# --------------------------------------------------------------------------------------------


def _floats(text: str, name: str, n: int | None = None) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise CLIError(f"{name} must be comma-separated numbers, got {text!r}") from None
    if n is not None and len(vals) != n:
        raise CLIError(f"{name} needs {n} comma-separated numbers, got {text!r}")
    if not all(math.isfinite(v) for v in vals):
        raise CLIError(f"{name} must be finite, got {text!r}")
    return vals


def read_positions(path) -> np.ndarray:
    """Node positions from a ``.npy`` array or a text/CSV file of ``x y`` rows.

    Text files: one node per row, two columns separated by whitespace or a comma; lines
    starting with ``#`` are comments.
    """
    path = Path(path)
    if not path.is_file():
        raise CLIError(f"no such file: {path}")
    try:
        if path.suffix == ".npy":
            x = np.load(path, allow_pickle=False)
        else:
            with path.open() as fh:
                lines = [ln for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
            delim = "," if lines and "," in lines[0] else None
            x = np.loadtxt(lines, delimiter=delim, ndmin=2)
    except (ValueError, OSError) as exc:
        raise CLIError(f"cannot read positions from {path}: {exc}") from None
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 2:
        raise CLIError(f"{path}: expected an array of shape (n_nodes, 2), got {x.shape}")
    if x.shape[0] < 4:
        raise CLIError(f"{path}: a wire needs at least 4 nodes (3 segments), got {x.shape[0]}")
    if not np.all(np.isfinite(x)):
        raise CLIError(f"{path}: positions contain NaN or infinite values")
    return x


def _plasticity(args):
    from .model import Plasticity

    if (args.plastic_s is None) != (args.plastic_theta is None):
        raise CLIError("plasticity needs both --plastic-s and --plastic-theta")
    if args.plastic_s is None:
        return None
    return Plasticity(s=args.plastic_s, theta_p=args.plastic_theta)


# --------------------------------------------------------------------------------------------
# crumple energy / measure
# --------------------------------------------------------------------------------------------


def _cmd_energy(args) -> int:
    from .energy import energy_terms
    from .geometry import find_crossings, segment_lengths
    from .model import Wire

    x = read_positions(args.file)
    if args.length == "auto":
        length = float(segment_lengths(x).sum())
    else:
        length = _floats(args.length, "--length", 1)[0]
    wire = Wire(
        k_b=args.kb,
        k_s=args.ks,
        n_segments=x.shape[0] - 1,
        length=length,
        confinement=args.confinement,
        hard_core=args.hard_core,
        hard_core_energy=args.hard_core_energy,
        plasticity=_plasticity(args),
        trap_center=tuple(_floats(args.center, "--center", 2)),
    )
    out = energy_terms(wire, x, args.lam).to_dict()
    crossings = len(find_crossings(x))
    out["crossings"] = crossings
    out["n_segments"] = wire.n_segments
    out["length"] = wire.length
    print(json.dumps(out, indent=2))
    if crossings:
        print(
            f"crumple: warning: the wire crosses itself {crossings} time(s); the hard core "
            "cannot see a crossing, so its energy is not meaningful",
            file=sys.stderr,
        )
    return 0


def _cmd_measure(args) -> int:
    from .observables import measure

    x = read_positions(args.file)
    kwargs = {
        "rg": args.rg,
        "fit_range": tuple(_floats(args.fit_range, "--fit-range", 2)),
        "contact_distance": args.contact_distance,
    }
    if args.center is not None:
        kwargs["center"] = tuple(_floats(args.center, "--center", 2))
    if args.radii is not None:
        kwargs["radii"] = _floats(args.radii, "--radii")
    print(json.dumps(measure(x, **kwargs), indent=2))
    return 0


# --------------------------------------------------------------------------------------------
# crumple run
# --------------------------------------------------------------------------------------------

_WIRE_KEYS = {
    "kb": "k_b",
    "ks": "k_s",
    "n_segments": "n_segments",
    "length": "length",
    "confinement": "confinement",
    "hard_core": "hard_core",
    "hard_core_energy": "hard_core_energy",
    "rest_angle_sd": "rest_angle_sd",
}
_RAMP_KEYS = ("initial_noise", "stage_noise", "stop_tol", "method", "ftol", "maxiter", "max_step")


def _load_toml(path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise CLIError(f"no such config file: {path}")
    try:
        with path.open("rb") as fh:
            cfg = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise CLIError(f"{path}: invalid TOML: {exc}") from None
    unknown = set(cfg) - {"wire", "ramp", "run"}
    if unknown:
        raise CLIError(f"{path}: unknown table(s) {sorted(unknown)}; use [wire], [ramp], [run]")
    return cfg


def _build_run(args):
    """Wire, Ramp and run options from the TOML file overridden by the flags."""
    from .model import Plasticity, Wire
    from .protocol import Ramp, default_schedule

    cfg = _load_toml(args.config) if args.config else {}
    w = dict(cfg.get("wire", {}))
    r = dict(cfg.get("ramp", {}))
    run = dict(cfg.get("run", {}))
    for flag, key in _WIRE_KEYS.items():
        v = getattr(args, flag)
        if v is not None:
            w[key] = v
    if args.plastic_s is not None or args.plastic_theta is not None:
        w["plasticity"] = {"s": args.plastic_s, "theta_p": args.plastic_theta}
        if None in w["plasticity"].values():
            raise CLIError("plasticity needs both --plastic-s and --plastic-theta")
    unknown = set(w) - set(Wire.__dataclass_fields__) - {"young", "radius", "bending", "stretching"}
    if unknown:
        raise CLIError(f"unknown [wire] key(s): {', '.join(sorted(unknown))}")
    if isinstance(w.get("plasticity"), dict):
        w["plasticity"] = Plasticity(**w["plasticity"])
    if "young" in w or "radius" in w:
        wire = Wire.from_material(**w)
    elif "bending" in w or "stretching" in w:
        wire = Wire.from_continuum(**w)
    else:
        w.setdefault("k_b", 5.0)
        w.setdefault("k_s", 5e5)
        wire = Wire(**w)
    for key in _RAMP_KEYS:
        v = getattr(args, key)
        if v is not None:
            r[key] = v
    if args.lambdas is not None:
        r["lambdas"] = _floats(args.lambdas, "--lambdas")
    elif "lambdas" not in r:
        sched = r.pop("schedule", {})
        if not isinstance(sched, dict):
            raise CLIError("[ramp] schedule must be a table (lam_min, lam_max, n)")
        r["lambdas"] = default_schedule(**sched)
    ramp = Ramp.from_dict(r)
    for key in ("replicas", "seed", "workers", "out", "figure_lambdas"):
        v = getattr(args, key)
        if v is not None:
            run[key] = v
    unknown = set(run) - {"replicas", "seed", "workers", "out", "figure_lambdas"}
    if unknown:
        raise CLIError(f"unknown [run] key(s): {', '.join(sorted(unknown))}")
    return wire, ramp, run


class _Progress:
    """Progress on stderr: a rewritten line on a terminal, a few lines otherwise."""

    def __init__(self, quiet: bool):
        self.quiet = quiet
        self.tty = sys.stderr.isatty()
        self.t0 = time.perf_counter()

    def stage(self, i, n, stage):
        if self.quiet or not self.tty:
            return
        ok = "ok" if stage.result.converged else "NOT CONVERGED"
        sys.stderr.write(
            f"\r  stage {i + 1:3d}/{n}  λ = {stage.lam:9.4g}  {ok:13s}"
            f"  {time.perf_counter() - self.t0:6.1f} s "
        )
        sys.stderr.flush()

    def replica(self, done, n, result):
        if self.quiet:
            return
        bad = len(result.failed_stages)
        note = "all stages converged" if not bad else f"{bad} stage(s) NOT converged"
        elapsed = time.perf_counter() - self.t0
        eta = elapsed / done * (n - done)
        end = "\n"
        sys.stderr.write(
            f"\r  replica {done}/{n} done: {len(result.stages)} stages, {note}"
            f"  [{elapsed:.1f} s elapsed, ~{eta:.0f} s left]{' ' * 10}{end}"
        )
        sys.stderr.flush()


def _cmd_run(args) -> int:
    from .figures import plot_configurations
    from .protocol import PAPER_LAMBDAS, run_ramp, run_replicas
    from .storage import save_ramps

    wire, ramp, run = _build_run(args)
    n_rep = int(run.get("replicas", 1))
    seed = run.get("seed", 0)
    workers = run.get("workers")
    out = Path(run.get("out", "crumple-out"))
    if n_rep < 1:
        raise CLIError(f"replicas must be >= 1, got {n_rep}")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    workers = min(n_rep, cores) if workers is None else int(workers)
    out.mkdir(parents=True, exist_ok=True)
    quiet = args.quiet
    if not quiet:
        print(
            f"crumple run: N = {wire.n_segments}, k_b = {wire.k_b:g}, k_s = {wire.k_s:g}, "
            f"confinement {wire.confinement}, {len(ramp.lambdas)} stages "
            f"(λ = {ramp.lambdas[0]:g} … {ramp.lambdas[-1]:g}), {n_rep} replica(s) "
            f"on {workers} worker(s), minimiser {ramp.method}",
            file=sys.stderr,
        )
    prog = _Progress(quiet)
    t0 = time.perf_counter()
    if n_rep == 1:
        from .protocol import replica_seeds

        res = run_ramp(wire, ramp, seed=np.random.default_rng(replica_seeds(seed, 1)[0]),
                       progress=prog.stage)  # fmt: skip
        prog.replica(1, 1, res)
        results = [res]
    else:
        results = run_replicas(
            wire, ramp, n_replicas=n_rep, seed=seed, workers=workers, progress=prog.replica
        )
    elapsed = time.perf_counter() - t0
    h5 = save_ramps(out / "ramps.h5", results, seed=seed)
    fig_lams = run.get("figure_lambdas")
    if fig_lams is None:
        fig_lams = [v for v in PAPER_LAMBDAS if v in ramp.lambdas] or [ramp.lambdas[-1]]
    elif isinstance(fig_lams, str):
        fig_lams = _floats(fig_lams, "--figure-lambdas")
    first = results[0]
    shown = [lam for lam in fig_lams if any(s.lam == float(lam) for s in first.stages)]
    if not shown:
        raise CLIError(f"none of the figure lambdas {fig_lams} is a stage of the ramp")
    fig = plot_configurations(
        [first.at(lam).positions for lam in shown],
        shown,
        title=f"k_b = {wire.k_b:g}, k_s = {wire.k_s:g}, N = {wire.n_segments} "
        f"({wire.confinement} confinement), replica 0",
        trap_center=wire.trap_center,
    )
    png = out / "configurations.png"
    fig.savefig(png, dpi=130)
    failed = [(r, lam, msg) for r, res in enumerate(results) for lam, msg in res.failed_stages]
    summary = {
        "results": str(h5),
        "figure": str(png),
        "replicas": n_rep,
        "stages": len(ramp.lambdas),
        "seconds": round(elapsed, 3),
        "converged": not failed,
        "failed_stages": [{"replica": r, "lambda": lam, "message": m} for r, lam, m in failed],
        "final_energy": [res.stages[-1].energy.to_dict() for res in results],
    }
    print(json.dumps(summary, indent=2))
    return 0 if not failed else 3


# --------------------------------------------------------------------------------------------
# crumple sweep / status
# --------------------------------------------------------------------------------------------


class _SweepProgress:
    """done / running / failed / ETA on stderr: one rewritten line on a terminal, else a line
    every ``every`` seconds and at the end."""

    def __init__(self, quiet: bool, every: float = 10.0, prefix: str = ""):
        self.quiet, self.every, self.prefix = quiet, every, prefix
        self.tty = sys.stderr.isatty()
        self.last = -math.inf

    def __call__(self, p) -> None:
        if self.quiet:
            return
        eta = "?" if p.eta is None else f"{p.eta:.0f} s"
        bar = ""
        if self.tty:
            width = 24
            filled = int(width * (p.done + p.failed) / max(p.total, 1))
            bar = f"[{'#' * filled}{'.' * (width - filled)}] "
        line = (
            f"{self.prefix}{bar}{p.done}/{p.total} done ({p.skipped} already), "
            f"{p.running} running, {p.failed} failed, {p.elapsed:.0f} s elapsed, ETA {eta}"
        )
        finished = p.done + p.failed == p.total
        if self.tty:
            sys.stderr.write(f"\r{line}   " + ("\n" if finished else ""))
        elif finished or time.monotonic() - self.last >= self.every:
            self.last = time.monotonic()
            sys.stderr.write(line + "\n")
        sys.stderr.flush()


def _cmd_sweep(args) -> int:
    from .sweep import Sweep, run_sweep

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
    report = run_sweep(
        sweep, args.out, workers=args.workers, scheduler=args.scheduler,
        progress=_SweepProgress(args.quiet),
    )  # fmt: skip
    print(json.dumps(report.to_dict(), indent=2))
    return 0 if report.complete else 3


def _cmd_status(args) -> int:
    from .sweep import sweep_status

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


def _finish_report(out, quiet: bool, summary: dict | None = None) -> int:
    from .reproduce import write_report

    def log(msg):
        if not quiet:
            print(f"crumple: {msg}", file=sys.stderr)

    t0 = time.perf_counter()
    res = write_report(out, log=log)
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
    from .paper import PROFILES, build_sweeps
    from .reproduce import run

    profile = "quick" if args.quick else args.profile
    if profile not in PROFILES:
        raise CLIError(f"unknown profile {profile!r}; choose one of {', '.join(PROFILES)}")
    if args.workers is not None and args.workers < 1:
        raise CLIError(f"--workers must be >= 1, got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise CLIError("--workers starts local workers; with --scheduler the cluster has its own")
    out = args.out or ("crumple-report-quick" if profile == "quick" else "crumple-report")
    if not args.quiet:
        n = sum(len(s) for s in build_sweeps(profile).values())
        print(f"crumple reproduce: profile {profile}, {n} ramps, into {out} (resumable: rerun "
              "the same line to continue)", file=sys.stderr)  # fmt: skip
    bars: dict[str, _SweepProgress] = {}

    def cb(name, p):
        bars.setdefault(name, _SweepProgress(args.quiet, prefix=f"{name:>8s}: "))(p)

    summary = run(out, profile, workers=args.workers, scheduler=args.scheduler,
                  progress=None if args.quiet else cb)  # fmt: skip
    return _finish_report(out, args.quiet, summary)


def _cmd_figures(args) -> int:
    if not Path(args.path).is_dir():
        raise CLIError(f"no such reproduction directory: {args.path}")
    return _finish_report(args.path, args.quiet)


# --------------------------------------------------------------------------------------------
# Parser
# --------------------------------------------------------------------------------------------


def _add_model_flags(p, required: bool):
    p.add_argument("--kb", type=float, required=required, help="bending rigidity k_b [energy]")
    p.add_argument("--ks", type=float, required=required, help="stretching modulus k_s")
    p.add_argument(
        "--confinement",
        choices=["per-length", "per-node"],
        default=None if not required else "per-length",
        help="confinement normalisation (default per-length; docs/model.md)",
    )
    p.add_argument("--hard-core", type=float, default=None if not required else 1e-5,
                   help="hard-core width d [length] (default 1e-5)")  # fmt: skip
    p.add_argument("--hard-core-energy", type=float, default=None if not required else 1e-3,
                   help="hard-core energy scale ε (default 1e-3)")  # fmt: skip
    p.add_argument("--plastic-s", type=float, help="softening factor s in [0, 1]")
    p.add_argument("--plastic-theta", type=float, help="yield angle θ_p [rad]")


def _add_cluster_flags(p) -> None:
    """Where the runs go (a local cluster or a scheduler) and whether to show progress."""
    p.add_argument("--workers", type=int, help="local worker processes (default: cores)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler, tcp://host:8786")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = _Parser(
        prog="crumple",
        description="Energy-minimal simulation of elastic wires crumpled in two dimensions.",
    )
    parser.add_argument("--version", action="version", version=f"crumple {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("run", help="run a quasi-static confinement ramp")
    p.add_argument("--config", help="TOML file with [wire], [ramp], [run] tables")
    _add_model_flags(p, required=False)
    p.add_argument("--n-segments", type=int, help="number of segments N (default 100)")
    p.add_argument("--rest-angle-sd", type=float,
                   help="imperfection: random rest angle per joint [rad] (default 0)")  # fmt: skip
    p.add_argument("--length", type=float, help="wire length L0 (default 1)")
    p.add_argument("--lambdas", help="comma-separated λ stages (default: geometric 1…2000)")
    p.add_argument("--method", choices=["newton", "powell"], help="minimiser (default newton)")
    p.add_argument("--ftol", type=float, help="equilibrium tolerance on node forces")
    p.add_argument("--maxiter", type=int, help="iterations per stage")
    p.add_argument("--max-step", type=float, help="largest node step per Newton iteration [length]")
    p.add_argument("--initial-noise", type=float, help="initial transverse noise / segment")
    p.add_argument("--stage-noise", type=float, help="random kick per stage / segment")
    p.add_argument("--stop-tol", type=float, help="stop when nodes move less than this")
    p.add_argument("--replicas", type=int, help="independent replicas (default 1)")
    p.add_argument("--workers", type=int, help="parallel processes (default: cores)")
    p.add_argument("--seed", type=int, help="base seed (default 0)")
    p.add_argument("--out", help="output directory (default crumple-out)")
    p.add_argument("--figure-lambdas", help="λ values to draw (default 70,200,300,1000)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("energy", help="energy of a configuration by term, as JSON")
    p.add_argument("file", help=".npy array or text/CSV file of x y rows, one node per row")
    _add_model_flags(p, required=True)
    p.add_argument("--lam", type=float, required=True, help="trap strength λ")
    p.add_argument("--length", default="1", help="rest length L0 of the wire, or 'auto'")
    p.add_argument("--center", default="0,0", help="trap centre x,y (default 0,0)")
    p.set_defaults(func=_cmd_energy)

    p = sub.add_parser("measure", help="observables of a configuration, as JSON")
    p.add_argument("file", help=".npy array or text/CSV file of x y rows, one node per row")
    p.add_argument("--center", help="centre x,y (default: centre of mass)")
    p.add_argument("--radii", help="comma-separated radii for mass_within")
    p.add_argument("--rg", choices=["r_max", "rms"], default="r_max", help="R_G (default r_max)")
    p.add_argument("--fit-range", default="0.5,1", help="D_M fit range in R/R_G")
    p.add_argument("--contact-distance", type=float, default=1e-5, help="contact distance")
    p.set_defaults(func=_cmd_measure)

    p = sub.add_parser("sweep", help="run a parameter sweep on Dask, resumably (docs/sweeps.md)")
    p.add_argument("config", help="sweep file: [sweep], [wire], [ramp] tables, [[point]]s")
    p.add_argument("--out", required=True, help="store directory (rerun to resume)")
    _add_cluster_flags(p)
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("reproduce", help="reproduce the paper: every figure and number, "
                       "side by side with the paper's (report.html)")  # fmt: skip
    p.add_argument(
        "--quick", action="store_true", help="every figure and row, fewer replicas and stages"
    )
    p.add_argument("--profile", default="full", help="full (default), quick or smoke")
    p.add_argument("--out", help="output directory (default crumple-report[-quick])")
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
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return args.func(args)
    except CLIError as exc:
        print(f"crumple: error: {exc}", file=sys.stderr)
        return 2
    except (ValueError, TypeError, OSError) as exc:
        print(f"crumple: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("crumple: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
