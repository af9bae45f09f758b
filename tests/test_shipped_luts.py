"""luts/ holds exactly what `lutbake bake --out luts` bakes, stays small, and passes the README's gate."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lutbake.bake import bake_array, default_specs
from lutbake.sample import Lut

LUTS = Path(__file__).resolve().parent.parent / "luts"


def test_each_shipped_lut_is_at_most_8_mib():
    exrs = sorted(LUTS.glob("*.exr"))
    assert len(exrs) == len(default_specs())
    for path in exrs:
        assert path.stat().st_size <= 8 * 2**20, path.name


@pytest.mark.parametrize("name", sorted(default_specs()))
def test_shipped_lut_passes_the_readme_gate(name):
    """`lutbake report LUT --max-de 1.0` (README) exits 0: p99 ΔE00 ≤ 1 at its 1,000 default held-out points."""
    out = subprocess.run([sys.executable, "-m", "lutbake.cli", "report", str(LUTS / f"{name}.exr"), "--max-de", "1.0",
                          "--no-approximations", "--json"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr or out.stdout[-2000:]
    summary = json.loads(out.stdout)
    assert summary["gate"]["passed"] and summary["lut_error"]["de00_p99"] <= 1.0
    assert summary["point_kinds"] == {"cell-centre": 500, "uniform": 500}


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
