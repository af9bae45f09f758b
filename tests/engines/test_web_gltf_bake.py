"""A `lutbake bake --gltf` output served in Babylon.js (engine/lutbake-babylon-gltf.js) and PlayCanvas
(engine/lutbake-playcanvas.js, lutbakeGltfOptions), routes picked by the engine-neutral
engine/lutbake-routes.js, in headless Chromium (WebGL2 on SwiftShader).

The Khronos showcase asset IridescenceSuzanne (its materials from tests/fixtures/khronos_iridescence.json on
generated geometry: a film over a dielectric of index 2 at one thickness, the same film over a grey metal, and
a textured-thickness film over index 1.5) is baked by the CLI with its third material sent to the runtime
table (`--route 2=runtime`). The engine's glTF loader loads it with lutbake's hook given the bake; each
material is rendered on a sphere with the film's Fresnel term as output and again with the parameters each
pixel used. At every pixel the term must be the manifest's model at those parameters to 1e-4: the atlas slice
read as `lutbake sample` reads it (lutbake.lut.sample.Atlas), one slice per channel for the metal, the runtime
model (runtime_colour) at the part's base for the runtime part. `serve: 'runtime'` sends every part to the
table. Both engines load the same asset, the third material's thickness texture included (PlayCanvas 2.23.3
with lutbake's fix of its thickness map, engine/lutbake-playcanvas.js fixIridescenceThicknessMap); stock
PlayCanvas with that fix alone (`serve: 'playcanvas'`) reads the same thickness at each pixel.
"""

import json
import shutil
import subprocess
import sys
import uuid

import numpy as np
import pytest
from engine_harness import ROOT
from gltf_assets import iridescent, khronos_document, stand_in
from runtime_contract import runtime_table_files
from web_engines import GLTF_PACKAGES, require_package, serve_gltf_bake

from lutbake.lut.sample import Atlas
from lutbake.modes.runtime import read_runtime_table, runtime_colour
from lutbake.physics.points import FilmPoints

TOLERANCE = 1e-4
ASSET = "IridescenceSuzanne"
ROUTES = {  # glTF material index -> each part's route, served from the bake and with serve 'runtime'
    "bake": {0: {"dielectric": "slice"}, 1: {"metal": "slice"}, 2: {"dielectric": "runtime"}, 3: {"metal": "constant"}},
    "runtime": {
        0: {"dielectric": "runtime"},
        1: {"metal": "runtime"},
        2: {"dielectric": "runtime"},
        3: {"metal": "constant"},
    },
}


def _bake(doc, folder):
    """The asset ``doc``'s stand-in baked by `lutbake bake --gltf` into ``folder``: (glTF, output folder,
    manifest)."""
    gltf = stand_in(doc, folder, ASSET)
    out = folder / "out"
    cli = [sys.executable, "-m", "lutbake", "bake", "--gltf", str(gltf), "--out", str(out), "--route", "2=runtime"]
    proc = subprocess.run(cli, capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return gltf, out, json.loads((out / f"{ASSET}.json").read_text())


@pytest.fixture(scope="module")
def baked():
    """The asset baked into a folder the harness serves, with a fourth material, a vacuum film on a black metal
    (vacuum over vacuum under the fitted mapping): its part is the constant 0 (docs/gltf.md)."""
    folder = ROOT / "build" / f"web-bake-{uuid.uuid4().hex[:8]}"
    doc = khronos_document(ASSET)
    doc["materials"].append(iridescent(ior=1.0, metallic=1.0, colour=[0.0, 0.0, 0.0], name="black"))
    yield _bake(doc, folder)
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="module")
def renders(baked, tmp_path_factory):
    """render(engine, serve): the engine's cells for every iridescent material of the asset, served by
    ``serve`` (bake, runtime, or for PlayCanvas its own term), each rendered once."""
    gltf, out, _ = baked
    done = {}

    def render(engine, serve):
        if (engine, serve) not in done:
            folder = tmp_path_factory.mktemp(f"{engine}-{serve}")
            done[engine, serve] = serve_gltf_bake(engine, gltf, out / f"{ASSET}.json", serve, folder, size=48)
        return done[engine, serve]

    return render


