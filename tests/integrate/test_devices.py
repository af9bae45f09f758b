"""OpenCL devices: the same numbers and bytes on every runtime, device choice, and naming it."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from airy_mp import airy_reflectance_mp

from lutbake.errors import OpenCLUnavailable
from lutbake.grid.spec import Axis, BakeSpec
from lutbake.integrate import devices as runtimes
from lutbake.integrate import opencl as integrate
from lutbake.integrate import program, selfcheck
from lutbake.lut.bake import bake, bake_array
from lutbake.physics.points import FilmPoints


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "lutbake.cli", *args], capture_output=True, text=True)


def _building_devices():
    """(index in `lutbake devices`, device) of each device whose compiler builds the kernel. Device 0 need not
    be one: PoCL 3.0 from PyPI cannot compile on CPUs newer than its LLVM (AMD Zen 5)."""
    return [
        (index, device)
        for index, device in enumerate(runtimes.opencl_devices())
        if not isinstance(program.built_program(device, "float64"), OpenCLUnavailable)
    ]


@pytest.mark.parametrize("thickness_nm", [0.0, 1e-9 / 3.0])
def test_grazing_over_a_base_matching_the_ambient_agrees_with_mpmath(kernel_device, thickness_nm):
    """The stack where PoCL once differed by 4.7e-6: its compiler fused (η3−κ3)(η3+κ3) − η1² into
    an fma, keeping a 1e-16 rounding error of η3 ± κ3 against cos² θ1 = 1e-12."""
    fast = integrate.OpenCLBackend("float64", device=kernel_device)
    stack = FilmPoints(eta1=1.0, eta2=1.5, eta3=1.0, kappa3=1e-12, cos_theta=1e-6, thickness_nm=thickness_nm)
    got = fast.reflectance(stack, 550.0)
    rs, rp = airy_reflectance_mp(1.0, 1.5, 1.0, 1e-12, 1e-6, thickness_nm, 550.0)
    assert abs(float(got) - 0.5 * (rs + rp)) <= 1e-13


def test_every_device_writes_the_same_exr_bytes(tmp_path):
    """The LUT's bytes do not depend on the runtime: every device's half EXR is the same file, and its
    texels are the numpy path's rounded to half (an adjacent half where they straddle a rounding edge)."""
    from lutbake.lut.sample import Lut

    axes = (
        Axis("cos_theta", 0.0, 1.0, 8, "sqrt"),
        Axis("opd_nm", 0.0, 2000.0, 16),
        Axis("eta3", 1.0, 3.0, 3),
        Axis("kappa3", 0.0, 4.0, 3, "sqrt"),
    )
    spec = BakeSpec(eta2=1.4, axes=axes, precision="half")
    numpy_image = bake_array(spec, "numpy")
    keys = [
        runtimes.device_key(d)
        for d in runtimes.opencl_devices()
        if not isinstance(program.built_program(d, "float64"), OpenCLUnavailable)
    ]
    assert keys, "no OpenCL device builds the kernel"
    files = {}
    for key in keys:
        result = bake(spec, tmp_path / f"{key}.exr", backend="opencl", device=key)
        files[key] = (tmp_path / f"{key}.exr").read_bytes()
        assert json.loads((tmp_path / f"{key}.json").read_text())["baked_on"]["device"] == result.device
        image = Lut.load(tmp_path / f"{key}.exr").image.astype(float)
        assert np.max(np.abs(image - numpy_image)) <= 1e-3  # a half's spacing below 1 is ≤ 4.9e-4
        assert np.mean(image == numpy_image.astype(np.float16)) > 0.99
    assert len(set(files.values())) == 1, f"EXR bytes differ between {', '.join(files)}"


def test_a_device_failing_its_self_check_is_refused_and_the_next_is_used(monkeypatch):
    building = _building_devices()
    assert building, "no OpenCL device builds the kernel"
    (first_index, _), devices = building[0], [d for _, d in building]
    first = runtimes.device_label(devices[0])
    monkeypatch.setattr(selfcheck, "_CHECKED", {})
    real = selfcheck.self_check_error
    monkeypatch.setattr(selfcheck, "self_check_error", lambda b: 1e-3 if b.device == first else real(b))
    with pytest.raises(OpenCLUnavailable, match="self-check"):
        integrate.OpenCLBackend("float64", device=str(first_index))
    if len(devices) > 1:
        assert integrate.OpenCLBackend("float64").device == runtimes.device_label(devices[1])
    else:
        with pytest.warns(RuntimeWarning, match="numpy path"):
            assert integrate.backend("auto").name == "numpy"


