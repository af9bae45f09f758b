"""The ground truth converges, and the fixed rules it replaces would not."""

import numpy as np

from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import _integrate, reference_colour, subset
from lutbake.spectral.rules import panel_rule, wavenumber_rule


def _hard_points(rng, n=150):
    """Thick films up to D = 20 µm, plus near-resonant ones (metal base at grazing,
    total reflection at the base) where R(λ) has narrow Fabry–Perot features."""
    thick = {
        "eta2": rng.uniform(1.2, 3.0, n),
        "opd_nm": rng.uniform(0, 20000, n),
        "cos_theta": rng.uniform(0, 1, n),
        "eta3": rng.uniform(1, 3, n),
        "kappa3": rng.uniform(0, 5, n),
    }
    resonant = {
        "eta2": rng.uniform(2.0, 3.0, n),
        "opd_nm": rng.uniform(5000, 20000, n),
        "cos_theta": rng.uniform(0.02, 0.3, n),
        "eta3": rng.uniform(1.0, 1.5, n),
        "kappa3": rng.choice([0.0, 20.0], n),
    }
    return [FilmPoints.build(**thick), FilmPoints.build(**resonant)]


def test_reference_is_converged_to_1e_7(rng):
    """Each point against a rule four times finer than the one it stopped at (points grouped by it:
    a third of the work of holding every point to four times the finest any point needed)."""
    for pts in _hard_points(rng):
        ref = reference_colour(pts)
        assert ref.converged.all()
        for nodes_per_nm in np.unique(ref.nodes_per_nm):
            at = np.flatnonzero(ref.nodes_per_nm == nodes_per_nm)
            truth = _integrate(subset(pts, at), panel_rule(4 * int(nodes_per_nm)))
            assert np.max(np.abs(ref.values[at] - truth)) <= 1e-7


def test_fixed_5nm_sampling_is_not_converged(rng):
    """The refinement test above can fail: 5 nm sampling misses by far more than 1e-7."""
    pts = _hard_points(rng)[1]
    ref = reference_colour(pts).values
    lam = np.arange(360.0, 831.0, 5.0)
    from lutbake.physics.colorimetry import colorimetry
    from lutbake.spectral.reference import spectral_reflectance

    w = colorimetry().sensitivity(lam) * 5.0
    coarse = spectral_reflectance(pts, lam)[2] @ w.T
    assert np.max(np.abs(coarse - ref)) > 1e-3


