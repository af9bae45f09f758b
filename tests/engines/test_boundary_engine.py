"""The documented domain's boundary in a real engine: three.js (headless Chromium, SwiftShader) runs the shipped
exact-mode and runtime includes, unmodified, on every combination of the boundary values (cos θ1 = 0, η2 = η1,
η3 = η1, D = 0, κ3 = 0) with values just inside it and beyond the η2 ≈ η3 ≈ η1 ridge, for an ambient of index 1
and 2. No channel may be NaN or Inf; each must be the float64 evaluation of the same math (exact.exact_colour,
runtime.runtime_colour) and meet its bound against the ground truth, which at cos θ1 = 0 is white (r12 = −1,
physics/optics.py). Before the include resolved a = (Y1 − Y2)/(Y1 + Y2) at Y1 = Y2 = 0, the exact mode
returned NaN at every point with cos θ1 = 0 and η2 = η1. The exact mode's and the runtime table's OSL scripts
run the same points in Cycles (tests/engines/osl_points.py: a Script node fed constants, which the probe rig's
tilted planes cannot do at cos θ1 = 0); there the old exact script's NaN came out black."""

import itertools
import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from engine_harness import ROOT, require_engine, run_jobs
from runtime_contract import CONTRACT_MAX, make_dropin, runtime_table_files

from lutbake.blender.library import osl_script
from lutbake.modes.exact import exact_colour, read_exact_table
from lutbake.modes.runtime import read_runtime_table, runtime_colour
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour

# Each boundary as a predicate on the columns (cos, d, η1, η2, η3, κ3).
BOUNDARIES = {
    "cos theta1 = 0": lambda p: p[0] == 0,
    "eta2 = eta1": lambda p: p[3] == p[2],
    "eta3 = eta1": lambda p: p[4] == p[2],
    "D = 0": lambda p: p[1] == 0,
    "kappa3 = 0": lambda p: p[5] == 0,
}
EXACT_CALLS = {  # η1 from p.w
    "exact": "lutbake_exact(lut, p.x, p.y, p.w, p.z, q.x, r.x)",
    "exact rgb": "lutbake_exact_rgb(lut, p.x, p.y, p.w, p.z, q.xyz, r.xyz)",
}
RUNTIME_CALLS = {
    "runtime": "lutbake_iridescence(lut, p.x, p.y, p.w, p.z, q.x, r.x)",
    "runtime rgb": "lutbake_iridescence_rgb(lut, p.x, p.y, p.w, p.z, q.xyz, r.xyz)",
}
MODEL_TOLERANCE = 1e-4  # float32 include against the float64 math (tests/engines/test_exact_engine.py)
# Against the ground truth: the exact mode's bound near its corner (test_exact_engine.py), the runtime contract.
TRUTH_BOUND = {"exact": 0.3, "runtime": CONTRACT_MAX}


def boundary_points(ambients) -> np.ndarray:
    """(6, n): cos θ1, d nm, η1, η2, η3, κ3 over every combination of the boundary values and values just
    inside (cos 1e-6, the ridge's cos 0.0212, normal incidence; η 1.0226 η1, the issue's ridge), float32."""
    rows = []
    for eta1 in ambients:
        grid = itertools.product(
            (0.0, 1e-6, 0.0212, 1.0), (0.0, 659.0, 1500.0), (1.0, 1.0226, 2.0), (1.0, 1.0226, 2.0), (0.0, 1.477)
        )
        rows += [(c, d, eta1, eta1 * e2, eta1 * e3, k3) for c, d, e2, e3, k3 in grid]
    return np.float32(np.array(rows).T).astype(float)


def _by_film(points, fn):
    """fn(rows, η1, η2) per film index pair (the float64 evaluation and the truth take scalars there)."""
    out = np.empty((points.shape[1], 3))
    for eta1, eta2 in {(a, b) for a, b in zip(points[2], points[3])}:
        at = (points[2] == eta1) & (points[3] == eta2)
        out[at] = fn(points[:, at], eta1, eta2)
    return out


def _truth(p, eta1, eta2):
    stack = FilmPoints.build(eta1=eta1, eta2=eta2, cos_theta=p[0], thickness_nm=p[1], eta3=p[4], kappa3=p[5])
    return reference_colour(stack).values


