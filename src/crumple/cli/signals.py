"""What a signal does to a run: SIGTERM as an exception, and the signal behind an exception."""

from __future__ import annotations

__all__ = ["Terminated", "signal_cause"]


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that workers are stopped on the way out."""


def signal_cause(exc: BaseException) -> BaseException | None:
    """The KeyboardInterrupt or :class:`Terminated` behind ``exc``, if a signal caused it.

    A signal that lands while Numba runs a Python callback of a compiled function (it unpickles
    constants there) comes out as a ``SystemError`` whose cause is the KeyboardInterrupt; it is
    still the user's Ctrl-C, and must end the run the same way (seen in a fresh-clone CI run:
    the replicas were lost and the exit status was 1)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, (KeyboardInterrupt, Terminated)):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def _on_sigterm(signum, frame):
    """The SIGTERM handler of ``crumple run``: raise :class:`Terminated` in the main thread."""
    raise Terminated
