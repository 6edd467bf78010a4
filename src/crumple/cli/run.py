"""``crumple run``: one quasi-static ramp, its replicas, and their results on disk.

What it guarantees:

* every parameter is validated, and echoed, before anything is simulated (figure λs
  included);
* an existing ``OUT/ramps.h5`` is never replaced without ``--overwrite``;
* the outputs are published consistently: both are written to temporary names first, then
  the old figure is removed, the new results renamed into place, the new figure last. A kill
  at any point leaves the old pair, the old results without a figure, the new results without
  a figure, or the new pair, never results beside another run's figure (``crumple plot``
  redraws a missing figure);
* Ctrl-C or SIGTERM stops every worker process within seconds and says what was kept: the
  replicas that had finished are written to ``OUT/ramps.interrupted.h5`` (and
  ``configurations.interrupted.png``), marked ``interrupted``, never to ``ramps.h5``, so that
  ``ramps.h5`` is always a complete run and ``--overwrite`` never replaces a complete old one
  with a partial set. The handler stays in place until the outputs are published (a signal
  while publishing keeps every replica), and further signals are ignored while the finished
  replicas are being saved.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np

from .advice import advice, warn
from .inputs import CLIError, add_model_flags, floats, load_toml, positive_int
from .progress import Progress
from .signals import Terminated, _on_sigterm, signal_cause

__all__ = ["cmd_run", "register"]

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
_RAMP_KEYS = (
    "initial_noise", "stage_noise", "stop_tol", "method", "ftol", "maxiter", "max_step",
    "curved_steps", "fallback", "coarsen",
)  # fmt: skip
_RUN_KEYS = ("replicas", "seed", "workers", "out", "figure_lambdas", "overwrite")
#: The tables of a run's TOML file ([protocol]: kind = "ramp" | "injection", and the
#: injection's parameters).
_TABLES = ("wire", "ramp", "run", "protocol")
#: Units of the echoed parameters (lengths in units of L0, energies in the paper's units).
_UNITS = {
    "k_b": "[energy]",
    "k_s": "[energy/length²]",
    "length": "[length]",
    "hard_core": "[length]",
    "hard_core_energy": "[energy]",
    "rest_angle_sd": "[rad]",
    "trap_center": "[length]",
    "ftol": "[energy/length]",
    "stop_tol": "[length]",
    "initial_noise": "[segment lengths]",
    "stage_noise": "[segment lengths]",
    "max_step": "[length]",
}


def build_wire(args, cfg: dict, defaults: dict | None = None):
    """The Wire of the TOML file's ``[wire]`` table overridden by the flags; ``defaults``
    fill keys that neither gives (the injection's cavity and thickness)."""
    from ..model import Plasticity, Wire

    w = dict(cfg.get("wire", {}))
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
    for k, v in (defaults or {}).items():
        w.setdefault(k, v(w) if callable(v) else v)
    if isinstance(w.get("plasticity"), dict):
        w["plasticity"] = Plasticity(**w["plasticity"])
    if "young" in w or "radius" in w:
        return Wire.from_material(**w)
    if "bending" in w or "stretching" in w:
        return Wire.from_continuum(**w)
    w.setdefault("k_b", 5.0)
    w.setdefault("k_s", 5e5)
    return Wire(**w)


def protocol_kind(args, cfg: dict) -> str:
    """``ramp`` or ``injection``: ``--protocol``, else the TOML's ``[protocol] kind``."""
    table = cfg.get("protocol", {})
    if not isinstance(table, dict):
        raise CLIError('[protocol] must be a table (kind = "ramp" | "injection", ...)')
    kind = args.protocol or table.get("kind", "ramp")
    if kind not in ("ramp", "injection"):
        raise CLIError(f"[protocol] kind must be 'ramp' or 'injection', got {kind!r}")
    if kind == "ramp" and set(table) - {"kind"}:
        raise CLIError(
            f"unknown [protocol] key(s) for kind = 'ramp': "
            f"{', '.join(sorted(set(table) - {'kind'}))} (the ramp's parameters go in [ramp])"
        )
    return kind


def build_run(args):
    """Wire, Ramp and run options from the TOML file overridden by the flags."""
    from ..protocol import Ramp, default_schedule
    from ..protocol_coarse import check_coarsen

    cfg = load_toml(args.config, _TABLES) if args.config else {}
    r = dict(cfg.get("ramp", {}))
    run = dict(cfg.get("run", {}))
    wire = build_wire(args, cfg)
    for key in _RAMP_KEYS:
        v = getattr(args, key)
        if v is not None:
            r[key] = v
    if args.lambdas is not None:
        r["lambdas"] = floats(args.lambdas, "--lambdas")
    elif "lambdas" not in r:
        sched = r.pop("schedule", {})
        if not isinstance(sched, dict):
            raise CLIError("[ramp] schedule must be a table (lam_min, lam_max, n)")
        r["lambdas"] = default_schedule(**sched)
    ramp = Ramp.from_dict(r)
    check_coarsen(wire, ramp.coarsen)  # before the output folder and the workers
    for key in _RUN_KEYS:
        v = getattr(args, key)
        if v is not None and v is not False:  # not `in (None, False)`: --workers 0 == False
            run[key] = v
    unknown = set(run) - set(_RUN_KEYS)
    if unknown:
        raise CLIError(f"unknown [run] key(s): {', '.join(sorted(unknown))}")
    run["replicas"] = positive_int(run.get("replicas", 1), "replicas")
    if run.get("workers") is not None:
        run["workers"] = positive_int(run["workers"], "--workers")
    seed = run.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise CLIError(f"seed must be a whole number >= 0, got {seed!r}")
    run["figure_lambdas"] = _figure_lambdas(run.get("figure_lambdas"), ramp)
    return wire, ramp, run


def _figure_lambdas(value, ramp) -> list[float]:
    """The λs to draw, each one of the ramp's stages: checked before anything is simulated."""
    from ..protocol import PAPER_LAMBDAS

    if value is None:
        return [v for v in PAPER_LAMBDAS if v in ramp.lambdas] or [ramp.lambdas[-1]]
    if isinstance(value, str):
        wanted = floats(value, "--figure-lambdas")
    else:
        try:
            wanted = [float(v) for v in value]
        except (TypeError, ValueError):
            raise CLIError(f"figure_lambdas must be a list of numbers, got {value!r}") from None
    stages = np.asarray(ramp.lambdas)
    out, missing = [], []
    for lam in wanted:
        hit = np.flatnonzero(np.isclose(stages, lam, rtol=1e-9, atol=0.0))
        (out.append(float(stages[hit[0]])) if hit.size else missing.append(lam))
    if missing or not out:
        raise CLIError(
            f"figure λ {', '.join(f'{v:g}' for v in missing) or '(none)'} not among the ramp's "
            f"stages ({', '.join(f'{v:g}' for v in ramp.lambdas)}); add them to --lambdas"
        )
    return out


def describe(wire, ramp, run, workers: int) -> str:
    """Every parameter the run uses, with units: what ``crumple run`` echoes."""

    def fmt(d, skip=()):
        parts = []
        for k, v in d.items():
            if k in skip:
                continue
            if isinstance(v, dict):
                v = ", ".join(f"{a} = {b:g}" for a, b in v.items())
                v = f"{{{v}}}"
            elif isinstance(v, float):
                v = f"{v:g}"
            elif isinstance(v, list | tuple):
                v = "(" + ", ".join(f"{a:g}" for a in v) + ")"
            parts.append(f"{k} = {v}" + (f" {_UNITS[k]}" if k in _UNITS else ""))
        return ", ".join(parts)

    wd = wire.to_dict()
    if wd.get("plasticity") is None:
        wd["plasticity"] = "none (elastic)"
    else:
        wd["plasticity"] = {"s": wire.plasticity.s, "theta_p [rad]": wire.plasticity.theta_p}
    lams = ramp.lambdas
    return (
        f"crumple run:\n  wire: {fmt(wd)}\n"
        f"  ramp: {len(lams)} stages, λ = {lams[0]:g} … {lams[-1]:g} [energy/length²], "
        f"{fmt(ramp.to_dict(), skip=('lambdas',))}\n"
        f"  run: {run['replicas']} replica(s) on {workers} worker(s), seed = {run.get('seed', 0)}, "
        f"out = {run.get('out', 'crumple-out')}, figure λ = "
        f"{', '.join(f'{v:g}' for v in run['figure_lambdas'])}"
    )


# --------------------------------------------------------------------------------------------
# Progress
# --------------------------------------------------------------------------------------------


# --------------------------------------------------------------------------------------------
# Replicas, in this process or in worker processes that a signal stops
# --------------------------------------------------------------------------------------------

_QUEUE = None


def _init_worker(queue) -> None:
    """Worker start: Ctrl-C goes to the parent only (which then stops the workers)."""
    global _QUEUE
    _QUEUE = queue
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


#: Seconds a stage runs before it reports its Newton iterations, and then between reports: a
#: stage at N = 100 takes milliseconds and reports none; one at N = 10⁵ runs for hours.
ITERATION_EVERY = 2.0
_clock = time.monotonic  # the replicas' clock (a test scripts it)


def _replica(wire, ramp, seed_seq, r: int, on_stage=None, on_iteration=None, iterations=True,
             on_coarse=None):  # fmt: skip
    """Replica ``r``: its stages, and, once a stage has run :data:`ITERATION_EVERY` seconds,
    its Newton iterations at most that often (with the seconds the stage has run), go to
    ``on_stage`` and ``on_iteration`` in this process, or tagged through the workers' queue;
    with ``iterations``, so do the stages of the coarse ramp that predicts it
    (``Ramp(coarsen=m)``), to ``on_coarse``."""
    from ..protocol import run_ramp

    def send(msg, local):
        if local is not None:
            local(*msg[1:])
        elif _QUEUE is not None:
            _QUEUE.put(msg)

    began = [_clock()] * 2  # the stage's start, and the last report in it (or its start)

    def progress(i, n, stage):
        began[:] = [_clock()] * 2
        send(("stage", r, i, stage.lam, stage.result.converged), on_stage)

    def iteration(i, lam, it, energy, max_force):
        now = _clock()
        if now - began[1] >= ITERATION_EVERY:
            began[1] = now
            send(("iteration", r, i, lam, it, energy, max_force, now - began[0]), on_iteration)

    def coarse(n_segments, i, n, stage):
        began[:] = [_clock()] * 2  # the wire's first stage starts after the coarse ramp
        send(("coarse", r, n_segments, i, n, stage.lam, stage.result.converged), on_coarse)

    within = iteration if iterations and ramp.method == "newton" else None
    # as crumple.protocol.run_replicas: replica r uses SeedSequence(seed).spawn(n)[r]
    rng = np.random.default_rng(seed_seq)
    return run_ramp(wire, ramp, seed=rng, progress=progress, iteration=within,
                    coarse_progress=coarse if iterations else None)  # fmt: skip


def _dispatch(prog: Progress, msg: tuple) -> None:
    """A worker's message, ``("stage", ...)``, ``("iteration", ...)`` or ``("coarse", ...)``,
    to ``prog``."""
    kind, *args = msg
    if kind == "stage":
        prog.stage(*args)
    elif kind == "iteration":
        prog.iteration(*args)
    elif kind == "coarse":
        prog.coarse(*args)
    else:
        raise ValueError(f"unknown progress message {msg!r}")


def run_all(wire, ramp, n_rep: int, seed: int, workers: int, prog: Progress, done: dict) -> None:
    """Run the replicas, filling ``done[r]`` as each finishes. With several workers, worker
    processes report every stage (and the iterations of long stages) through a queue; on any
    exception (KeyboardInterrupt, :class:`Terminated`) they are terminated before it
    propagates."""
    from ..protocol import replica_seeds

    seeds = replica_seeds(seed, n_rep)
    if workers == 1:
        for r in range(n_rep):
            done[r] = _replica(wire, ramp, seeds[r], r, prog.stage, prog.iteration, not prog.quiet,
                               prog.coarse)  # fmt: skip
            prog.replica(r, done[r])
        return
    import multiprocessing as mp
    import queue as queue_mod

    # forkserver/spawn: never fork a process that holds threads (numba, BLAS)
    ctx = mp.get_context("spawn" if sys.platform != "linux" else "forkserver")
    q = ctx.Queue()
    pool = ctx.Pool(workers, initializer=_init_worker, initargs=(q,))
    try:
        job = [(wire, ramp, seeds[r], r, None, None, not prog.quiet) for r in range(n_rep)]
        pending = {r: pool.apply_async(_replica, job[r]) for r in range(n_rep)}
        while pending:
            try:
                while True:
                    _dispatch(prog, q.get(timeout=0.2))
            except queue_mod.Empty:
                pass
            for r in [r for r, a in pending.items() if a.ready()]:
                done[r] = pending.pop(r).get()
                prog.replica(r, done[r])
    except BaseException:
        pool.terminate()  # SIGTERM to every worker, then joined: none is left running
        raise
    else:
        pool.close()
    finally:
        pool.join()
        q.close()
        q.join_thread()


# --------------------------------------------------------------------------------------------
# Publishing the outputs
# --------------------------------------------------------------------------------------------


def _fsync(path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def draw(results, wire, lambdas, *, replica: int = 0):
    """The Fig. 2-style figure of one replica at ``lambdas`` (those it reached)."""
    from ..figures import plot_configurations
    from ..geometry import close_segment_pairs
    from ..stage_observables import CONTACT_FACTOR

    first = results[0]
    shown = [lam for lam in lambdas if any(s.lam == lam for s in first.stages)]
    if not shown:  # stopped early (stop_tol) before every figure λ
        shown = [first.stages[-1].lam]
    xs = [first.at(lam).positions for lam in shown]
    d = CONTACT_FACTOR * wire.hard_core
    plast = (
        ""
        if wire.plasticity is None
        else f", plastic s = {wire.plasticity.s:g}, θ_p = {wire.plasticity.theta_p:g}"
    )
    return plot_configurations(
        xs,
        shown,
        title=f"k_b = {wire.k_b:g}, k_s = {wire.k_s:g}, N = {wire.n_segments} "
        f"({wire.confinement} confinement{plast}), replica {replica}",
        trap_center=wire.trap_center,
        contacts=[close_segment_pairs(x, d)[0] for x in xs],
        contact_distance=d,
    )


def publish(out: Path, results, *, seed, fig, attrs=None, tag: str = "") -> tuple[Path, Path]:
    """Write ``ramps<tag>.h5`` and ``configurations<tag>.png`` so that they always match
    (module docstring); ``tag=".interrupted"`` for the replicas kept after a signal."""
    from ..storage import atomic_path, save_ramps

    h5, png = out / f"ramps{tag}.h5", out / f"configurations{tag}.png"
    # atomic_path renames on leaving its block, the inner block first: so the order is
    # 1. the old figure goes (no moment shows it beside new results), 2. the new results are
    # renamed into place, 3. then their figure; a failure anywhere deletes the temporaries
    with atomic_path(png, suffix=".png") as tmp_png:
        fig.savefig(tmp_png, dpi=130)
        with atomic_path(h5, suffix=".h5") as tmp_h5:
            save_ramps(tmp_h5, results, seed=seed, attrs=attrs)
            png.unlink(missing_ok=True)  # 1.
        # 2. done on leaving the inner block; 3. on leaving this one
    _fsync(out)
    return h5, png


# --------------------------------------------------------------------------------------------
# The command
# --------------------------------------------------------------------------------------------


def cmd_run(args) -> int:
    cfg = load_toml(args.config, _TABLES) if args.config else {}
    if protocol_kind(args, cfg) == "injection":
        from .run_injection import cmd_injection

        return cmd_injection(args, cfg)
    from .run_injection import reject_injection_flags

    reject_injection_flags(args)
    wire, ramp, run = build_run(args)
    n_rep = run["replicas"]
    seed = run.get("seed", 0)
    out = Path(run.get("out", "crumple-out"))
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    workers = min(n_rep, cores) if run.get("workers") is None else min(run["workers"], n_rep)
    if (out / "ramps.h5").exists() and not run.get("overwrite"):
        raise CLIError(
            f"{out / 'ramps.h5'} exists: pass --overwrite to replace it, or choose another --out"
        )
    if out.exists() and not out.is_dir():
        raise CLIError(f"--out {out} exists and is not a directory")
    if not args.quiet:
        print(describe(wire, ramp, run, workers), file=sys.stderr)
    for msg in advice(wire, ramp, n_rep):
        warn(msg)
    out.mkdir(parents=True, exist_ok=True)
    prog = Progress(args.quiet, n_rep, len(ramp.lambdas), ftol=ramp.ftol, maxiter=ramp.maxiter)
    done: dict = {}
    main_thread = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGTERM, _on_sigterm) if main_thread else None
    t0 = time.perf_counter()
    try:  # the handler stays through publishing: a signal there still keeps every replica
        run_all(wire, ramp, n_rep, seed, workers, prog, done)
        elapsed = time.perf_counter() - t0
        results = [done[r] for r in range(n_rep)]
        fig = draw(results, wire, run["figure_lambdas"])
        h5, png = publish(out, results, seed=seed, fig=fig)
    except (KeyboardInterrupt, Terminated, SystemError) as exc:
        cause = signal_cause(exc)
        if cause is None:
            raise
        return _interrupted(cause, out, done, n_rep, wire, seed, run)
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, old)
    failed = [(r, lam, msg) for r, res in enumerate(results) for lam, msg in res.failed_stages]
    summary = {
        "results": str(h5),
        "figure": str(png),
        "replicas": n_rep,
        "stages": len(ramp.lambdas),
        "seconds": round(elapsed, 3),
        "converged": not failed,
        "failed_stages": [{"replica": r, "lambda": lam, "message": m} for r, lam, m in failed],
        "wire": wire.to_dict(),
        "ramp": {k: v for k, v in ramp.to_dict().items() if k != "lambdas"},
        "final_energy": [res.stages[-1].energy.to_dict() for res in results],
    }
    print(json.dumps(summary, indent=2))
    return 0 if not failed else 3


