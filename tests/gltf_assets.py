"""glTF inputs for the tests: the Khronos sample assets with KHR_materials_iridescence rebuilt from the facts
in tests/fixtures/khronos_iridescence.json (khronos_document, khronos_gltf: materials, textures, meshes and
variants as the assets write them, no geometry), stand-ins of them on generated geometry and images
(stand_in), and hand-written assets (.gltf and .glb)."""

import copy
import itertools
import json
import struct
from pathlib import Path

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "khronos_iridescence.json"
KHRONOS = json.loads(FIXTURE.read_text())["assets"]
SHOWCASE = [
    "CompareIridescence",
    "IridescenceAbalone",
    "IridescenceLamp",
    "IridescenceSuzanne",
    "IridescentDishWithOlives",
    "SunglassesKhronos",
    "CarConcept",
]
SPHERE_GRIDS = ["IridescenceDielectricSpheres", "IridescenceMetallicSpheres"]


def credit_line(name: str) -> str:
    """Who made the Khronos asset NAME, its license and where it comes from, in one line."""
    c = KHRONOS[name]["credit"]
    notice = f" ({c['notice']})" if "notice" in c else ""
    return f"{c['authors']}, {c['year']}, {c['license']}{notice}; {c['repository']} {c['path']} at {c['commit']}"


def khronos_document(name: str) -> dict:
    """The Khronos asset NAME as a glTF 2.0 document built from the fixture: its materials, textures,
    samplers, image names and KHR_materials_variants as the asset writes them, one node per mesh, one
    primitive per mesh with no attributes (lutbake reads no geometry) and no buffers."""
    facts = KHRONOS[name]
    if "grid" in facts:
        materials = _grid_materials(facts)
        meshes = [{"material": i} for i in range(len(materials))]
    else:
        materials = _table(facts["materials"], facts.get("material_count", 0))
        meshes = facts["meshes"]
    doc = document(
        materials,
        [_mesh(m) for m in meshes],
        asset={
            "version": "2.0",
            "copyright": credit_line(name),
            "generator": "lutbake tests/gltf_assets.py from tests/fixtures/khronos_iridescence.json",
        },
        nodes=[{"mesh": k, **({"name": m["name"]} if "name" in m else {})} for k, m in enumerate(meshes)],
        scenes=[{"nodes": list(range(len(meshes)))}],
        scene=0,
    )
    for key in ("textures", "samplers"):
        if key in facts:
            doc[key] = _table(facts[key])
    if "images" in facts:
        doc["images"] = [{"uri": uri} if uri else {} for uri in _table(facts["images"])]
    if "variants" in facts:
        doc["extensions"] = {"KHR_materials_variants": {"variants": [{"name": v} for v in facts["variants"]]}}
    doc["extensionsUsed"] = facts.get("extensionsUsed") or sorted(
        {e for m in materials for e in m.get("extensions", {})}
    )
    return doc


def khronos_gltf(name: str, folder: Path) -> Path:
    """khronos_document(NAME) written to FOLDER/NAME.gltf."""
    folder.mkdir(parents=True, exist_ok=True)
    return write_gltf(folder / f"{name}.gltf", khronos_document(name))


def _table(value, count: int = 0) -> list:
    """A fixture table as a glTF array: a list as it is; {index: entry} (the entries the fixture carries)
    with {} at the other indices, at least ``count`` long."""
    if isinstance(value, list):
        return copy.deepcopy(value)
    length = max([count] + [int(i) + 1 for i in value])
    return [copy.deepcopy(value.get(str(i), {})) for i in range(length)]


def _grid_materials(facts: dict) -> list:
    """A sphere grid's materials, the first axis slowest: the sphere template with each axis's value at its
    key (left out where the asset omits it), then the materials after the spheres."""
    materials = []
    for values in itertools.product(*(axis["values"] for axis in facts["grid"])):
        material = copy.deepcopy(facts["sphere"])
        for axis, value in zip(facts["grid"], values):
            if value != axis.get("omitted_at"):
                *parents, key = axis["key"].split(".")
                node = material
                for parent in parents:
                    node = node.setdefault(parent, {})
                node[key] = value
        materials.append(material)
    return materials + copy.deepcopy(facts["after"])


def _mesh(facts: dict) -> dict:
    """A mesh of one primitive using the fixture's material, and per variant (KHR_materials_variants) the
    material that variant maps it to."""
    primitive = {"attributes": {}, "material": facts["material"]}
    if "variants" in facts:
        mappings = [{"material": m, "variants": [v]} for v, m in enumerate(facts["variants"])]
        primitive["extensions"] = {"KHR_materials_variants": {"mappings": mappings}}
    return {**({"name": facts["name"]} if "name" in facts else {}), "primitives": [primitive]}


def document(materials, meshes=None, **extra) -> dict:
    """A glTF 2.0 document: ``materials``, one mesh per material using it unless ``meshes`` is given."""
    if meshes is None:
        meshes = [{"primitives": [{"attributes": {}, "material": i}]} for i in range(len(materials))]
    return {"asset": {"version": "2.0"}, "materials": materials, "meshes": meshes, **extra}


def iridescent(
    ior=1.3,
    d_max=400.0,
    d_min=None,
    thickness_texture=False,
    base_ior=None,
    metallic=0.0,
    colour=None,
    name=None,
    **keys,
) -> dict:
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


def _sphere(stacks: int = 24, slices: int = 48):
    """A unit UV sphere: (positions, normals, uvs, indices) as float32/uint16 arrays."""
    import numpy as np

    v, u = np.meshgrid(np.linspace(0, 1, stacks + 1), np.linspace(0, 1, slices + 1), indexing="ij")
    theta, phi = v * np.pi, u * 2 * np.pi
    normals = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], -1).reshape(-1, 3)
    uvs = np.stack([u, v], -1).reshape(-1, 2)
    row = slices + 1
    quads = [
        (i * row + j, (i + 1) * row + j, i * row + j + 1, (i + 1) * row + j + 1)
        for i in range(stacks)
        for j in range(slices)
    ]
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
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3", "min": [-1, -1, -1], "max": [1, 1, 1]},
        {"bufferView": 1, "componentType": 5126, "count": count, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": count, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
    ]
    textures = doc.get("textures", [])
    images = max([t.get("source", 0) for t in textures] + [-1]) + 1
    for i in range(images):
        _gradient_png(folder / f"{name}-image{i}.png", i)
    used = [i for i, m in enumerate(doc["materials"]) if "KHR_materials_iridescence" in m.get("extensions", {})]
    attributes = {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "TEXCOORD_1": 2}
    out = {
        "asset": doc["asset"],
        "materials": doc["materials"],
        "textures": [
            {"source": t.get("source", 0), **({"sampler": t["sampler"]} if "sampler" in t else {})} for t in textures
        ],
        "samplers": doc.get("samplers", []),
        "images": [{"uri": f"{name}-image{i}.png"} for i in range(images)],
        "buffers": [{"uri": f"{name}.bin", "byteLength": int(offsets[-1])}],
        "bufferViews": views,
        "accessors": accessors,
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 3, "material": i}]} for i in used],
        "nodes": [{"mesh": k} for k in range(len(used))],
        "scenes": [{"nodes": list(range(len(used)))}],
        "scene": 0,
        "extensionsUsed": doc.get("extensionsUsed", []),
    }
    return write_gltf(folder / f"{name}.gltf", out)
