"""The Blender the tests run (a Python with bpy, in its own environment because bpy needs numpy < 2):
LUTBAKE_BLENDER, else ./.venv-blender/bin/python, created on first need; shared by tests/engines/test_blender.py
and test_boundary_engine.py."""

import fcntl
import functools
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BPY_VERSION = "5.0.1"
BLENDER_VENV = ROOT / ".venv-blender"  # git-ignored; bpy pins numpy < 2, so not lutbake's environment
INSTALL = (
    f"the tests create it themselves (python3.11 -m venv .venv-blender; .venv-blender/bin/python -m pip "
    f"install bpy=={BPY_VERSION}, a ~370 MB download): install Python 3.11 with its venv module (Debian: "
    "apt-get install python3.11 python3.11-venv) and let pip reach the package index, and Mesa's OpenGL "
    "and the X11 libraries bpy loads (Debian: libgl1 libegl1 libegl-mesa0 libgl1-mesa-dri libx11-6 libxext6 "
    "libxfixes3 libxi6 libxrender1 libxt6 libsm6 libice6 libxkbcommon0); or set LUTBAKE_BLENDER to a "
    f"Blender {BPY_VERSION} executable"
)


def _bpy_version(python: Path) -> tuple:
    """(bpy's version string or None, the import's last error line)."""
    if not python.is_file():
        return None, f"{python} is missing"
    done = subprocess.run(
        [str(python), "-c", "import bpy; print(bpy.app.version_string)"], capture_output=True, text=True, timeout=300
    )
    lines = (done.stderr.strip() or done.stdout.strip() or "no output").splitlines()
    return (done.stdout.strip() if done.returncode == 0 else None), lines[-1]


def _install_blender_module() -> str | None:
    """.venv-blender with bpy BPY_VERSION, created when it is missing or its bpy does not import (an
    interrupted install is rebuilt whole). Under a lock beside it, so test processes running side by
    side (pytest-xdist) install it once. None when it imports, else why not."""
    python = BLENDER_VENV / "bin" / "python"
    with open(ROOT / ".venv-blender.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if _bpy_version(python)[0] == BPY_VERSION:
            return None
        base = shutil.which("python3.11")
        if base is None:
            return "no python3.11 on PATH"
        shutil.rmtree(BLENDER_VENV, ignore_errors=True)
        steps = {
            "python3.11 -m venv": [base, "-m", "venv", str(BLENDER_VENV)],
            f"pip install bpy=={BPY_VERSION}": [
                str(python),
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
                f"bpy=={BPY_VERSION}",
            ],
        }
        for name, command in steps.items():
            try:
                done = subprocess.run(command, capture_output=True, text=True, timeout=1800)
            except subprocess.TimeoutExpired:
                done = subprocess.CompletedProcess(command, 1, "", "did not finish in 30 min")
            if done.returncode != 0:
                shutil.rmtree(BLENDER_VENV, ignore_errors=True)
                lines = (done.stderr.strip() or done.stdout.strip() or "no output").splitlines()
                return f"{name} failed: {lines[-1]}"
        version, error = _bpy_version(python)
        return None if version == BPY_VERSION else f"bpy {BPY_VERSION} installed but does not import: {error}"


@functools.cache
def _chosen_blender() -> tuple:
    """(the Blender to run, None) or (None, what is wrong), once per test process."""
    chosen = os.environ.get("LUTBAKE_BLENDER")
    if chosen is None:
        failure = _install_blender_module()
        return (
            (None, f"bpy {BPY_VERSION} in .venv-blender ({failure})")
            if failure
            else (str(BLENDER_VENV / "bin" / "python"), None)
        )
    if not Path(chosen).is_file():
        return None, f"LUTBAKE_BLENDER={chosen!r} to be a file (or unset)"
    version, error = _bpy_version(Path(chosen)) if Path(chosen).name.startswith("python") else (BPY_VERSION, "")
    return (
        (chosen, None)
        if version == BPY_VERSION
        else (None, f"LUTBAKE_BLENDER={chosen!r} to have bpy {BPY_VERSION} ({error}), or to be unset")
    )


def blender_python() -> str:
    """The Blender the tests run: LUTBAKE_BLENDER (read here, at the tests' edge, and passed on as an
    argument), else .venv-blender/bin/python, installed on first need; fails (never skips) with what to
    install."""
    blender, wrong = _chosen_blender()
    if wrong:
        pytest.fail(f"the Blender tests need {wrong}; {INSTALL}", pytrace=False)
    return blender


# Run inside Blender by blend_file_state: opens a .blend, optionally unpacks it as a user would (File → External
# Data → Unpack Resources → Write Files to Original Location) and saves it, runs Report Missing Files (which
# prints its reports in the background) and prints one JSON line of the file's images and text blocks.
_FILE_STATE = """
import bpy, json, sys
blend, unpack = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
if unpack == "unpack":
    bpy.ops.file.unpack_all(method="WRITE_ORIGINAL")
    bpy.ops.wm.save_mainfile()
bpy.ops.file.report_missing_files()
state = {
    "images": {i.name: {"path": i.filepath, "packed": i.packed_file is not None} for i in bpy.data.images},
    "texts": {t.name: t.as_string().splitlines()[0] for t in bpy.data.texts},
}
print("STATE " + json.dumps(state))
"""


def blend_file_state(blender: str, blend: Path, unpack: bool = False) -> dict:
    """What Blender says of the .blend ``blend``: ``images`` (name → path and whether it is packed), ``texts``
    (name → first line), ``missing`` (the lines of Report Missing Files naming a path it did not find, and
    ``none_missing``: whether it said there are none), after unpacking every packed file to its original
    location when ``unpack``."""
    args = [str(blend), "unpack" if unpack else "keep"]
    command = (
        [blender, "-c", _FILE_STATE, *args]
        if Path(blender).name.startswith("python")
        else [blender, "--background", "--factory-startup", "--python-expr", _FILE_STATE, "--", *args]
    )
    done = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    state = json.loads(next(line for line in lines if line.startswith("STATE "))[len("STATE ") :])
    return {
        **state,
        "missing": [line for line in lines if "not found" in line],
        "none_missing": any("No missing files" in line for line in lines),
    }
