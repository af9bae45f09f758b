"""Old path of report_lut, write_report: now ``lutbake.quality.report``."""

import warnings

from lutbake.quality.report import report_lut, write_report

__all__ = ["report_lut", "write_report"]

warnings.warn(
    "lutbake.report is lutbake.quality.report (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
