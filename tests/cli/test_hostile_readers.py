"""Hostile inputs of issue 35 (reliability round 4): every reader bounded and typed the same way (JSON
integers, the runtime table's header, manifests, metal mappings, FIFOs), names that reach shaders and
terminals, Blender's failures, and what a refused bake leaves behind.

Every case gets the verdict of tests/cli/test_hostile.py's run_case (exit 0/1/2, no traceback, one stderr
line and nothing written on exit 2, no hang past 60 s); cases that need a fresh process run the CLI as one.
"""

import json
import os
import struct
import threading
from pathlib import Path

import numpy as np
import pytest
from test_hostile import run_case
from test_hostile_files import _patched, _write_like, good_files  # noqa: F401 (a fixture)

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
    _write_like_rgba(tmp_path / "bad.exr", image, edited)
    monkeypatch.setattr(lutfile, "read_pixels", _never_read)
    with pytest.raises(ValueError) as refused:
        read_runtime_table(tmp_path / "bad.exr")
    assert "bad.exr" in str(refused.value) and "\n" not in str(refused.value)


def test_a_runtime_table_declaring_12000_squared_texels_is_refused_before_allocation(
    runtime_table, tmp_path, monkeypatch
):
    """A genuine table's bytes with its data window set to 12000 x 12000 (1.15 GB of half RGBA, which ZIP's
    1032:1 bound lets 1.2 MB declare): the header's image size refuses it before any pixel is read."""
    data = _patched(runtime_table.read_bytes(), "dataWindow", "box2i", struct.pack("<4i", 0, 0, 11999, 11999))
    (tmp_path / "big.exr").write_bytes(data)
    monkeypatch.setattr(lutfile, "read_pixels", _never_read)
    with pytest.raises(ValueError, match="image size|cannot fit"):
        read_runtime_table(tmp_path / "big.exr")


def _write_like_rgba(path: Path, image: np.ndarray, meta) -> None:
    """test_hostile_files._write_like for four channels (the runtime table's RGBA)."""
    import Imath
    import OpenEXR

    kind = Imath.PixelType.HALF if image.dtype == np.float16 else Imath.PixelType.FLOAT
    header = OpenEXR.Header(image.shape[1], image.shape[0])
    header["channels"] = {c: Imath.Channel(Imath.PixelType(kind)) for c in "RGBA"}
    header["lutbake.metadata"] = json.dumps(meta).encode()
    out = OpenEXR.OutputFile(str(path), header)
    out.writePixels({c: np.ascontiguousarray(image[:, :, i]).tobytes() for i, c in enumerate("RGBA")})
    out.close()


# --- cause 7: a runtime table's file name reaches its includes escaped ----------------------------------


@pytest.mark.parametrize("name", ["nl\n#error injected\n.exr", "back\\slash\\.exr", "ü\r.exr"])
def test_runtime_table_names_reach_includes_escaped(name, tmp_path, capfd, monkeypatch):
    run_case(["runtime-table", "--out", name], tmp_path, capfd, monkeypatch, {0})
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
        _write_like(tmp_path / "bad.exr", image, _edited(meta, path, 2**64 if i % 2 else -(2**53) - 1))
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
