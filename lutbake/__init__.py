"""lutbake: physically correct thin-film iridescence baked into EXR lookup tables.

Data flow, one module per stage: points/plan (spec, validate) → spectral,
reference (ground truth) / integrate (kernel or numpy) → lutfile (EXR,
sidecar, shader includes) → sample (reference sampler) → report.
"""

import os
import signal
import sys


def interrupted_at_start_up(signum, frame):
    """Ctrl-C while modules load: one line and exit 130, no traceback (the CLI's main() takes over)."""
    sys.stderr.write("lutbake: interrupted\n")
    os._exit(130)


def set_sigint_handler(handler):
    """Install ``handler`` for SIGINT unless SIGINT is ignored or this is not the main thread; return the old one."""
    previous = signal.getsignal(signal.SIGINT)
    if previous is not signal.SIG_IGN:
        try:
            signal.signal(signal.SIGINT, handler)
        except ValueError:  # imported from another thread
            pass
    return previous


_previous = set_sigint_handler(interrupted_at_start_up)

from importlib.metadata import PackageNotFoundError, version  # noqa: E402

try:
    __version__ = version("lutbake")
except PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0+source"

set_sigint_handler(_previous)  # library users keep their own Ctrl-C behaviour
