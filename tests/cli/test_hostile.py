"""Hostile inputs (issue 16): a seeded table of bad sizes, headers, scenes, CSVs, paths and names.

Every case runs the command line in-process (a fresh working folder each) under a SIGALRM guard, and
asserts (tests/hostile_cases.run_case): exit code in {0, 1, 2}; no traceback; for exit 2 one stderr line and
nothing written; no NaN printed. Kill, concurrency and Ctrl-C tests run real processes (tests/io/test_fileset.py).
"""

import json
import textwrap
from pathlib import Path

import numpy as np
import pytest
from hostile_cases import TINY, run_case, tree_digests, write_exr


def _bake(*extra):
    return ["bake", "--eta2", "1.5", *TINY[:8], *extra, "--backend", "numpy", "--quiet", "--out", "x.exr"]


def _with_axis(flag, value):
    args = list(TINY)
    args[args.index(flag) + 1] = value
    return ["bake", "--eta2", "1.5", *args, "--out", "x.exr"]


SIZES = {
    "count 1e20": (_with_axis("--cos-theta", "0:1:99999999999999999999"), {2}),
    "counts 2^32 x 2^32": (
        ["bake", "--eta2", "1.5", "--cos-theta", "0:1:4294967296", "--opd", "0:1:4294967296", "--out", "x.exr"],
        {2},
    ),
    "count 2.5e8 under the old cell limit": (
        [
            "bake",
            "--eta2",
            "1.5",
            "--cos-theta",
            "0:1:250000000",
            "--opd",
            "0:1000:2",
            "--eta3",
            "1:2:2",
            "--kappa3",
            "0:1:2",
            "--out",
            "x.exr",
        ],
        {2},
    ),
    "peak memory over the budget": (
        [
            "bake",
            "--eta2",
            "1.5",
            "--cos-theta",
            "0:1:4000000",
            "--opd",
            "0:1000:2",
            "--eta3",
            "1:2:100",
            "--kappa3",
            "0:1:2",
            "--out",
            "x.exr",
        ],
        {2},
    ),
    "cells over the limit": (
        ["bake", "--eta2", "1.5", "--cos-theta", "0:1:10000", "--opd", "0:1000:10000", "--out", "x.exr"],
        {2},
    ),
    "opd 1e308": (_with_axis("--opd", "0:1e308:16"), {2}),
    "opd inf": (_with_axis("--opd", "0:inf:16"), {2}),
    "count 1": (_with_axis("--eta3", "1:2:1"), {2}),
    "count 0": (_with_axis("--eta3", "1:2:0"), {2}),
    "count -5": (_with_axis("--eta3", "1:2:-5"), {2}),
    "count not an integer": (_with_axis("--eta3", "1:2:2.5"), {2}),
    "min = max": (_with_axis("--kappa3", "1:1:4"), {2}),
    "nan bound": (_with_axis("--kappa3", "nan:1:4"), {2}),
    "unknown spacing": (_with_axis("--kappa3", "0:1:4:log"), {2}),
    "kappa3 1e308": (_with_axis("--kappa3", "0:1e308:2"), {2}),
    "eta3 1e308": (_with_axis("--eta3", "1:1e308:2"), {2}),
    "eta2 1e308": (["bake", "--eta2", "1e308", *TINY, "--out", "x.exr"], {2}),
    "eta2 nan": (["bake", "--eta2", "nan", *TINY, "--out", "x.exr"], {2}),
    "eta1 1e-300": (["bake", "--eta2", "1.5", "--eta1", "1e-300", *TINY, "--out", "x.exr"], {2}),
    "samples per cycle 1e9": (_bake("--samples-per-cycle", "1e9"), {2}),
    "memory limit 0": (_bake("--max-memory-gib", "0"), {2}),
    "tiny valid bake": (_bake(), {0}),
}

