"""The command line as a pipeline and a terminal use it (issue 15): strict JSON, pipes, stdin,
progress, refused flag conflicts, material names, and the batch `eval` paths."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import default_luts, node_parses

from lutbake.cli import cli
from lutbake.integrate.batch import fast_colours, truth_colours
from lutbake.io.strictjson import dumps
from lutbake.lut.bake import default_specs
from lutbake.physics.points import FilmPoints
from lutbake.quality.refine import tune
from lutbake.spectral.reference import reference_colour

ROOT = Path(__file__).resolve().parents[2]
TINY_AXES = ["--cos-theta", "0:1:4", "--opd", "0:600:6", "--eta3", "1:2:2", "--kappa3", "0:1:2"]


def run(*args, stdin=None, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "lutbake", *args], capture_output=True, text=True, input=stdin, cwd=cwd
    )


@pytest.fixture(scope="module")
def tiny_lut(tmp_path_factory):
    path = tmp_path_factory.mktemp("lut") / "tiny.exr"
    out = run("bake", "--eta2", "1.33", *TINY_AXES, "--out", str(path), "--quiet")
    assert out.returncode == 0, out.stderr
    return path


def test_strict_parser_rejects_nan_and_accepts_its_replacement():
    assert not node_parses(json.dumps({"a": float("nan")}))
    doc = json.loads(dumps({"a": float("nan"), "b": [np.float64("inf"), 1.5], "c": {"d": np.float64(2.0)}}))
    assert doc == {"a": None, "b": [None, 1.5], "c": {"d": 2.0}}


def test_every_json_output_parses_with_node(tiny_lut, tmp_path):
    commands = [
        ["eval", "--eta2", "1.33", "--thickness", "300", "--angle", "30", "--eta3", "1.5"],
        ["eval", "--eta2", "1.33", "--thickness", "300", "--angle", "30", "--eta3", "1.5", "--fast"],
        ["eval", "--eta2", "1.5", "--opd", "0", "--cos-theta", "1", "--eta3", "1.5", "--wavelength", "550"],
        ["inspect", str(tiny_lut)],
        ["sample", str(tiny_lut), "--angle", "30", "--thickness", "100", "--eta3", "1.2"],
        ["materials"],
        ["plan", "--scene", str(ROOT / "examples" / "soap-bubble.toml")],
        ["bake", "--eta2", "1.33", *TINY_AXES, "--out", str(tmp_path / "b.exr")],
        ["report", str(tiny_lut), "--points", "20", "--max-de", "1", "--search-budget", "200"],
        [
            "sweep",
            "--eta2",
            "1.33",
            *TINY_AXES,
            "--points",
            "10",
            "--out",
            str(tmp_path / "sweep"),
            "--search-budget",
            "200",
        ],
        ["tune", "--eta2", "1.33", *TINY_AXES, "--points", "10", "--max-de", "50", "--search-budget", "200"],
    ]  # and `check`: tests/quality/test_stability.py parses the one run of it the suite makes
    for args in commands:
        out = run(*args, "--json")
        assert out.returncode in (0, 1), (args, out.stderr)
        assert node_parses(out.stdout), (args, out.stdout[:500])
    # the sweep's LUT rows have no ns/eval: null in the printed and the written document
    sweep = json.loads((tmp_path / "sweep" / "sweep.json").read_text())
    assert node_parses((tmp_path / "sweep" / "sweep.json").read_text())
    assert any(r["ns_per_eval"] is None for r in sweep["rows"] if r["kind"] == "lut")
    assert sweep["point_kind"] == "uniform"


def test_closed_pipe_exits_0_without_a_traceback():
    proc = subprocess.Popen(
        [sys.executable, "-m", "lutbake", "inspect", str(default_luts() / "lutbake-eta2-1.33.exr")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # the reader is gone before the first write, as after `| head -1`
    assert proc.wait(timeout=120) == 0
    assert proc.stderr.read() == b""


def test_points_from_stdin_equal_points_from_a_file(tmp_path):
    csv = "eta2,thickness_nm,angle_deg,eta3,kappa3\n1.33,300,20,1.5,0\n2.0,120,60,2.5,3\n"
    (tmp_path / "p.csv").write_text(csv)
    from_file = run("eval", "--points", str(tmp_path / "p.csv"), "--json")
    from_stdin = run("eval", "--points", "-", "--json", stdin=csv)
    assert from_file.returncode == 0 and from_stdin.returncode == 0, from_stdin.stderr
    assert json.loads(from_stdin.stdout) == json.loads(from_file.stdout)


def test_python_dash_m_lutbake_runs_the_cli():
    out = run("--version")
    assert out.returncode == 0 and out.stdout.startswith("lutbake, version")


def test_materials_are_listed_and_found_in_any_case():
    listing = json.loads(run("materials", "--json").stdout)["materials"]
    names = {m["name"] for m in listing}
    assert {"Fe", "Cu", "water"} <= names
    assert "copper" in next(m for m in listing if m["name"] == "Cu")["aliases"]
    point = ["eval", "--eta2", "2.9", "--thickness", "40", "--angle", "30", "--json", "--base"]
    lower, canonical = run(*point, "cu"), run(*point, "Cu")
    assert lower.returncode == 0, lower.stderr
    assert json.loads(lower.stdout) == json.loads(canonical.stdout)


@pytest.mark.parametrize(
    "args, named",
    [
        (
            ["eval", "--eta2", "1.3", "--film", "water", "--thickness", "100", "--angle", "0", "--eta3", "1.5"],
            "--eta2 cannot be combined with --film",
        ),
        (
            ["eval", "--eta2", "1.3", "--thickness", "100", "--angle", "0", "--eta3", "1.5", "--base", "Fe"],
            "--eta3 cannot be combined with --base",
        ),
        (
            ["bake", "--scene", "examples/soap-bubble.toml", "--eta2", "1.3", "--out", "x"],
            "--eta2 cannot be combined with --scene",
        ),
        (
            ["bake", "--scene", "examples/soap-bubble.toml", "--opd", "0:100:8", "--out", "x"],
            "--opd cannot be combined with --scene",
        ),
        (["bake", "--eta2", "1.3", "--force", "--out", "x.exr"], "--force applies to --scene"),
        (["bake", "--base", "Cu"], "lutbake bake --scene"),
        (["bake", "--quiet", "--progress", "--eta2", "1.3", "--out", "x.exr"], "--quiet and --progress"),
        (
            [
                "eval",
                "--eta2",
                "1.3",
                "--thickness",
                "1",
                "--angle",
                "0",
                "--eta3",
                "1",
                "--fast",
                "--wavelength",
                "500",
            ],
            "--fast",
        ),
    ],
)
def test_conflicting_flags_are_refused_with_one_line(tmp_path, args, named):
    out = run(*args, cwd=ROOT)
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and named in lines[0], lines
    assert out.stdout == "" and not (ROOT / "x").exists() and not (ROOT / "x.exr").exists()


def test_sample_does_not_advertise_named_materials():
    assert "--base" not in run("sample", "--help").stdout


def test_every_option_has_help_text():
    missing = [
        f"{name} {p.opts[0]}"
        for name, cmd in cli.commands.items()
        for p in cmd.params
        if p.param_type_name == "option" and not p.hidden and not p.help
    ]
    assert missing == []


def test_bake_progress_advances_band_by_band(tmp_path):
    out = run(
        "bake",
        "--eta2",
        "1.33",
        "--cos-theta",
        "0:1:8",
        "--opd",
        "0:3000:64",
        "--eta3",
        "1:3:4",
        "--kappa3",
        "0:5:4",
        "--out",
        str(tmp_path / "p.exr"),
        "--progress",
    )
    assert out.returncode == 0, out.stderr
    counts = [int(line.split("] ")[1].split("/")[0]) for line in out.stderr.splitlines() if "] " in line]
    assert counts[0] == 0 and counts[-1] == 256
    assert any(0 < c < 256 for c in counts), out.stderr  # a band in between, not a jump 0 → 100 %
    assert counts == sorted(counts)


def test_progress_is_off_on_a_pipe_unless_asked(tmp_path):
    out = run("bake", "--eta2", "1.33", *TINY_AXES, "--out", str(tmp_path / "q.exr"))
    assert out.returncode == 0 and out.stderr == ""


def test_tune_reports_each_round_as_it_is_accepted():
    spec = default_specs("float")["lutbake-eta2-1.33"]
    seen = []
    result = tune(spec, 50.0, n_points=10, seed=0, max_rounds=1, on_round=seen.append)
    assert seen == result.rounds and len(seen) >= 1


def test_report_says_which_points_it_scores_and_shows_the_gate(tiny_lut):
    """On the terminal; the HTML report's gate and film line: tests/quality/test_report.py (it draws the figures,
    the slow part, once)."""
    out = run("report", str(tiny_lut), "--points", "20", "--max-de", "0.001", "--no-approximations")
    assert out.returncode == 1
    assert "(10 cell-centre + 10 uniform)" in out.stdout
    assert out.stdout.splitlines()[-1].startswith("gate p99 ΔE00 ") and out.stdout.endswith(" > 0.001: FAIL\n")


def _random_points(rng, n):
    return FilmPoints.build(
        eta2=rng.choice([1.33, 2.0], n),
        thickness_nm=rng.uniform(0, 1500, n),
        cos_theta=rng.uniform(0, 1, n),
        eta3=rng.uniform(1, 3, n),
        kappa3=rng.uniform(0, 5, n),
    )


def test_fast_batch_path_matches_the_per_point_ground_truth(rng):
    pts = _random_points(rng, 300)
    rgb, xyz, bound = fast_colours(pts, "cie1931", "rec709")
    assert np.all(bound == 0)
    assert np.max(np.abs(rgb - reference_colour(pts).values)) <= 3e-6
    assert np.max(np.abs(xyz - reference_colour(pts, basis="xyz").values)) <= 3e-6


def test_one_pass_truth_matches_the_two_separate_integrals(rng):
    pts = _random_points(rng, 200)
    rgb, xyz = truth_colours(pts, "cie1931", "acescg")
    assert np.max(np.abs(rgb - reference_colour(pts, "cie1931", "acescg").values)) <= 1e-9
    assert np.max(np.abs(xyz - reference_colour(pts, "cie1931", "acescg", "xyz").values)) <= 1e-9


def test_fast_path_refuses_named_materials():
    pts = FilmPoints.build(eta2=1.33, thickness_nm=100, cos_theta=1.0, base="Fe")
    with pytest.raises(ValueError, match="^fast takes constant indices"):
        fast_colours(pts, "cie1931", "rec709")
