"""The command line: outputs match the library, every bad input is one line and exit != 0."""

import json
import math
import os
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from crumple.cli import main, read_positions
from crumple.energy import energy_terms
from crumple.model import Plasticity, Wire
from crumple.observables import measure
from crumple.storage import load_ramps


@pytest.fixture()
def wire_file(tmp_path):
    t = np.linspace(0.3, 4 * np.pi, 31)  # a two-turn spiral that starts near its centre
    x = 0.02 * t[:, None] * np.c_[np.cos(t), np.sin(t)]
    np.save(tmp_path / "w.npy", x)
    np.savetxt(tmp_path / "w.txt", x, header="x y")
    np.savetxt(tmp_path / "w.csv", x, delimiter=",")
    return tmp_path, x


def run_cli(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("name", ["w.npy", "w.txt", "w.csv"])
def test_energy_matches_library(capsys, wire_file, name):
    d, x = wire_file
    code, out, err = run_cli(
        capsys, "energy", d / name, "--kb", 5, "--ks", 5e5, "--lam", 300,
        "--plastic-s", 0.2, "--plastic-theta", 0.1, "--confinement", "per-node",
    )  # fmt: skip
    assert code == 0, err
    got = json.loads(out)
    wire = Wire(k_b=5, k_s=5e5, n_segments=30, confinement="per-node",
                plasticity=Plasticity(s=0.2, theta_p=0.1))  # fmt: skip
    want = energy_terms(wire, x, 300).to_dict()
    for k in ("bending", "stretching", "confinement", "hard_core", "total"):
        assert got[k] == pytest.approx(want[k], rel=1e-12, abs=1e-300)
    assert got["crossings"] == 0


def test_energy_auto_length(capsys, wire_file):
    d, x = wire_file
    code, out, _ = run_cli(capsys, "energy", d / "w.npy", "--kb", 1, "--ks", 1e4, "--lam", 1,
                           "--length", "auto")  # fmt: skip
    assert code == 0
    assert json.loads(out)["length"] == pytest.approx(np.hypot(*np.diff(x, axis=0).T).sum())


@pytest.mark.parametrize("name", ["w.npy", "w.txt"])
def test_measure_matches_library(capsys, wire_file, name):
    d, x = wire_file
    code, out, err = run_cli(capsys, "measure", d / name, "--radii", "0.05,0.1,0.2", "--rg", "rms")
    assert code == 0, err
    got = json.loads(out)
    want = json.loads(json.dumps(measure(x, radii=[0.05, 0.1, 0.2], rg="rms")))
    assert got.keys() == want.keys()
    assert got["crossings"] == want["crossings"] and got["contacts"] == want["contacts"]
    for key, value in want["mass_size_exponent"].items():
        if isinstance(value, float):
            assert got["mass_size_exponent"][key] == pytest.approx(value), key
        else:
            assert got["mass_size_exponent"][key] == value, key
    np.testing.assert_allclose(got["mass_within"], want["mass_within"], rtol=1e-12)
    assert got["r_max"] == pytest.approx(want["r_max"])
    assert got["loops"] == want["loops"]


def test_measure_prints_the_loops(capsys, tmp_path):
    # a 60-gon whose ends stop 3e-3 apart: one loop at loop distance 1e-2, none at 1e-3
    phi = 2 * np.pi * np.arange(61) / 60
    x = np.c_[np.cos(phi), np.sin(phi)]
    x[-1] = x[0] - 3e-3 * (x[0] - x[-2]) / np.linalg.norm(x[0] - x[-2])
    np.save(tmp_path / "ring.npy", x)
    f = tmp_path / "ring.npy"
    code, out, err = run_cli(capsys, "measure", f, "--center", "1,0", "--loop-distance", "1e-2")
    assert code == 0, err
    got = json.loads(out)["loops"]
    assert got == json.loads(json.dumps(measure(x, center=(1, 0), loop_distance=1e-2)["loops"]))
    assert got["count"] == 1 and got["counts_by_depth"] == [1] and got["contact_distance"] == 1e-2
    assert got["area"]["total"] == pytest.approx(30 * np.sin(2 * np.pi / 60), rel=1e-12)
    code, out, _ = run_cli(capsys, "measure", f, "--center", "1,0")  # default 2 x 1e-5
    assert code == 0 and json.loads(out)["loops"]["count"] == 0


BAD = [
    ("energy", "{d}/missing.npy", "--kb", "5", "--ks", "5e5", "--lam", "1"),
    ("energy", "{d}/nan.npy", "--kb", "5", "--ks", "5e5", "--lam", "1"),
    ("energy", "{d}/shape.npy", "--kb", "5", "--ks", "5e5", "--lam", "1"),
    ("energy", "{d}/garbage.txt", "--kb", "5", "--ks", "5e5", "--lam", "1"),
    ("energy", "{d}/w.npy", "--kb", "-1", "--ks", "5e5", "--lam", "1"),
    ("energy", "{d}/w.npy", "--kb", "5", "--ks", "5e5", "--lam", "1", "--plastic-s", "2",
     "--plastic-theta", "0.1"),
    ("energy", "{d}/w.npy", "--kb", "5", "--ks", "5e5", "--lam", "1", "--plastic-s", "0.5"),
    ("energy", "{d}/w.npy", "--kb", "5", "--ks", "5e5"),
    ("energy", "{d}/w.npy", "--kb", "5", "--ks", "5e5", "--lam", "1", "--bogus"),
    ("measure", "{d}/w.npy", "--fit-range", "0.5"),
    ("measure", "{d}/w.npy", "--rg", "median"),
    ("measure", "{d}/w.npy", "--loop-distance", "-1"),
    ("run", "--kb", "nan", "--out", "{d}/o"),
    ("run", "--config", "{d}/missing.toml"),
    ("run", "--config", "{d}/bad.toml"),
    ("run", "--lambdas", "10,1", "--out", "{d}/o"),
    ("frobnicate",),
]  # fmt: skip


@pytest.mark.parametrize("args", BAD, ids=[" ".join(a[:2]) + f"#{i}" for i, a in enumerate(BAD)])
def test_bad_input_is_one_line(capsys, wire_file, args):
    d, _ = wire_file
    np.save(d / "nan.npy", np.full((5, 2), np.nan))
    np.save(d / "shape.npy", np.zeros((5, 3)))
    (d / "garbage.txt").write_text("1 2\nthree four\n")
    (d / "bad.toml").write_text("[wire]\nkb = 5\n")  # 'kb' is not a Wire field
    code, out, err = run_cli(capsys, *(a.format(d=d) for a in args))
    assert code != 0
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("crumple: error:"), err
    assert "Traceback" not in err


def test_run_writes_results_and_figure(capsys, tmp_path):
    cfg = tmp_path / "run.toml"
    cfg.write_text(
        "[wire]\nk_b = 5.0\nk_s = 5e5\nn_segments = 30\n"
        "[ramp]\nlambdas = [1, 70, 200]\n"
        "[run]\nreplicas = 2\nseed = 7\nworkers = 1\n"
    )
    code, out, err = run_cli(capsys, "run", "--config", cfg, "--out", tmp_path / "o",
                             "--figure-lambdas", "70,200", "--quiet")  # fmt: skip
    assert code == 0, err
    summary = json.loads(out)
    assert summary["converged"] and summary["replicas"] == 2
    with h5py.File(tmp_path / "o" / "ramps.h5") as f:
        assert f["positions"].shape == (2, 3, 31, 2)
        assert json.loads(f.attrs["wire"])["n_segments"] == 30
    assert (tmp_path / "o" / "configurations.png").stat().st_size > 1000


# --------------------------------------------------------------------------------------------
# Issue 15: what a new user and a fuzzer found
# --------------------------------------------------------------------------------------------


def one_line_error(code, out, err):
    assert code != 0
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("crumple: error:"), err
    return lines[0]


E = ("--kb", 5, "--ks", 5e5, "--lam", 1)


def test_energy_coincident_nodes_is_one_line(capsys, tmp_path):
    x = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.0], [0.2, 0.05], [0.3, 0.0]])
    np.save(tmp_path / "c.npy", x)
    msg = one_line_error(*run_cli(capsys, "energy", tmp_path / "c.npy", *E))
    assert "nodes 1 and 2 coincide" in msg


