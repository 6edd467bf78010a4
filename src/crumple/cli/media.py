"""``crumple plot`` and ``crumple animate``: pictures of a stored ramp, after the fact."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from .inputs import CLIError, floats
from .inspect import add_stage_flags
from .results import read_results, replica_index, stage_index

__all__ = ["cmd_animate", "cmd_plot", "register"]


def _title(attrs: dict, r: int) -> str:
    w = attrs["wire"]
    plast = w.get("plasticity")
    extra = f", plastic s = {plast['s']:g}, θ_p = {plast['theta_p']:g}" if plast else ""
    return (
        f"k_b = {w['k_b']:g}, k_s = {w['k_s']:g}, N = {w['n_segments']} "
        f"({w['confinement']} confinement{extra}), replica {r}"
    )


def cmd_plot(args) -> int:
    from ..figures import plot_configurations
    from ..geometry import close_segment_pairs
    from ..protocol import PAPER_LAMBDAS
    from ..stage_observables import CONTACT_FACTOR
    from ..storage import atomic_path

    res = read_results(args.file)
    r = replica_index(res, args.file, args.replica)
    n_run = int(res["n_stages"][r])
    lams = np.asarray(res["lambda"], float)
    if args.lam is not None:
        idx = [stage_index(res, args.file, r, v) for v in floats(args.lam, "--lam")]
    elif args.stage is not None:
        if not -n_run <= args.stage < n_run:
            raise CLIError(f"replica {r} has {n_run} stages (0 … {n_run - 1}), not {args.stage}")
        idx = [args.stage % n_run]
    else:
        idx = [s for s in range(n_run) if lams[s] in PAPER_LAMBDAS] or [n_run - 1]
    if not idx:
        raise CLIError("give at least one λ")
    out = Path(args.output)
    if out.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise CLIError(f"-o must end in .png, .svg or .pdf, got {out.name!r}")
    wire = res["attrs"]["wire"]
    d = CONTACT_FACTOR * wire["hard_core"]
    xs = [res["positions"][r, s] for s in idx]
    fig = plot_configurations(
        xs,
        [float(lams[s]) for s in idx],
        title=_title(res["attrs"], r),
        trap_center=tuple(wire.get("trap_center", (0.0, 0.0))),
        contacts=[close_segment_pairs(x, d)[0] for x in xs],
        contact_distance=d,
        common_scale=not args.own_scale,
    )
    # the temporary name keeps the suffix: Matplotlib picks the format from it
    with atomic_path(out, suffix=out.suffix) as tmp:
        fig.savefig(tmp, dpi=130)
    print(f"crumple: wrote {out}", file=sys.stderr)
    return 0


def cmd_animate(args) -> int:
    from matplotlib import animation

    from ..figures import ramp_animation
    from ..storage import atomic_path

    if not (0 < args.fps <= 100):
        raise CLIError(f"--fps must be in (0, 100], got {args.fps:g}")
    if args.dpi < 1:
        raise CLIError(f"--dpi must be >= 1 [dots per inch], got {args.dpi}")
    out = Path(args.output)
    suffix = out.suffix.lower()
    if suffix == ".gif":
        writer = animation.PillowWriter(fps=args.fps)
    elif suffix == ".mp4":
        if not animation.writers.is_available("ffmpeg"):
            raise CLIError("writing .mp4 needs ffmpeg, which is not installed; use -o ramp.gif")
        writer = animation.FFMpegWriter(fps=args.fps)
    else:
        raise CLIError(f"-o must end in .gif or .mp4, got {out.name!r}")
    res = read_results(args.file)
    r = replica_index(res, args.file, args.replica)
    n = int(res["n_stages"][r])
    energies = {t: res[f"energy/{t}"][r, :n] for t in ("bending", "stretching", "confinement",
                                                         "hard_core", "total")}  # fmt: skip
    anim = ramp_animation(
        res["positions"][r, :n],
        res["lambda"][:n],
        energies,
        converged=res["solver/converged"][r, :n],
        title=_title(res["attrs"], r),
    )
    # the temporary name keeps the suffix: Matplotlib picks the writer's format from it
    with atomic_path(out, suffix=out.suffix) as tmp:
        anim.save(tmp, writer=writer, dpi=args.dpi)
    print(f"crumple: wrote {out} ({n} frames, one per stage)", file=sys.stderr)
    return 0


def register(sub) -> None:
    p = sub.add_parser("plot", help="draw stored configurations of any stages (Fig. 2 style)")
    add_stage_flags(p, lam_help="comma-separated λ stages to draw (default: those of 70, 200, "
                    "300, 1000 in the file, else the last)")  # fmt: skip
    p.add_argument("-o", "--output", default="configurations.png", help="image (.png/.svg/.pdf)")
    p.add_argument("--own-scale", action="store_true",
                   help="each panel on its own scale, with a scale bar (default: one common "
                   "scale, so the shrinking shows)")  # fmt: skip
    p.set_defaults(func=cmd_plot)

    p = sub.add_parser("animate", help="the ramp as an animation, λ and energies on screen")
    p.add_argument("file", help="results file written by crumple run (ramps.h5)")
    p.add_argument("-o", "--output", default="ramp.gif",
                   help=".gif (Pillow, no ffmpeg needed) or .mp4 (needs ffmpeg)")  # fmt: skip
    p.add_argument("--replica", type=int, default=0, help="replica index")
    p.add_argument("--fps", type=float, default=5.0, help="frames (stages) per second")
    p.add_argument("--dpi", type=int, default=100, help="resolution [dots per inch], >= 1")
    p.set_defaults(func=cmd_animate)
