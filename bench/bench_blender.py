"""Blender: lutbake's node groups and Blender's own thin film against lutbake's ground truth, and the cost.

    python bench/bench_blender.py [--blender PATH] [--points 2000] [--json bench/blender-result.json]
    python bench/bench_blender.py --sections osl --points 300 --json bench/blender-osl-result.json
    python bench/bench_blender.py --sections thin_fade

Every figure in docs/blender.md comes from this script. Blender runs as `lutbake blender` runs it
(lutbake/blender/library.py: a Python with bpy, default ./.venv-blender/bin/python, or $LUTBAKE_BLENDER, or a
Blender executable): probe planes at known angles under a white world (lutbake/blender/probe.py), one
colour per plane, compared with lutbake's ground truth (reference.reference_rgb) by CIEDE2000.

1. ``setup``: Principled BSDF with thin film thickness 0 at random angles and base indices against the
   exact Fresnel term (the ground truth at d = 0): the set-up check (a white world of radiance 1, no view
   transform, N·V as intended).
2. ``blender_thin_film``: Blender's own thin film at ``--points`` random points each: θ uniform in 0–85°,
   d 20–1000 nm, film η2 1.2–2.4, over dielectric bases η3 1.0–2.5 (Principled BSDF), over absorbing
   bases with constant n 0.05–4, k 1.5–9 (Metallic BSDF, Physical Conductor), and over the named metals
   Au, Ag, Cu, Al, Fe, Ti, Cr given to Blender as per-channel n, k at 611/549/464 nm (``--points``/7 each)
   against the dispersive metal.
2b. ``thin_fade``: does Blender fade its thin film as it thins? The Principled BSDF at d 0–60 nm against
   the truth with the film's own index and with the index faded towards the ambient's below 30 nm and
   below 1 nm (``thin_film_fade``).
3. ``examples``: every example scene bake in docs/scenes, written as a library by `lutbake blender` and
   rendered in Cycles at 200 points per material (θ 0–85°, d over the material's range; η3, κ3 over a
   ranged base's ranges), and Blender's own thin film at the same points (constant film and base
   indices: a named one at 549 nm, a named metal per channel), both against the ground truth and
   against the ground truth clamped at 0 (Blender's closures clamp negative, out-of-gamut components:
   the error of the clamping alone is given too). A 4D LUT's group reads linearly; `lutbake sample`'s
   cubic and linear reads are given beside it.
4. ``eevee``: does EEVEE use the thin-film inputs? The Principled BSDF at d = 300 nm against d = 0.
5. ``osl``: the OSL materials of `lutbake blender --exact` and `--runtime-table` (one library) in Cycles:
   at 96 probes against their numpy twins (blender.verify_osl: the exact series in float64, the runtime
   include's float32 model) and the truth; at ``--points`` random points of section 2's domain per base
   kind (dielectric, constant n and k, the named metals per channel) against the ground truth, beside
   Blender's own thin film at the same points; and the render cost, as in section 6, against the Glossy
   BSDF rendered with Cycles' OSL on (OSL shades every material more slowly than Cycles' own nodes).
6. ``cost``: render seconds of one frame (64 probes × 32² px; Cycles 16 samples per pixel, EEVEE 1)
   for a constant-colour Glossy BSDF, lutbake's slice group and 4D LUT group into the same Glossy, and
   the Principled BSDF with its thin film: the median of 3 renders after a first one in the same
   Blender (the first, with EEVEE's shader compilation, is recorded apart), as ratios to the Glossy
   BSDF in the same run. Node counts per group. Needs section 3's libraries.

``--sections`` runs some of them (default: all); the JSON holds those run.

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

from make_scene_examples import bake_example  # noqa: E402

import lutbake  # noqa: E402
from lutbake.blender.library import (  # noqa: E402
    Probes,
    blender_thin_film_probes,
    lutbake_probes,
    render_probes,
    verify_osl,
    write_library,
)
from lutbake.blender.nodes import EXACT_MATERIAL, RUNTIME_MATERIAL  # noqa: E402
from lutbake.blender.programs import (  # noqa: E402
    LutRead,
    NumpyGraph,
    bilinear_program,
    read_manifest,
    read_program,
)
from lutbake.lut.sample import Lut  # noqa: E402
from lutbake.modes.exact import write_exact_table  # noqa: E402
from lutbake.modes.runtime import write_runtime_table  # noqa: E402
from lutbake.physics.colorimetry import delta_e00  # noqa: E402

METALS = ("Au", "Ag", "Cu", "Al", "Fe", "Ti", "Cr")
EXAMPLE_POINTS = 200
SECTIONS = ("setup", "blender_thin_film", "thin_fade", "examples", "eevee", "osl", "cost")
FADE_THICKNESSES_NM = (0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0)
FADE_FILMS = (1.33, 1.5, 2.0, 2.4)  # over a dielectric base η3 1.5, at cos θ 1 and 0.5
GRAZING_DEG = 85.0


def stats(de) -> dict:
    de = np.asarray(de)
    return {
        "median": float(np.median(de)),
        "p99": float(np.percentile(de, 99)),
        "max": float(de.max()),
        "points": int(de.size),
    }


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


def thin_film_cases(rng, n) -> dict:
    """Section 2's points: θ 0–85°, d 20–1000 nm, film η2 1.2–2.4, over each kind of base (label: the
    Blender closure that renders its own thin film there); the named metals ``n``/7 each."""

    def common(m):
        return {
            "eta2": rng.uniform(1.2, 2.4, m),
            "thickness_nm": rng.uniform(20.0, 1000.0, m),
            "cos_theta": _angles(rng, m),
        }

    cases = {
        "dielectric (Principled, eta3 1.0-2.5)": lutbake.FilmPoints.build(**common(n), eta3=rng.uniform(1.0, 2.5, n)),
        "absorbing (Conductor, n 0.05-4, k 1.5-9)": lutbake.FilmPoints.build(
            **common(n), eta3=rng.uniform(0.05, 4.0, n), kappa3=rng.uniform(1.5, 9.0, n)
        ),
    }
    per_metal = max(n // len(METALS), 10)
    return cases, {name: lutbake.FilmPoints.build(**common(per_metal), base=name) for name in METALS}


def thin_film_errors(render_rgb, cases, metals, clamped: bool = False) -> dict:
    """ΔE00 statistics of ``render_rgb(points)`` against the ground truth at ``thin_film_cases``' points
    (``clamped``: the truth held at 0 where negative, what a Blender closure can show)."""

    def de(pts):
        truth = lutbake.reference_rgb(pts)
        return delta_e00(render_rgb(pts), np.maximum(truth, 0.0) if clamped else truth)

    out = {label: stats(de(pts)) for label, pts in cases.items()}
    metal_de = {name: de(pts) for name, pts in metals.items()}
    out["named metals (Conductor, per-channel n, k)"] = {
        **stats(np.concatenate(list(metal_de.values()))),
        "by_metal": {k: stats(v) for k, v in metal_de.items()},
    }
    return out


def blender_thin_film(blender, rng, n) -> dict:
    return thin_film_errors(lambda pts: blender_film(blender, pts), *thin_film_cases(rng, n))


def _film_points(scene, read, probes) -> lutbake.FilmPoints:
    """The ground truth's film stacks at a material's probes (thickness clamped to the baked range)."""
    lo, hi = read.thickness_nm
    d = np.clip(probes.thickness_nm, lo, hi)
    if isinstance(read, LutRead):
        return lutbake.FilmPoints.build(
            eta1=read.eta1,
            eta2=read.eta2,
            cos_theta=probes.cos_theta,
            thickness_nm=d,
            eta3=probes.eta3,
            kappa3=probes.kappa3,
        )
    atlas = lutbake.Atlas.load(scene.folder / read.image)
    return lutbake.FilmPoints.build(**atlas.film_stack(read.material), cos_theta=probes.cos_theta, thickness_nm=d)


def _probes_in_domain(read, rng, n: int, cos_theta=None) -> Probes:
    """``n`` probes inside the material's domain: θ 0–85° unless ``cos_theta`` is given."""
    lo, hi = read.thickness_nm
    eta3 = kappa3 = None
    if isinstance(read, LutRead):
        e, k = read.axes[2:]
        eta3, kappa3 = rng.uniform(e["min"], e["max"], n), rng.uniform(k["min"], k["max"], n)
    return Probes(
        read.material,
        _angles(rng, n) if cos_theta is None else cos_theta,
        rng.uniform(lo, hi, n) if hi > lo else np.full(n, lo),
        eta3,
        kappa3,
        expected=None,
    )


