"""Blender node groups that read a lutbake scene bake: runs inside Blender, imports nothing of lutbake.

For each material of a scene manifest (``lutbake bake --scene``, or any bake that writes the same
atlas and manifest) it builds one shader node group whose output is the film's linear RGB Fresnel
term, and one material that feeds it into a Fresnel-free specular closure (Glossy BSDF), for Cycles
and EEVEE alike (docs/blender.md)::

    blender --background --factory-startup --python lutbake/blender/nodes.py -- SCENE.json --out LIB.blend
    python lutbake/blender/nodes.py SCENE.json --out LIB.blend          # a Python with the bpy module
    lutbake blender SCENE.json --out LIB.blend                  # the same, from lutbake (lutbake/blender/library.py)

With ``--osl lutbake_exact.osl`` (lutbake writes it for an exact-mode table: `lutbake blender --exact`) the
file also holds material ``lutbake exact``: the exact runtime mode, any film and base, as an OSL Script node
(Cycles with Open Shading Language on; shaders/exact.osl.in); with ``--osl lutbake_runtime.osl``
(`lutbake blender --runtime-table`), material ``lutbake runtime``: the runtime table's six bilinear reads
(shaders/runtime.osl.in).

Every read is one *node program* (``slice_program``, ``lut_program``, ``bilinear_program``) written
against a small graph interface, so one text of the maths both becomes Blender nodes (``NodeGraph``)
and is evaluated by numpy (``NumpyGraph``), which tests hold to ``lutbake sample`` without Blender.

Reads, as the sampler (lutbake/lut/sample.py) and docs/lut-format.md define them:

- a 2D slice (a fixed base): one bilinear fetch at x = √cos θ·(w − 1), y = (d − d_min)/(d_max − d_min)·(h − 1)
  inside the slice's rect;
- a 4D LUT (a base given as ranges): the *linear* rule, bilinear in (cos θ, D) inside the four tiles
  around (η3, κ3) and lerps across them. Nodes cannot express the 256-read cubic rule the header
  names; ``lutbake sample --interpolation linear`` is what these groups return.

A bilinear fetch is four Closest reads at texel centres blended by math nodes, not one Linear read:
EEVEE samples Linear image nodes with mipmaps and anisotropic filtering and GPUs quantize bilinear
weights (often to 8 bits), while texel centres read exactly everywhere. Images load as float
(``use_half_precision`` off), Non-Color, Extend. Blender's image rows run bottom-up: the EXR's last
scanline is v = 0, so scanline y is read at v = 1 − (y + ½)/H.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "MANIFEST_FORMAT",
    "BLENDER_SPACES",
    "EXACT_MATERIAL",
    "RUNTIME_MATERIAL",
    "OSL_MATERIALS",
    "SliceRead",
    "LutRead",
    "SceneReads",
    "read_manifest",
    "NumpyGraph",
    "NodeGraph",
    "slice_program",
    "lut_program",
    "bilinear_program",
    "read_program",
    "evaluate",
    "build_library",
    "build_osl",
    "main",
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


# --- what the manifest asks for -------------------------------------------------------------------


@dataclass(frozen=True)
class SliceRead:
    """A material served by a 2D slice of an atlas: rect (x0, y0, width, height) in texels, y in
    scanlines from the top; thickness range in nm (equal ends: one row)."""

    material: str
    image: str  # file name, beside the manifest
    rect: tuple
    thickness_nm: tuple

    @property
    def inputs(self) -> tuple:
        return ("Cos Theta", "Thickness (nm)")


@dataclass(frozen=True)
class LutRead:
    """A material served by a 4D LUT (docs/lut-format.md): axes (cos θ, D, η3, κ3) as the LUT's sidecar
    JSON lists them, ambient η1 and film η2."""

    material: str
    image: str
    axes: tuple  # four dicts: name, min, max, count, spacing
    eta1: float
    eta2: float
    tiles_x: str = "eta3"  # the axis whose nodes lay the tiles along x (the header's packing; κ3 since v6)

    @property
    def inputs(self) -> tuple:
        return ("Cos Theta", "Thickness (nm)", "Eta3", "Kappa3")

    @property
    def thickness_nm(self) -> tuple:
        d = self.axes[1]
        return (d["min"] / (2.0 * self.eta2), d["max"] / (2.0 * self.eta2))


@dataclass(frozen=True)
class SceneReads:
    name: str  # the manifest's stem: the scene's name in group names
    folder: Path
    space: str
    reads: tuple

    def group_name(self, material: str) -> str:
        return f"{GROUP_PREFIX} {self.name}/{material}"


def read_manifest(path) -> SceneReads:
    """The reads a scene manifest (SCENE.json) asks for; ValueError in one line naming the file and the
    field when it is not a lutbake scene manifest, or a file it names is missing."""
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
    try:
        space = doc["settings"]["space"]
        if space not in BLENDER_SPACES:
            raise ValueError(f"settings.space {space!r} is not one of {', '.join(BLENDER_SPACES)}")
        reads = tuple(_read_of(path.parent, name, entry) for name, entry in doc["materials"].items())
    except (KeyError, TypeError, IndexError) as exc:
        raise ValueError(f"manifest {str(path)!r}: missing or malformed field {exc}") from None
    except ValueError as exc:
        raise ValueError(f"manifest {str(path)!r}: {exc}") from None
    if not reads:
        raise ValueError(f"manifest {str(path)!r}: no materials")
    return SceneReads(path.stem, path.parent, space, reads)


def _read_of(folder: Path, name: str, entry: dict):
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
            meta = json.loads(sidecar.read_text())
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


def bilinear_program(g, image: str, size: tuple, x, y):
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


def _node_coordinate(g, value, lo: float, hi: float, count: int):
    """clamp((value − lo)/(hi − lo), 0, 1)·(count − 1): a uniform axis's node coordinate."""
    unit = g.clamp01(g.math("DIVIDE", g.math("SUBTRACT", value, lo), hi - lo))
    return g.math("MULTIPLY", unit, count - 1)


