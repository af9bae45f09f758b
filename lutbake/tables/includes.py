"""The include renderer: the GLSL, HLSL and OSL sources of every table kind, from lutbake/shaders/*.in.

``shader_includes(meta, table_name)`` renders a table's GLSL and HLSL includes from its header alone,
dispatching on its ``format``: a LUT's sampler (lutbake.*.in), the exact mode's series (exact.*.in), the
runtime table's reads (runtime.*.in). ``osl_source`` renders the OSL script of an exact or runtime table for
Blender's Cycles (its absolute path in the script). ``atlas_includes`` renders a scene atlas's, whose
constants come from the scene's manifest (which also names the 4D LUTs the scene uses beside the atlas).

Every name that reaches a shader goes through lutbake/io/names.py: ``shader_comment`` where it stands in a
// comment, ``shader_identifier`` where it names a constant, ``shader_string`` (which refuses what it cannot
carry) in an OSL string, so a hostile file, scene or material name cannot add a line to the source. Numbers
are written as Python's shortest round-trip repr: the same header gives the same bytes.
"""

from __future__ import annotations

import math
import string
import warnings
from collections.abc import Callable
from importlib import resources
from pathlib import Path

from lutbake.grid.axis import ROOT4_WEIGHT
from lutbake.grid.interpolation import mirrors_low_end
from lutbake.io.names import ADMITTANCE_SPACINGS, shader_comment, shader_identifier, shader_string
from lutbake.spectral.fourier import NU_HALF_BAND_PER_NM
from lutbake.tables.headers import EXACT_FORMAT, FORMAT, RUNTIME_FORMAT

__all__ = [
    "shader_includes",
    "include_fields",
    "osl_source",
    "atlas_includes",
    "shader_template",
    "warn_texture_size",
    "MAX_TEXTURE_SIZE",
]

# Larger than most desktop GPUs' guarantee; WebGL2 guarantees only 2048, many mobile GPUs 4096.
MAX_TEXTURE_SIZE = 8192


def shader_template(name: str) -> string.Template:
    """lutbake/shaders/``name`` (e.g. 'runtime.glsl.in') as a template of ``$field`` placeholders."""
    return string.Template(resources.files("lutbake").joinpath(f"shaders/{name}").read_text())


def shader_includes(meta: dict, table_name: str) -> dict:
    """GLSL and HLSL include texts of the table whose header is ``meta`` (a LUT, an exact or a runtime
    table), written for the file ``table_name``, keyed by file suffix."""
    fields = include_fields(meta, table_name)
    stem = _TEMPLATES[meta["format"]][0]
    return {suffix: shader_template(f"{stem}.{suffix}.in").substitute(fields) for suffix in ("glsl", "hlsl")}


def osl_source(meta: dict, table_path: str | Path) -> str:
    """The OSL script of an exact or runtime table (header ``meta``) that Cycles reads at ``table_path`` (as
    Blender writes it: ``//`` for the .blend's folder); ValueError when the path cannot stand in an OSL string."""
    stem = _TEMPLATES[meta["format"]][0]
    path = str(table_path)
    fields = {**include_fields(meta, path.rsplit("/", 1)[-1]), "table_path": shader_string(path)}
    return shader_template(f"{stem}.osl.in").substitute(fields)


def include_fields(meta: dict, table_name: str) -> dict:
    """The template fields of a table's shader sources: the file's name (escaped for a comment), what its
    header says of its origin and colours, and its kind's constants."""
    return {
        "table_name": shader_comment(table_name),
        "content_hash": meta["content_hash"],
        "space": meta["space"],
        "observer": meta["observer"],
        **_TEMPLATES[meta["format"]][1](meta, table_name),
    }


def warn_texture_size(width: int, height: int, name: str) -> None:
    """Warn when an image exceeds what many GPUs load (docs/engines.md: texture size)."""
    if max(width, height) > MAX_TEXTURE_SIZE:
        warnings.warn(
            f"{name}: {width}×{height} texels exceeds {MAX_TEXTURE_SIZE} in a dimension; many "
            f"GPUs cannot load it (WebGL2 guarantees 2048, mobile GPUs 4096)",
            stacklevel=2,
        )


def _lut_fields(meta: dict, table_name: str) -> dict:
    """A LUT's axes as the sampler's per-axis vectors (cos θ1, D, η3, κ3), its film and its packing."""
    axes = meta["axes"]
    warn_texture_size(meta["packing"]["width"], meta["packing"]["height"], table_name)
    zoomed = any("corner" in a for a in axes)
    root4 = {"root4": "1.0", "uniform-root4": _shader_float(ROOT4_WEIGHT)}
    return {
        "ident": shader_identifier(Path(table_name).stem),
        "eta1": repr(meta["constants"]["eta1"]),
        "eta2": repr(meta["constants"]["eta2"]),
        "eta1_f": _shader_float(meta["constants"]["eta1"]),
        "eta2_f": _shader_float(meta["constants"]["eta2"]),
        "min": _per_axis(axes, lambda a: _shader_float(a["min"])),
        "max": _per_axis(axes, lambda a: _shader_float(a["max"])),
        "count": _per_axis(axes, lambda a: _shader_float(a["count"])),
        "sqrt": _per_axis(axes, lambda a: "1.0" if a["spacing"] in ("sqrt", "sqrt-admittance") else "0.0"),
        "root4": _per_axis(axes, lambda a: root4.get(a["spacing"], "0.0")),
        "mirror": _per_axis(axes, lambda a: "1.0" if mirrors_low_end(a["spacing"], a["min"], zoomed) else "0.0"),
        "admittance": "1.0" if axes[2]["spacing"] in ADMITTANCE_SPACINGS else "0.0",
        "corner_share": _per_axis(
            axes, lambda a: _shader_float(a["corner"]["nodes"] / (a["count"] - 1)) if "corner" in a else "0.0"
        ),
        "corner_scale": _per_axis(axes, lambda a: _shader_float(a["corner"]["scale"]) if "corner" in a else "1.0"),
        "tiles_x_kappa3": "1.0" if meta["packing"]["tiles_x"] == "kappa3" else "0.0",
        "interpolation": meta.get("interpolation", "linear"),
        "cubic": "1.0" if meta.get("interpolation") == "cubic" else "0.0",
    }