@pytest.mark.parametrize(
    "array",
    [np.array([["0", "0"], ["0", "0"], ["1", "0"], ["2", "0"]]),
     np.array([["a", "b"]] * 5), np.ones((5, 2)) * (1 + 1j), np.ones((5, 2), bool)],
    ids=["numeric-strings", "strings", "complex", "bool"],
)  # fmt: skip
def test_npy_of_non_reals_is_refused(capsys, tmp_path, array):
    np.save(tmp_path / "s.npy", array)
    msg = one_line_error(*run_cli(capsys, "energy", tmp_path / "s.npy", *E))
    assert "real numbers" in msg


@pytest.mark.parametrize(
    "text",
    ["", "# only a comment\n", "1e400 0\n0 0\n1 0\n2 0\n"],
    ids=["empty", "comment", "overflow"],
)
def test_text_file_errors_print_no_numpy_warning(capsys, tmp_path, text):
    (tmp_path / "w.txt").write_text(text)
    one_line_error(*run_cli(capsys, "energy", tmp_path / "w.txt", *E))


@pytest.mark.parametrize("scale", [1e160, 1e200, 1e307])
@pytest.mark.parametrize("command", [("energy", *E), ("measure",)], ids=["energy", "measure"])
def test_overflowing_positions_are_one_line(capsys, tmp_path, scale, command):
    t = np.linspace(0.3, 4 * np.pi, 31)
    np.savetxt(tmp_path / "big.txt", scale * t[:, None] * np.c_[np.cos(t), np.sin(t)])
    msg = one_line_error(*run_cli(capsys, command[0], tmp_path / "big.txt", *command[1:]))
    assert "overflow" in msg


def test_measure_warns_when_contact_distance_exceeds_segments(capsys, tmp_path):
    x = np.c_[np.linspace(0, 5e-5, 11), np.zeros(11)]  # segments 5e-6 < the default 1e-5
    np.save(tmp_path / "fine.npy", x)
    code, out, err = run_cli(capsys, "measure", tmp_path / "fine.npy")
    assert code == 0 and "warning" in err and "--contact-distance" in err
    assert json.loads(out)["contacts"] > 0  # what the warning is about
    code, out, err = run_cli(capsys, "measure", tmp_path / "fine.npy", "--contact-distance", 1e-6)
    assert code == 0 and err == "" and json.loads(out)["contacts"] == 0


RUN_BAD = [
    (("--workers", "0"), "--workers must be >= 1"),
    (("--workers", "-2"), "--workers must be >= 1"),
    (("--replicas", "0"), "replicas must be >= 1"),
    (("--figure-lambdas", "70,123"), "figure λ 123 not among"),
    (("--lambdas", "-5,10"), "lambdas must be finite and >= 0"),
    (("--lambdas", "-5"), "lambdas must be finite and >= 0"),
    (("--plastic-s", "0.5"), "needs both"),
]


