"""The runtime path's contract (issue 22) and the table its tests load: max ΔE00 ≤ 1 and p99 ≤ 0.3 against the
ground truth over η2 1–3, d 0–1500 nm, cos θ 0–1, dielectric bases η3 1–3 / κ3 0–2, metals η3 0.05–4 /
κ3 1.5–9 and the named metals per channel; and a tighter regression bound (max ≤ 0.5), so that a loss of
accuracy well inside the contract still shows (measured: p99 ≈ 0.045, searched max 0.36; docs/engines.md)."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
import make_dropin  # noqa: E402  (writes the runtime and exact tables the engine tests load)

CONTRACT_MAX, CONTRACT_P99 = 1.0, 0.3
REGRESSION_MAX = 0.5


def runtime_table_files() -> Path:
    """luts/runtime/lutbake-runtime.exr (+ .json, .glsl, .hlsl) as `lutbake runtime-table` writes them with the current
    code, once per test process (docs/make_dropin.py; generated, not committed: the float64 build may round a
    half texel differently on another machine)."""
    return make_dropin.write_runtime_table()
