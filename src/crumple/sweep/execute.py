"""Running a sweep on Dask: the cluster, one task per run, progress and the report.

:func:`run_sweep` classifies the runs of a store (:mod:`crumple.sweep.store`), submits those
not done to a ``dask.distributed`` cluster (a ``LocalCluster`` by default, or
:func:`connect`'s client shared by several sweeps) and reports :class:`Progress` as they
finish. Each task (:func:`execute_run`) writes its own file, so an interruption loses at most
the runs in flight.
"""

from __future__ import annotations

import contextlib
import functools
import json
import math
import os
import socket
import sys
import time
import traceback
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from .. import stage_observables
from ..storage import atomic_write_text, save_ramps
from .spec import Sweep
from .store import (
    MANIFEST,
    Run,
    _classify,
    _failed,
    _h5,
    _manifest,
    _record_failure,
    _runs_dir,
    _store_lock,
)


@functools.cache
def _undo_dask_malloc_trim() -> bool:
    """Give glibc's allocator back its large thresholds in a Dask worker process.

    Dask's nanny starts workers with ``MALLOC_TRIM_THRESHOLD_=65536`` (to hand freed memory
    back to the OS). Setting it pins glibc's mmap threshold at 128 KiB, so every array above
    that (a dense Hessian at N >= 60) is mmapped and page-faulted afresh at each allocation:
    a default ramp at N = 100 ran 2.4x slower in a worker than in a plain process (1.4 s vs
    3.4 s, measured). The runs of a sweep are CPU-bound and small in memory, so the worker
    process gets the thresholds glibc's own dynamic scheme grows to (32 MiB for mmap). Once
    per process; a no-op elsewhere than Linux with glibc or without that variable.
    """
    if not os.environ.get("MALLOC_TRIM_THRESHOLD_") or not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL("libc.so.6")
        m_trim_threshold, m_mmap_threshold = -1, -3  # <malloc.h>
        return bool(libc.mallopt(m_mmap_threshold, 32 << 20)) and bool(
            libc.mallopt(m_trim_threshold, 64 << 20)
        )
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False


def _stage_reporter(topic: str | None, rid: str) -> Callable[[int], None] | None:
    """``report(stages_done)``: a Dask event on ``topic`` from the worker running ``rid`` (the
    client's :func:`_execute` counts the stages of the runs in flight). None outside a worker."""
    if topic is None:
        return None
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):  # not in a Dask worker
        return None

    def report(stages: int) -> None:
        worker.log_event(topic, {"id": rid, "stages": stages})  # batched, non-blocking

    return report


def execute_run(task: Mapping, out: str, topic: str | None = None) -> dict:
    """Compute one run on a worker and write ``OUT/runs/<id>.h5`` (or ``<id>.failed.json``).

    Never raises for an error of the run itself: the error is recorded and ``{"status":
    "failed"}`` returned, so that the sweep goes on. Returns a small summary dict. With
    ``topic``: a Dask event ``{"id", "stages"}`` when the run starts and after every stage.
    """
    _undo_dask_malloc_trim()
    out_path = Path(out)
    rid = task["id"]
    t0 = time.perf_counter()
    report = _stage_reporter(topic, rid)
    try:
        run = Run.from_task(task)
        if run.id != rid:
            raise RuntimeError(f"run id mismatch: task {rid}, parameters hash to {run.id}")
        if report is not None:
            report(0)
        result = run.compute(None if report is None else lambda i, n, stage: report(i + 1))
        _save(
            run,
            _h5(out_path, rid),
            [result],
            seed=run.seed,
            attrs={
                "run_id": rid,
                "replica": run.replica,
                "coords": task.get("coords", {}),
                "host": socket.gethostname(),
            },
            observables=lambda: _stage_observables(result),
        )
    except Exception as exc:  # recorded, with its traceback, for `crumple status`
        _record_failure(
            out_path,
            task,
            type(exc).__name__,
            f"{type(exc).__name__}: {exc}",
            traceback.format_exc(),
        )
        return {
            "id": rid,
            "status": "failed",
            "message": f"{type(exc).__name__}: {exc}",
            "seconds": time.perf_counter() - t0,
        }
    _failed(out_path, rid).unlink(missing_ok=True)
    return {"id": rid, "status": "done", "seconds": result.seconds, "converged": result.converged}