def slice_program(g, read: SliceRead, size: tuple, cos_theta, thickness_nm):
    """A slice's read (sample.Atlas.sample): x = √cos θ·(w − 1), y over the thickness rows, clamped to the
    rect, one bilinear fetch."""
    x0, y0, w, h = read.rect
    fx = g.math("MULTIPLY", g.math("SQRT", g.clamp01(cos_theta)), w - 1)
    lo, hi = read.thickness_nm
    x = g.math("ADD", fx, x0)
    y = g.math("ADD", _node_coordinate(g, thickness_nm, lo, hi, h), y0) if h > 1 and hi > lo else float(y0)
    return g.bilinear(read.image, size, x, y)


def _warp(g, value, spacing: str, snell):
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


def _axis_coordinate(g, value, axis: dict, snell):
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


def _lower_node(g, f, count: int):
    """(i, t): i = min(floor(f), N − 2), t = f − i (sample._lower_node)."""
    i = g.math("MINIMUM", g.math("FLOOR", f), count - 2)
    return i, g.math("SUBTRACT", f, i)


def lut_program(g, read: LutRead, size: tuple, cos_theta, thickness_nm, eta3, kappa3):
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
    corners = {}
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


def read_program(g, read, size: tuple, inputs: dict):
    """The read of ``read`` on the group inputs ``inputs`` (name → value)."""
    if isinstance(read, SliceRead):
        return slice_program(g, read, size, inputs["Cos Theta"], inputs["Thickness (nm)"])
    return lut_program(g, read, size, *(inputs[name] for name in read.inputs))


# --- numpy: the programs evaluated (float64), for tests without Blender ---------------------------

