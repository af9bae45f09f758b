"""A real engine samples what lutbake writes: three.js (pinned in engine/package-lock.json) in headless
Chromium loads every shipped LUT and a shipped scene atlas with EXRLoader's default settings, evaluates the
shipped GLSL includes, unmodified, at random points (domain edges and points outside the domain included)
into a float render target, and must return what `lutbake sample` says to 1e-4 (engine/page.js,
engine/harness.mjs): by each LUT's own rule (cubic for the default set: texel reads) and by the forced
linear rule (bilinear fetches; SwiftShader's filtering differs from exact bilinear by ~1e-5)."""

import csv
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import default_luts
from engine_harness import ENGINE, ROOT, require_engine, run_harness

from lutbake.io.names import shader_identifier as shader_ident
from lutbake.lut.bake import default_specs
from lutbake.lut.sample import load_table

sys.path.insert(0, str(ROOT / "docs"))
from make_scene_examples import bake_example  # noqa: E402

LUT_NAMES = sorted(default_specs())  # the default set, baked into luts/ (conftest.default_luts)
KAPPA3_TILED = "lutbake-eta2-2.00-metal"  # format v6: its tiles run along x by κ3 (test_default_luts)
ATLAS = ROOT / "docs" / "scenes" / "tempered-steel" / "tempered-steel.exr"  # baked by engine_run, not committed
TOLERANCE = 1e-4
POINTS = 2500
EDGE, OUTSIDE = 0.2, 0.2  # fractions of coordinates at a domain edge, and outside the domain


def _coordinates(rng, lo, hi, n, floor=None, ceil=None):
    """Uniform in [lo, hi]; EDGE of them exactly lo or hi; OUTSIDE of them up to 20% beyond (kept physical)."""
    v = rng.uniform(lo, hi, n)
    kind = rng.random(n)
    edge = kind < EDGE
    v[edge] = np.where(rng.random(edge.sum()) < 0.5, lo, hi)
    out = (kind >= EDGE) & (kind < EDGE + OUTSIDE)
    span = hi - lo
    v[out] = np.where(
        rng.random(out.sum()) < 0.5,
        lo - rng.uniform(0, 0.2 * span, out.sum()),
        hi + rng.uniform(0, 0.2 * span, out.sum()),
    )
    return np.clip(v, floor, ceil)


def _into_the_corner(columns: dict, rng, share: float = 0.25) -> None:
    """A ``share`` of the points moved next to the grazing corner a zoomed LUT resolves (cos θ1 1e-6–1e-2,
    D, η3 − 1 and κ3 at ratios 1e-2–1e2 to cos θ1, cos² θ1, or exactly 0), as float32 values, so the
    shader reads the very inputs `lutbake sample` does (η3 − 1 below float32's spacing would not be)."""
    n = columns["cos_theta"].size
    pick = rng.random(n) < share
    k = int(pick.sum())
    c = 10 ** rng.uniform(-6, -2, k)
    ratio = [np.where(rng.random(k) < 0.2, 0.0, 10 ** rng.uniform(-2, 2, k)) for _ in range(3)]
    moved = {"cos_theta": c, "opd_nm": ratio[0] * 30.0 * c, "eta3": 1.0 + ratio[1] * c * c, "kappa3": ratio[2] * c * c}
    for name, values in moved.items():
        columns[name][pick] = values.astype(np.float32).astype(float)


def lutbake_sample(folder: Path, path: Path, columns: dict, *args) -> list:
    """`lutbake sample PATH --points CSV --json` rows, run as a user would."""
    text = io.StringIO()
    writer = csv.writer(text)
    writer.writerow(columns)
    writer.writerows(zip(*(map(repr, map(float, c)) for c in columns.values())))
    points = folder / "points.csv"
    points.write_text(text.getvalue())
    out = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "sample", str(path), "--points", str(points), "--json", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)["points"]


def lut_job(folder: Path, path: Path, rng, interpolation=None) -> dict:
    """Points sampled by `lutbake sample` (by the header's rule, or ``interpolation``) and the include's
    matching call: lutbake_sample, or lutbake_sample_<interpolation>."""
    axes = load_table(path).axes
    limits = [(0.0, 1.0), (0.0, None), (0.01, None), (0.0, None)]  # η3 ≥ 0.01: what `sample` accepts
    columns = {
        name: _coordinates(rng, a.lo, a.hi, POINTS, *lim)
        for name, a, lim in zip(("cos_theta", "opd_nm", "eta3", "kappa3"), axes, limits)
    }
    if any(a.corner for a in axes):
        _into_the_corner(columns, rng)
    rows = lutbake_sample(folder, path, columns, *(["--interpolation", interpolation] if interpolation else []))
    function = f"lutbake_sample_{interpolation}" if interpolation else "lutbake_sample"
    return {
        "exr": f"/{path.relative_to(ROOT)}",
        "include": f"/{path.with_suffix('.glsl').relative_to(ROOT)}",
        "call": f"{function}(lut, {shader_ident(path.stem)}, p.x, p.y, p.z, p.w)",
        "points": [[r["cos_theta"], r["opd_nm"], r["eta3"], r["kappa3"]] for r in rows],
        "expected": [r["rgb"] for r in rows],
        "in_domain": [r["in_domain"] for r in rows],
    }


