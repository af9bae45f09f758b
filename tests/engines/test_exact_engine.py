"""The exact mode in a real engine: three.js in headless Chromium (engine/harness.mjs, engine/page.js) runs the
shipped include engine/exact/lutbake-exact.glsl, unmodified, on the shipped table at 2,500 points over the
KHR_materials_iridescence range (d 100–400 nm; η2 1.3 and 1.2, 1.5, 2.0; dielectric bases η3 1.0–2.5 and
Au, Ag, Al, Cu, Fe, Cr by per-channel n, k) into a float render target. It must match the float64
evaluation of the same math (exact.exact_colour) to 1e-4 and the ground truth to max ΔE00 ≤ 0.1; and at 400
points near the dielectric corner, where the include sums the terms past its cap in closed form (≤ 0.3)."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import default_luts
from engine_harness import ROOT, require_engine, run_jobs
from exact_cases import RGB_CALL, TABLE, float64_exact, ground_truth, khr_points

from lutbake.modes.exact import METALS, read_exact_table
from lutbake.physics.colorimetry import delta_e00
from lutbake.tables.lutfile import read_lut

sys.path.insert(0, str(ROOT / "docs"))
import make_dropin  # noqa: E402  (the side-by-side page of docs/engines.md)

SCALAR_CALL = "lutbake_exact(lut, p.x, p.y, 1.0, p.z, q.x, r.x)"


@pytest.fixture(scope="module")
def exact_run(tmp_path_factory):
    require_engine()
    make_dropin.write_exact_table()
    cos, thickness, eta2, eta3, kappa3, name = khr_points()
    points = [[c, d, e, 0.0, *n, 0.0, *k, 0.0] for c, d, e, n, k in zip(cos, thickness, eta2, eta3, kappa3)]
    job = {
        "exr": f"/{TABLE.relative_to(ROOT)}",
        "include": f"/{TABLE.with_suffix('.glsl').relative_to(ROOT)}",
        "float": True,
        "points": points,
    }
    dielectric = [p for p, n in zip(points, name) if n == "dielectric"]
    jobs = {
        "rgb": {**job, "call": RGB_CALL},
        "scalar": {**job, "call": SCALAR_CALL, "points": dielectric},
        "control": {**job, "call": RGB_CALL, "prelude": "#define LUTBAKE_SCANLINE0_AT_V0 1"},
    }
    got = run_jobs(tmp_path_factory.mktemp("exact-engine"), jobs)
    table = read_exact_table(TABLE)
    expected, terms = float64_exact(table, cos, thickness, eta2, eta3, kappa3)
    truth = ground_truth(cos, thickness, eta2, eta3, kappa3)
    return {k: np.array(v["rgb"]) for k, v in got.items()}, expected, truth, terms, name


def corner_points(n=400, seed=24):
    """Near the corner where the series needs ~1/(1 − |q|) terms and the include sums the rest in closed form:
    cos θ ≤ 0.02, D ≤ 20 nm, η3 ≤ 1.001, κ3 ≤ 0.001 (each cubed from uniform, so the decades near 0 are
    reached; a quarter on η3 = 1, κ3 = 0 exactly), η2 1.33 or 2.0; rounded to float32."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(0.0, 1.0, (n, 4)) ** 3
    u[: n // 4, 2:] = 0.0
    eta2 = np.where(np.arange(n) % 2 == 0, 1.33, 2.0)
    cos, opd, eta3, kappa3 = 0.02 * u[:, 0], 20.0 * u[:, 1], 1.0 + 1e-3 * u[:, 2], 1e-3 * u[:, 3]
    return [np.float32(v).astype(float) for v in (cos, opd / (2.0 * eta2), eta2, eta3, kappa3)]


@pytest.fixture(scope="module")
def corner_run(tmp_path_factory):
    """The scalar include at corner_points in three.js, the float64 evaluation and the ground truth there."""
    require_engine()
    make_dropin.write_exact_table()
    cos, thickness, eta2, eta3, kappa3 = corner_points()
    points = [[c, d, e, 0.0, n, n, n, 0.0, k, k, k, 0.0] for c, d, e, n, k in zip(cos, thickness, eta2, eta3, kappa3)]
    job = {
        "exr": f"/{TABLE.relative_to(ROOT)}",
        "include": f"/{TABLE.with_suffix('.glsl').relative_to(ROOT)}",
        "float": True,
        "points": points,
        "call": SCALAR_CALL,
    }
    got = np.array(run_jobs(tmp_path_factory.mktemp("exact-corner"), {"corner": job})["corner"]["rgb"])
    eta3, kappa3 = np.tile(eta3[:, None], 3), np.tile(kappa3[:, None], 3)
    expected, terms = float64_exact(read_exact_table(TABLE), cos, thickness, eta2, eta3, kappa3)
    return got, expected, ground_truth(cos, thickness, eta2, eta3, kappa3), terms


def _exact_table(folder: Path, env=None) -> dict:
    """`lutbake exact-table` into ``folder`` (in a process with ``env`` added): suffix -> bytes."""
    folder.mkdir()
    out = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "exact-table", "--out", str(folder / TABLE.name)],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
        timeout=600,
    )
    assert out.returncode == 0, out.stderr
    return {
        suffix: (folder / TABLE.name).with_suffix(f".{suffix}").read_bytes()
        for suffix in ("exr", "json", "glsl", "hlsl")
    }


