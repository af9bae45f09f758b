"""Hostile files and environments (issue 27): journals, EXR headers, the user cache, points CSVs, names that
reach shader source, outputs aliasing inputs, the default set as one transaction, signals and the process
environment. Seeded where cases are drawn.

Every case gets the verdict of tests/hostile_cases.py: exit 0, 1 or 2; no traceback; on exit 2 one line and
nothing written; no hang past 60 s; and here also nothing written outside the requested folder and no input
changed. In-process cases use hostile_cases.run_case; cases that need a fresh process (environment
variables read at import, closed descriptors, signals) run the CLI as a subprocess.
"""

import hashlib
import json
import os
import select
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hostile_cases import TINY, run_case, write_exr
from hostile_exr import CASE_SECONDS, assert_verdict, patched_attribute, run_cli, write_like
from tiny_luts import tiny_jobs

from lutbake.io import usercache
from lutbake.io.fileset import MAX_JOURNAL_BYTES, sha256_file
from lutbake.tables import headers, lutfile
from lutbake.tables.lutfile import read_lut

BAKE = ["bake", "--eta2", "1.5", *TINY, "--out"]


@pytest.fixture(autouse=True)
def _no_case_past_60_s(monkeypatch):
    """hostile_cases.run_case's alarm at this module's bound (the issue's 60 s)."""
    import hostile_cases

    monkeypatch.setattr(hostile_cases, "CASE_SECONDS", CASE_SECONDS)


def _digests(folder: Path) -> dict:
    """Every path under ``folder`` (links not followed) → SHA-256 of a file, or its kind."""
    out = {}
    for p in sorted(folder.rglob("*")):
        rel = str(p.relative_to(folder))
        if p.is_symlink():
            out[rel] = f"link to {os.readlink(p)}"
        elif p.is_file():
            out[rel] = sha256_file(p)
        else:
            out[rel] = "dir" if p.is_dir() else "other"
    return out


@pytest.fixture
def sandbox(tmp_path):
    """(work folder, the whole tree's digests before) with a victim file beside the work folder: a case
    may write only into the work folder's requested outputs."""
    work = tmp_path / "work"
    work.mkdir()
    (tmp_path / "victim.txt").write_text("outside the requested folder\n")
    return work


def _outside(work: Path) -> dict:
    return {k: v for k, v in _digests(work.parent).items() if not k.startswith("work")}


# --- journals: validated before trust ---------------------------------------------------------------


def _journal_doc(final="x.exr", tmp=None, digest="0" * 64, set_name="x.exr"):
    return {"set": set_name, "members": [[tmp or f".{final}.tmp-1", final, digest]]}


HOSTILE_JOURNALS = {
    "final name ../victim.txt": _journal_doc("../victim.txt"),
    "final name absolute": _journal_doc("/tmp/lutbake-never"),
    "final name in a subfolder": _journal_doc("sub/x.exr"),
    "final name .": _journal_doc("."),
    "final name empty": _journal_doc(""),
    "temporary not named after the final": _journal_doc(tmp=".other.tmp-1"),
    "temporary outside the folder": _journal_doc(tmp="../.x.exr.tmp-1"),
    "digest not hex": _journal_doc(digest="z" * 64),
    "digest short": _journal_doc(digest="0" * 63),
    "set name not the journal's": _journal_doc(set_name="other.exr"),
    "members empty": {"set": "x.exr", "members": []},
    "members a dict": {"set": "x.exr", "members": {"a": 1}},
    "member of two fields": {"set": "x.exr", "members": [[".x.exr.tmp-1", "x.exr"]]},
    "member of numbers": {"set": "x.exr", "members": [[1, 2, 3]]},
    "extra key": {**_journal_doc(), "rename": "everything"},
    "a list": [1, 2, 3],
    "null": None,
}


def _random_journal(rng) -> str:
    """A journal text drawn from valid parts and hostile ones (each draw hostile in at least one part)."""
    finals = ["x.exr", "../victim.txt", "/etc/passwd", "a/b", "..", "", "x\0y", 7, None]
    tmps = [".x.exr.tmp-1", "x.exr", "../.x.exr.tmp-1", "", 3.5, ".y.tmp-2"]
    digests = ["0" * 64, "g" * 64, "0" * 10, "", None, ["0"]]

    def pick(values):
        return values[int(rng.integers(len(values)))]

    while True:
        member = [pick(tmps), pick(finals), pick(digests)]
        if member != [".x.exr.tmp-1", "x.exr", "0" * 64]:
            break
    doc = {"set": pick(["x.exr", "y", "", "../x.exr"]), "members": [member] * int(rng.integers(1, 4))}
    text = json.dumps(doc)
    if rng.random() < 0.2:
        text = "[" * 5000 + text + "]" * 5000  # nesting past documents.MAX_NESTING
    return text


def _texts_of_journals():
    texts = {name: json.dumps(doc) for name, doc in HOSTILE_JOURNALS.items()}
    texts["not JSON"] = "{members: x.exr"
    texts["not UTF-8"] = b"\xff\xfe{}".decode("latin-1")
    texts["nested 100,000 deep"] = "[" * 100_000 + "]" * 100_000
    texts["over the size bound"] = json.dumps({**_journal_doc(), "pad": "x" * MAX_JOURNAL_BYTES})
    texts.update({f"seed {seed}": _random_journal(np.random.default_rng(seed)) for seed in range(12)})
    return texts


