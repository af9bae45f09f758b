"""Blender node groups that read a lutbake scene bake: runs inside Blender, imports nothing of lutbake.

For each material of a scene manifest (``lutbake bake --scene``, or any bake that writes the same
atlas and manifest) it builds one shader node group whose output is the film's linear RGB Fresnel
term, and one material that feeds it into a Fresnel-free specular closure (Glossy BSDF), for Cycles
and EEVEE alike (docs/blender.md)::

    blender --background --factory-startup --python lutbake/blender/nodes.py -- SCENE.json --out LIB.blend
    python lutbake/blender/nodes.py SCENE.json --out LIB.blend          # a Python with the bpy module
    lutbake blender SCENE.json --out LIB.blend                  # the same, from lutbake (lutbake/blender/library.py)

With ``--osl lutbake_exact.osl TABLE.exr`` (lutbake writes it for an exact-mode table: `lutbake blender --exact`) the
file also holds material ``lutbake exact``: the exact runtime mode, any film and base, as an OSL Script node
(Cycles with Open Shading Language on; shaders/exact.osl.in); with ``--osl lutbake_runtime.osl TABLE.exr``
(`lutbake blender --runtime-table`), material ``lutbake runtime``: the runtime table's six bilinear reads
(shaders/runtime.osl.in).

What each material reads, and the maths of the read as a node program, are lutbake/blender/programs.py's
(beside this file, loaded by path when Blender runs it); ``NodeGraph`` builds those programs into nodes,
each operation one node. Its bilinear fetch is four Closest reads at texel centres blended by Mix nodes,
not one Linear read (EEVEE samples Linear image nodes with mipmaps and anisotropic filtering, and GPUs
quantize bilinear weights). Images load as float (``use_half_precision`` off), Non-Color, Extend. Every
table is named relative to the .blend (``//NAME``), the OSL scripts' too: the file travels with its tables.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

if __name__ == "__main__":  # Blender runs this file as a script, outside lutbake: its sibling, by path
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import programs
else:
    from lutbake.blender import programs

__all__ = [
    "EXACT_MATERIAL",
    "RUNTIME_MATERIAL",
    "OSL_MATERIALS",
    "NodeGraph",
    "build_library",
    "build_osl",
    "OSL_FALLBACK_RGB",
    "osl_warning",
    "main",
]

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
        f"{programs.GROUP_PREFIX} bilinear {image}",
        {"X": (0.0, -1e9, 1e9), "Y": (0.0, -1e9, 1e9)},
        ("Colour", "NodeSocketColor"),
    )
    tree.description = (
        f"Bilinear read of {image} at texel-space (X, Y), Y in EXR scanlines from the top: four "
        "Closest reads at texel centres and three lerps (exact on every engine)"
    )
    graph = NodeGraph(tree, images, subgroups)
    x, y = (_Out(group_in.outputs[name], 0) for name in ("X", "Y"))
    _finish(graph, group_out, programs.bilinear_program(graph, image, size, x, y))
    return tree


def _read_group(scene: programs.SceneReads, read, images: dict, subgroups: dict):
    lo, hi = read.thickness_nm
    inputs = {"Cos Theta": (1.0, 0.0, 1.0), "Thickness (nm)": (0.5 * (lo + hi), 0.0, 1e5)}
    if isinstance(read, programs.LutRead):
        (e, k) = read.axes[2:]
        inputs.update({"Eta3": (0.5 * (e["min"] + e["max"]), 0.0, 100.0), "Kappa3": (float(k["min"]), 0.0, 100.0)})
    tree, group_in, group_out = _new_group(scene.group_name(read.material), inputs, ("Fresnel", "NodeSocketColor"))
    rule = (
        "one bilinear read of its 2D slice"
        if isinstance(read, programs.SliceRead)
        else "the linear rule of its 4D LUT (lutbake sample --interpolation linear)"
    )
    tree.description = (
        f"Linear RGB Fresnel term of lutbake material {read.material!r} ({read.image}: {rule}). "
        f"Cos Theta: N·V (or V·H); thickness baked over {lo:g}-{hi:g} nm"
    )
    graph = NodeGraph(tree, images, subgroups)
    values = {name: _Out(group_in.outputs[name], 0) for name in read.inputs}
    image = images[read.image]
    _finish(graph, group_out, programs.read_program(graph, read, tuple(image.size), values))
    return tree


def _incidence_group():
    """N·V from the geometry, clamped to [0, 1]: the cos θ of a mirror-like specular (one per file)."""
    import bpy

    name = f"{programs.GROUP_PREFIX} N·V"
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


def _material(name: str, incidence, reader, fallback_rgb: tuple = (0.8, 0.8, 0.8)):
    """Geometry N·V into ``reader`` (a function adding the node that returns the Fresnel term to a node
    tree), into a Glossy BSDF (roughness 0) whose own colour, ``fallback_rgb``, shows where the engine
    drops the reading node (an OSL Script node outside Cycles with OSL)."""
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
    glossy.inputs["Color"].default_value = (*fallback_rgb, 1.0)
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


def _load_image(folder: Path, name: str):
    import bpy

    image = bpy.data.images.load(str(folder / name), check_existing=True)
    image.colorspace_settings.name = "Non-Color"
    image.use_half_precision = False
    image.alpha_mode = "CHANNEL_PACKED"
    return image


def build_library(manifest) -> dict:
    """Node groups and materials for every material of ``manifest`` in the open Blender file; the
    file's working colour space is set to the bake's. Returns material name → node group."""
    import bpy

    scene = programs.read_manifest(manifest)
    if bpy.data.colorspace.working_space != programs.BLENDER_SPACES[scene.space]:
        bpy.ops.wm.set_working_color_space(convert_colors=False, working_space=programs.BLENDER_SPACES[scene.space])
    images = {r.image: _load_image(scene.folder, r.image) for r in scene.reads}
    incidence, subgroups, groups = _incidence_group(), {}, {}
    for read in scene.reads:
        groups[read.material] = _read_group(scene, read, images, subgroups)
        material = _material(scene.group_name(read.material), incidence, _group_node(groups[read.material]))
        _mark_asset(groups[read.material].description, groups[read.material], material)
    return groups


EXACT_MATERIAL = f"{programs.GROUP_PREFIX} exact"
RUNTIME_MATERIAL = f"{programs.GROUP_PREFIX} runtime"
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


# What an OSL material shows where its Script node does not run (EEVEE; Cycles with OSL off, or on a GPU
# other than OptiX): a magenta mirror, Blender's colour for a missing resource, and this warning.
OSL_FALLBACK_RGB = (1.0, 0.0, 1.0)


def osl_warning(material: str) -> str:
    """The one-line warning of an OSL material: the first line of its script's text block, and the
    `lutbake blender` report's."""
    return (
        f"material {material!r} needs Cycles with Open Shading Language on (CPU, or OptiX); in EEVEE or with "
        "OSL off it renders as a magenta mirror (1, 0, 1)"
    )


