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


# --------------------------------------------------------------------------------------------
# Progress (issue 15, defect 8)
# --------------------------------------------------------------------------------------------


def test_progress_counts_stages_inside_running_ramps(tmp_path):
    """Before any ramp finishes, the stages done inside the running ones are counted (no
    "0/N ... ETA ?" for the length of a ramp); "running" never exceeds the workers; at the
    end every planned stage is counted."""
    from crumple.sweep import Sweep, run_sweep

    lams = [1.0 + 40 * i for i in range(14)]
    sweep = Sweep(wire={"n_segments": 40, "k_b": [2, 4, 8]}, ramp={"lambdas": lams}, replicas=2)
    seen = []
    report = run_sweep(sweep, tmp_path, workers=2, progress=seen.append, refresh=0.02)
    assert report.complete
    assert max(p.running for p in seen) <= 2
    assert seen[-1].stages == seen[-1].stages_total == 6 * len(lams)
    assert seen[-1].running == 0 and seen[-1].eta == 0.0
    early = [p for p in seen if p.stages > (p.done + p.failed) * len(lams)]
    assert early, "no report counted the stages of a ramp in flight"
    assert any(p.done == 0 and p.eta is not None for p in seen)
    # resumed: everything is already there, and counted as such
    again = []
    run_sweep(sweep, tmp_path, workers=2, progress=again.append)
    assert again[-1].stages == again[-1].stages_skipped == 6 * len(lams)


def _p(total, done, running, stages, stages_total, skipped=0, stages_skipped=0, failed=0):
    from crumple.sweep.execute import Progress

    return Progress(total, done, failed, running, skipped, 0.0, None, stages=stages,
                    stages_total=stages_total, stages_skipped=stages_skipped)  # fmt: skip


def test_progress_line_sums_experiments_and_gives_an_eta_from_stages():
    from crumple.cli.progress import progress_line

    parts = {"elastic": _p(32, 0, 1, 40, 640), "powell": _p(1, 0, 1, 3, 40)}
    line = progress_line("simulating", parts, elapsed=86.0)
    assert line.startswith("simulating: 0/33 ramps, 43/680 stages (6%), 2 running, 0 failed")
    assert "1 min 26 s elapsed, ETA 21 min 14 s" in line  # 86 s / 43 stages * 637
    assert "[elastic 0/32, powell 0/1]" in line
    # stages of runs found already done are progress, not rate
    resumed = {"elastic": _p(32, 16, 0, 320, 640, skipped=16, stages_skipped=320)}
    line = progress_line("simulating", resumed, elapsed=5.0)
    assert "(16 ramps already done)" in line and "ETA ?" in line
    done = {"elastic": _p(32, 32, 0, 640, 640)}
    assert "ETA 0 s" in progress_line("simulating", done, elapsed=5.0, bar=10)
    assert "[##########]" in progress_line("simulating", done, elapsed=5.0, bar=10)


def test_job_progress_in_a_log_is_one_line_per_interval_and_phases_are_named():
    import io

    from crumple.cli.progress import JobProgress

    log = io.StringIO()
    job = JobProgress(stream=log, every=3600, grace=0)
    for i in range(50):  # many reports: in a log (not a terminal) one line, then the last
        job("elastic", _p(10, i // 10, 2, i, 60))
    job("elastic", _p(10, 10, 0, 60, 60))
    job.phase("measuring: fig3_mass_size (1/9)")
    lines = log.getvalue().splitlines()
    assert len(lines) == 3, lines
    assert lines[0].startswith("simulating: 0/10 ramps, 0/60 stages")
    assert lines[1].startswith("simulating: 10/10 ramps, 60/60 stages (100%)")
    assert lines[2].startswith("crumple: measuring: fig3_mass_size (1/9) (")
    # the first line of a log waits for the other experiments' first reports
    late = io.StringIO()
    job = JobProgress(stream=late, every=3600, grace=3600)
    job("plastic", _p(7, 0, 2, 0, 77))
    job("elastic", _p(16, 0, 0, 0, 176))
    assert late.getvalue() == ""
    job("plastic", _p(7, 7, 0, 77, 77))
    job("elastic", _p(16, 16, 0, 176, 176))
    assert late.getvalue().startswith("simulating: 23/23 ramps, 253/253 stages")
    quiet = io.StringIO()
    job = JobProgress(True, stream=quiet)
    job("elastic", _p(10, 10, 0, 60, 60))
    job.phase("writing report")
    assert quiet.getvalue() == ""


def test_figures_names_each_phase(capsys, smoke):
    """`crumple figures` says what it is doing during its minute: reading, measuring each
    section, drawing each figure, writing the report."""
    code, _, err = run_cli(capsys, "figures", smoke[0])
    assert code == 0, err
    for phase in ("measuring: reading the elastic runs", "measuring: fig3_mass_size",
                  "drawing figures: fig3_mass_size", "writing report"):  # fmt: skip
        assert f"crumple: {phase}" in err, err
