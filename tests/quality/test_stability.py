"""Stiff and extreme inputs: `lutbake check`, and a fuzz of the kernel path."""

import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest
from conftest import node_parses

from lutbake.integrate.opencl import OpenCLBackend
from lutbake.physics.optics import film_reflectance
from lutbake.physics.points import FilmPoints
from lutbake.quality import check


@pytest.fixture(scope="module")
def check_json():
    """`lutbake check --json`, run once (seconds): its stdout."""
    out = subprocess.run([sys.executable, "-m", "lutbake.cli", "check", "--json"], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr
    return out.stdout


def test_lutbake_check_passes_and_reports_every_case(check_json):
    doc = json.loads(check_json)
    groups = {c["group"] for c in doc["checks"]}
    assert groups == {
        "high finesse",
        "thick films",
        "degenerate stacks",
        "angles",
        "float32 kernel",
        "truncation",
        "fourier series",
    }
    for c in doc["checks"]:
        assert {"value", "reference", "error", "tolerance", "passed"} <= set(c)
        assert c["passed"] and np.isfinite(c["value"])


def test_check_json_parses_with_node(check_json):
    """`check --json` among the documents tests/cli/test_cli_honest.py parses with node."""
    assert node_parses(check_json)


def test_check_exits_1_on_a_failure(monkeypatch):
    from click.testing import CliRunner

    from lutbake.cli import cli

    failing = check.CheckResult("angles", "planted failure", 1.0, 0.0, 1.0, 1e-9)
    monkeypatch.setattr(check, "run_checks", lambda backend="auto", progress=None: [failing])
    result = CliRunner().invoke(cli, ["check"], standalone_mode=False)
    assert result.return_value == 1 and "FAIL planted failure" in result.output


WRONG_BY = 2e-4  # in RGB: 0.2 ΔE00 on mid grey


def _columns(stack):
    return (stack.eta1, stack.eta2, stack.cos_theta, stack.opd_nm, stack.eta3, stack.kappa3)


def _wrong_by(salt: str, columns):
    """A wrong fast answer's offset: WRONG_BY to 2·WRONG_BY, different at every stack (a hash of its
    parameters and ``salt``), so that it breaks continuity too."""
    rows = np.broadcast_arrays(*(np.atleast_1d(np.asarray(c, float)) for c in columns))
    digest = [hashlib.sha256(salt.encode() + np.array(r).tobytes()).digest() for r in zip(*rows)]
    return WRONG_BY * (1.0 + np.array([int.from_bytes(d[:4], "little") / 2**32 for d in digest]))[:, None]


class _WrongFastPath:
    """The numpy fast path, off by ``_wrong_by``; its float32 build by WRONG_BY more."""

    name = "numpy"

    def evaluate(self, spec, stack):
        from lutbake.integrate.numpy_path import NumpyBackend

        extra = WRONG_BY if spec.compute == "float32" else 0.0
        return NumpyBackend().evaluate(spec, stack) + _wrong_by("fast", _columns(stack)) + extra


def test_every_check_fails_an_answer_0_2_delta_e_off(monkeypatch):
    """Each case's tolerance means something: with the fast path off by 2e-4–4e-4 in RGB (its float32 build
    by 2e-4 more), the Fourier series off by 2e-4 and claiming the evanescent film, and the ground truth
    off by −2e-4, every case fails. (The far-past-the-cap case held its error to its recorded a-priori
    bound, 1.0, and passed any answer.)"""
    real_series, real_truth = check.series_colour, check.reference_colour

    def wrong_series(stack, tolerance):
        res = real_series(stack, tolerance=tolerance)
        return type(res)(**{**vars(res), "values": res.values + WRONG_BY, "terms": res.terms + 2})

    def wrong_truth(stack, *args, **kwargs):
        res = real_truth(stack, *args, **kwargs)
        return type(res)(**{**vars(res), "values": res.values - WRONG_BY})

    monkeypatch.setattr(check, "series_colour", wrong_series)
    monkeypatch.setattr(check, "reference_colour", wrong_truth)
    results = check.run_checks(_WrongFastPath())
    assert len(results) > 30
    assert [r.name for r in results if r.passed] == []
    assert max(r.tolerance for r in results) < WRONG_BY


def test_the_incoherent_limit_case_fails_the_single_pass_formula():
    """The D = 100 µm case holds the ground truth to R12 + (1 − R12)²R23 / (1 − R12 R23) within 2e-5
    (measured 7.2e-6); dropping the multiple reflections (the denominator) is off by more."""
    truth = check.reference_colour(check._stack(1.0, 1.5, 0.8, 100000.0, 1.0, 0.0)).values
    top = FilmPoints(eta1=1.0, eta2=1.5, eta3=1.5, kappa3=0.0, cos_theta=0.8, thickness_nm=0.0)
    bottom = FilmPoints(eta1=1.5, eta2=1.5, eta3=1.0, kappa3=0.0, cos_theta=np.sqrt(1 - 0.36 / 2.25), thickness_nm=0.0)
    r12, r23 = film_reflectance(top, 550.0), film_reflectance(bottom, 550.0)
    single_pass = 0.5 * sum(a + (1 - a) ** 2 * b for a, b in zip(r12[:2], r23[:2]))
    assert np.max(np.abs(truth - check._incoherent_limit(1.0, 1.5, 1.0, 0.0, 0.8))) <= check.INCOHERENT_TOLERANCE
    assert np.max(np.abs(truth - single_pass)) > check.INCOHERENT_TOLERANCE


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
    from lutbake.grid.spec import Axis, BakeSpec

    # 4×4×2×2: 44 texels past the cap, all measured (8×8×2×2 had 196, the worst 64 measured: 14 s of
    # ground truth at D up to 100 µm instead of 5 s, the same checks)
    axes = (
        Axis("cos_theta", 0.0, 0.1, 4),
        Axis("opd_nm", 0.0, 100000.0, 4),
        Axis("eta3", 2.0, 3.0, 2),
        Axis("kappa3", 50.0, 100.0, 2),
    )
    from lutbake.lut.bake import capped_error

    count, bound, measured = capped_error(BakeSpec(eta2=2.0, axes=axes))
    assert count > 0 and 1e-6 <= bound <= 1.0
    assert 0 < measured <= bound  # the a-priori bound holds where it is measured
    tame = BakeSpec(
        eta2=1.5,
        axes=(
            Axis("cos_theta", 0.0, 1.0, 8),
            Axis("opd_nm", 0.0, 4000.0, 8),
            Axis("eta3", 1.0, 3.0, 2),
            Axis("kappa3", 0.0, 5.0, 2),
        ),
    )
    assert capped_error(tame) == (0, 0.0, 0.0)


def test_grazing_texels_are_exact_so_never_counted_past_the_cap():
    """At cos θ1 = 0 every film reflects R ≡ 1 (the ground truth reads the D65 white, (1, 1, 1) in
    linear Rec.709), so the truncation bound is 0 there: the texels counted and measured past the cap
    are the ones that oscillate (a default metal LUT had half of its 5,268 counted texels at cos θ 0,
    and its 64 measured ones all there, residual 1e-15, while the oscillating ones reach 5e-7)."""
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.lut.bake import capped_error
    from lutbake.spectral.reference import reference_rgb

    spec = BakeSpec(
        eta2=2.0,
        axes=(
            Axis("cos_theta", 0.0, 0.0042, 2),
            Axis("opd_nm", 2500.0, 3000.0, 3),
            Axis("eta3", 0.02, 0.2, 2),
            Axis("kappa3", 7.0, 9.0, 2),
        ),
    )
    white = reference_rgb(FilmPoints.build(eta2=2.0, thickness_nm=700.0, cos_theta=0.0, eta3=0.02, kappa3=9.0))
    assert np.abs(white - 1.0).max() <= 1e-9
    count, bound, texels = spec.capped_texels()
    assert count > 0 and np.all(texels[0] > 0.0)
    assert spec.truncation_estimate(np.zeros(2), np.full(2, 3000.0), np.full(2, 0.02), np.full(2, 9.0)).max() == 0.0
    _, _, measured = capped_error(spec)
    assert measured <= bound  # within the a-priori bound where it is measured