EVALS = {
    "eval eta2 1e308": (["eval", "--eta2", "1e308", "--thickness", "300", "--cos-theta", "1", "--eta3", "1.5"], {2}),
    "eval eta3 kappa3 1e308": (
        ["eval", "--eta2", "1.3", "--thickness", "300", "--cos-theta", "1", "--eta3", "1e308", "--kappa3", "1e308"],
        {2},
    ),
    "eval eta1 1e-300": (
        ["eval", "--eta1", "1e-300", "--eta2", "1.3", "--thickness", "300", "--cos-theta", "1", "--eta3", "1.5"],
        {2},
    ),
    "eval absorbing film": (["eval", "--film", "Ag", "--thickness", "300", "--cos-theta", "1", "--eta3", "1.5"], {2}),
    "eval unknown film": (
        ["eval", "--film", "unobtainium", "--thickness", "300", "--cos-theta", "1", "--eta3", "1.5"],
        {2},
    ),
    "eval thickness 1e300": (
        ["eval", "--eta2", "1.3", "--thickness", "1e300", "--cos-theta", "1", "--eta3", "1.5"],
        {2},
    ),
    "eval optical path past the bound": (
        ["eval", "--eta2", "4", "--thickness", "1e5", "--cos-theta", "1", "--eta3", "1.5"],
        {2},
    ),
    "eval angle 91": (["eval", "--eta2", "1.3", "--thickness", "300", "--angle", "91", "--eta3", "1.5"], {2}),
    "eval wavelength 100": (
        ["eval", "--eta2", "1.3", "--thickness", "300", "--cos-theta", "1", "--eta3", "1.5", "--wavelength", "100"],
        {2},
    ),
    "eval at the domain corner": (
        [
            "eval",
            "--eta1",
            "0.01",
            "--eta2",
            "10",
            "--thickness",
            "100",
            "--cos-theta",
            "0",
            "--eta3",
            "10",
            "--kappa3",
            "1000",
        ],
        {0},
    ),
    "eval valid": (["eval", "--film", "TiO2", "--thickness", "300", "--cos-theta", "0.5", "--base", "Cu"], {0}),
}

CSVS = {
    "csv duplicated column": ("eta2,eta2,thickness_nm,cos_theta,eta3\n1.3,1.3,300,1,1.5\n", {2}),
    "csv unknown column": ("eta2,thick,cos_theta,eta3\n1.3,300,1,1.5\n", {2}),
    "csv not a number": ("eta2,thickness_nm,cos_theta,eta3\n1.3,abc,1,1.5\n", {2}),
    "csv ragged row": ("eta2,thickness_nm,cos_theta,eta3\n1.3,300,1\n", {2}),
    "csv empty": ("", {2}),
    "csv header only": ("eta2,thickness_nm,cos_theta,eta3\n", {2}),
    "csv nan cell": ("eta2,thickness_nm,cos_theta,eta3\nnan,300,1,1.5\n", {2}),
    "csv 1e308 cell": ("eta2,thickness_nm,cos_theta,eta3\n1e308,300,1,1.5\n", {2}),
    "csv binary garbage": ("\x00\x01\xff,\n\x02\n", {2}),
    "csv valid": ("eta2,thickness_nm,cos_theta,eta3,kappa3\n1.3,300,1,1.5,0\n1.5,100,0.2,2.0,3\n", {0}),
}

_SCENE_OK = """
[materials.soap]
film = 1.33
thickness_nm = 300
base = 1.0
"""


def _mat(name, film="1.33", thickness="300", base="1.0"):
    return f"[materials.{name}]\nfilm = {film}\nthickness_nm = {thickness}\nbase = {base}\n"