@pytest.fixture(
    scope="module", params=[(engine, serve) for engine in sorted(GLTF_PACKAGES) for serve in sorted(ROUTES)]
)
def served(request, baked, renders):
    """The engine's render of every iridescent material of the asset, served by ``serve`` (bake or runtime)."""
    engine, serve = request.param
    _, out, manifest = baked
    return serve, renders(engine, serve), manifest, out, read_runtime_table(runtime_table_files())


def _expected(part, route, record, out, samples, table):
    """The manifest's model of one part at each sample's (cos θ, thickness nm)."""
    cos, thickness = samples[:, 3], samples[:, 4]
    n = len(samples)
    if route == "constant":
        return np.tile(np.asarray(part["constant"], float), (n, 1))
    if route == "runtime":
        eta3, kappa3 = (
            (np.full(3, part["base"][0]), np.full(3, part["base"][1]))
            if "base" in part
            else (np.asarray(part["eta3"]), np.asarray(part["kappa3"]))
        )
        film = np.full(n, record["film"])
        return runtime_colour(table, cos, thickness, 1.0, film, np.tile(eta3, (n, 1)), np.tile(kappa3, (n, 1)))
    names = [part["material"]] * 3 if "material" in part else part["channels"]
    atlas = Atlas.load(out / f"{ASSET}.exr")
    return np.stack(
        [
            atlas.sample(name, FilmPoints.build(**atlas.film_stack(name), cos_theta=cos, thickness_nm=thickness))[:, c]
            for c, name in enumerate(names)
        ],
        -1,
    )


def test_each_material_is_served_by_its_route_and_equals_the_manifests_model(served):
    serve, cells, manifest, out, table = served
    records = {r["gltf_index"]: r for r in manifest["source"]["materials"]}
    assert {cell["lutbake"]["gltfIndex"]: cell["lutbake"]["parts"] for cell in cells} == ROUTES[serve]
    for cell in cells:
        record = records[cell["lutbake"]["gltfIndex"]]
        samples = np.array(cell["samples"], float)
        assert len(samples) >= 250, (record["gltf_index"], len(samples))
        ((part_name, route),) = cell["lutbake"]["parts"].items()
        assert cell["metallic"] == (1 if part_name == "metal" else 0)
        expected = _expected(record["parts"][part_name], route, record, out, samples, table)
        error = np.abs(samples[:, :3] - expected).max()
        assert error <= TOLERANCE, (serve, record["gltf_index"], route, error)


def test_the_check_tells_the_materials_apart(served):
    """Each material's pixels are far from every other material's term (its film, base and route) at the
    same parameters: the comparison above can fail."""
    serve, cells, manifest, out, table = served
    records = {r["gltf_index"]: r for r in manifest["source"]["materials"]}
    for cell in cells:
        samples = np.array(cell["samples"], float)
        for other in cells:
            if other is cell:
                continue
            record = records[other["lutbake"]["gltfIndex"]]
            ((part_name, route),) = other["lutbake"]["parts"].items()
            wrong = _expected(record["parts"][part_name], route, record, out, samples, table)
            assert np.abs(samples[:, :3] - wrong).max() > 100 * TOLERANCE, (
                serve,
                cell["lutbake"],
                record["gltf_index"],
            )


TEXTURED = 2  # the glTF material whose film thickness is textured: 200-600 nm by the texture's G
THICKNESS_NM = (200.0, 600.0)
ROW_NM = (THICKNESS_NM[1] - THICKNESS_NM[0]) / 31  # the stand-in's 32-row gradient (G along v): one row's step


def _record(manifest, gltf_index):
    return next(r for r in manifest["source"]["materials"] if r["gltf_index"] == gltf_index)