JOURNAL_TEXTS = _texts_of_journals()


@pytest.fixture(scope="module")
def whole_set(tmp_path_factory):
    """A whole tiny x.exr set, copied into each journal case's folder."""
    folder = tmp_path_factory.mktemp("set")
    assert run_cli([*BAKE, "x.exr"], folder)[0] == 0
    return {p.name: p.read_bytes() for p in folder.iterdir()}


@pytest.mark.parametrize("name", list(JOURNAL_TEXTS))
def test_a_hostile_journal_is_refused_and_left_alone(name, whole_set, sandbox, capfd, monkeypatch):
    """The next bake into the folder refuses in one line and changes nothing: not the journal, not the files
    it names, nothing outside; readers of the set refuse it too (it may be mid-commit)."""
    for member, data in whole_set.items():
        (sandbox / member).write_bytes(data)
    (sandbox / ".x.exr.tmp-1").write_bytes(b"a temporary the journal names")
    (sandbox / ".x.exr.commit").write_text(JOURNAL_TEXTS[name], encoding="latin-1")
    outside = _outside(sandbox)
    _, _, err = run_case([*BAKE, "x.exr"], sandbox, capfd, monkeypatch, {2})
    assert ".x.exr.commit" in err and "left as they are" in err
    _, _, err = run_case(["inspect", "x.exr"], sandbox, capfd, monkeypatch, {2})
    assert "mid-commit" in err
    assert _outside(sandbox) == outside


@pytest.mark.parametrize("kind", ["fifo", "symlink", "folder"])
def test_a_journal_that_is_not_a_regular_file_is_refused_without_reading_it(kind, sandbox, capfd, monkeypatch):
    """A FIFO would block a read forever; a link could point anywhere."""
    journal = sandbox / ".x.exr.commit"
    if kind == "fifo":
        os.mkfifo(journal)
    elif kind == "symlink":
        (sandbox.parent / "elsewhere.json").write_text(json.dumps(_journal_doc()))
        journal.symlink_to(sandbox.parent / "elsewhere.json")
    else:
        journal.mkdir()
    _, _, err = run_case([*BAKE, "x.exr"], sandbox, capfd, monkeypatch, {2})
    assert "not one lutbake wrote" in err


def test_a_journaled_temporary_that_changed_is_not_renamed(whole_set, sandbox, capfd, monkeypatch):
    """A well-formed journal whose temporary no longer hashes to its digest: refused, nothing renamed."""
    for member, data in whole_set.items():
        (sandbox / member).write_bytes(data)
    tmp = sandbox / ".x.exr.tmp-1"
    tmp.write_bytes(b"written after the journal")
    (sandbox / ".x.exr.commit").write_text(json.dumps(_journal_doc(digest=hashlib.sha256(b"other").hexdigest())))
    _, _, err = run_case([*BAKE, "x.exr"], sandbox, capfd, monkeypatch, {2})
    assert "changed after an interrupted commit" in err and tmp.exists()


# --- EXR headers: structure first, then every metadata key, before any pixel is read ----------------


def _leaves(doc, path=()):
    """(path, value) of every value in a JSON document, containers included."""
    yield path, doc
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for key, value in items:
        yield from _leaves(value, (*path, key))


def _retyped(value):
    """A value of another JSON type than ``value``: never valid where ``value`` was."""
    if isinstance(value, str):
        return 7
    if isinstance(value, (list, dict)):
        return "x" if value else 0
    return "7"  # numbers, booleans, null


# Keys older files go without (format versions before the truncation measurement, the Fourier-series
# integrator or the interpolation key; an atlas slice's id): removing one may leave a valid header.
_OPTIONAL = {
    "integrator",
    "interpolation",
    "capped_texels",
    "truncation_bound_rgb",
    "capped_error_rgb_max",
    "id",
    "closed_form_texels",
}
FORMATS = (headers.FORMAT, headers.ATLAS_FORMAT, headers.EXACT_FORMAT)


def _mutations(meta, seed: int, n: int):
    """``n`` seeded edits of ``meta``: (path, edited document, whether it may still be valid). Each puts a
    value of another type at a random path, or removes a key."""
    paths = [p for p, _ in _leaves(meta) if p]
    rng = np.random.default_rng(seed)
    for i in rng.choice(len(paths), n, replace=False):
        path = paths[i]
        edited = json.loads(json.dumps(meta))
        parent = edited
        for key in path[:-1]:
            parent = parent[key]
        removed = rng.random() < 0.3 and isinstance(parent, dict)
        if removed:
            del parent[path[-1]]
        else:
            parent[path[-1]] = _retyped(parent[path[-1]])
        # An atlas slice's film or base is a number or a material name: a string there may be valid.
        may_be_valid = path[-1] in _OPTIONAL if removed else "film" in path or "base" in path
        yield ".".join(map(str, path)), edited, may_be_valid


