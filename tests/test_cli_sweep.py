"""``crumple sweep``, ``status``, ``reproduce`` and ``figures`` (cli/sweep_cmds.py): damaged
stores are one-line errors, and the progress line tells the truth."""

import json

import pytest

from crumple.cli import main


def run_cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _one_line_error(code, err):
    assert code == 2
    assert err.startswith("crumple: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err


MANIFEST = {"format": "crumple-sweep", "format_version": 1, "runs": [{"id": "a" * 16}]}


@pytest.mark.parametrize(
    "manifest, match",
    [
        ([1, 2], "not a crumple sweep manifest"),
        ({k: v for k, v in MANIFEST.items() if k != "runs"}, "'runs' is missing"),
        ({**MANIFEST, "runs": "abc"}, "'runs' is missing or not a list"),
        ({**MANIFEST, "runs": [{"replica": 0}]}, r"runs\[0\] has no 'id'"),
        ({**MANIFEST, "runs": [5]}, r"runs\[0\] has no 'id'"),
        ({**MANIFEST, "format_version": "x"}, "format version"),
    ],
)
def test_status_of_a_damaged_manifest_is_one_line(capsys, tmp_path, manifest, match):
    import re

    (tmp_path / "sweep.json").write_text(json.dumps(manifest))
    code, _, err = run_cli(capsys, "status", tmp_path)
    _one_line_error(code, err)
    assert re.search(match, err), err


def test_status_of_a_valid_manifest_without_files(capsys, tmp_path):
    (tmp_path / "sweep.json").write_text(json.dumps(MANIFEST))
    code, out, err = run_cli(capsys, "status", tmp_path)
    assert code == 0, err
    assert "1 runs: 0 done, 0 failed, 0 damaged, 1 missing" in out


@pytest.mark.parametrize(
    "content, match",
    [
        ({"versions": {}}, r"no profile\)"),
        ([1], r"no profile\)"),
        ({"profile": {"name": "quick"}}, "no profile.replicas"),
        ("{not json", "not valid JSON"),
    ],
)
def test_figures_on_a_damaged_profile_is_one_line(capsys, tmp_path, content, match):
    import re

    text = content if isinstance(content, str) else json.dumps(content)
    (tmp_path / "profile.json").write_text(text)
    code, _, err = run_cli(capsys, "figures", tmp_path)
    _one_line_error(code, err)
    assert re.search(match, err), err
    # and reproduce into that directory says the same before it starts anything
    code, _, err = run_cli(capsys, "reproduce", "--profile", "smoke", "--quiet", "--out", tmp_path)
    _one_line_error(code, err)


POINTS = "[[point]]\nk_s = 5e5\ninitial_noise = 0.01\n[[point]]\nk_s = 1e5\ninitial_noise = 0.7\n"
HEAD = "[wire]\nn_segments = 10\nk_b = [2, 8]\n[ramp]\nlambdas = [1, 10]\n"


@pytest.mark.parametrize(
    "text, match",
    [
        ("[sweep]\nreplicas = 2.0\n" + HEAD, "replicas must be an integer >= 1, got 2.0"),
        (HEAD + "initial_noise = 0.7\n", r"initial noise must be in \[0, 0.5\), got 0.7"),
        (HEAD + "initial_noise = -1\n", "initial_noise must be >= 0"),
        # only the second point is bad: every point of the plan is checked, not the first
        (HEAD + POINTS, r"at k_b = 2.0, k_s = 100000.0, initial_noise = 0.7: initial noise must"),
    ],
)
def test_sweep_refuses_bad_parameters_before_any_run(capsys, tmp_path, text, match):
    """Every run's Wire and Ramp are built, and checked as run_ramp checks them, up front:
    nothing is submitted, no store is created."""
    import re

    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "store"
    code, _, err = run_cli(capsys, "sweep", tmp_path / "s.toml", "--out", out, "--quiet")
    _one_line_error(code, err)
    assert re.search(match, err), err
    assert not out.exists()
