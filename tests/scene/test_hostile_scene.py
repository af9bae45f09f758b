"""Hostile inputs on the scene path (issue 27's scene items, issue 23's malformed glTF): scene files that
alias outputs, nested documents, cache entries that lie, edited manifests, signals during a many-material
bake, 10^5 materials, the optical-path limit, truncated and malformed glTF/GLB. The verdict is
tests/hostile_cases.run_case's: exit 0/1/2, no traceback, one line and nothing written on exit 2."""

import json
import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from gltf_assets import document, glb_bytes, iridescent
from hostile_cases import run_case

SCENE = "[materials.soap]\nfilm = 1.33\nthickness_nm = [200, 400]\nbase = 1.0\n"
NUMPY = ["--backend", "numpy", "--quiet"]


def _tree(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@pytest.mark.parametrize("name", ["s.json", "s.glsl", "s.hlsl", "s.exr"])
def test_a_scene_file_named_like_its_own_output_is_refused(name, tmp_path, capfd, monkeypatch):
    (tmp_path / "T").mkdir()
    (tmp_path / "T" / name).write_text(SCENE)
    _, _, err = run_case(["bake", "--scene", f"T/{name}", "--out", "T", *NUMPY], tmp_path, capfd, monkeypatch, {2})
    assert "would overwrite its input" in err and (tmp_path / "T" / name).read_text() == SCENE


def test_a_deeply_nested_scene_file_is_one_line(tmp_path, capfd, monkeypatch):
    (tmp_path / "s.toml").write_text(SCENE + "x = " + "[" * 5000 + "]" * 5000 + "\n")
    _, _, err = run_case(["plan", "--scene", "s.toml"], tmp_path, capfd, monkeypatch, {2})
    assert "nests 5000 levels deep" in err


def _bake_reference(tmp_path, capfd, monkeypatch) -> dict:
    (tmp_path / "s.toml").write_text(SCENE)
    run_case(["bake", "--scene", "s.toml", "--out", "T", *NUMPY], tmp_path, capfd, monkeypatch, {0})
    return _tree(tmp_path / "T")


def _cache_entry(out: Path) -> tuple:
    npy = next((out / ".lutbake-cache").glob("slice-*.npy"))
    return npy, npy.with_suffix(".json")


@pytest.mark.parametrize("damage", ["zeroed", "huge header", "nested record", "record hash edited"])
def test_a_cache_entry_that_lies_is_recomputed(damage, tmp_path, capfd, monkeypatch):
    """A cache entry whose bytes are not what its record hashed (zeroed but a valid .npy of the right
    shape), whose header declares an 8 TB array (refused before np.load allocates), or whose record is
    deeply nested or hand-edited, is recomputed: the forced re-bake gives the first bake's bytes."""
    reference = _bake_reference(tmp_path, capfd, monkeypatch)
    npy, record = _cache_entry(tmp_path / "T")
    values = np.load(npy)
    if damage == "zeroed":
        np.save(npy, np.zeros_like(values))
    elif damage == "huge header":
        header = {"descr": "<f8", "fortran_order": False, "shape": (1 << 20, 1 << 20, 3)}
        with open(npy, "wb") as fh:
            np.lib.format.write_array_header_1_0(fh, header)
    elif damage == "nested record":
        record.write_text("[" * 5000 + "]" * 5000)
    else:
        info = json.loads(record.read_text())
        np.save(npy, values * 0.5)
        record.write_text(json.dumps({**info, "counts": info["counts"]}))
    (tmp_path / "T" / "s.json").unlink()  # not up to date: the slice comes from the cache or is recomputed
    run_case(["bake", "--scene", "s.toml", "--out", "T", *NUMPY], tmp_path, capfd, monkeypatch, {0})
    assert _tree(tmp_path / "T") == reference


def test_an_edited_manifest_is_not_up_to_date(tmp_path, capfd, monkeypatch):
    reference = _bake_reference(tmp_path, capfd, monkeypatch)
    manifest = tmp_path / "T" / "s.json"
    doc = json.loads(manifest.read_text())
    doc["materials"]["soap"]["de00_p99"] = 0.001  # a better error than was reached: a lie
    manifest.write_text(json.dumps(doc, indent=2) + "\n")
    _, out, _ = run_case(
        ["bake", "--scene", "s.toml", "--out", "T", "--json", *NUMPY], tmp_path, capfd, monkeypatch, {0}
    )
    assert json.loads(out)["up_to_date"] is False and _tree(tmp_path / "T") == reference
    manifest.write_text("[" * 5000 + "]" * 5000)  # nested past the bound: re-baked, no traceback
    run_case(["bake", "--scene", "s.toml", "--out", "T", *NUMPY], tmp_path, capfd, monkeypatch, {0})
    assert _tree(tmp_path / "T") == reference


def test_a_scene_past_the_optical_path_limit_names_its_field_and_writes_nothing(tmp_path, capfd, monkeypatch):
    (tmp_path / "s.toml").write_text(
        "[materials.a]\nfilm = 1.5\nthickness_nm = 100\nbase = 1.0\n"
        "[materials.thick]\nfilm = 2.0\nthickness_nm = [100, 60000]\nbase = 1.5\n"
    )
    _, _, err = run_case(["bake", "--scene", "s.toml", "--out", "T", *NUMPY], tmp_path, capfd, monkeypatch, {2})
    assert "s.toml:7: materials.thick.thickness_nm: the optical path" in err and "--opd" not in err
    assert not (tmp_path / "T").exists()
    doc = document([iridescent(ior=2.5, d_max=90000.0)])
    (tmp_path / "a.gltf").write_text(json.dumps(doc))
    _, _, err = run_case(["bake", "--gltf", "a.gltf", "--out", "G", *NUMPY], tmp_path, capfd, monkeypatch, {2})
    assert "KHR_materials_iridescence.iridescenceThicknessMaximum: the optical path" in err


def test_plan_of_100000_materials_finishes(tmp_path, capfd, monkeypatch):
    """No per-material O(ms) work: the plan of 10^5 materials in 97,000 distinct slices (film cycles every
    1,000 materials, thickness every 97; the ground-truth rate sampled on 8 jobs) ends well inside the
    hostile table's guard."""
    text = "".join(
        f"[materials.m{i}]\nfilm = {1.2 + (i % 1000) * 1e-3}\nthickness_nm = [100, {200 + i % 97}]\nbase = 1.5\n"
        for i in range(100_000)
    )
    (tmp_path / "s.toml").write_text(text)
    start = time.perf_counter()
    _, out, _ = run_case(["plan", "--scene", "s.toml", "--json"], tmp_path, capfd, monkeypatch, {0})
    assert len(json.loads(out)["jobs"]) == 97_000 and time.perf_counter() - start < 120


def _many_materials(folder: Path, n: int = 60) -> None:
    folder.mkdir()
    (folder / "s.toml").write_text(
        "".join(
            f"[materials.m{i}]\nfilm = {1.3 + 0.01 * i}\nthickness_nm = [100, 900]\n"
            f"base = {{ eta3 = 1.6, kappa3 = {0.1 * i} }}\n"
            for i in range(n)
        )
    )


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_stops_a_many_material_bake_at_once_and_leaves_nothing(sig, code, tmp_path):
    """60 slices queued: the signal lands while the first ones refine; queued ground truths are cancelled, not
    awaited. Within a few seconds (under load), exit 128 + signal, no set, no temporary, no journal."""
    _many_materials(tmp_path / "w")
    proc = subprocess.Popen(
        [sys.executable, "-m", "lutbake.cli", "bake", "--scene", "s.toml", "--out", "T", "--progress"],
        cwd=tmp_path / "w",
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.time() + 120
    while (
        not list((tmp_path / "w" / "T" / ".lutbake-cache").glob("*.npy")) if (tmp_path / "w" / "T").exists() else True
    ):
        assert proc.poll() is None and time.time() < deadline, "the bake ended before a slice was cached"
        time.sleep(0.05)
    sent = time.time()
    proc.send_signal(sig)
    proc.wait(timeout=60)
    stopped = time.time() - sent
    assert proc.returncode == code, proc.stderr.read()
    assert stopped < 5.0, stopped
    left = sorted(p.name for p in (tmp_path / "w" / "T").iterdir())
    assert left == [
        ".lutbake-cache"
    ]  # completed slices stay cached (content-hashed); no set member, temporary or journal
    assert all(p.suffix in (".npy", ".json") for p in (tmp_path / "w" / "T" / ".lutbake-cache").iterdir())


# --- malformed glTF / GLB ------------------------------------------------------------------------


def _glb(doc, binary=None) -> bytes:
    return glb_bytes(doc, binary)


_VALID = document([iridescent()])
MALFORMED = {
    "truncated GLB": (lambda: _glb(_VALID)[:40], "a.glb", "declares"),
    "GLB header past the file": (lambda: struct.pack("<III", 0x46546C67, 2, 10**9) + b"\0" * 8, "a.glb", "declares"),
    "GLB chunk past the end": (
        lambda: struct.pack("<III", 0x46546C67, 2, 24) + struct.pack("<II", 10**6, 0x4E4F534A) + b"{}  ",
        "a.glb",
        "past the end",
    ),
    "GLB version 1": (lambda: struct.pack("<III", 0x46546C67, 1, 12), "a.glb", "version 1"),
    "not JSON": (lambda: b"{materials: [", "a.gltf", "not JSON"),
    "not UTF-8": (lambda: b"\xff\xfe{}", "a.gltf", "not UTF-8"),
    "no asset": (lambda: json.dumps({"materials": []}).encode(), "a.gltf", "asset.version"),
    "materials not an array": (
        lambda: json.dumps({**_VALID, "materials": {"a": 1}}).encode(),
        "a.gltf",
        "materials: must be an array",
    ),
    "iridescenceIor a string": (
        lambda: json.dumps(document([iridescent(ior="1.5")])).encode(),
        "a.gltf",
        "iridescenceIor = '1.5' is not a number",
    ),
    "primitive material out of range": (
        lambda: json.dumps(
            document([iridescent()], meshes=[{"primitives": [{"attributes": {}, "material": 7}]}])
        ).encode(),
        "a.gltf",
        "material = 7",
    ),
    "variant out of range": (
        lambda: json.dumps(
            document(
                [iridescent()],
                meshes=[
                    {
                        "primitives": [
                            {
                                "attributes": {},
                                "extensions": {
                                    "KHR_materials_variants": {"mappings": [{"material": 0, "variants": [3]}]}
                                },
                            }
                        ]
                    }
                ],
            )
        ).encode(),
        "a.gltf",
        "variants[0] = 3",
    ),
    "GLB buffer without a binary chunk": (
        lambda: _glb({**_VALID, "buffers": [{"byteLength": 64}]}),
        "a.glb",
        "not the .glb's binary chunk",
    ),
    "buffer view of a missing buffer": (
        lambda: json.dumps({**_VALID, "bufferViews": [{"buffer": 2, "byteLength": 4}]}).encode(),
        "a.gltf",
        "bufferViews[0].buffer = 2",
    ),
    "huge accessor count": (
        lambda: _glb(
            {
                **_VALID,
                "buffers": [{"byteLength": 8}],
                "bufferViews": [{"buffer": 0, "byteLength": 8}],
                "accessors": [{"bufferView": 0, "componentType": 5126, "count": 10**12, "type": "VEC3"}],
            },
            b"\0" * 8,
        ),
        "a.glb",
        "count = 1,000,000,000,000",
    ),
    "huge material count": (
        lambda: json.dumps({**_VALID, "materials": [{}] * 100_001}).encode(),
        "a.gltf",
        "100,001 items",
    ),
    "truncated external buffer": (
        lambda: json.dumps({**_VALID, "buffers": [{"uri": "a.bin", "byteLength": 10**6}]}).encode(),
        "a.gltf",
        "truncated",
    ),
    "nested 5000 deep": (lambda: b"[" * 5000 + b"]" * 5000, "a.gltf", "nests 5000 levels deep"),
    "negative thickness": (
        lambda: json.dumps(document([iridescent(d_max=-5.0)])).encode(),
        "a.gltf",
        "iridescenceThicknessMaximum = -5.0 is not allowed",
    ),
    "film index past lutbake's domain": (
        lambda: json.dumps(document([iridescent(ior=50.0)])).encode(),
        "a.gltf",
        "iridescenceIor = 50.0 is not allowed",
    ),
    "unknown metal mapping": (lambda: json.dumps(_VALID).encode(), "a.gltf", "metal mapping 'gold'"),
    # issue 35, cause 1: integers past 2^64 never reach numpy
    "iridescenceIor 2^64": (
        lambda: json.dumps(document([iridescent(ior=2**64)])).encode(),
        "a.gltf",
        "outside ±2^53",
    ),
    "thickness maximum -2^64 in a GLB": (
        lambda: _glb(document([iridescent(d_max=-(2**64))])),
        "a.glb",
        "outside ±2^53",
    ),
    # issue 35, cause 2: accessor and buffer-view fields typed before use
    "componentType a list": (lambda: _accessor({"componentType": [5126]}), "a.glb", "componentType = [5126]"),
    "type a number": (lambda: _accessor({"type": 3}), "a.glb", "type = 3 is not one"),
    "byteStride null": (lambda: _accessor(view={"byteStride": None}), "a.glb", "byteStride = None"),
    "byteStride a string, count 2^33": (
        lambda: _accessor({"count": 2**33}, view={"byteStride": "12"}),
        "a.glb",
        "byteStride = '12'",
    ),
    "byteStride 2": (lambda: _accessor(view={"byteStride": 2}), "a.glb", "byteStride = 2"),
    "byteStride under the element": (lambda: _accessor(view={"byteStride": 8}), "a.glb", "shorter than"),
}


def _accessor(fields=None, view=None) -> bytes:
    """A GLB with one 48-byte buffer, one view over it and one VEC3 float accessor (``fields`` and ``view``
    override theirs)."""
    return _glb(
        {
            **_VALID,
            "buffers": [{"byteLength": 48}],
            "bufferViews": [{"buffer": 0, "byteLength": 48, **(view or {})}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", **(fields or {})}],
        },
        b"\0" * 48,
    )


@pytest.mark.parametrize("case", list(MALFORMED))
def test_malformed_gltf_is_one_line_exit_2_and_writes_nothing(case, tmp_path, capfd, monkeypatch):
    make, name, message = MALFORMED[case]
    (tmp_path / name).write_bytes(make())
    (tmp_path / "a.bin").write_bytes(b"\0" * 16)
    mapping = ["--metal-mapping", "gold"] if case == "unknown metal mapping" else []
    for command in (["plan", "--gltf", name], ["bake", "--gltf", name, "--out", "T", *NUMPY]):
        _, _, err = run_case([*command, *mapping], tmp_path, capfd, monkeypatch, {2})
        assert message in err, err
    assert not (tmp_path / "T").exists()


def test_report_on_a_manifest_that_is_no_gltf_bake_is_one_line(tmp_path, capfd, monkeypatch):
    (tmp_path / "m.json").write_text(json.dumps({"format": "lutbake-scene-manifest"}))
    _, _, err = run_case(["report", "m.json"], tmp_path, capfd, monkeypatch, {2})
    assert "format is not 'lutbake-scene-manifest' version 1" in err
    (tmp_path / "s.toml").write_text(SCENE)
    run_case(["bake", "--scene", "s.toml", "--out", "T", *NUMPY], tmp_path, capfd, monkeypatch, {0})
    _, _, err = run_case(["report", "T/s.json"], tmp_path, capfd, monkeypatch, {2})
    assert "not the manifest of a glTF bake" in err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["plan", "--scene", "s.toml", "--gltf", "a.gltf"], "give exactly one of --scene FILE.toml or --gltf"),
        (["plan"], "give exactly one of --scene FILE.toml or --gltf"),
        (["plan", "--scene", "s.toml", "--metal-mapping", "threejs"], "--metal-mapping applies to --gltf only"),
        (
            ["bake", "--eta2", "1.5", "--metal-mapping", "threejs", "--out", "x.exr"],
            "--metal-mapping applies to --gltf",
        ),
        (["bake", "--gltf", "a.gltf", "--opd", "0:100:8", "--out", "T"], "--opd cannot be combined with --gltf"),
        (["bake", "--gltf", "a.gltf", "--out", "T.exr"], "a scene bakes into a folder"),
    ],
)
def test_gltf_flag_conflicts_are_one_line(argv, message, tmp_path, capfd, monkeypatch):
    (tmp_path / "s.toml").write_text(SCENE)
    (tmp_path / "a.gltf").write_text(json.dumps(_VALID))
    _, _, err = run_case(argv, tmp_path, capfd, monkeypatch, {2})
    assert message in err, err


