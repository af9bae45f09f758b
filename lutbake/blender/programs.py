"""What a lutbake scene manifest asks Blender to read, and the maths of each read as a node program.

Imports nothing of lutbake and nothing of Blender: Blender runs lutbake/blender/nodes.py as a script, which
loads this file beside it, and lutbake imports it as ``lutbake.blender.programs`` (lutbake/blender/library.py
checks a manifest with it before Blender starts; the tests evaluate the programs).

``read_manifest`` reads a scene manifest (SCENE.json, `lutbake bake --scene`) into one read per material:
a 2D slice of the atlas (``SliceRead``) or a 4D LUT (``LutRead``). Every read is one *node program*
(``slice_program``, ``lut_program``, ``bilinear_program``) written against a small graph interface
(``math``, ``clamp01``, ``mix``, ``texel``, ``bilinear``), so one text of the maths both becomes Blender nodes
(``NodeGraph``, lutbake/blender/nodes.py) and is evaluated by numpy (``NumpyGraph``, ``evaluate``), which
tests hold to ``lutbake sample`` without Blender.

Reads, as the sampler (lutbake/lut/sample.py) and docs/lut-format.md define them:

- a 2D slice (a fixed base): one bilinear fetch at x = √cos θ·(w − 1), y = (d − d_min)/(d_max − d_min)·(h − 1)
  inside the slice's rect;
- a 4D LUT (a base given as ranges): the *linear* rule, bilinear in (cos θ, D) inside the four tiles
  around (η3, κ3) and lerps across them. Nodes cannot express the 256-read cubic rule the header
  names; ``lutbake sample --interpolation linear`` is what these groups return.

A bilinear fetch is four Closest reads at texel centres blended by lerps, not one Linear read: EEVEE
samples Linear image nodes with mipmaps and anisotropic filtering and GPUs quantize bilinear weights
(often to 8 bits), while texel centres read exactly everywhere. Blender's image rows run bottom-up: the
EXR's last scanline is v = 0, so scanline y is read at v = 1 − (y + ½)/H.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "MANIFEST_FORMAT",
    "BLENDER_SPACES",
    "GROUP_PREFIX",
    "SliceRead",
    "LutRead",
    "SceneReads",
    "read_manifest",
    "scene_reads",
    "NumpyGraph",
    "slice_program",
    "lut_program",
    "bilinear_program",
    "read_program",
    "evaluate",
]

MANIFEST_FORMAT = ("lutbake-scene-manifest", 1)
# lutbake's working spaces (lutbake/io/names.py) as Blender's colour-management names.
BLENDER_SPACES = {
    "rec709": "Linear Rec.709",
    "acescg": "ACEScg",
    "rec2020": "Linear Rec.2020",
    "p3": "Linear DCI-P3 D65",
}
GROUP_PREFIX = "lutbake"
# A value in a node program: a node socket (nodes.NodeGraph), an array (NumpyGraph) or a float constant;
# which depends on the graph, so the programs pass it on without looking inside.
Value = Any


class Graph(Protocol):
    """The interface node programs are written against (nodes.NodeGraph, NumpyGraph)."""

    def math(self, op: str, a: Value, b: Value = None) -> Value: ...
    def clamp01(self, a: Value) -> Value: ...
    def mix(self, a: Value, b: Value, t: Value) -> Value: ...
    def texel(self, image: str, u: Value, v: Value) -> Value: ...
    def bilinear(self, image: str, size: tuple[int, int], x: Value, y: Value) -> Value: ...


# --- what the manifest asks for -------------------------------------------------------------------


@dataclass(frozen=True)
class SliceRead:
    """A material served by a 2D slice of an atlas: rect (x0, y0, width, height) in texels, y in
    scanlines from the top; thickness range in nm (equal ends: one row)."""

    material: str
    image: str  # file name, beside the manifest
    rect: tuple[int, int, int, int]
    thickness_nm: tuple[float, float]

    @property
    def inputs(self) -> tuple[str, ...]:
        return ("Cos Theta", "Thickness (nm)")


@dataclass(frozen=True)
class LutRead:
    """A material served by a 4D LUT (docs/lut-format.md): axes (cos θ, D, η3, κ3) as the LUT's sidecar
    JSON lists them, ambient η1 and film η2."""

    material: str
    image: str
    axes: tuple[dict[str, Any], ...]  # four dicts: name, min, max, count, spacing
    eta1: float
    eta2: float
    tiles_x: str = "eta3"  # the axis whose nodes lay the tiles along x (the header's packing; κ3 since v6)

    @property
    def inputs(self) -> tuple[str, ...]:
        return ("Cos Theta", "Thickness (nm)", "Eta3", "Kappa3")

    @property
    def thickness_nm(self) -> tuple[float, float]:
        d = self.axes[1]
        return (d["min"] / (2.0 * self.eta2), d["max"] / (2.0 * self.eta2))


@dataclass(frozen=True)
class SceneReads:
    """What a scene manifest asks Blender to read: one read per material, in the manifest's order."""

    name: str  # the manifest's stem: the scene's name in group names
    folder: Path
    space: str
    reads: tuple[SliceRead | LutRead, ...]

    def group_name(self, material: str) -> str:
        return f"{GROUP_PREFIX} {self.name}/{material}"