SCENES = {
    "materials = 5": ("materials = 5\n", {2}),
    "materials as an array of tables": ("[[materials]]\nfilm = 1.3\n", {2}),
    "material body not a table": ("[materials]\nsoap = 5\n", {2}),
    "names collide after sanitising (a-b, a_b)": (_mat('"a-b"') + _mat("a_b"), {2}),
    "names collide by case (steel, STEEL)": (_mat("steel") + _mat("STEEL"), {2}),
    "non-ASCII name": (_mat('"stål"'), {2}),
    "empty name": (_mat('""'), {2}),
    "name with a space": (_mat('"two words"'), {2}),
    "absorbing named film": (_mat("x", film='"Ag"'), {2}),
    "film not a number or name": (_mat("x", film="true"), {2}),
    "thickness 1e300": (_mat("x", thickness="1e300"), {2}),
    "thickness range to 1e6": (_mat("x", thickness="[0, 1e6]"), {2}),
    "thickness range reversed": (_mat("x", thickness="[500, 100]"), {2}),
    "thickness range of one": (_mat("x", thickness="[300]"), {2}),
    "film index 1e300": (_mat("x", film="1e300"), {2}),
    "base index 1e300": (_mat("x", base="{ eta3 = 1e300 }"), {2}),
    "unknown base material": (_mat("x", base='"unobtainium"'), {2}),
    "eta1 = 1e300": ("[scene]\neta1 = 1e300\n" + _SCENE_OK, {2}),
    "max_de = 1e-300": ("[scene]\nmax_de = 1e-300\n" + _SCENE_OK, {2}),
    "space unknown": ("[scene]\nspace = 'srgb-ish'\n" + _SCENE_OK, {2}),
    "scene is a string": ("scene = 'x'\n" + _SCENE_OK, {2}),
    "unknown top-level key": ("colour = 1\n" + _SCENE_OK, {2}),
    "invalid TOML": ("[materials.x\nfilm = \n", {2}),
    "no materials": ("[scene]\nmax_de = 1.0\n", {2}),
    "valid scene": (_SCENE_OK, {0}),
}


def _random_scene(rng) -> str:
    """A scene with each field drawn from valid and hostile values."""
    films = ["1.33", "1.5", '"water"', '"SiO2"', '"Ag"', '"Fe2O3"', "0", "-1", "1e300", "true", '"nosuch"', "[1, 2]"]
    thick = ["300", "[100, 400]", "0", "-5", "1e300", "[400, 100]", "[1, 2, 3]", '"thin"', "nan", "inf"]
    bases = [
        "1.0",
        '"Cu"',
        "{ eta3 = 2.7, kappa3 = 2.8 }",
        "{ kappa3 = 1 }",
        "{ eta3 = 0 }",
        '"nosuch"',
        "{ eta3 = 1.5, colour = 1 }",
        "{ eta3 = 1e308, kappa3 = 1e308 }",
        "[]",
    ]
    names = ["soap", "a-b", "a_b", "STEEL", "steel", '"ü"', '""', "x1"]
    settings = [
        "",
        "[scene]\nmax_de = 1e-300\n",
        "[scene]\neta1 = 1e-300\n",
        "[scene]\nprecision = 'double'\n",
        "[scene]\nobserver = 'cie1964'\n",
    ]
    body = rng.choice(settings)
    for name in rng.choice(names, rng.integers(1, 3), replace=False):
        body += _mat(name, rng.choice(films), rng.choice(thick), rng.choice(bases))
    return body


@pytest.mark.parametrize("name", list(SIZES))
def test_hostile_sizes(name, tmp_path, capfd, monkeypatch):
    argv, expected = SIZES[name]
    rc, _, _ = run_case(argv, tmp_path, capfd, monkeypatch, expected)
    if rc == 0:
        assert sorted(p.name for p in tmp_path.iterdir()) == ["x.exr", "x.glsl", "x.hlsl", "x.json"]


@pytest.mark.parametrize("name", list(EVALS))
def test_hostile_eval(name, tmp_path, capfd, monkeypatch):
    argv, expected = EVALS[name]
    rc, out, _ = run_case(argv, tmp_path, capfd, monkeypatch, expected)
    if rc == 0:
        rgb = [float(v) for v in out.split("RGB")[1].split("XYZ")[0].split()]
        assert len(rgb) == 3 and all(np.isfinite(rgb))


@pytest.mark.parametrize("name", list(CSVS))
def test_hostile_csv(name, tmp_path, capfd, monkeypatch):
    text, expected = CSVS[name]
    (tmp_path / "p.csv").write_text(text, encoding="latin-1")
    rc, out, _ = run_case(["eval", "--points", "p.csv"], tmp_path, capfd, monkeypatch, expected)
    if rc == 0:
        assert out.count("RGB") == text.count("\n") - 1


