"""The series plan's remainder test where it is sure (kernels/airy.cl REMAINDER_SURE): past a column's
geometric count the test passes whatever its rounding, so its two exp are skipped. The plan with the skip
must be the plan without it, texel for texel and bit for bit, on grids that reach its edges."""

import numpy as np
import pytest

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.integrate.opencl import OpenCLBackend
from lutbake.integrate.program import KERNEL_SOURCES, DeviceProgram, kernel_defines
from lutbake.integrate.series import SeriesOnDevice

_SKIP = "#define SURE_REMAINDER 1"
_GUARD = "if (!REMAINDER_SURE(c, cap)) {"


def _rebuilt(program: DeviceProgram, old: str, new: str) -> DeviceProgram:
    """``program``'s kernels built again with ``old`` (found once in the sources) replaced by ``new``."""
    from importlib import resources

    import pyopencl as cl

    source = "\n".join(resources.files("lutbake.integrate").joinpath(name).read_text() for name in KERNEL_SOURCES)
    assert source.count(old) == 1
    options = (["-DLUTBAKE_FP64"] if program.compute == "float64" else []) + kernel_defines()
    built = cl.Program(program.ctx, source.replace(old, new)).build(options=options)
    return DeviceProgram(program.ctx, built, program.compute)


def _without_the_skip(program: DeviceProgram) -> DeviceProgram:
    """``program``'s kernels with every texel's remainder test run (SURE_REMAINDER 0)."""
    return _rebuilt(program, _SKIP, "#define SURE_REMAINDER 0")


# η2, then (lo, hi, nodes, spacing) of cos θ, D, η3 and κ3: thin films (cap = the budget) and thick ones (cap
# a few terms), grazing incidence over bases that reflect totally (|q| near 1: the guard on log max|q|), weak
# and strong absorbers, a base matching the film's index.
GRIDS = {
    "grazing-total-reflection": (
        1.5,
        ((0.0, 0.05, 24, "uniform"), (0.0, 20000.0, 48, "sqrt"), (1.0, 1.6, 8, "uniform"), (0.0, 0.01, 4, "uniform")),
    ),
    "metals": (
        2.0,
        ((0.0, 1.0, 16, "sqrt"), (0.0, 3000.0, 64, "sqrt"), (0.02, 4.0, 8, "sqrt"), (1.5, 9.0, 8, "root4")),
    ),
    "thick-dielectric": (
        1.33,
        ((0.0, 1.0, 16, "uniform"), (5000.0, 40000.0, 32, "uniform"), (1.0, 3.0, 8, "uniform"), (0.0, 2.0, 8, "sqrt")),
    ),
    "near-index-match": (
        1.5,
        ((0.0, 1.0, 16, "sqrt"), (0.0, 8000.0, 32, "sqrt"), (1.45, 1.55, 8, "uniform"), (0.0, 1e-4, 4, "uniform")),
    ),
}


def _grid(name: str, compute: str) -> BakeSpec:
    eta2, ranges = GRIDS[name]
    names = ("cos_theta", "opd_nm", "eta3", "kappa3")
    return BakeSpec(eta2=eta2, axes=tuple(Axis(n, *r) for n, r in zip(names, ranges)), compute=compute)


@pytest.mark.parametrize("compute", ["float64", "float32"])
@pytest.mark.parametrize("name", list(GRIDS))
def test_the_plan_is_the_same_with_the_remainder_test_run_at_every_texel(name, compute, kernel_device):
    spec = _grid(name, compute)
    program = OpenCLBackend(compute, device=kernel_device).program
    plans = [SeriesOnDevice(p, spec).plan() for p in (program, _without_the_skip(program))]
    assert plans[0].stats.texels == plans[1].stats.texels and sum(plans[0].stats.texels) == spec.cells
    assert plans[0].stats.bounds == plans[1].stats.bounds and plans[0].stats.shared_terms == plans[1].stats.shared_terms
    assert np.array_equal(plans[0].rest_per_row, plans[1].rest_per_row)
    assert (plans[0].kept is None) == (plans[1].kept is None)
    if plans[0].kept is not None:
        assert all(np.array_equal(a, b) for a, b in zip(plans[0].kept, plans[1].kept))
    assert plans[0].stats.series_texels > 0


@pytest.mark.parametrize("name", list(GRIDS))
def test_the_skip_takes_texels_of_every_grid(name, kernel_device):
    """The comparison above shows something only where the skip fires: with the texels it takes refused the
    series instead (a probe kernel), the plan's series texels drop."""
    spec = _grid(name, "float64")
    program = OpenCLBackend("float64", device=kernel_device).program
    probe = _rebuilt(program, _GUARD, "if (REMAINDER_SURE(c, cap)) return -1;\n    {")
    taken = SeriesOnDevice(program, spec).plan().stats.series_texels
    assert SeriesOnDevice(probe, spec).plan().stats.series_texels < taken