def _interrupted(exc, out: Path, done: dict, n_rep: int, wire, seed, run) -> int:
    """After Ctrl-C or SIGTERM: the workers are stopped; keep the finished replicas in
    ``ramps.interrupted.h5`` (never over a complete ``ramps.h5``), ignoring further signals
    while they are saved (a second Ctrl-C must not cost them, nor print a traceback)."""
    main_thread = threading.current_thread() is threading.main_thread()
    saved = {}
    if main_thread:
        for sig in (signal.SIGINT, signal.SIGTERM):
            saved[sig] = signal.signal(sig, signal.SIG_IGN)
    try:
        return _keep_finished(exc, out, done, n_rep, wire, seed, run)
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def _keep_finished(exc, out: Path, done: dict, n_rep: int, wire, seed, run) -> int:
    what = "terminated" if isinstance(exc, Terminated) else "interrupted"
    code = 143 if isinstance(exc, Terminated) else 130
    sys.stderr.write("\n" if sys.stderr.isatty() else "")
    if not done:
        print(
            f"crumple: {what}: no replica had finished, nothing was written "
            f"(files in {out} are unchanged)",
            file=sys.stderr,
        )
        return code
    kept = sorted(done)
    results = [done[r] for r in kept]
    fig = draw(results, wire, run["figure_lambdas"], replica=kept[0])
    h5, _ = publish(out, results, seed=seed, fig=fig, tag=".interrupted",
                    attrs={"interrupted": True, "replica_ids": kept})  # fmt: skip
    print(
        f"crumple: {what}: kept the {len(kept)} finished replica(s) of {n_rep} "
        f"(replica ids {kept}) in {h5}, marked 'interrupted' ({out / 'ramps.h5'} is "
        "untouched); rerun for all",
        file=sys.stderr,
    )
    return code


