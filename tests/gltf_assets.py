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
