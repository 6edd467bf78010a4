"""The default N = 100 ramp against the engine of an earlier commit, alternated in one process.

    python benchmarks/bench_against.py REV [PAIRS]       # e.g. 451a945 16

The package at git revision REV is exported (``git archive``) into a temporary folder as a
package of another name (its absolute imports of ``crumple`` renamed), so that both engines run
in this process, alternating ramp by ramp (the first of each pair alternates too): a machine
whose speed drifts by tens of per cent between runs minutes apart (this one) then drifts for
both alike. Prints the median CPU time of each, their ratio, the median and range of the ratios
pair by pair, and whether the two ends at the same positions (an engine change that claims the
same iterates must print True). CPU time is ``time.process_time``, one BLAS thread.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from threadpoolctl import threadpool_limits

import crumple.model
import crumple.protocol

ROOT = Path(__file__).resolve().parent.parent


def export(rev: str, into: Path) -> str:
    """The package ``crumple`` at ``rev`` as the package ``crumple_<rev>`` under ``into``;
    returns its name."""
    name = "crumple_" + re.sub(r"\W", "_", rev)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "src/crumple"],
                             check=True, capture_output=True).stdout  # fmt: skip
    with tempfile.TemporaryFile() as f:
        f.write(archive)
        f.seek(0)
        with tarfile.open(fileobj=f) as tar:
            tar.extractall(into, filter="data")
    (into / "src" / "crumple").rename(into / name)
    for path in (into / name).rglob("*.py"):
        text = path.read_text()
        new = re.sub(r"\b(from|import) crumple(\.|\s)", rf"\1 {name}\2", text)
        if new != text:
            path.write_text(new)
    return name


def main(rev: str, pairs: int = 16) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        name = export(rev, Path(tmp))
        sys.path.insert(0, tmp)
        old_protocol = __import__(f"{name}.protocol", fromlist=["run_ramp"])
        old_model = __import__(f"{name}.model", fromlist=["Wire"])
        legs = {
            rev: (old_protocol.run_ramp, old_model.Wire(k_b=5, k_s=5e5)),
            "this tree": (crumple.protocol.run_ramp, crumple.model.Wire(k_b=5, k_s=5e5)),
        }
        for run, wire in legs.values():  # compile (each package caches its own kernels)
            run(wire, seed=0)
        times = {k: [] for k in legs}
        ends = {}
        with threadpool_limits(limits=1, user_api="blas"):
            for i in range(pairs):
                for key in list(legs)[:: 1 if i % 2 == 0 else -1]:
                    run, wire = legs[key]
                    t0 = time.process_time()
                    ramp = run(wire, seed=0)
                    times[key].append(time.process_time() - t0)
                    ends[key] = ramp.stages[-1].positions
    old, new = np.array(times[rev]), np.array(times["this tree"])
    ratio = old / new
    print(f"== default ramp, N = 100, seed 0: {rev} against this tree, {pairs} pairs ==")
    print(f"  {rev}: {np.median(old):.4f} s CPU (median); this tree: {np.median(new):.4f} s")
    print(f"  speed-up {np.median(old) / np.median(new):.3f}x; pair by pair median "
          f"{np.median(ratio):.3f}x, range {ratio.min():.3f}-{ratio.max():.3f}")  # fmt: skip
    print(f"  the same end positions: {np.array_equal(ends[rev], ends['this tree'])}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 16)
