"""The Babylon.js and PlayCanvas runs the web-engine tests and bench/bench_web_engines.py share: the materials
(random, searched worst, named metals), one engine's render in headless Chromium, and its pixels as points."""

import numpy as np
import pytest
from engine_harness import ENGINE, ROOT, require_engine, run_harness
from runtime_contract import runtime_table_files

from lutbake.modes.exact import base_rgb
from lutbake.modes.runtime import read_runtime_table
from lutbake.quality.runtime_accuracy import BOXES, searched_worst, truth

SEARCHED = 3  # searched worst points per box
TRUTH_POINTS = 1500  # ground-truth points (spread over every material)


def sphere_material(kind, eta2, eta3, kappa3, thickness):
    """A sphere's material: film index, base (ior, or a metal per channel), thickness range (nm)."""
    eta3, kappa3 = np.broadcast_to(eta3, 3).astype(float), np.broadcast_to(kappa3, 3).astype(float)
    material = {"kind": kind, "iridescenceIOR": float(eta2), "thickness": [float(t) for t in thickness]}
    if not kappa3.any() and np.all(eta3 == eta3[0]):
        return {**material, "ior": float(eta3[0])}
    f0 = ((eta3 - 1) ** 2 + kappa3**2) / ((eta3 + 1) ** 2 + kappa3**2)  # Babylon's metallic base is its F0
    return {**material, "ior": 1.5, "metal": {"eta": eta3.tolist(), "kappa": kappa3.tolist(), "f0": f0.tolist()}}


def materials(table):
    """Random films over random dielectric and metal bases, the searched worst films and bases of both
    boxes (thickness fixed at the searched one), and two named metals, float32-rounded."""
    rng = np.random.default_rng(37)
    f32 = lambda v: np.float32(v).astype(float)  # noqa: E731
    out = []
    for _ in range(3):
        thin, thick = sorted(rng.uniform(0, 1500, 2))
        out.append(sphere_material("random", f32(rng.uniform(1, 3)), f32(rng.uniform(1, 3)), 0.0, (thin, thick)))
        n, k = f32(rng.uniform(0.05, 4, 3)), f32(rng.uniform(1.5, 9, 3))
        out.append(sphere_material("random", f32(rng.uniform(1, 3)), n, k, sorted(rng.uniform(0, 1500, 2))))
    for name, box in BOXES.items():
        worst = searched_worst(table, box, budget=800, seed=9)
        for candidate in worst.candidates[:SEARCHED]:
            cos, d, eta2, eta3, kappa3 = f32(box.point(np.array([candidate.where]))).ravel()
            out.append({**sphere_material(f"{name} searched", eta2, eta3, kappa3, (d, d)), "cos": float(cos)})
    for metal in ("Au", "Cu"):
        n, k = base_rgb(metal)
        out.append(sphere_material(f"{metal} per channel", f32(rng.uniform(1, 3)), f32(n), f32(k), (100, 900)))
    return out


PACKAGES = {"babylon": "@babylonjs/core", "playcanvas": "playcanvas"}  # harness command: the engine's package
OWN_MODES = {"babylon": "babylon", "playcanvas": "playcanvas", "webgpu": "three"}  # the engine's own term's mode


def run_engine(engine, folder):
    """The spheres of every material rendered by ``engine`` (babylon, playcanvas, or webgpu: three.js's
    WebGPURenderer) in headless Chromium, for lutbake's term and the engine's own (bench/bench_web_engines.py
    prints the same run's figures)."""
    path = runtime_table_files()
    table = read_runtime_table(path)
    spec = {"materials": materials(table), "modes": ["runtime", OWN_MODES[engine]], "size": 64, "stride": 3}
    return {"engine": engine, "table": table, "spec": spec, "result": render_spheres(engine, spec, path, folder)}


def render_spheres(engine, spec, runtime_path, folder):
    """The page's result for ``spec`` (materials, modes, size, stride, image) with the runtime table at
    ``runtime_path`` (docs/make_engines_figure.py draws the same renders)."""
    require_package({**PACKAGES, "webgpu": "three"}[engine])
    spec = {**spec, "runtime": f"/{runtime_path.with_suffix('').relative_to(ROOT)}"}
    return run_harness(engine, folder, spec, timeout=900)


GLTF_PACKAGES = {"babylon": "@babylonjs/loaders", "playcanvas": "playcanvas"}  # the glTF pages' engine: its package


def serve_gltf_bake(engine, gltf, manifest, serve, folder, size):
    """The `ENGINE-gltf` page's cells (engine/sphere-samples.js gltfCells) for the glTF asset at ``gltf`` with
    its `lutbake bake --gltf` output's ``manifest`` (paths in the repository), served by ``serve`` (bake or
    runtime, the runtime table beside), every other pixel of a ``size``² render."""
    require_package(GLTF_PACKAGES[engine])
    runtime = runtime_table_files()
    spec = {
        "runtime": f"/{runtime.with_suffix('').relative_to(ROOT)}",
        "asset": f"/{gltf.relative_to(ROOT)}",
        "manifest": f"/{manifest.relative_to(ROOT)}",
        "serve": serve,
        "metals": {},
        "size": size,
        "stride": 2,
    }
    # A forced 4D LUT (3 x 256 reads a pixel) drawn four times per material took over 600 s under a shared
    # machine's load (3 min at load 7): the limit only stops a hung page.
    return run_harness(f"{engine}-gltf", folder, spec, timeout=1800)["cells"]


def require_package(package):
    """Node, Chromium and the pinned ``package`` (engine/package-lock.json): the test fails without them."""
    require_engine()
    if not (ENGINE / "node_modules" / package).is_dir():
        pytest.fail(f"the pinned {package} is missing: cd engine && npm ci", pytrace=False)


def engine_points(run, mode):
    """(rgb (n, 3), cos, d, η2, η3 (n, 3), κ3 (n, 3), material index) over every sphere of ``mode``."""
    rows, bases, index = [], [], []
    for cell in run["result"]["cells"]:
        if cell["mode"] != mode:
            continue
        m = run["spec"]["materials"][cell["material"]]
        base = (m["metal"]["eta"], m["metal"]["kappa"]) if "metal" in m else ([m["ior"]] * 3, [0.0] * 3)
        samples = np.array(cell["samples"], float)
        rows.append(samples)
        bases.append(np.repeat(np.array(base, float)[None], len(samples), 0))
        index += [cell["material"]] * len(samples)
    data, base = np.vstack(rows), np.vstack(bases)
    return data[:, :3], data[:, 3], data[:, 4], data[:, 5], base[:, 0], base[:, 1], np.array(index)


def truth_subset(engine_run, mode):
    rgb, cos, d, eta2, eta3, kappa3, _ = engine_points(engine_run, mode)
    pick = np.random.default_rng(5).choice(len(rgb), TRUTH_POINTS, replace=False)
    return rgb[pick], truth(cos[pick], d[pick], eta2[pick], eta3[pick], kappa3[pick])