_NUMPY_OPS = {
    "ADD": lambda a, b: a + b,
    "SUBTRACT": lambda a, b: a - b,
    "MULTIPLY": lambda a, b: a * b,
    "DIVIDE": lambda a, b: a / b,
    "MINIMUM": lambda a, b: _np().minimum(a, b),
    "MAXIMUM": lambda a, b: _np().maximum(a, b),
    "SQRT": lambda a, _: _np().sqrt(a),
    "FLOOR": lambda a, _: _np().floor(a),
}


def _np():
    import numpy

    return numpy


class NumpyGraph:
    """Evaluates node programs with numpy, as Blender's nodes compute them (Closest image reads with
    Extend, rows bottom-up) but in float64. ``images`` maps a file name to its (height, width, 3) texels
    in scanline order, as lutbake reads them."""

    def __init__(self, images: dict):
        self.images = images

    def math(self, op, a, b=None):
        return _NUMPY_OPS[op](_np().asarray(a, float), None if b is None else _np().asarray(b, float))

    def clamp01(self, a):
        return _np().clip(a, 0.0, 1.0)

    def mix(self, a, b, t):
        t = _np().asarray(t, float)[..., None]
        return a * (1.0 - t) + b * t

    def texel(self, image, u, v):
        np = _np()
        texels = self.images[image]
        height, width = texels.shape[:2]
        column = np.clip(np.floor(np.asarray(u) * width), 0, width - 1).astype(int)
        row_from_bottom = np.clip(np.floor(np.asarray(v) * height), 0, height - 1).astype(int)
        return texels[height - 1 - row_from_bottom, column].astype(float)

    def bilinear(self, image, size, x, y):
        return bilinear_program(self, image, size, x, y)


def evaluate(read, texels, inputs: dict):
    """RGB (…, 3) that ``read``'s node group returns for ``inputs`` (name → array), evaluated by numpy."""
    height, width = texels.shape[:2]
    return read_program(NumpyGraph({read.image: texels}), read, (width, height), inputs)


# --- Blender: the programs as nodes ----------------------------------------------------------------

_COLUMN_WIDTH, _ROW_HEIGHT = 200, 180


class NodeGraph:
    """Builds node programs into a shader node tree: each operation one node, placed in a column one
    to the right of its deepest input, so the graph reads left to right."""

    def __init__(self, tree, images: dict, subgroups: dict):
        self.tree, self.images, self.subgroups = tree, images, subgroups
        self.rows = {}

    def place(self, node, *inputs):
        column = 1 + max((getattr(s, "column", 0) for s in inputs if not isinstance(s, (int, float))), default=0)
        row = self.rows.get(column, 0)
        self.rows[column] = row + 1
        node.location = (column * _COLUMN_WIDTH, -row * _ROW_HEIGHT)
        return column

    def link(self, socket, value):
        if isinstance(value, (int, float)):
            socket.default_value = float(value)
        else:
            self.tree.links.new(value.socket, socket)

    def math(self, op, a, b=None):
        node = self.tree.nodes.new("ShaderNodeMath")
        node.operation = op
        node.label = op.lower()
        self.link(node.inputs[0], a)
        if b is not None:
            self.link(node.inputs[1], b)
        return _Out(node.outputs[0], self.place(node, a, b if b is not None else 0))

    def clamp01(self, a):
        node = self.tree.nodes.new("ShaderNodeClamp")
        self.link(node.inputs["Value"], a)
        node.inputs["Min"].default_value, node.inputs["Max"].default_value = 0.0, 1.0
        return _Out(node.outputs[0], self.place(node, a))

    def mix(self, a, b, t):
        node = self.tree.nodes.new("ShaderNodeMix")
        node.data_type, node.blend_type = "RGBA", "MIX"
        node.clamp_factor, node.clamp_result = False, False
        # the node keeps one socket set per data type: the RGBA ones by identifier
        self.link(_socket(node.inputs, "Factor_Float"), t)
        self.link(_socket(node.inputs, "A_Color"), a)
        self.link(_socket(node.inputs, "B_Color"), b)
        return _Out(_socket(node.outputs, "Result_Color"), self.place(node, a, b, t))

    def texel(self, image, u, v):
        uv = self.tree.nodes.new("ShaderNodeCombineXYZ")
        self.link(uv.inputs["X"], u)
        self.link(uv.inputs["Y"], v)
        node = self.tree.nodes.new("ShaderNodeTexImage")
        node.image, node.interpolation, node.extension = self.images[image], "Closest", "EXTEND"
        self.tree.links.new(uv.outputs[0], node.inputs["Vector"])
        column = self.place(uv, u, v)
        node.location = (uv.location[0] + _COLUMN_WIDTH, uv.location[1])
        self.rows[column + 1] = max(self.rows.get(column + 1, 0), self.rows[column])
        return _Out(node.outputs["Color"], column + 1)

    def bilinear(self, image, size, x, y):
        """One group node per fetch; the group (four reads and three lerps) is built once per image."""
        if image not in self.subgroups:
            self.subgroups[image] = _bilinear_group(image, size, self.images, self.subgroups)
        node = self.tree.nodes.new("ShaderNodeGroup")
        node.node_tree = self.subgroups[image]
        self.link(node.inputs["X"], x)
        self.link(node.inputs["Y"], y)
        return _Out(node.outputs[0], self.place(node, x, y))


