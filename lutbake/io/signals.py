"""Signal handling for the command line (installed by cli.py only; the library changes no handlers).

SIGINT (Ctrl-C), SIGTERM and SIGHUP (a closed terminal) stop a command with exit status 128 + the signal's
number (130, 143, 129) and one line on stderr, never a traceback. While modules load, the process leaves at
once (nothing is written yet). Once the CLI runs, the first signal unwinds the stack as ``Interrupted`` (a
KeyboardInterrupt), so open file sets discard their temporaries (lutbake/io/fileset.py); signals that follow are
ignored, so that clean-up runs to its end. A commit that has written its journal finishes before a
signal is handled (lutbake/io/fileset.py blocks them for the renames). Every C extension imported once the
CLI has started initialises with the stop signals held (``hold_stop_signals_in_extension_imports``): a
handler's exception raised inside an extension's initialisation cannot unwind cleanly (pyopencl's C++
aborts the process, OpenEXR turns it into an ImportError), so the signal is handled once the import is done.
"""

from __future__ import annotations

import contextlib
import importlib.machinery
import os
import signal
import sys
import threading
from types import ModuleType
from typing import TYPE_CHECKING, NoReturn

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator, Sequence
    from importlib.machinery import ModuleSpec
    from types import FrameType

    # what signal.signal takes and signal.getsignal returns
    _Handler = Callable[[int, FrameType | None], object] | int | signal.Handlers | None

__all__ = [
    "Interrupted",
    "STOP_SIGNALS",
    "exit_status",
    "hold_stop_signals_in_extension_imports",
    "interrupted_at_start_up",
    "raise_interrupted",
    "set_handler",
    "stop_signals_held",
]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_WORDS: dict[int, str] = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated", signal.SIGHUP: "hung up"}


class Interrupted(KeyboardInterrupt):
    """The command was stopped by ``signum`` (SIGINT, SIGTERM or SIGHUP)."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        super().__init__(f"signal {signum}")
        self.signum = signum


def exit_status(exc: BaseException) -> int:
    """128 + the signal that stopped the command (130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP)."""
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
    """The stop signals wait until the block ends, then arrive: for work that a stop must not cut short (a
    journaled commit, lutbake/io/fileset.py) or that cannot unwind (a C++ extension's initialisation).

    Blocking them in this thread's mask is not enough: the kernel hands a process-directed signal to any
    thread that does not block it, such as OpenEXR's compression pool or an OpenCL runtime's workers, and
    Python then runs the handler in the main thread regardless. So in the main thread a handler that only
    records the signal stands in for the block's length, and what it recorded is raised again at the end."""
    pending: list[int] = []
    deferred = _deferring_handlers(pending)
    previous_mask = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        for signum, handler in deferred.items():
            signal.signal(signum, handler)
        signal.pthread_sigmask(signal.SIG_SETMASK, previous_mask)
        for signum in dict.fromkeys(pending):  # each signal once, in the order it came
            signal.raise_signal(signum)


def _deferring_handlers(pending: list[int]) -> dict[int, _Handler]:
    """Install, for every stop signal not ignored, a handler appending it to ``pending``; return the handlers
    it replaced (none outside the main thread, where handlers cannot be set)."""
    replaced: dict[int, _Handler] = {}
    if threading.current_thread() is not threading.main_thread():
        return replaced
    for signum in STOP_SIGNALS:
        previous = signal.getsignal(signum)
        if previous is not signal.SIG_IGN and previous is not None:  # None: a handler not set from Python
            signal.signal(signum, lambda received, frame: pending.append(received))
            replaced[signum] = previous
    return replaced


class _HeldExtensionLoader(importlib.machinery.ExtensionFileLoader):
    """A C extension's loader whose initialisation runs with the stop signals held."""

    def create_module(self, spec: ModuleSpec) -> ModuleType:
        with stop_signals_held():
            return super().create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        with stop_signals_held():
            super().exec_module(module)


class _HeldExtensionFinder:
    """The file-system finder's own answer, with a C extension's loader replaced by ``_HeldExtensionLoader``."""

    @staticmethod
    def find_spec(name: str, path: Sequence[str] | None = None, target: ModuleType | None = None) -> ModuleSpec | None:
        spec = importlib.machinery.PathFinder.find_spec(name, path, target)
        if spec is not None and type(spec.loader) is importlib.machinery.ExtensionFileLoader:
            spec.loader = _HeldExtensionLoader(spec.loader.name, spec.loader.path)
        return spec


def hold_stop_signals_in_extension_imports() -> None:
    """From now on, every C extension found on the file system initialises with the stop signals held (the
    finder goes just before Python's own, whose answer it returns; for the command line only)."""
    if any(isinstance(f, _HeldExtensionFinder) for f in sys.meta_path):
        return
    at = next((i for i, f in enumerate(sys.meta_path) if f is importlib.machinery.PathFinder), len(sys.meta_path))
    sys.meta_path.insert(at, _HeldExtensionFinder())