@pytest.mark.parametrize("kind", ["lut", "atlas", "exact"])
@pytest.mark.parametrize("seed", range(3))
def test_tampered_metadata_is_refused_naming_the_field(kind, seed, good_files, tmp_path, capfd, monkeypatch):
    """12 seeded edits per format and seed (a value of another type anywhere in the document, or a key
    removed): refused in one line naming the file and the field, before a pixel is read (an exact table,
    which the CLI reads only through exact.read_exact_table, straight through read_lut)."""
    meta, image = read_lut(good_files[kind], formats=FORMATS)
    real_read_pixels = lutfile.read_pixels
    for field, edited, optional in _mutations(meta, seed, 12):
        write_like(tmp_path / "bad.exr", image, edited)
        monkeypatch.setattr(lutfile, "read_pixels", real_read_pixels if optional else _never_read)
        if kind == "exact":
            try:
                read_lut(tmp_path / "bad.exr", formats=(headers.EXACT_FORMAT,))
                assert optional, field
            except ValueError as exc:
                assert "bad.exr" in str(exc) and "\n" not in str(exc), (field, exc)
            continue
        rc, _, err = run_case(["inspect", "bad.exr"], tmp_path, capfd, monkeypatch, {0, 2} if optional else {2})
        assert rc == 0 or "bad.exr" in err, (field, err)


def _never_read(path, structure):
    raise AssertionError("pixels read before the header was validated")


def _channel_types(data: bytes, pixel_type: int, only=None) -> bytes:
    """Every (or ``only`` one) channel of the chlist set to ``pixel_type`` (0 UINT, 1 HALF, 2 FLOAT)."""
    key = b"channels\0chlist\0"
    at = data.index(key) + len(key)
    (size,) = struct.unpack("<i", data[at : at + 4])
    chlist = bytearray(data[at + 4 : at + 4 + size])
    pos = 0
    while chlist[pos] != 0:
        end = chlist.index(0, pos)
        if only is None or chlist[pos:end].decode() == only:
            chlist[end + 1 : end + 5] = struct.pack("<i", pixel_type)
        pos = end + 17
    return data[: at + 4] + bytes(chlist) + data[at + 4 + size :]


STRUCTURES = {
    "UINT channels": lambda d: _channel_types(d, 0),
    "one UINT channel": lambda d: _channel_types(d, 0, "G"),
    "mixed HALF and FLOAT": lambda d: _channel_types(d, 1, "B"),
    "PIZ compression": lambda d: patched_attribute(d, "compression", "compression", bytes([4])),
    "unknown compression 99": lambda d: patched_attribute(d, "compression", "compression", bytes([99])),
    "data window of 12000 x 12000 in a small file": lambda d: patched_attribute(
        d, "dataWindow", "box2i", struct.pack("<4i", 0, 0, 11999, 11999)
    ),
    "data window of 2^31 - 1": lambda d: patched_attribute(
        d, "dataWindow", "box2i", struct.pack("<4i", 0, 0, 2**31 - 1, 7)
    ),
    "data window off the origin": lambda d: patched_attribute(
        d, "dataWindow", "box2i", struct.pack("<4i", 3, 0, 10, 7)
    ),
    "data window reversed": lambda d: patched_attribute(d, "dataWindow", "box2i", struct.pack("<4i", 0, 0, -5, 7)),
    "tiled flag": lambda d: d[:4] + struct.pack("<I", struct.unpack("<I", d[4:8])[0] | 0x200) + d[8:],
    "multi-part flag": lambda d: d[:4] + struct.pack("<I", struct.unpack("<I", d[4:8])[0] | 0x1000) + d[8:],
    "wrong magic number": lambda d: b"\x76\x2f\x31\x00" + d[4:],
    "attribute size past the end": lambda d: _oversized(d),
    "compression attribute of 0 bytes": lambda d: _emptied(d, b"compression\0compression\0"),
    "data window attribute of 0 bytes": lambda d: _emptied(d, b"dataWindow\0box2i\0"),
    "header cut in the middle": lambda d: d[:300],
    "attribute name longer than 31 bytes": lambda d: d.replace(b"compression\0", b"c" * 40 + b"\0", 1),
}


def _emptied(data: bytes, key: bytes) -> bytes:
    """The attribute starting with ``key`` (name, type) given size 0 and no value."""
    at = data.index(key) + len(key)
    (size,) = struct.unpack("<i", data[at : at + 4])
    return data[:at] + struct.pack("<i", 0) + data[at + 4 + size :]


def _oversized(data: bytes) -> bytes:
    key = b"lutbake.metadata\0string\0"
    at = data.index(key) + len(key)
    return data[:at] + struct.pack("<i", 2**30) + data[at + 4 :]


@pytest.mark.parametrize("name", list(STRUCTURES))
def test_exr_structure_is_checked_before_pixels_are_allocated(name, good_files, tmp_path, capfd, monkeypatch):
    monkeypatch.setattr(lutfile, "read_pixels", _never_read)
    (tmp_path / "bad.exr").write_bytes(STRUCTURES[name](good_files["lut"].read_bytes()))
    _, out, err = run_case(["inspect", "bad.exr"], tmp_path, capfd, monkeypatch, {2})
    assert "bad.exr" in err and out == ""


