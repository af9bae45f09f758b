"""Texture-driven metals (a base colour texture on a metal: F0 per texel and channel) of a `lutbake bake --gltf`
output served in Babylon.js (engine/lutbake-babylon-gltf.js) and PlayCanvas (engine/lutbake-playcanvas.js), in
headless Chromium (WebGL2 on SwiftShader), as the three.js plugin serves them (tests/engines/test_gltf_engine.py).

The asset (IridescenceLamp, baked with `--route 2=bake`), its base colour texture of random and searched
colours and the model of a pixel are tests/web_metals.py's (bench/bench_web_engines.py metals prints the same
figures). At every pixel the engine's term must be lutbake's model at the parameters
and base colour the pixel used (bench_gltf_runtime.baked_term: the LUT read as `lutbake sample` reads it at
each channel's base from the F0 table, runtime.model per channel) to 1e-4; and against the spectral ground
truth the runtime table within its contract, the bake as lutbake's own samplers are. Both engines load the
same bake, its thickness textures included (PlayCanvas with lutbake's fixIridescenceThicknessMap).
The same bake runs bench/bench_web_engines.py gltf-cost's page end to end (tests/web_gltf_cost.py) on a tiny
render: what it captures and counts, not how long it takes.
"""

import re
import shutil
import uuid

import numpy as np
import pytest
from engine_harness import ROOT
from runtime_contract import CONTRACT_MAX, CONTRACT_P99
from web_engines import GLTF_PACKAGES
from web_gltf_cost import VARIANTS, hook_costs
from web_metals import ROUTES, bake_for_engines, metal_model, serve_metals, truth_errors

TOLERANCE = 1e-4
OWN_TERMS = {"babylon": "evalIridescence(", "playcanvas": "calcIridescence("}  # each engine's own film term
THICKNESS_SAMPLERS = {"babylon": "iridescenceThicknessSampler", "playcanvas": "texture_iridescenceThicknessMap"}
CUBIC_LUT_READS = 256  # texel reads of one cubic 4D LUT sample (the LUT include's lutbake_sample_cubic)


@pytest.fixture(scope="module")
def baked():
    """The asset baked into a folder the harness serves, by engine (tests/web_metals.py)."""
    folder = ROOT / "build" / f"web-metals-{uuid.uuid4().hex[:8]}"
    yield bake_for_engines(folder, sorted(GLTF_PACKAGES))
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="module", params=[(e, s) for e in sorted(GLTF_PACKAGES) for s in sorted(ROUTES)], ids="-".join)
def served(request, baked, tmp_path_factory):
    """The engine's render of both materials, served by ``serve``: (serve, cells, manifest, out, runtime
    table, {glTF index: rows in bench_gltf_runtime's columns})."""
    engine, serve = request.param
    folder = tmp_path_factory.mktemp(f"{engine}-{serve}")
    return serve, *serve_metals(engine, baked[engine], serve, folder, size=64)


def test_texture_driven_metals_equal_lutbakes_model_at_every_pixel(served):
    serve, cells, manifest, out, table, rows = served
    records = {r["gltf_index"]: r for r in manifest["source"]["materials"]}
    assert {cell["lutbake"]["gltfIndex"]: cell["lutbake"]["parts"] for cell in cells} == ROUTES[serve]
    for index, got in rows.items():
        metallic = got[:, 5]
        assert len(got) >= 500 and (metallic > 0.9).sum() > 100 and (metallic < 0.1).sum() > 50, (index, len(got))
        colours = got[metallic > 0, 7:10]
        assert (colours < 1e-6).any(0).all() and (colours > 0.99).any(0).all()  # the F0 table's ends are read
        error = np.abs(got[:, :3] - metal_model(serve, records[index], manifest, out, table, got)).max()
        assert error <= TOLERANCE, (serve, index, error)


def test_the_check_tells_base_colours_apart(served):
    """The same pixels against the model at the base colour's channels rotated: far off, so the comparison
    above reads each pixel's own base colour per channel."""
    serve, cells, manifest, out, table, rows = served
    records = {r["gltf_index"]: r for r in manifest["source"]["materials"]}
    for index, got in rows.items():
        wrong = got.copy()
        wrong[:, 7:10] = got[:, [8, 9, 7]]
        model = metal_model(serve, records[index], manifest, out, table, wrong)
        assert np.abs(got[:, :3] - model).max() > 100 * TOLERANCE


def test_texture_driven_metals_against_the_ground_truth(served):
    """ΔE00 against the spectral ground truth at the pixels' parameters: served by the runtime table within its
    contract; served by the bake, the error of lutbake's own samplers at the same pixels to 0.01 (the engine
    adds none; the pixels sit at the thickness range's end and the F0 table's ends and searched points, not
    where the bake scored its p99, so the figures, in docs/engines.md, may pass the bake's stated bound)."""
    serve, cells, manifest, out, table, rows = served
    records = {r["gltf_index"]: r for r in manifest["source"]["materials"]}
    for index, got in rows.items():
        de, own = truth_errors(serve, records[index], manifest, out, table, got, index)
        if serve == "runtime":
            assert np.percentile(de, 99) <= CONTRACT_P99 and de.max() <= CONTRACT_MAX, (index, de.max())
            continue
        assert np.abs(de - own).max() <= 0.01, (index, np.abs(de - own).max())


@pytest.mark.parametrize("engine", sorted(GLTF_PACKAGES))
def test_the_gltf_hook_cost_captures_and_counts_each_variants_shader(engine, baked, tmp_path):
    """The glTF-hook cost page on a 16² target, one round: per material the four variants are drawn and timed
    in one page; lutbake's (bake, runtime) shaders call lutbake's functions and say which routes served
    them, the engine's own (stock) calls its film term, the draw without a film neither; the films' shaders
    all sample the thickness texture (stock PlayCanvas with lutbake's fix of its thickness map); every shader
    compiles to SPIR-V with arithmetic and reads, and the forced 4D LUT's three cubic reads per channel are
    all counted (loops unrolled)."""
    costs = hook_costs(engine, baked[engine], tmp_path, size=16, rounds=1, draws=1)
    assert sorted(costs) == sorted(ROUTES["bake"])
    for index, variants in costs.items():
        assert tuple(variants) == VARIANTS, index
        for variant, cost in variants.items():
            served = variant in ROUTES
            assert bool(re.search(r"\blutbake\w*\(", cost["shader"])) == served, (index, variant)
            assert cost["routes"] == (ROUTES[variant][index] if served else None), (index, variant)
            assert cost["arithmetic"] > 0 and cost["texture_instructions"] > 0 and np.isfinite(cost["ms"])
        assert OWN_TERMS[engine] in variants["stock"]["shader"] and OWN_TERMS[engine] not in variants["none"]["shader"]
        for variant in ("stock", *ROUTES):  # the engine's own film and lutbake's read the same thickness textures
            assert THICKNESS_SAMPLERS[engine] in variants[variant]["shader"], (index, variant)
    assert costs[2]["bake"]["texture_instructions"] >= 3 * CUBIC_LUT_READS > costs[2]["runtime"]["texture_instructions"]