def _exact_fields(meta: dict, table_name: str) -> dict:
    """The exact table's layout, its tail bound's constants and the include's defaults (exact.*.in)."""
    table, tail = meta["table"], meta["tail"]
    return {
        "step": repr(table["step_nm"]),
        "width": table["width"],
        "rows": table["rows_per_part"],
        "texels": table["texels"],
        "x_max": repr(table["x_max_nm"]),
        "nu0": repr(table["nu0_per_nm"]),
        "mass": repr(tail["mass"]),
        "edge": repr(tail["edge"]),
        "variation": repr(tail["variation"]),
        "tolerance": repr(meta["include"]["tolerance"]),
        "band": repr(2.0 * math.pi * NU_HALF_BAND_PER_NM),
        "max_terms": meta["include"]["max_terms"],
    }


def _runtime_fields(meta: dict, table_name: str) -> dict:
    """The runtime table's slices, tiles and white (runtime.*.in)."""
    t = meta["table"]
    return {
        "nu0": repr(t["nu0_per_nm"]),
        "x_max": repr(t["x_max_nm"]),
        "zoom": repr(t["zoom_nm"]),
        "last_slice": repr(float(t["slices"] - 1)),
        "half_span": repr(0.5 * (t["nodes"] - 1)),
        "nodes": repr(float(t["nodes"])),
        "tiles": repr(float(t["tiles_per_row"])),
        "band": repr(float(t["band_rows"] * t["nodes"])),
        "width": repr(float(t["width"])),
        "height": repr(float(t["height"])),
        "white": ", ".join(repr(v) for v in t["white"]),
    }


# format → (the stem of its templates in lutbake/shaders/, the fields of its constants)
_TEMPLATES = {
    FORMAT: ("lutbake", _lut_fields),
    EXACT_FORMAT: ("exact", _exact_fields),
    RUNTIME_FORMAT: ("runtime", _runtime_fields),
}


def _per_axis(axes: list, value: Callable[[dict], str]) -> str:
    return ", ".join(value(a) for a in axes)


def _shader_float(value: float) -> str:
    text = repr(float(value))
    return text if ("e" in text or "." in text) else text + ".0"


# --- a scene atlas: one LutbakeSlice constant per slice material, a comment per 4D LUT -----------------

_ATLAS_LINES = {
    "glsl": (
        "const LutbakeSlice {ident} = LutbakeSlice(vec4({rect}), vec2({thick}), vec2({size}));",
        "// {name}: 4D LUT {file} (sample it with {stem}.glsl)",
    ),
    "hlsl": (
        "static const LutbakeSlice {ident} = {{float4({rect}), float2({thick}), float2({size})}};",
        "// {name}: 4D LUT {file} (sample it with {stem}.hlsl)",
    ),
}


def atlas_includes(manifest: dict, atlas: dict) -> dict:
    """GLSL and HLSL include texts for a scene (its manifest and ``atlas.pack_atlas`` layout), keyed by suffix."""
    return {lang: _atlas_include(manifest, atlas, lang) for lang in _ATLAS_LINES}


def _atlas_include(manifest: dict, atlas: dict, lang: str) -> str:
    """The scene's atlas sampler and one LutbakeSlice constant per slice material (a comment per 4D LUT)."""
    slice_line, lut_line = _ATLAS_LINES[lang]
    scene = Path(manifest["scene"]).stem
    size = ", ".join(str(float(v)) for v in (atlas["width"], atlas["height"]))
    lines = []
    for name, e in manifest["materials"].items():
        if e["kind"] == "slice":
            th = e["axes"]["thickness_nm"]
            lines.append(
                slice_line.format(
                    ident=shader_identifier(f"{scene}_{name}"),
                    size=size,
                    rect=", ".join(str(float(v)) for v in e["rect"]),
                    thick=f"{float(th['min'])}, {float(th['max'])}",
                )
            )
        else:
            lines.append(
                lut_line.format(
                    name=shader_comment(name), file=shader_comment(e["file"]), stem=shader_comment(Path(e["file"]).stem)
                )
            )
    return shader_template(f"atlas.{lang}.in").substitute(
        scene=shader_comment(manifest["scene"]),
        scene_hash=manifest["scene_hash"][:16],
        atlas=shader_comment(f"{scene}.exr"),
        materials="\n".join(lines),
    )