@pytest.mark.parametrize("flags,match", RUN_BAD, ids=[" ".join(f) for f, _ in RUN_BAD])
def test_run_refuses_before_simulating(capsys, tmp_path, monkeypatch, flags, match):
    import crumple.cli.run as clirun

    def boom(*a, **k):
        raise AssertionError("simulated before validating")

    monkeypatch.setattr(clirun, "run_all", boom)
    msg = one_line_error(*run_cli(capsys, "run", "--out", tmp_path / "o", *flags))
    assert match in msg
    assert not (tmp_path / "o").exists()


def test_run_toml_replicas_must_be_whole(capsys, tmp_path):
    cfg = tmp_path / "r.toml"
    cfg.write_text("[run]\nreplicas = 2.0\n")
    assert "replicas" in one_line_error(*run_cli(capsys, "run", "--config", cfg))


def test_negative_list_values_parse():
    from crumple.cli import build_parser
    from crumple.cli.inputs import join_negative_values

    args = build_parser().parse_args(join_negative_values(["run", "--lambdas", "-5,10"]))
    assert args.lambdas == "-5,10"
    args = build_parser().parse_args(
        join_negative_values(["energy", "f", "--kb", "1", "--ks", "1", "--lam", "1",
                              "--center", "-0.1,0.2"]))  # fmt: skip
    assert args.center == "-0.1,0.2"


RUN_SMALL = ("--n-segments", 20, "--lambdas", "1,10,70", "--figure-lambdas", "70", "--quiet")


def test_run_never_overwrites_without_flag(capsys, tmp_path):
    out = tmp_path / "o"
    code, _, err = run_cli(capsys, "run", "--out", out, "--kb", 5, *RUN_SMALL)
    assert code == 0, err
    with h5py.File(out / "ramps.h5") as f:
        assert json.loads(f.attrs["wire"])["k_b"] == 5
    msg = one_line_error(*run_cli(capsys, "run", "--out", out, "--kb", 8, *RUN_SMALL))
    assert "--overwrite" in msg
    with h5py.File(out / "ramps.h5") as f:
        assert json.loads(f.attrs["wire"])["k_b"] == 5  # untouched
    code, _, err = run_cli(capsys, "run", "--out", out, "--kb", 8, "--overwrite", *RUN_SMALL)
    assert code == 0, err
    with h5py.File(out / "ramps.h5") as f:
        assert json.loads(f.attrs["wire"])["k_b"] == 8


@pytest.mark.parametrize("fail_at", [1, 2])
def test_run_outputs_never_mismatch_after_a_kill(capsys, tmp_path, monkeypatch, fail_at):
    """A kill between the renames leaves no new results beside the old figure (nor the
    reverse): the old figure is removed first, then results, then the new figure."""
    import crumple.cli.run as clirun

    out = tmp_path / "o"
    assert run_cli(capsys, "run", "--out", out, "--kb", 5, *RUN_SMALL)[0] == 0
    old_png = (out / "configurations.png").read_bytes()
    calls = []
    real = clirun.os.replace

    def replace(a, b):
        if Path(b).name in ("ramps.h5", "configurations.png"):  # not save_ramps' own rename
            calls.append(b)
            if len(calls) == fail_at:
                raise KeyboardInterrupt  # the kill
        return real(a, b)

    monkeypatch.setattr(clirun.os, "replace", replace)
    code = main(["run", "--out", str(out), "--kb", "8", "--overwrite", *map(str, RUN_SMALL)])
    assert code == 130
    with h5py.File(out / "ramps.h5") as f:
        k_b = json.loads(f.attrs["wire"])["k_b"]
    png = out / "configurations.png"
    assert not png.exists() or (k_b == 5 and png.read_bytes() == old_png)
    assert k_b == (5 if fail_at == 1 else 8)
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary left


def test_powell_has_its_own_budget_and_shows_stages(capsys, tmp_path):
    from crumple.cli import build_parser
    from crumple.cli.run import build_run
    from crumple.protocol import DEFAULT_MAXITER

    args = build_parser().parse_args(["run", "--method", "powell"])
    assert build_run(args)[1].maxiter == DEFAULT_MAXITER["powell"] == 20
    args = build_parser().parse_args(["run", "--method", "powell", "--maxiter", "3"])
    assert build_run(args)[1].maxiter == 3
    assert build_run(build_parser().parse_args(["run"]))[1].maxiter == 5000  # Newton's
    code, _, err = run_cli(capsys, "run", "--out", tmp_path / "p", "--method", "powell",
                           "--n-segments", 8, "--lambdas", "1,2", "--maxiter", 2)  # fmt: skip
    assert code in (0, 3), err
    assert "stage 1/2" in err and "maxiter = 2" in err


def test_run_echoes_every_parameter_and_warns_on_identical_replicas(capsys, tmp_path):
    code, out, err = run_cli(capsys, "run", "--out", tmp_path / "o", "--n-segments", 20,
                             "--lambdas", "1,10", "--replicas", 2, "--workers", 1,
                             "--plastic-s", 0.3, "--plastic-theta", 0.2)  # fmt: skip
    assert code == 0, err
    from crumple.model import Wire as W

    for key in W.__dataclass_fields__:
        assert f"{key} = " in err, key
    assert "s = 0.3" in err and "theta_p [rad] = 0.2" in err
    assert "rest_angle_sd" in err.split("warning:")[1]
    assert json.loads(out)["wire"]["plasticity"] == {"s": 0.3, "theta_p": 0.2}


