"""Reading and validating what the user gives the command line: files, flags, TOML.

Everything here turns bad input into a :class:`CLIError` with a one-line message; nothing
here runs physics.
"""

from __future__ import annotations

import argparse
import math
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np

__all__ = ["CLIError", "read_positions"]


class CLIError(Exception):
    """An error to report on one line."""


class HelpFormatter(argparse.HelpFormatter):
    """Appends ``(default: X)`` to a flag's help unless the help already states it, the
    default is None (the value then comes from a TOML file or the library) or a store_true."""

    def _get_help_string(self, action):
        text = action.help or ""
        if "default" in text or action.default in (None, False, argparse.SUPPRESS):
            return text
        if action.option_strings or action.nargs in ("?", "*"):
            text += " (default: %(default)s)"
        return text


class Parser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line, not usage + message."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message):
        raise CLIError(f"{message} (see '{self.prog} --help')")


#: Flags whose value is a comma-separated list of numbers, which may start with "-".
LIST_FLAGS = ("--lambdas", "--figure-lambdas", "--lam", "--radii", "--center", "--fit-range")
_NUMBER_LIST = re.compile(r"^-[\d.]")


def join_negative_values(argv: list[str]) -> list[str]:
    """``--lambdas -5,10`` → ``--lambdas=-5,10``.

    argparse takes a value that starts with ``-`` for an option unless it is one plain
    negative number, so a list such as ``-5,10`` would be "expected one argument".

    >>> join_negative_values(["run", "--lambdas", "-5,10", "--kb", "-1"])
    ['run', '--lambdas=-5,10', '--kb', '-1']
    """
    out: list[str] = []
    i = 0
    while i < len(argv):
        a = argv[i]
        if a in LIST_FLAGS and i + 1 < len(argv) and _NUMBER_LIST.match(argv[i + 1]):
            out.append(f"{a}={argv[i + 1]}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def floats(text: str, name: str, n: int | None = None) -> list[float]:
    """Comma-separated finite numbers; ``n`` of them if given."""
    try:
        vals = [float(v) for v in str(text).split(",") if v.strip()]
    except ValueError:
        raise CLIError(f"{name} must be comma-separated numbers, got {text!r}") from None
    if n is not None and len(vals) != n:
        raise CLIError(f"{name} needs {n} comma-separated numbers, got {text!r}")
    if not all(math.isfinite(v) for v in vals):
        raise CLIError(f"{name} must be finite, got {text!r}")
    return vals


def positive_int(value, name: str) -> int:
    """An integer >= 1 (an int, or a float/str that is exactly one: TOML's ``2.0`` is not)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise CLIError(f"{name} must be a whole number >= 1, got {value!r}")
    if value < 1:
        raise CLIError(f"{name} must be >= 1, got {value}")
    return value


def _read_xyz(path: Path) -> np.ndarray:
    """XYZ: a count line, a comment line, then ``name x y [z]`` rows (z must be 0)."""
    lines = path.read_text().splitlines()
    if len(lines) < 2:
        raise CLIError(f"{path}: an XYZ file needs a count line and a comment line")
    try:
        n = int(lines[0].split()[0])
    except (ValueError, IndexError):
        raise CLIError(f"{path}: the first line of an XYZ file is the number of nodes") from None
    rows = [ln.split() for ln in lines[2 : 2 + n] if ln.strip()]
    if len(rows) != n:
        raise CLIError(f"{path}: the header says {n} nodes, the file has {len(rows)}")
    try:
        x = np.array([[float(v) for v in r[1:]] for r in rows])
    except ValueError as exc:
        raise CLIError(f"cannot read positions from {path}: {exc}") from None
    if x.ndim != 2 or x.shape[1] not in (2, 3):
        raise CLIError(f"{path}: expected 'name x y [z]' rows")
    if x.shape[1] == 3:
        if np.any(x[:, 2] != 0):
            raise CLIError(f"{path}: z must be 0 for a wire in two dimensions")
        x = x[:, :2]
    return x


#: Largest |coordinate| accepted [length]: squares of larger values overflow a double
#: (sqrt(1.8e308) = 1.3e154), and the cell lists of the hard core stop working long before.
#: Lengths are in units of the wire's rest length, so a wire is of order 1.
MAX_COORDINATE = 1e150


def read_positions(path) -> np.ndarray:
    """Node positions from a ``.npy`` array, an ``.xyz`` file or a text/CSV file of ``x y``
    rows.

    Text files: one node per row, two columns separated by whitespace or a comma; lines
    starting with ``#`` are comments. Refused, each with a one-line :class:`CLIError`: a
    missing or empty file, anything but real numbers (strings, complex, booleans, objects), a
    shape other than ``(n_nodes, 2)``, fewer than 4 nodes, NaN or infinite values (including
    values that overflow a double), coordinates beyond :data:`MAX_COORDINATE`. Reading never
    prints a NumPy warning.
    """
    path = Path(path)
    if not path.is_file():
        raise CLIError(f"no such file: {path}")
    try:
        # a warning (empty file, overflow on parsing) is an error here, not a line on stderr
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            if path.suffix == ".npy":
                x = np.load(path, allow_pickle=False)
            elif path.suffix == ".xyz":
                x = _read_xyz(path)
            else:
                with path.open() as fh:
                    lines = [ln for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
                if not lines:
                    raise CLIError(f"{path}: no positions in the file (empty, or only comments)")
                delim = "," if "," in lines[0] else None
                x = np.loadtxt(lines, delimiter=delim, ndmin=2)
    except CLIError:
        raise
    except (ValueError, OSError, UnicodeDecodeError, Warning) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CLIError(f"cannot read positions from {path}: {msg}") from None
    x = np.asarray(x)
    if x.dtype.kind not in "iuf":
        what = {"c": "complex numbers", "b": "booleans", "U": "strings", "S": "strings"}
        raise CLIError(
            f"{path}: positions must be real numbers, the array holds "
            f"{what.get(x.dtype.kind, str(x.dtype))}"
        )
    x = x.astype(np.float64)
    if x.ndim != 2 or x.shape[1] != 2:
        raise CLIError(f"{path}: expected an array of shape (n_nodes, 2), got {x.shape}")
    if x.shape[0] < 4:
        raise CLIError(f"{path}: a wire needs at least 4 nodes (3 segments), got {x.shape[0]}")
    if not np.all(np.isfinite(x)):
        raise CLIError(f"{path}: positions contain NaN or infinite values")
    big = float(np.abs(x).max())
    if big > MAX_COORDINATE:
        raise CLIError(
            f"{path}: coordinates up to {big:.3g}: beyond {MAX_COORDINATE:g} their squares "
            "overflow double precision; give lengths in units of the wire's length"
        )
    return x


def plasticity(args):
    """The Plasticity of ``--plastic-s`` and ``--plastic-theta`` (both or neither), or None."""
    from ..model import Plasticity

    if (args.plastic_s is None) != (args.plastic_theta is None):
        raise CLIError("plasticity needs both --plastic-s and --plastic-theta")
    if args.plastic_s is None:
        return None
    return Plasticity(s=args.plastic_s, theta_p=args.plastic_theta)


def load_toml(path, tables=("wire", "ramp", "run")) -> dict:
    """A TOML file with only the given tables."""
    path = Path(path)
    if not path.is_file():
        raise CLIError(f"no such config file: {path}")
    try:
        with path.open("rb") as fh:
            cfg = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise CLIError(f"{path}: invalid TOML: {exc}") from None
    unknown = set(cfg) - set(tables)
    if unknown:
        names = ", ".join(f"[{t}]" for t in tables)
        raise CLIError(f"{path}: unknown table(s) {sorted(unknown)}; use {names}")
    return cfg


def add_model_flags(p, required: bool) -> None:
    """The wire's physical parameters, shared by ``run`` and ``energy``."""
    p.add_argument("--kb", type=float, required=required,
                   help="bending rigidity k_b per joint [energy]"
                   + ("" if required else " (default 5)"))  # fmt: skip
    p.add_argument("--ks", type=float, required=required,
                   help="stretching modulus k_s per segment [energy/length²]"
                   + ("" if required else " (default 5e5)"))  # fmt: skip
    p.add_argument(
        "--confinement",
        choices=["per-length", "per-node"],
        default=None if not required else "per-length",
        help="confinement normalisation (default per-length; docs/model.md)",
    )
    p.add_argument("--hard-core", type=float, default=None if not required else 1e-5,
                   help="hard-core width d [length] (default 1e-5)")  # fmt: skip
    p.add_argument("--hard-core-energy", type=float, default=None if not required else 1e-3,
                   help="hard-core energy scale ε [energy] (default 1e-3)")  # fmt: skip
    p.add_argument("--plastic-s", type=float,
                   help="plasticity: softening factor s in [0, 1] (default: elastic)")  # fmt: skip
    p.add_argument("--plastic-theta", type=float,
                   help="plasticity: yield angle θ_p [rad] (default: elastic)")  # fmt: skip
