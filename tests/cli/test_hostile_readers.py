"""Hostile inputs of issue 35 (reliability round 4): every reader bounded and typed the same way (JSON
integers, the runtime table's header, manifests, metal mappings, FIFOs), names that reach shaders and
terminals, Blender's failures, and what a refused bake leaves behind.

Every case gets the verdict of tests/cli/test_hostile.py's run_case (exit 0/1/2, no traceback, one stderr
line and nothing written on exit 2, no hang past 60 s); cases that need a fresh process run the CLI as one.
"""

import json
import os
import signal
import struct
import threading
from pathlib import Path

import pytest
from hostile_cases import run_case
from hostile_exr import patched_attribute, write_like

from lutbake.io import documents
from lutbake.modes.runtime.files import read_runtime_table, write_runtime_table
from lutbake.tables import headers, lutfile
from lutbake.tables.lutfile import read_lut

FORMATS = (headers.FORMAT, headers.ATLAS_FORMAT, headers.EXACT_FORMAT, headers.RUNTIME_FORMAT)


def _never_read(path, structure):
    raise AssertionError("pixels read before the header was validated")


@pytest.fixture(scope="module")
def runtime_table(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("runtime") / "rt.exr"
    write_runtime_table(path)
    return path


def _numbers(doc, path=()):
    """(path, value) of every number (not a boolean) in a JSON document."""
    if isinstance(doc, (int, float)) and not isinstance(doc, bool):
        yield path, doc
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for key, value in items:
        yield from _numbers(value, (*path, key))


def _edited(meta: dict, path: tuple, value) -> dict:
    edited = json.loads(json.dumps(meta))
    parent = edited
    for key in path[:-1]:
        parent = parent[key]
    parent[path[-1]] = value
    return edited


# --- cause 6: the runtime table's reader runs the header checks of every table kind ---------------------


@pytest.mark.parametrize(
    "edit",
    [
        "metadata a list",
        "band_rows 10^9",
        "tiles_per_row 0",
        "slices a string",
        "width past the image",
        "white of 4 values",
    ],
)
def test_a_tampered_runtime_table_is_refused_before_its_pixels(edit, runtime_table, tmp_path, monkeypatch):
    meta, image = read_lut(runtime_table, (headers.RUNTIME_FORMAT,))
    table = meta["table"]
    edited = {
        "metadata a list": [meta],
        "band_rows 10^9": _edited(meta, ("table", "band_rows"), 10**9),
        "tiles_per_row 0": _edited(meta, ("table", "tiles_per_row"), 0),
        "slices a string": _edited(meta, ("table", "slices"), "129" * 10**6),
        "width past the image": _edited(meta, ("table", "width"), table["width"] * 12000),
        "white of 4 values": _edited(meta, ("table", "white"), [1.0] * 4),
    }[edit]
    write_like(tmp_path / "bad.exr", image, edited, "RGBA")
    monkeypatch.setattr(lutfile, "read_pixels", _never_read)
    with pytest.raises(ValueError) as refused:
        read_runtime_table(tmp_path / "bad.exr")
    assert "bad.exr" in str(refused.value) and "\n" not in str(refused.value)


def test_a_runtime_table_declaring_12000_squared_texels_is_refused_before_allocation(
    runtime_table, tmp_path, monkeypatch
):
    """A genuine table's bytes with its data window set to 12000 x 12000 (1.15 GB of half RGBA, which ZIP's
    1032:1 bound lets 1.2 MB declare): the header's image size refuses it before any pixel is read."""
    data = patched_attribute(runtime_table.read_bytes(), "dataWindow", "box2i", struct.pack("<4i", 0, 0, 11999, 11999))
    (tmp_path / "big.exr").write_bytes(data)
    monkeypatch.setattr(lutfile, "read_pixels", _never_read)
    with pytest.raises(ValueError, match="image size|cannot fit"):
        read_runtime_table(tmp_path / "big.exr")


# --- cause 7: a runtime table's file name reaches its includes escaped ----------------------------------


@pytest.mark.parametrize("name", ["nl\n#error injected\n.exr", "back\\slash\\.exr", "ü\r.exr"])
def test_runtime_table_names_reach_includes_escaped(name, tmp_path, capfd, monkeypatch):
    _, out, _ = run_case(["runtime-table", "--out", name], tmp_path, capfd, monkeypatch, {0})
    assert len(out.splitlines()) == 1, out  # the terminal gets one line: the name escaped
    for suffix in (".glsl", ".hlsl"):
        text = (tmp_path / name).with_suffix(suffix).read_text()
        assert text.isascii() and not any(line.startswith("#error") for line in text.splitlines())
        assert not any(line.rstrip().endswith("\\") for line in text.splitlines() if line.startswith("//"))


# --- cause 1: JSON integers past ±2^53 are refused where JSON is parsed --------------------------------


@pytest.mark.parametrize("kind", ["lut", "atlas", "exact"])
def test_an_integer_past_2_to_the_64_in_a_header_is_one_line(kind, good_files, tmp_path, capfd, monkeypatch):  # noqa: F811
    """Every number of a LUT's, atlas's and exact table's header (v6 LUT, slices included) replaced in turn
    by 2^64 (which numpy cannot take) and by -2^53 - 1: refused in one line before a pixel is read."""
    meta, image = read_lut(good_files[kind], formats=FORMATS)
    monkeypatch.setattr(lutfile, "read_pixels", _never_read)
    numbers = list(_numbers(meta))
    for i, (path, _) in enumerate(numbers[:: max(1, len(numbers) // 12)]):
        write_like(tmp_path / "bad.exr", image, _edited(meta, path, 2**64 if i % 2 else -(2**53) - 1))
        if kind == "exact":
            with pytest.raises(ValueError, match="outside ±2\\^53") as refused:
                read_lut(tmp_path / "bad.exr", formats=(headers.EXACT_FORMAT,))
            assert "\n" not in str(refused.value)
            continue
        _, _, err = run_case(["inspect", "bad.exr"], tmp_path, capfd, monkeypatch, {2})
        assert "outside ±2^53" in err, (path, err)


def test_json_integers_are_bounded_at_parse_time():
    assert documents.load_json("[9007199254740992, -9007199254740992]", "x") == [2**53, -(2**53)]
    for text in ("18446744073709551616", "[-9007199254740993]", "1" + "0" * 5000):
        with pytest.raises(ValueError, match="outside ±2\\^53"):
            documents.load_json(text, "x")


# --- every reader: FIFOs, devices and folders refused before a read -------------------------------------


@pytest.mark.parametrize("kind", ["fifo", "device", "folder"])
def test_readers_refuse_what_is_not_a_regular_file_without_blocking(kind, tmp_path):
    path = tmp_path / "x"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    else:
        path = Path("/dev/zero")
    done = threading.Event()
    errors: list = []

    def read() -> None:
        for reader in (lambda: documents.read_text(path, "doc", 1 << 20), lambda: headers.exr_header(path)):
            try:
                reader()
            except ValueError as exc:
                errors.append(str(exc))
        done.set()

    threading.Thread(target=read, daemon=True).start()
    assert done.wait(30), f"reading a {kind} blocked"
    assert len(errors) == 2 and all("not a regular file" in e for e in errors), errors


# --- cause 3: the bounded JSON reader's memory follows the text, not 125 bytes per character ------------

_PEAK_SCRIPT = """
import sys
from lutbake.scene.gltf.asset import read_gltf
def kib(field):  # this address space's own figures (ru_maxrss would count the forking parent's)
    return next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith(field))
resident = kib("VmRSS:")
read_gltf(sys.argv[1])
print(kib("VmHWM:") - resident)
"""


def test_a_10_mb_gltf_with_an_embedded_buffer_costs_a_few_times_its_size(tmp_path):
    """The peak while reading a 10 MB .gltf whose buffer is a data: URI grows by at most 5 bytes per byte of
    the file (its bytes, its text, the parsed string, each once, and a fixed chunk for the nesting count);
    the regex that skipped strings before kept ~125 bytes of state per character (1.2 GB here)."""
    import base64
    import subprocess
    import sys

    path = tmp_path / "big.gltf"
    data = base64.b64encode(bytes(7_500_000)).decode()
    doc = {"asset": {"version": "2.0"}, "buffers": [{"uri": "data:;base64," + data, "byteLength": 7_500_000}]}
    path.write_text(json.dumps(doc))
    done = subprocess.run(
        [sys.executable, "-c", _PEAK_SCRIPT, str(path)], capture_output=True, text=True, timeout=60, check=True
    )
    growth_bytes = int(done.stdout) * 1024  # the peak over the resident size before the read
    assert growth_bytes < 5 * path.stat().st_size, (growth_bytes, path.stat().st_size)


# --- causes 4 and 5: one typed, bounded, sealed reader for the scene manifest (report, blender, bake) -----


@pytest.fixture(scope="module")
def gltf_bake(tmp_path_factory) -> Path:
    """A two-material glTF bake (a dielectric, a metal): its folder holds a.json, a.exr and the includes."""
    from gltf_assets import document, iridescent

    from lutbake import cli

    folder = tmp_path_factory.mktemp("gltf")
    (folder / "a.gltf").write_text(
        json.dumps(document([iridescent(), iridescent(metallic=1.0, colour=[0.9, 0.6, 0.3])]))
    )
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        with pytest.raises(SystemExit) as done:
            cli.main(["bake", "--gltf", "a.gltf", "--out", "G", "--backend", "numpy", "--quiet"])
    finally:
        os.chdir(cwd)
    assert done.value.code == 0
    return folder / "G"


def _copy(bake: Path, into: Path) -> Path:
    into.mkdir(exist_ok=True)
    for p in bake.iterdir():
        if p.is_file():
            (into / p.name).write_bytes(p.read_bytes())
    return into


def _resealed(doc: dict) -> dict:
    from lutbake.io.manifest import sealed

    return sealed({k: v for k, v in doc.items() if k != "manifest_hash"})


def _manifest_edits(doc: dict) -> dict:
    """Name → an edited manifest: careless edits (unsealed) and hostile ones (resealed with the new hash)."""
    first = next(iter(doc["materials"]))
    record = doc["source"]["materials"][0]
    edits = {
        "a field removed, not resealed": ({k: v for k, v in doc.items() if k != "settings"}, "settings"),
        "a value changed, not resealed": (_edited(doc, ("source", "materials", 0, "film"), 1.7), "manifest_hash"),
    }
    for name, path, value, message in [
        ("parts a list", ("source", "materials", 0, "parts"), [], "parts is not an object"),
        ("thickness a string", ("source", "materials", 0, "thickness_nm"), "400", "thickness_nm"),
        ("film a string", ("source", "materials", 0, "film"), "1.3", "film"),
        ("part of no material", ("source", "materials", 0, "parts", "dielectric", "material"), "zz", "zz"),
        ("rect a string", ("materials", first, "rect"), "0,0,4,1", "rect"),
        ("file outside the folder", ("materials", first, "file"), "../outside.exr", "beside the manifest"),
        ("files key with a folder", ("files",), {"../x": "0" * 64}, "files"),
        ("records a dict", ("source", "materials"), {}, "source.materials"),
        ("a metal's eta3 a string", ("source", "materials", 1, "parts", "metal", "eta3"), "0.2", "metal.eta3"),
        ("a metal of two channels", ("source", "materials", 1, "parts", "metal", "channels"), ["x", "y"], "channels"),
        ("a material not an object", ("materials", first), [], "is not an object"),
        ("space unknown", ("settings", "space"), "srgb", "settings.space"),
        ("newline in a material's kind", ("materials", first, "kind"), "x\nlutbake: error: forged", "kind"),
        ("a route unknown", ("source", "materials", 0, "parts", "dielectric", "route"), "gpu", "route"),
        (
            "a constant part of two numbers",
            ("source", "materials", 0, "parts", "dielectric"),
            {"constant": [0, 0]},
            "constant",
        ),
    ]:
        edits[name] = (_resealed(_edited(doc, path, value)), message)
    assert record["parts"], "the fixture's first record has a baked part"
    return edits


MANIFEST_EDITS = [
    "a field removed, not resealed",
    "a value changed, not resealed",
    "parts a list",
    "thickness a string",
    "film a string",
    "part of no material",
    "rect a string",
    "file outside the folder",
    "files key with a folder",
    "records a dict",
    "a metal's eta3 a string",
    "a metal of two channels",
    "a material not an object",
    "space unknown",
    "newline in a material's kind",
    "a route unknown",
    "a constant part of two numbers",
]


@pytest.mark.parametrize("edit", MANIFEST_EDITS)
def test_an_edited_manifest_is_one_line_for_report_and_blender(edit, gltf_bake, tmp_path, capfd, monkeypatch):
    """`report M.json --out R` and `blender M.json` refuse it in one line naming the field, write nothing
    and change no input; Blender is never looked up (the --blender given does not exist)."""
    folder = _copy(gltf_bake, tmp_path / "G")
    doc, message = _manifest_edits(json.loads((folder / "a.json").read_text()))[edit]
    (folder / "a.json").write_text(json.dumps(doc, indent=2))
    for argv in (
        ["report", "G/a.json", "--out", "R", "--points", "10"],
        ["blender", "G/a.json", "--out", "lib.blend", "--blender", str(tmp_path / "no-blender")],
    ):
        _, _, err = run_case(argv, tmp_path, capfd, monkeypatch, {2})
        assert message in err and "no-blender" not in err, (argv, err)


@pytest.mark.parametrize("kind", ["fifo", "oversize", "nested", "device"])
def test_a_manifest_that_cannot_be_read_bounded_is_refused_before_reading(kind, tmp_path, capfd, monkeypatch):
    path = tmp_path / "m.json"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "oversize":
        with open(path, "wb") as fh:  # sparse: 300 MB declared, nothing stored
            fh.truncate(300 << 20)
    elif kind == "nested":
        path.write_text("[" * 100_000 + "]" * 100_000)
    else:
        path.symlink_to("/dev/zero")
    for argv in (
        ["report", "m.json"],
        ["blender", "m.json", "--out", "lib.blend", "--blender", str(tmp_path / "no-blender")],
    ):
        _, _, err = run_case(argv, tmp_path, capfd, monkeypatch, {2})
        assert "manifest" in err and "no-blender" not in err, err


def test_a_lut_sidecar_fifo_is_refused_without_blocking(tmp_path, capfd, monkeypatch):
    """A manifest naming a 4D LUT whose sidecar is a FIFO: one line (lutbake's side reads it bounded)."""
    from lutbake.blender.library import read_scene
    from lutbake.io.manifest import sealed

    (tmp_path / "t.exr").write_bytes(b"")
    os.mkfifo(tmp_path / "t.json")
    doc = sealed(
        {
            "format": "lutbake-scene-manifest",
            "format_version": 1,
            "scene": "s.toml",
            "scene_hash": "0" * 64,
            "settings": {"space": "rec709"},
            "materials": {"m": {"kind": "lut", "file": "t.exr"}},
            "files": {},
        }
    )
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="sidecar"):
        read_scene(tmp_path / "m.json")


@pytest.mark.parametrize("how", ["same name", "hard link"])
def test_report_refuses_to_overwrite_the_manifest_it_reads(how, gltf_bake, tmp_path, capfd, monkeypatch):
    folder = _copy(gltf_bake, tmp_path / "G")
    if how == "same name":
        (folder / "a.json").rename(folder / "receipts.json")
        argv = ["report", "G/receipts.json", "--out", "G", "--points", "10"]
    else:
        (tmp_path / "R").mkdir()
        os.link(folder / "a.json", tmp_path / "R" / "receipts.html")
        argv = ["report", "G/a.json", "--out", "R", "--points", "10"]
    _, _, err = run_case(argv, tmp_path, capfd, monkeypatch, {2})
    assert "would be overwritten" in err


def test_receipts_are_written_both_or_neither(gltf_bake, tmp_path, capfd, monkeypatch):
    from lutbake.scene.gltf import receipt

    _copy(gltf_bake, tmp_path / "G")

    def fails(receipts):
        raise ValueError("the page could not be rendered")

    monkeypatch.setattr(receipt, "_html", fails)
    _, _, err = run_case(["report", "G/a.json", "--out", "R", "--points", "10"], tmp_path, capfd, monkeypatch, {2})
    assert "could not be rendered" in err and not any((tmp_path / "R").glob("receipts*"))


def test_the_genuine_manifest_still_reports(gltf_bake, tmp_path, capfd, monkeypatch):
    _copy(gltf_bake, tmp_path / "G")
    run_case(["report", "G/a.json", "--out", "R", "--points", "10"], tmp_path, capfd, monkeypatch, {0})
    assert sorted(p.name for p in (tmp_path / "R").iterdir()) == ["receipts.html", "receipts.json"]


# --- causes 9 and 10: metal-mapping files and material names -----------------------------------------------


@pytest.mark.parametrize(
    "mapping, message",
    [
        ({"materials": {"a\nlutbake: error: forged": "Au"}}, "no such glTF material"),
        ({"materials": {"0": ["Au"]}}, "is not a lutbake material name"),
        ({"materials": {"²": "Au"}}, "no such glTF material"),
        ({"materials": {"9" * 5000: "Au"}}, "no such glTF material"),
        ({"materials": {"0": "x" * 60_000}}, "60,000 characters"),
        ({"materials": {"0": "Au"}, "default": ["fitted"]}, "default"),
        ({"material": {"0": "Au"}}, "must be an object with 'materials'"),
        ({"materials": [["0", "Au"]]}, "materials must be an object"),
    ],
)
def test_hostile_metal_mapping_files_are_one_line(mapping, message, tmp_path, capfd, monkeypatch):
    from gltf_assets import document, iridescent

    doc = document([{**iridescent(metallic=1.0), "name": ["a", "list"]}, iridescent(metallic=1.0, name="b")])
    (tmp_path / "a.gltf").write_text(json.dumps(doc))
    (tmp_path / "map.json").write_text(json.dumps(mapping))
    _, _, err = run_case(["plan", "--gltf", "a.gltf", "--metal-mapping", "map.json"], tmp_path, capfd, monkeypatch, {2})
    assert message in err, err


def test_a_60000_character_material_name_is_refused_before_the_catalogue(tmp_path, capfd, monkeypatch):
    argv = ["eval", "--eta2", "1.3", "--thickness", "300", "--cos-theta", "1", "--base", "x" * 60_000]
    _, _, err = run_case(argv, tmp_path, capfd, monkeypatch, {2})
    assert "60,000 characters" in err and len(err) < 200


# --- cause 11: a Blender that fails without a word -----------------------------------------------------------


@pytest.mark.parametrize("status", [2, 3])
def test_a_blender_that_exits_without_stderr_is_one_line(status, gltf_bake, tmp_path, capfd, monkeypatch):
    fake = tmp_path / "blender"
    fake.write_text(f"#!/bin/sh\nexit {status}\n")
    fake.chmod(0o755)
    _copy(gltf_bake, tmp_path / "G")
    _, _, err = run_case(
        ["blender", "G/a.json", "--out", "lib.blend", "--blender", str(fake)], tmp_path, capfd, monkeypatch, {1}
    )
    assert f"exit {status}" in err and len(err.strip().splitlines()) == 1 and not (tmp_path / "lib.blend").exists()


# --- cause 12: a bake refused mid-way leaves no folder behind -------------------------------------------------


@pytest.mark.parametrize(
    "env, flags",
    [
        ({"LUTBAKE_DEVICE": "99"}, []),
        ({"OCL_ICD_VENDORS": "/nonexistent-vendors"}, ["--backend", "opencl"]),
    ],
)
def test_a_gltf_bake_refused_for_its_device_leaves_no_out_folder(env, flags, tmp_path):
    from gltf_assets import document, iridescent
    from hostile_exr import assert_verdict, run_cli

    (tmp_path / "a.gltf").write_text(json.dumps(document([iridescent()])))
    rc, out, err = run_cli(["bake", "--gltf", "a.gltf", "--out", "G/sub", "--quiet", *flags], tmp_path, env=env)
    assert_verdict(rc, out, err, {2})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gltf"], err


# --- cause 8: the three.js loaders' set check reads only what lutbake writes at a fixed place ----------------


def test_names_cannot_steer_the_engine_set_check(tmp_path, capfd, monkeypatch):
    """A scene whose file name carries another scene's "(scene hash X)": its own EXR + include pair is accepted,
    the other scene's EXR with its include refused (the check took the first "(scene hash X)" of the line,
    which the name comes before)."""
    from engine_harness import engine_accepts as _engine_accepts

    scene = "[scene]\nmax_de = 5.0\n[materials.soap]\nfilm = {film}\nthickness_nm = 300\nbase = 1.0\n"
    (tmp_path / "other.toml").write_text(scene.format(film=1.5))
    run_case(
        ["bake", "--scene", "other.toml", "--out", "B", "--backend", "numpy", "--quiet"],
        tmp_path,
        capfd,
        monkeypatch,
        {0},
    )
    other_hash = json.loads((tmp_path / "B" / "other.json").read_text())["scene_hash"][:16]
    hostile = f"x (scene hash {other_hash})"
    (tmp_path / f"{hostile}.toml").write_text(scene.format(film=1.33))
    argv = ["bake", "--scene", f"{hostile}.toml", "--out", "A", "--backend", "numpy", "--quiet"]
    run_case(argv, tmp_path, capfd, monkeypatch, {0})
    pairs = [
        (f"A/{hostile}.exr", f"A/{hostile}.glsl"),
        ("B/other.exr", f"A/{hostile}.glsl"),
        ("B/other.exr", "B/other.glsl"),
    ]
    assert _engine_accepts(tmp_path, pairs) == [True, False, True]


# --- cause 14: a stop signal inside any C extension's initialisation waits for the import's end -------------

_SIGNAL_INSIDE_EXTENSION = """
import importlib.machinery, os, signal, sys
from lutbake import cli  # installs the start-up handlers and holds stop signals in extension imports
from lutbake.io.signals import STOP_SIGNALS, raise_interrupted, set_handler
for signum in STOP_SIGNALS:
    set_handler(signum, raise_interrupted)  # as main() does
inside = []
def tracked(step):  # runs inside the held block, as the extension's own initialisation does
    def run(self, arg):
        inside.append(self.name)
        try:
            return step(self, arg)
        finally:
            inside.pop()
    return run
for step in ("create_module", "exec_module"):  # single-phase initialisation runs in the first, multi-phase in both
    loader = importlib.machinery.ExtensionFileLoader
    setattr(loader, step, tracked(getattr(loader, step)))
sent = []
class Hook:  # the signal lands while an extension initialises, at its first import of Python code
    def find_spec(self, name, path, target=None):
        if inside and not sent:
            sent.append((inside[-1], name))
            os.kill(os.getpid(), int(sys.argv[2]))
sys.meta_path.insert(0, Hook())
try:
    __import__(sys.argv[1])
except KeyboardInterrupt as exc:
    print(sent[0][0], type(exc).__name__)
"""


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
@pytest.mark.parametrize("module", ["OpenEXR", "numpy", "matplotlib.pyplot", "pyopencl"])
def test_a_stop_signal_inside_a_c_extension_s_initialisation_is_handled_after_it(module, signum):
    """The C extensions on the commands' paths (OpenEXR for every table, numpy, matplotlib (Pillow under it) for
    the reports, pyopencl), each imported in a fresh process with a stop signal sent from inside an
    extension's initialisation (at its first import of Python code): the initialisation runs to its end,
    then the signal unwinds as Interrupted (exit 128 + signal in the CLI). Unheld, OpenEXR's initialisation
    swallowed the interrupt (the stop was lost) or, caught elsewhere in it, raised ImportError (exit 1)."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", _SIGNAL_INSIDE_EXTENSION, module, str(int(signum))],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    assert done.stdout.split()[-1:] == ["Interrupted"], (done.stdout, done.stderr)


# --- Blender: --verify probes only inside the baked axes ------------------------------------------------------


def test_blender_verify_probes_stay_inside_every_axis(tmp_path):
    """A 4D LUT whose η3 axis starts near lutbake's domain edge (0.02, a metal's): every probe lies inside
    the axes, both ends included (probes 5% past them were refused: "eta3 = -0.0627 is not allowed")."""
    from lutbake.blender.library import probe_points
    from lutbake.blender.programs import LutRead, SceneReads
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.lut.bake import bake

    ranges = {"cos_theta": (0.0, 1.0, 4), "opd_nm": (100.0, 1000.0, 4), "eta3": (0.02, 0.5, 2), "kappa3": (0.0, 1.0, 2)}
    bake(BakeSpec(eta2=1.5, axes=tuple(Axis(n, *r) for n, r in ranges.items())), tmp_path / "m.exr", "numpy")
    meta = json.loads((tmp_path / "m.json").read_text())
    read = LutRead("m", "m.exr", tuple(meta["axes"]), meta["constants"]["eta1"], meta["constants"]["eta2"])
    probes = probe_points(SceneReads("s", tmp_path, "rec709", (read,)), read, 40)
    for values, (low, high) in (
        (probes.eta3, (0.02, 0.5)),
        (probes.kappa3, (0.0, 1.0)),
        (probes.thickness_nm, read.thickness_nm),
    ):
        assert values.min() == pytest.approx(low) and values.max() == pytest.approx(high)
        assert low <= values.min() and values.max() <= high