def build_osl(osl_path, table_path) -> None:
    """An OSL Script node (Cycles, OSL on) in the material OSL_MATERIALS names for ``osl_path``'s file name:
    the script's text (written by lutbake for the table ``table_path``, which it reads at the path relative
    to the .blend that it holds) is kept in the file, its first line the material's warning. The table is
    also an image of the material (an Image Texture node, unconnected: Cycles and EEVEE drop it), so that
    Report Missing Files and Pack Resources see it."""
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
    text.from_string(f"// lutbake: {osl_warning(name)}\n{path.read_text()}")
    material = _material(name, _incidence_group(), _script_node(text), OSL_FALLBACK_RGB)
    table = material.node_tree.nodes.new("ShaderNodeTexImage")
    table.image = _load_image(Path(table_path).parent, Path(table_path).name)
    table.label, table.location = "the script's table (for Pack Resources; not read here)", (260, -300)
    _mark_asset(description, material)


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
    """``lutbake/blender/nodes.py [SCENE.json] [--osl lutbake_MODE.osl TABLE.exr ...] --out LIB.blend [--link]``:
    a new file holding the scene's groups and materials, and the OSL materials (exact mode, runtime table)."""
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
        nargs=2,
        default=[],
        metavar=("SCRIPT", "TABLE"),
        help="lutbake_exact.osl or lutbake_runtime.osl (lutbake writes them for a table) and the table; repeatable",
    )
    args = parser.parse_args(argv)
    if args.manifest is None and not args.osl:
        parser.error("give a manifest, --osl, or both")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    _bundled_modules()
    if args.manifest:
        build_library(args.manifest)
    for script, table in args.osl:
        build_osl(script, table)
    out = Path(args.out).absolute()
    for image in bpy.data.images:
        if not args.link:
            image.pack()
        image.filepath = bpy.path.relpath(image.filepath, start=str(out.parent))  # //NAME: it travels with the .blend
        for packed in image.packed_files:  # Blender keeps the absolute path: unpack beside the .blend instead,
            packed.filepath = image.filepath  # where the OSL scripts read their tables
    bpy.ops.wm.save_as_mainfile(filepath=str(out), relative_remap=True, compress=False)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except ValueError as exc:
        print(f"lutbake: error: {exc}", file=sys.stderr)
        sys.exit(2)
