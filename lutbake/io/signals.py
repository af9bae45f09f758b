"""Signal handling for the command line (installed by cli.py only; the library changes no handlers).

SIGINT (Ctrl-C) and SIGTERM stop a command with exit status 128 + the signal's number (130, 143) and
one line on stderr, never a traceback. While modules load, the process leaves at once (nothing is
written yet). Once the CLI runs, the first signal unwinds the stack as ``Interrupted`` (a
KeyboardInterrupt), so open file sets discard their temporaries (lutbake/io/fileset.py); signals that follow are
ignored, so that clean-up runs to its end. A commit that has written its journal finishes before a
signal is handled (lutbake/io/fileset.py blocks them for the renames).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from typing import TYPE_CHECKING, NoReturn

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator
    from types import FrameType

    # what signal.signal takes and signal.getsignal returns
    _Handler = Callable[[int, FrameType | None], object] | int | signal.Handlers | None

__all__ = [
    "Interrupted",
    "STOP_SIGNALS",
    "exit_status",
    "interrupted_at_start_up",
    "raise_interrupted",
    "set_handler",
    "stop_signals_held",
]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_WORDS: dict[int, str] = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated"}


class Interrupted(KeyboardInterrupt):
    """The command was stopped by ``signum`` (SIGINT or SIGTERM)."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(f"signal {signum}")
        self.signum = signum


def exit_status(exc: BaseException) -> int:
    """128 + the signal that stopped the command (130 for Ctrl-C, 143 for SIGTERM)."""
    return 128 + getattr(exc, "signum", signal.SIGINT)


def message(signum: int) -> str:
    """The one line printed when ``signum`` stops the command."""
    return f"lutbake: {_WORDS.get(signum, 'interrupted')}"


def interrupted_at_start_up(signum: int, frame: FrameType | None) -> NoReturn:
    """A stop signal while modules load: one line and exit 128 + signum, no traceback (main() takes over)."""
    with contextlib.suppress(AttributeError, OSError):  # stderr closed: the exit status still says it
        sys.stderr.write(message(signum) + "\n")
    os._exit(128 + signum)


def raise_interrupted(signum: int, frame: FrameType | None) -> NoReturn:
    """Unwind like Ctrl-C, once: later stop signals are ignored so discarding temporaries is not cut short."""
    for other in STOP_SIGNALS:
        set_handler(other, signal.SIG_IGN)
    raise Interrupted(signum)


def set_handler(signum: int, handler: _Handler) -> _Handler:
    """Install ``handler`` for ``signum`` unless the signal is ignored or this is not the main
    thread; return the previous handler."""
    previous = signal.getsignal(signum)
    if previous is not signal.SIG_IGN:
        with contextlib.suppress(ValueError):  # not the main thread
            signal.signal(signum, handler)
    return previous


@contextlib.contextmanager
def stop_signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM wait (pending) until the block ends, then arrive: for work that a stop must not cut
    short (a journaled commit, lutbake/io/fileset.py) or that cannot unwind (a C++ extension's initialisation)."""
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
