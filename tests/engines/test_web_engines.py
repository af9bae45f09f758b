"""lutbake's runtime table in Babylon.js and PlayCanvas: PBRMaterial's iridescence through
engine/lutbake-babylon.js (a material plugin), StandardMaterial's through engine/lutbake-playcanvas.js (a
shader chunk override).

Each engine (pinned in engine/package-lock.json, headless Chromium, WebGL2 through SwiftShader) renders lit
spheres (metallic workflow, KHR_materials_iridescence parameters; a film whose thickness range is not one
value reads it from a random thickness texture, in PlayCanvas with lutbake's fix of its thickness map) with
the drop-in's output set to the film's Fresnel term and again to the parameters each pixel used (cos θ, d,
η2); those pixels read thicknesses across the range. At every pixel the term must be runtime.model's
at those parameters to 1e-4; the materials are random films over dielectric and metal bases, the films
and bases of the worst points a search of the numpy model found (the sphere's pixels sweep cos θ through
the searched one), and named metals per channel. Against the ground truth the contract holds (max
ΔE00 ≤ 1, p99 ≤ 0.3), and the engine's own term, rendered in the same page, is an order of magnitude off.
"""

import json
import subprocess

import numpy as np
import pytest
from engine_harness import ENGINE, ROOT, require_engine
from runtime_contract import CONTRACT_MAX, CONTRACT_P99, REGRESSION_MAX, runtime_table_files
from web_engines import PACKAGES, engine_points, run_engine, truth_subset

from lutbake.modes.exact import base_rgb
from lutbake.modes.runtime import read_runtime_table, runtime_colour
from lutbake.physics.colorimetry import delta_e00

TOLERANCE = 1e-4


@pytest.fixture(scope="module", params=sorted(PACKAGES))
def engine_run(request, tmp_path_factory):
    return run_engine(request.param, tmp_path_factory.mktemp(f"{request.param}-engine"))


def test_the_engine_loads_the_table_half_bilinear_and_not_anisotropic(engine_run):
    result = engine_run["result"]
    texture = result["texture"]
    if engine_run["engine"] == "babylon":
        assert result["babylon"] == "9.28.0" and result["webgl"] == 2
        assert texture["textureType"] == 2 and texture["samplingMode"] == 2  # HALF_FLOAT, BILINEAR
        assert texture["anisotropicFilteringLevel"] == 1 and texture["wrapU"] == texture["wrapV"] == 0  # CLAMP
    else:
        assert result["playcanvas"] == "2.23.3" and result["device"] == "webgl2"
        assert texture["format"] == 12 and texture["minFilter"] == texture["magFilter"] == 1  # RGBA16F, LINEAR
        assert texture["anisotropy"] == 1 and not texture["mipmaps"] and texture["addressU"] == texture["addressV"] == 1


def test_the_engine_returns_the_model(engine_run):
    rgb, cos, d, eta2, eta3, kappa3, index = engine_points(engine_run, "runtime")
    assert len(rgb) >= 10000
    model = runtime_colour(engine_run["table"], cos, d, 1.0, eta2, eta3, kappa3)
    assert np.abs(rgb - model).max() <= TOLERANCE, np.abs(rgb - model).max()
    for k, m in enumerate(engine_run["spec"]["materials"]):
        mine = index == k
        assert mine.sum() >= 300, (m, mine.sum())
        if "cos" in m:  # the sphere's pixels sweep through the searched cos θ
            assert np.abs(cos[mine] - m["cos"]).min() <= 0.01, m
        thin, thick = m["thickness"]
        if thin != thick:  # a thickness texture: the pixels read thicknesses across the range
            assert len(np.unique(d[mine])) >= 50 and d[mine].min() >= thin - 1e-3 and d[mine].max() <= thick + 1e-3, m
            assert np.ptp(d[mine]) >= 0.8 * (thick - thin), (m, np.ptp(d[mine]))


def test_the_engine_meets_the_contract_and_its_own_term_does_not(engine_run):
    got, reference = truth_subset(engine_run, "runtime")
    de = delta_e00(got, reference)
    assert np.percentile(de, 99) <= CONTRACT_P99 and de.max() <= min(CONTRACT_MAX, REGRESSION_MAX), (
        np.percentile(de, 99),
        de.max(),
    )
    own, reference_own = truth_subset(engine_run, engine_run["engine"])
    de_own = delta_e00(own, reference_own)
    assert de_own.max() >= 10 * de.max() and np.percentile(de_own, 99) >= 10 * np.percentile(de, 99), (
        de_own.max(),
        de.max(),
    )


GLTF_METALS = {"oxide": base_rgb("Cu")}  # the metallic glTF material's base, per channel, by its name