@pytest.mark.parametrize("kind", ["lut", "atlas"])
def test_a_small_file_declaring_a_huge_image_is_refused_before_allocation(
    kind, good_files, tmp_path, capfd, monkeypatch
):
    """Metadata and data window agree on 12000 x 12000 float texels (1.7 GB) in a file of a few kB: only
    the compression's worst-case ratio can tell, before OpenEXR allocates the image."""
    meta, image = read_lut(good_files[kind], formats=FORMATS)
    if kind == "lut":
        for axis, count in zip(meta["axes"], (3000, 3000, 4, 4)):
            axis["count"] = count
        meta["packing"].update(width=12000, height=12000, tile_width=3000, tile_height=3000)
    else:
        meta["slices"][0]["rect"] = [0, 0, 12000, 12000]
        meta["slices"][0]["axes"]["cos_theta"]["count"] = meta["slices"][0]["axes"]["thickness_nm"]["count"] = 12000
    write_like(tmp_path / "small.exr", image, meta)
    data = patched_attribute(
        (tmp_path / "small.exr").read_bytes(), "dataWindow", "box2i", struct.pack("<4i", 0, 0, 11999, 11999)
    )
    (tmp_path / "bad.exr").write_bytes(data)
    monkeypatch.setattr(lutfile, "read_pixels", _never_read)
    _, _, err = run_case(["inspect", "bad.exr"], tmp_path, capfd, monkeypatch, {2})
    assert "12000 x 12000 texels cannot fit" in err


HEADER_VALUES = {
    "axis without unit": lambda m: m["axes"][1].pop("unit"),
    "axis unit of another axis": lambda m: m["axes"][1].update(unit="1"),
    "cos_theta axis past 1": lambda m: m["axes"][0].update(max=2.0),
    "opd axis below 0": lambda m: m["axes"][1].update(min=-100.0),
    "eta3 axis to 1e308": lambda m: m["axes"][2].update(max=1e308),
    "kappa3 axis to 5000": lambda m: m["axes"][3].update(max=5000.0),
    "eta2 outside the domain": lambda m: m["constants"].update(eta2=50.0),
    "count a float": lambda m: m["axes"][0].update(count=4.0),
    "count true": lambda m: m["axes"][2].update(count=True),
    "format_version true": lambda m: m.update(format_version=True),
    "no packing": lambda m: m.pop("packing"),
    "no spectral block": lambda m: m.pop("spectral"),
    "spectral a list": lambda m: m.update(spectral=[1]),
    "integrator without series_bound_rgb_max": lambda m: m["integrator"].pop("series_bound_rgb_max"),
    "observer unknown": lambda m: m.update(observer="cie2042"),
    "illuminant with an escape sequence": lambda m: m.update(illuminant="D65\x1b]0;owned\x07"),
    "illuminant with a newline": lambda m: m.update(illuminant="D65\nfake line"),
    "content hash not hex": lambda m: m.update(content_hash="not a hash"),
    "channels GBR": lambda m: m.update(channels=["G", "B", "R"]),
    "precision half over FLOAT channels": lambda m: m.update(precision="half"),
    "metadata nested 10,000 deep": lambda m: None,  # the text is built below: json.dumps would recurse
    "corner zoom in a version 4 file": lambda m: m["axes"][1].update(corner={"nodes": 1, "scale": 30.0}),
    "uniform-root4 in a version 4 file": lambda m: m["axes"][0].update(spacing="uniform-root4"),
    "corner zoom on cos_theta": lambda m: _v5(m, 0, {"nodes": 1, "scale": 1.0}),
    "corner nodes past N - 2": lambda m: _v5(m, 1, {"nodes": 3, "scale": 30.0}),
    "corner scale 0": lambda m: _v5(m, 1, {"nodes": 1, "scale": 0.0}),
    "corner without scale": lambda m: _v5(m, 3, {"nodes": 1}),
    "corner a list": lambda m: _v5(m, 2, [1, 1.0]),
    "corner on eta3 not from eta1": lambda m: (_v5(m, 2, {"nodes": 1, "scale": 1.0}), m["axes"][2].update(min=1.2)),
    "tiles by kappa3 in a version 5 file": lambda m: (
        m.update(format_version=5),
        m["packing"].update(tiles_x="kappa3", tiles_y="eta3"),
    ),
    "tiles by cos_theta": lambda m: (m.update(format_version=6), m["packing"].update(tiles_x="cos_theta")),
    "tiles along y by the axis along x": lambda m: (m.update(format_version=6), m["packing"].update(tiles_y="eta3")),
}


def _v5(meta: dict, axis: int, corner) -> None:
    """A version 5 header whose axis ``axis`` has the corner record ``corner``."""
    meta.update(format_version=5)
    meta["axes"][axis]["corner"] = corner


@pytest.mark.parametrize("name", list(HEADER_VALUES))
def test_lut_header_values_are_checked(name, good_files, tmp_path, capfd, monkeypatch):
    meta, image = read_lut(good_files["lut"])
    HEADER_VALUES[name](meta)
    text = json.dumps(meta)
    if name == "metadata nested 10,000 deep":
        text = text[:-1] + ', "nested": ' + "[" * 10_000 + "]" * 10_000 + "}"
    write_exr(tmp_path / "bad.exr", text, image.astype(np.float32))
    for command in (
        ["inspect"],
        ["sample", "--cos-theta", "0.5", "--opd", "100", "--eta3", "1.5"],
        ["report", "--points", "10", "--no-approximations"],
    ):
        _, _, err = run_case([*command, "bad.exr"], tmp_path, capfd, monkeypatch, {2})
        assert "bad.exr" in err


ATLAS_VALUES = {
    "no scene_hash": lambda m: m.pop("scene_hash"),
    "slice without materials": lambda m: m["slices"][0].pop("materials"),
    "material name with a newline": lambda m: m["slices"][0].update(materials=["soap\nx"]),
    "rect past the image": lambda m: m["slices"][0].update(rect=[0, 0, 10_000, 1]),
    "thickness outside the domain": lambda m: m["slices"][0]["axes"]["thickness_nm"].update(max=1e9),
    "film a list": lambda m: m["slices"][0].update(film=[1.33]),
    "base of one number": lambda m: m["slices"][0].update(base=[1.0]),
    "eta1 a string": lambda m: m.update(eta1="1.0"),
}