#: crumple run's flags beyond the wire's: (flag, type, help with default and units).
_FLAGS = [
    ("--n-segments", int, "number of segments N (default 100)"),
    ("--rest-angle-sd", float, "imperfection: random rest angle per joint [rad] (default 0)"),
    ("--length", float, "wire length L0 [length] (default 1)"),
    ("--lambdas", str, "comma-separated λ stages [energy/length²] (default: 44 stages, "
     "geometric 1 … 2000 plus 70, 200, 300, 1000)"),
    ("--ftol", float, "equilibrium: largest node force [energy/length] (default 1e-6)"),
    ("--maxiter", int, "budget per stage: Newton iterations (default 5000) or Powell sweeps "
     "(default 20): Ramp's default for the method"),
    ("--max-step", float, "largest Newton node step, the trust radius cap [length] (default 0.5)"),
    ("--initial-noise", float,
     "transverse noise of the initial wire [segment lengths] (default 0.01)"),
    ("--stage-noise", float, "random kick before every stage [segment lengths] (default 0)"),
    ("--stop-tol", float, "stop when no node moves more than this [length] (default: never)"),
    ("--coarsen", int, "Newton: start each stage where the same continuum wire with N/COARSEN "
     "segments, ramped first, predicts (default 1: the plain ramp)"),
    ("--replicas", int, "independent replicas (default 1)"),
    ("--workers", int, "parallel processes, >= 1 (default: cores, at most one per replica)"),
    ("--seed", int, "base seed (default 0)"),
    ("--out", str, "output directory (default crumple-out)"),
    ("--figure-lambdas", str,
     "λ stages to draw (default: those of 70, 200, 300, 1000 in the ramp)"),
]  # fmt: skip