def read_manifest(path: str | PathLike[str]) -> SceneReads:
    """The reads a scene manifest (SCENE.json) asks for, inside Blender (lutbake/blender/nodes.py), where
    lutbake's bounded reader already checked the file (lutbake/blender/library.py: ``scene_reads`` of
    lutbake.io.manifest's document); ValueError in one line naming the file and the field otherwise."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"manifest {str(path)!r} does not exist")
    try:
        doc = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ValueError(
            f"manifest {str(path)!r} is not JSON ({exc.__class__.__name__}): give the SCENE.json "
            "that `lutbake bake --scene` wrote"
        ) from None
    if not isinstance(doc, dict) or (doc.get("format"), doc.get("format_version")) != MANIFEST_FORMAT:
        raise ValueError(
            f"manifest {str(path)!r}: format is not {MANIFEST_FORMAT[0]!r} version {MANIFEST_FORMAT[1]} "
            "(the SCENE.json that `lutbake bake --scene` writes)"
        )
    return scene_reads(path, doc, lambda sidecar: json.loads(sidecar.read_text()))


def scene_reads(path: Path, doc: dict[str, Any], load_sidecar: Callable[[Path], Any]) -> SceneReads:
    """The reads of the manifest document ``doc`` (read from ``path``), a 4D LUT's sidecar read by
    ``load_sidecar`` (bounded on lutbake's side); ValueError naming the field."""
    try:
        space = doc["settings"]["space"]
        if space not in BLENDER_SPACES:
            raise ValueError(f"settings.space {space!r} is not one of {', '.join(BLENDER_SPACES)}")
        reads = tuple(_read_of(path.parent, name, entry, load_sidecar) for name, entry in doc["materials"].items())
    except (KeyError, TypeError, IndexError) as exc:
        raise ValueError(f"manifest {str(path)!r}: missing or malformed field {exc}") from None
    except ValueError as exc:
        raise ValueError(f"manifest {str(path)!r}: {exc}") from None
    if not reads:
        raise ValueError(f"manifest {str(path)!r}: no materials")
    return SceneReads(path.stem, path.parent, space, reads)


def _read_of(
    folder: Path, name: str, entry: dict[str, Any], load_sidecar: Callable[[Path], Any]
) -> SliceRead | LutRead:
    image = entry["file"]
    if not (folder / image).is_file():
        raise ValueError(f"materials.{name}.file {image!r} is not beside the manifest")
    if entry["kind"] == "slice":
        th = entry["axes"]["thickness_nm"]
        x0, y0, w, h = (int(v) for v in entry["rect"])
        if w < 2 or h < 1:
            raise ValueError(f"materials.{name}.rect {entry['rect']} is not a slice of at least 2 x 1 texels")
        return SliceRead(name, image, (x0, y0, w, h), (float(th["min"]), float(th["max"])))
    if entry["kind"] == "lut":
        sidecar = (folder / image).with_suffix(".json")
        try:
            meta = load_sidecar(sidecar)
        except (OSError, ValueError):
            raise ValueError(f"materials.{name}: the LUT's sidecar {sidecar.name!r} is missing or not JSON") from None
        axes = tuple(meta["axes"])
        if [a["name"] for a in axes] != ["cos_theta", "opd_nm", "eta3", "kappa3"]:
            raise ValueError(f"materials.{name}: {sidecar.name} axes are not cos_theta, opd_nm, eta3, kappa3")
        tiles_x = meta["packing"]["tiles_x"]
        if tiles_x not in ("eta3", "kappa3"):
            raise ValueError(f"materials.{name}: {sidecar.name} packing.tiles_x {tiles_x!r} is not eta3 or kappa3")
        return LutRead(name, image, axes, float(meta["constants"]["eta1"]), float(meta["constants"]["eta2"]), tiles_x)
    raise ValueError(f"materials.{name}.kind {entry['kind']!r} is not 'slice' or 'lut'")


# --- node programs: the maths of each read, once ---------------------------------------------------


def bilinear_program(g: Graph, image: str, size: tuple[int, int], x: Value, y: Value) -> Value:
    """Bilinear read at texel-space (x, y), y in scanlines from the top, measured between texel centres
    (sample._bilinear): four Closest reads at texel centres, Extend at the image's edges, three lerps."""
    width, height = size
    x0, y0 = g.math("FLOOR", x), g.math("FLOOR", y)
    tx, ty = g.math("SUBTRACT", x, x0), g.math("SUBTRACT", y, y0)
    u0 = g.math("DIVIDE", g.math("ADD", x0, 0.5), width)
    u1 = g.math("ADD", u0, 1.0 / width)
    # Blender's rows run bottom-up: scanline y sits at v = 1 − (y + ½)/H, the next one 1/H lower.
    v0 = g.math("DIVIDE", g.math("SUBTRACT", height - 0.5, y0), height)
    v1 = g.math("SUBTRACT", v0, 1.0 / height)
    top = g.mix(g.texel(image, u0, v0), g.texel(image, u1, v0), tx)
    bottom = g.mix(g.texel(image, u0, v1), g.texel(image, u1, v1), tx)
    return g.mix(top, bottom, ty)


def _node_coordinate(g: Graph, value: Value, lo: float, hi: float, count: int) -> Value:
    """clamp((value − lo)/(hi − lo), 0, 1)·(count − 1): a uniform axis's node coordinate."""
    unit = g.clamp01(g.math("DIVIDE", g.math("SUBTRACT", value, lo), hi - lo))
    return g.math("MULTIPLY", unit, count - 1)


def slice_program(g: Graph, read: SliceRead, size: tuple[int, int], cos_theta: Value, thickness_nm: Value) -> Value:
    """A slice's read (sample.Atlas.sample): x = √cos θ·(w − 1), y over the thickness rows, clamped to the
    rect, one bilinear fetch."""
    x0, y0, w, h = read.rect
    fx = g.math("MULTIPLY", g.math("SQRT", g.clamp01(cos_theta)), w - 1)
    lo, hi = read.thickness_nm
    x = g.math("ADD", fx, x0)
    y = g.math("ADD", _node_coordinate(g, thickness_nm, lo, hi, h), y0) if h > 1 and hi > lo else float(y0)
    return g.bilinear(read.image, size, x, y)


def _warp(g: Graph, value: Value, spacing: str, snell: tuple[float, Value]) -> Value:
    """The coordinate in which an axis's nodes are uniform (grid/axis.py, _warp); ``snell`` carries η1 and
    cos θ1 for the admittance spacings, whose v² − (η1 sin θ1)² is (v − η1)(v + η1) + (η1 cos θ1)², as the
    includes write it (no cancellation near v = η1)."""
    if spacing == "uniform":
        return value
    if spacing in ("sqrt", "root4"):
        root = g.math("SQRT", g.math("MAXIMUM", value, 0.0))
        return g.math("SQRT", root) if spacing == "root4" else root
    if spacing in ("admittance", "sqrt-admittance"):
        eta1, cos_theta = snell
        if isinstance(value, float):
            square = (value - eta1) * (value + eta1)
        else:
            square = g.math("MULTIPLY", g.math("SUBTRACT", value, eta1), g.math("ADD", value, eta1))
        grazing = g.math("MULTIPLY", g.math("MULTIPLY", cos_theta, cos_theta), eta1 * eta1)
        root = g.math("SQRT", g.math("MAXIMUM", g.math("ADD", square, grazing), 0.0))
        return g.math("SQRT", root) if spacing == "sqrt-admittance" else root
    raise ValueError(f"axis spacing {spacing!r} is not one of uniform, sqrt, root4, admittance, sqrt-admittance")


def _axis_coordinate(g: Graph, value: Value, axis: dict[str, Any], snell: tuple[float, Value]) -> Value:
    """Node coordinate f = clamp(u, 0, 1)·(N − 1) of ``value`` on ``axis`` (docs/lut-format.md, Axes)."""
    if "corner" in axis:  # only the default LUTs zoom into the corner; scene and glTF bakes never do
        raise ValueError(
            f"axis {axis['name']}: the grazing corner's zoom (LUT format v5) has no node graph; "
            "Blender reads scene and glTF bakes"
        )
    lo, hi = _warp(g, float(axis["min"]), axis["spacing"], snell), _warp(g, float(axis["max"]), axis["spacing"], snell)
    span = g.math("SUBTRACT", hi, lo)
    unit = g.clamp01(g.math("DIVIDE", g.math("SUBTRACT", _warp(g, value, axis["spacing"], snell), lo), span))
    return g.math("MULTIPLY", unit, int(axis["count"]) - 1)


def _lower_node(g: Graph, f: Value, count: int) -> tuple[Value, Value]:
    """(i, t): i = min(floor(f), N − 2), t = f − i (sample._lower_node)."""
    i = g.math("MINIMUM", g.math("FLOOR", f), count - 2)
    return i, g.math("SUBTRACT", f, i)


def lut_program(
    g: Graph,
    read: LutRead,
    size: tuple[int, int],
    cos_theta: Value,
    thickness_nm: Value,
    eta3: Value,
    kappa3: Value,
) -> Value:
    """A 4D LUT's linear read (sample.Lut._linear): bilinear in (cos θ, D) inside the tiles of η3 nodes
    a, a + 1 and κ3 nodes b, b + 1, then lerps by t_a and t_b."""
    ax_cos, ax_opd, ax_eta3, ax_kappa3 = read.axes
    snell = (read.eta1, g.clamp01(cos_theta))
    opd_nm = g.math("MULTIPLY", thickness_nm, 2.0 * read.eta2)
    f_cos = _axis_coordinate(g, cos_theta, ax_cos, snell)
    f_opd = _axis_coordinate(g, opd_nm, ax_opd, snell)
    a, t_a = _lower_node(g, _axis_coordinate(g, eta3, ax_eta3, snell), int(ax_eta3["count"]))
    b, t_b = _lower_node(g, _axis_coordinate(g, kappa3, ax_kappa3, snell), int(ax_kappa3["count"]))
    n_cos, n_opd = int(ax_cos["count"]), int(ax_opd["count"])
    corners: dict[tuple[int, int], Value] = {}
    for da in (0, 1):
        for db in (0, 1):  # x = tile column·N_cos + f_cos, y = tile row·N_opd + f_opd (layout.TileLayout)
            eta3_node, kappa3_node = g.math("ADD", a, float(da)), g.math("ADD", b, float(db))
            column, row = (eta3_node, kappa3_node) if read.tiles_x == "eta3" else (kappa3_node, eta3_node)
            x = g.math("ADD", g.math("MULTIPLY", column, n_cos), f_cos)
            y = g.math("ADD", g.math("MULTIPLY", row, n_opd), f_opd)
            corners[da, db] = g.bilinear(read.image, size, x, y)
    lower = g.mix(corners[0, 0], corners[1, 0], t_a)
    upper = g.mix(corners[0, 1], corners[1, 1], t_a)
    return g.mix(lower, upper, t_b)


def read_program(g: Graph, read: SliceRead | LutRead, size: tuple[int, int], inputs: dict[str, Value]) -> Value:
    """The read of ``read`` on the group inputs ``inputs`` (name → value)."""
    if isinstance(read, SliceRead):
        return slice_program(g, read, size, inputs["Cos Theta"], inputs["Thickness (nm)"])
    return lut_program(g, read, size, *(inputs[name] for name in read.inputs))


# --- numpy: the programs evaluated (float64), for tests without Blender ---------------------------

_NUMPY_OPS: dict[str, Callable[[Any, Any], Any]] = {
    "ADD": lambda a, b: a + b,
    "SUBTRACT": lambda a, b: a - b,
    "MULTIPLY": lambda a, b: a * b,
    "DIVIDE": lambda a, b: a / b,
    "MINIMUM": lambda a, b: _np().minimum(a, b),
    "MAXIMUM": lambda a, b: _np().maximum(a, b),
    "SQRT": lambda a, _: _np().sqrt(a),
    "FLOOR": lambda a, _: _np().floor(a),
}


def _np() -> ModuleType:  # numpy, imported when a program is evaluated, not when Blender loads this file
    import numpy

    return numpy


class NumpyGraph:
    """Evaluates node programs with numpy, as Blender's nodes compute them (Closest image reads with
    Extend, rows bottom-up) but in float64. ``images`` maps a file name to its (height, width, 3) texels
    in scanline order, as lutbake reads them."""

    def __init__(self, images: dict[str, np.ndarray]):
        self.images = images

    def math(self, op: str, a: Value, b: Value = None) -> np.ndarray:
        return _NUMPY_OPS[op](_np().asarray(a, float), None if b is None else _np().asarray(b, float))

    def clamp01(self, a: Value) -> np.ndarray:
        return _np().clip(a, 0.0, 1.0)

    def mix(self, a: Value, b: Value, t: Value) -> np.ndarray:
        t = _np().asarray(t, float)[..., None]
        return a * (1.0 - t) + b * t

    def texel(self, image: str, u: Value, v: Value) -> np.ndarray:
        np = _np()
        texels = self.images[image]
        height, width = texels.shape[:2]
        column = np.clip(np.floor(np.asarray(u) * width), 0, width - 1).astype(int)
        row_from_bottom = np.clip(np.floor(np.asarray(v) * height), 0, height - 1).astype(int)
        return texels[height - 1 - row_from_bottom, column].astype(float)

    def bilinear(self, image: str, size: tuple[int, int], x: Value, y: Value) -> np.ndarray:
        return bilinear_program(self, image, size, x, y)


def evaluate(read: SliceRead | LutRead, texels: np.ndarray, inputs: dict[str, np.ndarray]) -> np.ndarray:
    """RGB (…, 3) that ``read``'s node group returns for ``inputs`` (name → array), evaluated by numpy."""
    height, width = texels.shape[:2]
    return read_program(NumpyGraph({read.image: texels}), read, (width, height), inputs)
