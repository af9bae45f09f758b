"""glTF inputs for the tests: the Khronos sample assets' JSON in ../shared/gltf-assets/ (read there, never
copied), glTF files written from their extracts, and hand-written ones (.gltf and .glb)."""

import json
import struct
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def shared_folder() -> Path:
    """../shared beside the repository; in a git worktree, beside its main checkout."""
    beside = ROOT.parent / "shared"
    if beside.is_dir():
        return beside
    common = subprocess.run(["git", "rev-parse", "--git-common-dir"], cwd=ROOT, capture_output=True, text=True)
    return (ROOT / common.stdout.strip()).resolve().parent.parent / "shared"


ASSETS = shared_folder() / "gltf-assets"
SHOWCASE = ["CompareIridescence", "IridescenceAbalone", "IridescenceLamp", "IridescenceSuzanne",
            "IridescentDishWithOlives", "SunglassesKhronos"]


def asset_path(name: str) -> Path:
    return ASSETS / name / f"{name}.gltf"


def document(materials, meshes=None, **extra) -> dict:
    """A glTF 2.0 document: ``materials``, one mesh per material using it unless ``meshes`` is given."""
    if meshes is None:
        meshes = [{"primitives": [{"attributes": {}, "material": i}]} for i in range(len(materials))]
    return {"asset": {"version": "2.0"}, "materials": materials, "meshes": meshes, **extra}


def iridescent(ior=1.3, d_max=400.0, d_min=None, thickness_texture=False, base_ior=None, metallic=0.0,
               colour=None, name=None, **keys) -> dict:
    """A material with KHR_materials_iridescence (``keys`` go into the extension as they are)."""
    ext = {"iridescenceFactor": 1.0, "iridescenceIor": ior, "iridescenceThicknessMaximum": d_max, **keys}
    if d_min is not None:
        ext["iridescenceThicknessMinimum"] = d_min
    if thickness_texture:
        ext["iridescenceThicknessTexture"] = {"index": 0}
    exts = {"KHR_materials_iridescence": ext}
    if base_ior is not None:
        exts["KHR_materials_ior"] = {"ior": base_ior}
    pbr = {"metallicFactor": metallic}
    if colour is not None:
        pbr["baseColorFactor"] = [*colour, 1.0]
    out = {"extensions": exts, "pbrMetallicRoughness": pbr}
    return out if name is None else {"name": name, **out}


def write_gltf(path: Path, doc: dict) -> Path:
    path.write_text(json.dumps(doc))
    return path


def glb_bytes(doc: dict, binary: bytes | None = None) -> bytes:
    """A GLB container (glTF 2.0, section 4.4): header, JSON chunk (space-padded), optional BIN chunk."""
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text
    if binary is not None:
        binary += b"\0" * (-len(binary) % 4)
        chunks += struct.pack("<II", len(binary), 0x004E4942) + binary
    return struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks


def car_concept(path: Path) -> Path:
    """CarConcept as far as its extract holds it: materials 22 and 25 verbatim, the others plain, and
    two body meshes mapping 11/22/23 and 10/24/25 to the three variants (KHR_materials_variants)."""
    extract = json.loads((ASSETS / "CarConcept" / "materials-extract.json").read_text())
    materials = [{"name": f"material {i}"} for i in range(26)]
    for index, body in extract["materials"].items():
        materials[int(index)] = body

    def body(default, variants):
        mappings = [{"material": m, "variants": [v]} for v, m in enumerate(variants)]
        return {"primitives": [{"attributes": {}, "material": default,
                                "extensions": {"KHR_materials_variants": {"mappings": mappings}}}]}

    doc = document(materials, [body(11, (11, 22, 23)), body(10, (24, 24, 25))],
                   textures=[{} for _ in range(15)],
                   extensions={"KHR_materials_variants": {"variants": [{"name": n} for n in extract["variants"]]}})
    return write_gltf(path, doc)


def sphere_grid(name: str, path: Path) -> Path:
    """A sphere-grid asset (IridescenceDielectricSpheres / IridescenceMetallicSpheres) written from its
    extract: one material per sphere, each used by one primitive."""
    extract = json.loads((ASSETS / name / "materials-extract.json").read_text())
    materials = []
    for m in extract["materials"]:
        grey = m.get("baseColorGrey", 0.8)
        ext = {"KHR_materials_iridescence": {"iridescenceFactor": 1, "iridescenceIor": m["iridescenceIor"],
                                             "iridescenceThicknessMaximum": m["thickness_nm"]}}
        if "ior" in m:
            ext["KHR_materials_ior"] = {"ior": m["ior"]}
        materials.append({"extensions": ext, "pbrMetallicRoughness": {
            "metallicFactor": m["metallicFactor"], "baseColorFactor": [grey, grey, grey, 1], "roughnessFactor": 0.1}})
    return write_gltf(path, document(materials))


