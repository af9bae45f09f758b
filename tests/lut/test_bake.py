"""Bake: kernel against numpy and the ground truth, the EXR contract, atomicity, determinism."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import LUT_MEMBERS, README_LUTS, default_luts

from lutbake.errors import ParameterError
from lutbake.grid.spec import Axis, BakeSpec
from lutbake.integrate.numpy_path import NumpyBackend
from lutbake.lut.bake import bake, bake_array, default_specs
from lutbake.lut.sample import Lut
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour
from lutbake.tables.exr import exr_rows
from lutbake.tables.lutfile import read_lut


def random_spec(rng, shape=(32, 64, 8, 8), **kw):
    lo = [rng.uniform(0, 0.3), rng.uniform(0, 500), rng.uniform(1, 1.5), rng.uniform(0, 1)]
    hi = [rng.uniform(0.7, 1.0), rng.uniform(2000, 6000), rng.uniform(2, 3.5), rng.uniform(2, 8)]
    spacing = ["sqrt", "uniform", "uniform", "sqrt"]
    names = ["cos_theta", "opd_nm", "eta3", "kappa3"]
    axes = tuple(Axis(n, a, b, c, s) for n, a, b, c, s in zip(names, lo, hi, shape, spacing))
    return BakeSpec(eta2=rng.uniform(1.2, 2.5), axes=axes, **kw)


@pytest.fixture(scope="module")
def spec():
    """16×32×4×4: both ends of every axis and spectral rule levels 0–7 (16 to 2048 nodes, 5 cells at 7),
    the levels the 32×64×8×8 grid it replaces reached, at 1/16 of its 18 s of numpy."""
    return random_spec(np.random.default_rng(7), (16, 32, 4, 4))


@pytest.fixture(scope="module")
def numpy_grid(spec):
    return bake_array(spec, "numpy")


@pytest.fixture(scope="module")
def kernel_grid(spec, kernel_device):
    """The kernel's direct quadrature (the series is tested against it in test_fourier.py)."""
    return bake_array(spec, "opencl", "direct", kernel_device)


def test_kernel_float64_equals_numpy_on_every_cell(spec, kernel_grid, numpy_grid):
    assert kernel_grid.shape == (4 * 32, 4 * 16, 3)
    assert set(np.unique(spec.row_levels(0, 4 * 32))) == set(range(8))
    assert np.max(np.abs(kernel_grid - numpy_grid)) <= 1e-10


def test_kernel_float32_within_2e5_of_float64(spec, kernel_grid, kernel_device):
    from dataclasses import replace

    f32 = bake_array(replace(spec, compute="float32"), "opencl", "direct", kernel_device)
    assert np.max(np.abs(f32 - kernel_grid)) <= 2e-5


