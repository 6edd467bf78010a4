"""One progress display over a whole job (``crumple sweep``, ``reproduce``, ``figures``).

:func:`progress_line` formats the state of every experiment as one line (a pure function,
tested); :class:`JobProgress` receives :class:`crumple.sweep.Progress` reports from the
sweeps, keeps the latest of each, and writes the line to stderr: rewritten in place on a
terminal (at most twice a second), or one line every ``every`` seconds in a log (CI), so
that a log of a long run stays short and each of its lines says where the job is.
"""

from __future__ import annotations

import math
import os
import shutil
import sys
import threading
import time
from collections.abc import Mapping
from typing import Any, TextIO

from ..sweep.execute import eta_seconds

__all__ = ["JobProgress", "duration", "progress_line"]


def duration(seconds: float | None) -> str:
    """``42 s``, ``3 min 05 s``, ``2 h 07 min``; ``?`` for None.

    >>> duration(None), duration(42.4), duration(185), duration(7625)
    ('?', '42 s', '3 min 05 s', '2 h 07 min')
    """
    if seconds is None or not math.isfinite(seconds):
        return "?"
    s = round(max(0.0, seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def progress_line(phase: str, parts: Mapping[str, Any], *, elapsed: float, bar: int = 0) -> str:
    """The state of a job in one line.

    The ETA is the time the remaining stages take at the rate of the stages done in this
    session (stages of runs found already done do not count towards the rate); ``?`` until a
    stage is done. Stages of runs in flight count as their workers report them, so the ETA
    and the count move during a long first ramp.

    Parameters
    ----------
    phase : str
        What the job is doing: ``simulating``, ``measuring``, ``drawing figures``, ...
    parts : mapping
        Experiment name -> its latest :class:`crumple.sweep.Progress` (or anything with
        the same attributes). Several experiments are summed; one is shown alone.
    elapsed : float
        Seconds since the job started.
    bar : int
        Width of a ``[###...]`` bar (0: none, for logs).

    Examples
    --------
    >>> from types import SimpleNamespace as P
    >>> a = P(total=32, done=14, failed=0, running=2, skipped=0, stages=300,
    ...       stages_total=640, stages_skipped=0)
    >>> b = P(total=3, done=0, failed=0, running=0, skipped=0, stages=0, stages_total=60,
    ...       stages_skipped=0)
    >>> print(progress_line("simulating", {"elastic": a, "disorder": b}, elapsed=150))
    ... # doctest: +NORMALIZE_WHITESPACE
    simulating: 14/35 ramps, 300/700 stages (42%), 2 running, 0 failed,
    2 min 30 s elapsed, ETA 3 min 20 s [elastic 14/32, disorder 0/3]
    """
    ps = list(parts.values())
    total = sum(p.total for p in ps)
    done = sum(p.done for p in ps)
    failed = sum(p.failed for p in ps)
    running = sum(p.running for p in ps)
    st = sum(getattr(p, "stages", 0) for p in ps)
    st_total = sum(getattr(p, "stages_total", 0) for p in ps)
    st_skip = sum(getattr(p, "stages_skipped", 0) for p in ps)
    work = st - st_skip
    if st_total:
        frac = st / st_total
        eta = eta_seconds(elapsed, work, st_total - st)
        count = f"{done}/{total} ramps, {st}/{st_total} stages ({math.floor(100 * frac)}%)"
    else:  # reports without stage counts: runs only
        frac = (done + failed) / max(total, 1)
        fresh = done + failed - sum(p.skipped for p in ps)
        eta = eta_seconds(elapsed, fresh, total - done - failed)
        count = f"{done}/{total} ramps"
    if done + failed == total:
        eta = 0.0
    already = sum(p.skipped for p in ps)
    line = f"{phase}: "
    if bar:
        filled = min(bar, int(bar * frac))
        line += f"[{'#' * filled}{'.' * (bar - filled)}] "
    line += count
    if already:
        line += f" ({already} ramps already done)"
    line += (
        f", {running} running, {failed} failed, {duration(elapsed)} elapsed, ETA {duration(eta)}"
    )
    if len(parts) > 1:
        line += " [" + ", ".join(f"{k} {p.done}/{p.total}" for k, p in parts.items()) + "]"
    return line


class JobProgress:
    """The progress display of one job, on ``stream`` (default stderr).

    Call it as ``progress(experiment, Progress)`` (``crumple.reproduce.run``'s callback) or
    use :meth:`sweep` for a single sweep; :meth:`phase` announces a new phase on its own line.
    Thread-safe: ``reproduce`` reports from one thread per experiment.
    """

    def __init__(
        self,
        quiet: bool = False,
        *,
        every: float = 30.0,
        stream: TextIO | None = None,
        grace: float = 10.0,
    ):
        self.quiet, self.every, self.grace = quiet, every, grace
        self.stream = sys.stderr if stream is None else stream
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.parts: dict[str, Any] = {}
        self.t0 = time.monotonic()
        self.last = -math.inf
        self.name = "simulating"
        self.open = False  # a rewritten line is on screen
        self.lock = threading.Lock()

    def __call__(self, experiment: str, p) -> None:
        with self.lock:
            self.parts[experiment] = p
            self._show()

    def sweep(self, p) -> None:
        """The callback of :func:`crumple.sweep.run_sweep`."""
        self("sweep", p)

    def _show(self) -> None:
        if self.quiet:
            return
        now = time.monotonic()
        finished = all(p.done + p.failed == p.total for p in self.parts.values())
        if not finished and now - self.last < (0.5 if self.tty else self.every):
            return
        # in a log, the first line waits a fixed min(grace, every) seconds: long enough, in
        # practice, for every experiment to report once (each reports as soon as it has
        # checked its store), so that the first line's totals are usually the job's; it does
        # not wait for the reports themselves (an experiment slow to start shows up later)
        if not finished and not self.tty and now - self.t0 < min(self.grace, self.every):
            return
        self.last = now
        line = progress_line(self.name, self.parts, elapsed=now - self.t0, bar=20 * self.tty)
        if self.tty:
            self._emit(f"\r{line}\x1b[K")
            self.open = not self.quiet
        else:
            self._emit(line + "\n")

    def _emit(self, text: str) -> None:
        """Write and flush; if the stream is gone (a closed pipe: ``2>&1 | head``), go quiet
        instead of failing the job: the display is a courtesy, the results are the point."""
        try:
            self.stream.write(text)
            self.stream.flush()
        except OSError:
            self.quiet, self.open = True, False

    def close(self) -> None:
        """End a rewritten line (on a terminal) so that what follows starts on its own."""
        with self.lock:
            if self.open and not self.quiet:
                self._emit("\n")
            self.open = False

    def phase(self, message: str) -> None:
        """A line such as ``drawing figures: fig4_gamma (3/9)``, after the progress line."""
        if self.quiet:
            return
        with self.lock:
            elapsed = duration(time.monotonic() - self.t0)
            self._emit(("\n" if self.open else "") + f"crumple: {message} ({elapsed} elapsed)\n")
            self.open = False


#: Where no earlier replica has measured a stage's cost, it is taken at the pace of the last
#: this many stages measured (a ramp's stages cost more as λ grows and contacts multiply).
RECENT_STAGES = 5


def time_left(costs: dict, ran: dict, left: dict, elapsed: float, recent: list) -> float:
    """Seconds left, from the cost of each stage index measured so far.

    ``costs[i]``: the durations measured for stage i (in any replica); ``ran[r]``: the stages
    replica r has run; ``left[r]``: the stages it has still to run (every replica, started or
    not); ``recent``: the durations in the order measured. A stage index not measured yet costs
    the mean of the last :data:`RECENT_STAGES` durations. The time left is the elapsed time
    times the work left over the work done, both in those costs: so a second replica is timed
    by the first one's stages, the parallel workers' rate is the one measured, and the average
    over all stages (which read "~2 s left" before a 70 s last stage at N = 10⁴) is the special
    case of equal costs. NaN before anything was measured.

    >>> costs = {0: [1.0], 1: [1.0], 2: [10.0]}       # one replica, 3 of 5 stages run
    >>> time_left(costs, {0: 3}, {0: 2}, 12.0, [1.0, 1.0, 10.0])  # 2 more at (1+1+10)/3 each
    8.0
    """
    if not recent:
        return math.nan
    pace = sum(recent[-RECENT_STAGES:]) / len(recent[-RECENT_STAGES:])
    cost = {i: sum(v) / len(v) for i, v in costs.items() if v}

    def work(first, count):
        return sum(cost.get(i, pace) for i in range(first, first + count))

    done = sum(work(0, n) for n in ran.values())
    todo = sum(work(ran.get(r, 0), n) for r, n in left.items())
    return elapsed * todo / done if done > 0 else math.nan


def _columns(stream) -> int:
    """The width of the terminal ``stream`` writes to (stderr's own, not stdout's: a run's
    summary on stdout may go to a file); else :func:`shutil.get_terminal_size`'s guess."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, OSError, ValueError):
        return shutil.get_terminal_size().columns


class Progress:
    """Stages and replicas done, on stderr: one rewritten line on a terminal (cut to its
    width), else a line at most every ``every`` seconds, and one line per finished replica.
    The time left weighs each remaining stage by what that stage cost in earlier replicas
    (:func:`time_left`). A stage that runs long also reports its Newton iterations
    (:meth:`iteration`), in a log at most every ``every_iteration`` seconds; ``ftol`` and
    ``maxiter``, the ramp's, are shown beside them."""

    def __init__(
        self,
        quiet: bool,
        n_replicas: int,
        n_stages: int,
        every: float = 5.0,
        every_iteration: float = 30.0,
        *,
        ftol: float | None = None,
        maxiter: int | None = None,
    ):
        self.quiet, self.every, self.every_iteration = quiet, every, every_iteration
        self.ftol, self.maxiter = ftol, maxiter
        self.n_rep, self.n_stages = n_replicas, n_stages
        self.tty = sys.stderr.isatty()
        self.clock = time.monotonic  # the logs' throttle (a test scripts it)
        self.t0 = time.perf_counter()
        self.last = {"stage": -math.inf, "iteration": -math.inf}  # each kind's last line in a log
        self.stages_done: dict[int, int] = {}
        self.not_converged = 0
        self.replicas_done = 0
        self.ran: dict[int, int] = {}  # stages each replica has run
        self.finished: dict[int, float] = {}  # when each replica's last stage finished
        self.costs: dict[int, list[float]] = {}  # stage index -> the durations measured
        self.recent: list[float] = []  # the durations, in the order measured

    def _write(self, line: str, force: bool = False, kind: str = "stage") -> None:
        """``line``: on a terminal over the last one, cut to the terminal's width; in a log
        when ``force`` or when the last line of its ``kind`` ("stage" or "iteration") is older
        than that kind's interval."""
        if self.quiet:
            return
        try:
            if self.tty:  # erase to the line's end, and never wrap (a wrapped line stays)
                sys.stderr.write("\r\x1b[K" + line[: _columns(sys.stderr) - 1])
            else:
                now = self.clock()
                every = self.every if kind == "stage" else self.every_iteration
                if force or now - self.last[kind] >= every:
                    self.last[kind] = now
                    sys.stderr.write(line + "\n")
            sys.stderr.flush()
        except OSError:  # stderr closed (e.g. `2>&1 | head`): go quiet, keep computing
            self.quiet = True

    def _measure(self, r: int, i: int, now: float) -> None:
        """The duration of replica r's stage i: since its stage i - 1 finished, or, for the
        first stage of a replica that started with the run (none had finished), since the
        start; otherwise its start is not known and nothing is measured."""
        start = self.finished.get(r, 0.0 if self.replicas_done == 0 and i == 0 else None)
        if start is not None:
            self.costs.setdefault(i, []).append(now - start)
            self.recent.append(now - start)
        self.finished[r] = now
        self.ran[r] = i + 1

    def stage(self, r: int, i: int, lam: float, converged: bool) -> None:
        self.stages_done[r] = i + 1
        self.not_converged += not converged
        done = sum(self.stages_done.values())
        total = self.n_rep * self.n_stages
        elapsed = time.perf_counter() - self.t0
        self._measure(r, i, elapsed)
        left = {q: self.n_stages - self.stages_done.get(q, 0) for q in range(self.n_rep)}
        eta = time_left(self.costs, self.ran, left, elapsed, self.recent)
        bad = f", {self.not_converged} NOT converged" if self.not_converged else ""
        self._write(
            f"  stage {done}/{total} (replica {r}: λ = {lam:.4g}){bad}, "
            f"{self.replicas_done}/{self.n_rep} replica(s) done, {duration(elapsed)} elapsed, "
            f"~{duration(eta)} left"
        )

    def iteration(
        self, r: int, i: int, lam: float, it: int, energy: float, max_force: float, seconds
    ) -> None:
        """Replica r's stage i has run ``seconds``: its Newton iteration ``it`` reached
        ``energy`` and ``max_force``."""
        cap = "" if self.maxiter is None else f"/{self.maxiter}"
        goal = "" if self.ftol is None else f" (ftol {self.ftol:.3g})"
        bad = f", {self.not_converged} NOT converged" if self.not_converged else ""
        # what moves first: a terminal's line is cut to its width
        self._write(
            f"  λ = {lam:.4g}: energy {energy:.10g}, max force {max_force:.3g}{goal}, "
            f"iteration {it}{cap}, {duration(seconds)} into stage {i + 1}/{self.n_stages} of "
            f"replica {r}{bad}",
            kind="iteration",
        )

    def coarse(self, r: int, n_segments: int, i: int, n: int, lam: float, converged: bool) -> None:
        """Replica r's coarse ramp (``Ramp(coarsen=m)``, on a wire of ``n_segments``) has
        finished its stage i of n: it predicts where the wire's stages start, and runs before
        them. What moves comes first (a terminal's line is cut to its width); its last stage
        is always logged."""
        bad = ", NOT converged" if not converged else ""
        self._write(
            f"  coarse ramp ({n_segments} segments) stage {i + 1}/{n}, λ = {lam:.4g}{bad}, "
            f"{duration(time.perf_counter() - self.t0)} elapsed (replica {r}; it predicts "
            "where the wire's stages start)",
            force=i + 1 == n,
        )

    def replica(self, r: int, result) -> None:
        self.replicas_done += 1
        self.stages_done[r] = self.n_stages  # an early stop counts as all its stages
        bad = len(result.failed_stages)
        note = "all stages converged" if not bad else f"{bad} stage(s) NOT converged"
        elapsed = time.perf_counter() - self.t0
        self._write(
            f"  replica {r} done ({self.replicas_done}/{self.n_rep}): {len(result.stages)} "
            f"stages, {note}  [{duration(elapsed)} elapsed]",
            force=True,
        )
        if getattr(result, "coarse", None) is not None:  # Ramp(coarsen=m): its coarse ramp
            self._write(f"    replica {r}'s {result.coarse}", force=True)
        if self.tty and not self.quiet:
            sys.stderr.write("\n")
