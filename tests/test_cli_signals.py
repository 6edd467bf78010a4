"""Signals to ``crumple run`` with worker processes: nothing keeps running, and the command
says what it kept (issue 15, defects 5 and 9)."""

import os
import signal
import subprocess
import sys
import time

import psutil
import pytest

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="process groups, forkserver")

# Powell with a huge budget: every stage runs far longer than the test
SLOW = [
    "--method", "powell", "--maxiter", "100000", "--n-segments", "100", "--lambdas", "1,2,3,4",
]  # fmt: skip


def group(pgid: int) -> list[psutil.Process]:
    """Every live process of a process group (the command and everything it started)."""
    out = []
    for p in psutil.process_iter():
        try:
            if os.getpgid(p.pid) == pgid and p.status() != psutil.STATUS_ZOMBIE:
                out.append(p)
        except (ProcessLookupError, psutil.NoSuchProcess):
            pass
    return out


def start(tmp_path, *flags):
    proc = subprocess.Popen(
        [sys.executable, "-m", "crumple.cli", "run", "--out", str(tmp_path / "o"), *flags],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group: pgid == proc.pid
    )
    workers = []
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        # the workers are the forkserver's children (it is the command's child)
        servers = [k for k in psutil.Process(proc.pid).children()
                   if "forkserver" in " ".join(k.cmdline())]  # fmt: skip
        workers = [w for s in servers for w in s.children()]
        if len(workers) >= 2:
            break
        time.sleep(0.2)
    assert len(workers) >= 2, proc.communicate(timeout=5)
    time.sleep(2.0)  # let them start on the ramp
    return proc


def wait_group_empty(pgid: int, timeout: float = 10.0) -> list:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        left = group(pgid)
        if not left:
            return []
        time.sleep(0.2)
    return [(p.pid, p.cmdline()) for p in group(pgid)]


def test_sigterm_leaves_no_worker_running(tmp_path):
    proc = start(tmp_path, "--replicas", "2", "--workers", "2", *SLOW)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 143, err
    assert wait_group_empty(proc.pid) == []
    assert "terminated" in err and "nothing was written" in err
    assert "Traceback" not in err


def test_sigterm_while_workers_report_their_newton_iterations(tmp_path):
    """Newton stages long enough to report their iterations through the workers' queue: a
    SIGTERM then still stops every process, with the same message and nothing written."""
    long_newton = ["--n-segments", "3000", "--hard-core", "3e-5", "--lambdas", "1000,2000"]
    proc = start(tmp_path, "--replicas", "2", "--workers", "2", *long_newton)
    seen, deadline = "", time.monotonic() + 120
    while time.monotonic() < deadline and "iteration" not in seen:
        line = proc.stderr.readline()
        if not line:
            break
        seen += line
    assert "iteration" in seen, seen
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 143, seen + err
    assert wait_group_empty(proc.pid) == []
    assert "terminated" in err and "nothing was written" in err
    assert "Traceback" not in err
    assert not (tmp_path / "o" / "ramps.h5").exists()


def test_sigint_stops_within_seconds_and_says_what_was_kept(tmp_path):
    proc = start(tmp_path, "--replicas", "4", "--workers", "2", *SLOW)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert time.monotonic() - t0 < 10, err
    assert proc.returncode == 130, err
    assert wait_group_empty(proc.pid) == []
    assert "interrupted: no replica had finished, nothing was written" in err
    assert "Traceback" not in err
    assert not (tmp_path / "o" / "ramps.h5").exists()


def test_sigint_keeps_finished_replicas(tmp_path):
    """Replicas that finished before Ctrl-C are written, marked as such."""
    import json

    import h5py

    # replica 0 of a fast ramp finishes; the in-process loop is then stopped in replica 1
    # (a ramp takes ~0.6 s: 8 replicas leave seconds for the signal to arrive before the end)
    proc = subprocess.Popen(
        [sys.executable, "-m", "crumple.cli", "run", "--out", str(tmp_path / "o"),
         "--replicas", "8", "--workers", "1", "--n-segments", "100"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    err = ""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        err += line
        if "replica 0 done" in line or not line:
            break
    proc.send_signal(signal.SIGINT)
    _, rest = proc.communicate(timeout=30)
    err += rest
    assert proc.returncode == 130, err
    assert "kept the 1 finished replica(s) of 8" in err, err
    with h5py.File(tmp_path / "o" / "ramps.interrupted.h5") as f:
        assert f["positions"].shape[0] == 1
        assert json.loads(f.attrs["interrupted"]) is True
        assert json.loads(f.attrs["replica_ids"]) == [0]
    assert (tmp_path / "o" / "configurations.interrupted.png").exists()
    assert not (tmp_path / "o" / "ramps.h5").exists()  # ramps.h5 is always a complete run


def test_a_ctrl_c_inside_a_compiled_call_is_still_a_ctrl_c():
    """Numba turns a KeyboardInterrupt raised in its Python callbacks into a SystemError caused
    by it; the CLI must read it as the interrupt it is, and nothing else as one."""
    from crumple.cli.run import Terminated, signal_cause

    def wrapped(inner):
        try:
            try:
                raise inner
            except BaseException as e:
                raise SystemError("returned a result with an exception set") from e
        except SystemError as outer:
            return outer

    ctrl_c = KeyboardInterrupt()
    assert signal_cause(wrapped(ctrl_c)) is ctrl_c
    term = Terminated()
    assert signal_cause(wrapped(term)) is term
    assert signal_cause(wrapped(ValueError("x"))) is None
    assert signal_cause(SystemError("plain")) is None