def examples(blender, rng, folder: Path) -> dict:
    rows = {}
    for scene in sorted((ROOT / "examples").glob("*.toml")):  # docs/scenes is baked, not kept in the repository
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
            shown = np.maximum(truth, 0.0)  # what a Blender closure can show: negative components clamp at 0
            theirs = blender_film(blender, pts)
            row = {
                "kind": "4D LUT, linear rule" if isinstance(read, LutRead) else "slice",
                "negative_points": int((truth < 0).any(axis=1).sum()),
                "truth_clamped_at_0": stats(delta_e00(shown, truth)),
                "lutbake_blender": stats(delta_e00(ours[i], truth)),
                "blender_thin_film": stats(delta_e00(theirs, truth)),
                "lutbake_blender_vs_clamped_truth": stats(delta_e00(ours[i], shown)),
                "blender_thin_film_vs_clamped_truth": stats(delta_e00(theirs, shown)),
            }
            if isinstance(read, LutRead):
                lut = Lut.load(scene.folder / read.image)
                row["lutbake_sample_cubic"] = stats(delta_e00(lut.sample(pts), truth))
                row["lutbake_sample_linear"] = stats(delta_e00(lut.sample(pts, interpolation="linear"), truth))
            rows[f"{scene.name}/{read.material}"] = row
    return rows


