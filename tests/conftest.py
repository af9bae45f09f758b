"""Shared fixtures. Kernel tests run once per OpenCL device that builds the kernel
(parametrized by ``kernel_device``, the device's key in the test id: ``[pocl-system]``,
``[pocl-pypi]``, ``[intel-pypi]``); the summary names each runtime (which PoCL, which Intel)
and lists which were exercised and which could not be."""

import atexit
import fcntl
import os
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

# One BLAS thread per test process (and the CLI processes tests start): pytest-xdist already runs one
# worker per core, and OpenBLAS threads competing for a busy core made numpy.linalg calls (the
# Gauss–Legendre nodes under `lutbake check`) 3–6× slower. Set before numpy loads OpenBLAS.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest

warnings.filterwarnings("ignore", module="colour")


def _register_intel_runtime() -> None:
    """Intel's CPU runtime from the cpu extra registered beside the system's runtimes for this process and
    those it starts (pytest-xdist's workers, the CLI), as a user registers it (docs/devices.md): a vendor
    folder from lutbake's own function, named by OCL_ICD_VENDORS before pyopencl loads. An OCL_ICD_VENDORS
    already set (the caller's choice, or this process's parent's folder) is left as it is."""
    from lutbake.integrate.icd import SYSTEM_VENDORS, environment_intel_library, write_vendor_folder

    library = environment_intel_library()
    if "OCL_ICD_VENDORS" in os.environ or library is None:
        return
    folder = Path(tempfile.mkdtemp(prefix="lutbake-test-icd-"))
    atexit.register(shutil.rmtree, folder, True)
    system = Path(os.environ.get("OPENCL_VENDOR_PATH") or SYSTEM_VENDORS)
    os.environ["OCL_ICD_VENDORS"] = str(write_vendor_folder(folder, library, system))


_register_intel_runtime()

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_LUTS = ROOT / "luts"
README_LUTS = ROOT / "lutbake-luts"  # README command 1, `lutbake bake` in the repo root (CI runs it first)
LUT_MEMBERS = (".json", ".glsl", ".hlsl", ".exr")  # the .exr last: a set is current once its .exr is


def _holds_the_default_set(folder: Path) -> bool:
    """Every default LUT in ``folder`` has the content hash of the current default spec, and includes that
    the current templates write (a template change leaves the hash as it was)."""
    from lutbake.lut.bake import default_specs
    from lutbake.tables.includes import shader_includes
    from lutbake.tables.lutfile import read_lut

    def current(name, spec):
        meta = read_lut(folder / f"{name}.exr")[0]
        return meta["content_hash"] == spec.content_hash and all(
            (folder / f"{name}.{suffix}").read_text() == text
            for suffix, text in shader_includes(meta, f"{name}.exr").items()
        )

    try:
        return all(current(name, spec) for name, spec in default_specs().items())
    except (OSError, ValueError, KeyError):
        return False


