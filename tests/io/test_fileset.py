"""File sets as one unit (issue 16): kills inside every commit window, concurrent writers, stale
temporaries, the scene cache, working-folder independence and Ctrl-C at start-up. Real processes."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from commit_stops import kill_at, stopping_cli
from engine_harness import engine_accepts
from hostile_cases import TINY

from lutbake.io.fileset import sha256_file
from lutbake.tables.headers import exr_header
from lutbake.tables.lutfile import read_lut

SCENE = """[materials.soap]
film = {film}
thickness_nm = 300
base = 1.0
"""
STOPS_LUT = 5  # the journal, then four renames
STOPS_SCENE = 5  # the journal, then atlas, two includes, manifest


def _start(*args, cwd, stop=False):
    return subprocess.Popen(
        stopping_cli(*args) if stop else [sys.executable, "-m", "lutbake.cli", *args],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _run(*args, cwd):
    proc = _start(*args, cwd=cwd)
    out, err = proc.communicate(timeout=300)
    return proc.returncode, out, err


def _lut_hashes(folder: Path, name="x"):
    """content_hash of each of the four members of a LUT set."""
    meta, _ = read_lut(folder / f"{name}.exr")
    glsl, hlsl = ((folder / f"{name}.{s}").read_text() for s in ("glsl", "hlsl"))
    sidecar = json.loads((folder / f"{name}.json").read_text())["content_hash"]
    return meta["content_hash"], sidecar, meta["content_hash"] in glsl, meta["content_hash"] in hlsl


def _assert_lut_set(folder: Path, expected_hash: str):
    exr, sidecar, in_glsl, in_hlsl = _lut_hashes(folder)
    assert exr == sidecar == expected_hash and in_glsl and in_hlsl
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".")]


@pytest.fixture(scope="module")
def lut_sets(tmp_path_factory):
    """Content hashes of the η2 1.5 (old) and 1.33 (new) tiny LUTs."""
    folder = tmp_path_factory.mktemp("ref")
    hashes = {}
    for eta2 in ("1.5", "1.33"):
        rc, _, err = _run("bake", "--eta2", eta2, *TINY, "--out", f"{eta2}.exr", cwd=folder)
        assert rc == 0, err
        hashes[eta2] = read_lut(folder / f"{eta2}.exr")[0]["content_hash"]
    return hashes


def _hash_of(path: Path) -> str:
    """The set a member says it belongs to, read independently of lutbake's readers: the EXR header's
    lutbake.content_hash attribute, or the hash on an include's second line."""
    if path.suffix == ".exr":
        return exr_header(path)["attributes"]["lutbake.content_hash"][1].decode()
    return path.read_text().splitlines()[1].split()[3].rstrip(";")


@pytest.mark.parametrize("stop", range(STOPS_LUT))
def test_lut_bake_killed_in_each_commit_window_leaves_one_whole_set(stop, tmp_path, lut_sets):
    """kill -9 before the journal and between each rename after it (members renamed in the order exr,
    json, glsl, hlsl): lutbake's readers refuse the set while its journal is there; an engine's loader,
    which knows nothing of journals, refuses exactly the EXR + include pairs of two different bakes."""
    assert _run("bake", "--eta2", "1.5", *TINY, "--out", "x.exr", cwd=tmp_path)[0] == 0
    kill_at(_start("bake", "--eta2", "1.33", *TINY, "--out", "x.exr", cwd=tmp_path, stop=True), stop)
    journaled = (tmp_path / ".x.exr.commit").exists()
    assert journaled == (stop > 0)
    if journaled:  # readers refuse a set that is mid-commit
        rc, _, err = _run("inspect", "x.exr", cwd=tmp_path)
        assert rc == 2 and "mid-commit" in err and len(err.strip().splitlines()) == 1
    pairs = [("x.exr", "x.glsl"), ("x.exr", "x.hlsl")]
    same = [_hash_of(tmp_path / exr) == _hash_of(tmp_path / include) for exr, include in pairs]
    assert engine_accepts(tmp_path, pairs) == same
    assert same == {0: [True, True], 1: [True, True], 2: [False, False], 3: [False, False], 4: [True, False]}[stop]
    # The next writer of the folder (another LUT here) completes the commit and drops dead temporaries.
    assert _run("bake", "--eta2", "2.0", *TINY, "--out", "other.exr", cwd=tmp_path)[0] == 0
    for p in tmp_path.glob("other.*"):
        p.unlink()
    _assert_lut_set(tmp_path, lut_sets["1.33"] if stop > 0 else lut_sets["1.5"])


