"""lutbake: physically correct thin-film iridescence baked into EXR lookup tables.

Data flow, one module per stage: points/plan (spec, validate) → spectral,
reference (ground truth) / integrate (kernel or numpy) → lutfile (EXR,
sidecar, shader includes) → sample (reference sampler) → report.
"""



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
