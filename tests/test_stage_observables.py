"""Per-stage observables: the registry, its storage in a sweep's run files, what load returns
(also for stores written before the observables existed), and γ at straight stages."""

from __future__ import annotations

import json
from types import MappingProxyType

import h5py
import numpy as np
import pytest

from crumple import stage_observables as so
from crumple.model import Wire
from crumple.observables import r_max, radius_of_gyration
from crumple.storage import verify_ramps
from crumple.sweep import Sweep, _manifest, load
from crumple.sweep.execute import execute_run

# --------------------------------------------------------------------------------------------
# The registry on shapes whose values are known
# --------------------------------------------------------------------------------------------


def test_every_entry_is_named_documented_and_has_units():
    assert {"r_max", "radius_of_gyration", "contacts", "n_loops"} <= set(so.OBSERVABLES)
    for name, o in so.OBSERVABLES.items():
        assert o.name == name and o.units and o.doc


def test_straight_wire_and_closed_ring():
    wire = Wire(k_b=5.0, k_s=5e5, n_segments=10)
    straight = np.c_[np.linspace(-0.5, 0.5, 11), np.zeros(11)]
    v = so.compute(straight[None], wire)
    assert v["r_max"][0] == pytest.approx(0.5)
    assert v["radius_of_gyration"][0] == pytest.approx(np.sqrt(1 / 12))
    assert v["contour_length"][0] == pytest.approx(1.0)
    assert v["max_turning_angle"][0] == 0.0
    assert v["contacts"][0] == v["n_loops"][0] == v["loop_contacts"][0] == 0
    # a 10-gon whose last node stops d short of the first: one contact, one loop
    phi = 2 * np.pi * np.arange(11) / 10
    ring = 0.16 * np.c_[np.cos(phi), np.sin(phi)]
    side = ring[0] - ring[9]
    ring[10] = ring[0] - wire.hard_core * side / np.linalg.norm(side)
    v = so.compute(np.stack([ring, np.full_like(ring, np.nan)]), wire)
    assert v["n_loops"][0] == 1 and v["n_loops_nested"][0] == 0 and v["contacts"][0] >= 1
    assert v["contacts_interior"][0] == 0  # the ends close the loop: not an interior contact
    assert all(np.isnan(v[k][1]) for k in so.OBSERVABLES)  # a stage not run


def test_a_crossing_wire_has_no_loops_but_its_other_observables():
    wire = Wire(k_b=5.0, k_s=5e5, n_segments=3)
    bowtie = np.array([[0.0, 0.0], [0.3, 0.3], [0.3, 0.0], [0.0, 0.3]])  # segments 0 and 2 cross
    v = so.compute(bowtie[None], wire)
    assert np.isnan(v["n_loops"][0]) and np.isnan(v["loop_contacts"][0])
    assert v["r_max"][0] > 0 and v["contacts"][0] == 1


def test_gamma_is_nan_at_straight_stages_only():
    g = so.gamma([1e-6, 1.0, 2.0, 1.0], [1e-24, 4.0, 0.0, np.nan], [1e-10, 0.2, 0.5, 0.5])
    assert np.isnan(g[0]) and g[1] == 0.25 and np.isnan(g[2]) and np.isnan(g[3])


# --------------------------------------------------------------------------------------------
# Stored by a sweep, returned by load
# --------------------------------------------------------------------------------------------

SWEEP = Sweep(wire={"n_segments": 12, "k_b": [5.0, 8.0]}, ramp={"lambdas": [1, 300, 3000]})


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """A two-run store, written by execute_run as a Dask worker would (no cluster)."""
    out = tmp_path_factory.mktemp("stage_obs")
    (out / "runs").mkdir()
    (out / "sweep.json").write_text(json.dumps(_manifest(SWEEP)))
    for run in SWEEP.runs():
        assert execute_run(run.to_task(), str(out))["status"] == "done"
    return out


def test_runs_store_every_observable_with_units(store):
    for run in SWEEP.runs():
        h5 = store / "runs" / f"{run.id}.h5"
        verify_ramps(h5, run_id=run.id)
        with h5py.File(h5, "r") as f:
            assert set(f["observables"]) == set(so.OBSERVABLES)
            assert f["observables/r_max"].shape == (1, 3)
            assert f["observables/r_max"].attrs["units"] == "length"