def test_kernel_matches_ground_truth_within_the_spectral_target(spec, kernel_grid, rng):
    n_cos, n_opd, n_eta3, n_kappa3 = spec.shape
    y = rng.integers(0, n_opd * n_kappa3, 200)
    x = rng.integers(0, n_cos * n_eta3, 200)
    v = [a.values() for a in spec.axes]
    pts = FilmPoints.build(
        eta1=spec.eta1,
        eta2=spec.eta2,
        cos_theta=v[0][x % n_cos],
        opd_nm=v[1][y % n_opd],
        eta3=v[2][x // n_cos],
        kappa3=v[3][y // n_opd],
    )
    truth = reference_colour(pts, spec.observer, spec.space).values
    assert np.max(np.abs(kernel_grid[y, x] - truth)) <= 1e-5


def test_grazing_and_evanescent_texels_are_physical(kernel_device):
    """Film below the ambient index (η1 > η2: evanescent film past the critical angle)."""
    axes = (
        Axis("cos_theta", 0.0, 1.0, 16),
        Axis("opd_nm", 0.0, 3000.0, 16),
        Axis("eta3", 1.0, 3.0, 4),
        Axis("kappa3", 0.0, 4.0, 4),
    )
    spec = BakeSpec(eta2=1.2, eta1=1.5, axes=axes)
    grid = bake_array(spec, "opencl", "direct", kernel_device)
    assert np.max(np.abs(grid - bake_array(spec, "numpy"))) <= 1e-10
    series = bake_array(spec, "opencl", device=kernel_device)
    assert np.max(np.abs(series - grid)) <= 1e-5
    for g in (grid, series):
        assert np.allclose(g.reshape(4, 16, 4, 16, 3)[:, :, :, 0], 1.0, atol=1e-6)  # cos θ = 0 column


def _lut_stack(lut, cos_theta, opd_nm, eta3, kappa3):
    """Film stacks of the LUT's film at its coordinates (cos θ1, D, η3, κ3)."""
    return FilmPoints.texels(eta1=lut.eta1, eta2=lut.eta2, cos_theta=cos_theta, opd_nm=opd_nm, eta3=eta3, kappa3=kappa3)


def _small_spec(**kw):
    axes = (
        Axis("cos_theta", 0.0, 1.0, 16, "sqrt"),
        Axis("opd_nm", 0.0, 2000.0, 32),
        Axis("eta3", 1.0, 3.0, 4),
        Axis("kappa3", 0.0, 4.0, 4, "sqrt"),
    )
    return BakeSpec(eta2=1.4, axes=axes, **kw)


@pytest.fixture(scope="module")
def lut_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("lut") / "small.exr"
    bake(_small_spec(), path)
    return path


def test_file_set_and_header_are_self_describing(lut_path):
    for suffix in (".json", ".glsl", ".hlsl"):
        assert lut_path.with_suffix(suffix).is_file()
    lut = Lut.load(lut_path)
    sidecar = json.loads(lut_path.with_suffix(".json").read_text())
    baked_on = sidecar.pop("baked_on")
    assert sidecar == lut.meta
    assert baked_on["device"] and " / " in baked_on["device"]  # 'platform / device'
    assert lut.meta["constants"]["eta2"] == 1.4 and lut.meta["spectral"]["error_rgb_max"] <= 1e-5
    assert [a.name for a in lut.axes] == ["cos_theta", "opd_nm", "eta3", "kappa3"]
    assert lut.image.shape == (4 * 32, 4 * 16, 3) and lut.image.dtype == np.float32
    assert "lutbake_sample" in lut_path.with_suffix(".glsl").read_text()


def test_stored_values_are_the_kernel_values(lut_path):
    lut = Lut.load(lut_path)
    grid = bake_array(_small_spec())
    assert np.array_equal(lut.image, grid.astype(np.float32))


def test_sampler_is_exact_at_nodes(lut_path):
    lut = Lut.load(lut_path)
    v = [a.values() for a in lut.axes]
    i = np.meshgrid(*[np.arange(a.count) for a in lut.axes], indexing="ij")
    got = lut.sample(_lut_stack(lut, v[0][i[0]], v[1][i[1]], v[2][i[2]], v[3][i[3]]))
    stored = lut.image.reshape(4, 32, 4, 16, 3).transpose(3, 1, 2, 0, 4)  # (cos, opd, eta3, kappa3, 3)
    assert np.max(np.abs(got - stored)) <= 1e-6 * np.max(np.abs(stored))


def _interp_first_axis(grid, x):
    """``grid`` read at the fractional node index ``x`` of its first axis: np.interp down each column."""
    nodes = np.arange(grid.shape[0])
    return np.apply_along_axis(lambda column: np.interp(x, nodes, column), 0, grid)


def _quadrilinear(grid, coords):
    """Independent multilinear interpolation: one axis at a time with np.interp (each pass reads the grid's
    first axis at the point's next coordinate, leaving the remaining axes)."""
    out = []
    for c in coords:
        g = grid
        for x in c:
            g = _interp_first_axis(g, x)
        out.append(g)
    return np.array(out)


def test_linear_reads_between_nodes_are_quadrilinear(lut_path, rng):
    lut = Lut.load(lut_path)
    grid = lut.image.reshape(4, 32, 4, 16, 3).transpose(3, 1, 2, 0, 4).astype(float)
    pts = [rng.uniform(a.lo, a.hi, 60) for a in lut.axes]
    stack = _lut_stack(lut, *pts)
    got = lut.sample(stack, interpolation="linear")
    coords = np.stack(lut.node_coords(stack), axis=1)
    assert np.max(np.abs(got - _quadrilinear(grid, coords))) <= 1e-6


def test_sampler_clamps_outside_the_domain(lut_path):
    lut = Lut.load(lut_path)
    inside = lut.sample(_lut_stack(lut, 0.5, 2000.0, 3.0, 4.0))
    assert np.allclose(lut.sample(_lut_stack(lut, 0.5, 2500.0, 3.5, 9.0)), inside)
    assert not lut.in_domain(_lut_stack(lut, 0.5, 2500.0, 3.0, 4.0))
    assert lut.in_domain(_lut_stack(lut, 0.5, 2000.0, 3.0, 4.0))


def test_sampler_refuses_a_stack_of_another_film(lut_path):
    """A LUT holds one film (η1, η2) and constant bases: another is refused, naming both values."""
    lut = Lut.load(lut_path)
    other = FilmPoints.build(eta2=1.5, opd_nm=700.0, cos_theta=0.5, eta3=1.7)
    with pytest.raises(ParameterError, match=r"^eta2 1\.5 differs from the LUT's eta2 = 1\.4$"):
        lut.sample(other)
    ambient = FilmPoints.build(eta1=1.33, eta2=1.4, opd_nm=700.0, cos_theta=0.5, eta3=1.7)
    with pytest.raises(ParameterError, match=r"^eta1 1\.33 differs from the LUT's eta1 = 1\.0$"):
        lut.in_domain(ambient)
    gold = FilmPoints.build(eta2=1.4, thickness_nm=200.0, cos_theta=0.5, base="Au")
    with pytest.raises(ParameterError, match=r"^base 'Au' differs from the LUT's base = None$"):
        lut.sample(gold)


def test_filter_bits_quantize_weights(lut_path):
    lut = Lut.load(lut_path)
    exact = lut.sample(_lut_stack(lut, 0.33, 777.0, 1.7, 1.3), interpolation="linear")
    coarse = lut.sample(_lut_stack(lut, 0.33, 777.0, 1.7, 1.3), filter_bits=2, interpolation="linear")
    assert 0 < np.max(np.abs(exact - coarse)) < 0.05


def test_half_precision_storage(tmp_path):
    path = tmp_path / "half.exr"
    bake(_small_spec(precision="half"), path)
    lut = Lut.load(path)
    assert lut.image.dtype == np.float16
    assert np.max(np.abs(lut.image.astype(float) - bake_array(_small_spec()))) <= 1e-3


def test_same_inputs_give_the_same_bytes(tmp_path, lut_path):
    again = tmp_path / "small.exr"
    bake(_small_spec(), again)
    assert again.read_bytes() == lut_path.read_bytes()
    for suffix in (".json", ".glsl", ".hlsl"):
        assert again.with_suffix(suffix).read_bytes() == lut_path.with_suffix(suffix).read_bytes()


def test_chunked_bake_equals_one_band(tmp_path):
    spec = _small_spec()
    bake(spec, tmp_path / "a.exr", chunk_cells=64)
    bake(spec, tmp_path / "b.exr")
    assert (tmp_path / "a.exr").read_bytes() == (tmp_path / "b.exr").read_bytes()


def test_oiiotool_reads_the_lut_and_its_attributes(lut_path):
    oiiotool = shutil.which("oiiotool", path=os.path.dirname(sys.executable)) or shutil.which("oiiotool")
    assert oiiotool, "oiiotool (openimageio test dependency) is not installed"
    out = subprocess.run([oiiotool, "--info", "-v", str(lut_path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "64 x  128, 3 channel, float openexr" in out.stdout
    assert 'compression: "zip"' in out.stdout
    assert "lutbake.constants.eta2" in out.stdout and "lutbake.metadata" in out.stdout


def _cli(*args, cwd=None):
    return subprocess.Popen(
        [sys.executable, "-m", "lutbake.cli", *args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT, signal.SIGTERM])
def test_interrupted_bake_leaves_no_partial_lut(tmp_path, sig):
    """A slow (numpy) bake is killed mid-way: the previous LUT survives, byte for byte."""
    out = tmp_path / "lut.exr"
    out.write_bytes(b"previous")
    proc = _cli(
        "bake",
        "--eta2",
        "1.5",
        "--cos-theta",
        "0:1:64",
        "--opd",
        "0:20000:256",
        "--eta3",
        "1:3:8",
        "--kappa3",
        "0:5:8",
        "--backend",
        "numpy",
        "--quiet",
        "--out",
        str(out),
    )
    deadline = time.time() + 60
    while not any(p.name.startswith(".lut.exr.tmp") for p in tmp_path.iterdir()):
        assert proc.poll() is None and time.time() < deadline, proc.stderr.read() if proc.poll() else "timeout"
        time.sleep(0.05)
    proc.send_signal(sig)
    proc.wait(timeout=60)
    assert proc.returncode != 0
    assert out.read_bytes() == b"previous"
    assert not out.with_suffix(".json").exists()
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    if sig == signal.SIGKILL:  # no handler runs: at most the hidden temporary remains
        assert all(name.startswith(".lut.exr.tmp-") for name in leftovers)
    else:  # SIGINT and SIGTERM clean up
        assert leftovers == []


@pytest.mark.parametrize(
    "args, named",
    [
        (["--eta2", "1.5", "--opd", "100:50:8"], "--opd range 100:50 is empty or reversed"),
        (["--eta2", "1.5", "--eta3", "1:3:1"], "--eta3 count 1 is not allowed"),
        (["--eta2", "1.5", "--cos-theta", "0:1.5:8"], "cos_theta = 1.5"),
        (["--eta2", "1.5", "--kappa3", "0:5:8:log"], "spacing 'log'"),
        (["--eta2", "0", "--opd", "0:100:8"], "eta2 = 0.0"),
        (["--eta2", "1.5", "--opd", "0:100"], "is not A:B:N"),
        (["--eta2", "1.5", "--kappa3", "0:5:8:admittance"], "allowed only on --eta3"),
        (["--eta2", "1.5", "--eta3", "0.5:3:8:admittance"], "needs A >= eta1"),
        (["--eta2", "1.5", "--eta3", "0.5:3:8:sqrt-admittance"], "needs A >= eta1"),
        (["--eta2", "1.5", "--opd", "0:3000:8:sqrt-admittance"], "allowed only on --eta3"),
    ],
)
def test_bad_bake_input_exits_2_and_writes_nothing(tmp_path, args, named):
    proc = _cli("bake", *args, "--out", str(tmp_path / "x.exr"))
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2 and named in err and len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_bake_json_says_where_the_time_went(tmp_path):
    """`bake --json`: each LUT's stages (compile, plan, device, write, other) are non-negative and add up to its
    wall time; the process's CPU over the bake is counted (lutbake/lut/pipeline.py); the library's imports
    are timed."""
    flags = ["--cos-theta", "0:1:8", "--opd", "0:2000:16", "--eta3", "1:3:4", "--kappa3", "0:4:4"]
    proc = _cli("bake", "--quiet", "--json", "--eta2", "1.4", *flags, "--out", str(tmp_path / "x.exr"))
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    summary = json.loads(out)
    row = summary["luts"][0]
    stages = row["stages"]
    parts = [stages[f"{name}_s"] for name in ("compile", "plan", "device", "write", "other")]
    assert min(parts) >= 0.0 and stages["compile_s"] > 0.0 and stages["write_s"] > 0.0
    assert sum(parts) == pytest.approx(row["seconds"], rel=1e-9)
    assert stages["cpu_s"] > 0.0 and stages["cpu_per_wall"] == pytest.approx(stages["cpu_s"] / row["seconds"])
    assert summary["imports_s"] > 0.0
    phases = ("compile", "plan", "device", "write", "other")
    assert sorted(stages["stage_cpu_s"]) == sorted(phases) and min(stages["stage_cpu_s"].values()) >= 0.0
    assert sum(stages["stage_cpu_s"].values()) == pytest.approx(stages["cpu_s"], rel=1e-9)  # other: the rest
    for phase in phases:
        wall, cpu = stages[f"{phase}_s"], stages["stage_cpu_s"][phase]
        assert stages["idle_core_s"][phase] == pytest.approx(max(0.0, stages["cores"] * wall - cpu), abs=1e-12)
    assert stages["idle_core_s_total"] == pytest.approx(sum(stages["idle_core_s"].values()))
    whole = summary["set"]  # one LUT: the set's sums are its own
    assert whole["seconds"] == row["seconds"] and whole["cpu_s"] == stages["cpu_s"] and whole["cells"] == row["cells"]
    assert whole["stage_s"] == {phase: stages[f"{phase}_s"] for phase in phases}
    assert whole["idle_core_s"] == stages["idle_core_s"] and whole["stage_cpu_s"] == stages["stage_cpu_s"]


def test_a_set_bake_sums_its_luts_stages():
    """sets.totals: the set's wall, CPU and each stage's wall, CPU and idle core-seconds are its LUTs' sums,
    and a stage's cores are its summed CPU over its summed wall (not a mean of the LUTs' ratios)."""
    from pathlib import Path

    from lutbake.io.cores import usable_cores
    from lutbake.lut.bake import BakeResult
    from lutbake.lut.pipeline import BakeStages
    from lutbake.lut.sets import totals

    first = BakeStages(plan_s=1.0, write_s=0.5, cpu_s=2.5, stage_cpu_s={"plan": 2.0, "write": 0.25})
    second = BakeStages(plan_s=3.0, device_s=0.5, cpu_s=4.0, stage_cpu_s={"plan": 3.0, "device": 1.0})
    results = [BakeResult(Path(f"{n}.exr"), 10, seconds, "opencl", "d", 0.0, stages=st)
               for n, seconds, st in ((1, 2.0, first), (2, 3.5, second))]  # fmt: skip
    whole = totals(results)
    assert whole["cells"] == 20 and whole["seconds"] == 5.5 and whole["cpu_s"] == 6.5
    assert whole["stage_s"] == {"compile": 0.0, "plan": 4.0, "device": 0.5, "write": 0.5, "other": 0.5}
    assert whole["stage_cpu_s"]["plan"] == 5.0 and whole["stage_cores"]["plan"] == 1.25
    assert whole["stage_cpu_s"]["other"] == pytest.approx(0.25)  # each LUT's CPU outside its stages
    cores = usable_cores()  # each LUT's idle is its own, never below 0: on 1 core the first plan's is 0, not -1
    assert whole["idle_core_s"]["plan"] == pytest.approx(max(0.0, cores * 1.0 - 2.0) + max(0.0, cores * 3.0 - 3.0))
    assert whole["idle_core_s_total"] == pytest.approx(sum(whole["idle_core_s"].values()))


def test_bake_stages_put_each_stage_cpu_in_its_own_stage():
    """BakeStages.clock counts the process's CPU within each stage: a stage that computes on this thread
    gets CPU near its wall, one that sleeps next to none and leaves its wall idle on every core."""
    from lutbake.lut.pipeline import BakeStages

    stages = BakeStages()
    with stages.clock("plan"):
        end = time.process_time() + 0.15
        while time.process_time() < end:  # 0.15 s of this thread's CPU, however long a busy machine takes
            pass
    with stages.clock("write"):
        time.sleep(0.2)
    stages.cpu_s = sum(stages.stage_cpu_s.values())
    described = stages.describe(stages.plan_s + stages.write_s, cores=2)
    assert described["stage_cpu_s"]["plan"] >= 0.15 and described["stage_cpu_s"]["write"] < 0.05
    assert described["stage_cores"]["write"] < 0.25 and described["stage_cores"]["plan"] > 0.0
    assert described["idle_core_s"]["write"] == pytest.approx(2 * stages.write_s - stages.stage_cpu_s["write"])
    assert described["other_s"] == 0.0 and described["stage_cpu_s"]["other"] == 0.0


def test_unwritable_output_exits_2(tmp_path):
    proc = _cli("bake", "--eta2", "1.5", "--out", str(tmp_path / "missing" / "x.exr"))
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2 and "does not exist" in err
    # A folder nobody may write, root included (CI runs as root, so a chmod would not do).
    locked = "/proc/self"
    assert not os.access(locked, os.W_OK)
    proc = _cli("bake", "--eta2", "1.5", "--out", f"{locked}/x.exr")
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2 and "not writable" in err and len(err.strip().splitlines()) == 1


def test_default_bake_writes_the_default_set():
    """`lutbake bake` with no options writes the default set into ./lutbake-luts/ and says so: the
    set conftest.default_luts has that command bake in the repo root (README command 1; in CI, the
    run .ci/run made before the tests) holds every member of every default LUT and nothing else,
    each header the current default spec's (half precision), byte for byte what luts/ holds."""
    luts = default_luts()
    specs = default_specs()
    members = sorted(p.name for p in README_LUTS.iterdir() if not p.name.startswith("."))
    assert members == sorted(f"{name}{suffix}" for name in specs for suffix in LUT_MEMBERS)
    for name, spec in specs.items():
        meta = read_lut(README_LUTS / f"{name}.exr")[0]
        assert meta["content_hash"] == spec.content_hash and meta["precision"] == "half"
        for suffix in LUT_MEMBERS:
            assert (README_LUTS / f"{name}{suffix}").read_bytes() == (luts / f"{name}{suffix}").read_bytes()


@pytest.mark.parametrize("name", ["lutbake-eta2-1.50", "lutbake-eta2-2.00-metal"])
def test_a_default_lut_has_the_same_bytes_on_any_number_of_compression_threads(tmp_path, name):
    """OpenEXR compresses a band's blocks of 16 rows on its own thread pool (lutbake/tables/exr.py): a default
    LUT (a dielectric one, and the metal one whose tiles run along x) rewritten from its own pixels, in
    bands that straddle the blocks, on no pool, one thread and three, is its file byte for byte each time."""
    path = default_luts() / f"{name}.exr"
    meta, image = read_lut(path)[:2]
    height, width, _ = image.shape
    for threads in (0, 1, 3):
        out = tmp_path / f"{threads}.exr"
        with exr_rows(out, width, height, meta, "half", threads=threads) as exr:
            for y in range(0, height, 40):
                exr.write_rows(image[y : y + 40])
        assert out.read_bytes() == path.read_bytes(), f"{threads} threads"


def test_row_levels_equal_per_texel_levels(spec):
    width, height = spec.image_size
    for y0, y1 in ((0, 5), (height // 3, height // 3 + 70), (height - 9, height)):
        per_texel = spec.cell_levels(*(a.ravel() for a in spec.cell_params(y0, y1)))
        assert np.array_equal(spec.row_levels(y0, y1), per_texel)


def test_auto_backend_falls_back_to_numpy_with_a_warning(monkeypatch):
    from lutbake.errors import OpenCLUnavailable
    from lutbake.integrate import opencl as integrate
    from lutbake.integrate import program

    monkeypatch.setattr(program, "built_program", lambda device, compute: OpenCLUnavailable("no platform (simulated)"))
    with pytest.warns(RuntimeWarning, match="numpy path"):
        assert isinstance(integrate.backend("auto"), NumpyBackend)
    with pytest.raises(OpenCLUnavailable):
        integrate.backend("opencl")


def test_sample_command_refuses_another_film(lut_path, tmp_path):
    """--eta2 (or a CSV's eta2 column) other than the LUT's is refused in the flags' words, exit 2."""
    flag = subprocess.run(
        [
            sys.executable,
            "-m",
            "lutbake.cli",
            "sample",
            str(lut_path),
            "--eta2",
            "1.5",
            "--opd",
            "700",
            "--cos-theta",
            "0.5",
            "--eta3",
            "1.7",
        ],
        capture_output=True,
        text=True,
    )
    assert flag.returncode == 2 and "--eta2 1.5 differs from the LUT's eta2 = 1.4" in flag.stderr
    csv = tmp_path / "pts.csv"
    csv.write_text("eta2,thickness_nm,cos_theta,eta3\n1.4,250,0.5,1.7\n1.33,250,0.5,1.7\n")
    column = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "sample", str(lut_path), "--points", str(csv)],
        capture_output=True,
        text=True,
    )
    assert column.returncode == 2 and "--eta2 1.33 differs from the LUT's eta2 = 1.4" in column.stderr


def test_sample_and_inspect_commands(lut_path, tmp_path):
    csv = tmp_path / "pts.csv"
    csv.write_text("cos_theta,opd_nm,eta3,kappa3\n0.5,700,1.7,1.3\n1.2,700,1.7,1.3\n")
    bad = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "sample", str(lut_path), "--points", str(csv)],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2 and "cos_theta = 1.2" in bad.stderr
    csv.write_text("cos_theta,opd_nm,eta3,kappa3\n0.5,700,1.7,1.3\n0.9,2500,1.7,1.3\n")
    out = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "sample", str(lut_path), "--points", str(csv), "--json"],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    rows = json.loads(out.stdout)["points"]
    lut = Lut.load(lut_path)
    assert np.allclose(rows[0]["rgb"], lut.sample(_lut_stack(lut, 0.5, 700.0, 1.7, 1.3)), atol=1e-12)
    assert rows[0]["in_domain"] and not rows[1]["in_domain"]
    meta = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "inspect", str(lut_path), "--json"], capture_output=True, text=True
    )
    assert json.loads(meta.stdout) == lut.meta
    text = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "inspect", str(lut_path)], capture_output=True, text=True
    )
    assert "axis opd_nm" in text.stdout and lut.meta["content_hash"] in text.stdout
    mix = lut.meta["integrator"]
    assert f"Fourier series at {mix['series_texels']} texels" in text.stdout
    assert f"direct rule at {mix['direct_texels']}" in text.stdout


