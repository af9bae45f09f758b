"""One writer, one bounded reader and one include renderer for every table kind (lutbake/tables/).

The runtime table's reader refuses what the LUT readers refuse (a metadata document that is not an object,
any field missing or of another type, tampered band fields, a data window of 12000² texels), each before a
pixel is read; the reader of one kind refuses a file of another; a file name holding a newline or ``*/``
reaches the exact and runtime includes escaped, and glslang accepts them.
"""

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from shader_compile import compile_shader
from tiny_luts import a_lut

from lutbake.modes.exact import write_exact_table
from lutbake.modes.runtime import read_runtime_table, write_runtime_table
from lutbake.tables import lutfile
from lutbake.tables.exr import write_image
from lutbake.tables.headers import EXACT_FORMAT, FORMAT, RUNTIME_FORMAT
from lutbake.tables.includes import osl_source, shader_includes
from lutbake.tables.lutfile import read_lut

SIDE = 12000  # texels a side the hostile files declare: 12000² RGBA half is 1.15 GB


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    """A tiny LUT (numpy), the exact table and the runtime table, each written by its library function."""
    folder = tmp_path_factory.mktemp("tables")
    write_exact_table(folder / "exact.exr")
    write_runtime_table(folder / "rt.exr")
    return {"lut": a_lut(folder), "exact": folder / "exact.exr", "runtime": folder / "rt.exr"}


@pytest.fixture
def no_pixel_read(monkeypatch):
    """Fail any test that reads a pixel: every refusal here comes from the header."""

    def never(path, structure):
        raise AssertionError(f"{path}: pixels read before the header was refused")

    monkeypatch.setattr(lutfile, "read_pixels", never)


def _rgba_exr(path: Path, metadata_text: str, height: int, width: int) -> Path:
    """An RGBA half ZIP EXR of zeros whose lutbake.metadata is ``metadata_text``, written with OpenEXR's own
    bindings (not lutbake's writer)."""
    import Imath
    import OpenEXR

    header = OpenEXR.Header(width, height)
    header["channels"] = {c: Imath.Channel(Imath.PixelType(Imath.PixelType.HALF)) for c in "RGBA"}
    header["compression"] = Imath.Compression(Imath.Compression.ZIP_COMPRESSION)
    header["lutbake.metadata"] = metadata_text.encode()
    out = OpenEXR.OutputFile(str(path), header)
    out.writePixels({c: np.zeros((height, width), np.float16).tobytes() for c in "RGBA"})
    out.close()
    return path


def _with_data_window(path: Path, height: int, width: int) -> bytes:
    """The bytes of the EXR at ``path`` with its data window set to ``width`` × ``height`` (same size)."""
    data = path.read_bytes()
    key = b"dataWindow\0box2i\0"
    at = data.index(key) + len(key) + 4
    return data[:at] + struct.pack("<4i", 0, 0, width - 1, height - 1) + data[at + 16 :]


def _leaves(doc, path=()):
    """(path, value) of every value below the root of a JSON document, containers included."""
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for key, value in items:
        yield (*path, key), value
        yield from _leaves(value, (*path, key))


def _edits(meta: dict):
    """(field the refusal must name, edited document): every value given another JSON type, every key
    removed. The field is the path up to its first list index (a list is checked whole)."""
    for path, value in _leaves(meta):
        field = ".".join(path[: next((i for i, k in enumerate(path) if isinstance(k, int)), len(path))])
        retyped = 7 if isinstance(value, str) else ("x" if value else 0) if isinstance(value, (list, dict)) else "7"
        yield field, _replaced(meta, path, retyped)
        if not isinstance(path[-1], int):
            yield field, _replaced(meta, path, None)


def _replaced(meta: dict, path: tuple, value):
    """A copy of ``meta`` with the value at ``path`` set to ``value`` (None: removed)."""
    doc = json.loads(json.dumps(meta))
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    if value is None:
        del parent[path[-1]]
    else:
        parent[path[-1]] = value
    return doc


