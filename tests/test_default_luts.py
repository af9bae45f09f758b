"""The default LUT set (`lutbake bake --out luts`, baked into luts/ by conftest.default_luts) stays within
its byte budget, passes the README's gate and issue 13's p99 target (docs/accuracy.md has the 5,000-point
figures and the max)."""

import json
import subprocess
import sys

import pytest

from conftest import DEFAULT_LUTS as LUTS, default_luts
from lutbake.bake import default_specs


@pytest.fixture(scope="module", autouse=True)
def luts():
    return default_luts()


def test_each_default_lut_is_at_most_8_mib():
    exrs = sorted(LUTS.glob("*.exr"))
    assert len(exrs) == len(default_specs())
    for path in exrs:
        assert path.stat().st_size <= 8 * 2**20, path.name


@pytest.mark.parametrize("name", sorted(default_specs()))
def test_default_lut_passes_the_readme_gate(name):
    """`lutbake report LUT --max-de 1.0` (README) exits 0: p99 ΔE00 ≤ 1 at its 1,000 default held-out points."""
    out = subprocess.run([sys.executable, "-m", "lutbake.cli", "report", str(LUTS / f"{name}.exr"), "--max-de", "1.0",
                          "--no-approximations", "--json"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr or out.stdout[-2000:]
    summary = json.loads(out.stdout)
    assert summary["gate"]["passed"] and summary["lut_error"]["de00_p99"] <= 1.0
    assert summary["point_kinds"] == {"cell-centre": 500, "uniform": 500}
    # issue 13's p99 target, read cubic as the header says (linear reads of the same files score ~0.7)
    assert summary["interpolation"] == "cubic" and summary["lut_error"]["de00_p99"] <= 0.3