def test_wavenumber_rule_error_falls_with_node_count(rng):
    pts = _hard_points(rng)[0]
    ref = reference_colour(pts).values
    errors = [np.max(np.abs(_integrate(pts, wavenumber_rule(n)) - ref)) for n in (128, 256, 512)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < errors[0] / 10


def test_wavenumber_rule_is_exact_for_polynomials_in_wavenumber():
    """Product integration of a degree-7 interpolant: exact up to degree 7, not beyond."""
    ref = panel_rule(16)
    for count in (16, 64, 250, 4096, 16384):  # dense rules: nodes far closer than the 1 nm CMF grid
        rule = wavenumber_rule(count)
        for degree in range(8):
            exact = ref.weights @ (1e3 / ref.wavelength_nm) ** degree
            assert np.max(np.abs(rule.weights @ (1e3 / rule.wavelength_nm) ** degree - exact)) < 1e-9 * 3**degree
    rule = wavenumber_rule(16)
    exact = ref.weights @ (1e3 / ref.wavelength_nm) ** 9
    assert np.max(np.abs(rule.weights @ (1e3 / rule.wavelength_nm) ** 9 - exact)) > 1e-9


def test_ladder_meets_its_error_target_on_random_texels(rng):
    """Per-texel levels (bandwidth × harmonics) hold |ΔRGB| ≤ 1e-5 at 3 samples/cycle."""
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.integrate.numpy_path import NumpyBackend

    n = 300
    spec = BakeSpec(
        eta2=1.8,
        axes=(
            Axis("cos_theta", 0.0, 1.0, 2),
            Axis("opd_nm", 0.0, 8000.0, 2),
            Axis("eta3", 1.0, 3.0, 2),
            Axis("kappa3", 0.0, 8.0, 2),
        ),
    )
    pts = FilmPoints.build(
        eta2=1.8,
        cos_theta=rng.uniform(0, 1, n) ** 2,
        opd_nm=rng.uniform(0, 8000, n),
        eta3=rng.uniform(1, 3, n),
        kappa3=rng.uniform(0, 8, n),
    )
    fast = NumpyBackend().evaluate(spec, pts)
    assert np.max(np.abs(fast - reference_colour(pts).values)) <= 1e-5


def test_dense_rules_converge_on_a_high_finesse_texel():
    """Regression: weights projected at 8 points per nm starved dense rules (error stuck at 1.2e-5)."""
    pts = FilmPoints.build(eta2=2.0, cos_theta=0.05, opd_nm=20000.0, eta3=2.5, kappa3=40.0)
    truth = reference_colour(pts).values
    errors = [np.max(np.abs(_integrate(pts, wavenumber_rule(n)) - truth)) for n in (1024, 4096, 16384)]
    assert errors[0] > errors[1] > errors[2] and errors[2] < 1e-10


def test_knotted_rule_is_exact_for_spectra_with_kinks_at_its_knots():
    """Cut at the knots, the rule integrates a spectrum that is a different cubic in ν on each side
    of every knot (continuous, kinked: what a linearly interpolated index table gives) to rounding;
    the uncut rule of the same count keeps the kinks' O(h²) error."""
    knots = (450.0, 523.0, 611.0)
    ref = panel_rule(16)  # the knots sit on its 1 nm panel edges: exact there too

    def kinked(lam):
        x = 1e3 / lam
        pieces = [np.ones_like(x)] + [np.maximum(x - 1e3 / k, 0.0) for k in knots]
        return sum(((-1) ** i) * (i + 1) * p + 0.3 * p**3 for i, p in enumerate(pieces))

    exact = ref.weights @ kinked(ref.wavelength_nm)
    for count in (64, 256, 1024):
        cut = wavenumber_rule(count, knots_nm=knots)
        assert cut.count >= count and cut.name.endswith("-4-panels")
        assert np.max(np.abs(cut.weights @ kinked(cut.wavelength_nm) - exact)) < 1e-12
        plain = wavenumber_rule(count)
        assert np.max(np.abs(plain.weights @ kinked(plain.wavelength_nm) - exact)) > 1e-7


def test_knotted_rule_cuts_only_where_every_panel_gets_its_nodes():
    from lutbake.spectral.rules import MIN_PANEL_NODES

    knots = tuple(np.linspace(370.0, 820.0, 20))  # 21 panels
    assert wavenumber_rule(64, knots_nm=knots).count == 64  # 21 × 4 > 64: the plain rule
    assert wavenumber_rule(128, knots_nm=knots).name.endswith("-21-panels")
    assert 21 * MIN_PANEL_NODES > 64


def test_rules_are_built_once_per_machine_and_read_back_bit_exact(tmp_path, monkeypatch, cache_folder):
    """A rule's nodes and weights persist in the user cache, one entry per distinct rule; a later
    process reads them without building, bit for bit; a damaged entry is rebuilt."""
    import lutbake.spectral.rules as spectral

    cache_folder(tmp_path)
    spectral.wavenumber_rule.cache_clear()
    fresh = wavenumber_rule(256, knots_nm=(450.0,))
    wavenumber_rule(256, knots_nm=(451.0,))
    assert len(list(tmp_path.glob("wavenumber-rule-*"))) == 2
    build = spectral._panel_rule_arrays

    def refuse(*args):
        raise AssertionError("rebuilt a cached rule")

    monkeypatch.setattr(spectral, "_panel_rule_arrays", refuse)
    spectral.wavenumber_rule.cache_clear()
    again = wavenumber_rule(256, knots_nm=(450.0,))
    np.testing.assert_array_equal(again.weights, fresh.weights)
    np.testing.assert_array_equal(again.wavelength_nm, fresh.wavelength_nm)
    for entry in tmp_path.glob("wavenumber-rule-*"):
        entry.write_bytes(b"not a numpy file")
    monkeypatch.setattr(spectral, "_panel_rule_arrays", build)
    spectral.wavenumber_rule.cache_clear()
    np.testing.assert_array_equal(wavenumber_rule(256, knots_nm=(450.0,)).weights, fresh.weights)
    spectral.wavenumber_rule.cache_clear()


def test_reference_does_not_depend_on_its_thread_count(rng):
    """The points' chunks are fixed by the points and the rule, not by the threads that run them: one
    thread and three give the same bits (thick films: many chunks at the finest rules)."""
    pts = _hard_points(rng, n=40)[0]
    one, three = (reference_colour(pts, workers=w) for w in (1, 3))
    assert np.array_equal(one.values, three.values)
    assert np.array_equal(one.nodes_per_nm, three.nodes_per_nm)


def test_a_rule_finer_than_a_chunk_is_summed_in_spans_to_rounding():
    """2048 nodes per nm (a resonant point's last refinement: 962,560 nodes, 15 chunks' worth) is integrated
    span by span and the spans summed in order: the one matrix product over every node to the rounding of
    reordered sums (√M·ε/2·Σ|w| ~ 1e-13 for random-walk rounding; seen 2e-15); a span shifted by one node
    moves it by more."""
    from lutbake.spectral.reference import _CELLS_PER_CHUNK, _rule, unpolarized_reflectance

    pts = FilmPoints.build(eta2=1.67, cos_theta=[1e-4, 3e-3, 0.5], thickness_nm=500.0, eta3=1.0, kappa3=0.0)
    rule = _rule(2048, "cie1931", "rec709", "rgb")
    assert rule.count > 10 * _CELLS_PER_CHUNK
    whole = unpolarized_reflectance(pts, rule.wavelength_nm) @ rule.weights.T
    np.testing.assert_allclose(_integrate(pts, rule), whole, rtol=0, atol=1e-13)


def _receipt_points(rng, n):
    """Stacks like a glTF receipt's dear ones: η1 = 1, grazing to normal incidence over near-totally reflecting
    metals, black bases (η3 = 1, κ3 = 0) and dielectrics."""
    kind = rng.integers(0, 3, n)
    return FilmPoints.build(
        eta2=rng.uniform(1.2, 2.5, n),
        thickness_nm=rng.uniform(0, 1500, n),
        cos_theta=np.where(kind == 0, rng.choice([1e-3, 1e-2, 0.05], n), rng.uniform(0.05, 1, n)),
        eta3=np.choose(kind, [rng.uniform(0.05, 0.5, n), np.ones(n), rng.uniform(1.0, 2.0, n)]),
        kappa3=np.choose(kind, [rng.uniform(3, 30, n), np.zeros(n), np.zeros(n)]),
    )


def test_the_truth_by_fringes_is_the_truth_by_optics_to_rounding(rng, monkeypatch):
    """reference_colour with physics/fringes.py (where it applies) and with optics at every node (the truth
    before it). Each node's R from either is within 16u·(Σ + 1) of the exact R (tests/physics: Σ the inputs'
    sensitivity, here by differences of optics), each sum of M products rounds by ~√M·u·Σ|w R| (random walk),
    so at a point that stops at the same rule the colours differ by ≤ Σ_k |w_k|·32u·(Σ_k + 1) + 2√M·u·Σ|w|;
    where rounding moves the stop by one level (a last difference within that of the 1e-9 tolerance), by at
    most the tolerance more."""
    from airy_mp import optics_sensitivity

    from lutbake.spectral import reference

    u = np.finfo(float).eps / 2
    pts = _receipt_points(rng, 24)
    fringes = reference_colour(pts)
    monkeypatch.setattr(reference, "fringe_points", lambda points: np.zeros(len(points), bool))
    optics = reference_colour(pts)
    assert np.mean(fringes.nodes_per_nm == optics.nodes_per_nm) >= 0.9
    assert fringes.nodes_per_nm.max() >= 64  # resonant points among them
    for i in range(len(pts)):
        rule = panel_rule(int(fringes.nodes_per_nm[i]))
        fields = (pts.eta1, pts.eta2, pts.eta3, pts.kappa3, pts.cos_theta, pts.thickness_nm)
        columns = [np.full(rule.count, f[i]) for f in fields] + [rule.wavelength_nm]
        sensitivity = 0.5 * optics_sensitivity(columns).sum(axis=0)  # R = (R_s + R_p)/2
        bound = np.abs(rule.weights) @ (32 * u * (sensitivity + 1)) + 2 * np.sqrt(rule.count) * u * np.abs(
            rule.weights
        ).sum(axis=1)
        if fringes.nodes_per_nm[i] != optics.nodes_per_nm[i]:
            bound = bound + reference.DEFAULT_TOLERANCE
        assert np.all(np.abs(fringes.values[i] - optics.values[i]) <= bound), i