@pytest.mark.parametrize("name", list(ATLAS_VALUES))
def test_atlas_header_values_are_checked(name, good_files, tmp_path, capfd, monkeypatch):
    meta, image = read_lut(good_files["atlas"], formats=(headers.ATLAS_FORMAT,))
    ATLAS_VALUES[name](meta)
    write_like(tmp_path / "bad.exr", image, meta)
    for command in (
        ["inspect"],
        ["sample", "--material", "soap", "--thickness", "250", "--angle", "30"],
        ["report", "--points", "10"],
    ):
        _, _, err = run_case([*command, "bad.exr"], tmp_path, capfd, monkeypatch, {2})
        assert "bad.exr" in err


def test_valid_files_of_every_format_still_read(good_files):
    for kind, fmt in (("lut", headers.FORMAT), ("atlas", headers.ATLAS_FORMAT), ("exact", headers.EXACT_FORMAT)):
        meta, image = read_lut(good_files[kind], formats=(fmt,))
        assert meta["format"] == fmt and image.ndim == 3 and np.isfinite(image).all()


# --- the user cache: nothing in it trusted --------------------------------------------------------------


def _entry(folder: Path, kind="t", key=b"k"):
    return folder / f"{kind}-{hashlib.sha256(key).hexdigest()[:24]}.npz"


def test_user_cache_entries_are_checked_before_use(tmp_path, cache_folder):
    """An entry declaring an 8 TB array is refused from its header (nothing allocated); a zeroed entry of
    the right shape, or one whose values changed, fails its stored hash; each is rebuilt and rewritten."""
    cache_folder(tmp_path)
    built = {"a": np.arange(6.0).reshape(2, 3)}
    calls = []

    def build():
        calls.append(1)
        return {k: v.copy() for k, v in built.items()}

    assert np.array_equal(usercache.cached_arrays("t", b"k", {"a": (2, 3)}, build)["a"], built["a"])
    path = _entry(tmp_path)
    assert usercache.cached_arrays("t", b"k", {"a": (2, 3)}, build) and len(calls) == 1  # reused
    header = {"descr": "<f8", "fortran_order": False, "shape": (10**12,)}
    import io
    import zipfile

    member = io.BytesIO()
    np.lib.format.write_array_header_2_0(member, header)
    stale = {"zeroed": {"a": np.zeros((2, 3))}, "edited": {"a": built["a"] + 1e-12}}
    for damage in ("8 TB", "zeroed", "edited"):
        if damage == "8 TB":
            with zipfile.ZipFile(path, "w") as archive:
                archive.writestr("a.npy", member.getvalue())
                archive.writestr("sha256.npy", member.getvalue())
        else:
            old = dict(np.load(path))
            np.savez(path, **stale[damage], sha256=old["sha256"])
        got = usercache.cached_arrays("t", b"k", {"a": (2, 3)}, build)
        assert np.array_equal(got["a"], built["a"]), damage
    assert len(calls) == 4
    assert usercache._load(path, {"a": (2, 3)}) is not None  # the last rebuild was stored again


def test_an_unusable_cache_folder_costs_a_rebuild_only(tmp_path, monkeypatch, cache_folder):
    (tmp_path / "file").write_text("the cache folder's parent is a file")
    cache_folder(tmp_path / "file" / "lutbake")
    got = usercache.cached_arrays("t", b"k", {"a": (1,)}, lambda: {"a": np.ones(1)})
    assert got["a"][0] == 1.0
    cache_folder(tmp_path / "ro" / "lutbake")
    monkeypatch.setattr(os, "access", lambda path, mode: False)  # a read-only folder, even for root
    assert usercache.writable_folder() is None
    assert usercache.cached_arrays("t", b"k", {"a": (1,)}, lambda: {"a": np.ones(1)})["a"][0] == 1.0


# --- points CSV: bounded, streamed, no silent conflict -------------------------------------------------

CSV_CASES = {
    "a 200 kB field": ("eta2,thickness_nm,cos_theta,eta3\n1.3," + "3" * 200_000 + ",1,1.5\n", "over 4,096 bytes"),
    "a quoted field over lines past the csv field limit": (
        'eta2,thickness_nm,cos_theta,eta3\n1.3,"' + ("3" * 4000 + "\n") * 40 + '",1,1.5\n',
        "line",
    ),
    "a 100,000-column header": (",".join(["eta2"] * 100_000) + "\n", "over 4,096 bytes"),
    "800 repeated columns within the line bound": (",".join(["eta2"] * 800) + "\n1\n", "appears twice"),
    "NUL bytes": ("eta2,thickness_nm\x00\n1,2\n", "NUL"),
    "not UTF-8": ("eta2,thickness_nm,cos_theta,eta3\n1.3,\xff300,1,1.5\n", "not UTF-8"),
    "eta2 column with --film": ("eta2,thickness_nm,cos_theta,eta3\n1.3,300,1,1.5\n", "conflicts with the film"),
    "eta3 column with --base": ("eta2,thickness_nm,cos_theta,eta3\n1.3,300,1,1.5\n", "conflicts with the base"),
    "kappa3 column with --base": ("eta2,thickness_nm,cos_theta,kappa3\n1.3,300,1,0\n", "conflicts with the base"),
    "eta2 column and --eta2": ("eta2,thickness_nm,cos_theta,eta3\n1.3,300,1,1.5\n", "both give it"),
}
_CSV_FLAGS = {
    "eta2 column with --film": ["--film", "water"],
    "eta3 column with --base": ["--base", "Cu"],
    "kappa3 column with --base": ["--base", "Cu"],
    "eta2 column and --eta2": ["--eta2", "1.4"],
}


