"""``crumple run --protocol injection``: a wire pushed into a cavity, its replicas, on disk.

Writes ``OUT/injection.h5`` (:mod:`crumple.injection_storage`) and ``OUT/injection.png`` (the
cavity and the wire at chosen injected lengths), never over an existing ``injection.h5``
without ``--overwrite``. Parameters come from the TOML file (``[wire]``, ``[protocol]`` with
``kind = "injection"`` and the :class:`crumple.injection.Injection` keys, ``[run]``) overridden
by the flags, and are echoed before anything is simulated.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from .inputs import CLIError, floats, positive_int

__all__ = ["add_injection_flags", "cmd_injection", "reject_injection_flags"]

#: Injection flags: (flag, Injection key or None, type, help).
_FLAGS = [
    ("--cavity-radius", None, float, "injection: cavity radius R_c [length] (default 0.1)"),
    ("--thickness", None, float, "injection: wire thickness h, the hard-core width [length] "
     "(default R_c/50)"),
    ("--push", "push", float, "injection: length pushed in per stage [length] (default one "
     "segment)"),
    ("--stop-length", "stop_length", float, "injection: stop at this injected length [length] "
     "(default L0 less one segment)"),
    ("--entry-angle", "angle", float, "injection: channel angle from the inward radial [rad] "
     "(default 0)"),
    ("--jam-force", "jam_force", float, "injection: stop when the feed force exceeds this "
     "[energy/length] (default: never)"),
    ("--max-push", "max_push", float, "injection: largest channel move per minimisation "
     "[length] (default an eighth of a segment)"),
    ("--noise", "noise", float, "injection: transverse kick of a released node [segment "
     "lengths] (default 0.01)"),
    ("--figure-lengths", None, str, "injection: injected lengths to draw (default: four, "
     "evenly spread)"),
]  # fmt: skip
_SHARED = ("ftol", "maxiter", "max_step")


def reject_injection_flags(args) -> None:
    """Raise :class:`CLIError` naming any injection flag given to a ramp (as an injection
    rejects the ramp's flags)."""
    given = [flag for flag, *_ in _FLAGS
             if getattr(args, flag[2:].replace("-", "_"), None) is not None]  # fmt: skip
    if given:
        raise CLIError(
            f"{', '.join(given)}: injection flag(s), not a ramp's (set kind = 'injection' in "
            "the [protocol] table, or --protocol injection)"
        )


_RUN_KEYS = ("replicas", "seed", "out", "overwrite", "figure_lengths")


def add_injection_flags(p) -> None:
    for flag, _, kind, text in _FLAGS:
        p.add_argument(flag, type=kind, help=text)


def _injection(args, cfg: dict):
    from ..injection import Injection

    table = {k: v for k, v in cfg.get("protocol", {}).items() if k != "kind"}
    known = set(Injection.__dataclass_fields__)
    unknown = set(table) - known
    if unknown:
        raise CLIError(
            f"unknown [protocol] key(s) for kind = 'injection': "
            f"{', '.join(sorted(unknown))}; known: {', '.join(sorted(known))}"
        )
    for flag, key, _, _ in _FLAGS:
        v = getattr(args, flag[2:].replace("-", "_"))
        if key is not None and v is not None:
            table[key] = v
    for key in _SHARED:
        if getattr(args, key) is not None:
            table[key] = getattr(args, key)
    for key in (
        "initial_noise",
        "stage_noise",
        "stop_tol",
        "lambdas",
        "method",
        "curved_steps",
        "fallback",
        "coarsen",
    ):
        if getattr(args, key) is not None:
            raise CLIError(f"--{key.replace('_', '-')} is a ramp flag, not an injection's")
    return Injection.from_dict(table)


def _wire(args, cfg: dict):
    from .run import build_wire

    if args.thickness is not None and args.hard_core is not None:
        raise CLIError("give the thickness once: --thickness or --hard-core")
    if args.thickness is not None:
        args.hard_core = args.thickness
    if args.cavity_radius is not None:
        cfg = {**cfg, "wire": {**cfg.get("wire", {}), "cavity_radius": args.cavity_radius}}
    defaults = {"cavity_radius": 0.1, "hard_core": lambda w: w["cavity_radius"] / 50.0}
    return build_wire(args, cfg, defaults)


def _run_options(args, cfg: dict) -> dict:
    run = dict(cfg.get("run", {}))
    for key in ("replicas", "seed", "out", "overwrite", "figure_lengths"):
        v = getattr(args, key, None)
        if v is not None and v is not False:
            run[key] = v
    unknown = set(run) - set(_RUN_KEYS)
    if unknown:
        raise CLIError(f"unknown [run] key(s) for an injection: {', '.join(sorted(unknown))}")
    run["replicas"] = positive_int(run.get("replicas", 1), "replicas")
    seed = run.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise CLIError(f"seed must be a whole number >= 0, got {seed!r}")
    return run


def _figure_lengths(value, planned: np.ndarray) -> list[float]:
    """The planned stages nearest to the asked lengths (default four, evenly spread)."""
    if value is None:
        idx = np.unique(np.linspace(0, len(planned) - 1, min(4, len(planned))).round())
        return [float(planned[int(i)]) for i in idx]
    wanted = floats(value, "--figure-lengths") if isinstance(value, str) else list(value)
    out = []
    for v in wanted:
        hit = np.flatnonzero(np.isclose(planned, float(v), rtol=1e-9, atol=1e-12))
        if not hit.size:
            raise CLIError(f"figure length {v:g} is not a planned stage (every {planned[0]:g} "
                           f"up to {planned[-1]:g})")  # fmt: skip
        out.append(float(planned[hit[0]]))
    return out


def _progress(quiet: bool, r: int):
    t0 = time.perf_counter()
    last = [-math.inf]
    tty = sys.stderr.isatty()

    def report(i, n, stage):
        if quiet or (not tty and time.monotonic() - last[0] < 5.0 and i + 1 < n):
            return
        last[0] = time.monotonic()
        bad = "" if stage.result.converged else " NOT converged"
        line = (
            f"  replica {r}: stage {i + 1}/{n}, L_in = {stage.injected_length:.4g}, "
            f"F = {stage.feed_force:.4g}{bad}, {time.perf_counter() - t0:.0f} s"
        )
        sys.stderr.write(f"\r{line}   " if tty else line + "\n")
        sys.stderr.flush()

    return report


def draw(results, lengths):
    """The first replica at ``lengths`` (those it reached) in its cavity."""
    from ..figures import plot_injection

    res = results[0]
    stages = [s for s in res.stages if any(np.isclose(s.injected_length, v) for v in lengths)]
    stages = stages or [res.stages[-1]]
    w = res.wire
    return plot_injection(
        [s.positions for s in stages], [s.injected_length for s in stages], w.cavity_radius,
        free=[s.free for s in stages], forces=[s.feed_force for s in stages],
        title=f"injection: k_b = {w.k_b:g}, k_s = {w.k_s:g}, N = {w.n_segments}, R_c = "
        f"{w.cavity_radius:g}, h = {w.hard_core:g}; stopped: "
        f"{'stop length reached' if res.stop_reason == 'length' else 'jammed'}",
    )  # fmt: skip


def cmd_injection(args, cfg: dict) -> int:
    from ..injection import run_injection
    from ..injection_storage import planned_lengths, save_injections
    from ..protocol import replica_seeds
    from ..storage import atomic_path

    if "ramp" in cfg:
        raise CLIError(
            "a [ramp] table with [protocol] kind = 'injection': the injection's "
            "parameters go in [protocol]"
        )
    wire = _wire(args, cfg)
    inj = _injection(args, cfg)
    run = _run_options(args, cfg)
    planned = planned_lengths(wire, inj)  # checks the injection against the wire
    figure = _figure_lengths(run.get("figure_lengths"), planned)
    out = Path(run.get("out", "crumple-out"))
    h5, png = out / "injection.h5", out / "injection.png"
    if h5.exists() and not run.get("overwrite"):
        raise CLIError(f"{h5} exists: pass --overwrite to replace it, or choose another --out")
    if not args.quiet:
        print(f"crumple run (injection):\n  wire: {json.dumps(wire.to_dict())}\n  injection: "
              f"{json.dumps(inj.to_dict())}, {len(planned)} stages\n  run: {run['replicas']} "
              f"replica(s), seed = {run.get('seed', 0)}, out = {out}", file=sys.stderr)  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    results = []
    for r, s in enumerate(replica_seeds(run.get("seed", 0), run["replicas"])):
        results.append(run_injection(wire, inj, seed=np.random.default_rng(s),
                                     progress=_progress(args.quiet, r)))  # fmt: skip
    if not args.quiet and sys.stderr.isatty():
        sys.stderr.write("\n")
    fig = draw(results, figure)
    with atomic_path(png, suffix=".png") as tmp_png:
        fig.savefig(tmp_png, dpi=130)
        with atomic_path(h5, suffix=".h5") as tmp_h5:
            save_injections(tmp_h5, results, seed=run.get("seed", 0))
            png.unlink(missing_ok=True)
    failed = [{"replica": r, "injected_length": L, "message": m}
              for r, res in enumerate(results) for L, m in res.failed_stages]  # fmt: skip
    print(json.dumps({
        "results": str(h5), "figure": str(png), "replicas": len(results),
        "seconds": round(time.perf_counter() - t0, 3), "converged": not failed,
        "failed_stages": failed,
        "stop": [{"reason": res.stop_reason, "message": res.stop_message} for res in results],
        "final_injected_length": [res.stages[-1].injected_length for res in results],
        "final_feed_force": [res.stages[-1].feed_force for res in results],
        "final_energy": [res.stages[-1].energy.to_dict() for res in results],
    }, indent=2))  # fmt: skip
    return 0 if not failed else 3