@pytest.mark.parametrize("name", list(SCENES))
def test_hostile_scenes(name, tmp_path, capfd, monkeypatch):
    text, expected = SCENES[name]
    (tmp_path / "s.toml").write_text(textwrap.dedent(text), encoding="utf-8")
    rc, _, err = run_case(["plan", "--scene", "s.toml"], tmp_path, capfd, monkeypatch, expected)
    if rc == 2:
        assert "s.toml" in err  # names the file
    rc_bake, _, _ = run_case(["bake", "--scene", "s.toml", "--out", "T"], tmp_path, capfd, monkeypatch, expected)
    assert rc_bake == rc
    if rc == 2:
        assert not (tmp_path / "T").exists()


@pytest.mark.parametrize("seed", range(20))
def test_fuzzed_scenes(seed, tmp_path, capfd, monkeypatch):
    """Seeded random scenes: plan either accepts them or refuses with one line naming the file."""
    (tmp_path / "s.toml").write_text(_random_scene(np.random.default_rng(seed)), encoding="utf-8")
    rc, _, err = run_case(["plan", "--scene", "s.toml"], tmp_path, capfd, monkeypatch, {0, 2})
    if rc == 2:
        assert "s.toml" in err


# --- headers: tampered and foreign LUTs ------------------------------------------------------------


@pytest.fixture(scope="module")
def good_lut(tmp_path_factory):
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.lut.bake import bake

    axes = (
        Axis("cos_theta", 0.0, 1.0, 4),
        Axis("opd_nm", 0.0, 1000.0, 4),
        Axis("eta3", 1.0, 2.0, 2),
        Axis("kappa3", 0.0, 1.0, 2),
    )
    path = tmp_path_factory.mktemp("lut") / "good.exr"
    bake(BakeSpec(eta2=1.5, axes=axes), path, "numpy")
    return path


def _tamper(meta, image, edit):
    meta = json.loads(json.dumps(meta))
    return edit(meta, image)


def _drop(key):
    return lambda m, im: ({k: v for k, v in m.items() if k != key}, im)


def _axis(field, value, index=1):
    def edit(m, im):
        m["axes"][index][field] = value
        return m, im

    return edit


HEADERS = {
    "no constants": _drop("constants"),
    "no packing": _drop("packing"),
    "no spectral": _drop("spectral"),
    "no axes": _drop("axes"),
    "metadata a JSON list": lambda m, im: ([1, 2, 3], im),
    "metadata a JSON string": lambda m, im: ("lutbake", im),
    "axis count larger than the image": _axis("count", 400),
    "axis count 1": _axis("count", 1),
    "axis count a string": _axis("count", "4"),
    "NaN bound": _axis("min", float("nan")),
    "min = max": _axis("max", 0.0),
    "unknown spacing": _axis("spacing", "log"),
    "axes reordered": lambda m, im: ({**m, "axes": m["axes"][::-1]}, im),
    "1x1 image": lambda m, im: (m, im[:1, :1]),
    "eta2 negative": lambda m, im: ({**m, "constants": {"eta1": 1.0, "eta2": -1.0}}, im),
    "NaN texels": lambda m, im: (m, np.full_like(im, np.nan)),
    "format version 7": lambda m, im: ({**m, "format_version": 7}, im),  # one past what this reader knows
    "admittance on kappa3": lambda m, im: (
        {**m, "axes": [*m["axes"][:3], {**m["axes"][3], "spacing": "admittance"}]},
        im,
    ),
    "root4 in a v2 file": lambda m, im: (
        {**m, "format_version": 2, "axes": [{**m["axes"][0], "spacing": "root4"}, *m["axes"][1:]]},
        im,
    ),
    "admittance in a v1 file": lambda m, im: (
        {**m, "format_version": 1, "axes": [*m["axes"][:2], {**m["axes"][2], "spacing": "admittance"}, m["axes"][3]]},
        im,
    ),
    "sqrt-admittance in a v3 file": lambda m, im: (
        {
            **m,
            "format_version": 3,
            "axes": [*m["axes"][:2], {**m["axes"][2], "spacing": "sqrt-admittance"}, m["axes"][3]],
        },
        im,
    ),
    "sqrt-admittance on opd": lambda m, im: (
        {**m, "axes": [m["axes"][0], {**m["axes"][1], "spacing": "sqrt-admittance"}, *m["axes"][2:]]},
        im,
    ),
    "admittance below eta1": lambda m, im: (
        {**m, "axes": [*m["axes"][:2], {**m["axes"][2], "spacing": "admittance", "min": 0.5}, m["axes"][3]]},
        im,
    ),
    "spectral counts empty": lambda m, im: ({**m, "spectral": {**m["spectral"], "counts": []}}, im),
}


