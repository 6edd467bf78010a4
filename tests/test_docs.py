"""Every code block of the README and of docs/*.md runs as written (issue 15, defect 1).

* ``python`` blocks run in order, one namespace per file, in a fresh directory that holds
  ``examples/`` and the sweep stores the docs read (``runs`` and ``sweep-small``: the README's
  and docs/sweeps.md's ``crumple sweep examples/sweep-small.toml``, made once here).
* ``bash`` blocks: every ``crumple ...`` line is parsed by the real parser (subcommand and
  flags must exist), without running it.
* A block preceded by the line ``<!-- skip-test: why -->`` is not run: use it only for a block
  that cannot be self-contained (a cluster, a store that takes hours), and say why.
"""

import contextlib
import io
import re
import shlex
import shutil
from pathlib import Path

import pytest

from crumple.cli import CLIError, build_parser
from crumple.cli.inputs import join_negative_values

ROOT = Path(__file__).resolve().parents[1]
FILES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
SKIP = re.compile(r"^<!-- skip-test(:.*)? -->$")
_FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.M | re.S)


def blocks(path: Path, lang: str) -> list[tuple[int, str]]:
    """(line number, code) of every ``lang`` block not marked to skip."""
    text = path.read_text(encoding="utf-8")
    out = []
    for m in _FENCE.finditer(text):
        if m.group(1) != lang:
            continue
        before = text[: m.start()].rstrip().splitlines()
        if before and SKIP.match(before[-1].strip()):
            continue
        out.append((text[: m.start()].count("\n") + 1, m.group(2)))
    return out


def crumple_lines(code: str) -> list[str]:
    """The ``crumple`` command lines of a shell block (after ``&&``, with a venv prefix)."""
    out = []
    for line in code.splitlines():
        for part in line.split("&&"):
            part = part.strip()
            part = re.sub(r"^\S*/bin/crumple\b", "crumple", part)
            if part.startswith("crumple "):
                out.append(part)
    return out


def _id(p: Path) -> str:
    return str(p.relative_to(ROOT))


@pytest.mark.parametrize("path", FILES, ids=_id)
def test_shell_blocks_use_existing_commands_and_flags(path):
    parser = build_parser()
    for lineno, code in blocks(path, "bash"):
        for line in crumple_lines(code):
            argv = shlex.split(line, comments=True)[1:]
            try:
                parser.parse_args(join_negative_values(argv))
            except CLIError as exc:
                pytest.fail(f"{_id(path)}:{lineno}: `{line}`: {exc}")


@pytest.fixture(scope="session")
def stores(tmp_path_factory):
    """``crumple sweep examples/sweep-small.toml`` once, under both names the docs use."""
    from crumple.sweep import Sweep, run_sweep

    d = tmp_path_factory.mktemp("stores")
    report = run_sweep(Sweep.from_toml(ROOT / "examples" / "sweep-small.toml"), d / "runs",
                       workers=1)  # fmt: skip
    assert report.complete
    shutil.copytree(d / "runs", d / "sweep-small")
    return d


PY_FILES = [p for p in FILES if blocks(p, "python")]


@pytest.mark.parametrize("path", PY_FILES, ids=_id)
def test_python_blocks_run(path, stores, tmp_path, monkeypatch):
    for name in ("runs", "sweep-small"):
        (tmp_path / name).symlink_to(stores / name)
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__doc_block__"}
    for lineno, code in blocks(path, "python"):
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                exec(compile(code, f"{_id(path)}:{lineno}", "exec"), namespace)
        except Exception as exc:
            pytest.fail(f"{_id(path)}:{lineno}: {type(exc).__name__}: {exc}")


def test_the_collector_sees_blocks_and_skips(tmp_path):
    readme = ROOT / "README.md"
    assert len(blocks(readme, "python")) >= 2 and blocks(readme, "bash")
    text = (
        "a\n<!-- skip-test: a probe -->\n```python\nraise SystemExit\n```\n```python\nx = 1\n```\n"
    )
    (tmp_path / "probe.md").write_text(text)
    assert [c for _, c in blocks(tmp_path / "probe.md", "python")] == ["x = 1\n"]