def test_a_plain_ramp_of_many_segments_is_warned_about(capsys, tmp_path, monkeypatch):
    """From SLOW_PLAIN_RAMP segments, a plain ramp that a coarser wire could predict is warned
    about (the default schedule takes more than half an hour at N = 5 × 10⁴), naming the
    largest of 10, 5, 4, 2 that divides N; a coarsened ramp, a wire no coarser wire can
    predict and a smaller wire are not."""
    from crumple.cli import advice
    from crumple.protocol import Ramp

    slow = advice.slow_plain_ramp
    n = advice.SLOW_PLAIN_RAMP
    big = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=n)
    assert "coarsen = 10" in slow(big, Ramp()) and f"{n // 10} segments moved" in slow(big, Ramp())
    odd = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=n + 5)  # 5 divides it
    assert "coarsen = 5" in slow(odd, Ramp()) and f"{(n + 5) // 5} segments" in slow(odd, Ramp())
    prime = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=50_021)
    assert prime.n_segments >= n and slow(prime, Ramp()) is None  # no factor to coarsen by
    assert slow(big, Ramp(coarsen=10)) is None
    assert slow(big, Ramp(method="powell")) is None
    assert slow(big, Ramp(stage_noise=1e-3)) is None  # coarsen needs stage_noise = 0
    per_node = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=n,
                                   confinement="per-node")  # fmt: skip
    assert slow(per_node, Ramp()) is None
    small = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=n - 10)
    assert slow(small, Ramp()) is None
    monkeypatch.setattr(advice, "SLOW_PLAIN_RAMP", 30)  # the command prints it
    for extra, warned in (((), True), (("--coarsen", 10), False)):
        code, _, err = run_cli(capsys, "run", "--out", tmp_path / f"o{warned}", "--n-segments", 30,
                               "--lambdas", "1,10", "--workers", 1, *extra)  # fmt: skip
        assert code == 0, err
        assert ("warning: a plain ramp of 30 segments" in err) is warned


@pytest.mark.parametrize("flag", ["--curved-steps", "--no-curved-steps"])
def test_run_curved_steps_flag_reaches_the_stored_ramp(capsys, tmp_path, flag):
    code, out, err = run_cli(capsys, "run", "--out", tmp_path / "o", "--n-segments", 20,
                             "--lambdas", "1,10", "--workers", 1, flag)  # fmt: skip
    assert code == 0, err
    on = flag == "--curved-steps"
    assert json.loads(out)["ramp"]["curved_steps"] is on
    assert f"curved_steps = {on}" in err
    assert load_ramps(tmp_path / "o" / "ramps.h5")[0].ramp.curved_steps is on


@pytest.mark.parametrize("choice", ["exact", "projected"])
def test_run_fallback_flag_reaches_the_stored_ramp(capsys, tmp_path, choice):
    code, out, err = run_cli(capsys, "run", "--out", tmp_path / "o", "--n-segments", 20,
                             "--lambdas", "1,10", "--workers", 1, "--fallback", choice)  # fmt: skip
    assert code == 0, err
    assert json.loads(out)["ramp"]["fallback"] == choice
    assert f"fallback = {choice}" in err
    assert load_ramps(tmp_path / "o" / "ramps.h5")[0].ramp.fallback == choice


def test_help_shows_defaults_and_units(capsys):
    for cmd in ("run", "energy", "measure", "export", "plot", "animate"):
        with pytest.raises(SystemExit):
            main([cmd, "--help"])
        text = capsys.readouterr().out
        assert "default" in text, cmd
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for unit in ("[energy]", "[length]", "[energy/length]", "[rad]", "[segment lengths]"):
        assert unit in text, unit


@pytest.fixture(scope="module")
def ramp_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("ramp")
    code = main(["run", "--out", str(d), "--n-segments", "24", "--lambdas", "1,10,70,200",
                 "--replicas", "2", "--workers", "1", "--rest-angle-sd", "0.01", "--kb", "3",
                 "--plastic-s", "0.5", "--plastic-theta", "0.2", "--quiet"])  # fmt: skip
    assert code == 0
    return d / "ramps.h5"


@pytest.mark.parametrize("fmt", ["npy", "csv", "xyz"])
def test_export_then_energy_round_trip(capsys, tmp_path, ramp_file, fmt):
    from crumple.storage import load_ramps

    capsys.readouterr()
    dest = tmp_path / f"w.{fmt}"
    code, _, err = run_cli(capsys, "export", ramp_file, "--lam", 70, "--replica", 1, "-o", dest)
    assert code == 0, err
    stage = load_ramps(ramp_file)[1].at(70.0)
    np.testing.assert_array_equal(read_positions(dest), stage.positions)
    # the export prints the crumple energy line that recomputes the stored energy
    line = err.split("energy: ")[1].rstrip(")\n")
    args = line.split()[3:]  # after "crumple energy PATH"
    code, out, err = run_cli(capsys, "energy", dest, *args)
    assert code == 0, err
    got = json.loads(out)
    # the wire is imperfect (--rest-angle-sd 0.01): the export writes its rest angles beside
    # the positions and the printed line passes them, so every term, bending included, agrees
    assert "--rest-angles" in line and (tmp_path / "w.rest.npy").is_file()
    for k in ("bending", "stretching", "confinement", "hard_core", "total"):
        assert got[k] == pytest.approx(getattr(stage.energy, k), rel=1e-12, abs=1e-300), k