@pytest.mark.parametrize("command", ["inspect", "sample", "report"])
@pytest.mark.parametrize("name", list(HEADERS))
def test_hostile_headers(name, command, good_lut, tmp_path, capfd, monkeypatch):
    from lutbake.tables.lutfile import read_lut

    meta, image = read_lut(good_lut)
    meta, image = _tamper(meta, image.astype(np.float32), HEADERS[name])
    write_exr(tmp_path / "bad.exr", json.dumps(meta), image)
    extra = {
        "inspect": [],
        "report": ["--points", "10", "--no-approximations"],
        "sample": ["--cos-theta", "0.5", "--opd", "100", "--eta3", "1.5"],
    }[command]
    _, _, err = run_case([command, "bad.exr", *extra], tmp_path, capfd, monkeypatch, {2})
    assert "bad.exr" in err


FILES = {
    "truncated EXR": lambda good, path: path.write_bytes(good.read_bytes()[: good.stat().st_size - 300]),
    "half an EXR header": lambda good, path: path.write_bytes(good.read_bytes()[:200]),
    "text file": lambda good, path: path.write_text("not an exr\n"),
    "empty file": lambda good, path: path.write_bytes(b""),
    "EXR without lutbake metadata": lambda good, path: write_exr(path, None, np.zeros((2, 2, 3))),
    "metadata not JSON": lambda good, path: write_exr(path, "{not json", np.zeros((2, 2, 3))),
    "a folder": lambda good, path: path.mkdir(),
    "missing": lambda good, path: None,
}


@pytest.mark.parametrize("name", list(FILES))
def test_hostile_lut_files(name, good_lut, tmp_path, capfd, monkeypatch):
    FILES[name](good_lut, tmp_path / "bad.exr")
    _, out, err = run_case(["inspect", "bad.exr"], tmp_path, capfd, monkeypatch, {2})
    assert "bad.exr" in err and out == ""  # no OpenEXR noise on stdout


# --- paths -----------------------------------------------------------------------------------------


def test_member_path_that_is_a_folder_keeps_the_old_set(tmp_path, capfd, monkeypatch):
    """The issue's mkdir lut.glsl case: exit 2 and the η2 1.5 set stays whole (no mixed set)."""
    run_case(_bake(), tmp_path, capfd, monkeypatch, {0})
    (tmp_path / "x.glsl").unlink()
    (tmp_path / "x.glsl").mkdir()
    before = tree_digests(tmp_path)
    argv = _bake()
    argv[argv.index("1.5")] = "1.33"
    _, _, err = run_case(argv, tmp_path, capfd, monkeypatch, {2})
    assert "x.glsl" in err and tree_digests(tmp_path) == before


@pytest.mark.parametrize("member", ["s.exr", "s.json", "s.glsl", ".lutbake-cache"])
def test_scene_output_in_the_way_writes_nothing(member, tmp_path, capfd, monkeypatch):
    (tmp_path / "s.toml").write_text(_SCENE_OK)
    out = tmp_path / "T"
    out.mkdir()
    if member == ".lutbake-cache":
        (out / member).write_text("a file where the cache folder goes")
    else:
        (out / member).mkdir()
    _, _, err = run_case(["bake", "--scene", "s.toml", "--out", "T"], tmp_path, capfd, monkeypatch, {2})
    assert member in err