def test_the_textured_thickness_is_read_per_pixel_and_the_check_sees_it(served):
    """Material 2's pixels read their thickness from its texture (spread over most of 200-600 nm; in
    PlayCanvas through lutbake's fix of its thickness map), and the 1e-4 check above would see a thickness
    read one texel row off: lutbake's model there is > 1e-3 from the engine's term at most pixels."""
    serve, cells, manifest, out, table = served
    cell = next(c for c in cells if c["lutbake"]["gltfIndex"] == TEXTURED)
    record = _record(manifest, TEXTURED)
    samples = np.array(cell["samples"], float)
    thickness = samples[:, 4]
    assert THICKNESS_NM[0] - 1e-3 <= thickness.min() and thickness.max() <= THICKNESS_NM[1] + 1e-3, thickness
    assert np.ptp(thickness) > 0.75 * (THICKNESS_NM[1] - THICKNESS_NM[0]), np.ptp(thickness)
    ((part_name, route),) = cell["lutbake"]["parts"].items()
    for step in (-ROW_NM, ROW_NM):
        shifted = samples.copy()
        shifted[:, 4] = np.clip(thickness + step, *THICKNESS_NM)
        wrong = _expected(record["parts"][part_name], route, record, out, shifted, table)
        off = np.abs(samples[:, :3] - wrong).max(-1)
        assert np.median(off) > 10 * TOLERANCE, (serve, step, np.median(off))


def test_stock_playcanvas_with_the_fix_reads_the_same_thickness(renders):
    """Stock PlayCanvas 2.23.3 does not compile a material with iridescenceThicknessMap (docs/engines.md);
    with fixIridescenceThicknessMap alone (`serve: 'playcanvas'`: its own term) every iridescent material
    renders the pixels lutbake's serving renders, at the same cos θ, film index and thickness (the textured
    material's read from its texture), with its own approximation's term, not lutbake's."""
    own, lutbake = renders("playcanvas", "playcanvas"), renders("playcanvas", "runtime")
    assert [cell["lutbake"] for cell in own] == [None] * len(lutbake) and len(lutbake) == len(ROUTES["runtime"])
    for stock, served in zip(own, lutbake):
        mine, theirs = np.array(stock["samples"], float), np.array(served["samples"], float)
        assert len(mine) >= 250 and mine.shape == theirs.shape, (served["lutbake"], mine.shape, theirs.shape)
        np.testing.assert_allclose(mine[:, 3:6], theirs[:, 3:6], rtol=1e-6, atol=1e-6)
        assert np.isfinite(mine[:, :3]).all()  # its own approximation: not bounded by 1 (it reaches 1.08 here)
        if served["lutbake"]["gltfIndex"] == TEXTURED:
            assert np.ptp(mine[:, 4]) > 0.75 * (THICKNESS_NM[1] - THICKNESS_NM[0]), np.ptp(mine[:, 4])
            assert np.abs(mine[:, :3] - theirs[:, :3]).max() > 0.01


THICKNESS_FIX_CASES = """
import * as pc from 'playcanvas';
import { fixIridescenceThicknessMap } from './lutbake-playcanvas.js';
const fixed = (declarations) => {
  const device = { on() {} };
  const chunks = pc.ShaderChunks.get(device, pc.SHADERLANGUAGE_GLSL);
  chunks.set('stdDeclarationPS', `#ifdef ${declarations}\nuniform sampler2D texture_iridescenceThicknessMap;\n#endif`);
  chunks.set('iridescenceThicknessPS', '// the device thickness chunk');
  const material = fixIridescenceThicknessMap(new pc.StandardMaterial(), device);
  return material.getShaderChunks(pc.SHADERLANGUAGE_GLSL).get('iridescenceThicknessPS') ?? null;
};
console.log(JSON.stringify({ version: pc.version, broken: fixed('STD_IRIDESCENCE_THICKNESS_TEXTURE_ALLOCATE'),
                             repaired: fixed('STD_IRIDESCENCETHICKNESS_TEXTURE_ALLOCATE') }));
"""


