"""luts/ holds exactly what `lutbake bake --out luts` bakes, and stays small."""

from pathlib import Path

import numpy as np
import pytest

from lutbake.bake import bake_array, default_specs
from lutbake.sample import Lut

LUTS = Path(__file__).resolve().parent.parent / "luts"


def test_shipped_set_is_small():
    assert sum(p.stat().st_size for p in LUTS.iterdir()) < 20 * 2**20


@pytest.mark.parametrize("name", sorted(default_specs()))
def test_shipped_lut_is_the_default_bake(name):
    spec = default_specs()[name]
    lut = Lut.load(LUTS / f"{name}.exr")
    assert lut.meta["content_hash"] == spec.content_hash
    for suffix in (".json", ".glsl", ".hlsl"):
        assert (LUTS / f"{name}{suffix}").is_file()
    fresh = bake_array(spec).astype(np.float16)
    # float64 results from different OpenCL devices may round to adjacent halves
    assert np.max(np.abs(lut.image.astype(float) - fresh.astype(float))) <= 1e-3
    assert np.mean(lut.image == fresh) > 0.999