@pytest.mark.parametrize(
    "argv",
    [
        ["bake", "--scene", "s.toml", "--out", "f.txt"],
        ["bake", "--scene", "s.toml", "--out", "T.exr"],
        ["bake", "--scene", "missing.toml", "--out", "T"],
        ["bake", "--scene", ".", "--out", "T"],
        ["bake", "--eta2", "1.5", *TINY, "--out", "f.txt/x.exr"],
        ["bake", "--eta2", "1.5", *TINY, "--out", "x.txt"],
        ["bake", "--eta2", "1.5", *TINY, "--out", "nowhere/x.exr"],
        ["bake", "--out", "f.txt"],
        ["sweep", "--eta2", "1.5", "--opd", "0:1e308:16", "--out", "S"],
        ["sweep", "--eta2", "1.5", "--eta3", "1:2:1", "--out", "S"],
        ["sweep", "--eta2", "1.5", *TINY[:8], "--out", "f.txt"],
    ],
)
def test_hostile_paths(argv, tmp_path, capfd, monkeypatch):
    (tmp_path / "s.toml").write_text(_SCENE_OK)
    (tmp_path / "f.txt").write_text("a file")
    run_case(argv, tmp_path, capfd, monkeypatch, {2})
    assert not (tmp_path / "S").exists() and not (tmp_path / "T").exists()


# --- budgets ---------------------------------------------------------------------------------------


def test_cells_are_exact_integers_checked_before_work():
    """2^24 × 2^24 × 2 × 2 overflows int64 arithmetic nowhere: the limit sees the exact count."""
    from lutbake.grid.axis import MAX_COUNT
    from lutbake.grid.spec import Axis, BakeSpec

    axes = (
        Axis("cos_theta", 0.0, 1.0, MAX_COUNT),
        Axis("opd_nm", 0.0, 1.0, MAX_COUNT),
        Axis("eta3", 1.0, 2.0, 2),
        Axis("kappa3", 0.0, 1.0, 2),
    )
    with pytest.raises(ValueError, match=f"grid of {4 * MAX_COUNT**2} cells exceeds"):
        BakeSpec(eta2=1.5, axes=axes)


def test_peak_memory_estimate_covers_the_measured_peaks():
    """Every bake bench/bench_memory.py measured (its shapes, each in its own process) peaked below the
    estimate its budget checks before any work (tests/grid/test_memory.py measures the model's accuracy)."""
    from lutbake.lut.bake import default_specs

    rows = json.loads((Path(__file__).resolve().parents[2] / "bench" / "memory-result.json").read_text())
    assert rows and all(row["peak_rss_mib"] <= row["estimate_before_work_mib"] for row in rows)
    spec = next(iter(default_specs().values()))
    budget = spec.budget()
    assert spec.precision == "half" and budget["output_bytes"] == spec.cells * 3 * 2  # RGB, 2 bytes each


def test_scene_target_not_met_at_the_cap_exits_1_with_what_was_reached(tmp_path, capfd, monkeypatch):
    """A target no slice within the cap can meet: the set is written, exit 1, the reached p99 named."""
    import lutbake.scene.jobs

    monkeypatch.setattr(lutbake.scene.jobs, "MAX_SLICE_COUNT", 8)  # a small cap keeps the case fast
    (tmp_path / "s.toml").write_text("[scene]\nmax_de = 0.01\n" + _mat("soap", thickness="[100, 600]"))
    _, _, err = run_case(["bake", "--scene", "s.toml", "--out", "T"], tmp_path, capfd, monkeypatch, {1})
    manifest = json.loads((tmp_path / "T" / "s.json").read_text())
    reached = manifest["materials"]["soap"]["de00_p99"]
    assert reached > 0.01 and f"soap p99 ΔE00 {reached:.3f}" in err and len(err.strip().splitlines()) == 1
