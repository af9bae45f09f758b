"""The runtime table's accuracy figures for docs/engines.md and the README, and the error side of the
error-vs-cost table (the cost side: bench/bench_runtime_cost.py).

Over the issue's domain (η2 1–3, d 0–1500 nm, cos θ 0–1; dielectric bases η3 1–3, κ3 0–2; metals η3
0.05–4, κ3 1.5–9; the named metals Au, Ag, Cu, Al, Fe, Ti, Cr at their per-channel indices), against the
ground truth (lutbake/spectral/reference.py) at float32-rounded inputs:
1. the runtime path (runtime.model: the include's arithmetic; tests/engines/test_runtime_engine.py holds three.js
   to it within 1e-4): random points, the full stress grid, a searched maximum per box and per metal
   (worstcase.find_worst), and the same random points with 8-bit filter weights;
2. at the same random points, the other paths that take any film: the exact mode at tolerances 1e-3, 1e-4
   (its default) and 1e-5 (float64 evaluation of its include on the default table, with its terms per
   pixel: its cost), three.js's evalIridescence (approximations.khr_iridescence_rgb, as r187 runs it) and
   Belcour & Barla 2017.

Rerun: python docs/make_runtime.py [--points N] [--budget B] [--searched-only]   (prints Markdown; ~15 min on 2 cores)
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))  # this checkout's lutbake, installed or not: the imports below follow it (E402)

from lutbake.modes.approximations import belcour_barla_rgb, khr_iridescence_rgb  # noqa: E402
from lutbake.modes.exact import exact_colour  # noqa: E402
from lutbake.modes.exact import stored_table as exact_table  # noqa: E402
from lutbake.modes.runtime import runtime_colour, stored_table  # noqa: E402
from lutbake.physics.colorimetry import delta_e00  # noqa: E402
from lutbake.physics.points import FilmPoints  # noqa: E402
from lutbake.quality.runtime_accuracy import (  # noqa: E402
    BOXES,
    NAMED_METALS,
    named_error,
    searched_maxima,
    searched_named_worst,
    stress_error,
    truth,
)

RESULT = ROOT / "docs" / "runtime-result.json"


def stats(de) -> dict:
    return {"points": int(de.size), "p99": float(np.percentile(de, 99)), "max": float(de.max())}


def exact_mode(cos, d, eta2, eta3, kappa3, tolerance=None):
    """The exact mode's float64 evaluation, one film index per call: (RGB (n, 3), terms per point (n,))."""
    table = exact_table()
    out, terms = np.empty((cos.size, 3)), np.empty(cos.size)
    for i in range(cos.size):
        r = exact_colour(
            table,
            cos[i : i + 1],
            d[i : i + 1],
            1.0,
            float(eta2[i]),
            eta3[i : i + 1],
            kappa3[i : i + 1],
            tolerance=tolerance,
        )
        out[i], terms[i] = r.values[0], r.terms[0]
    return out, terms


def random_rows(table, n: int, seed: int) -> dict:
    """ΔE00 of every any-film path at the same random points of each box."""
    out = {}
    for name, box in BOXES.items():
        cols = tuple(np.float32(c).astype(float) for c in box.point(np.random.default_rng(seed).random((n, 5))))
        ref = truth(*cols)
        stack = FilmPoints.build(
            eta1=1.0, eta2=cols[2], cos_theta=cols[0], thickness_nm=cols[1], eta3=cols[3], kappa3=cols[4]
        )
        paths = {
            "runtime": runtime_colour(table, cols[0], cols[1], 1.0, *cols[2:]),
            "runtime, 8-bit filter weights": runtime_colour(table, cols[0], cols[1], 1.0, *cols[2:], filter_bits=8),
            "three.js r187 (KHR)": khr_iridescence_rgb(stack),
            "Belcour & Barla 2017": belcour_barla_rgb(stack),
        }
        out[name] = {path: stats(delta_e00(rgb, ref)) for path, rgb in paths.items()}
        for tolerance in (1e-3, 1e-4, 1e-5):  # the exact mode at its tolerances: error against terms (cost)
            rgb, terms = exact_mode(*cols, tolerance=tolerance)
            out[name][f"exact mode, tolerance {tolerance:g}"] = {
                **stats(delta_e00(rgb, ref)),
                "terms_mean": float(terms.mean()),
                "terms_max": int(terms.max()),
            }
    return out


def print_searched(searched: dict):
    print("| base | box search max (where) | ridge search max (where: cos θ, d nm, η2, η3, κ3) |\n|---|---|---|")
    for name, s in searched.items():
        where = {k: ", ".join(f"{v:.4g}" for v in s[k]["at"].values()) for k in ("box", "ridge")}
        print(f"| {name} | {s['box']['max']:.3f} ({where['box']}) | {s['ridge']['max']:.3f} ({where['ridge']}) |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=2000, help="random points per base box")
    parser.add_argument("--budget", type=int, default=6000, help="evaluations per searched maximum (per box)")
    parser.add_argument("--searched-only", action="store_true", help="only the searched maxima (~5 min)")
    args = parser.parse_args()
    table = stored_table()
    if args.searched_only:
        print_searched(searched_maxima(table, args.budget))
        return
    result = {"random": random_rows(table, args.points, seed=22)}
    result["stress"] = {name: stats(stress_error(table, box)) for name, box in BOXES.items()}
    result["searched"] = searched_maxima(table, args.budget)
    rng = np.random.default_rng(23)
    result["named"] = {}
    for metal in NAMED_METALS:
        worst = searched_named_worst(table, metal, budget=args.budget // 4, seed=1)
        de = named_error(table, metal)(rng.random((args.points // 4, 3)))
        result["named"][metal] = {**stats(de), "searched_max": worst.value}
    RESULT.write_text(json.dumps(result, indent=2) + "\n")

    print("| base | points | random p99 / max | stress grid max | searched max |\n|---|---|---|---|---|")
    for name in BOXES:
        r, s, w = result["random"][name]["runtime"], result["stress"][name], result["searched"][name]
        print(
            f"| {name} | {r['points']} + {s['points']} + {w['evaluations']} | {r['p99']:.3f} / {r['max']:.3f} | "
            f"{s['max']:.3f} | {w['max']:.3f} |"
        )
    for metal, r in result["named"].items():
        print(f"| {metal} per channel | {r['points']} | {r['p99']:.3f} / {r['max']:.3f} | | {r['searched_max']:.3f} |")
    print(
        "\n| path (any film) | dielectric p99 / max | metal p99 / max | exact mode terms, mean (max) |\n"
        "|---|---|---|---|"
    )
    for path in result["random"]["dielectric"]:
        d, m = result["random"]["dielectric"][path], result["random"]["metal"][path]
        terms = (
            f"{d['terms_mean']:.1f} ({d['terms_max']}); {m['terms_mean']:.1f} ({m['terms_max']})"
            if "terms_mean" in d
            else ""
        )
        print(f"| {path} | {d['p99']:.3f} / {d['max']:.3f} | {m['p99']:.3f} / {m['max']:.3f} | {terms} |")
    print()
    print_searched(result["searched"])


if __name__ == "__main__":
    main()
