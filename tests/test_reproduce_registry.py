"""A study added to the report from outside the package: straight-wire buckling.

This test module *is* a report section (see :mod:`crumple.reproduce.registry`): it declares
its own experiment (a straight wire of 16 segments ramped in the trap, at three k_b), how it
measures (the stage at which the wire first bends), how it draws and what it says (one table
row: the exponent of λ_c against k_b, against Euler's scaling λ_c ∝ B/L⁴, i.e. 1). It
registers itself with :func:`crumple.reproduce.registry.register` and appears in the smoke
report, without a change to any other section.

The physics: the trap compresses the straight wire along its axis (the ends are pulled in
hardest); it stays straight (every joint below 1e-3 rad) until the compression reaches the
Euler load ~ B/L², with B = k_b Δs the continuum bending modulus. With the wire stiff in
stretching, dimensional analysis leaves λ_c = C B / L⁴: λ_c ∝ k_b.
"""

from __future__ import annotations

import json
import math
import shutil
import sys

import numpy as np
import pytest

import crumple.reproduce as reproduce
from crumple.cli import main
from crumple.fit import fit_power_law
from crumple.paper import PaperValue
from crumple.reproduce import check_report, registry, run
from crumple.reproduce.common import Context, Estimate, Record, _row
from crumple.reproduce.experiments import Experiment
from crumple.sweep import Sweep

# ---- the section ----------------------------------------------------------------------------

K_B = (1.0, 4.0, 16.0)
LAMBDAS = tuple(float(v) for v in np.geomspace(1.0, 400.0, 19))
#: A joint turned by more than this [rad] means the wire has buckled.
BENT = 0.1


def _build(profile) -> Sweep:
    """Three k_b, one replica, whatever the profile (the study is tiny)."""
    return Sweep(
        wire={"n_segments": 16, "confinement": "per-length"},
        ramp={"lambdas": list(LAMBDAS)},
        points=[{"k_b": kb, "k_s": 1e5} for kb in K_B],
        replicas=1,
        seed=7,
    )


EULER = Experiment(name="euler", levels=("k_b", "k_s"), build=_build)

NAME = "euler_buckling"
READS = (EULER,)
NEEDS: tuple[str, ...] = ()
VALUE = PaperValue(
    "euler_lambda_c",
    "exponent of the buckling λ_c against k_b (straight wire, N = 16)",
    1.0,
    "Euler's scaling λ_c ∝ B/L⁴ (test experiment, not the paper's)",
)
VALUES = (VALUE,)
FIGURES = {"fig_euler_buckling": "Test study: the buckling λ_c of a straight wire against k_b"}


def measure(ctx: Context) -> Record:
    """λ_c per k_b (geometric midpoint of the bracketing stages) and its power law in k_b."""
    s = ctx.series["euler"]
    kb, brackets = [], []
    for p, key in enumerate(s.keys):
        bent = np.flatnonzero(s.obs["max_angle"][p, 0] > BENT)
        if bent.size and bent[0] > 0:
            kb.append(key[0])
            brackets.append((float(s.lam[bent[0] - 1]), float(s.lam[bent[0]])))
    lam_c = [math.sqrt(a * b) for a, b in brackets]
    fit = fit_power_law(kb, lam_c)
    # the stages bracket λ_c to a factor r: the exponent is known to ln r / ln(k_b range)
    resolution = math.log(LAMBDAS[1] / LAMBDAS[0]) / math.log(max(kb) / min(kb))
    est = Estimate(fit.exponent, math.hypot(fit.stderr, resolution), len(kb), (min(kb), max(kb)))
    row = _row(VALUE.key, est, "1 × 3 k_b", "λ_c between the last straight and the first "
               f"bent stage (a joint beyond {BENT} rad)", reference=VALUE)  # fmt: skip
    return Record(
        rows=(row,),
        extra={"euler_brackets": {f"{k:g}": b for k, b in zip(kb, brackets, strict=True)}},
        detail={"k_b": kb, "lam_c": lam_c, "brackets": brackets},
    )


def draw(rec: Record) -> dict:
    """λ_c against k_b on log axes, the brackets as error bars."""
    from matplotlib.figure import Figure

    d = rec.detail
    fig = Figure(figsize=(4, 3), layout="constrained")
    ax = fig.subplots()
    lo = [c - a for c, (a, _) in zip(d["lam_c"], d["brackets"], strict=True)]
    hi = [b - c for c, (_, b) in zip(d["lam_c"], d["brackets"], strict=True)]
    ax.errorbar(d["k_b"], d["lam_c"], yerr=[lo, hi], fmt="o")
    ax.set(xscale="log", yscale="log", xlabel="k_b", ylabel="λ_c")
    return {"fig_euler_buckling": fig}


def discuss(rec: Record, records) -> dict[str, str]:
    b = rec.extra["euler_brackets"]
    return {VALUE.key: "Brackets per k_b: " + "; ".join(f"{k}: {v}" for k, v in b.items()) + "."}


SECTION = sys.modules[__name__]

# ---- the tests --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def with_euler(smoke, tmp_path_factory):
    """The smoke store, copied, with this section registered: the study's runs are added and
    the report redrawn by ``crumple figures`` (the global registry)."""
    out = tmp_path_factory.mktemp("euler") / "repro"
    shutil.copytree(smoke[0], out)
    registry.register(SECTION)
    try:
        summary = run(out, "smoke", workers=1)
        assert main(["figures", str(out), "--quiet"]) == 0
        yield out, summary
    finally:
        registry.unregister(SECTION)


def test_the_study_runs_only_its_own_experiment(with_euler):
    _, summary = with_euler
    assert summary["experiments"]["euler"]["computed"] == len(K_B)
    assert all(e["computed"] == 0 for k, e in summary["experiments"].items() if k != "euler")


def test_the_study_appears_in_the_report(with_euler, capsys):
    out, _ = with_euler
    assert check_report(out) == []
    res = json.loads((out / "results.json").read_text())
    (row,) = [r for r in res["rows"] if r["key"] == VALUE.key]
    assert row["paper"] == 1.0 and row["verdict"] != "not measured"
    assert 0.6 < row["ours"] < 1.4  # Euler's scaling, to the resolution of the stages
    md = (out / "report.md").read_text()
    assert VALUE.quantity in md and "figures/fig_euler_buckling.png" in md
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == len(FIGURES) + len(reproduce.FIGURES)


def test_the_other_sections_are_untouched(with_euler, smoke):
    out, _ = with_euler
    before = json.loads((smoke[0] / "results.json").read_text())
    after = json.loads((out / "results.json").read_text())
    assert [r for r in after["rows"] if r["key"] != VALUE.key] == before["rows"]
    assert after["claims"] == before["claims"]
    assert after["alternatives"] == before["alternatives"]


def test_registration_is_checked():
    with pytest.raises(ValueError, match="lacks"):
        registry.register(object())
    clash = type("Clash", (), {**{k: getattr(SECTION, k) for k in registry._REQUIRED}})
    clash.NAME = "fig3_mass_size"
    with pytest.raises(ValueError, match="already registered"):
        registry.register(clash)
    clash.NAME, clash.NEEDS = "new", ("nowhere",)
    with pytest.raises(ValueError, match="needs nowhere"):
        registry.register(clash)
    assert clash not in registry.sections()  # a refused section is not half-registered
    assert set(reproduce.FIGURES) == set(registry.figures(registry.SECTIONS))