def test_export_round_trip_total_energy(capsys, tmp_path):
    from crumple.storage import load_ramps

    d = tmp_path / "r"
    assert run_cli(capsys, "run", "--out", d, *RUN_SMALL)[0] == 0
    code, _, err = run_cli(
        capsys, "export", d / "ramps.h5", "--stage", -1, "-o", tmp_path / "x.npy"
    )
    assert code == 0, err
    code, out, err = run_cli(capsys, "energy", tmp_path / "x.npy", "--kb", 5, "--ks", 5e5,
                             "--lam", 70)  # fmt: skip
    assert code == 0, err
    want = load_ramps(d / "ramps.h5")[0].stages[-1].energy
    assert json.loads(out)["total"] == pytest.approx(want.total, rel=1e-12)


def test_export_to_stdout_and_bad_choices(capsys, ramp_file):
    code, out, err = run_cli(capsys, "export", ramp_file, "--format", "xyz")
    assert code == 0 and out.splitlines()[0] == "25"
    for bad, match in [(("--lam", 5, "--format", "csv"), "no stage at λ = 5"),
                       (("--replica", 7, "--format", "csv"), "2 replica(s)"),
                       (("--stage", 9, "--format", "csv"), "4 stages"), ((), "--format"),
                       (("--format", "npy"), "-o FILE.npy")]:  # fmt: skip
        code, out, err = run_cli(capsys, "export", ramp_file, *bad)
        assert match in one_line_error(code, out, err)


def test_plot_and_animate(capsys, tmp_path, ramp_file):
    from PIL import Image

    code, _, err = run_cli(capsys, "plot", ramp_file, "--lam", "10,200", "-o", tmp_path / "p.png")
    assert code == 0, err
    with Image.open(tmp_path / "p.png") as im:
        assert im.size[0] > 500
    code, _, err = run_cli(capsys, "plot", ramp_file, "--stage", 0, "--own-scale",
                           "-o", tmp_path / "q.svg")  # fmt: skip
    assert code == 0, err
    code, _, err = run_cli(capsys, "animate", ramp_file, "-o", tmp_path / "a.gif", "--fps", 10)
    assert code == 0, err
    with Image.open(tmp_path / "a.gif") as im:
        assert im.n_frames == 4
    for args, match in [(("plot", ramp_file, "--lam", 3), "no stage"),
                        (("plot", ramp_file, "-o", tmp_path / "x.txt"), ".png"),
                        (("animate", ramp_file, "-o", tmp_path / "x.avi"), ".gif"),
                        (("animate", tmp_path / "none.h5"), "no such")]:  # fmt: skip
        assert match in one_line_error(*run_cli(capsys, *args))


def test_run_with_worker_processes_matches_the_library(capsys, tmp_path):
    """crumple run's own worker pool (stoppable, with per-stage progress) gives the replicas
    of crumple.protocol.run_replicas, bit for bit."""
    from crumple.protocol import Ramp, run_replicas
    from crumple.storage import load_ramps

    flags = ["--n-segments", 20, "--lambdas", "1,10,70", "--replicas", 3, "--workers", 2,
             "--rest-angle-sd", 0.02, "--seed", 5, "--figure-lambdas", 70]  # fmt: skip
    code, _, err = run_cli(capsys, "run", "--out", tmp_path / "o", *flags)
    assert code == 0, err
    got = load_ramps(tmp_path / "o" / "ramps.h5")
    want = run_replicas(Wire(k_b=5, k_s=5e5, n_segments=20, rest_angle_sd=0.02),
                        Ramp(lambdas=(1, 10, 70)), n_replicas=3, seed=5, workers=1)  # fmt: skip
    for g, w in zip(got, want, strict=True):
        for sg, sw in zip(g.stages, w.stages, strict=True):
            np.testing.assert_array_equal(sg.positions, sw.positions)


class _ClosedPipe:
    """A stderr whose reader has gone (``2>&1 | head -n 1``)."""

    def isatty(self):
        return False

    def write(self, text):
        raise BrokenPipeError(32, "Broken pipe")

    def flush(self):
        raise BrokenPipeError(32, "Broken pipe")


def test_progress_goes_quiet_on_a_closed_pipe(monkeypatch):
    from types import SimpleNamespace

    from crumple.cli.progress import JobProgress
    from crumple.cli.run import Progress

    job = JobProgress(stream=_ClosedPipe(), every=0.0, grace=0.0)
    p = SimpleNamespace(total=2, done=2, failed=0, running=0, skipped=0)
    job.sweep(p)  # must not raise
    job.phase("drawing figures")
    job.close()
    assert job.quiet
    monkeypatch.setattr("sys.stderr", _ClosedPipe())
    prog = Progress(quiet=False, n_replicas=1, n_stages=2, every=0.0)
    prog.stage(0, 0, 10.0, True)  # must not raise
    assert prog.quiet


def _progress_at(monkeypatch, ticks, n_replicas, n_stages):
    """A Progress whose clock reads ``ticks`` (the start, then one per call)."""
    from crumple.cli.run import Progress

    clock = iter(ticks)
    monkeypatch.setattr("crumple.cli.progress.time.perf_counter", lambda: next(clock))
    return Progress(quiet=False, n_replicas=n_replicas, n_stages=n_stages, every=0.0)


def _last_line(capsys) -> str:
    return capsys.readouterr().err.strip().splitlines()[-1]


def test_the_time_left_follows_stages_that_grow_costlier(monkeypatch, capsys):
    """Stages of 1, 1, 1, then 10 s: after 7 of 10 the three left are timed at the pace of the
    last five (8.2 s each: ~25 s), not at the average of all seven (6.1 s each: ~18 s), which
    read "~2 s left" before a last stage of 70 s at N = 10⁴."""
    ticks = [0.0, 1.0, 2.0, 3.0, 13.0, 23.0, 33.0, 43.0]
    prog = _progress_at(monkeypatch, ticks, 1, 10)
    for i in range(7):
        prog.stage(0, i, 10.0 * i, True)
    assert "~25 s left" in _last_line(capsys)


