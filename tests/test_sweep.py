"""Sweeps: content-addressed runs, Dask execution, resume after kill -9, failures, damaged
files, loading into xarray, and the command line."""

import fcntl
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import crumple
from crumple.cli import main
from crumple.model import Plasticity, Wire
from crumple.protocol import Ramp, replica_seeds, run_replicas
from crumple.stage_observables import STRAIGHT
from crumple.storage import save_ramps, verify_ramps
from crumple.sweep import (
    IncompleteSweepWarning,
    Sweep,
    canonical_json,
    load,
    run_id,
    run_sweep,
    sweep_status,
)

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "sweep-small.toml"


def run_files(out) -> dict[str, Path]:
    return {p.stem: p for p in sorted((Path(out) / "runs").glob("*.h5"))}


def positions_of(out) -> dict[str, np.ndarray]:
    """Stored positions of every run, read with h5py alone."""
    got = {}
    for rid, p in run_files(out).items():
        with h5py.File(p, "r") as f:
            got[rid] = f["positions"][()]
    return got


def assert_same_positions(a, b):
    pa, pb = positions_of(a), positions_of(b)
    assert sorted(pa) == sorted(pb)
    for rid in pa:
        assert pa[rid].tobytes() == pb[rid].tobytes(), rid  # bit for bit, NaN padding included


@pytest.fixture(scope="module")
def small():
    return Sweep.from_toml(EXAMPLE)


@pytest.fixture(scope="module")
def client():
    """Two single-threaded worker processes, shared by the tests that need a cluster."""
    import logging

    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as c,
    ):
        yield c


@pytest.fixture(scope="module")
def reference(small, tmp_path_factory):
    """The example sweep, uninterrupted, on one local worker."""
    out = tmp_path_factory.mktemp("reference")
    report = run_sweep(small, out, workers=1)
    assert report.complete and len(report.computed) == len(small) == 12
    assert report.workers == 1
    return out


# --------------------------------------------------------------------------------------------
# Ids, seeds, the sweep description
# --------------------------------------------------------------------------------------------


def test_pinned_run_ids():
    """Changing any of these silently orphans every stored result: bump RUN_ID_SCHEMA instead
    and say so in the changelog. Every parameter is given, so that a changed default (a
    different run, rightly a different id) does not fail this test."""
    ramp = Ramp(lambdas=(1, 10, 100), maxiter=500)
    assert run_id(Wire(k_b=5, k_s=5e5, n_segments=20), ramp, 0, 0) == "5eddca8549109f84"
    assert run_id(Wire(k_b=5, k_s=5e5, n_segments=20), ramp, 1, 0) == "11dc157ea3290fb8"
    plastic = Wire(k_b=2, k_s=1e5, n_segments=40, plasticity=Plasticity(s=0.2, theta_p=0.3))
    ramp = Ramp(lambdas=(1, 70, 1000), ftol=1e-7, maxiter=500)
    assert run_id(plastic, ramp, 3, 2024) == "46ca2e14af21b78b"


@pytest.mark.skipif("rest_angle_sd" not in Wire.__dataclass_fields__, reason="no such field")
def test_a_parameter_at_its_neutral_value_leaves_the_id_alone():
    """rest_angle_sd = 0 reproduces the runs made before the parameter existed (ID_NEUTRAL)."""
    ramp = Ramp(lambdas=(1, 10, 100), maxiter=500)
    flat = Wire(k_b=5, k_s=5e5, n_segments=20, rest_angle_sd=0.0)
    assert run_id(flat, ramp, 0, 0) == "5eddca8549109f84"
    assert run_id(flat.replace(rest_angle_sd=0.05), ramp, 0, 0) != "5eddca8549109f84"


@pytest.mark.skipif("rest_angle_sd" not in Wire.__dataclass_fields__, reason="no such field")
def test_rest_angles_of_an_imperfect_wire_are_stored(tmp_path):
    from crumple.storage import load_ramps

    wire = Wire(k_b=5, k_s=5e5, n_segments=20, rest_angle_sd=0.05)
    res = run_replicas(wire, Ramp(lambdas=(1, 10)), n_replicas=2, seed=1)
    back = load_ramps(save_ramps(tmp_path / "r.h5", res))
    for a, b in zip(res, back, strict=True):
        assert a.rest_angles.shape == (19,)
        np.testing.assert_array_equal(a.rest_angles, b.rest_angles)
    verify_ramps(tmp_path / "r.h5")