@pytest.fixture(scope="module")
def boundary_run(tmp_path_factory):
    """{call: (points, engine RGB, float64 RGB, ground truth)}: the exact mode under ambients of index 1 and 2,
    the runtime table under its documented ambient, 1 (its X range is η2 ≤ 3 at d ≤ 1500 nm)."""
    require_engine()
    exact, runtime = make_dropin.write_exact_table(), runtime_table_files()
    exact_table, runtime_table = read_exact_table(exact), read_runtime_table(runtime)
    paths = {
        "exact": (exact, boundary_points((1.0, 2.0))),
        "runtime": (runtime, boundary_points((1.0,))),
    }
    model = {
        "exact": lambda p: _by_film(
            p, lambda q, e1, e2: exact_colour(exact_table, q[0], q[1], e1, e2, q[4], q[5]).values
        ),
        "runtime": lambda p: runtime_colour(runtime_table, *p),
    }
    jobs = {}
    for name, call in {**EXACT_CALLS, **RUNTIME_CALLS}.items():
        path, points = paths[name.split()[0]]
        rows = [[c, d, e2, e1, e3, e3, e3, 0.0, k3, k3, k3, 0.0] for c, d, e1, e2, e3, k3 in points.T]
        files = {"exr": f"/{path.relative_to(ROOT)}", "include": f"/{path.with_suffix('.glsl').relative_to(ROOT)}"}
        jobs[name] = {**files, "float": path == exact, "call": call, "points": rows}
    got = run_jobs(tmp_path_factory.mktemp("boundary"), jobs)
    out = {}
    for kind, (_, points) in paths.items():
        expected, truth = model[kind](points), _by_film(points, _truth)
        for name in (kind, f"{kind} rgb"):
            out[name] = (points, np.array(got[name]["rgb"], float), expected, truth)
    return out


@pytest.mark.parametrize("boundary", sorted(BOUNDARIES))
@pytest.mark.parametrize("call", sorted({**EXACT_CALLS, **RUNTIME_CALLS}))
def test_the_boundary_is_finite_the_model_and_the_truth(boundary_run, boundary, call):
    points, got, model, truth = boundary_run[call]
    on = BOUNDARIES[boundary](points)
    got, model, truth = got[on], model[on], truth[on]
    assert on.sum() >= 54
    assert np.isfinite(got).all(), f"{(~np.isfinite(got).all(axis=1)).sum()} of {on.sum()} points not finite"
    assert np.abs(got - model).max() <= MODEL_TOLERANCE
    assert delta_e00(got, truth).max() <= TRUTH_BOUND[call.split()[0]]


def test_grazing_incidence_is_white_in_every_path(boundary_run):
    """cos θ1 = 0: the ground truth is Ŵ(0) (white) for every stack; so are both includes."""
    for points, got, _, truth in boundary_run.values():
        grazing = points[0] == 0
        white = truth[grazing][0]
        assert np.abs(truth[grazing] - white).max() <= 1e-12 and white.min() > 0.9
        assert np.abs(got[grazing] - white).max() <= 1e-3


@pytest.fixture(scope="module", params=["exact", "runtime"])
def osl_run(request, tmp_path_factory):
    """(kind, points, Cycles RGB, float64 RGB, ground truth): the exact mode's OSL script at boundary_points under
    ambients 1 and 2, the runtime table's under 1 (as boundary_run)."""
    from blender_harness import blender_python

    kind = request.param
    if kind == "exact":
        path, points = make_dropin.write_exact_table(), boundary_points((1.0, 2.0))
        table = read_exact_table(path)
        model = _by_film(points, lambda q, e1, e2: exact_colour(table, q[0], q[1], e1, e2, q[4], q[5]).values)
    else:
        path, points = runtime_table_files(), boundary_points((1.0,))
        model = runtime_colour(read_runtime_table(path), *points)
    folder = tmp_path_factory.mktemp(f"osl-boundary-{kind}")
    (folder / "job.json").write_text(json.dumps({"osl": osl_script(kind, path), "points": points.T.tolist()}))
    proc = subprocess.run(
        [
            blender_python(),
            str(Path(__file__).with_name("osl_points.py")),
            *(str(folder / f) for f in ("job.json", "result.json")),
        ],
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    got = np.array(json.loads((folder / "result.json").read_text())["rgb"], float)
    return kind, points, got, model, _by_film(points, _truth)


@pytest.mark.parametrize("boundary", sorted(BOUNDARIES))
def test_the_osl_script_on_the_boundary_is_finite_the_model_and_the_truth(osl_run, boundary):
    """The exact mode's and the runtime table's OSL scripts in Cycles: finite, the float64 model, the bound."""
    kind, points, got, model, truth = osl_run
    on = BOUNDARIES[boundary](points)
    assert on.sum() >= {"exact": 96, "runtime": 54}[kind] and np.isfinite(got[on]).all()
    assert np.abs(got[on] - model[on]).max() <= MODEL_TOLERANCE
    assert delta_e00(got[on], truth[on]).max() <= TRUTH_BOUND[kind]