def test_a_second_replica_is_timed_by_the_first_ones_stages(monkeypatch, capsys):
    """Replica 0: four stages of 1 s, then one of 70 s; replica 1 has run two stages of 1 s.
    Its three stages left cost what they cost in replica 0 (1 + 1 + 70 s): ~72 s, where the
    recent pace said ~44 s and the average ~33 s."""
    from types import SimpleNamespace

    ticks = [0.0, 1.0, 2.0, 3.0, 4.0, 74.0, 74.0, 75.0, 76.0]
    prog = _progress_at(monkeypatch, ticks, 2, 5)
    for i in range(5):
        prog.stage(0, i, 1.0, True)
    prog.replica(0, SimpleNamespace(failed_stages=[], stages=[None] * 5))
    for i in range(2):
        prog.stage(1, i, 1.0, True)
    assert "~1 min 12 s left" in _last_line(capsys)


def test_the_time_left_weighs_the_stages_by_their_measured_costs():
    from crumple.cli.progress import time_left

    costs = {0: [1.0], 1: [1.0, 1.0], 2: [1.0], 3: [1.0], 4: [70.0]}
    assert time_left(costs, {0: 5, 1: 2}, {0: 0, 1: 3}, 76.0, [1.0] * 4 + [70.0, 1.0]) == 72.0
    # two workers: the same work done in half the time leaves half the time
    assert time_left(costs, {0: 5, 1: 2}, {0: 0, 1: 3}, 38.0, [1.0] * 4 + [70.0, 1.0]) == 36.0
    assert math.isnan(time_left({}, {}, {0: 3}, 0.0, []))
    assert time_left(costs, {0: 5}, {0: 0}, 74.0, [1.0]) == 0.0  # nothing left


def test_a_long_stage_reports_its_newton_iterations(monkeypatch):
    """Once a stage has run ITERATION_EVERY seconds, a replica reports its Newton iterations
    at most that often, with the seconds the stage has run (in this process to the
    callbacks, from a worker tagged through the queue); a quick stage reports none, nor does
    a run asked to be quiet."""
    import queue

    import crumple.cli.run as clirun
    from crumple.protocol import Ramp, replica_seeds

    wire = Wire(k_b=5, k_s=5e5, n_segments=30, rest_angle_sd=0.02)
    ramp, seed = Ramp(lambdas=(1.0, 30.0, 300.0)), replica_seeds(3, 1)[0]
    stages, its = [], []
    res = clirun._replica(wire, ramp, seed, 0, lambda *a: stages.append(a), its.append)
    assert [a[1] for a in stages] == [0, 1, 2] and not its  # milliseconds: nothing within
    tick = iter(range(10**6))  # a clock that moves one second per reading
    monkeypatch.setattr(clirun, "_clock", lambda: float(next(tick)))
    again = clirun._replica(wire, ramp, seed, 0, lambda *a: None, lambda *a: its.append(a))
    for i, (s1, s2) in enumerate(zip(res.stages, again.stages, strict=True)):
        np.testing.assert_array_equal(s1.positions, s2.positions)
        mine = [a for a in its if a[1] == i]
        # one reading per step: every second step is 2 s after the last report or the start
        assert [a[3] for a in mine] == list(range(2, s2.result.iterations + 1, 2))
        assert all(a[0] == 0 and a[2] == s2.lam and a[6] == a[3] for a in mine)
    last = [a for a in its if a[1] == 2][-1]
    assert last[4] == pytest.approx(res.stages[2].result.energy, rel=1e-3)  # energy, then
    assert 0 <= last[5] < 1e-3 * last[4]  # the largest force, of a step near the stage's end
    quiet = []
    clirun._replica(wire, ramp, seed, 0, lambda *a: None, lambda *a: quiet.append(a), False)
    assert not quiet
    monkeypatch.setattr(clirun, "_QUEUE", q := queue.Queue())
    clirun._replica(wire, ramp, seed, 3)
    sent = []
    while not q.empty():
        sent.append(q.get_nowait())
    assert {m[0] for m in sent} == {"stage", "iteration"} and all(m[1] == 3 for m in sent)
    assert len([m for m in sent if m[0] == "stage"]) == 3


def test_a_coarsened_replica_reports_its_coarse_ramp(monkeypatch, capsys):
    """With ``Ramp(coarsen=m)`` a replica reports the coarse ramp's stages before its own (in
    this process to ``on_coarse``, from a worker tagged through the queue), the display says
    which wire they are on and that they only predict, and a quiet run reports none."""
    import queue

    import crumple.cli.run as clirun
    from crumple.protocol import Ramp, replica_seeds

    wire = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=40)
    ramp, seed = Ramp(lambdas=(1.0, 30.0), coarsen=4), replica_seeds(3, 1)[0]
    order = []
    clirun._replica(wire, ramp, seed, 0, lambda *a: order.append(("stage", a)), lambda *a: None,
                    True, lambda *a: order.append(("coarse", a)))  # fmt: skip
    assert [k for k, _ in order] == ["coarse", "coarse", "stage", "stage"]
    assert [a[:5] for _, a in order[:2]] == [(0, 10, 0, 2, 1.0), (0, 10, 1, 2, 30.0)]
    quiet = []
    clirun._replica(wire, ramp, seed, 0, lambda *a: None, lambda *a: None, False, quiet.append)
    assert not quiet
    monkeypatch.setattr(clirun, "_QUEUE", q := queue.Queue())
    clirun._replica(wire, ramp, seed, 2)
    sent = [q.get_nowait() for _ in range(q.qsize())]
    assert [m[0] for m in sent] == ["coarse", "coarse", "stage", "stage"]
    assert sent[0][:4] == ("coarse", 2, 10, 0)
    prog = _progress_at(monkeypatch, [0.0, 75.0, 80.0, 85.0], 1, 2)
    clirun._dispatch(prog, ("coarse", 0, 10000, 43, 44, 2000.0, False))
    assert _last_line(capsys).strip() == (
        "coarse ramp (10000 segments) stage 44/44, λ = 2000, NOT converged, 1 min 15 s elapsed "
        "(replica 0; it predicts where the wire's stages start)"
    )
    assert prog.stages_done == {} and prog.not_converged == 0  # the wire's count is its own
    prog.every = 1e9  # a log's lines at most every 10⁹ s: the coarse ramp's last is forced
    capsys.readouterr()
    prog.coarse(0, 10, 1, 3, 10.0, True)
    prog.coarse(0, 10, 2, 3, 100.0, True)
    assert [ln.split(",")[0] for ln in capsys.readouterr().err.splitlines()] == [
        "  coarse ramp (10 segments) stage 3/3"
    ]