def _scene_state(out: Path):
    """(scene hash of the manifest, of the atlas header); asserts every member hash the manifest lists."""
    import OpenEXR

    manifest = json.loads((out / "scene.json").read_text())
    for name, digest in manifest["files"].items():
        assert sha256_file(out / name) == digest, name
    with OpenEXR.File(str(out / "scene.exr")) as exr:
        atlas = json.loads(exr.header()["lutbake.metadata"])
    return manifest["scene_hash"], atlas["scene_hash"]


@pytest.fixture
def two_scenes(tmp_path):
    for folder, film in (("a", "1.33"), ("b", "1.5")):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "scene.toml").write_text(SCENE.format(film=film))
    return tmp_path


@pytest.mark.parametrize("stop", [0, 1, 2, STOPS_SCENE - 1])
def test_scene_bake_killed_in_a_commit_window_is_never_up_to_date_over_another_scene(stop, two_scenes):
    root = two_scenes
    assert _run("bake", "--scene", "a/scene.toml", "--out", "T", cwd=root)[0] == 0
    kill_at(_start("bake", "--scene", "b/scene.toml", "--out", "T", cwd=root, stop=True), stop)
    rc, out, err = _run("bake", "--scene", "a/scene.toml", "--out", "T", "--json", cwd=root)
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["up_to_date"] == (stop == 0)  # before the journal, T still holds a's whole set
    manifest_hash, atlas_hash = _scene_state(root / "T")
    assert manifest_hash == atlas_hash
    assert not [p.name for p in (root / "T").iterdir() if p.name.startswith(".") and p.name != ".lutbake-cache"]


def test_scene_up_to_date_check_verifies_member_hashes(two_scenes):
    root = two_scenes
    assert _run("bake", "--scene", "a/scene.toml", "--out", "T", cwd=root)[0] == 0
    assert _run("bake", "--scene", "b/scene.toml", "--out", "U", cwd=root)[0] == 0
    (root / "T" / "scene.exr").write_bytes((root / "U" / "scene.exr").read_bytes())  # b's atlas, a's manifest
    rc, out, err = _run("bake", "--scene", "a/scene.toml", "--out", "T", "--json", cwd=root)
    assert rc == 0 and not json.loads(out)["up_to_date"], err
    assert len(set(_scene_state(root / "T"))) == 1


def test_concurrent_lut_writers_are_serialized(tmp_path, lut_sets):
    """Two bakes of different sets into one output: both succeed and the result is one whole set."""
    procs = [_start("bake", "--eta2", eta2, *TINY, "--out", "x.exr", cwd=tmp_path) for eta2 in ("1.5", "1.33")]
    for proc in procs:
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
    exr, sidecar, in_glsl, in_hlsl = _lut_hashes(tmp_path)
    assert exr == sidecar and exr in lut_sets.values() and in_glsl and in_hlsl


def test_concurrent_scene_writers_are_serialized(two_scenes):
    root = two_scenes
    procs = [_start("bake", "--scene", f"{s}/scene.toml", "--out", "T", cwd=root) for s in ("a", "b")]
    for proc in procs:
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
    assert len(set(_scene_state(root / "T"))) == 1