def test_bake_names_its_device_in_stdout_json_and_sidecar(tmp_path):
    """--device N names the N-th device of `lutbake devices`; the last one that builds the kernel, so that on a
    machine with two the choice is seen to be honoured rather than the default."""
    building = _building_devices()
    assert building, "no OpenCL device builds the kernel"
    index, device = building[-1]
    flags = [
        "bake",
        "--quiet",
        "--eta2",
        "1.4",
        "--cos-theta",
        "0:1:4",
        "--opd",
        "0:1000:4",
        "--eta3",
        "1:2:2",
        "--kappa3",
        "0:1:2",
        "--device",
        str(index),
    ]
    text = _cli(*flags, "--out", str(tmp_path / "a.exr"))
    label = runtimes.device_label(device)
    assert text.returncode == 0, text.stderr
    assert f"on {label}" in text.stdout
    doc = json.loads(_cli(*flags, "--out", str(tmp_path / "b.exr"), "--json").stdout)
    assert doc["luts"][0]["device"] == label
    assert json.loads((tmp_path / "b.json").read_text())["baked_on"]["device"] == label


def _bake_in_process(argv, capfd, monkeypatch):
    """(exit status, stderr) of the CLI run in this process, $LUTBAKE_DEVICE unset (so --device alone names one)."""
    from lutbake import cli

    monkeypatch.delenv("LUTBAKE_DEVICE", raising=False)
    try:
        cli.main(argv)
        status = 0
    except SystemExit as exc:
        status = exc.code
    return status, capfd.readouterr().err


@pytest.mark.parametrize("default_set", [False, True], ids=["one-lut", "default-set"])
def test_a_named_device_that_cannot_run_is_refused_and_only_the_default_falls_back(
    tmp_path, capfd, monkeypatch, default_set
):
    """Issue 27: `--device N` whose kernel does not build is one line, exit 2, nothing written (not a silent
    numpy bake); without --device the same failure falls back to numpy, saying so. Every device is made to
    fail its build here, so the test runs alike where PoCL builds (Zen 3) and where it cannot (Zen 5)."""
    index, device = _building_devices()[-1]
    monkeypatch.setattr(
        integrate,
        "device_program",
        lambda d, compute: OpenCLUnavailable(f"{runtimes.device_label(d)}: error: no build"),
    )
    grid = ["--eta2", "1.4", "--cos-theta", "0:1:4", "--opd", "0:1000:4", "--eta3", "1:2:2", "--kappa3", "0:1:2"]
    out = tmp_path / "out"
    target = ["--out", str(out)] if default_set else [*grid, "--out", str(out / "a.exr")]
    if not default_set:
        out.mkdir()
    with monkeypatch.context() as patch:  # a regression fails here at once rather than bake for minutes
        patch.setattr(integrate, "NumpyBackend", lambda: pytest.fail("a named device fell back to numpy"))
        status, err = _bake_in_process(["bake", "--quiet", *target, "--device", str(index)], capfd, monkeypatch)
    assert status == 2 and len(err.strip().splitlines()) == 1, err
    assert err.startswith(f"lutbake: error: --device '{index}' cannot run the kernel ("), err
    assert "no build" in err and "numpy" not in err
    assert not out.exists() if default_set else not any(out.iterdir())
    with pytest.raises(integrate.DeviceCannotRun):  # the library alike, and catchable as OpenCLUnavailable
        integrate.backend("auto", device=runtimes.device_key(device))
    if not default_set:
        with pytest.warns(RuntimeWarning, match="baking with the numpy path"):
            status, err = _bake_in_process(["bake", "--quiet", *target], capfd, monkeypatch)
        assert status == 0, err
        assert json.loads((out / "a.json").read_text())["baked_on"]["backend"] == "numpy"


def test_a_device_passed_as_a_value_runs_alone_and_is_never_swapped(monkeypatch):
    """``device=`` takes a pyopencl Device as well as a selector: that device runs the kernel, and where it
    cannot, the caller hears so (DeviceCannotRun naming it) rather than getting another device or numpy."""
    _, device = _building_devices()[-1]
    label = runtimes.device_label(device)
    assert integrate.backend("auto", device=device).device == label
    real = integrate.device_program
    monkeypatch.setattr(
        integrate,
        "device_program",
        lambda d, compute: (
            OpenCLUnavailable(f"{runtimes.device_label(d)}: error: no build") if d == device else real(d, compute)
        ),
    )
    monkeypatch.setattr(integrate, "NumpyBackend", lambda: pytest.fail("a device passed in fell back to numpy"))
    with pytest.raises(integrate.DeviceCannotRun, match="no build") as refused:
        integrate.backend("auto", device=device)
    assert repr(label) in str(refused.value)


