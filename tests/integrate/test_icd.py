"""Intel's CPU runtime registered by the user, not by lutbake: the vendor folder lutbake writes for
OCL_ICD_VENDORS, and `lutbake devices` saying when the runtime is installed but not registered."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from lutbake.integrate import icd

_KEYS = (
    "import json; from lutbake.integrate.devices import device_key, opencl_devices; "
    "print(json.dumps([device_key(d) for d in opencl_devices()]))"
)


def _run(args, env):
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env, timeout=300)


def test_the_vendor_folder_links_the_systems_runtimes_and_names_intels(tmp_path):
    """A link to each .icd of the system's folder and one .icd naming Intel's library; written again, it is
    brought up to date (an .icd the system no longer holds goes, what it holds now comes)."""
    system, library = tmp_path / "system", tmp_path / "libintelocl.so"
    system.mkdir()
    library.write_bytes(b"")
    for name in ("pocl.icd", "gpu.icd"):
        (system / name).write_text(f"lib{name[:-4]}.so\n")
    (system / "notes.txt").write_text("not an icd")
    folder = icd.write_vendor_folder(tmp_path / "vendors", library, system)
    assert sorted(p.name for p in folder.iterdir()) == ["gpu.icd", icd.INTEL_ICD, "pocl.icd"]
    assert (folder / "pocl.icd").resolve() == (system / "pocl.icd").resolve()
    assert (folder / icd.INTEL_ICD).read_text() == f"{library.resolve()}\n"
    (system / "gpu.icd").unlink()
    (system / "new.icd").write_text("libnew.so\n")
    icd.write_vendor_folder(folder, library, system)
    assert sorted(p.name for p in folder.iterdir()) == [icd.INTEL_ICD, "new.icd", "pocl.icd"]
    with pytest.raises(ValueError, match="is the system's own"):
        icd.write_vendor_folder(system, library, system)


def test_intel_vendor_folder_refuses_an_environment_without_intels_runtime(tmp_path, monkeypatch):
    monkeypatch.setattr(icd, "environment_intel_library", lambda: None)
    with pytest.raises(ValueError, match="not installed"):
        icd.intel_vendor_folder(tmp_path)
    assert not any(tmp_path.iterdir())


def test_devices_says_when_intels_runtime_is_not_registered_and_icd_folder_registers_it(tmp_path):
    """Without OCL_ICD_VENDORS lutbake lists no Intel device, and `lutbake devices` names the installed,
    unregistered runtime and the command that registers it; the folder `--icd-folder` prints, exported,
    lists Intel's runtime beside the others (the system's PoCL still among them)."""
    library = icd.environment_intel_library()
    env = {k: v for k, v in os.environ.items() if k != "OCL_ICD_VENDORS"}
    env["LUTBAKE_CACHE_DIR"] = str(tmp_path / "cache")
    alone = _run(["-c", _KEYS], env)
    assert alone.returncode == 0, alone.stderr
    assert "intel-pypi" not in json.loads(alone.stdout)
    survey = _run(["-m", "lutbake.cli", "devices", "--json"], env)
    assert survey.returncode == 0, survey.stderr
    assert json.loads(survey.stdout)["unregistered_intel"] == (library and str(library))
    if library is None:  # the cpu extra is not installed: nothing to register
        assert _run(["-m", "lutbake.cli", "devices", "--icd-folder"], env).returncode == 2
        return
    text = _run(["-m", "lutbake.cli", "devices"], env).stdout.splitlines()
    assert text[-1] == (
        f"Intel's OpenCL CPU runtime ({library}) is installed but not registered: "
        "export OCL_ICD_VENDORS=$(lutbake devices --icd-folder) to use it"
    )
    written = _run(["-m", "lutbake.cli", "devices", "--icd-folder"], env)
    assert written.returncode == 0, written.stderr
    folder = Path(written.stdout.strip())
    assert folder == tmp_path / "cache" / icd.VENDOR_FOLDER and folder.is_dir()
    registered = _run(["-c", _KEYS], {**env, "OCL_ICD_VENDORS": str(folder)})
    assert registered.returncode == 0, registered.stderr
    keys = set(json.loads(registered.stdout))
    assert "intel-pypi" in keys and set(json.loads(alone.stdout)) <= keys, (alone.stdout, registered.stdout)
