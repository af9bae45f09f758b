"""Old path of run_checks: now ``lutbake.quality.check``."""

import warnings

from lutbake.quality.check import run_checks

__all__ = ["run_checks"]

warnings.warn(
    "lutbake.check is lutbake.quality.check (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
