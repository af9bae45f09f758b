"""Blender: lutbake's node groups and Blender's own thin film against lutbake's ground truth, and the cost.

    python bench/bench_blender.py [--blender PATH] [--points 2000] [--json bench/blender-result.json]

Every figure in docs/blender.md comes from this script. Blender runs as `lutbake blender` runs it
(lutbake/blender.py: a Python with bpy, default ./.venv-blender/bin/python, or $LUTBAKE_BLENDER, or a
Blender executable): probe planes at known angles under a white world (lutbake/blender_probe.py), one
colour per plane, compared with lutbake's ground truth (reference.reference_rgb) by CIEDE2000.

1. ``setup``: Principled BSDF with thin film thickness 0 at random angles and base indices against the
   exact Fresnel term (the ground truth at d = 0): the set-up check (a white world of radiance 1, no view
   transform, N·V as intended).
2. ``blender_thin_film``: Blender's own thin film at ``--points`` random points each: θ uniform in 0–85°,
   d 20–1000 nm, film η2 1.2–2.4, over dielectric bases η3 1.0–2.5 (Principled BSDF), over absorbing
   bases with constant n 0.05–4, k 1.5–9 (Metallic BSDF, Physical Conductor), and over the named metals
   Au, Ag, Cu, Al, Fe, Ti, Cr given to Blender as per-channel n, k at 611/549/464 nm (``--points``/7 each)
   against the dispersive metal.
3. ``examples``: every example scene bake in docs/scenes, written as a library by `lutbake blender` and
   rendered in Cycles at 200 points per material (θ 0–85°, d over the material's range; η3, κ3 over a
   ranged base's ranges), and Blender's own thin film at the same points (constant film and base
   indices: a named one at 549 nm, a named metal per channel), both against the ground truth and
   against the ground truth clamped at 0 (Blender's closures clamp negative, out-of-gamut components:
   the error of the clamping alone is given too). A 4D LUT's group reads linearly; `lutbake sample`'s
   cubic and linear reads are given beside it.
4. ``eevee``: does EEVEE use the thin-film inputs? The Principled BSDF at d = 300 nm against d = 0.
5. ``exact_mode_osl``: `lutbake blender --exact`'s OSL material in Cycles at 96 probes against the
   float64 evaluation of the same series (blender.verify_exact) and, on dielectric bases, the truth.
6. ``cost``: render seconds of one frame (64 probes × 32² px; Cycles 16 samples per pixel, EEVEE 1)
   for a constant-colour Glossy BSDF, lutbake's slice group and 4D LUT group into the same Glossy, and
   the Principled BSDF with its thin film: the median of 3 renders after a first one in the same
   Blender (the first, with EEVEE's shader compilation, is recorded apart), as ratios to the Glossy
   BSDF in the same run; the exact mode's OSL material against the Glossy BSDF with Cycles' OSL on
   (OSL shades every material more slowly than Cycles' own nodes). Node counts per group.

The machine's 1-minute load average is recorded (timings are taken on a shared machine: compare the
ratios, not the seconds).
"""

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "docs"))

import lutbake  # noqa: E402
from lutbake.blender import (Probes, blender_thin_film_probes, lutbake_probes, render_probes,  # noqa: E402
                             verify_exact, write_library)
from lutbake.blender_nodes import (EXACT_MATERIAL, LutRead, NumpyGraph, bilinear_program, read_manifest,  # noqa: E402
                                   read_program)
from lutbake.exact import write_exact_table  # noqa: E402
from lutbake.colorimetry import delta_e00  # noqa: E402
from lutbake.sample import Lut  # noqa: E402
from make_scene_examples import bake_example  # noqa: E402

METALS = ("Au", "Ag", "Cu", "Al", "Fe", "Ti", "Cr")
EXAMPLE_POINTS = 200
GRAZING_DEG = 85.0


def stats(de) -> dict:
    de = np.asarray(de)
    return {"median": float(np.median(de)), "p99": float(np.percentile(de, 99)), "max": float(de.max()),
            "points": int(de.size)}


def _angles(rng, n):
    return np.cos(np.radians(rng.uniform(0.0, GRAZING_DEG, n)))


