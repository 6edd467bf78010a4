"""Fixtures shared by the reproduction tests, and the session's SIGINT."""

from __future__ import annotations

import signal

import pytest

# A session started in the background by a non-interactive shell (``pytest &`` in a script)
# inherits SIGINT ignored, and Python then installs no KeyboardInterrupt handler: the tests of
# crumple's Ctrl-C handling (tests/test_cli_signals.py, tests/test_cli.py) would send a signal
# that nothing sees. The session restores Python's own handler; the processes the tests start
# then begin with SIGINT's default action, as from a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def smoke(tmp_path_factory):
    """The ``smoke`` profile run and reported once per session: (dir, summary, report).

    Tests that add to the store work on a copy of it (tests/test_reproduce_registry.py)."""
    from crumple.reproduce import run, write_report

    out = tmp_path_factory.mktemp("repro")
    summary = run(out, "smoke", workers=2)
    report = write_report(out)
    return out, summary, report