def _save(run, path, results, *, seed, attrs, observables) -> None:
    """A ramp's file (:func:`crumple.storage.save_ramps`, with ``observables``) or an
    injection's (:func:`crumple.injection_storage.save_injections`, which measures its own)."""
    if run.protocol == "injection":
        from ..injection_storage import save_injections

        save_injections(path, results, seed=seed, attrs=attrs)
    else:
        save_ramps(path, results, seed=seed, attrs=attrs, observables=observables())


def _stage_observables(result) -> dict:
    """Every entry of :data:`crumple.stage_observables.OBSERVABLES` at every stage of the
    ramp, as ``save_ramps`` stores them: name → (values (1, S), {units, doc})."""
    pos = np.full((len(result.ramp.lambdas), result.wire.n_nodes, 2), np.nan)
    for s, st in enumerate(result.stages):
        pos[s] = st.positions
    values = stage_observables.compute(pos, result.wire)
    meta = stage_observables.OBSERVABLES
    return {
        k: (v[None, :], {"units": meta[k].units, "doc": meta[k].doc}) for k, v in values.items()
    }


@dataclass(frozen=True, slots=True)
class Progress:
    """State of a running sweep, for a progress display.

    ``done`` counts every finished run of the sweep (``skipped`` of them were already in the
    store); ``running`` the runs in flight (runs that a worker has started and not finished:
    at most one per worker thread); ``eta`` seconds (None until some work is done).

    ``stages``, ``stages_total``: λ stages done and planned, over every run of the sweep; a
    finished run counts all its planned stages (also one that stopped early on ``stop_tol``),
    a run in flight the stages its worker has reported. ``stages_skipped``: those of the runs
    already in the store (done before ``elapsed`` started, so not part of the rate).
    """

    total: int
    done: int
    failed: int
    running: int
    skipped: int
    elapsed: float
    eta: float | None
    stages: int = 0
    stages_total: int = 0
    stages_skipped: int = 0


@dataclass(frozen=True, slots=True)
class SweepReport:
    """Outcome of :func:`run_sweep`."""

    path: Path
    total: int
    skipped: int
    computed: tuple[str, ...]
    failed: Mapping[str, str]
    seconds: float
    workers: int

    @property
    def complete(self) -> bool:
        return not self.failed

    def to_dict(self) -> dict:
        return {
            "store": str(self.path),
            "runs": self.total,
            "already_done": self.skipped,
            "computed": len(self.computed),
            "failed": len(self.failed),
            "failed_runs": [{"id": k, "message": v} for k, v in self.failed.items()],
            "workers": self.workers,
            "seconds": round(self.seconds, 3),
        }


@contextlib.contextmanager
def _connect(client, scheduler, workers, n_todo, quiet_logs):
    if client is not None:
        yield client
        return
    from distributed import Client, LocalCluster

    if scheduler is not None:
        with Client(scheduler, timeout="20s") as c:
            yield c
        return
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    if int(workers) < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    import logging

    with _sigint_ignored():  # inherited by the worker processes spawned now
        cluster = LocalCluster(
            n_workers=max(1, min(int(workers), n_todo)),
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port: never collides with another cluster
            silence_logs=logging.ERROR if quiet_logs else logging.WARNING,
        )
    with cluster, Client(cluster) as c:
        yield c


