"""Signal handling for the command line (installed by cli.py only; the library changes no handlers).

Ctrl-C while modules load prints one line and exits 130 without a traceback;
once the CLI runs, SIGINT and SIGTERM unwind as KeyboardInterrupt, so open
file sets are discarded (fileset.py) and the CLI exits 128 + the signal
(130 for SIGINT, 143 for SIGTERM).
"""

import os
import signal
import sys


def interrupted_at_start_up(signum, frame):
    """Ctrl-C while modules load: one line and exit 130, no traceback (the CLI's main() takes over)."""
    sys.stderr.write("lutbake: interrupted\n")
    os._exit(130)


class Interrupted(KeyboardInterrupt):
    """KeyboardInterrupt raised for a signal other than SIGINT; the CLI exits 128 + ``signum``."""

    def __init__(self, signum: int):
        super().__init__(f"signal {signum}")
        self.signum = signum


def raise_interrupt(signum, frame):
    """Unwind like Ctrl-C (the CLI's SIGTERM handler)."""
    raise Interrupted(signum)


def set_handler(signum, handler):
    """Install ``handler`` for ``signum`` unless the signal is ignored or this is not the main
    thread; return the previous handler."""
    previous = signal.getsignal(signum)
    if previous is not signal.SIG_IGN:
        try:
            signal.signal(signum, handler)
        except ValueError:  # not the main thread
            pass
    return previous