@pytest.fixture(scope="module", params=sorted(PACKAGES))
def gltf_run(request):
    """A glTF asset (a soap film over KHR_materials_ior 1.6, an oxide film on a metal) loaded by the engine's
    glTF loader with lutbake's hook (Babylon: the loader extension of engine/lutbake-babylon-gltf.js;
    PlayCanvas: the container's material postprocess, lutbakeGltfOptions), each material rendered on the
    sphere as above. The asset is written under out/ (the harness serves only the repository)."""
    engine = request.param
    from gltf_assets import document, iridescent, stand_in

    require_engine()
    path = runtime_table_files()
    materials = [
        iridescent(ior=1.33, d_min=200, d_max=600, base_ior=1.6, name="soap"),
        iridescent(ior=2.0, d_min=100, d_max=300, metallic=1.0, colour=(0.9, 0.6, 0.5), name="oxide"),
    ]
    doc = document(materials, extensionsUsed=["KHR_materials_iridescence", "KHR_materials_ior"])
    asset = stand_in(doc, ROOT / "out" / "babylon-gltf", "films")
    metals = {name: {"eta": n.tolist(), "kappa": k.tolist()} for name, (n, k) in GLTF_METALS.items()}
    spec = {
        "runtime": f"/{path.with_suffix('').relative_to(ROOT)}",
        "asset": f"/{asset.relative_to(ROOT)}",
        "metals": metals,
        "size": 64,
        "stride": 3,
    }
    job, out = asset.parent / f"{engine}-spec.json", asset.parent / f"{engine}-result.json"
    job.write_text(json.dumps(spec))
    proc = subprocess.run(
        ["node", str(ENGINE / "harness.mjs"), f"{engine}-gltf", str(job), str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    return read_runtime_table(path), json.loads(out.read_text())


def test_the_engines_gltf_loader_serves_the_asset_from_the_runtime_table(gltf_run):
    table, result = gltf_run
    cells = {cell["name"]: cell for cell in result["cells"]}
    assert set(cells) == {"soap", "oxide"}
    assert cells["soap"]["ior"] == pytest.approx(1.6) and cells["soap"]["metallic"] == 0  # KHR_materials_ior
    assert cells["oxide"]["metallic"] == 1
    bases = {"soap": (np.full(3, 1.6), np.zeros(3)), "oxide": GLTF_METALS["oxide"]}
    for name, cell in cells.items():
        samples = np.array(cell["samples"], float)
        assert len(samples) >= 900
        cos, d, eta2 = samples[:, 3:6].T
        n = len(samples)
        eta3, kappa3 = (np.tile(np.asarray(v, float), (n, 1)) for v in bases[name])
        model = runtime_colour(table, cos, d, 1.0, eta2, eta3, kappa3)
        assert np.abs(samples[:, :3] - model).max() <= TOLERANCE, (name, np.abs(samples[:, :3] - model).max())
        other = runtime_colour(table, cos, d, 1.0, eta2, np.full((n, 3), 1.5), np.zeros((n, 3)))
        assert np.abs(samples[:, :3] - other).max() > 1e-2  # the base the asset names made the difference


READ_EXR = """
import { readExr } from './engine/lutbake-exr.js';
import { readFileSync, writeFileSync } from 'node:fs';
const [path, out, ...cuts] = process.argv.slice(1);
const bytes = readFileSync(path);
const slice = (n) => bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + n);
const table = await readExr(path, slice(bytes.length));
writeFileSync(out, Buffer.from(table.texels.buffer));
const errors = [];
for (const n of cuts.map(Number)) {
  errors.push(await readExr(path, slice(n)).then(() => 'read', (e) => e.message));
}
console.log(JSON.stringify({ width: table.width, height: table.height, errors }));
"""


def test_the_engine_neutral_exr_reader_is_openexrs_bit_for_bit_and_refuses_truncated_files(tmp_path):
    """engine/lutbake-exr.js (what Babylon and PlayCanvas upload) against OpenEXR's own reading of the runtime
    table, every half texel, scanline 0 first; a file cut anywhere is refused with a message naming it."""
    import OpenEXR

    require_engine()
    path = runtime_table_files().with_suffix(".exr")
    cuts = [4, 100, 3000, path.stat().st_size // 2, path.stat().st_size - 1]
    out = tmp_path / "texels.bin"
    proc = subprocess.run(
        ["node", "--input-type=module", "-e", READ_EXR, str(path), str(out), *map(str, cuts)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout)
    exr = OpenEXR.InputFile(str(path))
    width, height = result["width"], result["height"]
    planes = [np.frombuffer(exr.channel(c), np.uint16).reshape(height, width) for c in "RGBA"]
    assert np.array_equal(np.fromfile(out, np.uint16).reshape(height, width, 4), np.stack(planes, -1))
    assert len(result["errors"]) == len(cuts)
    assert all(str(path) in error and error != "read" for error in result["errors"]), result["errors"]