def default_luts() -> Path:
    """luts/: the default LUT set as `lutbake bake` with no options writes it. Not tracked (up to 8 MiB each).
    The set is baked once, by README command 1 into lutbake-luts/ (CI runs it before the tests; run here
    when lutbake-luts/ is missing or stale: a content hash differs from the current default specs) and
    copied into luts/ when luts/ is stale. Under a lock that test processes running side by side
    (pytest-xdist) share."""
    from lutbake.lut.bake import default_specs

    DEFAULT_LUTS.mkdir(exist_ok=True)
    with open(DEFAULT_LUTS / ".bake.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not _holds_the_default_set(README_LUTS):
            out = subprocess.run(
                [sys.executable, "-m", "lutbake.cli", "bake", "--quiet"],
                cwd=ROOT,
                check=True,
                capture_output=True,
                text=True,
                timeout=600,
            )
            assert out.stdout.endswith(f"default LUT set in {README_LUTS.name}/\n"), out.stdout
        if not _holds_the_default_set(DEFAULT_LUTS):
            for name in default_specs():
                for suffix in LUT_MEMBERS:
                    temporary = DEFAULT_LUTS / f".{name}{suffix}.copy"
                    shutil.copyfile(README_LUTS / f"{name}{suffix}", temporary)
                    os.replace(temporary, DEFAULT_LUTS / f"{name}{suffix}")
    return DEFAULT_LUTS


def _survey_devices():
    """(keys of devices whose compiler builds the kernel, {key: why not} for the rest)."""
    from lutbake.errors import OpenCLUnavailable
    from lutbake.integrate.devices import device_key, device_label, opencl_devices
    from lutbake.integrate.program import built_program

    try:
        devices = opencl_devices()
    except (OpenCLUnavailable, ImportError) as exc:
        return [], {"opencl": str(exc)}
    builds, excluded = [], {}
    for device in devices:
        built = built_program(device, "float64")
        if isinstance(built, OpenCLUnavailable):
            excluded[device_key(device, devices)] = str(built)
        else:
            builds.append((device_key(device, devices), device_label(device)))
    return builds, excluded


_DEVICES, _EXCLUDED = _survey_devices()


def pytest_generate_tests(metafunc):
    if "kernel_device" in metafunc.fixturenames:
        keys = [key for key, _ in _DEVICES]
        metafunc.parametrize("kernel_device", keys, ids=keys, scope="module")


# Modules that take the most CPU (bench/bench_suite.py), the longest first: pytest-xdist hands modules to
# its workers in collection order (pyproject: --no-loadscope-reorder), so the long ones start early and
# the short ones fill the end of the run on both workers, instead of one worker finishing a long module alone.
LONGEST_FIRST = (
    "test_fileset.py",
    "test_exact_engine.py",
    "test_blender.py",
    "test_blend_files.py",
    "test_scene.py",
    "test_report.py",
    "test_cli_honest.py",
    "test_gltf_runtime.py",
    "test_bake.py",
    "test_api.py",
    "test_default_luts.py",
    "test_engine.py",
    "test_stability.py",
    "test_spectral.py",
)


@pytest.fixture
def cache_folder():
    """``cache_folder(path)``: the user cache in ``path`` for this test (lutbake.io.usercache.use_folder), the
    previous choice restored after it."""
    from lutbake.io import usercache

    first = usercache.use_folder(None)
    usercache.use_folder(first)
    yield usercache.use_folder
    usercache.use_folder(first)


def _run_order(item) -> int:
    name = item.path.name
    return LONGEST_FIRST.index(name) if name in LONGEST_FIRST else len(LONGEST_FIRST)


def pytest_collection_modifyitems(items):
    """Run the longest modules first (a stable sort: the order within a module is kept). Tag each kernel
    test with its device key; user properties travel with the test's reports, so the summary counts
    correctly when pytest-xdist runs tests in worker processes."""
    items.sort(key=_run_order)
    for item in items:
        key = getattr(item, "callspec", None) and item.callspec.params.get("kernel_device")
        if key:
            item.user_properties.append(("kernel_device", key))


def _device_of(report):
    return dict(getattr(report, "user_properties", ())).get("kernel_device")  # collection reports have none


def pytest_terminal_summary(terminalreporter):
    """Per OpenCL runtime: how many kernel tests ran on it, and their outcomes."""
    tr = terminalreporter
    tr.section("OpenCL runtimes exercised by the kernel tests")
    for key, label in _DEVICES:
        counts = {
            outcome: sum(
                _device_of(r) == key for r in tr.stats.get(outcome, []) if r.when == "call" or outcome == "error"
            )
            for outcome in ("passed", "failed", "error", "skipped")
        }
        ran = ", ".join(f"{n} {o}" for o, n in counts.items() if n) or "no kernel test ran"
        tr.write_line(f"{key}: {label}: {ran}")
    for key, reason in _EXCLUDED.items():
        tr.write_line(f"{key}: not exercised (the kernel does not build): {reason}")


def node_parses(text: str) -> bool:
    """Node.js's JSON.parse, a strict parser (no NaN, no Infinity), accepts ``text``; fails (never skips) where
    Node.js is missing, as the engine tests do."""
    if shutil.which("node") is None:
        pytest.fail("the strict-JSON checks need Node.js (apt-get install nodejs)", pytrace=False)
    script = "JSON.parse(require('fs').readFileSync(0, 'utf8'))"
    return subprocess.run(["node", "-e", script], input=text, text=True, capture_output=True).returncode == 0


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


@pytest.fixture(scope="module")
def good_files(tmp_path_factory):
    """A tiny LUT, a one-material scene atlas and an exact table, baked once (the hostile-input tests tamper
    with copies)."""
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.lut.bake import bake
    from lutbake.modes.exact import write_exact_table
    from lutbake.scene.bake import bake_scene
    from lutbake.scene.toml import load_scene

    folder = tmp_path_factory.mktemp("good")
    axes = (
        Axis("cos_theta", 0.0, 1.0, 4),
        Axis("opd_nm", 0.0, 1000.0, 4),
        Axis("eta3", 1.0, 2.0, 2),
        Axis("kappa3", 0.0, 1.0, 2),
    )
    bake(BakeSpec(eta2=1.5, axes=axes), folder / "lut.exr", "numpy")
    (folder / "s.toml").write_text(
        "[scene]\nmax_de = 5.0\n[materials.soap]\nfilm = 1.33\nthickness_nm = [200, 300]\nbase = 1.0\n"
    )
    bake_scene(load_scene(folder / "s.toml"), folder / "scene", backend="numpy")
    write_exact_table(folder / "exact.exr")
    return {"lut": folder / "lut.exr", "atlas": folder / "scene" / "s.exr", "exact": folder / "exact.exr"}
