"""lutbake: physically correct thin-film iridescence baked into EXR lookup tables.

Data flow, one module per stage: points/plan (spec, validate) → spectral,
reference (ground truth) / integrate (kernel or numpy) → lutfile (EXR,
sidecar, shader includes) → sample (reference sampler) → report.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("lutbake")
except PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0+source"
