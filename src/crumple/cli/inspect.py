"""``crumple energy``, ``crumple measure`` and ``crumple export``: one configuration in, numbers
or a file out."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

from .advice import warn
from .inputs import CLIError, add_model_flags, floats, plasticity, read_positions
from .results import pick_stage, read_results

__all__ = ["cmd_energy", "cmd_export", "cmd_measure", "register"]


# --------------------------------------------------------------------------------------------
# crumple energy
# --------------------------------------------------------------------------------------------


def cmd_energy(args) -> int:
    from ..energy import energy_terms
    from ..geometry import find_crossings, segment_lengths
    from ..model import Wire

    x = read_positions(args.file)
    seg = segment_lengths(x)
    if np.any(seg == 0):
        i = int(np.flatnonzero(seg == 0)[0])
        raise CLIError(
            f"{args.file}: nodes {i} and {i + 1} coincide (a segment of length 0 has no "
            "direction, so its bending energy is undefined)"
        )
    if args.length == "auto":
        length = float(seg.sum())
    else:
        length = floats(args.length, "--length", 1)[0]
    wire = Wire(
        k_b=args.kb,
        k_s=args.ks,
        n_segments=x.shape[0] - 1,
        length=length,
        confinement=args.confinement,
        hard_core=args.hard_core,
        hard_core_energy=args.hard_core_energy,
        plasticity=plasticity(args),
        trap_center=tuple(floats(args.center, "--center", 2)),
    )
    rest = None
    if args.rest_angles is not None:
        rest = read_rest_angles(args.rest_angles, x.shape[0])
    with np.errstate(all="ignore"):  # overflow is caught below as a non-finite result
        out = energy_terms(wire, x, args.lam, rest_angles=rest).to_dict()
        crossings = len(find_crossings(x))
    bad = [k for k, v in out.items() if not math.isfinite(v)]
    if bad:
        raise CLIError(
            f"the energy is not finite ({', '.join(bad)}): the positions (largest |x| = "
            f"{np.abs(x).max():.3g}) overflow double precision; rescale them"
        )
    out["crossings"] = crossings
    out["n_segments"] = wire.n_segments
    out["length"] = wire.length
    print(json.dumps(out, indent=2, allow_nan=False))
    if crossings:
        warn(
            f"the wire crosses itself {crossings} time(s); the hard core cannot see a "
            "crossing, so its energy is not meaningful"
        )
    return 0


def read_rest_angles(path, n_nodes: int) -> np.ndarray:
    """An imperfect wire's rest angles [rad], shape (n_nodes - 2,), from a .npy file (as
    ``crumple export`` writes them beside the positions) or a text file of one angle a line."""
    path = Path(path)
    if not path.is_file():
        raise CLIError(f"no such rest-angle file: {path}")
    try:
        a = np.load(path) if path.suffix == ".npy" else np.loadtxt(path, ndmin=1)
    except (OSError, ValueError) as exc:
        raise CLIError(f"{path}: cannot read rest angles ({exc})") from None
    a = np.asarray(a, dtype=float).ravel()
    if a.shape != (n_nodes - 2,):
        raise CLIError(
            f"{path} holds {a.size} rest angle(s); a wire of {n_nodes} nodes has {n_nodes - 2}"
        )
    if not np.isfinite(a).all():
        raise CLIError(f"{path}: the rest angles must be finite numbers [rad]")
    return a


# --------------------------------------------------------------------------------------------
# crumple measure
# --------------------------------------------------------------------------------------------


def cmd_measure(args) -> int:
    from ..geometry import segment_lengths
    from ..observables import measure
    from ..stage_observables import CONTACT_DISTANCE

    x = read_positions(args.file)
    dist = CONTACT_DISTANCE if args.contact_distance is None else args.contact_distance
    seg = segment_lengths(x)
    positive = seg[seg > 0]
    shortest = float(positive.min()) if positive.size else 0.0
    if shortest and dist >= shortest:
        # segments i and i + 2 are one segment apart along the wire: with a distance that
        # large every straight stretch counts as contacts with itself
        how = "the default" if args.contact_distance is None else "--contact-distance"
        warn(
            f"the contact distance {dist:g} ({how}) is not below the shortest segment "
            f"{shortest:.3g}, so the wire's own neighbouring segments count as contacts; pass "
            "--contact-distance below the segment length (docs/observables.md)"
        )
    kwargs = {
        "rg": args.rg,
        "fit_range": tuple(floats(args.fit_range, "--fit-range", 2)),
        "contact_distance": dist,
        "loop_distance": args.loop_distance,
    }
    if args.center is not None:
        kwargs["center"] = tuple(floats(args.center, "--center", 2))
    if args.radii is not None:
        kwargs["radii"] = floats(args.radii, "--radii")
    with np.errstate(all="ignore"):
        out = measure(x, **kwargs)
    try:
        text = json.dumps(out, indent=2, allow_nan=False)
    except ValueError:
        raise CLIError(
            f"a measurement is not finite: the positions (largest |x| = {np.abs(x).max():.3g}) "
            "overflow double precision; rescale them"
        ) from None
    print(text)
    return 0


# --------------------------------------------------------------------------------------------
# crumple export
# --------------------------------------------------------------------------------------------

_FORMATS = ("npy", "csv", "xyz")


def rest_path(output) -> Path:
    """Where ``crumple export -o OUTPUT`` writes an imperfect wire's rest angles:
    ``w.csv`` -> ``w.rest.npy``."""
    out = Path(output)
    return out.with_name(f"{out.stem}.rest.npy")


def cmd_export(args) -> int:
    from ..storage import atomic_path, atomic_write_text

    fmt = args.format
    if fmt is None:
        suffix = Path(args.output).suffix.lstrip(".") if args.output else ""
        if suffix not in _FORMATS:
            raise CLIError("give --format npy|csv|xyz (or an -o name ending in one of them)")
        fmt = suffix
    if fmt == "npy" and not args.output:
        raise CLIError("--format npy writes a binary file: give -o FILE.npy")
    res = read_results(args.file)
    r, s = pick_stage(res, args.file, replica=args.replica, lam=args.lam, stage=args.stage)
    x = res["positions"][r, s]
    lam = float(res["lambda"][s])
    wire = res["attrs"]["wire"]
    rest = res.get("rest_angles")
    rest = None if rest is None or np.isnan(rest[r]).all() else rest[r]
    rest_file = rest_path(args.output or "FILE") if rest is not None else None
    if rest is not None and not args.output:
        warn(
            f"{args.file} is an imperfect wire: its rest angles [rad], which its bending "
            "energy needs, go to a file beside the positions; export with -o FILE to get them"
        )
    hint = energy_command(wire, lam, args.output or "FILE", rest_angles=rest_file)
    header = (
        f"crumple export of {args.file}: replica {r}, stage {s}, lambda = {lam:g}, "
        f"{x.shape[0]} nodes [length]; energy: {hint}"
    )
    if rest_file is not None and args.output:
        with atomic_path(rest_file, suffix=".npy") as tmp:
            np.save(tmp, rest)
    if fmt == "npy":
        with atomic_path(args.output, suffix=".npy") as tmp:
            np.save(tmp, x)
    else:
        if fmt == "csv":
            rows = "\n".join(f"{a!r},{b!r}" for a, b in x.tolist())
            text = f"# {header}\n# x,y\n{rows}\n"
        else:
            rows = "\n".join(f"C {a!r} {b!r} 0.0" for a, b in x.tolist())
            text = f"{x.shape[0]}\n{header}\n{rows}\n"
        if args.output:
            atomic_write_text(args.output, text)
        else:
            sys.stdout.write(text)
            return 0
    print(f"crumple: wrote {args.output} ({header})", file=sys.stderr)
    return 0


def energy_command(wire: dict, lam: float, path, rest_angles=None) -> str:
    """The ``crumple energy`` line that recomputes a stored stage's energy from its export
    (with ``--rest-angles FILE`` for an imperfect wire)."""
    parts = [f"crumple energy {path} --kb {wire['k_b']!r} --ks {wire['k_s']!r} --lam {lam!r}"]
    if rest_angles is not None:
        parts.append(f"--rest-angles {rest_angles}")
    if wire.get("length", 1.0) != 1.0:
        parts.append(f"--length {wire['length']!r}")
    if wire.get("confinement", "per-length") != "per-length":
        parts.append(f"--confinement {wire['confinement']}")
    if wire.get("hard_core", 1e-5) != 1e-5:
        parts.append(f"--hard-core {wire['hard_core']!r}")
    if wire.get("hard_core_energy", 1e-3) != 1e-3:
        parts.append(f"--hard-core-energy {wire['hard_core_energy']!r}")
    if wire.get("plasticity"):
        p = wire["plasticity"]
        parts.append(f"--plastic-s {p['s']!r} --plastic-theta {p['theta_p']!r}")
    c = wire.get("trap_center", (0.0, 0.0))
    if tuple(c) != (0.0, 0.0):
        parts.append(f"--center={c[0]!r},{c[1]!r}")
    return " ".join(parts)


# --------------------------------------------------------------------------------------------
# Parser
# --------------------------------------------------------------------------------------------


def add_stage_flags(p, *, lam_help: str) -> None:
    """Which replica and which stage of a results file."""
    p.add_argument("file", help="results file written by crumple run (ramps.h5)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--lam", help=lam_help)
    g.add_argument("--stage", type=int, help="stage index (0 first, -1 last)")
    p.add_argument("--replica", type=int, default=0, help="replica index")


def register(sub) -> None:
    p = sub.add_parser("energy", help="energy of a configuration by term, as JSON")
    p.add_argument("file", help=".npy array, .xyz, or text/CSV file of x y rows [length]")
    add_model_flags(p, required=True)
    p.add_argument("--lam", type=float, required=True, help="trap strength λ [energy/length²]")
    p.add_argument("--length", default="1", help="rest length L0 of the wire [length], or 'auto'")
    p.add_argument("--center", default="0,0", help="trap centre x,y [length]")
    p.add_argument(
        "--rest-angles",
        help="an imperfect wire's rest angles [rad]: .npy or text, n_nodes - 2 values (crumple "
        "export -o FILE writes them to FILE's stem + .rest.npy); default: a straight wire",
    )
    p.set_defaults(func=cmd_energy)

    p = sub.add_parser("measure", help="observables of a configuration, as JSON")
    p.add_argument("file", help=".npy array, .xyz, or text/CSV file of x y rows [length]")
    p.add_argument("--center", help="centre x,y [length] (default: centre of mass)")
    p.add_argument("--radii", help="comma-separated radii for mass_within [length]")
    p.add_argument("--rg", choices=["r_max", "rms"], default="r_max", help="which R_G")
    p.add_argument("--fit-range", default="0.5,1", help="D_M fit range in units of R_G")
    p.add_argument(
        "--contact-distance",
        type=float,
        help="contact distance [length] (default 2e-5 = 2 × the hard-core width of Table I, "
        "as the contacts a sweep stores; warns when it is not below the shortest segment)",
    )
    p.add_argument(
        "--loop-distance",
        type=float,
        help="the loops' contact distance [length] (default: the contact distance; "
        "docs/observables.md)",
    )
    p.set_defaults(func=cmd_measure)

    p = sub.add_parser(
        "export",
        help="one stored configuration as .npy, CSV or XYZ (for crumple energy/measure or "
        "other codes)",
    )
    add_stage_flags(p, lam_help="trap strength λ of the stage (default: the last stage)")
    p.add_argument("--format", choices=_FORMATS, help="npy, csv or xyz (default: from -o)")
    p.add_argument(
        "-o",
        "--output",
        help="output file (default: standard output, csv/xyz); an imperfect wire's rest "
        "angles [rad] go beside it, to its stem + .rest.npy (w.csv -> w.rest.npy)",
    )
    p.set_defaults(func=cmd_export)
