"""The cores this process may run on: the default size of every pool of worker threads lutbake starts
(OpenEXR's compression pool, the ground truth's integration)."""

from __future__ import annotations

import os

__all__ = ["usable_cores"]


def usable_cores() -> int:
    """Cores in this process's affinity mask (a container's or ``taskset``'s limit), else all of them."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # no affinity outside Linux
        return os.cpu_count() or 1