def test_the_thickness_fix_declares_the_sampler_once():
    """engine/lutbake-playcanvas.js fixIridescenceThicknessMap on devices with hand-made chunks (node, no
    browser): where the declarations chunk declares the sampler under the define nothing sets (PlayCanvas
    2.23.3), the material's thickness chunk is the device's preceded by the declaration under the define the
    material sets (unless the other is set); where they declare it under the define the material sets (a fixed
    PlayCanvas), the material's chunks are left alone."""
    require_package("playcanvas")
    cli = ["node", "--input-type=module", "-e", THICKNESS_FIX_CASES]
    proc = subprocess.run(cli, capture_output=True, text=True, cwd=ROOT / "engine", timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    got = json.loads(proc.stdout)
    assert got["version"] == "2.23.3"
    assert got["broken"] == (
        "#if defined(STD_IRIDESCENCETHICKNESS_TEXTURE_ALLOCATE)"
        " && !defined(STD_IRIDESCENCE_THICKNESS_TEXTURE_ALLOCATE)\n"
        "uniform sampler2D {STD_IRIDESCENCETHICKNESS_TEXTURE_NAME};\n#endif\n// the device thickness chunk"
    )
    assert got["repaired"] is None


ROUTE_CASES = """
import { bakeTerms, partRoutes } from './engine/lutbake-routes.js';
const bake = { stem: 'Scene', atlas: null, include: '', manifest: { scene_hash: 'ab'.repeat(32), materials: {
  s: { kind: 'slice' }, r: { kind: 'runtime' }, l: { kind: 'lut', file: 'l.exr' } }, metal_tables: {} },
  luts: { 'l.exr': { texture: 'the LUT texture', include: '// the LUT include', ident: 'LUTBAKE_L' } } };
const table = { f0: [0, 0.25, 0.5], eta3: [1, 1.25, 0.5], kappa3: [0, 1.5, 3] };
bake.manifest.metal_tables.fitted = table;   // a table at the manifest's top level, named by the part
const textured = { mapping: 'fitted', texture: true, table, channels: ['l', 'l', 'l'] };
const record = (parts) => ({ gltf_index: 7, name: 'Vase', film: 1.3, parts });
const cases = {
  slice: [{ dielectric: { material: 's', base: [1.5, 0] } }, true, 'bake'],
  handedOver: [{ dielectric: { material: 'r', base: [1.5, 0] } }, true, 'bake'],
  missing: [{ dielectric: { material: 'gone', base: [1.5, 0] } }, true, 'bake'],
  served: [{ dielectric: { material: 's', base: [1.5, 0] } }, true, 'runtime'],
  namedKept: [{ metal: { mapping: 'named', channels: ['s', 's', 's'] } }, true, 'runtime'],
  namedMissing: [{ metal: { mapping: 'named', channels: ['gone', 's', 's'] } }, true, 'bake'],
  noRuntime: [{ dielectric: { material: 'gone', base: [1.5, 0] } }, false, 'bake'],
  texturedLut: [{ metal: textured }, true, 'bake'],
  texturedRuntime: [{ metal: textured }, true, 'runtime'],
  texturedNamed: [{ metal: { ...textured, table: 'fitted' } }, true, 'bake'],
  texturedUnnamed: [{ metal: { ...textured, table: 'gone' } }, true, 'bake'],
};
const out = {};
for (const [name, [parts, runtime, serve]] of Object.entries(cases)) {
  try {
    const routes = partRoutes(bake, record(parts), { runtime, serve });
    const { terms, include, lut } = bakeTerms(bake, record(parts), routes);
    out[name] = { routes, terms, include, lut };
  } catch (e) { out[name] = { error: e.message }; }
}
const hostile = {  // manifest values that must not reach a shader's source
  filmNotANumber: [
    { ...record({ dielectric: { material: 'r', base: [1.5, 0] } }), film: '1.3); discard; (' }, 'runtime'],
  baseNotANumber: [record({ dielectric: { material: 'r', base: [1.5, null] } }), 'runtime'],
  oneNodeTable: [record({ metal: { ...textured, table: { f0: [0], eta3: [1], kappa3: [0] } } }), 'runtime'],
  unevenTable: [record({ metal: { ...textured, table: { ...table, kappa3: [0, 1.5] } } }), 'runtime'],
};
for (const [name, [rec, serve]] of Object.entries(hostile)) {
  try {
    bakeTerms(bake, rec, partRoutes(bake, rec, { runtime: true, serve }));
    out[name] = { error: null };
  } catch (e) { out[name] = { error: e.message }; }
}
console.log(JSON.stringify(out));
"""


def test_routes_follow_the_manifest_and_refuse_what_an_engine_cannot_serve():
    """engine/lutbake-routes.js on hand-made records (node, no browser): a slice where the manifest has one,
    the runtime table where the part's entry is handed over (`kind: "runtime"`) or absent or `serve` says so,
    a named metal kept baked; a texture-driven metal at the pixel's base colour through its F0 table (a constant
    array in the include, read between its nodes and clamped at its ends) and its 4D LUT per channel (bound as
    lutbakeLut) or the runtime table; a part that needs the table without one and a named metal the bake lacks
    are refused, naming the material; a manifest value that is not a finite number, or an F0 table of fewer
    than two nodes or uneven columns, is refused before it reaches a shader's source."""
    require_package("playcanvas")
    proc = subprocess.run(
        ["node", "--input-type=module", "-e", ROUTE_CASES], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    got = json.loads(proc.stdout)
    routes = {name: case.get("routes") for name, case in got.items()}
    assert routes["slice"] == {"dielectric": "slice"}
    assert (
        got["slice"]["terms"]["dielectric"]
        == "lutbake_atlas_sample(lutbakeAtlas, LUTBAKE_SCENE_S, cosTheta, thicknessNm)"
    )
    assert routes["handedOver"] == routes["missing"] == routes["served"] == {"dielectric": "runtime"}
    assert got["served"]["terms"]["dielectric"].startswith(
        "lutbake_iridescence(lutbakeTable, cosTheta, thicknessNm, 1.0, 1.3, 1.5, 0.0)"
    )
    assert routes["namedKept"] == {"metal": "slice"}
    for name, words in {
        "namedMissing": "named metal is not in the bake",
        "noRuntime": "dielectric part is not baked",
    }.items():
        assert "glTF material 7 'Vase'" in got[name].get("error", "") and words in got[name]["error"], (name, got[name])
    textured = "lutbakeTexturedMetal(lutbakeBaseColour, cosTheta, thicknessNm)"
    assert routes["texturedLut"] == {"metal": "lut"} and routes["texturedRuntime"] == {"metal": "runtime"}
    assert got["texturedLut"]["terms"]["metal"] == got["texturedRuntime"]["terms"]["metal"] == textured
    assert got["texturedLut"]["lut"] == "the LUT texture" and got["texturedRuntime"]["lut"] is None
    table = "vec2[3](\n  vec2(1.0, 0.0),\n  vec2(1.25, 1.5),\n  vec2(0.5, 3.0))"
    clamp = "clamp(f0 / 0.5, 0.0, 1.0) * 2.0"
    for name, reads in {
        "texturedLut": ["// the LUT include", "lutbake_sample(lutbakeLut, LUTBAKE_L, cosTheta, opd, g.x, g.y).g"],
        "texturedNamed": ["// the LUT include"],
        "texturedRuntime": [
            "lutbake_iridescence_rgb(lutbakeTable, cosTheta, thicknessNm, 1.0, 1.3, vec3(r.x, g.x, b.x)"
        ],
    }.items():
        for text in [table, clamp, *reads]:
            assert text in got[name]["include"], (name, text)
    assert "metal table 'gone' is not in the manifest's metal_tables" in got["texturedUnnamed"]["error"]
    assert got["filmNotANumber"]["error"] == 'manifest value "1.3); discard; (" is not a finite number'
    assert got["baseNotANumber"]["error"] == "manifest value null is not a finite number"
    for name in ("oneNodeTable", "unevenTable"):
        assert "must be arrays of at least 2 finite numbers, all of one length" in got[name]["error"], got[name]
