"""lutbake: physically correct thin-film iridescence baked into EXR lookup tables (README.md, docs/api.md).

Subpackages by stage, lowest layer first; no import runs back up a layer (import-linter checks it):
``errors`` and ``io`` (the edges: errors in the library's terms, bounded readers, file sets, the cache),
``physics`` (film stacks, materials, the Airy reflectance, colorimetry), ``spectral`` (the spectral rules,
Fourier series, poles and the converged reference), ``grid`` (axes, the bake spec, the texel layout),
``integrate`` (a plan integrated on an OpenCL device or by numpy) beside ``tables`` (the EXR files, their
headers, the shader includes), ``lut`` (bake and sample a LUT), ``modes`` (the exact mode, the
approximations, the runtime table), ``quality`` (reports, refinement, checks), ``scene`` (scene and glTF
bakes) beside ``blender``, and ``cli`` (the command line). Each package's docstring names its stages.

The public API is the names in ``__all__`` (docs/api.md): FilmPoints, Axis, BakeSpec, bake_lut, BakeResult,
default_specs, Lut, Atlas, reference_colour, reference_rgb, report_lut, write_report, run_checks,
load_scene, load_gltf_scene, plan_scene, bake_scene. They load on first use, so ``import lutbake`` (and the
command line's ``--help``) stays fast; importing lutbake changes no process state (signal handlers,
environment). The former flat layout's import paths of the public names still work (lutbake/_moved/).
"""

# typing.TYPE_CHECKING without importing typing, which ``import lutbake`` does not load otherwise
TYPE_CHECKING = False
if TYPE_CHECKING:
    from typing import Any
del TYPE_CHECKING  # not a name of the package

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


def __getattr__(name: str) -> "Any":  # each public name has its own type
    """Public names and ``__version__`` on first use (importlib.metadata alone costs ~0.1 s)."""
    if name == "__version__":
        value = _version()
    elif name in _API:
        from importlib import import_module

        target = _API[name]
        module, attr = target if isinstance(target, tuple) else (target, name)
        value = getattr(import_module(f"{__name__}.{module}"), attr)
    else:
        raise AttributeError(f"module 'lutbake' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("lutbake")
    except PackageNotFoundError:  # running from a source tree
        return "0.0.0+source"