@pytest.mark.parametrize("name", list(CSV_CASES))
def test_hostile_points_csv(name, sandbox, capfd, monkeypatch):
    text, message = CSV_CASES[name]
    (sandbox / "p.csv").write_bytes(text.encode("latin-1"))
    digest = sha256_file(sandbox / "p.csv")
    _, _, err = run_case(["eval", "--points", "p.csv", *_CSV_FLAGS.get(name, [])], sandbox, capfd, monkeypatch, {2})
    assert message in err and sha256_file(sandbox / "p.csv") == digest


def test_points_past_the_bound_are_refused_at_the_first_one(sandbox, capfd, monkeypatch):
    """The bound (10^6 points; 100 here) is met while streaming: the rest of the input is never read."""
    import lutbake.physics.points

    monkeypatch.setattr(lutbake.physics.points, "MAX_CSV_POINTS", 100)
    read = []

    class Endless:
        """An endless CSV: every line read is counted."""

        def readline(self, limit):
            read.append(1)
            return b"eta2,thickness_nm,cos_theta,eta3\n" if len(read) == 1 else b"1.3,300,1,1.5\n"

    with pytest.raises(ValueError, match="more than 100 points"):
        lutbake.physics.points.read_csv_columns(Endless())
    assert len(read) == 102


@pytest.mark.parametrize("source", ["/dev/zero", "closed stdin", "empty stdin"])
def test_points_from_streams(source, sandbox):
    args = ["eval", "--points", source if source == "/dev/zero" else "-"]
    if source == "closed stdin":
        rc, out, err = run_cli(args, sandbox, stdin=None, preexec_fn=lambda: os.close(0))
    else:
        rc, out, err = run_cli(args, sandbox)
    assert_verdict(rc, out, err, {2})
    assert {"/dev/zero": "over 4,096 bytes", "closed stdin": "stdin is closed", "empty stdin": "needs a header row"}[
        source
    ] in err


def test_sample_takes_a_lut_s_film_as_a_default_not_a_conflict(good_files, sandbox, capfd, monkeypatch):
    """A CSV with an eta2 column equal to the LUT's is sampled; one of another film is refused."""
    for eta2, expected in (("1.5", {0}), ("1.33", {2})):
        (sandbox / "p.csv").write_text(f"eta2,opd_nm,cos_theta,eta3\n{eta2},300,0.5,1.5\n")
        run_case(["sample", str(good_files["lut"]), "--points", "p.csv"], sandbox, capfd, monkeypatch, expected)


# --- outputs never overwrite an input ----------------------------------------------------------------


@pytest.mark.parametrize("how", ["same name", "hard link"])
def test_report_refuses_to_overwrite_the_lut_it_reads(how, good_files, sandbox, capfd, monkeypatch):
    lut = sandbox / "summary.json"  # a LUT under the name report writes its summary to
    if how == "same name":
        lut.write_bytes(good_files["lut"].read_bytes())
        argv = ["report", "summary.json", "--out", ".", "--points", "10"]
    else:
        (sandbox / "lut.exr").write_bytes(good_files["lut"].read_bytes())
        (sandbox / "R").mkdir()
        os.link(sandbox / "lut.exr", sandbox / "R" / "report.html")
        argv = ["report", "lut.exr", "--out", "R", "--points", "10"]
    _, _, err = run_case(argv, sandbox, capfd, monkeypatch, {2})
    assert "would be overwritten" in err


# --- names that reach shader source --------------------------------------------------------------------


@pytest.mark.parametrize("name", ["nl\n#error injected\n.exr", "ü.exr", "back\\slash\\.exr", "tab\tand\rcr.exr"])
def test_file_names_reach_shaders_escaped_and_stay_intact_elsewhere(name, sandbox, capfd, monkeypatch, tmp_path):
    from shader_compile import GLSL_MAIN, HLSL_MAIN, LUT_CALL, compile_shader

    run_case([*BAKE, name], sandbox, capfd, monkeypatch, {0})
    out = sandbox / name
    assert sorted(p.name for p in sandbox.iterdir()) == sorted(
        out.with_suffix(s).name for s in (".exr", ".glsl", ".hlsl", ".json")
    )
    for hlsl in (False, True):
        text = out.with_suffix(".hlsl" if hlsl else ".glsl").read_text()
        assert text.isascii() and not any(line.startswith("#error") for line in text.splitlines())
        ident = text.split("LutbakeLut ")[-1].split()[0]
        shader = tmp_path / ("s.hlsl" if hlsl else "s.frag")
        main = (HLSL_MAIN if hlsl else GLSL_MAIN).replace("CALL", LUT_CALL[hlsl].format(ident=ident))
        shader.write_text(("" if hlsl else "#version 450\n") + text + main)
        compiled = compile_shader(shader, hlsl)
        assert compiled.returncode == 0 and "reserved" not in compiled.stdout, compiled.stdout