def _smoothstep(lo: float, hi: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def thin_film_fade(blender) -> dict:
    """Does Cycles fade its thin film below some thickness? The Principled BSDF's thin film at
    FADE_THICKNESSES_NM (films FADE_FILMS over η3 1.5, cos θ 1 and 0.5) against the truth with the film's
    own index, and against the truth with the index faded towards the ambient's below 30 nm and below
    1 nm (η2' = η1 + (η2 − η1)·smoothstep(0, w, d), w = 30 or 1): per thickness, the max ΔE00 to each."""
    d = np.repeat(FADE_THICKNESSES_NM, len(FADE_FILMS) * 2)
    eta2 = np.tile(np.repeat(FADE_FILMS, 2), len(FADE_THICKNESSES_NM))
    cos_theta = np.tile([1.0, 0.5], len(FADE_THICKNESSES_NM) * len(FADE_FILMS))
    rendered = blender_film(blender, lutbake.FilmPoints.build(eta2=eta2, thickness_nm=d, cos_theta=cos_theta, eta3=1.5))
    models = {
        "no fade": eta2,
        **{f"fade below {w:g} nm": 1.0 + (eta2 - 1.0) * _smoothstep(0.0, w, d) for w in (30.0, 1.0)},
    }
    out = {}
    for label, film in models.items():
        de = delta_e00(
            rendered,
            lutbake.reference_rgb(lutbake.FilmPoints.build(eta2=film, thickness_nm=d, cos_theta=cos_theta, eta3=1.5)),
        )
        out[label] = {f"{t:g} nm": float(de[d == t].max()) for t in FADE_THICKNESSES_NM}
    return out


def eevee_thin_film(blender, rng) -> dict:
    n = 32
    common = {"eta2": 1.8, "cos_theta": _angles(rng, n), "eta3": 1.5}
    with_film = lutbake.FilmPoints.build(thickness_nm=300.0, **common)
    without = lutbake.FilmPoints.build(thickness_nm=0.0, **common)
    out = {}
    for engine in ("BLENDER_EEVEE", "CYCLES"):
        a, b = blender_film(blender, with_film, engine), blender_film(blender, without, engine)
        out[engine] = {
            "max_abs_rgb_300nm_vs_0nm": float(np.abs(a - b).max()),
            "de00_vs_truth_300nm": stats(delta_e00(a, lutbake.reference_rgb(with_film))),
        }
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


def _osl_probes(library: Path, material: str, points) -> tuple:
    """(job materials, job probes) rendering ``points`` with ``library``'s OSL material ``material`` (Cycles,
    OSL on), the base per channel as Blender's own thin film gets it (blender_thin_film_probes)."""
    _, probes = blender_thin_film_probes(points)
    return [{"kind": "lutbake", "library": str(library), "material": material}], [{**p, "material": 0} for p in probes]


def osl_materials(blender, rng, n, folder: Path, repeats: int = 3) -> dict:
    """`lutbake blender --exact --runtime-table`: the OSL materials against their numpy twins, against the
    truth beside Blender's own thin film, and their render cost."""
    write_exact_table(folder / "exact.exr")
    write_runtime_table(folder / "runtime.exr")
    library = folder / "osl.blend"
    write_library(None, library, blender, exact=folder / "exact.exr", runtime_table=folder / "runtime.exr")
    out = {
        f"{kind}_vs_numpy": verify_osl(library, kind, folder / f"{kind}.exr", blender, n_points=96)
        for kind in ("exact", "runtime")
    }
    cases, metals = thin_film_cases(rng, n)
    renderers = {"blender thin film": lambda pts: blender_film(blender, pts)}
    for label, material in (("lutbake runtime (OSL)", RUNTIME_MATERIAL), ("lutbake exact (OSL)", EXACT_MATERIAL)):
        renderers[label] = lambda pts, material=material: np.array(
            render(blender, "CYCLES", *_osl_probes(library, material, pts), osl=True)["rgb"]
        )
    for key, clamped in (("vs_truth", False), ("vs_truth_clamped", True)):
        out[key] = {label: thin_film_errors(_once(rgb), cases, metals, clamped) for label, rgb in renderers.items()}
    out["negative_points"] = {
        label: int((lutbake.reference_rgb(pts) < 0).any(axis=-1).sum()) for label, pts in {**cases, **metals}.items()
    }
    m = 64
    cos_theta, d, eta2 = _angles(rng, m), rng.uniform(20, 1000, m), rng.uniform(1.2, 2.4, m)
    glossy = ([{"kind": "glossy", "color": [0.5, 0.4, 0.3]}], [{"cos_theta": float(c)} for c in cos_theta])
    for base, base_args in (("dielectric", {"eta3": rng.uniform(1.0, 2.5, m)}), ("Cu", {"base": "Cu"})):
        pts = lutbake.FilmPoints.build(eta2=eta2, thickness_nm=d, cos_theta=cos_theta, **base_args)
        chosen = {
            "Glossy BSDF, constant colour": glossy,
            "lutbake runtime (OSL)": _osl_probes(library, RUNTIME_MATERIAL, pts),
            "lutbake exact (OSL)": _osl_probes(library, EXACT_MATERIAL, pts),
        }
        out[f"cost ({base} base)"] = _render_costs(blender, "CYCLES", 16, True, chosen, repeats)
    return out


def _once(render_rgb):
    """``render_rgb`` rendering each points object once (scored twice: against the truth and clamped)."""
    done = {}

    def rgb(pts):
        if id(pts) not in done:
            done[id(pts)] = render_rgb(pts)
        return done[id(pts)]

    return rgb


def _render_costs(blender, engine, samples, osl, chosen, repeats) -> dict:
    """Median render seconds of each candidate after a first render, and its ratio to the Glossy BSDF's."""
    rows = {}
    for label, (materials, probes) in chosen.items():
        result = render(blender, engine, materials, probes, cell_px=32, samples=samples, repeat=repeats + 1, osl=osl)
        rows[label] = {
            "first_render_seconds": result["render_seconds"],
            "render_seconds": float(np.median(result["repeat_seconds"])),
        }
    base = rows["Glossy BSDF, constant colour"]["render_seconds"]
    return {label: {**row, "ratio_to_glossy": row["render_seconds"] / base} for label, row in rows.items()}


def cost(blender, folder: Path, repeats: int = 3) -> dict:
    steel = read_manifest(ROOT / "docs" / "scenes" / "tempered-steel" / "tempered-steel.json")
    coated = read_manifest(ROOT / "docs" / "scenes" / "textured-base" / "textured-base.json")
    n, rng = 64, np.random.default_rng(5)
    cos_theta = _angles(rng, n)
    candidates = {
        "Glossy BSDF, constant colour": (
            [{"kind": "glossy", "color": [0.5, 0.4, 0.3]}],
            [{"cos_theta": float(c)} for c in cos_theta],
        )
    }
    for scene, label in ((steel, "lutbake slice group"), (coated, "lutbake 4D LUT group (linear)")):
        probes = _probes_in_domain(scene.reads[-1], rng, n, cos_theta)
        candidates[label] = lutbake_probes(scene, folder / f"{scene.name}.blend", [probes])  # written by examples()
    pts = lutbake.FilmPoints.build(eta2=2.9, thickness_nm=rng.uniform(10, 70, n), cos_theta=cos_theta, eta3=1.5)
    candidates["Principled BSDF, thin film"] = blender_thin_film_probes(pts)
    out = {
        engine: _render_costs(blender, engine, samples, False, candidates, repeats)
        for engine, samples in (("CYCLES", 16), ("BLENDER_EEVEE", 1))
    }
    out["nodes"] = {
        "slice (tempered-steel/steel_werner)": node_counts(steel.reads[-1], (32, 84)),
        "4D LUT (textured-base/coated_metal)": node_counts(coated.reads[0], (64, 144)),
    }
    out["library_bytes"] = {p.name: p.stat().st_size for p in sorted(folder.glob("*.blend"))}
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--blender", default=os.environ.get("LUTBAKE_BLENDER", str(ROOT / ".venv-blender" / "bin" / "python"))
    )
    parser.add_argument("--points", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--sections", nargs="+", choices=SECTIONS, default=list(SECTIONS))
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    doc = {"load_average_1min": os.getloadavg()[0], "machine": platform.processor() or platform.machine()}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench-blender-") as folder:
        folder = Path(folder)
        sections = {
            "setup": lambda: setup_check(args.blender, rng),
            "blender_thin_film": lambda: blender_thin_film(args.blender, rng, args.points),
            "thin_fade": lambda: thin_film_fade(args.blender),
            "examples": lambda: examples(args.blender, rng, folder),
            "eevee": lambda: eevee_thin_film(args.blender, rng),
            "osl": lambda: osl_materials(
                args.blender, np.random.default_rng([args.seed, 5]), args.points, folder
            ),  # its own points: the other sections' stay as they were
            "cost": lambda: cost(args.blender, folder),
        }
        for name in SECTIONS:
            if name in args.sections:
                doc[name] = sections[name]()
    doc["blender"] = render_probes(
        {"engine": "CYCLES", "materials": [{"kind": "glossy", "color": [1, 1, 1]}], "probes": [{"cos_theta": 1.0}]},
        args.blender,
    )["blender"]
    doc["load_average_1min_end"] = os.getloadavg()[0]
    doc["seconds"] = time.perf_counter() - start
    text = json.dumps(doc, indent=2)
    if args.json:
        args.json.write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
