"""lutbake: physically correct thin-film iridescence baked into EXR lookup tables.

Data flow, one module per stage: points/plan (spec, validate) → spectral,
reference (ground truth) / integrate (kernel or numpy) → lutfile (EXR,
sidecar, shader includes) → sample (reference sampler) → report. Scenes:
a source (scene_toml, gltf_scene) → scene (the model) → scene_plan (jobs)
→ scene_jobs (slices, refine) → atlas (packing) → scene_bake (the file set).

The public API is the names in ``__all__`` (docs/api.md). They load on first
use, so ``import lutbake`` (and the command line's ``--help``) stays fast;
importing lutbake changes no process state (signal handlers, environment).
"""

# public name -> the module (lutbake.<module>) that defines it, and its name there when it differs
# (the function bake.bake is public as bake_lut: a package attribute named like a submodule is
# replaced by the submodule when that is imported)
_API = {
    "Axis": "grid.axis",
    "BakeSpec": "grid.spec",
    "FilmPoints": "physics.points",
    "reference_colour": "spectral.reference",
    "reference_rgb": "spectral.reference",
    "bake_lut": ("lut.bake", "bake"),
    "BakeResult": "lut.bake",
    "default_specs": "lut.bake",
    "Lut": "lut.sample",
    "Atlas": "lut.sample",
    "report_lut": "quality.report",
    "write_report": "quality.report",
    "load_scene": "scene.toml",
    "load_gltf_scene": "scene.gltf.materials",
    "plan_scene": "scene.plan",
    "bake_scene": "scene.bake",
    "run_checks": "quality.check",
}

# the former flat layout's module paths of the public names (lutbake/_moved/)
__path__.append(__path__[0] + "/_moved")

__all__ = sorted(_API) + ["__version__"]


def __getattr__(name):
    """Public names and ``__version__`` on first use (importlib.metadata alone costs ~0.1 s)."""
    if name == "__version__":
        value = _version()
    elif name in _API:
        from importlib import import_module

        module, attr = _API[name] if isinstance(_API[name], tuple) else (_API[name], name)
        value = getattr(import_module(f"{__name__}.{module}"), attr)
    else:
        raise AttributeError(f"module 'lutbake' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("lutbake")
    except PackageNotFoundError:  # running from a source tree
        return "0.0.0+source"
