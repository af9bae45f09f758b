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


def __getattr__(name):
    """``__version__`` on first use: importlib.metadata costs ~0.1 s that `--help` need not pay."""
    if name != "__version__":
        raise AttributeError(f"module 'lutbake' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("lutbake")
    except PackageNotFoundError:  # running from a source tree
        value = "0.0.0+source"
    globals()["__version__"] = value
    return value