def _admittance_spec(spacing="admittance", **kw):
    axes = (
        Axis("cos_theta", 0.0, 1.0, 8, "sqrt"),
        Axis("opd_nm", 0.0, 2000.0, 8),
        Axis("eta3", 1.2, 3.0, 5, spacing),
        Axis("kappa3", 0.0, 4.0, 3, "sqrt"),
    )
    return BakeSpec(eta2=1.4, eta1=1.2, axes=axes, **kw)


@pytest.mark.parametrize("spacing, power", [("admittance", 0.5), ("sqrt-admittance", 0.25)])
def test_admittance_nodes_are_uniform_in_the_base_admittance_at_each_cos_node(spacing, power):
    spec = _admittance_spec(spacing)
    cos_t = spec.axis["cos_theta"].values()
    eta3 = spec.eta3_columns().reshape(5, 8)  # (η3 node, cos node)
    g = (eta3**2 - 1.2**2 * (1 - cos_t**2)) ** power  # the admittance, or its square root
    assert np.allclose(np.diff(g, axis=0), (g[-1] - g[0]) / 4, rtol=0, atol=1e-12)
    assert np.all(eta3[0] == 1.2) and np.all(eta3[-1] == 3.0)
    assert eta3[1, 0] < eta3[1, -1]  # grazing: crowded towards η3 = η1
    normal = np.linspace(1.2 ** (2 * power), 3.0 ** (2 * power), 5) ** (1 / (2 * power))
    assert np.allclose(eta3[:, -1], normal)  # normal incidence: uniform in η3 or √η3


