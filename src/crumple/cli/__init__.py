"""The ``crumple`` command line: thin wrappers over the library.

    crumple run       [--config FILE.toml] [flags]    a ramp (or --protocol injection): HDF5, PNG
    crumple energy    FILE --kb .. --ks .. --lam ..    energy of a configuration by term (JSON)
    crumple measure   FILE [options]                   observables of a configuration (JSON)
    crumple export    FILE.h5 [--lam L | --stage i]    one stored configuration as npy/csv/xyz
    crumple plot      FILE.h5 [--lam L,...]            stored configurations as a figure
    crumple animate   FILE.h5 -o ramp.gif              the ramp as an animation
    crumple sweep     CONFIG.toml --out PATH [...]     run a parameter sweep on Dask (resumable)
    crumple status    PATH                             done / failed / missing runs of a sweep
    crumple reproduce [--quick] [--out DIR]            the paper's figures and numbers
    crumple figures   DIR                              redraw reproduce's report, no simulation
    crumple study     continuum [--quick] [--out DIR]  a study beyond the paper (continuum limit)
    crumple study     cavity [--quick] [--out DIR]     injection into a cavity vs the potential

Every error is one line on stderr and a non-zero exit status, never a traceback.

Modules, by concept: :mod:`.inputs` (reading and validating files, flags, TOML),
:mod:`.results` (reading a results file), :mod:`.run`, :mod:`.run_injection` (run
--protocol injection), :mod:`.inspect` (energy, measure, export), :mod:`.media` (plot,
animate), :mod:`.sweep_cmds` (sweep, status, reproduce, figures), :mod:`.study` (study).
Each command module has a ``register(subparsers)``.
"""

from __future__ import annotations

import sys

from . import inspect, media, run, study, sweep_cmds
from .inputs import CLIError, Parser, join_negative_values, read_positions

__all__ = ["CLIError", "build_parser", "main", "read_positions"]


def build_parser() -> Parser:
    """The ``crumple`` parser with every subcommand."""
    from .. import __version__

    parser = Parser(
        prog="crumple",
        description="Energy-minimal simulation of elastic wires crumpled in two dimensions. "
        "Lengths are in units of the wire's rest length L0, energies in the paper's units.",
    )
    parser.add_argument("--version", action="version", version=f"crumple {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for module in (run, inspect, media, sweep_cmds, study):
        module.register(sub)
    return parser


def main(argv=None) -> int:
    """Run one command; return its exit status (2: bad input, 130: interrupted)."""
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = parser.parse_args(join_negative_values(argv))
        return args.func(args)
    except CLIError as exc:
        print(f"crumple: error: {exc}", file=sys.stderr)
        return 2
    except (ValueError, TypeError, OSError) as exc:
        print(f"crumple: error: {'; '.join(str(exc).splitlines())}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, SystemError) as exc:
        if not isinstance(run.signal_cause(exc), KeyboardInterrupt):
            raise
        print("crumple: interrupted", file=sys.stderr)
        return 130