def _socket(sockets, identifier: str):
    return next(s for s in sockets if s.identifier == identifier)


@dataclass
class _Out:
    socket: object
    column: int


def _new_group(name: str, inputs: dict, output: tuple):
    """A shader node group with float inputs (name → (default, min, max)) and one output (name, type)."""
    import bpy

    tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for label, (default, lo, hi) in inputs.items():
        socket = tree.interface.new_socket(label, in_out="INPUT", socket_type="NodeSocketFloat")
        socket.default_value, socket.min_value, socket.max_value = default, lo, hi
    tree.interface.new_socket(output[0], in_out="OUTPUT", socket_type=output[1])
    group_in, group_out = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    group_in.location = (0, 0)
    return tree, group_in, group_out


def _finish(graph: NodeGraph, group_out, result):
    group_out.location = ((max(graph.rows, default=0) + 2) * _COLUMN_WIDTH, 0)
    graph.tree.links.new(result.socket, group_out.inputs[0])


def _bilinear_group(image: str, size: tuple, images: dict, subgroups: dict):
    tree, group_in, group_out = _new_group(
        f"{GROUP_PREFIX} bilinear {image}",
        {"X": (0.0, -1e9, 1e9), "Y": (0.0, -1e9, 1e9)},
        ("Colour", "NodeSocketColor"),
    )
    tree.description = (
        f"Bilinear read of {image} at texel-space (X, Y), Y in EXR scanlines from the top: four "
        "Closest reads at texel centres and three lerps (exact on every engine)"
    )
    graph = NodeGraph(tree, images, subgroups)
    x, y = (_Out(group_in.outputs[name], 0) for name in ("X", "Y"))
    _finish(graph, group_out, bilinear_program(graph, image, size, x, y))
    return tree


def _read_group(scene: SceneReads, read, images: dict, subgroups: dict):
    lo, hi = read.thickness_nm
    inputs = {"Cos Theta": (1.0, 0.0, 1.0), "Thickness (nm)": (0.5 * (lo + hi), 0.0, 1e5)}
    if isinstance(read, LutRead):
        (e, k) = read.axes[2:]
        inputs.update({"Eta3": (0.5 * (e["min"] + e["max"]), 0.0, 100.0), "Kappa3": (float(k["min"]), 0.0, 100.0)})
    tree, group_in, group_out = _new_group(scene.group_name(read.material), inputs, ("Fresnel", "NodeSocketColor"))
    rule = (
        "one bilinear read of its 2D slice"
        if isinstance(read, SliceRead)
        else "the linear rule of its 4D LUT (lutbake sample --interpolation linear)"
    )
    tree.description = (
        f"Linear RGB Fresnel term of lutbake material {read.material!r} ({read.image}: {rule}). "
        f"Cos Theta: N·V (or V·H); thickness baked over {lo:g}-{hi:g} nm"
    )
    graph = NodeGraph(tree, images, subgroups)
    values = {name: _Out(group_in.outputs[name], 0) for name in read.inputs}
    image = images[read.image]
    _finish(graph, group_out, read_program(graph, read, tuple(image.size), values))
    return tree