def test_sqrt_admittance_crowds_harder_than_admittance_at_grazing():
    first = [_admittance_spec(s).eta3_columns().reshape(5, 8)[1, 1] for s in ("admittance", "sqrt-admittance")]
    assert 1.2 < first[1] < first[0]


@pytest.mark.parametrize("spacing", ["admittance", "sqrt-admittance"])
def test_admittance_bake_kernel_equals_numpy_and_sampler_is_exact_at_its_nodes(tmp_path, kernel_device, spacing):
    spec = _admittance_spec(spacing)
    kernel = bake_array(spec, "opencl", "direct", kernel_device)
    assert np.max(np.abs(kernel - bake_array(spec, "numpy"))) <= 1e-10
    bake(spec, tmp_path / "adm.exr")
    lut = Lut.load(tmp_path / "adm.exr")
    assert lut.meta["format_version"] == 4 and lut.meta["axes"][2]["spacing"] == spacing
    i = np.meshgrid(*[np.arange(n) for n in spec.shape], indexing="ij")
    cos_t, opd, kappa3 = (a.values()[j] for a, j in zip(np.array(spec.axes)[[0, 1, 3]], (i[0], i[1], i[3])))
    eta3 = spec.eta3_columns().reshape(5, 8)[i[2], i[0]]
    stored = lut.image.reshape(3, 8, 5, 8, 3).transpose(3, 1, 2, 0, 4)  # (cos, opd, eta3, kappa3, 3)
    assert np.max(np.abs(lut.sample(_lut_stack(lut, cos_t, opd, eta3, kappa3)) - stored)) <= 1e-6 * np.max(
        np.abs(stored)
    )
    pts = FilmPoints.build(
        eta1=1.2, eta2=1.4, cos_theta=cos_t.ravel(), opd_nm=opd.ravel(), eta3=eta3.ravel(), kappa3=kappa3.ravel()
    )
    truth = reference_colour(pts, spec.observer, spec.space).values
    assert np.max(np.abs(stored.reshape(-1, 3) - truth)) <= 1e-5