def connect(
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    max_workers: int | None = None,
    quiet_logs: bool = True,
):
    """A Dask client to pass to several :func:`run_sweep` calls (one cluster for all).

    With ``scheduler``: a client of that scheduler. Otherwise a ``LocalCluster`` of
    ``workers`` single-threaded worker processes (default one per core, at most
    ``max_workers``), shut down when the ``with`` block ends::

        with connect(workers=2) as client:
            run_sweep(sweep_a, "a", client=client)
            run_sweep(sweep_b, "b", client=client)
    """
    if workers is not None and scheduler is not None:
        raise ValueError("workers starts a local cluster; with a scheduler it is unused")
    n = max_workers if max_workers is not None else 1 << 30
    return _connect(None, scheduler, workers, max(1, int(n)), quiet_logs)


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while local workers start: they inherit it (through spawn), so Ctrl-C
    stops the sweep in this process, which shuts them down, instead of printing a traceback
    from every worker. Restored on exit; a no-op outside the main thread."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def run_sweep(
    sweep: Sweep,
    out,
    *,
    client=None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[Progress], None] | None = None,
    refresh: float = 1.0,
    quiet_logs: bool = True,
) -> SweepReport:
    """Run every run of ``sweep`` that ``out`` does not hold yet, on Dask.

    Parameters
    ----------
    sweep : Sweep
    out : str or Path
        The store (created if needed). It must be on a file system that every worker sees
        under the same path: each task writes its own run file.
    client : distributed.Client, optional
        Run on this client's cluster (left open).
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:8786``) to connect to.
    workers : int, optional
        Without ``client`` or ``scheduler``: a ``LocalCluster`` of this many single-threaded
        worker processes (default: one per core, at most one per run to compute).
    progress : callable, optional
        ``progress(Progress)`` every ``refresh`` seconds and whenever runs finish.

    Returns
    -------
    SweepReport

    Notes
    -----
    Resuming: runs whose file is present and passes :func:`crumple.storage.verify_ramps` are
    skipped; failed runs, damaged files (deleted first) and missing runs are computed. A run
    that raises is recorded in ``runs/<id>.failed.json`` and the sweep goes on. A worker that
    dies has its run rescheduled by the scheduler (up to ``distributed.scheduler.allowed-
    failures`` times, 3 by default); after that the run is recorded as failed. Runs that do
    not converge are not failures: they are stored, with ``converged`` false at the stages
    concerned.
    """
    if not isinstance(sweep, Sweep):
        raise TypeError(f"sweep must be a Sweep, got {type(sweep).__name__}")
    if client is not None and scheduler is not None:
        raise ValueError("give a client or a scheduler address, not both")
    if workers is not None and (client is not None or scheduler is not None):
        raise ValueError("workers starts a local cluster; with a client or scheduler it is unused")
    out = Path(out).resolve()
    _runs_dir(out).mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with _store_lock(out):
        for tmp in _runs_dir(out).glob(".*.tmp"):  # left by a run killed while writing
            tmp.unlink(missing_ok=True)
        atomic_write_text(out / MANIFEST, json.dumps(_manifest(sweep), indent=1))
        todo = _todo(sweep, out)
        total, skipped = len(sweep), len(sweep) - len(todo)
        failed: dict[str, str] = {}
        computed: list[str] = []
        n_workers = 0
        if todo:
            with _connect(client, scheduler, workers, len(todo), quiet_logs) as c:
                n_workers = len(c.scheduler_info().get("workers", {}))
                n = sum(len(r.stages) for r in sweep.runs())
                computed, failed = _execute(c, todo, out, total, skipped, progress, refresh, t0, n)
        elif progress is not None:
            n = sum(len(r.stages) for r in sweep.runs())
            progress(Progress(total, total, 0, 0, skipped, time.perf_counter() - t0, 0.0,
                              stages=n, stages_total=n, stages_skipped=n))  # fmt: skip
    return SweepReport(
        path=out,
        total=total,
        skipped=skipped,
        computed=tuple(computed),
        failed=MappingProxyType(failed),
        seconds=time.perf_counter() - t0,
        workers=n_workers,
    )


def _todo(sweep: Sweep, out: Path) -> list[Run]:
    """The runs of ``sweep`` that ``out`` does not hold; damaged files are deleted."""
    todo = []
    for run in sweep.runs():
        state, _ = _classify(out, run.id)
        if state == "corrupt":
            _h5(out, run.id).unlink(missing_ok=True)
        if state != "done":
            todo.append(run)
    return todo


