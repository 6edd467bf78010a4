"""Parameter sweeps: grids or lists of parameter points × replicas, run on Dask, stored per run.

A **sweep** (:class:`Sweep`, or a TOML file, see ``docs/sweeps.md``) is a set of parameter
points (a cartesian grid over any model, protocol and minimiser parameter, and/or an explicit
list of points) times a number of replicas, with one base seed. A **run** (:class:`Run`) is
one point and one replica: one confinement ramp (:func:`crumple.protocol.run_ramp`).

* Runs are **content-addressed**: :func:`run_id` hashes the canonical parameters of the wire
  and the ramp, the replica index and the base seed (``1`` and ``1.0`` are the same run).
* Replica ``r`` of a point draws its randomness from
  ``replica_seeds(seed, n_replicas)[r]`` (:func:`crumple.protocol.replica_seeds`), whose spawn
  key is ``(r,)`` whatever ``n_replicas``: a sweep's replica equals
  ``run_replicas(wire, ramp, n_replicas=..., seed=seed)[r]`` bit for bit, raising the number
  of replicas keeps the runs already done, and the stored positions do not depend on the
  number of workers or on the order in which runs finish.
* :func:`run_sweep` executes the runs that are not yet done on a ``dask.distributed``
  cluster (a ``LocalCluster`` by default). Each task writes its own file, atomically, so an
  interruption loses at most the runs in flight; rerunning computes only what is missing,
  failed or damaged.
* :func:`load` reads a store into an :class:`xarray.Dataset`; :func:`sweep_status` says what
  is done, failed and missing.

Modules, each depending only on those above it:

    store     run ids (content addresses), run files, status, lock, failure records
    spec      Sweep: a TOML file or dict -> validated parameter points -> runs
    execute   run_sweep and connect: Dask, one task per run, progress
    dataset   load: a store as an xarray.Dataset

The store layout is in :mod:`crumple.sweep.store`.
"""

from .dataset import IncompleteSweepWarning, load
from .execute import Progress, SweepReport, connect, execute_run, run_sweep
from .spec import Sweep
from .store import (
    ID_NEUTRAL,
    MANIFEST,
    RUN_ID_SCHEMA,
    Run,
    SweepStatus,
    canonical_json,
    run_id,
    sweep_status,
)
from .store import (
    _manifest as _manifest,  # tests write manifests of their own
)

__all__ = [
    "ID_NEUTRAL",
    "MANIFEST",
    "RUN_ID_SCHEMA",
    "IncompleteSweepWarning",
    "Progress",
    "Run",
    "Sweep",
    "SweepReport",
    "SweepStatus",
    "canonical_json",
    "connect",
    "execute_run",
    "load",
    "run_id",
    "run_sweep",
    "sweep_status",
]
