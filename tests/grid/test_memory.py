"""The memory model (lutbake/grid/memory.py, BakeSpec.memory) against peak RSS measured in fresh processes, and the
budget's refusals: a non-finite or non-positive limit, and grids whose arrays would not fit."""

import json
import os
import subprocess
import sys

import pytest
from conftest import _DEVICES

from lutbake.errors import ParameterError
from lutbake.grid.spec import Axis, BakeSpec

_CHILD = """
import json, sys
from lutbake.lut.bake import bake, resident_bytes
from lutbake.integrate.opencl import backend as make_backend
from lutbake.grid.spec import Axis, BakeSpec
shape, opd, backend, device = json.loads(sys.argv[1]), float(sys.argv[2]), sys.argv[3], sys.argv[5] or None
spec = BakeSpec(eta2=1.5, precision="half", axes=(Axis("cos_theta", 0.0, 1.0, shape[0], "sqrt"),
                Axis("opd_nm", 0.0, opd, shape[1]), Axis("eta3", 1.0, 3.0, shape[2]),
                Axis("kappa3", 0.0, 5.0, shape[3], "sqrt")))
integrator = make_backend(backend, device=device)
runtime = resident_bytes()
bake(spec, sys.argv[4], backend, memory_limit_gib=64.0, device=device)
print(json.dumps({"peak": resident_bytes(peak=True), "runtime": runtime, "device": integrator.device,
                  "estimate": spec.memory(backend, runtime_bytes=runtime, plan=integrator.series_plan(spec))["peak"],
                  "before_plan": spec.memory(backend, runtime_bytes=runtime)["peak"]}))
"""


def pytest_generate_tests(metafunc):
    """``memory_runtime``: (device key, alone) for each runtime the kernels run on (conftest's
    ``kernel_device``), registered as lutbake registers them, and PyPI's PoCL alone (OCL_ICD_VENDORS an
    empty folder: `pip install lutbake` without the cpu extra on a machine with no runtime of its own).
    That is the smallest runtime (~100 MiB against ~165 MiB for PoCL beside Debian's and Intel's), where
    an error in the model's other items weighs most."""
    if "memory_runtime" in metafunc.fixturenames:
        keys = [key for key, _ in _DEVICES]
        runtimes = [(key, False) for key in keys] + [("pocl-pypi", True)] * ("pocl-pypi" in keys)
        metafunc.parametrize("memory_runtime", runtimes, ids=[key + "-alone" * alone for key, alone in runtimes])


def _measured(tmp_path, shape, opd_nm, backend, device="", env=None) -> dict:
    """The child's JSON line: one shape baked in its own process (peak RSS is that process's own)."""
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(shape), str(opd_nm), backend, str(tmp_path / "m.exr"), device],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize(
    "shape, opd_nm",
    [
        ((600, 600, 2, 2), 100.0),  # (cos θ, D) pairs: X per pair, the plan's term counts; 1.4 bands
        ((32, 8, 120, 120), 100.0),  # (cos θ, η3, κ3) columns: the series constants
        ((64, 256, 8, 8), 4000.0),  # one band in flight, the closed form's table
    ],
)
def test_estimate_is_within_1_25x_of_the_measured_peak(tmp_path, shape, opd_nm, memory_runtime):
    """Each shape bakes in its own process on each runtime; the estimate with the runtime's resident bytes
    and the plan (the bake's last check before its bands) is within 1.25x of the peak RSS, and with the
    plan's outcome bounded from the shape (the check before it) not below it."""
    device, alone = memory_runtime
    (tmp_path / "no-vendors").mkdir()
    env = {"OCL_ICD_VENDORS": str(tmp_path / "no-vendors")} if alone else None
    row = _measured(tmp_path, shape, opd_nm, "opencl", device, env)
    assert 1 / 1.25 <= row["estimate"] / row["peak"] <= 1.25, row
    assert row["before_plan"] >= row["peak"], row


def test_numpy_estimate_is_within_1_25x_of_the_measured_peak(tmp_path):
    """The numpy path's optics chunks (16 × 32 × 8 × 8): as above."""
    row = _measured(tmp_path, (16, 32, 8, 8), 1000.0, "numpy")
    assert 1 / 1.25 <= row["estimate"] / row["peak"] <= 1.25, row
    assert row["before_plan"] >= row["peak"], row


def _spec(shape):
    axes = (
        Axis("cos_theta", 0.0, 1.0, shape[0]),
        Axis("opd_nm", 0.0, 4000.0, shape[1]),
        Axis("eta3", 1.0, 2.0, shape[2]),
        Axis("kappa3", 0.0, 1.0, shape[3]),
    )
    return BakeSpec(eta2=1.33, axes=axes)


@pytest.mark.parametrize("limit", [float("nan"), float("inf"), 0.0, -1.0, "lots"])
def test_budget_refuses_a_limit_that_is_not_a_finite_positive_number(limit):
    with pytest.raises(ParameterError, match="memory_limit_gib .* is not allowed: must be a finite number"):
        _spec((4, 4, 2, 2)).check_budget(limit)


def test_every_array_of_a_huge_cos_by_opd_grid_is_counted():
    """20000 × 20000 (cos θ × D) × 2 × 2: the plan's arrays per (cos θ, D) pair alone are 22 GB (the 0.9 GiB
    estimate before them let a bake die allocating 5.96 GiB); under 2 GiB it is refused before any work."""
    spec = _spec((20000, 20000, 2, 2))
    assert spec.memory()["arrays"] >= 4e8 * 56
    with pytest.raises(ParameterError, match=r"needs about \d+\.\d GiB of memory, over the 2 GiB limit"):
        spec.check_budget(2.0)


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "lutbake.cli", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.parametrize(
    "extra, named",
    [
        (["--eta3", "1:2:2", "--max-memory-gib", "nan"], "--max-memory-gib nan is not allowed"),
        (
            ["--eta3", "1:2:2", "--cos-theta", "0:1:20000", "--opd", "0:4000:20000", "--max-memory-gib", "2"],
            "over the 2 GiB limit",
        ),
        # one image row of 16 M texels: a band (numpy path: its stacks and RGB) holds at least one row
        (
            [
                "--eta3",
                "1:2:4000",
                "--cos-theta",
                "0:1:4000",
                "--opd",
                "0:100:2",
                "--max-memory-gib",
                "1",
                "--backend",
                "numpy",
            ],
            "over the 1 GiB limit",
        ),
    ],
)
def test_bake_over_budget_exits_2_with_one_line_and_writes_nothing(tmp_path, extra, named):
    out = _cli("bake", "--eta2", "1.33", "--kappa3", "0:1:2", *extra, "--out", "x.exr", cwd=tmp_path)
    assert out.returncode == 2 and named in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert list(tmp_path.iterdir()) == []
