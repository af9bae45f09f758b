"""The three.js iridescence drop-in side by side (docs/img/dropin.png, the table in docs/engines.md).

MeshPhysicalMaterial spheres with KHR_materials_iridescence parameters, their film Fresnel term by three.js's
built-in evalIridescence, by lutbake's runtime table (the drop-in's default), its exact mode and a shipped
lutbake LUT (engine/lutbake-iridescence.js),
read back per pixel with the parameters each pixel used, against the ground truth at those parameters
(constant indices: the dielectric's ior, the metal's n, k at 611/549/464 nm per channel) and, for metals,
against the dispersive metal (its n, k at every wavelength): what the per-channel mapping costs.

Rerun: (cd engine && npm ci) && python docs/make_dropin.py   (needs node and Debian's chromium; it writes the exact
table into engine/exact/ and the runtime table into luts/ first, as `lutbake exact-table` and `lutbake runtime-table`
do)
"""

import functools
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from make_accuracy import bake_default_luts  # noqa: E402

from lutbake.modes.exact import METALS, base_rgb  # noqa: E402
from lutbake.physics.colorimetry import delta_e00  # noqa: E402
from lutbake.physics.points import FilmPoints  # noqa: E402
from lutbake.spectral.reference import reference_colour  # noqa: E402

IMAGE = ROOT / "docs" / "img" / "dropin.png"
# The exact mode's table the drop-in loads: written here, not kept in the repository (its float32 texels may
# differ in the last bit between machines: docs/design-notes.md#determinism).
EXACT_TABLE = ROOT / "engine" / "exact" / "lutbake-exact.exr"
# (label, iridescenceIOR, thickness nm, base: an ior or a metal's name, LUT)
MATERIALS = [
    ("soap bubble, 400 nm", 1.33, 400.0, 1.0, "luts/lutbake-eta2-1.33"),
    ("soap on glass, 300 nm", 1.33, 300.0, 1.5, "luts/lutbake-eta2-1.33"),
    ("oxide on Cu, 150 nm", 2.0, 150.0, "Cu", "luts/lutbake-eta2-2.00-metal"),
    ("oxide on Fe, 250 nm", 2.0, 250.0, "Fe", "luts/lutbake-eta2-2.00-metal"),
]
SWATCH_COS = np.linspace(1.0, 0.05, 16)
MODES = ("three", "runtime", "exact", "lut", "lut-linear")  # lut-linear: the LUT by the drop-in's lutRule 'linear'
RUNTIME = ROOT / "luts" / "runtime" / "lutbake-runtime.exr"  # beside, not among, the default LUTs


def _base(base):
    """(η3, κ3), each (3,), per channel."""
    if isinstance(base, float):
        return np.full(3, base), np.zeros(3)
    return base_rgb(base)


def truth(cos, thickness, eta2, base) -> np.ndarray:
    """Ground truth with constant indices per channel (channel c with the base's c-th n, k; a dielectric
    base has one index for all three: one integral)."""
    if isinstance(base, float):
        return reference_colour(
            FilmPoints.build(eta1=1.0, eta2=eta2, cos_theta=cos, thickness_nm=thickness, eta3=base)
        ).values
    eta3, kappa3 = _base(base)
    out = np.empty((np.size(cos), 3))
    for c in range(3):
        pts = FilmPoints.build(
            eta1=1.0, eta2=eta2, cos_theta=cos, thickness_nm=thickness, eta3=eta3[c], kappa3=kappa3[c]
        )
        out[:, c] = reference_colour(pts).values[:, c]
    return out


def dispersive_truth(cos, thickness, eta2, metal) -> np.ndarray:
    pts = FilmPoints.build(eta1=1.0, eta2=eta2, cos_theta=cos, thickness_nm=thickness, base=METALS[metal])
    return reference_colour(pts).values


