"""The exact runtime mode's figures for docs/engines.md (accuracy and term counts, no timings).

1. three.js in headless Chromium runs the shipped include on the 2,500 KHR-range points of
   tests/engines/test_exact_engine.py (tests/exact_cases.khr_points): |ΔRGB| against the float64 evaluation,
   ΔE00 against the ground truth, and the term counts of the rule (float64 evaluation, same rule) per base.
2. A half-float table instead of the float one (float64 evaluation): ΔE00 against the ground truth.
3. What the base mappings cost: a metal as per-channel constant n, k (611/549/464 nm) against the dispersive
   metal, and glass as a constant ior (SiO2's n at 549 nm) against dispersive SiO2, over the same range.

Rerun: python bench/bench_exact_mode.py   (needs node and Debian's chromium; writes bench/exact-mode-result.json)
"""

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from engine_harness import run_jobs  # noqa: E402
from exact_cases import RGB_CALL, TABLE, float64_exact, ground_truth, khr_points  # noqa: E402

from lutbake.modes.exact import METALS, base_rgb, read_exact_table, write_exact_table  # noqa: E402
from lutbake.physics.colorimetry import delta_e00  # noqa: E402
from lutbake.physics.materials import material  # noqa: E402
from lutbake.physics.points import FilmPoints  # noqa: E402
from lutbake.spectral.reference import reference_colour  # noqa: E402


def stats(values) -> dict:
    v = np.asarray(values, float)
    return {
        "mean": float(v.mean()),
        "p50": float(np.percentile(v, 50)),
        "p99": float(np.percentile(v, 99)),
        "max": float(v.max()),
    }


def engine(points, truth):
    cos, thickness, eta2, eta3, kappa3, name = points
    rows = [[c, d, e, 0.0, *n, 0.0, *k, 0.0] for c, d, e, n, k in zip(cos, thickness, eta2, eta3, kappa3)]
    job = {
        "exr": f"/{TABLE.relative_to(ROOT)}",
        "include": f"/{TABLE.with_suffix('.glsl').relative_to(ROOT)}",
        "float": True,
        "points": rows,
        "call": RGB_CALL,
    }
    with tempfile.TemporaryDirectory() as tmp:
        got = np.array(run_jobs(Path(tmp), {"rgb": job})["rgb"]["rgb"])
    expected, terms = float64_exact(read_exact_table(TABLE), cos, thickness, eta2, eta3, kappa3)
    de = delta_e00(got, truth)
    out = {
        "points": int(cos.size),
        "engine_vs_float64_rgb_max": float(np.abs(got - expected).max()),
        "engine_vs_truth_de00": stats(de),
        "per_base": {},
    }
    for base in np.unique(name):
        at = name == base
        out["per_base"][str(base)] = {"terms": stats(terms[at]), "de00_max": float(de[at].max())}
    return out


def half_table(points, truth):
    cos, thickness, eta2, eta3, kappa3, _ = points
    with tempfile.TemporaryDirectory() as tmp:
        write_exact_table(Path(tmp) / "half.exr", precision="half")
        values, _ = float64_exact(read_exact_table(Path(tmp) / "half.exr"), cos, thickness, eta2, eta3, kappa3)
    return {"rgb_max": float(np.abs(values - truth).max()), "de00": stats(delta_e00(values, truth))}


def mappings(points):
    """ΔE00 of the constant per-channel base against the dispersive material, same points."""
    cos, thickness, eta2, *_ = points
    n = 400
    cos, thickness, eta2 = cos[:n], thickness[:n], eta2[:n]
    out = {}
    for name, page in {**METALS, "SiO2 as ior": "SiO2"}.items():
        if name in METALS:
            eta3, kappa3 = base_rgb(name)
        else:
            eta3 = np.full(3, float(material(page).index(np.array([549.0]))[0][0]))
            kappa3 = np.zeros(3)
        constant = ground_truth(cos, thickness, eta2, np.tile(eta3, (n, 1)), np.tile(kappa3, (n, 1)))
        dispersive = reference_colour(
            FilmPoints.build(eta1=1.0, eta2=eta2, cos_theta=cos, thickness_nm=thickness, base=page)
        ).values
        out[name] = stats(delta_e00(constant, dispersive))
    return out


def main():
    points = khr_points()
    truth = ground_truth(*points[:5])
    result = {
        "engine": engine(points, truth),
        "half_table": half_table(points, truth),
        "base_mapping_vs_dispersive_de00": mappings(points),
    }
    text = json.dumps(result, indent=2)
    (ROOT / "bench" / "exact-mode-result.json").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
