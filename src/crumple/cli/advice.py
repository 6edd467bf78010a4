"""What ``crumple run`` tells the user about a run before it starts: warnings (on stderr) of a
run that will not give what its user likely wants, or that will take far longer than it need.
Each is a function of the wire and the ramp that returns its message or None."""

from __future__ import annotations

import sys

__all__ = ["SLOW_PLAIN_RAMP", "advice", "identical_replicas", "slow_plain_ramp", "warn"]


def warn(msg: str) -> None:
    """Print ``msg`` as the CLI's warning, on stderr."""
    print(f"crumple: warning: {msg}", file=sys.stderr)


def advice(wire, ramp, n_rep: int) -> list[str]:
    """Every warning for a run of ``n_rep`` replicas of ``ramp`` on ``wire``, in order."""
    found = (identical_replicas(wire, ramp, n_rep), slow_plain_ramp(wire, ramp))
    return [msg for msg in found if msg is not None]


def identical_replicas(wire, ramp, n_rep: int) -> str | None:
    """The warning for replicas of a perfect wire, which follow nearly the same path."""
    if n_rep > 1 and wire.rest_angle_sd == 0 and ramp.stage_noise == 0:
        return (
            f"{n_rep} replicas of a perfect wire (rest_angle_sd = 0, stage_noise = 0) follow "
            "nearly the same path, whatever their initial noise (docs/model.md); for an "
            "ensemble give the wire imperfections, e.g. --rest-angle-sd 0.01"
        )
    return None


#: From this many segments a plain Newton ramp that a coarser wire could predict is warned
#: about. The default schedule with curved steps took 6 min of CPU at N = 2 × 10⁴, more than
#: half an hour at 5 × 10⁴, and more than 3.8 h at 10⁵ (older engines); predicted by the wire
#: with N/10 segments, 4.6 min at 5 × 10⁴ and 16–22 min at 10⁵ (docs/performance.md, the
#: scaling table).
SLOW_PLAIN_RAMP = 50_000


def slow_plain_ramp(wire, ramp) -> str | None:
    """The warning for a plain ramp of :data:`SLOW_PLAIN_RAMP` segments or more that a
    coarser wire could predict (None: no warning). It names the largest factor of 10, 5, 4, 2
    that divides N and passes :func:`crumple.protocol_coarse.check_coarsen`."""
    from ..protocol_coarse import check_coarsen

    if ramp.coarsen > 1 or ramp.method != "newton" or wire.n_segments < SLOW_PLAIN_RAMP:
        return None
    if ramp.stage_noise > 0:  # coarsen needs stage_noise = 0
        return None
    for m in (10, 5, 4, 2):
        try:
            check_coarsen(wire, m)
        except ValueError:
            continue
        return (
            f"a plain ramp of {wire.n_segments} segments is slow on one core (the default "
            "schedule, λ up to 2000: more than half an hour at N = 5 × 10⁴, more than 3.8 h "
            f"at N = 10⁵); `coarsen = {m}` in [ramp] (or --coarsen {m}) starts each stage "
            "from the last equilibrium moved as the same wire with "
            f"{wire.n_segments // m} segments moved (with coarsen = 10: 4.6 min at N = 5 × 10⁴, "
            "16–22 min at N = 10⁵; "
            "a stage that snaps through then takes the coarse wire's branch: docs/model.md, "
            '"The ramp predicted by a coarser wire"; examples/huge.toml)'
        )
    return None