def test_every_field_of_a_runtime_header_is_checked_before_a_pixel_is_read(tables, tmp_path, no_pixel_read):
    """Each of the header's values retyped, each key removed (59 documents): refused in one line naming the
    file and the field. A field the writer adds and the schema does not check fails here."""
    meta = json.loads(tables["runtime"].with_suffix(".json").read_text())
    height, width = meta["table"]["height"], meta["table"]["width"]
    cases = list(_edits(meta))
    assert len(cases) >= 59
    for field, edited in cases:
        bad = _rgba_exr(tmp_path / "bad.exr", json.dumps(edited), height, width)
        with pytest.raises(ValueError) as refused:
            read_runtime_table(bad)
        message = str(refused.value)
        assert "bad.exr" in message and "\n" not in message, (field, message)
        if field in ("format", "format_version"):
            assert "is not a lutbake-runtime v1 file" in message, (field, message)
        else:
            assert f"metadata field {field} is missing or invalid" in message, (field, message)


RUNTIME_VALUES = {
    "metadata a list": (lambda m: [m], "is not a lutbake-runtime v1 file"),
    "metadata a string": (lambda m: "lutbake-runtime", "is not a lutbake-runtime v1 file"),
    "format version 2": (lambda m: {**m, "format_version": 2}, "is not a lutbake-runtime v1 file"),
    "a LUT's format": (lambda m: {**m, "format": "lutbake-lut"}, "is not a lutbake-runtime v1 file"),
    "band_rows 5": (lambda m: _table(m, band_rows=5), "table.band_rows"),
    "band_rows 0": (lambda m: _table(m, band_rows=0), "table.band_rows"),
    "tiles_per_row 16": (lambda m: _table(m, tiles_per_row=16), "table.band_rows"),
    "slices 200": (lambda m: _table(m, slices=200), "table.band_rows"),
    "nodes 34": (lambda m: _table(m, nodes=34), "table (image size)"),
    "width 1057": (lambda m: _table(m, width=1057), "table (image size)"),
    "white of two channels": (lambda m: _table(m, white=[1.0, 1.0]), "table.white"),
    "white NaN": (lambda m: _table(m, white=[1.0, float("nan"), 1.0]), "table.white"),
    "nodes 2^40": (lambda m: _table(m, nodes=1 << 40), "table.nodes"),
    "zoom 0": (lambda m: _table(m, zoom_nm=0.0), "table.zoom_nm"),
    "channels RGB": (lambda m: {**m, "channels": ["R", "G", "B"]}, "metadata field channels"),
    "precision float over HALF channels": (lambda m: {**m, "precision": "float"}, "precision (channel type)"),
    "illuminant with an escape sequence": (lambda m: {**m, "illuminant": "D65\x1b]0;owned\x07"}, "illuminant"),
    "content hash not hex": (lambda m: {**m, "content_hash": "not a hash"}, "content_hash"),
}


def _table(meta: dict, **changes) -> dict:
    return {**meta, "table": {**meta["table"], **changes}}


@pytest.mark.parametrize("name", list(RUNTIME_VALUES))
def test_a_tampered_runtime_header_is_refused_naming_the_field(name, tables, tmp_path, no_pixel_read):
    meta = json.loads(tables["runtime"].with_suffix(".json").read_text())
    edit, expected = RUNTIME_VALUES[name]
    bad = _rgba_exr(tmp_path / "bad.exr", json.dumps(edit(meta)), meta["table"]["height"], meta["table"]["width"])
    with pytest.raises(ValueError, match="bad.exr") as refused:
        read_runtime_table(bad)
    assert expected in str(refused.value)


def test_a_small_runtime_table_declaring_12000_squared_texels_is_refused_from_its_size(tables, tmp_path, no_pixel_read):
    """Header and data window agree on 12000² RGBA half texels (1.15 GB) in a file of a few kB: only the
    compression's worst-case ratio can tell, and does before OpenEXR allocates the image."""
    meta = json.loads(tables["runtime"].with_suffix(".json").read_text())
    meta["table"].update(nodes=400, tiles_per_row=30, slices=301, band_rows=10, width=SIDE, height=SIDE)
    small = _rgba_exr(tmp_path / "small.exr", json.dumps(meta), 8, 8)
    (tmp_path / "bad.exr").write_bytes(_with_data_window(small, SIDE, SIDE))
    with pytest.raises(ValueError, match=f"{SIDE} x {SIDE} texels cannot fit in"):
        read_runtime_table(tmp_path / "bad.exr")