def atlas_job(folder: Path, path: Path, material: str, rng) -> dict:
    th = load_table(path).slice_of(material)["axes"]["thickness_nm"]
    columns = {
        "cos_theta": _coordinates(rng, 0.0, 1.0, POINTS, 0.0, 1.0),
        "thickness_nm": _coordinates(rng, th["min"], th["max"], POINTS, 0.0),
    }
    rows = lutbake_sample(folder, path, columns, "--material", material)
    ident = shader_ident(f"{path.stem}_{material}")
    return {
        "exr": f"/{path.relative_to(ROOT)}",
        "include": f"/{path.with_suffix('.glsl').relative_to(ROOT)}",
        "call": f"lutbake_atlas_sample(lut, {ident}, p.x, p.y)",
        "points": [[r["cos_theta"], r["thickness_nm"], 0.0, 0.0] for r in rows],
        "expected": [r["rgb"] for r in rows],
        "in_domain": [r["in_domain"] for r in rows],
    }


def together(job: dict, other_lut: Path) -> dict:
    """``job`` with another LUT's and the atlas's includes in the same shader, all three samplers called
    (the others weighted 0 on this job's texture): WebGL2 compiles them together, the result is unchanged."""
    other = shader_ident(other_lut.stem)
    atlas_ident = shader_ident(f"{ATLAS.stem}_{next(iter(load_table(ATLAS).materials))}")
    return {
        **job,
        "include": [
            job["include"],
            f"/{other_lut.with_suffix('.glsl').relative_to(ROOT)}",
            f"/{ATLAS.with_suffix('.glsl').relative_to(ROOT)}",
        ],
        "call": f"{job['call']} + 0.0 * lutbake_sample(lut, {other}, p.x, p.y, p.z, p.w)"
        f" + 0.0 * lutbake_atlas_sample(lut, {atlas_ident}, p.x, p.y)",
    }


@pytest.fixture(scope="module")
def engine_run(tmp_path_factory):
    require_engine()
    bake_example(ATLAS.stem)  # docs/scenes is baked, not kept in the repository (docs/design-notes.md#determinism)
    folder = tmp_path_factory.mktemp("engine")
    rng = np.random.default_rng(10)
    luts = [default_luts() / f"{name}.exr" for name in LUT_NAMES]
    jobs = {p.stem: lut_job(folder, p, rng) for p in luts}
    jobs.update({f"{ATLAS.stem}:{m}": atlas_job(folder, ATLAS, m, rng) for m in load_table(ATLAS).materials})
    # Negative control: the same LUT with the other row order must be far off, so the check can fail.
    first = jobs[luts[0].stem]
    jobs["one shader: two LUT includes and an atlas include"] = together(first, luts[1])
    jobs["control: scanline 0 at v = 0"] = {**first, "prelude": "#define LUTBAKE_SCANLINE0_AT_V0 1"}
    # The default LUTs are read cubic; the 4-fetch linear rule stays callable and must match too, and
    # reading them linearly must miss the cubic expectation (the cubic path is what the jobs above check).
    jobs["linear reads"] = lut_job(folder, luts[1], rng, "linear")
    jobs["linear reads, tiles along x by κ3"] = lut_job(folder, default_luts() / f"{KAPPA3_TILED}.exr", rng, "linear")
    jobs["control: linear reads of a cubic LUT"] = {
        **first,
        "call": first["call"].replace("lutbake_sample(", "lutbake_sample_linear("),
    }
    sent = [{k: v for k, v in j.items() if k not in ("expected", "in_domain")} for j in jobs.values()]
    result = run_harness("evaluate", folder, sent, timeout=300)
    return result, dict(zip(jobs, zip(jobs.values(), result["results"])))


def _max_error(job, got) -> float:
    return float(np.abs(np.array(got["rgb"]) - np.array(job["expected"])).max())


def test_the_engine_is_three_js_with_default_exr_loader_settings(engine_run):
    result, runs = engine_run
    assert result["three"] == json.loads((ENGINE / "package.json").read_text())["dependencies"]["three"].split(".")[1]
    for _job, got in runs.values():
        assert got["texture"]["flipY"] is False  # EXRLoader's default: rows bottom-up, as OpenGL reads them


@pytest.mark.parametrize(
    "name",
    LUT_NAMES
    + [
        "tempered-steel:steel_constant",
        "tempered-steel:steel_werner",
        "one shader: two LUT includes and an atlas include",
        "linear reads",
        "linear reads, tiles along x by κ3",
    ],
)
def test_engine_matches_lutbake_sample(engine_run, name):
    _, runs = engine_run
    job, got = runs[name]
    inside = np.array(job["in_domain"])
    assert len(job["points"]) >= 2000 and 0.2 < inside.mean() < 0.9  # edges and outside points included
    assert _max_error(job, got) <= TOLERANCE


def test_the_check_fails_with_the_other_row_order(engine_run):
    _, runs = engine_run
    assert _max_error(*runs["control: scanline 0 at v = 0"]) > 0.1


def test_the_check_tells_cubic_from_linear_reads(engine_run):
    _, runs = engine_run
    assert load_table(default_luts() / f"{LUT_NAMES[0]}.exr").interpolation == "cubic"
    assert _max_error(*runs["control: linear reads of a cubic LUT"]) > 30 * TOLERANCE


def test_docs_show_the_helper_the_test_runs():
    """docs/engines.md's three.js snippet is engine/page.js's helper verbatim."""
    page = (ENGINE / "page.js").read_text()
    begin, end = "// --- docs/engines.md snippet: begin\n", "// --- docs/engines.md snippet: end"
    snippet = page[page.index(begin) + len(begin) : page.index(end)]
    assert "function lutbakeMaterial(" in snippet
    assert snippet in (ROOT / "docs" / "engines.md").read_text()