def test_ids_canonicalise_numbers():
    a = Sweep(wire={"k_b": 5, "n_segments": 20}, ramp={"lambdas": [1, 10], "maxiter": 500})
    b = Sweep(
        wire={"k_b": 5.0, "n_segments": 20.0}, ramp={"lambdas": [1.0, 10.0], "maxiter": 500.0}
    )
    c = Sweep(
        wire={"k_b": np.float32(5), "n_segments": np.int64(20)},
        ramp={"lambdas": (1, 10), "maxiter": np.int32(500)},
    )
    assert [r.id for r in a.runs()] == [r.id for r in b.runs()] == [r.id for r in c.runs()]
    assert canonical_json({"x": -0.0, "maxiter": 3.0, "k": 1}) == '{"k":1.0,"maxiter":3,"x":0.0}'
    other = Sweep(wire={"k_b": 5.000001, "n_segments": 20}, ramp={"lambdas": [1, 10]})
    assert other.runs()[0].id != a.runs()[0].id


def test_more_replicas_keep_the_runs_already_there():
    three = Sweep(wire={"n_segments": 20}, ramp={"lambdas": [1, 10]}, replicas=3, seed=7)
    five = Sweep(wire={"n_segments": 20}, ramp={"lambdas": [1, 10]}, replicas=5, seed=7)
    assert [r.id for r in five.runs()[:3]] == [r.id for r in three.runs()]
    # the generator of replica r does not depend on the number of replicas either
    for r in range(3):
        want = np.random.default_rng(replica_seeds(7, 5)[r]).random(4)
        assert np.array_equal(three.runs()[r].rng().random(4), want)