def _sphere(stacks: int = 24, slices: int = 48):
    """A unit UV sphere: (positions, normals, uvs, indices) as float32/uint16 arrays."""
    import numpy as np

    v, u = np.meshgrid(np.linspace(0, 1, stacks + 1), np.linspace(0, 1, slices + 1), indexing="ij")
    theta, phi = v * np.pi, u * 2 * np.pi
    normals = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], -1).reshape(-1, 3)
    uvs = np.stack([u, v], -1).reshape(-1, 2)
    row = slices + 1
    quads = [(i * row + j, (i + 1) * row + j, i * row + j + 1, (i + 1) * row + j + 1)
             for i in range(stacks) for j in range(slices)]
    indices = np.array([(a, c, b, c, d, b) for a, b, c, d in quads], dtype=np.uint16).ravel()
    return normals.astype(np.float32), normals.astype(np.float32), uvs.astype(np.float32), indices


def _gradient_png(path: Path, seed: int) -> None:
    """A 32×32 RGB texture whose channels vary across it (thickness in G, metalness in B, colour in RGB)."""
    import numpy as np
    from PIL import Image

    y, x = np.mgrid[0:32, 0:32] / 31.0
    phase = seed * 0.7
    rgb = np.stack([0.5 + 0.5 * np.sin(6 * x + phase), y, 0.5 + 0.5 * np.cos(5 * (x + y) + phase)], -1)
    Image.fromarray((rgb * 255).round().astype("uint8")).save(path)


def stand_in(doc: dict, folder: Path, name: str) -> Path:
    """The asset's materials, textures and samplers as they are, on generated geometry and images: one unit
    sphere per material that has KHR_materials_iridescence, each its own mesh and node (the material used
    directly, variants included), gradient PNGs for every image. Written to FOLDER/NAME.gltf + .bin."""
    import numpy as np

    folder.mkdir(parents=True, exist_ok=True)
    positions, normals, uvs, indices = _sphere()
    blobs = [positions.tobytes(), normals.tobytes(), uvs.tobytes(), indices.tobytes()]
    offsets = np.cumsum([0] + [len(b) for b in blobs])
    (folder / f"{name}.bin").write_bytes(b"".join(blobs))
    views = [{"buffer": 0, "byteOffset": int(o), "byteLength": len(b)} for o, b in zip(offsets, blobs)]
    count = len(positions)
    accessors = [{"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3",
                  "min": [-1, -1, -1], "max": [1, 1, 1]},
                 {"bufferView": 1, "componentType": 5126, "count": count, "type": "VEC3"},
                 {"bufferView": 2, "componentType": 5126, "count": count, "type": "VEC2"},
                 {"bufferView": 3, "componentType": 5123, "count": len(indices), "type": "SCALAR"}]
    textures = doc.get("textures", [])
    images = max([t.get("source", 0) for t in textures] + [-1]) + 1
    for i in range(images):
        _gradient_png(folder / f"{name}-image{i}.png", i)
    used = [i for i, m in enumerate(doc["materials"]) if "KHR_materials_iridescence" in m.get("extensions", {})]
    attributes = {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "TEXCOORD_1": 2}
    out = {"asset": {"version": "2.0"}, "materials": doc["materials"],
           "textures": [{"source": t.get("source", 0), **({"sampler": t["sampler"]} if "sampler" in t else {})}
                        for t in textures],
           "samplers": doc.get("samplers", []), "images": [{"uri": f"{name}-image{i}.png"} for i in range(images)],
           "buffers": [{"uri": f"{name}.bin", "byteLength": int(offsets[-1])}], "bufferViews": views,
           "accessors": accessors,
           "meshes": [{"primitives": [{"attributes": attributes, "indices": 3, "material": i}]} for i in used],
           "nodes": [{"mesh": k} for k in range(len(used))], "scenes": [{"nodes": list(range(len(used)))}],
           "scene": 0, "extensionsUsed": doc.get("extensionsUsed", [])}
    return write_gltf(folder / f"{name}.gltf", out)