def _zeros_exr(path: Path, meta: dict, side: int) -> Path:
    """A ``side``² RGBA half ZIP EXR of zeros under ``meta``, built by repeating one 16-scanline chunk that
    OpenEXR wrote: a well-formed file OpenEXR decodes whole (~1 MB for 12000², within ZIP's ratio)."""
    write_image(path, np.zeros((16, side, 4)), meta, "half")
    data = path.read_bytes()
    table = next(at for at in range(len(data)) if struct.unpack_from("<Q", data, at)[0] == at + 8)  # one offset
    header = _with_data_window(path, side, side)[:table]
    chunk = data[table + 16 :]  # after the chunk's offset, its first scanline and size
    count = side // 16
    first = len(header) + 8 * count
    offsets = struct.pack(f"<{count}Q", *(first + k * (8 + len(chunk)) for k in range(count)))
    path.write_bytes(header + offsets + b"".join(struct.pack("<ii", 16 * k, len(chunk)) + chunk for k in range(count)))
    return path


def test_a_12000_squared_image_under_a_runtime_header_is_refused_before_its_pixels(tables, tmp_path, no_pixel_read):
    """A well-formed 12000² image (1.15 GB of half texels in ~1.2 MB) under the runtime table's own header,
    which says 1056 × 396: refused by the header's image size, before the pixels are read."""
    meta = json.loads(tables["runtime"].with_suffix(".json").read_text())
    bad = _zeros_exr(tmp_path / "bad.exr", meta, SIDE)
    assert bad.stat().st_size * 1032 >= SIDE * SIDE * 4 * 2  # it passes the compression bound
    with pytest.raises(ValueError, match=r"metadata field table \(image size\)"):
        read_runtime_table(bad)


def test_refusing_a_12000_squared_image_holds_a_small_part_of_it_in_memory(tables, tmp_path):
    """The same file read in a fresh process, pixels and all if the reader let it through: the refusal's
    peak resident memory stays under a quarter of the 1.15 GB the file declares (a reader that decodes the
    image before checking its header peaks at 2.3 GB: docs/stability.md)."""
    meta = json.loads(tables["runtime"].with_suffix(".json").read_text())
    bad = _zeros_exr(tmp_path / "bad.exr", meta, SIDE)
    script = (
        "import sys\n"
        "from lutbake.modes.runtime import read_runtime_table\n"
        "try:\n    read_runtime_table(sys.argv[1])\nexcept ValueError as exc:\n    print(exc)\n"
        "print(next(line.split()[1] for line in open('/proc/self/status') if line.startswith('VmHWM:')))\n"
    )  # VmHWM, this process's own peak (getrusage's starts from the forking parent's size), kB
    done = subprocess.run([sys.executable, "-c", script, str(bad)], capture_output=True, text=True, timeout=120)
    message, peak = done.stdout.strip().splitlines()
    assert "table (image size)" in message, done.stdout + done.stderr
    assert int(peak) * 1024 < SIDE * SIDE * 4 * 2 / 4, peak


def test_one_reader_reads_each_kind_and_refuses_another(tables):
    every = (FORMAT, EXACT_FORMAT, RUNTIME_FORMAT)
    for kind, fmt, channels in (("lut", FORMAT, 3), ("exact", EXACT_FORMAT, 3), ("runtime", RUNTIME_FORMAT, 4)):
        meta, image = read_lut(tables[kind], every)
        assert meta["format"] == fmt and image.shape[2] == channels and np.isfinite(image).all()
        written = {s: tables[kind].with_suffix(f".{s}").read_text() for s in ("glsl", "hlsl")}
        assert shader_includes(meta, tables[kind].name) == written  # the includes, from the header alone
    with pytest.raises(ValueError, match="rt.exr' is not a lutbake EXR: channels A, B, G, R, expected R, G, B$"):
        read_lut(tables["runtime"])
    with pytest.raises(
        ValueError, match="is not a readable lutbake runtime table: channels B, G, R, expected R, G, B, A"
    ):
        read_runtime_table(tables["lut"])
    with pytest.raises(ValueError, match="is not a readable lutbake runtime table: channels B, G, R"):
        read_runtime_table(tables["exact"])