def test_the_exact_table_is_the_same_bytes_on_one_machine(tmp_path):
    """The determinism contract (docs/design-notes.md#determinism), part 1: same inputs, same machine, same
    bytes, every member."""
    first, second = (_exact_table(tmp_path / name) for name in ("a", "b"))
    assert first == second


def test_the_exact_table_across_blas_kernels_keeps_the_contract(tmp_path):
    """Part 2, across machines, emulated on this one: OpenBLAS's SSE3 kernel (Prescott, which any x86-64 CPU
    runs) instead of the one it picks for this CPU sums in another order. Measured on Zen 5: 1 of 196,608
    float32 values 1 ULP apart and two header figures differing in their last digits, the difference
    reported between an AVX2 and an AVX-512 machine. Each run builds its own user cache (the colour and
    transform tables are BLAS results too). Every stored value stays within 1 ULP, every header number
    within 1e-12 (relative, or absolute near 0), every string and the table's shape identical; the
    includes differ only in those numbers."""
    here = _exact_table(tmp_path / "a", {"LUTBAKE_CACHE_DIR": str(tmp_path / "cache-a")})
    other = _exact_table(
        tmp_path / "b", {"LUTBAKE_CACHE_DIR": str(tmp_path / "cache-b"), "OPENBLAS_CORETYPE": "Prescott"}
    )
    bits = [
        read_lut(tmp_path / name / TABLE.name, formats=("lutbake-exact",))[1].view(np.int32).astype(np.int64)
        for name in ("a", "b")
    ]
    assert bits[0].shape == bits[1].shape and np.abs(bits[0] - bits[1]).max() <= 1  # float32: at most 1 ULP
    assert_within_contract(json.loads(here["json"]), json.loads(other["json"]))
    for suffix in ("glsl", "hlsl"):
        assert_texts_within_contract(here[suffix].decode(), other[suffix].decode())