def register(sub) -> None:
    p = sub.add_parser(
        "run",
        help="run a quasi-static confinement ramp (or an injection into a cavity)",
        description="Run a quasi-static confinement ramp (and its replicas); write "
        "OUT/ramps.h5 and OUT/configurations.png. Lengths are in units of L0, energies in the "
        "paper's units. Flags override the TOML file; every parameter is echoed before the run.",
    )
    p.add_argument("--config", help="TOML file with [wire], [ramp], [run] tables")
    add_model_flags(p, required=False)
    for flag, kind, text in _FLAGS:
        p.add_argument(flag, type=kind, help=text)
    p.add_argument("--method", choices=["newton", "powell"], help="minimiser (default newton)")
    p.add_argument(
        "--curved-steps",
        action=argparse.BooleanOptionalAction,
        help="Newton: also try curved trial points where no contact acts "
        "(default: crumple.relax.CURVED_STEPS)",
    )
    p.add_argument(
        "--fallback",
        choices=["auto", "projected", "exact", "caps"],
        help="Newton: the step where the Hessian is indefinite (default auto: exact above "
        "1000 segments, contact-projected below; caps: exact with the contacts at a "
        "segment's end projected)",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an existing OUT/ramps.h5 (refused otherwise)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument(
        "--protocol",
        choices=["ramp", "injection"],
        help="the loading protocol (default: the TOML's [protocol] kind, else ramp)",
    )
    from .run_injection import add_injection_flags

    add_injection_flags(p)
    p.set_defaults(func=cmd_run)
