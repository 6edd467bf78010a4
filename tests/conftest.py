"""Fixtures shared by the reproduction tests."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def smoke(tmp_path_factory):
    """The ``smoke`` profile run and reported once per session: (dir, summary, report).

    Tests that add to the store work on a copy of it (tests/test_reproduce_registry.py)."""
    from crumple.reproduce import run, write_report

    out = tmp_path_factory.mktemp("repro")
    summary = run(out, "smoke", workers=2)
    report = write_report(out)
    return out, summary, report