def render(blender, engine, materials, probes, **job):
    return render_probes({"engine": engine, "materials": materials, "probes": probes, **job}, blender)


def blender_film(blender, points, engine="CYCLES") -> np.ndarray:
    materials, probes = blender_thin_film_probes(points)
    return np.array(render(blender, engine, materials, probes)["rgb"])


def setup_check(blender, rng) -> dict:
    n = 64
    pts = lutbake.FilmPoints.build(eta2=1.5, thickness_nm=0.0, cos_theta=_angles(rng, n), eta3=rng.uniform(1.0, 2.5, n))
    return {"max_abs_rgb": float(np.abs(blender_film(blender, pts) - lutbake.reference_rgb(pts)).max()), "points": n}


def blender_thin_film(blender, rng, n) -> dict:
    def common(m):
        return {"eta2": rng.uniform(1.2, 2.4, m), "thickness_nm": rng.uniform(20.0, 1000.0, m),
                "cos_theta": _angles(rng, m)}

    cases = {"dielectric (Principled, eta3 1.0-2.5)": lutbake.FilmPoints.build(**common(n), eta3=rng.uniform(1.0, 2.5, n)),
             "absorbing (Conductor, n 0.05-4, k 1.5-9)": lutbake.FilmPoints.build(
                 **common(n), eta3=rng.uniform(0.05, 4.0, n), kappa3=rng.uniform(1.5, 9.0, n))}
    out = {}
    for label, pts in cases.items():
        out[label] = stats(delta_e00(blender_film(blender, pts), lutbake.reference_rgb(pts)))
    per_metal = max(n // len(METALS), 10)
    metal_de = {}
    for name in METALS:
        pts = lutbake.FilmPoints.build(**common(per_metal), base=name)
        metal_de[name] = delta_e00(blender_film(blender, pts), lutbake.reference_rgb(pts))
    out["named metals (Conductor, per-channel n, k)"] = {
        **stats(np.concatenate(list(metal_de.values()))), "by_metal": {k: stats(v) for k, v in metal_de.items()}}
    return out


def _film_points(scene, read, probes) -> lutbake.FilmPoints:
    """The ground truth's film stacks at a material's probes (thickness clamped to the baked range)."""
    lo, hi = read.thickness_nm
    d = np.clip(probes.thickness_nm, lo, hi)
    if isinstance(read, LutRead):
        return lutbake.FilmPoints.build(eta1=read.eta1, eta2=read.eta2, cos_theta=probes.cos_theta, thickness_nm=d,
                                        eta3=probes.eta3, kappa3=probes.kappa3)
    atlas = lutbake.Atlas.load(scene.folder / read.image)
    return lutbake.FilmPoints.build(**atlas.film_stack(read.material), cos_theta=probes.cos_theta, thickness_nm=d)


def _probes_in_domain(read, rng, n: int, cos_theta=None) -> Probes:
    """``n`` probes inside the material's domain: θ 0–85° unless ``cos_theta`` is given."""
    lo, hi = read.thickness_nm
    eta3 = kappa3 = None
    if isinstance(read, LutRead):
        e, k = read.axes[2:]
        eta3, kappa3 = rng.uniform(e["min"], e["max"], n), rng.uniform(k["min"], k["max"], n)
    return Probes(read.material, _angles(rng, n) if cos_theta is None else cos_theta,
                  rng.uniform(lo, hi, n) if hi > lo else np.full(n, lo), eta3, kappa3, expected=None)


def examples(blender, rng, folder: Path) -> dict:
    rows = {}
    for scene in sorted((ROOT / "examples").glob("*.toml")):   # docs/scenes is baked, not kept in the repository
        bake_example(scene.stem)
    for manifest in sorted((ROOT / "docs" / "scenes").glob("*/*.json")):
        if manifest.stem.startswith("lut-"):
            continue
        scene = read_manifest(manifest)
        library = folder / f"{scene.name}.blend"
        write_library(manifest, library, blender)
        probes = [_probes_in_domain(read, rng, EXAMPLE_POINTS) for read in scene.reads]
        truth_points = [_film_points(scene, read, p) for read, p in zip(scene.reads, probes)]
        materials, job = lutbake_probes(scene, library, probes)
        ours = np.array(render(blender, "CYCLES", materials, job)["rgb"]).reshape(len(probes), EXAMPLE_POINTS, 3)
        for i, (read, pts) in enumerate(zip(scene.reads, truth_points)):
            truth = lutbake.reference_rgb(pts)
            shown = np.maximum(truth, 0.0)   # what a Blender closure can show: negative components clamp at 0
            theirs = blender_film(blender, pts)
            row = {"kind": "4D LUT, linear rule" if isinstance(read, LutRead) else "slice",
                   "negative_points": int((truth < 0).any(axis=1).sum()),
                   "truth_clamped_at_0": stats(delta_e00(shown, truth)),
                   "lutbake_blender": stats(delta_e00(ours[i], truth)),
                   "blender_thin_film": stats(delta_e00(theirs, truth)),
                   "lutbake_blender_vs_clamped_truth": stats(delta_e00(ours[i], shown)),
                   "blender_thin_film_vs_clamped_truth": stats(delta_e00(theirs, shown))}
            if isinstance(read, LutRead):
                lut = Lut.load(scene.folder / read.image)
                row["lutbake_sample_cubic"] = stats(delta_e00(lut.sample(pts), truth))
                row["lutbake_sample_linear"] = stats(delta_e00(lut.sample(pts, interpolation="linear"), truth))
            rows[f"{scene.name}/{read.material}"] = row
    return rows


def eevee_thin_film(blender, rng) -> dict:
    n = 32
    common = {"eta2": 1.8, "cos_theta": _angles(rng, n), "eta3": 1.5}
    with_film = lutbake.FilmPoints.build(thickness_nm=300.0, **common)
    without = lutbake.FilmPoints.build(thickness_nm=0.0, **common)
    out = {}
    for engine in ("BLENDER_EEVEE", "CYCLES"):
        a, b = blender_film(blender, with_film, engine), blender_film(blender, without, engine)
        out[engine] = {"max_abs_rgb_300nm_vs_0nm": float(np.abs(a - b).max()),
                       "de00_vs_truth_300nm": stats(delta_e00(a, lutbake.reference_rgb(with_film)))}
    return out


class _Counter(NumpyGraph):
    """Counts the nodes a program builds: Math and Clamp nodes, Mix nodes, Image Texture nodes (each
    with a Combine XYZ) and bilinear group nodes (whose insides are one group per image)."""

    def __init__(self, images):
        super().__init__(images)
        self.nodes = {"math": 0, "mix": 0, "image": 0, "bilinear group nodes": 0}

    def math(self, op, a, b=None):
        self.nodes["math"] += 1
        return super().math(op, a, b)

    def clamp01(self, a):
        self.nodes["math"] += 1
        return super().clamp01(a)

    def mix(self, a, b, t):
        self.nodes["mix"] += 1
        return super().mix(a, b, t)

    def texel(self, image, u, v):
        self.nodes["image"] += 1
        return super().texel(image, u, v)

    def bilinear(self, image, size, x, y):
        self.nodes["bilinear group nodes"] += 1
        return np.zeros(np.shape(x) + (3,))


def node_counts(read, size) -> dict:
    """Nodes in a material's group, and in the bilinear group it calls (one per image)."""
    images = {read.image: np.zeros((size[1], size[0], 3))}
    group, bilinear = _Counter(images), _Counter(images)
    read_program(group, read, size, {name: np.zeros(1) for name in read.inputs})
    bilinear_program(bilinear, read.image, size, np.zeros(1), np.zeros(1))
    return {"group": group.nodes, "bilinear group": bilinear.nodes}


def _exact_probes(folder: Path, points) -> tuple:
    """The exact mode's OSL material (library exact.blend, written by exact_mode()) at ``points``."""
    fields = np.broadcast_arrays(points.cos_theta, points.thickness_nm, points.eta2, points.eta3)
    probes = [{"cos_theta": float(c), "thickness_nm": float(d), "eta2": float(e2), "eta3_rgb": [float(e3)] * 3,
               "kappa3_rgb": [0.0] * 3} for c, d, e2, e3 in zip(*fields)]
    return [{"kind": "lutbake", "library": str(folder / "exact.blend"), "material": EXACT_MATERIAL}], probes


def exact_mode(blender, folder: Path) -> dict:
    """`lutbake blender --exact`: the OSL material against the float64 series and the ground truth."""
    write_exact_table(folder / "exact.exr")
    write_library(None, folder / "exact.blend", blender, exact=folder / "exact.exr")
    return verify_exact(folder / "exact.blend", folder / "exact.exr", blender, n_points=96)


def cost(blender, folder: Path, repeats: int = 3) -> dict:
    steel = read_manifest(ROOT / "docs" / "scenes" / "tempered-steel" / "tempered-steel.json")
    coated = read_manifest(ROOT / "docs" / "scenes" / "textured-base" / "textured-base.json")
    n, rng = 64, np.random.default_rng(5)
    cos_theta = _angles(rng, n)
    candidates = {"Glossy BSDF, constant colour": ([{"kind": "glossy", "color": [0.5, 0.4, 0.3]}],
                                                   [{"cos_theta": float(c)} for c in cos_theta])}
    for scene, label in ((steel, "lutbake slice group"), (coated, "lutbake 4D LUT group (linear)")):
        probes = _probes_in_domain(scene.reads[-1], rng, n, cos_theta)
        candidates[label] = lutbake_probes(scene, folder / f"{scene.name}.blend", [probes])   # written by examples()
    pts = lutbake.FilmPoints.build(eta2=2.9, thickness_nm=rng.uniform(10, 70, n), cos_theta=cos_theta, eta3=1.5)
    candidates["Principled BSDF, thin film"] = blender_thin_film_probes(pts)
    exact = {"Glossy BSDF, constant colour": candidates["Glossy BSDF, constant colour"],
             "lutbake exact (OSL)": _exact_probes(folder, pts)}
    out = {}
    for engine, samples, osl, chosen in (("CYCLES", 16, False, candidates), ("BLENDER_EEVEE", 1, False, candidates),
                                         ("CYCLES", 16, True, exact)):
        rows = {}
        for label, (materials, probes) in chosen.items():
            result = render(blender, engine, materials, probes, cell_px=32, samples=samples, repeat=repeats + 1, osl=osl)
            rows[label] = {"first_render_seconds": result["render_seconds"],
                           "render_seconds": float(np.median(result["repeat_seconds"]))}
        base = rows["Glossy BSDF, constant colour"]["render_seconds"]
        out[engine + (" (OSL)" if osl else "")] = {label: {**row, "ratio_to_glossy": row["render_seconds"] / base}
                                                   for label, row in rows.items()}
    out["nodes"] = {"slice (tempered-steel/steel_werner)": node_counts(steel.reads[-1], (32, 84)),
                    "4D LUT (textured-base/coated_metal)": node_counts(coated.reads[0], (64, 144))}
    out["library_bytes"] = {p.name: p.stat().st_size for p in sorted(folder.glob("*.blend"))}
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--blender", default=os.environ.get("LUTBAKE_BLENDER", str(ROOT / ".venv-blender" / "bin" / "python")))
    parser.add_argument("--points", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    doc = {"load_average_1min": os.getloadavg()[0], "machine": platform.processor() or platform.machine()}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench-blender-") as folder:
        folder = Path(folder)
        doc["setup"] = setup_check(args.blender, rng)
        doc["blender_thin_film"] = blender_thin_film(args.blender, rng, args.points)
        doc["examples"] = examples(args.blender, rng, folder)
        doc["eevee"] = eevee_thin_film(args.blender, rng)
        doc["exact_mode_osl"] = exact_mode(args.blender, folder)
        doc["cost"] = cost(args.blender, folder)
    doc["blender"] = render_probes({"engine": "CYCLES", "materials": [{"kind": "glossy", "color": [1, 1, 1]}],
                                    "probes": [{"cos_theta": 1.0}]}, args.blender)["blender"]
    doc["load_average_1min_end"] = os.getloadavg()[0]
    doc["seconds"] = time.perf_counter() - start
    text = json.dumps(doc, indent=2)
    if args.json:
        args.json.write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
