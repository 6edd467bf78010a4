"""Round trip of ramp results through HDF5, atomic writes, and readability without crumple."""

import json
from dataclasses import replace

import h5py
import numpy as np
import pytest

from crumple.model import Plasticity, Wire
from crumple.protocol import Ramp, run_replicas
from crumple.storage import FORMAT, load_ramps, read_attrs, save_ramps


@pytest.fixture(scope="module")
def results():
    wire = Wire(k_b=5, k_s=5e5, n_segments=20, plasticity=Plasticity(s=0.2, theta_p=0.5))
    return run_replicas(wire, Ramp(lambdas=(1, 20, 200)), n_replicas=2, seed=3)


def test_round_trip_is_exact(tmp_path, results):
    path = save_ramps(tmp_path / "r.h5", results, seed=3)
    back = load_ramps(path)
    assert len(back) == len(results)
    for a, b in zip(results, back, strict=True):
        assert a.wire == b.wire and a.ramp == b.ramp
        np.testing.assert_array_equal(a.initial, b.initial)
        assert len(a.stages) == len(b.stages)
        for sa, sb in zip(a.stages, b.stages, strict=True):
            assert sa.lam == sb.lam
            np.testing.assert_array_equal(sa.positions, sb.positions)
            assert sa.energy == sb.energy
            assert sa.result.converged == sb.result.converged
            assert sa.result.message == sb.result.message
            assert sa.result.iterations == sb.result.iterations


def test_a_file_from_before_the_curved_steps_switch_reads_as_straight_steps(tmp_path, results):
    """Files written before ``Ramp.curved_steps`` existed have no such key; their ramps took
    straight steps only, whatever the default is now."""
    on = [replace(r, ramp=replace(r.ramp, curved_steps=True)) for r in results]
    path = save_ramps(tmp_path / "r.h5", on, seed=3)
    assert all(r.ramp.curved_steps for r in load_ramps(path))
    with h5py.File(path, "r+") as f:
        ramp = json.loads(f.attrs["ramp"])
        del ramp["curved_steps"]
        f.attrs["ramp"] = json.dumps(ramp)
    assert all(r.ramp.curved_steps is False for r in load_ramps(path))


def test_a_file_from_before_the_fallback_choice_reads_as_the_projected_fallback(tmp_path, results):
    """Files written before ``Ramp.fallback`` existed took the projected fallback at every N,
    whatever "auto" resolves to now; the key, once written, is read back as written."""
    exact = [replace(r, ramp=replace(r.ramp, fallback="exact")) for r in results]
    path = save_ramps(tmp_path / "r.h5", exact, seed=3)
    assert all(r.ramp.fallback == "exact" for r in load_ramps(path))
    with h5py.File(path, "r+") as f:
        ramp = json.loads(f.attrs["ramp"])
        del ramp["fallback"]
        f.attrs["ramp"] = json.dumps(ramp)
    assert all(r.ramp.fallback == "projected" for r in load_ramps(path))


def test_file_is_plain_hdf5_with_parameters_as_attributes(tmp_path, results):
    path = save_ramps(tmp_path / "r.h5", results, seed=3)
    with h5py.File(path, "r") as f:  # read with h5py alone, as any user would
        assert f.attrs["format"] == FORMAT
        wire = json.loads(f.attrs["wire"])
        assert wire["k_b"] == 5.0 and wire["plasticity"] == {"s": 0.2, "theta_p": 0.5}
        assert f["positions"].shape == (2, 3, 21, 2)
        assert f["energy/total"].shape == (2, 3)
        assert set(json.loads(f.attrs["versions"])) >= {"crumple", "numpy", "scipy", "numba"}
    assert read_attrs(path)["seed"] == 3


def test_early_stop_is_nan_padded(tmp_path):
    wire = Wire(k_b=5, k_s=5e5, n_segments=10)
    # stop_tol larger than any motion: stops after the second stage
    res = run_replicas(wire, Ramp(lambdas=(1, 1.1, 1.2, 1.3), stop_tol=1.0), n_replicas=1)
    assert len(res[0].stages) == 2
    path = save_ramps(tmp_path / "r.h5", res)
    with h5py.File(path) as f:
        assert f["n_stages"][0] == 2
        assert np.isnan(f["positions"][0, 2:]).all()
    assert len(load_ramps(path)[0].stages) == 2


def test_failed_write_leaves_no_file(tmp_path, results, monkeypatch):
    target = tmp_path / "r.h5"

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(h5py.Group, "create_group", boom)
    with pytest.raises(RuntimeError):
        save_ramps(target, results)
    assert list(tmp_path.iterdir()) == []


def test_not_a_results_file(tmp_path):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not hdf5")
    with pytest.raises(ValueError, match="not a readable HDF5"):
        load_ramps(bad)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = 1
    with pytest.raises(ValueError, match="not a crumple ramp file"):
        load_ramps(other)


def test_mixed_replicas_refused(tmp_path, results):
    other = run_replicas(Wire(k_b=1, k_s=5e5, n_segments=20), Ramp(lambdas=(1, 20, 200)),
                         n_replicas=1)  # fmt: skip
    with pytest.raises(ValueError, match="share the wire"):
        save_ramps(tmp_path / "r.h5", [results[0], other[0]])
