"""The command line: outputs match the library, every bad input is one line and exit != 0."""

import json

import h5py
import numpy as np
import pytest

from crumple.cli import main
from crumple.energy import energy_terms
from crumple.model import Plasticity, Wire
from crumple.observables import measure


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