def spec() -> dict:
    materials, swatches = [], []
    for label, eta2, thickness, base, lut in MATERIALS:
        m = {
            "label": label,
            "iridescenceIOR": eta2,
            "thickness": thickness,
            "lut": f"/{lut}",
            "exact": "/engine/exact/lutbake-exact",
            "runtime": f"/{RUNTIME.relative_to(ROOT).with_suffix('')}",
            "ior": base if isinstance(base, float) else 1.5,
        }
        if not isinstance(base, float):
            n, k = base_rgb(base)
            m["metal"] = {
                "eta": n.tolist(),
                "kappa": k.tolist(),
                "f0": (((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)).tolist(),
            }
        materials.append(m)
        swatches.append(truth(SWATCH_COS, thickness, eta2, base).tolist())
    return {"materials": materials, "swatches": swatches}


@functools.lru_cache(maxsize=1)
def write_exact_table() -> Path:
    """engine/exact/lutbake-exact.{exr,json,glsl,hlsl} as `lutbake exact-table` writes them on this machine,
    once per process (a second writer of the folder waits on the bake's lock and writes the same bytes)."""
    EXACT_TABLE.parent.mkdir(exist_ok=True)
    subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "exact-table", "--out", str(EXACT_TABLE.relative_to(ROOT))],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
        timeout=600,
    )
    return EXACT_TABLE


@functools.lru_cache(maxsize=1)
def write_runtime_table() -> Path:
    """luts/runtime/lutbake-runtime.{exr,json,glsl,hlsl} as `lutbake runtime-table` writes them here, once
    per process (generated, not committed: like the exact table, its texels may round differently elsewhere)."""
    RUNTIME.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "runtime-table", "--out", str(RUNTIME.relative_to(ROOT))],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
        timeout=600,
    )
    return RUNTIME


def run(image: Path) -> tuple:
    """Render in headless Chromium: ({(material, mode): (fresnel (n, 3), parameters (n, 3))}, the runtime
    table's texel type the drop-in's loader chose in this context {"precision", "reason"})."""
    write_exact_table()
    write_runtime_table()
    with tempfile.TemporaryDirectory() as tmp:
        job, result = Path(tmp) / "spec.json", Path(tmp) / "result.json"
        job.write_text(json.dumps(spec()))
        proc = subprocess.run(
            ["node", str(ROOT / "engine" / "harness.mjs"), "dropin", str(job), str(result), str(image)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=600,
        )
        if proc.returncode:
            raise RuntimeError(proc.stderr[-4000:])
        page = json.loads(result.read_text())
        cells = page["cells"]
    out = {}
    for cell in cells:
        s = np.array(cell["samples"], float)
        out[(cell["material"], cell["mode"])] = (s[:, :3], s[:, 3:])
    return out, page["runtimeTable"]


def errors(cells: dict, dispersive: bool = True) -> list:
    """Rows (material, mode, max ΔE00, p99 ΔE00 vs constant-index truth, max ΔE00 vs the dispersive metal
    (None for dielectrics or without ``dispersive``), pixels)."""
    rows = []
    for label, eta2, _, base, _ in MATERIALS:
        fresnel, params = cells[(label, "exact")]
        cos, thickness = params[:, 0], params[:, 1]
        ref = truth(cos, thickness, eta2, base)
        disp = None if isinstance(base, float) or not dispersive else dispersive_truth(cos, thickness, eta2, base)
        for mode in MODES:
            rgb, p = cells[(label, mode)]
            assert np.allclose(p, params, atol=1e-6), "modes rendered different pixels"
            de = delta_e00(rgb, ref)
            rows.append(
                (
                    label,
                    mode,
                    float(de.max()),
                    float(np.percentile(de, 99)),
                    None if disp is None else float(delta_e00(rgb, disp).max()),
                    len(rgb),
                )
            )
    return rows


def main():
    bake_default_luts()
    cells, runtime_table = run(IMAGE)
    rows = errors(cells)
    print(f"runtime table: {runtime_table['precision']} texels ({runtime_table['reason']})\n")
    print(
        "| material | mode | max ΔE00 | p99 ΔE00 | max ΔE00 vs dispersive metal | pixels |\n|---|---|---|---|---|---|"
    )
    for label, mode, worst, p99, disp, n in rows:
        print(f"| {label} | {mode} | {worst:.3f} | {p99:.3f} | {'—' if disp is None else f'{disp:.2f}'} | {n} |")


if __name__ == "__main__":
    main()
