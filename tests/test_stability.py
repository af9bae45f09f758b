"""Stiff and extreme inputs: `lutbake check`, and a fuzz of the kernel path."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import node_parses
from lutbake import check
from lutbake.integrate import OpenCLBackend
from lutbake.optics import film_reflectance
from lutbake.points import FilmPoints


@pytest.fixture(scope="module")
def check_json():
    """`lutbake check --json`, run once (seconds): its stdout."""
    out = subprocess.run([sys.executable, "-m", "lutbake.cli", "check", "--json"], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr
    return out.stdout


def test_lutbake_check_passes_and_reports_every_case(check_json):
    doc = json.loads(check_json)
    groups = {c["group"] for c in doc["checks"]}
    assert groups == {"high finesse", "thick films", "degenerate stacks", "angles", "float32 kernel", "truncation",
                      "fourier series"}
    for c in doc["checks"]:
        assert {"value", "reference", "error", "tolerance", "passed"} <= set(c)
        assert c["passed"] and np.isfinite(c["value"])


@pytest.mark.skipif(shutil.which("node") is None, reason="Node.js is the strict parser this test uses")
def test_check_json_parses_with_node(check_json):
    """`check --json` among the documents tests/test_cli_honest.py parses with node."""
    assert node_parses(check_json)


def test_check_exits_1_on_a_failure(monkeypatch):
    from click.testing import CliRunner

    from lutbake.cli import cli

    failing = check.CheckResult("angles", "planted failure", 1.0, 0.0, 1.0, 1e-9)
    monkeypatch.setattr(check, "run_checks", lambda backend="auto", progress=None: [failing])
    result = CliRunner().invoke(cli, ["check"], standalone_mode=False)
    assert result.return_value == 1 and "FAIL planted failure" in result.output


def _extreme_inputs(rng, n):
    """Random stacks biased to the stiff corners of every axis."""
    def pick(choices, lo, hi):
        return np.where(rng.random(n) < 0.3, rng.choice(choices, n), rng.uniform(lo, hi, n))
    cos_theta = pick([0.0, 1e-12, 1e-6, 1.0], 0.0, 1.0)
    opd = pick([0.0, 1e-9, 1e5], 0.0, 1e5)
    eta3 = pick([1.0, 0.05, 5.0], 0.05, 5.0)
    kappa3 = pick([0.0, 1e-12, 1e-9, 100.0], 0.0, 100.0)
    lam = rng.uniform(360.0, 830.0, n)
    return cos_theta, opd, eta3, kappa3, lam


@pytest.mark.parametrize("compute", ["float64", "float32"])
@pytest.mark.parametrize("eta1, eta2", [(1.0, 1.5), (1.0, 1.0), (1.6, 1.2), (1.0, 3.0)])
def test_kernel_fuzz_finite_and_within_0_1(rng, compute, eta1, eta2, kernel_device):
    """≥ 100,000 extreme inputs per configuration (800,000 in all) through the kernel, per device."""
    cos_theta, opd, eta3, kappa3, lam = _extreme_inputs(rng, 100_000)
    stack = FilmPoints.texels(eta1=eta1, eta2=eta2, cos_theta=cos_theta, opd_nm=opd, eta3=eta3, kappa3=kappa3)
    r = OpenCLBackend(compute, device=kernel_device).reflectance(stack, lam)
    assert np.all(np.isfinite(r))
    assert r.min() >= 0.0 and r.max() <= 1.0
    if compute == "float64":
        ref = film_reflectance(stack, lam)[2]
        assert np.max(np.abs(r - ref)) <= 1e-10


def test_reference_reflectance_fuzz_within_0_1(rng):
    cos_theta, opd, eta3, kappa3, lam = _extreme_inputs(rng, 200_000)
    for eta1, eta2 in [(1.0, 1.5), (1.6, 1.2), (1.0, 1.0)]:
        stack = FilmPoints.texels(eta1=eta1, eta2=eta2, cos_theta=cos_theta, opd_nm=opd, eta3=eta3, kappa3=kappa3)
        r = film_reflectance(stack, lam)
        for v in r:
            assert np.all(np.isfinite(v)) and v.min() >= 0.0 and v.max() <= 1.0


def test_bake_records_texels_past_the_spectral_cap():
    from lutbake.plan import Axis, BakeSpec

    # 4×4×2×2: 44 texels past the cap, all measured (8×8×2×2 had 196, the worst 64 measured: 14 s of
    # ground truth at D up to 100 µm instead of 5 s, the same checks)
    axes = (Axis("cos_theta", 0.0, 0.1, 4), Axis("opd_nm", 0.0, 100000.0, 4), Axis("eta3", 2.0, 3.0, 2),
            Axis("kappa3", 50.0, 100.0, 2))
    from lutbake.bake import capped_error

    count, bound, measured = capped_error(BakeSpec(eta2=2.0, axes=axes))
    assert count > 0 and 1e-6 <= bound <= 1.0
    assert 0 < measured <= bound  # the a-priori bound holds where it is measured
    tame = BakeSpec(eta2=1.5, axes=(Axis("cos_theta", 0.0, 1.0, 8), Axis("opd_nm", 0.0, 4000.0, 8),
                                    Axis("eta3", 1.0, 3.0, 2), Axis("kappa3", 0.0, 5.0, 2)))
    assert capped_error(tame) == (0, 0.0, 0.0)


def test_grazing_texels_are_exact_so_never_counted_past_the_cap():
    """At cos θ1 = 0 every film reflects R ≡ 1 (the ground truth reads the D65 white, (1, 1, 1) in
    linear Rec.709), so the truncation bound is 0 there: the texels counted and measured past the cap
    are the ones that oscillate (a default metal LUT had half of its 5,268 counted texels at cos θ 0,
    and its 64 measured ones all there, residual 1e-15, while the oscillating ones reach 5e-7)."""
    from lutbake.bake import capped_error
    from lutbake.plan import Axis, BakeSpec
    from lutbake.reference import reference_rgb

    spec = BakeSpec(eta2=2.0, axes=(Axis("cos_theta", 0.0, 0.0042, 2), Axis("opd_nm", 2500.0, 3000.0, 3),
                                    Axis("eta3", 0.02, 0.2, 2), Axis("kappa3", 7.0, 9.0, 2)))
    white = reference_rgb(FilmPoints.build(eta2=2.0, thickness_nm=700.0, cos_theta=0.0, eta3=0.02, kappa3=9.0))
    assert np.abs(white - 1.0).max() <= 1e-9
    count, bound, texels = spec.capped_texels()
    assert count > 0 and np.all(texels[0] > 0.0)
    assert spec.truncation_estimate(np.zeros(2), np.full(2, 3000.0), np.full(2, 0.02), np.full(2, 9.0)).max() == 0.0
    _, _, measured = capped_error(spec)
    assert measured <= bound   # within the a-priori bound where it is measured
