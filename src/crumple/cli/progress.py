"""One progress display over a whole job (``crumple sweep``, ``reproduce``, ``figures``).

:func:`progress_line` formats the state of every experiment as one line (a pure function,
tested); :class:`JobProgress` receives :class:`crumple.sweep.Progress` reports from the
sweeps, keeps the latest of each, and writes the line to stderr: rewritten in place on a
terminal (at most twice a second), or one line every ``every`` seconds in a log (CI), so
that a log of a long run stays short and each of its lines says where the job is.
"""

from __future__ import annotations

import math
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
