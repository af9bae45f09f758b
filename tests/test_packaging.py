"""The wheel a user installs: built from the repository, it holds every file of the package (kernels, shader
templates and tables included) and, installed alone, bakes and reads a LUT from a folder outside the clone."""

import subprocess
import sys
import zipfile

import pytest
from conftest import ROOT


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    dist = tmp_path_factory.mktemp("dist")
    out = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(ROOT)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr
    (built,) = dist.glob("lutbake-*.whl")
    return built


def test_wheel_holds_every_file_of_the_package(wheel):
    tracked = subprocess.run(
        ["git", "ls-files", "lutbake"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()
    with zipfile.ZipFile(wheel) as archive:
        packed = set(archive.namelist())
    assert tracked and sorted(set(tracked) - packed) == []


def test_installed_wheel_bakes_and_inspects_from_another_folder(wheel, tmp_path):
    target, elsewhere = tmp_path / "site", tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(wheel)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr
    env = {"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}

    def lutbake(*args):
        return subprocess.run(
            [sys.executable, "-m", "lutbake", *args],
            cwd=elsewhere,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )

    where = subprocess.run(
        [sys.executable, "-c", "import lutbake; print(lutbake.__file__)"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
    )
    assert where.stdout.startswith(str(target)), where
    baked = lutbake(
        "bake",
        "--quiet",
        "--backend",
        "opencl",
        "--eta2",
        "1.4",
        "--cos-theta",
        "0:1:8",
        "--opd",
        "0:1000:8",
        "--eta3",
        "1:2:2",
        "--kappa3",
        "0:1:2",
        "--out",
        "wheel-test.exr",
    )
    assert baked.returncode == 0, baked.stderr
    assert sorted(p.name for p in elsewhere.iterdir()) == [f"wheel-test.{s}" for s in ("exr", "glsl", "hlsl", "json")]
    assert lutbake("inspect", "wheel-test.exr").returncode == 0