# --- issue 35, cause 13: buffer URIs consult nothing outside the asset's folder --------------------------


@pytest.mark.parametrize(
    "uri", ["../outside.bin", "/OUTSIDE", "sub/../../outside.bin", "%2E%2E/outside.bin", "link.bin"]
)
def test_a_buffer_uri_outside_the_asset_folder_is_never_looked_at(uri, tmp_path, capfd, monkeypatch):
    """Whether the outside file exists, and how long it is, changes neither the exit code nor the output:
    the URI is an engine's business (a warning), never stat()ed."""
    asset = tmp_path / "asset"
    asset.mkdir()
    (asset / "sub").mkdir()
    os.symlink("../outside.bin", asset / "link.bin")
    uri = uri.replace("/OUTSIDE", str(tmp_path / "outside.bin"))
    (asset / "a.gltf").write_text(json.dumps({**_VALID, "buffers": [{"uri": uri, "byteLength": 10**6}]}))
    seen = []
    for outside in (None, 10, 2 * 10**6):
        if outside is not None:
            (tmp_path / "outside.bin").write_bytes(b"\0" * outside)
        rc, _, err = run_case(["plan", "--gltf", "asset/a.gltf"], tmp_path, capfd, monkeypatch, {0})
        assert "not a file in the asset's folder" in err and "1,000,000" not in err, err
        seen.append((rc, err))  # (the plan's output holds a timing measured just now)
    assert seen[0] == seen[1] == seen[2]


def test_a_buffer_uri_inside_the_asset_folder_through_a_link_is_still_checked(tmp_path, capfd, monkeypatch):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "a.bin").write_bytes(b"\0" * 16)
    os.symlink("data/a.bin", tmp_path / "link.bin")
    (tmp_path / "a.gltf").write_text(json.dumps({**_VALID, "buffers": [{"uri": "link%2ebin", "byteLength": 64}]}))
    _, _, err = run_case(["plan", "--gltf", "a.gltf"], tmp_path, capfd, monkeypatch, {2})
    assert "holds 16 bytes (truncated)" in err
