"""Colour weights: flat spectra map to grey, whites match colour-science's own integration."""

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    import colour

from lutbake.physics.colorimetry import OBSERVERS, SPACES, colorimetry, delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour
from lutbake.spectral.rules import panel_rule, wavenumber_rule


@pytest.mark.parametrize("space", list(SPACES))
@pytest.mark.parametrize("observer", list(OBSERVERS))
def test_flat_reflectance_is_grey_in_every_space(space, observer):
    for rule in (panel_rule(4, observer, space), wavenumber_rule(37, observer, space)):
        for rho in (0.0, 0.04, 0.5, 1.0):
            rgb = rule.weights @ np.full(rule.count, rho)
            assert np.max(np.abs(rgb - rho)) <= 1e-6


def test_grey_through_the_reference_integrator():
    """d = 0 on glass is spectrally flat (R = 0.04 at normal incidence)."""
    pts = FilmPoints.build(eta2=1.5, thickness_nm=0.0, cos_theta=1.0, eta3=1.5)
    for space in SPACES:
        rgb = reference_colour(pts, space=space).values[0]
        assert np.max(np.abs(rgb - 0.04)) <= 1e-6


@pytest.mark.parametrize("space", list(SPACES))
@pytest.mark.parametrize("observer", list(OBSERVERS))
def test_white_is_the_illuminant_white(space, observer):
    """XYZ of a perfect reflector (grazing incidence, R = 1) equals colour-science's
    integration of the same illuminant, and for the 2° observer sits on the space's
    nominal white chromaticity (to 2e-4: nominal whites are rounded, and the ACES
    white regenerated through the daylight series lands 1.3e-4 from its own xy)."""
    cm = colorimetry(observer, space)
    pts = FilmPoints.build(eta2=1.5, thickness_nm=300.0, cos_theta=0.0, eta3=2.0, kappa3=1.0)
    xyz = reference_colour(pts, observer, space, basis="xyz").values[0]
    sd = colour.SpectralDistribution(dict(zip(cm.wavelength_nm, cm.illuminant)))
    cmfs = colour.MSDS_CMFS[OBSERVERS[observer]]
    expected = colour.sd_to_XYZ(sd, cmfs, method="Integration") / 100.0
    expected = expected / expected[1]
    assert np.max(np.abs(xyz - expected)) <= 2e-4
    if observer == "cie1931":
        xy = xyz[:2] / xyz.sum()
        assert np.max(np.abs(xy - cm.whitepoint_xy)) <= 2e-4


def test_delta_e_is_zero_for_equal_and_positive_for_different_colours():
    a = np.array([[0.2, 0.3, 0.4], [0.5, 0.5, 0.5]])
    assert np.all(delta_e00(a, a) == 0)
    b = a + [0.01, 0.0, 0.0]
    assert np.all(delta_e00(a, b) > 0.1)
    # grey steps of equal lightness difference are about equally far apart
    assert delta_e00([0.18] * 3, [0.2] * 3) == pytest.approx(
        colour.delta_E(
            colour.XYZ_to_Lab([0.18 * 0.9505, 0.18, 0.18 * 1.089]),
            colour.XYZ_to_Lab([0.2 * 0.9505, 0.2, 0.2 * 1.089]),
            method="CIE 2000",
        ),
        rel=1e-3,
    )


def _colour_science_delta_e00(rgb_a, rgb_b, observer, space):
    """colour-science's own pipeline: RGB → XYZ (the space's matrix) → Lab (its white xy) → CIE 2000."""
    cs = colour.RGB_COLOURSPACES[SPACES[space]]
    cm = colorimetry(observer, space)
    xy_white = colour.XYZ_to_xy(cm.rgb_to_xyz(np.ones(3)))
    lab = [colour.XYZ_to_Lab(np.asarray(v) @ np.asarray(cs.matrix_RGB_to_XYZ).T, xy_white) for v in (rgb_a, rgb_b)]
    return colour.delta_E(lab[0], lab[1], method="CIE 2000")


@pytest.mark.parametrize("space", ["rec709", "acescg"])
def test_delta_e00_matches_colour_science(space, rng):
    """lutbake's CIEDE2000 against colour.delta_E on 20,000 pairs: bright, dark (below CIELAB's linear
    toe), near-equal, achromatic (hue undefined) and out-of-gamut (negative) colours."""
    a = np.concatenate(
        [
            rng.uniform(0, 1, (5000, 3)),
            rng.uniform(0, 0.004, (5000, 3)),
            np.repeat(rng.uniform(0, 1, (5000, 1)), 3, axis=1),
            rng.uniform(-0.05, 1, (5000, 3)),
        ]
    )
    b = np.concatenate(
        [
            rng.uniform(0, 1, (5000, 3)),
            a[5000:10000] * rng.uniform(0.9, 1.1, (5000, 3)),
            np.repeat(rng.uniform(0, 1, (5000, 1)), 3, axis=1),
            a[15000:] + rng.normal(0, 0.01, (5000, 3)),
        ]
    )
    ours = delta_e00(a, b, "cie1931", space)
    theirs = _colour_science_delta_e00(a, b, "cie1931", space)
    np.testing.assert_allclose(ours, theirs, rtol=1e-9, atol=1e-9)


def test_tables_from_the_cache_equal_colour_sciences(tmp_path, cache_folder):
    from lutbake.physics import colorimetry as module

    cache_folder(tmp_path)
    fresh = module._read_colour_science("cie1964", "p3")
    first = module._colour_science_tables("cie1964", "p3")  # built, stored
    again = module._colour_science_tables("cie1964", "p3")  # read back
    assert len(list(tmp_path.iterdir())) == 1
    for name in fresh:
        np.testing.assert_array_equal(first[name], fresh[name])
        np.testing.assert_array_equal(again[name], fresh[name])


def test_a_bake_with_a_warm_cache_does_not_import_colour_science(tmp_path):
    """colour-science costs ~2 s per process; with its tables cached, baking and scoring never load it."""
    probe = """
import sys, lutbake
from lutbake.io.usercache import use_folder
use_folder(sys.argv[2])
from lutbake.physics.colorimetry import delta_e00
spec = lutbake.default_specs()["lutbake-eta2-1.50"]
from dataclasses import replace
lutbake.bake_lut(replace(spec, axes=tuple(a.resized(4) for a in spec.axes)), sys.argv[1])
delta_e00([0.1, 0.2, 0.3], [0.1, 0.2, 0.31])
print("colour" in sys.modules)
"""
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    runs = [
        subprocess.run(
            [sys.executable, "-c", probe, str(tmp_path / f"{i}.exr"), str(tmp_path / "cache")],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        for i in range(2)
    ]
    assert [r.returncode for r in runs] == [0, 0], runs[-1].stderr
    assert [r.stdout.strip() for r in runs] == ["True", "False"]  # first fills the cache, then never again
