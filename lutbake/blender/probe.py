"""Render probe planes in Blender and report each one's colour: how lutbake checks what Blender returns.

Runs inside Blender (a Blender executable's --python, or a Python with the bpy module); imports nothing
of lutbake. One JSON job in, one JSON result out::

    python lutbake/blender/probe.py JOB.json RESULT.json

Each probe is a flat plane tilted about the x axis so that N·V is the probe's cos θ, in one row along x
under an orthographic camera looking down −z, lit only by a uniform white world (radiance 1): a
perfectly specular plane then shows its Fresnel term times 1. Reflected rays stay in the plane
x = const, so no probe sees another. Per-probe film parameters reach the shader as object custom
properties read by Attribute nodes (type Object), the way a texture would feed them. Materials:

- ``{"kind": "lutbake", "library": LIB.blend, "material": NAME, "closure": "glossy"}``: the material
  that ``lutbake/blender/nodes.py`` wrote, with its thickness (and η3, κ3) inputs fed from the probe's
  properties; closure "emission" shows the group's output through an Emission shader instead;
- ``{"kind": "principled"}``: Blender's Principled BSDF with its own thin film (film η2 over a
  dielectric η3), base colour black, roughness 0;
- ``{"kind": "conductor"}``: Blender's Metallic BSDF, Physical Conductor, per-channel n and k, thin film;
- ``{"kind": "glossy", "color": [r, g, b]}``: a Glossy BSDF of a constant colour (a cost baseline).

Optional job keys: ``open`` (a .blend to build the probes in, a material's library when it is the file itself:
its paths resolve as they do for a user who opens it; default a new file), ``cell_px`` (pixels per probe cell,
default 4), ``samples`` (Cycles samples per pixel, default 1: each probe is deterministic), ``repeat``
(renders of the same scene, default 1) and ``osl`` (Cycles' Open Shading Language, which the exact mode's
Script node needs; default off).
Result: per probe the mean RGB of the cell's inner pixels and their spread (max − min over those
pixels and channels), the engine, Blender's version, the first render's wall seconds (with EEVEE's
shader compilation) and the later ones'.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
import time
from pathlib import Path

import bpy

CELL_PX = 4  # default pixels per probe along x and y; all but the outer ring are measured
PROPERTIES = ("thickness_nm", "eta2", "eta3", "kappa3", "eta3_rgb", "kappa3_rgb")


def _attribute(tree, name: str, output: str = "Fac"):
    node = tree.nodes.new("ShaderNodeAttribute")
    node.attribute_type, node.attribute_name = "OBJECT", name
    return node.outputs[output]


# The reading node's inputs (a node group's, or the exact mode's Script node's) and the probe property
# feeding each; a colour input (the Script node's per-channel η3, κ3) takes the property's _rgb vector.
FED_INPUTS = {
    "Thickness (nm)": "thickness_nm",
    "Thickness": "thickness_nm",
    "Eta2": "eta2",
    "Eta3": "eta3",
    "Kappa3": "kappa3",
}


def lutbake_material(spec: dict):
    """The library's material with its reading node's free inputs fed from the probe's properties: the
    open file's own (job key ``open``) or appended from it. Append rebases the images' relative paths but
    not a Script node's string inputs: a table path relative to the library (``//NAME``) is made absolute."""
    if bpy.data.filepath and Path(bpy.data.filepath).samefile(spec["library"]):
        material = bpy.data.materials[spec["material"]]
    else:
        with bpy.data.libraries.load(spec["library"], link=False) as (source, target):
            target.materials = [spec["material"]]
        material = target.materials[0]
        _absolute_script_paths(material.node_tree, spec["library"])
    tree = material.node_tree
    group = next(n for n in tree.nodes if n.type in ("GROUP", "SCRIPT") and len(n.inputs) > 1)
    for socket in group.inputs:
        if socket.name in FED_INPUTS:
            per_channel = socket.type == "RGBA"
            prop = FED_INPUTS[socket.name] + ("_rgb" if per_channel else "")
            tree.links.new(_attribute(tree, prop, "Vector" if per_channel else "Fac"), socket)
    if spec.get("closure", "glossy") == "emission":  # the group alone, without the engine's closure storage
        emission = tree.nodes.new("ShaderNodeEmission")
        tree.links.new(group.outputs[0], emission.inputs["Color"])
        tree.links.new(emission.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return material


def _absolute_script_paths(tree, library: str):
    for node in tree.nodes:
        for socket in node.inputs if node.type == "SCRIPT" else ():
            if socket.type == "STRING" and socket.default_value.startswith("//"):
                socket.default_value = bpy.path.abspath(socket.default_value, start=str(Path(library).parent))


def principled_material(spec: dict):
    material = bpy.data.materials.new("blender thin film: principled")
    tree = material.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0
    for socket, prop in (("IOR", "eta3"), ("Thin Film Thickness", "thickness_nm"), ("Thin Film IOR", "eta2")):
        tree.links.new(_attribute(tree, prop), bsdf.inputs[socket])
    return material


def conductor_material(spec: dict):
    material = bpy.data.materials.new("blender thin film: conductor")
    tree = material.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    metal = tree.nodes.new("ShaderNodeBsdfMetallic")
    metal.fresnel_type = "PHYSICAL_CONDUCTOR"
    metal.inputs["Roughness"].default_value = 0.0
    tree.links.new(_attribute(tree, "eta3_rgb", "Vector"), metal.inputs["IOR"])
    tree.links.new(_attribute(tree, "kappa3_rgb", "Vector"), metal.inputs["Extinction"])
    tree.links.new(_attribute(tree, "thickness_nm"), metal.inputs["Thin Film Thickness"])
    tree.links.new(_attribute(tree, "eta2"), metal.inputs["Thin Film IOR"])
    tree.links.new(metal.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return material


def glossy_material(spec: dict):
    material = bpy.data.materials.new("glossy")
    tree = material.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    glossy = tree.nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Color"].default_value = (*spec["color"], 1.0)
    glossy.inputs["Roughness"].default_value = 0.0
    tree.links.new(glossy.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return material


MATERIALS = {
    "lutbake": lutbake_material,
    "principled": principled_material,
    "conductor": conductor_material,
    "glossy": glossy_material,
}


def _plane(material):
    """A unit square in the xy plane, 0.9 wide (a gap between neighbours), with ``material``."""
    mesh = bpy.data.meshes.new("probe")
    mesh.from_pydata([(-0.45, -0.5, 0), (0.45, -0.5, 0), (0.45, 0.5, 0), (-0.45, 0.5, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    return mesh


def build_scene(job: dict):
    """Planes, camera and world for ``job``'s probes, in a new file or in the file ``job["open"]`` (where
    relative paths resolve against that file's folder, as for a user who opens it); returns the scene."""
    if job.get("open"):
        bpy.ops.wm.open_mainfile(filepath=job["open"], load_ui=False)
    else:
        bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    materials = [MATERIALS[spec["kind"]](spec) for spec in job["materials"]]
    n = len(job["probes"])
    meshes = [_plane(material) for material in materials]
    for i, probe in enumerate(job["probes"]):
        obj = bpy.data.objects.new(f"probe {i:05d}", meshes[probe.get("material", 0)])
        tilt = math.acos(probe["cos_theta"])
        obj.location = (i + 0.5 - n / 2, 0.0, 0.0)
        obj.rotation_euler = (tilt, 0.0, 0.0)
        obj.scale = (1.0, 1.2 / probe["cos_theta"], 1.0)  # its projection overfills the cell in y
        for prop in PROPERTIES:
            if prop in probe:
                obj[prop] = probe[prop]
        scene.collection.objects.link(obj)
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", float(n)
    camera.data.clip_start, camera.data.clip_end = 0.1, 1000.0
    camera.location = (0.0, 0.0, 100.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    world = bpy.data.worlds.new("white")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    scene.world = world
    _render_settings(scene, job["engine"], n, job.get("cell_px", CELL_PX), job.get("samples", 1), job.get("osl", False))
    return scene


def _render_settings(scene, engine: str, n: int, cell_px: int, samples: int, osl: bool):
    render = scene.render
    render.engine = engine
    render.resolution_x, render.resolution_y, render.resolution_percentage = n * cell_px, cell_px, 100
    render.image_settings.file_format, render.image_settings.color_depth = "OPEN_EXR", "32"
    scene.view_settings.view_transform, scene.view_settings.look = "Standard", "None"
    scene.view_settings.exposure, scene.view_settings.gamma = 0.0, 1.0
    if engine == "CYCLES":
        scene.cycles.device, scene.cycles.samples = "CPU", samples
        scene.cycles.shading_system = osl
        scene.cycles.use_denoising, scene.cycles.use_adaptive_sampling = False, False
        scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    else:
        scene.eevee.taa_render_samples = 1
        render.filter_size = 0.0


def render(job: dict) -> dict:
    scene = build_scene(job)
    with tempfile.TemporaryDirectory() as folder:
        scene.render.filepath = str(Path(folder) / "probes.exr")
        seconds = []
        for _ in range(job.get("repeat", 1)):  # later renders reuse what the first compiled (EEVEE's shaders)
            start = time.perf_counter()
            bpy.ops.render.render(write_still=True)
            seconds.append(time.perf_counter() - start)
        image = bpy.data.images.load(scene.render.filepath)
        width, height = image.size
        pixels = [0.0] * (width * height * 4)
        image.pixels.foreach_get(pixels)
    rgb, spread, cell = [], [], job.get("cell_px", CELL_PX)
    ring = int(0.05 * cell) + 1  # pixels wholly inside the plane, which spans 0.05–0.95 of its cell
    for i in range(len(job["probes"])):
        inner = [
            pixels[4 * (row * width + col) : 4 * (row * width + col) + 3]
            for row in range(ring, cell - ring)
            for col in range(i * cell + ring, (i + 1) * cell - ring)
        ]
        rgb.append([sum(p[c] for p in inner) / len(inner) for c in range(3)])
        spread.append(max(max(p[c] for p in inner) - min(p[c] for p in inner) for c in range(3)))
    return {
        "rgb": rgb,
        "spread": spread,
        "engine": job["engine"],
        "blender": bpy.app.version_string,
        "render_seconds": seconds[0],
        "repeat_seconds": seconds[1:],
    }


def main(argv=None) -> int:
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    job_path, result_path = argv
    result = render(json.loads(Path(job_path).read_text()))
    Path(result_path).write_text(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