# A table's name → how the includes' first line (a // comment) shows it. A newline would end the comment and
# make the rest a source line; a backslash before it would continue the comment over the next source line.
# No file name holds "/": the name with "*/" and "/*" goes to the renderer straight.
HOSTILE_NAMES = {
    "rt\n#error injected.exr": r"rt\n#error injected.exr",
    "rt\\\n#error injected.exr": r"rt\x5c\n#error injected.exr",
    "a */ b /* c\n#error injected.exr": r"a */ b /* c\n#error injected.exr",
}
CALLS = {  # kind → (writer, GLSL call, HLSL texture type, HLSL call)
    "runtime": (
        write_runtime_table,
        "lutbake_iridescence(table, params.x, params.y, 1.0, params.z, params.w, 0.5)",
        "Texture2D<float4>",
        "lutbake_iridescence(table, linear_clamp, params.x, params.y, 1.0, params.z, params.w, 0.5)",
    ),
    "exact": (
        write_exact_table,
        "lutbake_exact(table, params.x, params.y, 1.0, 1.3, params.z, params.w)",
        "Texture2D<float3>",
        "lutbake_exact(table, params.x, params.y, 1.0, 1.3, params.z, params.w)",
    ),
}


def _sources(kind: str, name: str, tables: dict, folder: Path) -> dict:
    """The GLSL and HLSL sources of a ``kind`` table named ``name``: the files its writer commits, or, for a
    name no file can have, the renderer's output for its header. With the OSL script's refusal (its table
    path in an OSL string) for the file."""
    if "/" in name:
        return shader_includes(json.loads(tables[kind].with_suffix(".json").read_text()), name)
    out = folder / name
    CALLS[kind][0](out)
    assert sorted(p.name for p in folder.iterdir()) == sorted(
        out.with_suffix(s).name for s in (".exr", ".glsl", ".hlsl", ".json")
    )
    with pytest.raises(ValueError, match="holds a double quote or a control character"):
        osl_source(json.loads(out.with_suffix(".json").read_text()), out)
    return {s: out.with_suffix(f".{s}").read_text() for s in ("glsl", "hlsl")}


@pytest.mark.parametrize("kind", list(CALLS))
@pytest.mark.parametrize("name", list(HOSTILE_NAMES))
def test_a_hostile_table_name_reaches_the_includes_escaped_and_glslang_accepts_them(kind, name, tables, tmp_path):
    _, glsl_call, texture, hlsl_call = CALLS[kind]
    (tmp_path / "set").mkdir()
    texts = _sources(kind, name, tables, tmp_path / "set")
    for suffix, text in texts.items():
        first = text.splitlines()[0]
        assert first.startswith("// lutbake ") and first.endswith(f" for {HOSTILE_NAMES[name]}"), (suffix, first)
        assert text.isascii() and not any(line.startswith("#error") for line in text.splitlines())
    glsl = tmp_path / "s.frag"
    glsl.write_text(
        "#version 450\n" + texts["glsl"] + "layout(binding = 0) uniform highp sampler2D table;\n"
        "layout(location = 0) in highp vec4 params;\nlayout(location = 0) out highp vec4 colour;\n"
        f"void main() {{ colour = vec4({glsl_call}, 1.0); }}\n"
    )
    compiled = compile_shader(glsl, hlsl=False)
    assert compiled.returncode == 0, compiled.stdout + compiled.stderr
    hlsl = tmp_path / "s.hlsl"
    hlsl.write_text(
        f"{texture} table : register(t0);\nSamplerState linear_clamp : register(s0);\n"
        + texts["hlsl"]
        + f"float4 main(float4 params : TEXCOORD0) : SV_Target {{ return float4({hlsl_call}, 1.0); }}\n"
    )
    compiled = compile_shader(hlsl, hlsl=True)
    assert compiled.returncode == 0, compiled.stdout + compiled.stderr


@pytest.mark.parametrize("kind", list(CALLS))
def test_the_osl_script_names_its_table_escaped_and_holds_its_path(kind, tables, tmp_path):
    """The OSL script's first line escapes the name as the includes do; its table path stands in an OSL
    string as it is (Cycles opens it)."""
    out = tmp_path / "stål\\rt.exr"
    CALLS[kind][0](out)
    script = osl_source(json.loads(out.with_suffix(".json").read_text()), out)
    assert script.splitlines()[0].endswith(r" for st\xe5l\x5crt.exr")
    assert f'string Table = "{out}"' in script
