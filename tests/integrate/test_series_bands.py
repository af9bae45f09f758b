"""The series' bands on the device against the plan: the closed form's pass runs over the texels the plan
counts in the band's rows (lutbake/integrate/series.py), and a band's value does not depend on how the
image is cut into bands."""

import numpy as np
import pytest

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.spectral.fourier import series_colour


@pytest.fixture(scope="module")
def stiff_spec():
    """Metals near grazing incidence, films to 6 µm: a fifth of the texels beyond the series, in some
    rows and not others."""
    axes = (
        Axis("cos_theta", 0.0, 0.1, 8, "sqrt"),
        Axis("opd_nm", 0.0, 6000.0, 16, "sqrt"),
        Axis("eta3", 0.02, 4.0, 4, "sqrt"),
        Axis("kappa3", 1.5, 20.0, 4, "sqrt"),
    )
    return BakeSpec(eta2=2.0, axes=axes, samples_per_cycle=8.0)


def _series_of(spec, device):
    from lutbake.integrate.opencl import OpenCLBackend

    fast = OpenCLBackend("float64", device=device)
    return fast, fast._series_of(spec)


def test_plan_counts_per_row_the_texels_numpy_leaves_beyond_the_series(stiff_spec, kernel_device):
    _, series = _series_of(stiff_spec, kernel_device)
    width, height = stiff_spec.image_size
    params = [np.ravel(p) for p in stiff_spec.cell_params(0, height)]
    beyond = series_colour(stiff_spec.texel_stacks(params), integrate=False).path.reshape(height, width) > 0
    rest_per_row = series.plan().rest_per_row
    assert 0 < np.count_nonzero(rest_per_row) < height  # some rows hold none: their bands skip the pass
    np.testing.assert_array_equal(rest_per_row, beyond.sum(axis=1))


def test_bands_of_any_height_give_the_same_bits(stiff_spec, kernel_device):
    fast, _ = _series_of(stiff_spec, kernel_device)
    width, height = stiff_spec.image_size
    whole = fast.bake_rows(stiff_spec, 0, height)
    by_rows = np.concatenate([fast.bake_rows(stiff_spec, y, y + 1) for y in range(height)])
    by_threes = np.concatenate([fast.bake_rows(stiff_spec, y, min(y + 3, height)) for y in range(0, height, 3)])
    assert np.array_equal(whole.view(np.uint64), by_rows.view(np.uint64))
    assert np.array_equal(whole.view(np.uint64), by_threes.view(np.uint64))


def test_a_band_that_leaves_other_texels_than_planned_raises(stiff_spec, kernel_device):
    fast, series = _series_of(stiff_spec, kernel_device)
    plan = series.plan()
    row = int(np.flatnonzero(plan.rest_per_row)[0])
    plan.rest_per_row[row] -= 1  # the plan now counts one texel fewer than the series leaves
    try:
        with pytest.raises(RuntimeError, match="where the plan counted"):
            fast.bake_rows(stiff_spec, row, row + 1)
    finally:
        plan.rest_per_row[row] += 1