def test_the_wires_first_stage_is_timed_from_the_end_of_its_coarse_ramp(monkeypatch):
    """A coarse ramp of 100 s (a scripted clock) before the wire's first stage: that stage's
    iterations report the seconds since the coarse ramp ended, not since the replica began."""
    import crumple.cli.run as clirun
    import crumple.protocol as protocol
    from crumple.protocol import Ramp, replica_seeds

    now = [0.0]

    def clock():
        now[0] += 1.0  # one second per reading
        return now[0]

    def slow(*args):  # the coarse ramp takes 100 s before its stages report
        now[0] += 100.0
        return coarse_path(*args)

    coarse_path = protocol.coarse_path
    monkeypatch.setattr(clirun, "_clock", clock)
    monkeypatch.setattr(protocol, "coarse_path", slow)
    wire = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=40)
    its, ramp, seed = [], Ramp(lambdas=(30.0, 300.0), coarsen=4), replica_seeds(1, 1)[0]
    quiet = lambda *a: None  # noqa: E731
    res = clirun._replica(wire, ramp, seed, 0, quiet, lambda *a: its.append(a), True, quiet)
    first = [a for a in its if a[1] == 0]
    assert res.stages[0].result.iterations >= 4 and first
    assert first[0][6] <= 4.0  # seconds into the stage: 2, not 100-odd


def test_one_worker_shows_the_coarse_ramps(monkeypatch):
    """``run_all`` with one worker hands the display's ``coarse`` to every replica."""
    import crumple.cli.run as clirun
    from crumple.protocol import Ramp

    class Display:
        quiet = False

        def __init__(self):
            self.seen = []

        def stage(self, *a):
            self.seen.append("stage")

        def iteration(self, *a):
            pass

        def coarse(self, r, n_segments, *a):
            self.seen.append(("coarse", r, n_segments))

        def replica(self, r, result):
            self.seen.append(("replica", r))

    wire = Wire.from_continuum(bending=0.05, stretching=5000.0, n_segments=40)
    prog, done = Display(), {}
    clirun.run_all(wire, Ramp(lambdas=(1.0, 30.0), coarsen=4), 2, 0, 1, prog, done)
    one = [("coarse", 0, 10)] * 2 + ["stage"] * 2 + [("replica", 0)]
    assert prog.seen == one + [("coarse", 1, 10)] * 2 + ["stage"] * 2 + [("replica", 1)]


def test_worker_messages_reach_the_display_by_their_kind():
    import crumple.cli.run as clirun

    class Seen:
        def __init__(self):
            self.calls = []

        def stage(self, *a):
            self.calls.append(("stage", len(a)))

        def iteration(self, *a):
            self.calls.append(("iteration", len(a)))

    prog = Seen()
    clirun._dispatch(prog, ("stage", 0, 1, 10.0, True))
    clirun._dispatch(prog, ("iteration", 0, 1, 10.0, 5, 1.5, 0.2, 3.0))
    assert prog.calls == [("stage", 4), ("iteration", 7)]
    with pytest.raises(ValueError, match="unknown progress message"):
        clirun._dispatch(prog, ("done", 0))


def test_the_iteration_line_names_the_stage_the_step_and_the_target(monkeypatch, capsys):
    prog = _progress_at(monkeypatch, [0.0, 65.0, 200.0, 201.0], 1, 2)
    prog.ftol, prog.maxiter, prog.every_iteration = 1e-6, 5000, 0.0
    prog.stage(0, 0, 1.0, False)
    prog.iteration(0, 1, 300.0, 17, 2.5, 0.125, 135.0)
    assert _last_line(capsys).strip() == (
        "λ = 300: energy 2.5, max force 0.125 (ftol 1e-06), iteration 17/5000, 2 min 15 s "
        "into stage 2/2 of replica 0, 1 NOT converged"
    )


def test_crumple_run_shows_the_ramps_target_beside_a_long_stages_iterations(
    monkeypatch, capsys, tmp_path
):
    import crumple.cli.run as clirun

    monkeypatch.setattr(clirun, "ITERATION_EVERY", 0.0)  # every stage counts as long
    flags = ["--n-segments", 20, "--lambdas", "1,300", "--maxiter", 700, "--figure-lambdas", 300]
    code, _, err = run_cli(capsys, "run", "--out", tmp_path / "o", *flags)
    assert code == 0, err
    line = next(row for row in err.splitlines() if "iteration" in row)
    assert line.startswith("  λ = 1: energy ") and "(ftol 1e-06), iteration 1/700, " in line