def test_a_non_ascii_scene_file_name_makes_identifiers_glslang_accepts(sandbox, capfd, monkeypatch, tmp_path):
    from shader_compile import ATLAS_CALL, GLSL_MAIN, compile_shader

    (sandbox / "stål.toml").write_text(
        "[scene]\nmax_de = 5.0\n[materials.soap]\nfilm = 1.33\nthickness_nm = 300\nbase = 1.0\n"
    )
    run_case(
        ["bake", "--scene", "stål.toml", "--out", "T", "--backend", "numpy", "--quiet"],
        sandbox,
        capfd,
        monkeypatch,
        {0},
    )
    text = (sandbox / "T" / "stål.glsl").read_text()
    assert text.isascii() and "LUTBAKE_ST_UE5_L_SOAP" in text
    shader = tmp_path / "s.frag"
    shader.write_text(
        "#version 450\n" + text + GLSL_MAIN.replace("CALL", ATLAS_CALL[False].format(ident="LUTBAKE_ST_UE5_L_SOAP"))
    )
    compiled = compile_shader(shader, False)
    assert compiled.returncode == 0 and "reserved" not in compiled.stdout, compiled.stdout


# --- the default set: one transaction ------------------------------------------------------------------


def test_a_set_of_luts_failing_at_its_last_lut_commits_none(tmp_path, monkeypatch):
    """bake_set (the default set's path): the 3rd LUT fails after two are written to temporaries; the
    folder keeps the old set of all three, and no temporary."""
    import lutbake.lut.bake

    lutbake.lut.bake.bake_set(tiny_jobs(tmp_path), "set", "numpy")
    before = _digests(tmp_path)
    real, calls = lutbake.lut.bake.write_lut, []

    def failing(spec, out_path, files, *args, **kwargs):
        calls.append(out_path.name)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        return real(spec, out_path, files, *args, **kwargs)

    monkeypatch.setattr(lutbake.lut.bake, "write_lut", failing)
    with pytest.raises(OSError):
        lutbake.lut.bake.bake_set(tiny_jobs(tmp_path, eta1=1.1), "set", "numpy")
    assert calls == ["lut-1.33.exr", "lut-1.5.exr", "lut-2.0.exr"] and _digests(tmp_path) == before


def test_a_folder_in_the_way_of_the_default_set_s_second_lut_writes_nothing(sandbox):
    (sandbox / "D").mkdir()
    (sandbox / "D" / "lutbake-eta2-1.33-metal.json").mkdir()
    before = _digests(sandbox.parent)
    rc, out, err = run_cli(["bake", "--out", "D", "--backend", "numpy", "--quiet"], sandbox)
    assert_verdict(rc, out, err, {2})
    assert "lutbake-eta2-1.33-metal.json" in err and _digests(sandbox.parent) == before


def test_a_set_killed_in_its_journal_window_rolls_forward_whole(tmp_path):
    """kill -9 after the first rename of a three-LUT set: the next writer completes all three."""
    import lutbake.lut.bake

    lutbake.lut.bake.bake_set(tiny_jobs(tmp_path), "set", "numpy")
    from commit_stops import kill_at, stopping

    script = (
        "from pathlib import Path; sys.path[:0] = ['tests']; import lutbake.lut.bake, tiny_luts; "
        f"lutbake.lut.bake.bake_set(tiny_luts.tiny_jobs(Path({str(tmp_path)!r}), 1.1), 'set', 'numpy')"
    )
    proc = subprocess.Popen(stopping(script), cwd=Path(__file__).resolve().parents[2])

    kill_at(proc, 5)  # the journal and the first LUT's four renames pass; killed before the second LUT's
    assert (tmp_path / ".set.commit").exists()
    sidecars = [json.loads(p.with_suffix(".json").read_text())["constants"]["eta1"] for p in _exrs(tmp_path)]
    assert sidecars == [1.1, 1.0, 1.0]  # a mixed folder while the journal is there
    lutbake.lut.bake.bake_set(tiny_jobs(tmp_path, prefix="other")[:1], "other", "numpy")  # the next writer
    assert [read_lut(p)[0]["constants"]["eta1"] for p in _exrs(tmp_path)] == [1.1, 1.1, 1.1]


def _exrs(folder):
    return sorted(folder.glob("lut-*.exr"))


# --- signals: stop within a second, exit 128 + signal, leave nothing --------------------------------------


