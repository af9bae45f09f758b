"""Live progress on stderr: what a long command is doing, how far it is, when it will end.

Library functions report through a plain callback ``progress(done, total, note)``
(``total`` None when unknown; its type is ``Progress``); the CLI turns it into a ``Meter``. On a
terminal the meter redraws one line (at most 10 times a second); forced on
a pipe (``--progress``) it prints one line per update, at most one a second.
The ETA is the remaining work at the rate measured since the first unit was
done (set-up before it, e.g. a bake's error probes, does not skew it), never a guess.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

__all__ = ["Meter", "AnyMeter", "Progress", "meter", "format_seconds", "no_progress"]

# progress(done, total or None when unknown, note): what every long library function reports through
Progress = Callable[[int, int | None, str], None]

_TTY_INTERVAL_S, _PIPE_INTERVAL_S, _BAR_WIDTH = 0.1, 1.0, 24


def format_seconds(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    return (
        f"{seconds // 60} min {seconds % 60:02d} s"
        if seconds < 3600
        else f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"
    )


class Meter:
    """One labelled progress line; call it as ``meter(done, total, note)``."""

    def __init__(self, label: str, stream: TextIO | None = None) -> None:
        self.label, self.stream = label, stream or sys.stderr
        self.tty = self.stream.isatty()
        self.start = time.perf_counter()
        self._last_draw, self._width = -1e9, 0
        self._note: str | None = None
        # (time, done) of the first update with work done: the rate's origin
        self._first: tuple[float, int] | None = None
        self(0, None, "starting")

    def __call__(self, done: int, total: int | None = None, note: str = "") -> None:
        now = time.perf_counter()
        if done and self._first is None:
            self._first = (now, done)
        finished = total is not None and done >= total
        quiet_spell = now - self._last_draw < (_TTY_INTERVAL_S if self.tty else _PIPE_INTERVAL_S)
        if quiet_spell and not finished and note == self._note:
            return
        self._last_draw, self._note = now, note
        self._write(self._line(done, total, note, now - self.start, self._eta(done, total, now)))

    def _eta(self, done: int, total: int | None, now: float) -> float | None:
        if not total or self._first is None or done <= self._first[1] or done >= total:
            return None
        t0, d0 = self._first
        return (now - t0) / (done - d0) * (total - done)

    def _line(self, done: int, total: int | None, note: str, elapsed: float, eta: float | None = None) -> str:
        parts = [f"{self.label}:"]
        if total:
            filled = int(_BAR_WIDTH * min(done / total, 1.0))
            parts.append(f"[{'#' * filled}{'.' * (_BAR_WIDTH - filled)}] {done}/{total}")
        parts.append(f"{format_seconds(elapsed)} elapsed")
        if eta is not None:
            parts.append(f"ETA {format_seconds(eta)}")
        if note:
            parts.append(f"— {note}")
        return " ".join(parts)

    def _write(self, line: str) -> None:
        if self.tty:
            pad = max(0, self._width - len(line))
            self.stream.write("\r" + line + " " * pad)
            self._width = len(line)
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def clear(self) -> None:
        """Erase the live line so a result printed on the terminal does not land inside it."""
        if self.tty and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self.stream.flush()
            self._width, self._last_draw = 0, -1e9

    def close(self, note: str = "done") -> None:
        self._last_draw = -1e9
        self._write(self._line(0, None, note, time.perf_counter() - self.start))
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()


def no_progress(done: int, total: int | None = None, note: str = "") -> None:
    """The default callback of library functions: report nothing."""


class _Silent:
    __call__ = staticmethod(no_progress)

    def clear(self) -> None:
        pass

    def close(self, note: str = "done") -> None:
        pass


# what ``meter`` returns: the meter, or its silent stand-in with the same three calls
AnyMeter = Meter | _Silent


def meter(label: str, show: bool | None) -> AnyMeter:
    """A Meter when ``show`` (None: only when stderr is a terminal), else a silent stand-in."""
    if show is None:
        show = sys.stderr.isatty()
    return Meter(label) if show else _Silent()