def test_a_log_shows_stages_and_iterations_each_at_its_own_interval(monkeypatch, capsys):
    from crumple.cli.run import Progress

    prog = Progress(quiet=False, n_replicas=1, n_stages=3, every=5.0, every_iteration=30.0)
    now = [0.0]
    prog.clock = lambda: now[0]
    shown = []
    for t, call in [(0, "s"), (1, "i"), (20, "i"), (3, "s"), (6, "s"), (31, "i"), (40, "i")]:
        now[0] = float(t)
        if call == "s":
            prog.stage(0, 0, 1.0, True)
        else:
            prog.iteration(0, 1, 10.0, 7, 1.0, 0.5, 1.0)
        out = capsys.readouterr().err
        shown.append(bool(out))
    assert shown == [True, True, False, False, True, True, False]


def test_a_terminal_line_is_erased_and_cut_to_stderrs_width(monkeypatch, capsys):
    import crumple.cli.progress as cp
    from crumple.cli.run import Progress

    prog = Progress(quiet=False, n_replicas=1, n_stages=3)
    prog.tty = True
    monkeypatch.setattr(cp, "_columns", lambda stream: 40)
    prog.iteration(0, 1, 10.0, 7, 1.0, 0.5, 1.0)
    prog.stage(0, 1, 10.0, True)
    parts = capsys.readouterr().err.split("\r\x1b[K")
    assert parts[0] == "" and len(parts) == 3
    assert all(0 < len(p) <= 39 for p in parts[1:])
    assert parts[1].startswith("  λ = 10: energy 1") and parts[2].startswith("  stage 2/3")


@pytest.mark.skipif(sys.platform != "linux", reason="a pseudo-terminal")
def test_the_width_is_that_of_stderrs_terminal():
    import fcntl
    import pty
    import struct
    import termios

    from crumple.cli.progress import _columns

    main, side = pty.openpty()
    try:
        fcntl.ioctl(side, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 173, 0, 0))
        with open(side, "w", closefd=False) as tty:
            assert _columns(tty) == 173
    finally:
        os.close(main)
        os.close(side)


@pytest.mark.parametrize("dpi", [0, -3])
def test_animate_refuses_a_dpi_below_one(capsys, tmp_path, ramp_file, dpi):
    code, out, err = run_cli(capsys, "animate", ramp_file, "-o", tmp_path / "a.gif", "--dpi", dpi)
    assert "--dpi must be >= 1" in one_line_error(code, out, err)
    assert not list(tmp_path.iterdir())  # nothing left behind


def _stop_after_replica_0(monkeypatch, exc=KeyboardInterrupt):
    """run_all that finishes replica 0, then is stopped as by Ctrl-C."""
    import crumple.cli.run as clirun

    real = clirun.run_all

    def run_all(wire, ramp, n_rep, seed, workers, prog, done):
        real(wire, ramp, 1, seed, workers, prog, done)
        raise exc

    monkeypatch.setattr(clirun, "run_all", run_all)


def test_a_signal_while_publishing_keeps_every_replica(capsys, tmp_path, monkeypatch):
    import signal

    import crumple.cli.run as clirun

    real, seen = clirun.publish, []

    def publish(out, results, **kw):
        seen.append(signal.getsignal(signal.SIGTERM))
        if not kw.get("tag"):
            raise KeyboardInterrupt  # Ctrl-C while the complete run is being written
        return real(out, results, **kw)

    monkeypatch.setattr(clirun, "publish", publish)
    code, _, err = run_cli(capsys, "run", "--out", tmp_path, "--replicas", 2, *RUN_SMALL)
    assert code == 130 and "kept the 2 finished replica(s) of 2" in err, err
    assert seen[0] is clirun._on_sigterm  # the handler was still in place
    with h5py.File(tmp_path / "ramps.interrupted.h5") as f:
        assert f["positions"].shape[0] == 2


def test_an_interrupted_overwrite_keeps_the_complete_old_results(capsys, tmp_path, monkeypatch):
    assert run_cli(capsys, "run", "--out", tmp_path, "--replicas", 2, *RUN_SMALL)[0] == 0
    old = (tmp_path / "ramps.h5").read_bytes()
    _stop_after_replica_0(monkeypatch)
    code, _, err = run_cli(capsys, "run", "--out", tmp_path, "--replicas", 2, "--kb", 8,
                           "--overwrite", *RUN_SMALL)  # fmt: skip
    assert code == 130 and "kept the 1 finished replica(s) of 2" in err, err
    assert (tmp_path / "ramps.h5").read_bytes() == old
    with h5py.File(tmp_path / "ramps.interrupted.h5") as f:
        assert f["positions"].shape[0] == 1 and json.loads(f.attrs["wire"])["k_b"] == 8


def test_a_second_signal_while_saving_is_ignored(capsys, tmp_path, monkeypatch):
    import os
    import signal

    import crumple.cli.run as clirun

    real = clirun.publish

    def publish(out, results, **kw):
        os.kill(os.getpid(), signal.SIGTERM)  # the impatient second kill
        os.kill(os.getpid(), signal.SIGINT)
        return real(out, results, **kw)

    _stop_after_replica_0(monkeypatch)
    monkeypatch.setattr(clirun, "publish", publish)
    code, _, err = run_cli(capsys, "run", "--out", tmp_path, "--replicas", 2, *RUN_SMALL)
    assert code == 130 and "kept the 1 finished replica(s)" in err, err
    assert (tmp_path / "ramps.interrupted.h5").is_file()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
