"""A glTF bake's receipts with the shared ground truth (SharedTruth: consecutive materials' stacks integrated
together, once per distinct stack) against the unshared one (once per part and mapping): the same receipts."""

import subprocess
import sys

import numpy as np
from gltf_assets import document, iridescent, write_gltf

from lutbake.physics.points import FilmPoints
from lutbake.scene.gltf import receipt, scoring
from lutbake.scene.gltf.scoring import SharedTruth
from lutbake.spectral.reference import reference_colour

# The two paths' truths differ only by where a point falls in the truth's chunks (vectorized and scalar loops
# round a few operations differently, ~1e-16 each); ΔE00 amplifies that by at most ~1e4 near black. A stack
# given another stack's truth moves a ΔE00 statistic by far more than 1e-9.
_ROUNDING = 1e-9


def _differences(a, b, where=""):
    """Every (|a - b| relative above 1, place) of two receipts' numbers; their structure and text equal."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        return [d for k in a for d in _differences(a[k], b[k], f"{where}.{k}")]
    if isinstance(a, list):
        assert len(a) == len(b), where
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _differences(x, y, f"{where}[{i}]")]
    if isinstance(a, float):
        return [(abs(a - b) / max(1.0, abs(a)), where)]
    assert a == b, where
    return []


def _counted_receipts(monkeypatch, manifest, shared):
    """The receipts at 60 points a part, seed 3, and the points the ground truth integrated for them."""
    points = []

    def counted(stack):
        points.append(len(stack))
        return reference_colour(stack).values

    monkeypatch.setattr(receipt, "truth_rgb", counted)
    monkeypatch.setattr(scoring, "truth_rgb", counted)
    return receipt.gltf_receipts(manifest, 60, 3, max_de=1.0, shared_truth=shared), sum(points)


def test_shared_truth_gives_the_unshared_receipts_with_fewer_integrations(tmp_path, monkeypatch):
    """A black metal (both metal mappings put F0 = 0 on the bare ambient: one stack for the part and its other
    mapping), a coloured metal (a base per channel) and a dielectric: every field and number of the receipts
    equal to rounding, the shared path integrating fewer points (the black metal's other mapping reused)."""
    materials = [
        iridescent(ior=1.6, d_max=450, metallic=1.0, colour=[0.0, 0.0, 0.0]),
        iridescent(ior=1.7, d_max=300, metallic=1.0, colour=[0.9, 0.5, 0.2]),
        iridescent(ior=1.3, d_max=500),
    ]
    gltf = write_gltf(tmp_path / "g.gltf", document(materials))
    proc = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "bake", "--gltf", str(gltf), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    shared, shared_points = _counted_receipts(monkeypatch, tmp_path / "out" / "g.json", True)
    unshared, unshared_points = _counted_receipts(monkeypatch, tmp_path / "out" / "g.json", False)
    worst = max(_differences(shared, unshared))
    assert worst[0] <= _ROUNDING, worst
    assert shared["materials"][0]["parts"]["metal"]["de00"]["other_mapping"]["de00_max"] == 0.0  # the same stack
    # unshared: black metal 2 stacks, coloured metal 3 channels x 2 mappings, dielectric 1; shared: the black
    # metal's other mapping reused
    assert (unshared_points, shared_points) == (9 * 60, 8 * 60)


def test_shared_truth_integrates_each_distinct_stack_once_and_returns_its_own_truth():
    """Equal stacks (distinct objects) share one integration; stacks differing in one field, or in the named
    base, keep their own truth, each equal to its own reference_colour to rounding."""
    rng = np.random.default_rng(5)
    cos, d = rng.uniform(0.05, 1.0, 40), rng.uniform(100.0, 900.0, 40)
    stacks = [
        FilmPoints.build(eta2=1.5, cos_theta=cos, thickness_nm=d, eta3=1.2, kappa3=2.0),
        FilmPoints.build(eta2=1.5, cos_theta=cos.copy(), thickness_nm=d.copy(), eta3=1.2, kappa3=2.0),
        FilmPoints.build(eta2=1.5, cos_theta=cos, thickness_nm=d, eta3=1.2, kappa3=2.5),
        FilmPoints.build(eta2=1.5, cos_theta=cos, thickness_nm=d, base="Au"),
        FilmPoints.build(eta2=1.5, cos_theta=cos, thickness_nm=d, base="Ag"),
    ]
    truth = SharedTruth()
    assert all(truth.record(s).shape == (40, 3) for s in stacks)
    truth.integrate()
    assert (truth.stacks, truth.integrated, truth.points) == (5, 4, 160)
    for s in stacks:
        np.testing.assert_allclose(truth.colour(s), reference_colour(s).values, rtol=0, atol=1e-14)
    assert np.max(np.abs(truth.colour(stacks[3]) - truth.colour(stacks[4]))) > 0.01
    assert np.max(np.abs(truth.colour(stacks[0]) - truth.colour(stacks[2]))) > 1e-3