def _bake_until_rows(folder: Path):
    """A bake several seconds long on the numpy path, returned once it reports its first band of rows."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "lutbake.cli",
            "bake",
            "--eta2",
            "1.33",
            "--cos-theta",
            "0:1:24",
            "--opd",
            "0:3000:96",
            "--eta3",
            "1:3:8",
            "--kappa3",
            "0:2:8",
            "--backend",
            "numpy",
            "--progress",
            "--out",
            "x.exr",
        ],
        cwd=folder,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    seen, deadline = b"", time.monotonic() + CASE_SECONDS
    while b"rows" not in seen:
        ready, _, _ = select.select([proc.stderr], [], [], max(deadline - time.monotonic(), 0))
        chunk = proc.stderr.read1(4096) if ready else b""
        if not chunk:
            proc.kill()
            pytest.fail(f"no band of rows within {CASE_SECONDS} s: {seen.decode()}")
        seen += chunk
    return proc


@pytest.mark.parametrize("signum, status", [(signal.SIGTERM, 143), (signal.SIGINT, 130), (signal.SIGHUP, 129)])
def test_a_stop_signal_ends_a_bake_at_once_and_leaves_nothing(signum, status, sandbox):
    """SIGHUP (a closed terminal) too: it killed the bake without a handler, leaving a temporary (issue 35)."""
    proc = _bake_until_rows(sandbox)
    start = time.monotonic()
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=CASE_SECONDS)
    waited = time.monotonic() - start
    assert proc.returncode == status, err
    assert waited < 5.0, waited  # measured 0.03–0.12 s at load 2–9 on 2 cores; 5 s leaves room for CI
    assert b"Traceback" not in err and err.decode().strip().splitlines()[-1] in (
        "lutbake: terminated",
        "lutbake: interrupted",
        "lutbake: hung up",
    )
    assert list(sandbox.iterdir()) == []


def test_sigterm_inside_the_journal_window_finishes_the_commit(tmp_path):
    """SIGTERM delivered while the writer stands between two renames is held until the set is whole: exit
    143 with the new set and no journal (without the held signals: exit 143 with a journal and a mixed set)."""
    assert run_cli([*BAKE, "x.exr"], tmp_path)[0] == 0
    from commit_stops import stopping_cli, wait_stopped

    proc = subprocess.Popen(
        stopping_cli("bake", "--eta2", "1.33", *TINY, "--out", "x.exr"),
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )

    for stop in range(3):  # the journal and the first rename pass; stopped before the second
        wait_stopped(proc)
        if stop < 2:
            os.kill(proc.pid, signal.SIGCONT)
    os.kill(proc.pid, signal.SIGTERM)
    while proc.poll() is None:
        os.kill(proc.pid, signal.SIGCONT)
        time.sleep(0.05)
    assert proc.returncode == 143
    assert not (tmp_path / ".x.exr.commit").exists()
    assert {
        json.loads((tmp_path / "x.json").read_text())["constants"]["eta2"],
        read_lut(tmp_path / "x.exr")[0]["constants"]["eta2"],
    } == {1.33}


# --- the process environment ------------------------------------------------------------------------


def test_environment_cases(good_files, sandbox, tmp_path):
    """PYOPENCL_CTX naming nothing, --backend opencl with no OpenCL platform, XDG_CACHE_HOME a file,
    stdout closed: one line and exit 2 for what the user must change, else the command's result."""
    lut = str(good_files["lut"])
    (tmp_path / "cache-file").write_text("not a folder")
    no_vendors = tmp_path / "no-vendors"
    no_vendors.mkdir()
    # No OpenCL at all, on every machine: the loader reads no vendor file (OCL_ICD_VENDORS an empty folder:
    # neither the system's runtimes nor the Intel runtime lutbake registers), and the one runtime it loads
    # whatever the environment says, PyPI's PoCL in pyopencl's own folder (docs/devices.md), offers no
    # device (POCL_DEVICES names none).
    no_opencl = {"OCL_ICD_VENDORS": str(no_vendors), "POCL_DEVICES": "none"}
    cases = [
        (
            {"PYOPENCL_CTX": "garbage"},
            ["bake", "--eta2", "1.5", *TINY[:8], "--quiet", "--out", "a.exr"],
            {2},
            "PYOPENCL_CTX='garbage'",
        ),
        (
            no_opencl,
            ["bake", "--eta2", "1.5", *TINY[:8], "--backend", "opencl", "--out", "b.exr"],
            {2},
            "--backend auto or numpy",
        ),
        (
            no_opencl,
            [
                "eval",
                "--fast",
                "--backend",
                "opencl",
                "--eta2",
                "1.3",
                "--thickness",
                "300",
                "--angle",
                "0",
                "--eta3",
                "1.5",
            ],
            {2},
            "--backend auto or numpy",
        ),
        (
            {"XDG_CACHE_HOME": str(tmp_path / "cache-file"), "LUTBAKE_CACHE_DIR": ""},
            ["bake", "--eta2", "1.5", *TINY[:8], "--quiet", "--out", "c.exr"],
            {0},
            "",
        ),
    ]
    for env, args, expected, message in cases:
        before = _outside(sandbox)
        rc, out, err = run_cli(args, sandbox, env=env)
        assert_verdict(rc, out, err, expected)
        assert message in err and _outside(sandbox) == before
        assert "cache" not in err.lower() and "matplotlib" not in err.lower(), err  # no noise from the cache home
    closed = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "inspect", lut],
        cwd=sandbox,
        stderr=subprocess.PIPE,
        text=True,
        timeout=CASE_SECONDS,
        preexec_fn=lambda: os.close(1),
    )  # `inspect good.exr >&-`
    assert closed.returncode == 0 and closed.stderr == "", closed.stderr


def test_the_engine_loaders_check_atlas_and_exact_sets_too(good_files, tmp_path):
    """checkSameSet on every (EXR, include) pair of a LUT, an atlas and an exact table: each EXR with its own
    include is loaded, with another's refused (a LUT's and an exact table's includes name a content hash,
    an atlas's a scene hash)."""
    from engine_harness import engine_accepts

    folder = good_files["lut"].parent
    stems = {kind: str(path.relative_to(folder).with_suffix("")) for kind, path in good_files.items()}
    pairs = [(f"{stems[a]}.exr", f"{stems[b]}.glsl") for a in stems for b in stems]
    assert engine_accepts(folder, pairs) == [a == b for a in stems for b in stems]