def test_grid_points_and_dims():
    s = Sweep(
        wire={"n_segments": 20, "plasticity": {"s": [0.2, 1.0], "theta_p": 0.3}},
        ramp={"schedule": {"lam_min": 1, "lam_max": [100, 1000], "n": 4}},
        points=[{"k_b": 2, "k_s": 1e5}, {"k_b": 5, "k_s": 5e5}, {"k_b": 5, "k_s": 1e5}],
        replicas=2,
    )
    assert list(s.dims) == ["s", "lam_max", "point"]
    assert s.dims["point"] == ((2.0, 1e5), (5.0, 5e5), (5.0, 1e5))
    assert s.shape == (2, 2, 3, 2) and len(s) == 24
    run = s.runs()[2 * 3 * 2 - 1]  # s = 0.2, lam_max = 1000, last point, replica 1
    assert run.wire.k_b == 5 and run.wire.k_s == 1e5 and run.wire.plasticity.s == 0.2
    assert run.ramp.lambdas[-1] == 1000 and run.replica == 1 and run.index == (0, 1, 2)
    assert Sweep.from_dict(s.to_dict()).runs() == s.runs()
    # material and list-valued parameters
    m = Sweep(wire={"young": [1e9, 2e9], "radius": 1e-3, "n_segments": 20},
              ramp={"lambdas": [[1, 10], [1, 20]]})  # fmt: skip
    assert m.dims["lambdas"] == ("[1.0, 10.0]", "[1.0, 20.0]")
    assert m.runs()[0].wire == Wire.from_material(young=1e9, radius=1e-3, n_segments=20)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"wire": {"kb": 5}}, r"\[wire\] unknown key 'kb' \(did you mean 'k_b'\?\)"),
        ({"wire": {"k_b": [5, -1]}}, r"\[wire\] at k_b = -1.0: k_b must be a positive"),
        ({"wire": {"k_b": []}}, r"\[wire\] k_b = \[\]: an empty list"),
        ({"wire": {"k_b": [5, 5.0]}}, r"\[wire\] k_b lists the value 5.0 twice"),
        ({"wire": {"n_segments": 20.5}}, r"n_segments must be an integer, got 20.5"),
        ({"wire": {"k_b": 5, "young": 1e9, "radius": 1e-3}}, r"not a mix: got k_b, young"),
        ({"wire": {"plasticity": {"s": [0.5, 2], "theta_p": 0.3}}}, r"at s = 2.0: plasticity s"),
        ({"ramp": {"schedule": {"lam_mx": 3}}}, r"\[ramp\] schedule: unknown key 'lam_mx'"),
        ({"ramp": {"ftol": [1e-6, -1]}}, r"\[ramp\] at ftol = -1.0: ftol must be positive"),
        ({"ramp": {"method": "bfgs"}}, r"method must be 'newton' or 'powell', got 'bfgs'"),
        ({"ramp": {"lambdas": [1, 2], "schedule": {}}}, r"lambdas or schedule, not both"),
        ({"replicas": 0}, r"\[sweep\] replicas must be an integer >= 1, got 0"),
        ({"seed": -3}, r"\[sweep\] seed must be an integer >= 0, got -3"),
        ({"points": [{"k_b": 1}, {"k_s": 1}]}, r"every point must set the same keys"),
        ({"points": [{"k_b": 1}, {"k_b": 1.0}]}, r"lists the point \{'k_b': 1.0\} twice"),
        ({"wire": {"k_b": [1, 2]}, "points": [{"k_b": 3}]}, r"k_b is also swept"),
    ],
)
def test_validation_names_key_and_value(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Sweep(**kwargs)


@pytest.mark.parametrize(
    "text, message",
    [
        ("[wire]\nk_b = [5, -1]\n", "k_b must be a positive finite number, got -1.0"),
        ("[wires]\nk_b = 5\n", "unknown table [wires] (did you mean 'wire'?)"),
        ("[sweep]\nreplica = 3\n", "[sweep] unknown key 'replica' (did you mean 'replicas'?)"),
        ("[ramp]\nschedule = { lam_min = 10, lam_max = 1 }\n", "need 0 < lam_min < lam_max"),
        ("[wire]\nk_b = \n", "invalid TOML"),
        ("[point]\nk_b = 5\n", "write [[point]], not [point]"),
    ],
)
def test_bad_sweep_file_is_one_line(tmp_path, capsys, text, message):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    code = main(["sweep", str(bad), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("crumple: error: ") and str(bad) in err
    assert message in err
    assert not (tmp_path / "out").exists()  # nothing started, nothing written


def test_cli_argument_errors(tmp_path, capsys):
    assert main(["sweep", str(tmp_path / "none.toml"), "--out", str(tmp_path)]) == 2
    assert "no such sweep file" in capsys.readouterr().err
    assert main(["sweep", str(EXAMPLE), "--out", str(tmp_path), "--workers", "0"]) == 2
    assert "--workers must be >= 1" in capsys.readouterr().err
    assert main(["status", str(tmp_path / "nowhere")]) == 2
    assert "no such sweep store" in capsys.readouterr().err
    assert main(["status", str(tmp_path)]) == 2
    assert "is not a sweep store" in capsys.readouterr().err


def test_a_second_sweep_on_a_locked_store_is_refused(tmp_path, small):
    (tmp_path / "runs").mkdir()
    with (tmp_path / ".lock").open("a") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX)  # as a running sweep holds it
        with pytest.raises(ValueError, match="another crumple sweep is writing"):
            run_sweep(small, tmp_path, workers=1)


# --------------------------------------------------------------------------------------------
# Execution and determinism
# --------------------------------------------------------------------------------------------


def test_store_is_self_describing(reference, small):
    manifest = json.loads((reference / "sweep.json").read_text())
    assert manifest["format"] == "crumple-sweep" and len(manifest["runs"]) == 12
    assert [r["id"] for r in manifest["runs"]] == [r.id for r in small.runs()]
    run = small.runs()[4]
    with h5py.File(reference / "runs" / f"{run.id}.h5", "r") as f:  # h5py alone
        assert json.loads(f.attrs["run_id"]) == run.id
        assert json.loads(f.attrs["replica"]) == run.replica == 1
        assert json.loads(f.attrs["coords"]) == {"k_b": 2.0, "s": 1.0}
        assert json.loads(f.attrs["wire"]) == run.wire.to_dict()
        assert json.loads(f.attrs["seed"]) == 2024
        assert f["positions"].shape == (1, len(run.ramp.lambdas), 41, 2)
        assert f.attrs["complete"]


def test_replica_equals_run_replicas_bit_for_bit(reference, small):
    run = small.runs()[0]
    direct = run_replicas(run.wire, run.ramp, n_replicas=3, seed=2024)
    stored = positions_of(reference)
    for r, res in enumerate(direct):
        rid = small.runs()[r].id
        want = np.array([s.positions for s in res.stages])
        assert stored[rid][0].tobytes() == want.tobytes()


def test_one_and_two_workers_store_identical_positions(reference, small, client, tmp_path):
    report = run_sweep(small, tmp_path, client=client)
    assert report.complete and len(report.computed) == 12 and report.workers == 2
    assert_same_positions(reference, tmp_path)


def test_sigkill_then_resume_recomputes_only_missing_runs(reference, tmp_path, capsys):
    out = tmp_path / "killed"
    cmd = [sys.executable, "-m", "crumple.cli", "sweep", str(EXAMPLE), "--out", str(out),
           "--workers", "2", "--quiet"]  # fmt: skip
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)  # fmt: skip
    deadline = time.monotonic() + 240
    try:
        while len(run_files(out)) < 2:
            assert proc.poll() is None, proc.stderr.read().decode()
            assert time.monotonic() < deadline, "no run finished in time"
            time.sleep(0.01)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the sweep and its workers, as kill -9 on a job
        proc.wait()
        proc.stderr.close()
    before = {rid: (p.stat().st_ino, p.stat().st_mtime_ns) for rid, p in run_files(out).items()}
    assert 2 <= len(before) < 12, "the sweep was not interrupted part-way"
    for p in run_files(out).values():
        verify_ramps(p)  # whatever is under a final name is complete
    status = sweep_status(out)
    assert len(status.done) == len(before) and len(status.missing) == 12 - len(before)

    code = main(["sweep", str(EXAMPLE), "--out", str(out), "--workers", "2", "--quiet"])
    report = json.loads(capsys.readouterr().out)
    assert code == 0
    assert report["already_done"] == len(before) and report["computed"] == 12 - len(before)
    after = {rid: (p.stat().st_ino, p.stat().st_mtime_ns) for rid, p in run_files(out).items()}
    assert {rid: after[rid] for rid in before} == before  # finished runs were not rewritten
    assert not list((out / "runs").glob(".*.tmp"))
    assert_same_positions(reference, out)


def test_failing_run_is_recorded_and_the_others_finish(tmp_path, client, capsys, monkeypatch):
    # initial_noise >= 0.5 makes run_ramp raise. Sweep refuses it up front (initial_state is
    # called on every point, issue 15); that check is switched off here, in this process only,
    # so that the worker processes meet a genuine run-time failure
    monkeypatch.setattr("crumple.sweep.spec.initial_state", lambda *a, **k: None)
    sweep = Sweep(
        wire={"n_segments": 20},
        ramp={"lambdas": [1, 10, 100]},
        points=[{"k_b": 5, "initial_noise": 0.01}, {"k_b": 5, "initial_noise": 0.7},
                {"k_b": 2, "initial_noise": 0.01}],
        replicas=2,
    )  # fmt: skip
    report = run_sweep(sweep, tmp_path, client=client)
    bad = {r.id for r in sweep.runs() if r.ramp.initial_noise == 0.7}
    assert set(report.failed) == bad and len(report.computed) == 4
    for rid in bad:
        record = json.loads((tmp_path / "runs" / f"{rid}.failed.json").read_text())
        assert record["error"] == "ValueError" and "initial noise must be in" in record["message"]
        assert "Traceback" in record["traceback"] and record["coords"]["initial_noise"] == 0.7
        assert not (tmp_path / "runs" / f"{rid}.h5").exists()

    assert main(["status", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "6 runs: 4 done, 2 failed, 0 damaged, 0 missing" in text
    for rid in bad:
        assert f"failed   {rid}  ValueError: initial noise must be in" in text

    with pytest.warns(IncompleteSweepWarning, match="2 of 6 runs"):
        ds = load(tmp_path)
    assert ds.sizes == {"point": 3, "replica": 2, "lam": 3}
    assert ds["done"].sel(k_b=5.0, initial_noise=0.7).values.tolist() == [False, False]
    assert np.isnan(ds["E_total"].sel(k_b=5.0, initial_noise=0.7)).all()
    assert ds["done"].sel(k_b=2.0).all()

    again = run_sweep(sweep, tmp_path, client=client)  # failed runs are tried again
    assert again.skipped == 4 and set(again.failed) == bad


def test_damaged_files_are_detected_and_recomputed(reference, small, client, tmp_path):
    out = tmp_path / "store"
    shutil.copytree(reference, out)
    ids = [r.id for r in small.runs()]
    damaged = ids[:5]
    p = [out / "runs" / f"{rid}.h5" for rid in damaged]
    p[0].write_bytes(p[0].read_bytes()[: p[0].stat().st_size // 2])  # truncated
    p[1].write_bytes(b"\x89HDF\r\n\x1a\n" + os.urandom(2000))  # garbage
    with h5py.File(p[2], "a") as f:
        del f.attrs["complete"]  # written, but not to the end
    with h5py.File(p[3], "a") as f:
        del f["energy/total"]  # a dataset missing
    shutil.copy(out / "runs" / f"{ids[6]}.h5", p[4])  # another run's file under this name

    status = sweep_status(out)
    assert sorted(status.corrupt) == sorted(damaged) and len(status.done) == 7
    with pytest.warns(IncompleteSweepWarning, match="5 of 12 runs"):
        ds = load(out, positions=True)
    for rid in damaged:  # never read as data
        at = {k: v for k, v in zip(ds.run_id.dims, np.argwhere(ds.run_id.values == rid)[0],
                                   strict=True)}  # fmt: skip
        assert not ds["done"][at] and np.isnan(ds["positions"][at]).all()

    report = run_sweep(small, out, client=client)
    assert sorted(report.computed) == sorted(damaged) and report.skipped == 7
    assert sweep_status(out).complete
    assert_same_positions(reference, out)


def test_a_worker_that_dies_has_its_run_retried(tmp_path, client):
    sweep = Sweep(wire={"n_segments": 60, "k_b": [2.0, 5.0]}, ramp={"schedule": {"n": 12}},
                  replicas=2)  # fmt: skip
    result = {}
    thread = threading.Thread(target=lambda: result.update(r=run_sweep(sweep, tmp_path,
                                                                       client=client)))  # fmt: skip
    thread.start()
    deadline = time.monotonic() + 60
    while not any(client.processing().values()):
        assert time.monotonic() < deadline
        time.sleep(0.02)
    busy = next(w for w, keys in client.processing().items() if keys)
    pid = client.run(os.getpid, workers=[busy])[busy]
    os.kill(pid, signal.SIGKILL)
    thread.join(timeout=240)
    report = result["r"]
    assert report.complete and len(report.computed) == 4
    assert sweep_status(tmp_path).complete
    assert pid not in client.run(os.getpid).values()  # it did die (the nanny restarted it)


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------


def test_load_gives_a_labelled_dataset(reference, small):
    ds = crumple.load(reference)
    assert dict(ds.sizes) == {"k_b": 2, "s": 2, "replica": 3, "lam": 11}
    assert ds["lam"].values.tolist() == list(small.lambdas)
    mean = ds.sel(k_b=8).mean("replica")
    assert mean["E_total"].dims == ("s", "lam")
    run = small.runs()[4]  # k_b = 2, s = 1, replica 1
    with h5py.File(reference / "runs" / f"{run.id}.h5", "r") as f:
        one = ds.sel(k_b=2.0, s=1.0, replica=1)
        assert one["run_id"].item() == run.id
        np.testing.assert_array_equal(one["E_bending"], f["energy/bending"][0])
        np.testing.assert_array_equal(one["iterations"], f["solver/iterations"][0])
        assert one["converged"].values.tolist() == f["solver/converged"][0].tolist()
        gamma = f["energy/stretching"][0] / f["energy/bending"][0]
        straight = f["observables/max_turning_angle"][0] < STRAIGHT
        assert straight[0] and not straight[-1]  # γ at the straight first stage is NaN
        np.testing.assert_array_equal(one["gamma"], np.where(straight, np.nan, gamma))
        np.testing.assert_array_equal(one["n_loops"], f["observables/n_loops"][0])
        pos = crumple.load(reference, positions=True)["positions"]
        assert pos.dims == ("k_b", "s", "replica", "lam", "node", "xy")
        np.testing.assert_array_equal(pos.sel(k_b=2.0, s=1.0, replica=1), f["positions"][0])
    assert ds["done"].all() and ds.attrs["runs_done"] == 12


def test_load_pads_runs_with_different_schedules_and_sizes(tmp_path):
    """lam is the union of every run's stages; positions are NaN-padded along node."""
    sweep = Sweep(wire={"n_segments": [10, 12]}, ramp={"lambdas": [[1, 10], [1, 5]]})
    (tmp_path / "runs").mkdir()
    from crumple.sweep import _manifest

    (tmp_path / "sweep.json").write_text(json.dumps(_manifest(sweep)))
    for run in sweep.runs():  # written as a worker would, without a cluster
        save_ramps(tmp_path / "runs" / f"{run.id}.h5", [run.compute()], seed=0,
                   attrs={"run_id": run.id})  # fmt: skip
    ds = load(tmp_path, positions=True)
    assert ds["lam"].values.tolist() == [1.0, 5.0, 10.0]
    assert ds.sizes["node"] == 13
    one = ds.sel(n_segments=10, lambdas="[1.0, 10.0]", replica=0)
    assert np.isnan(one["E_total"].sel(lam=5.0)) and not np.isnan(one["E_total"].sel(lam=10.0))
    assert not one["converged"].sel(lam=5.0)
    assert np.isnan(one["positions"].sel(lam=10.0)[11:]).all()
    assert not np.isnan(one["positions"].sel(lam=10.0)[:11]).any()


def test_sweep_files_in_the_docs_are_valid():
    import re
    import tomllib

    text = (EXAMPLE.parents[1] / "docs" / "sweeps.md").read_text()
    blocks = re.findall(r"```toml\n(.*?)```", text, flags=re.S)
    sweeps = [Sweep.from_dict(tomllib.loads(b)) for b in blocks]
    assert len(sweeps) == 2
    assert sweeps[0].shape == (3, 2, 2, 10) and sweeps[0].replicas == 10
    assert list(sweeps[1].dims) == ["theta_p", "point"] and len(sweeps[1]) == 6


_DAMAGE = [
    (lambda m: m.pop("lambdas"), "'lambdas' is missing"),
    (lambda m: m.update(lambdas=[1, "x"]), "finite numbers"),
    (lambda m: m.update(lambdas=[10, 1]), "not increasing"),
    (lambda m: m.pop("sweep"), "'sweep' is missing"),
    (lambda m: m.update(sweep=[1]), "'sweep' is not a dict"),
    (lambda m: m.update(replicas=0), "'replicas' is not a whole number"),
    (lambda m: m["dims"][0].pop("name"), r"dims\[0\] has no 'name'"),
    (lambda m: m["dims"][0].update(values=5), r"dims\[0\] \(k_b\) has no list of 'values'"),
    (lambda m: m["runs"][0].update(index=[7]), r"runs\[0\] has an 'index'"),
    (lambda m: m["runs"][0].pop("index"), r"runs\[0\] has an 'index'"),
    (lambda m: m["runs"][0].update(index="a"), r"runs\[0\] has an 'index'"),
    (lambda m: m["runs"][1].update(replica=3), r"runs\[1\] has a 'replica'"),
]


@pytest.mark.parametrize("damage, match", _DAMAGE, ids=[m for _, m in _DAMAGE])
def test_load_of_a_damaged_manifest_is_one_valueerror(tmp_path, damage, match):
    from crumple.sweep import _manifest

    m = _manifest(Sweep(wire={"n_segments": 12, "k_b": [5.0, 8.0]}, ramp={"lambdas": [1, 10]}))
    damage(m)
    (tmp_path / "runs").mkdir()
    (tmp_path / "sweep.json").write_text(json.dumps(m))
    with pytest.raises(ValueError, match=match):
        load(tmp_path)