def _incidence_group():
    """N·V from the geometry, clamped to [0, 1]: the cos θ of a mirror-like specular (one per file)."""
    import bpy

    name = f"{GROUP_PREFIX} N·V"
    if name in bpy.data.node_groups:
        return bpy.data.node_groups[name]
    tree, _, group_out = _new_group(name, {}, ("Cos Theta", "NodeSocketFloat"))
    tree.description = "cos θ = N·V (Geometry: Normal · Incoming), clamped to [0, 1]"
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    dot = tree.nodes.new("ShaderNodeVectorMath")
    dot.operation = "DOT_PRODUCT"
    clamp = tree.nodes.new("ShaderNodeClamp")
    tree.links.new(geometry.outputs["Normal"], dot.inputs[0])
    tree.links.new(geometry.outputs["Incoming"], dot.inputs[1])
    tree.links.new(dot.outputs["Value"], clamp.inputs["Value"])
    tree.links.new(clamp.outputs[0], group_out.inputs[0])
    for i, node in enumerate((geometry, dot, clamp, group_out)):
        node.location = (i * _COLUMN_WIDTH, 0)
    return tree


def _material(name: str, incidence, reader):
    """Geometry N·V into ``reader`` (a function adding the node that returns the Fresnel term to a node
    tree), into a Glossy BSDF (roughness 0)."""
    import bpy

    material = bpy.data.materials.new(name)
    tree = material.node_tree
    tree.nodes.clear()
    cos_node = tree.nodes.new("ShaderNodeGroup")
    cos_node.node_tree = incidence
    read_node = reader(tree)
    tree.links.new(cos_node.outputs[0], next(s for s in read_node.inputs if s.name in ("Cos Theta", "CosTheta")))
    glossy = tree.nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Roughness"].default_value = 0.0
    tree.links.new(read_node.outputs[0], glossy.inputs["Color"])
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(glossy.outputs[0], out.inputs["Surface"])
    for i, node in enumerate((cos_node, read_node, glossy, out)):
        node.location = (i * 260, 0)
    return material


def _group_node(group):
    def add(tree):
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        return node

    return add


def _script_node(text):
    """An OSL Script node running ``text``; Cycles compiles it and makes its sockets (the scene's
    engine must be Cycles with OSL on)."""

    def add(tree):
        node = tree.nodes.new("ShaderNodeScript")
        node.mode, node.script = "INTERNAL", text
        if not node.inputs:
            raise RuntimeError(f"Cycles did not compile {text.name} (see Blender's messages above)")
        return node

    return add


def _load_image(folder: Path, name: str, pack: bool):
    import bpy

    image = bpy.data.images.load(str(folder / name), check_existing=True)
    image.colorspace_settings.name = "Non-Color"
    image.use_half_precision = False
    image.alpha_mode = "CHANNEL_PACKED"
    if pack:
        image.pack()
    return image


def build_library(manifest, pack: bool = True) -> dict:
    """Node groups and materials for every material of ``manifest`` in the open Blender file; the
    file's working colour space is set to the bake's. Returns material name → node group."""
    import bpy

    scene = read_manifest(manifest)
    if bpy.data.colorspace.working_space != BLENDER_SPACES[scene.space]:
        bpy.ops.wm.set_working_color_space(convert_colors=False, working_space=BLENDER_SPACES[scene.space])
    images = {r.image: _load_image(scene.folder, r.image, pack) for r in scene.reads}
    incidence, subgroups, groups = _incidence_group(), {}, {}
    for read in scene.reads:
        groups[read.material] = _read_group(scene, read, images, subgroups)
        material = _material(scene.group_name(read.material), incidence, _group_node(groups[read.material]))
        _mark_asset(groups[read.material].description, groups[read.material], material)
    return groups