def test_stale_temporaries_of_dead_processes_are_removed(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale, live = tmp_path / f".x.exr.tmp-{dead.pid}", tmp_path / f".y.exr.tmp-{os.getpid()}"
    stale.write_bytes(b"partial LUT of a killed bake")
    live.write_bytes(b"a live writer's temporary")
    assert _run("bake", "--eta2", "1.5", *TINY, "--out", "x.exr", cwd=tmp_path)[0] == 0
    assert not stale.exists() and live.exists()


def test_scene_bytes_do_not_depend_on_the_working_folder(tmp_path):
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "scene.toml").write_text(SCENE.format(film="1.33"))
    assert _run("bake", "--scene", "scenes/scene.toml", "--out", "T1", cwd=tmp_path)[0] == 0
    assert _run("bake", "--scene", "scene.toml", "--out", "../T2", cwd=tmp_path / "scenes")[0] == 0
    for name in ("scene.json", "scene.glsl", "scene.hlsl", "scene.exr"):
        assert (tmp_path / "T1" / name).read_bytes() == (tmp_path / "T2" / name).read_bytes(), name


@pytest.mark.parametrize("damage", ["wrong shape", "truncated", "not finite"])
def test_bad_cache_entries_are_recomputed(damage, tmp_path):
    (tmp_path / "scene.toml").write_text(SCENE.format(film="1.33"))
    rc, out, err = _run("bake", "--scene", "scene.toml", "--out", "T", "--json", cwd=tmp_path)
    assert rc == 0, err
    first = json.loads(out)
    reference = (tmp_path / "T" / "scene.exr").read_bytes()
    npy = next((tmp_path / "T" / ".lutbake-cache").glob("*.npy"))
    if damage == "wrong shape":  # a valid .npy that would give the atlas a 5 x 3 rect
        np.save(npy, np.zeros((5, 3, 3)))
    elif damage == "truncated":
        npy.write_bytes(npy.read_bytes()[:100])
    else:
        np.save(npy, np.full(np.load(npy).shape, np.nan))
    (tmp_path / "T" / "scene.exr").unlink()  # the set is incomplete: the bake must go to the cache
    rc, out, err = _run("bake", "--scene", "scene.toml", "--out", "T", "--json", cwd=tmp_path)
    assert rc == 0 and "Traceback" not in err, err
    assert json.loads(out)["computed"] == first["computed"] != []
    assert (tmp_path / "T" / "scene.exr").read_bytes() == reference


_SIGNAL_DURING_IMPORT = """
import os, signal, sys
seen = []
signal.signal(signal.SIGINT, lambda *_: seen.append(hasattr(sys.modules.get("pyopencl"), "get_platforms")))
class Hook:   # Ctrl-C while pyopencl's modules load (its C++ extension's enums: a similar moment)
    def find_spec(self, name, path, target=None):
        if name == "pyopencl.tools":
            os.kill(os.getpid(), signal.SIGINT)
sys.meta_path.insert(0, Hook())
from lutbake.integrate.devices import import_pyopencl
import_pyopencl()
print(seen)
"""


def test_ctrl_c_while_pyopencl_loads_arrives_once_it_is_loaded():
    """Ctrl-C that lands while pyopencl initialises must wait: raised inside its C++ extension's
    initialisation, the handler's exception cannot unwind (the process aborted, exit -6, once in CI).
    The signal is held through the first import and handled once pyopencl is whole."""
    out = subprocess.run([sys.executable, "-c", _SIGNAL_DURING_IMPORT], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[True]"  # handled once, after the import (unheld: [False])


@pytest.mark.parametrize("delay", [0.0, 0.1, 0.3, 0.5])
def test_ctrl_c_during_start_up_is_one_line_and_exit_130(delay, tmp_path):
    """Ctrl-C while lutbake's modules load. The clock starts when lutbake's code runs (its start-up
    handler is installed before click is imported): before that, Python's own start-up (.pth files,
    compiling modules in a fresh venv) owns SIGINT and no package can answer for it."""
    # `check` runs for seconds after its imports, so every delay lands while lutbake is still working
    proc = subprocess.Popen(
        [sys.executable, "-X", "importtime", "-m", "lutbake.cli", "check", "--quiet"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    seen = []
    for line in proc.stderr:  # import-time lines: wait for click, imported after the handler
        seen.append(line)
        if line.rstrip().split("|")[-1].strip() == "click":  # at any depth of the import tree
            break
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    out, rest = proc.communicate(timeout=120)
    err = "".join(line for line in seen + rest.splitlines(True) if not line.startswith("import time:"))
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert err.strip().splitlines()[-1] == "lutbake: interrupted"