def test_a_pyopencl_ctx_selector_names_the_device_pyopencl_would():
    """A selector in PYOPENCL_CTX's syntax (the CLI passes $PYOPENCL_CTX with that origin) names what
    pyopencl's own platform:device indices name; one naming nothing is refused in PYOPENCL_CTX's words."""
    cl = runtimes.import_pyopencl()
    assert runtimes.find_device("0:0", runtimes.PYOPENCL_CTX) == cl.get_platforms()[0].get_devices()[0]
    with pytest.raises(ValueError) as refused:
        runtimes.find_devices("garbage", runtimes.PYOPENCL_CTX)
    assert str(refused.value).startswith("PYOPENCL_CTX='garbage' names no OpenCL device (")
    assert str(refused.value).endswith("): unset it, or give a platform:device index such as 0:0")


def test_an_unwritable_cache_home_turns_pyopencls_caches_off(tmp_path, monkeypatch):
    """XDG_CACHE_HOME a file: no binary cache for the build (cache_dir False) and pyopencl's invoker store
    off (it would raise making its folder when the first kernel is made); a writable home keeps both."""
    cl = runtimes.import_pyopencl()
    monkeypatch.setattr(cl, "_PYOPENCL_NO_CACHE", False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "home"))
    assert program._pyopencl_caches(cl) is None and cl._PYOPENCL_NO_CACHE is False
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "file"))
    assert program._pyopencl_caches(cl) is False and cl._PYOPENCL_NO_CACHE is True


def test_a_kernel_cache_that_fails_costs_the_cache_only(kernel_device, tmp_path, monkeypatch):
    """Where pyopencl's binary cache fails (its folder under a file), pyopencl looks
    PYOPENCL_CACHE_FAILURE_FATAL up in the environment, a KeyError where it is unset: the program is built
    again without the cache (runtimes that cache builds themselves, PoCL, never reach pyopencl's)."""
    (tmp_path / "file").write_text("")
    monkeypatch.delenv("PYOPENCL_CACHE_FAILURE_FATAL", raising=False)
    monkeypatch.setattr(program, "_pyopencl_caches", lambda cl: str(tmp_path / "file" / "cache"))
    _, built = program._build(runtimes.find_device(kernel_device), "float64")
    assert program.Kernels.of(built).plan_rows.function_name == "plan_rows"


def test_unknown_device_is_refused_with_one_line():
    out = _cli("bake", "--eta2", "1.4", "--out", "never.exr", "--device", "no-such-runtime")
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1
    assert "'no-such-runtime' matches no OpenCL device" in out.stderr and "pocl" in out.stderr


def test_devices_command_lists_every_device():
    out = _cli("devices", "--json")
    assert out.returncode == 0, out.stderr
    rows = json.loads(out.stdout)["devices"]
    assert [r["label"] for r in rows] == [runtimes.device_label(d) for d in runtimes.opencl_devices()]
    assert sum(r["default"] for r in rows) == 1
    assert len({r["key"] for r in rows}) == len(rows)
    for r in rows:
        assert r["key"].startswith(f"{r['runtime']['family']}-{r['runtime']['origin'].lower()}")
        if r["float64"]["builds"]:
            assert r["float64"]["self_check_error"] <= selfcheck.SELF_CHECK_TOLERANCE["float64"]
            assert r["cells_per_second"] > 0


_PLAIN_PYOPENCL = """
import json, pyopencl as cl
print(json.dumps([[p.name.strip(), p.version.strip(), d.name.strip()] for p in cl.get_platforms()
                  for d in p.get_devices()]))
"""


def test_every_runtime_is_found_and_each_is_named_apart():
    """Every device pyopencl alone finds (PyPI's PoCL from its own folder, the system's vendor list: Debian's
    PoCL where installed) is listed, and Intel's runtime where the environment holds it; the two PoCLs
    have keys of their own (the family and where the runtime came from), so a test id or --device names one."""
    plain = json.loads(
        subprocess.run([sys.executable, "-c", _PLAIN_PYOPENCL], capture_output=True, text=True, check=True).stdout
    )
    devices = runtimes.opencl_devices()
    listed = [[d.platform.name.strip(), d.platform.version.strip(), d.name.strip()] for d in devices]
    assert all(row in listed for row in plain), (plain, listed)
    keys = [runtimes.device_key(d) for d in devices]
    assert len(set(keys)) == len(keys), keys
    origins = {(runtimes.runtime_of(d).family, runtimes.runtime_of(d).origin) for d in devices}
    pyopencl_icds = Path(runtimes.import_pyopencl().__file__).parent / ".libs"
    if any("pocl" in icd.name for icd in pyopencl_icds.glob("*.icd")):  # pocl-binary-distribution
        assert ("pocl", "PyPI") in origins and "pocl-pypi" in keys
    if (Path(sys.prefix) / "lib" / "libintelocl.so").is_file():  # the cpu extra
        assert ("intel", "PyPI") in origins and "intel-pypi" in keys
    for device in devices:
        runtime = runtimes.runtime_of(device)
        label = runtimes.device_label(device)
        assert label.startswith(f"{runtime.name} {runtime.version} ({runtime.origin}") and device.name.strip() in label
        if runtime.family == "pocl":  # which PoCL: its version and LLVM's, from the platform's own words
            assert f"PoCL {runtime.version}" in device.platform.version and f"LLVM {runtime.llvm}" in label