def test_default_eta3_axis_falls_back_to_uniform_under_an_ambient_above_its_low_end():
    from lutbake.lut.domain import lut_spec

    def eta3_spacing(eta1):
        spec = lut_spec(1.5, eta1, space="rec709", observer="cie1931", interpolation="cubic", compute="float64")
        return spec.axis["eta3"].spacing

    assert eta3_spacing(1.0) == "sqrt-admittance" and eta3_spacing(1.33) == "uniform"


def test_a_lut_made_without_texels_has_coordinates_but_refuses_to_sample():
    """Lut.in_memory(spec, None) (a search over the grid's domain) knows its axes, never reads texels."""
    spec = BakeSpec(
        eta2=1.5,
        axes=(
            Axis("cos_theta", 0.0, 1.0, 4),
            Axis("opd_nm", 0.0, 600.0, 8),
            Axis("eta3", 1.0, 2.0, 2),
            Axis("kappa3", 0.0, 1.0, 2),
        ),
    )
    lut = Lut.in_memory(spec, None)
    stack = FilmPoints.build(eta2=1.5, opd_nm=300.0, cos_theta=0.5, eta3=1.5, kappa3=0.5)
    assert [a.count for a in lut.axes] == [4, 8, 2, 2] and bool(lut.in_domain(stack).all())
    for rule in ("cubic", "linear"):
        with pytest.raises(ValueError, match="without texels"):
            lut.sample(stack, interpolation=rule)
