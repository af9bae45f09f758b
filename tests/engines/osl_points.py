"""Evaluate a lutbake OSL script at given inputs in Cycles (runs inside Blender's Python; imports nothing of
lutbake). The probe rig of lutbake/blender/probe.py sets cos θ by tilting a plane, which cannot reach
cos θ = 0; here each point is a camera-facing plane whose material feeds the Script node constants
(CosTheta, Thickness, Eta1, Eta2, Eta3, Kappa3) and shows its Fresnel output through an Emission shader,
under a black world::

    python osl_points.py JOB.json RESULT.json     JOB: {"osl": script text, "points": [[cos, d, η1, η2, η3, κ3], ...]}

RESULT: {"rgb": [[r, g, b], ...]} (the mean of each plane's inner pixels), "blender": its version.
"""

import json
import sys
import tempfile
from pathlib import Path

import bpy

CELL = 4  # pixels per point along x and y


def _material(index: int, text, point) -> bpy.types.Material:
    material = bpy.data.materials.new(f"point{index}")
    tree = material.node_tree
    tree.nodes.clear()
    script = tree.nodes.new("ShaderNodeScript")
    script.mode, script.script = "INTERNAL", text
    script.update()
    cos, thickness, eta1, eta2, eta3, kappa3 = point
    for name, value in (("CosTheta", cos), ("Thickness", thickness), ("Eta1", eta1), ("Eta2", eta2)):
        script.inputs[name].default_value = value
    script.inputs["Eta3"].default_value = (eta3, eta3, eta3, 1.0)
    script.inputs["Kappa3"].default_value = (kappa3, kappa3, kappa3, 1.0)
    emission = tree.nodes.new("ShaderNodeEmission")
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(script.outputs["Fresnel"], emission.inputs["Color"])
    tree.links.new(emission.outputs[0], output.inputs["Surface"])
    return material


def _bundled_modules() -> None:
    """Blender's own modules (oslquery, which compiling a Script node needs) on sys.path, as
    lutbake/blender/nodes.py does."""
    version = f"python{sys.version_info[0]}.{sys.version_info[1]}"
    folder = Path(bpy.utils.resource_path("LOCAL")) / "python" / "lib" / version / "site-packages"
    if folder.is_dir() and str(folder) not in sys.path:
        sys.path.append(str(folder))


def render(job: dict) -> list:
    _bundled_modules()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine, scene.cycles.shading_system = "CYCLES", True
    text = bpy.data.texts.new("lutbake.osl")
    text.from_string(job["osl"])
    n = len(job["points"])
    for i, point in enumerate(job["points"]):
        bpy.ops.mesh.primitive_plane_add(size=0.9, location=(i - 0.5 * (n - 1), 0.0, 0.0))
        bpy.context.object.data.materials.append(_material(i, text, point))
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type, camera.data.ortho_scale = "ORTHO", float(n)
    camera.location = (0.0, 0.0, 10.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.world = bpy.data.worlds.new("black")
    render = scene.render
    render.engine = "CYCLES"
    render.resolution_x, render.resolution_y, render.resolution_percentage = n * CELL, CELL, 100
    render.image_settings.file_format, render.image_settings.color_depth = "OPEN_EXR", "32"
    scene.view_settings.view_transform, scene.view_settings.look = "Standard", "None"
    scene.cycles.device, scene.cycles.samples, scene.cycles.shading_system = "CPU", 1, True
    scene.cycles.use_denoising, scene.cycles.use_adaptive_sampling = False, False
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    with tempfile.TemporaryDirectory() as folder:
        render.filepath = str(Path(folder) / "points.exr")
        bpy.ops.render.render(write_still=True)
        image = bpy.data.images.load(render.filepath)
        pixels = [0.0] * (image.size[0] * image.size[1] * 4)
        image.pixels.foreach_get(pixels)
    width = n * CELL
    out = []
    for i in range(n):
        inner = [
            pixels[4 * (row * width + col) : 4 * (row * width + col) + 3]
            for row in (1, 2)
            for col in (i * CELL + 1, i * CELL + 2)
        ]
        out.append([sum(p[c] for p in inner) / len(inner) for c in range(3)])
    return out


if __name__ == "__main__":
    job_path, result_path = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:3]
    job = json.loads(Path(job_path).read_text())
    Path(result_path).write_text(json.dumps({"rgb": render(job), "blender": bpy.app.version_string}))