def test_load_returns_the_observables(store):
    ds = load(store, positions=True)
    for k in so.OBSERVABLES:
        assert ds[k].dims == ("k_b", "replica", "lam")
        assert ds[k].attrs["units"] == so.OBSERVABLES[k].units
    assert ds.attrs["observables_computed_on_load"] == 0
    x = ds["positions"].sel(k_b=8.0, replica=0, lam=3000.0).values
    one = ds.sel(k_b=8.0, replica=0, lam=3000.0)
    assert one["r_max"] == r_max(x) and one["radius_of_gyration"] == radius_of_gyration(x)
    assert one["n_loops"] >= 0


def test_load_gamma_is_nan_at_the_straight_stage(store):
    """Issue 15, defect 2: γ read 1e15-1e21 at straight stages (E_b is round-off there)."""
    ds = load(store)
    first = ds.sel(lam=1.0)
    assert (first["max_turning_angle"] < so.STRAIGHT).all()
    assert (first["E_stretching"] / first["E_bending"] > 1e6).all()  # what it used to read
    assert np.isnan(first["gamma"]).all()
    bent = ds.sel(lam=3000.0)
    np.testing.assert_array_equal(bent["gamma"], bent["E_stretching"] / bent["E_bending"])


def test_a_store_written_before_the_observables_gets_them_computed_on_load(store, tmp_path):
    """Files without the observables group (or lacking one entry, added to the registry later)
    load with the same values, computed from their positions."""
    import shutil

    old = tmp_path / "old"
    shutil.copytree(store, old)
    files = sorted((old / "runs").glob("*.h5"))
    with h5py.File(files[0], "a") as f:
        del f["observables"]
    with h5py.File(files[1], "a") as f:
        del f["observables/n_loops"]
    for p in files:
        verify_ramps(p)  # still a valid run file: the group is optional
    got, want = load(old), load(store)
    assert got.attrs["observables_computed_on_load"] == 2
    for k in (*so.OBSERVABLES, "gamma"):
        np.testing.assert_array_equal(got[k], want[k])


def test_one_contact_distance_everywhere():
    """crumple measure, measure() and the stored contacts count at one distance, 2 d."""
    import inspect as pyinspect

    import crumple.cli.media
    import crumple.cli.run
    from crumple.model import Wire
    from crumple.observables import measure
    from crumple.stage_observables import CONTACT_DISTANCE, CONTACT_FACTOR

    assert CONTACT_DISTANCE == CONTACT_FACTOR * Wire(k_b=1, k_s=1, n_segments=3).hard_core
    assert pyinspect.signature(measure).parameters["contact_distance"].default == CONTACT_DISTANCE
    for mod in (crumple.cli.media, crumple.cli.run):  # no copies of the factor
        assert "CONTACT_FACTOR" not in vars(mod)


def test_a_failing_observable_stores_nan_and_keeps_the_run(tmp_path, monkeypatch, caplog):
    def boom(x, wire):
        raise ZeroDivisionError("a bug in a new observable")

    registry = dict(so.OBSERVABLES)
    registry["boom"] = so.StageObservable(name="boom", units="1", doc="raises", func=boom)
    monkeypatch.setattr(so, "OBSERVABLES", MappingProxyType(registry))
    sweep = Sweep(wire={"n_segments": 12}, ramp={"lambdas": [1, 300]})
    (tmp_path / "runs").mkdir()
    (tmp_path / "sweep.json").write_text(json.dumps(_manifest(sweep)))
    (run,) = sweep.runs()
    with caplog.at_level("WARNING", logger="crumple.stage_observables"):
        assert execute_run(run.to_task(), str(tmp_path))["status"] == "done"
    with h5py.File(tmp_path / "runs" / f"{run.id}.h5", "r") as f:
        assert np.isnan(f["observables/boom"][()]).all()
        assert np.isfinite(f["observables/r_max"][()]).all()
    assert "'boom' failed at 2 stage(s)" in caplog.text and "ZeroDivisionError" in caplog.text