def _execute(client, todo, out, total, skipped, progress, refresh, t0, stages_total):
    from distributed import as_completed

    token = os.urandom(4).hex()
    topic = f"crumple-stages-{token}"  # one topic per sweep: sweeps may share a client
    n_stages = {run.id: len(run.stages) for run in todo}
    in_flight: dict[str, int] = {}  # run id -> stages reported by its worker

    def on_event(event) -> None:  # on the client's event loop: a dict update, nothing more
        msg = event[1] if isinstance(event, tuple) else event
        if isinstance(msg, dict) and msg.get("id") in n_stages:
            in_flight[msg["id"]] = max(in_flight.get(msg["id"], 0), int(msg["stages"]))

    client.subscribe_topic(topic, on_event)
    tasks = {}
    for run in todo:
        task = run.to_task()
        fut = client.submit(
            execute_run, task, str(out), topic, key=f"crumple-run-{run.id}-{token}", pure=False
        )
        tasks[fut.key] = (fut, task)
    pending = as_completed([f for f, _ in tasks.values()])
    computed: list[str] = []
    failed: dict[str, str] = {}
    finished_ids: set[str] = set()
    last = -math.inf
    threads = sum(client.nthreads().values()) or 1
    planned = sum(n_stages.values())
    skipped_stages = stages_total - planned
    try:
        while not pending.is_empty():
            batch = pending.next_batch(block=False)
            for fut in batch:
                _, task = tasks.pop(fut.key)
                if fut.status == "finished":
                    summary = fut.result()
                else:  # the worker died too often (KilledWorker), or the cluster went away
                    exc = fut.exception() if fut.status == "error" else None
                    msg = f"{type(exc).__name__}: {exc}" if exc is not None else fut.status
                    msg = f"worker lost while computing this run ({msg})"
                    _record_failure(out, task, type(exc).__name__ if exc else "Cancelled", msg, "")
                    summary = {"id": task["id"], "status": "failed", "message": msg}
                if summary["status"] == "done":
                    computed.append(summary["id"])
                else:
                    failed[summary["id"]] = summary["message"]
                finished_ids.add(task["id"])
                fut.release()
            now = time.perf_counter()
            if progress is not None and (batch or now - last >= refresh or pending.is_empty()):
                if now - last >= 5 * refresh:
                    threads = sum(client.nthreads().values()) or threads
                last = now
                remaining = len(todo) - len(finished_ids)
                started = {k: v for k, v in list(in_flight.items()) if k not in finished_ids}
                work = sum(n_stages[k] for k in finished_ids) + sum(started.values())
                elapsed = now - t0
                eta = eta_seconds(elapsed, work, planned - work)
                progress(
                    Progress(
                        total=total,
                        done=skipped + len(computed),
                        failed=len(failed),
                        running=min(threads, remaining, len(started)),
                        skipped=skipped,
                        elapsed=elapsed,
                        eta=eta,
                        stages=skipped_stages + work,
                        stages_total=stages_total,
                        stages_skipped=skipped_stages,
                    )
                )
            if not batch:
                time.sleep(min(0.1, refresh))
    except BaseException:
        client.cancel([f for f, _ in tasks.values()])
        raise
    finally:
        client.unsubscribe_topic(topic)
    return computed, failed


def eta_seconds(elapsed: float, done: float, remaining: float) -> float | None:
    """Seconds left if the ``remaining`` units of work go at the rate of the ``done`` ones
    (``elapsed`` seconds); None until some work is done. The one ETA of the package: the
    sweep's :class:`Progress` and :func:`crumple.cli.progress.progress_line` both use it.

    >>> eta_seconds(100.0, 25, 75), eta_seconds(5.0, 0, 10)
    (300.0, None)
    """
    if done <= 0:
        return None
    return max(0.0, elapsed / done * remaining)