def assert_within_contract(a, b, path="header"):
    """Same structure and strings; numbers within 1e-12 relative (or absolute for values near 0)."""
    assert type(a) is type(b), path
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for key in a:
            assert_within_contract(a[key], b[key], f"{path}.{key}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_within_contract(x, y, f"{path}[{i}]")
    elif isinstance(a, float):
        assert abs(a - b) <= 1e-12 * max(abs(a), abs(b), 1.0), (path, a, b)
    else:
        assert a == b, path


def assert_texts_within_contract(a: str, b: str):
    """Texts equal but for their numbers, which agree within 1e-12."""
    number = re.compile(r"[-+]?\d+\.\d*(?:[eE][-+]?\d+)?")
    assert number.sub("#", a) == number.sub("#", b)
    for x, y in zip(number.findall(a), number.findall(b)):
        assert_within_contract(float(x), float(y), "include")


def test_the_engine_matches_the_float64_series(exact_run):
    got, expected, _, _, name = exact_run
    assert len(expected) >= 2000 and set(METALS) <= set(name)
    assert np.abs(got["rgb"] - expected).max() <= 1e-4
    dielectric = name == "dielectric"
    assert np.abs(got["scalar"] - expected[dielectric]).max() <= 1e-4


def test_the_engine_matches_the_ground_truth(exact_run):
    got, _, truth, terms, name = exact_run
    assert delta_e00(got["rgb"], truth).max() <= 0.1
    assert terms.max() <= 64


def test_the_engine_sums_the_corner_as_the_float64_evaluation(corner_run):
    """Where the cap binds (the closed-form tail in use), three.js's float32 include returns the float64
    evaluation's numbers and stays within ΔE00 0.3 of the ground truth (without the tail: up to 100)."""
    got, expected, truth, terms = corner_run
    assert (terms == 64).mean() > 0.3
    assert np.abs(got - expected).max() <= 1e-4
    assert delta_e00(got, truth).max() <= 0.3


def test_the_check_fails_with_the_other_row_order(exact_run):
    got, expected, _, _, _ = exact_run
    assert np.abs(got["control"] - expected).max() > 0.1


class TestDropIn:
    """Its own scope for pytest-xdist's --dist loadscope: the drop-in page and the KHR-points run above are
    the two slowest engine fixtures, and may run on different workers."""

    @pytest.fixture(scope="class")
    def dropin(self, tmp_path_factory):
        """The drop-in page: MeshPhysicalMaterial spheres (soap films on dielectrics, oxides on Cu and Fe)
        beside the default LUTs' spheres (read from luts/)."""
        require_engine()
        default_luts()
        image = tmp_path_factory.mktemp("dropin") / "dropin.png"
        cells, runtime_table = make_dropin.run(image)  # raises on a shader error
        rows = make_dropin.errors(cells, dispersive=False)
        return image, {(label, mode): (worst, n) for label, mode, worst, _, _, n in rows}, runtime_table

    def test_the_drop_in_exact_mode_matches_the_ground_truth(self, dropin):
        image, rows, _ = dropin
        assert image.stat().st_size > 10_000
        for label, *_ in make_dropin.MATERIALS:
            worst, n = rows[(label, "exact")]
            assert n >= 500 and worst <= 0.1, (label, worst)

    def test_the_drop_in_runtime_table_matches_the_ground_truth(self, dropin):
        """The drop-in's default path (the runtime table, any iridescenceIOR) on the same spheres, its table
        loaded as the loader picks it at run time: float32, as SwiftShader's WebGL2 context filters float32
        textures (OES_texture_float_linear, which three.js enables)."""
        _, rows, runtime_table = dropin
        assert runtime_table == {"precision": "float", "reason": "OES_texture_float_linear present"}
        for label, *_ in make_dropin.MATERIALS:
            worst, n = rows[(label, "runtime")]
            assert n >= 500 and worst <= 0.3, (label, worst)

    def test_the_drop_in_reads_a_lut_linearly_when_asked(self, dropin):
        """lutRule 'linear' (4 bilinear fetches) changes what the drop-in returns and stays within ΔE00 1."""
        _, rows, _ = dropin
        for label, *_ in make_dropin.MATERIALS:
            linear, cubic = rows[(label, "lut-linear")][0], rows[(label, "lut")][0]
            assert linear != cubic and linear <= 1.0, (label, linear, cubic)

    def test_the_drop_in_check_can_fail(self, dropin):
        """three.js's own term, read back the same way, is far from the truth: the comparison sees a wrong term."""
        _, rows, _ = dropin
        assert min(rows[(label, "three")][0] for label, *_ in make_dropin.MATERIALS) > 1.0