def test_devices_are_tried_pocl_first_the_systems_before_pypis():
    """The stated rule (lutbake/integrate/devices.py, docs/devices.md): PoCL before other runtimes, the system's PoCL
    before PyPI's; the default device is the first in that order whose kernel builds and passes the
    self-check."""
    devices = runtimes.opencl_devices()
    rank = [(runtimes.runtime_of(d).family != "pocl", runtimes.runtime_of(d).origin != "system") for d in devices]
    assert rank == sorted(rank)
    first = next(device for _, device in _building_devices())
    assert integrate.OpenCLBackend("float64").device == runtimes.device_label(first)


def test_device_pocl_means_a_pocl_that_builds(monkeypatch):
    """--device pocl: the first PoCL whose kernel builds and passes its self-check, never another runtime.
    The PoCLs are made to fail their build one by one, from the first: the next PoCL runs, and once none
    is left the named family is refused (even where Intel's runtime builds)."""
    pocls = [d for _, d in _building_devices() if runtimes.runtime_of(d).family == "pocl"]
    assert pocls, "no PoCL builds the kernel"
    real = integrate.device_program
    broken = []
    monkeypatch.setattr(
        integrate,
        "device_program",
        lambda d, compute: (
            OpenCLUnavailable(f"{runtimes.device_label(d)}: error: no build") if d in broken else real(d, compute)
        ),
    )
    for pocl in pocls:
        assert integrate.OpenCLBackend("float64", device="pocl").device == runtimes.device_label(pocl)
        broken.append(pocl)
    with pytest.raises(integrate.DeviceCannotRun, match="no build"):
        integrate.backend("auto", device="pocl")


# PyPI's PoCL 3.0 building the kernel on AMD Zen 5, as pyopencl words it (recorded under qemu-x86_64
# -cpu EPYC-Milan,family=26,model=2: LLVM 14 names the CPU 'generic'; docs/devices.md).
_ZEN5_BUILD_LOG = (
    "clBuildProgram failed: BUILD_PROGRAM_FAILURE - clBuildProgram failed: BUILD_PROGRAM_FAILURE\n\n"
    "Build on <pyopencl.Device 'pthread-AMD EPYC' on 'Portable Computing Language' at 0x400067a550>:"
    "\n\nerror: unknown target CPU 'generic'\nDevice pthread-AMD EPYC failed to build the program\n\n"
    "(options: -DLUTBAKE_FP64 -DMAX_NEAR=32)"
)


def test_a_runtime_that_cannot_compile_for_the_cpu_is_one_line_saying_why(monkeypatch, capsys):
    """`lutbake devices` names a device whose compiler fails in one line: which runtime (version, LLVM, PyPI
    or system), that it cannot compile for this CPU, and what does."""
    from lutbake import cli

    devices = runtimes.opencl_devices()
    index, pocl = next((i, d) for i, d in enumerate(devices) if runtimes.runtime_of(d).family == "pocl")
    runtime = runtimes.runtime_of(pocl)
    real = integrate.device_program
    monkeypatch.setattr(
        integrate,
        "device_program",
        lambda d, compute: (
            OpenCLUnavailable(f"{runtimes.device_label(d)}: {program.why_not_built(d, RuntimeError(_ZEN5_BUILD_LOG))}")
            if d == pocl
            else real(d, compute)
        ),
    )
    try:
        cli.main(["devices"])
    except SystemExit as exc:
        assert exc.code == 0
    lines = capsys.readouterr().out.splitlines()
    entry = lines.index(next(line for line in lines if line.startswith(f"{index} ")))
    assert lines[entry] == (
        f"{index} {runtimes.device_key(pocl)}: PoCL {runtime.version} ({runtime.origin}, LLVM {runtime.llvm}) / "
        f"{pocl.name.strip()}: cannot compile for this CPU: unknown target CPU 'generic' (LLVM {runtime.llvm} does "
        "not know this CPU; Debian's pocl-opencl-icd, which picks the target from the CPU's features, builds on "
        "such CPUs)"
    )
    assert entry + 1 == len(lines) or lines[entry + 1][0].isdigit()  # nothing more about it