EXACT_MATERIAL = f"{GROUP_PREFIX} exact"
RUNTIME_MATERIAL = f"{GROUP_PREFIX} runtime"
# The OSL materials, by the script's file name (lutbake writes lutbake_exact.osl, lutbake_runtime.osl):
# material name and asset description.
OSL_MATERIALS = {
    "lutbake_exact": (
        EXACT_MATERIAL,
        "Exact thin-film Fresnel term for any film and base (Cycles with Open "
        "Shading Language on): lutbake's exact runtime mode",
    ),
    "lutbake_runtime": (
        RUNTIME_MATERIAL,
        "Thin-film Fresnel term for any film and base from lutbake's runtime "
        "table (Cycles with Open Shading Language on): 24 texel reads, no loop",
    ),
}


def build_osl(osl_path) -> None:
    """An OSL Script node (Cycles, OSL on) in the material OSL_MATERIALS names for ``osl_path``'s file name:
    the script's text (written by lutbake for one table, whose path it holds) is kept in the file."""
    import bpy

    path = Path(osl_path)
    if path.stem not in OSL_MATERIALS:
        raise ValueError(
            f"--osl {str(path)!r}: the file name must be one of {', '.join(f'{stem}.osl' for stem in OSL_MATERIALS)}"
        )
    name, description = OSL_MATERIALS[path.stem]
    scene = bpy.context.scene
    scene.render.engine, scene.cycles.shading_system = "CYCLES", True
    text = bpy.data.texts.new(path.name)
    text.from_string(path.read_text())
    _mark_asset(description, _material(name, _incidence_group(), _script_node(text)))


def _mark_asset(description: str, *items):
    for item in items:
        item.asset_mark()
        item.asset_data.description = description


def _bundled_modules() -> None:
    """Blender's own Python modules (oslquery, which compiling a Script node needs) on sys.path: a Blender
    executable has them there, the bpy module keeps them beside its scripts."""
    import bpy

    folder = (
        Path(bpy.utils.resource_path("LOCAL"))
        / "python"
        / "lib"
        / f"python{sys.version_info[0]}.{sys.version_info[1]}"
        / "site-packages"
    )
    if folder.is_dir() and str(folder) not in sys.path:
        sys.path.append(str(folder))


def main(argv=None) -> int:
    """``lutbake/blender/nodes.py [SCENE.json] [--osl lutbake_MODE.osl ...] --out LIB.blend [--link]``: a new file
    holding the scene's groups and materials, and the OSL materials (exact mode, runtime table)."""
    import bpy

    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    parser = argparse.ArgumentParser(prog="nodes.py", description=__doc__.split("\n")[0])
    parser.add_argument("manifest", nargs="?", help="SCENE.json of a lutbake scene bake")
    parser.add_argument("--out", required=True, help="the .blend to write")
    parser.add_argument("--link", action="store_true", help="reference the EXRs by path instead of packing them")
    parser.add_argument(
        "--osl",
        action="append",
        default=[],
        help="lutbake_exact.osl or lutbake_runtime.osl (lutbake writes them for a table); repeatable",
    )
    args = parser.parse_args(argv)
    if args.manifest is None and not args.osl:
        parser.error("give a manifest, --osl, or both")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    _bundled_modules()
    if args.manifest:
        build_library(args.manifest, pack=not args.link)
    for osl in args.osl:
        build_osl(osl)
    bpy.ops.wm.save_as_mainfile(filepath=str(Path(args.out).absolute()), relative_remap=True, compress=False)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except ValueError as exc:
        print(f"lutbake: error: {exc}", file=sys.stderr)
        sys.exit(2)
