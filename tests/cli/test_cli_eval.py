"""`lutbake eval`: the command-line contract (JSON, CSV, exit codes, one-line errors)."""

import json
import subprocess
import sys

import numpy as np
import pytest

from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "lutbake.cli", *args], capture_output=True, text=True, cwd=cwd)


def test_eval_json_matches_the_library():
    out = run("eval", "--eta2", "1.33", "--thickness", "300", "--angle", "30", "--eta3", "1.0", "--json")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    pts = FilmPoints.build(eta2=1.33, thickness_nm=300, angle_deg=30, eta3=1.0)
    assert np.allclose(doc["points"][0]["rgb"], reference_colour(pts).values[0], atol=1e-12)
    assert doc["space"] == "rec709" and doc["observer"] == "cie1931"


def test_eval_at_one_wavelength_gives_fresnel_for_bare_glass():
    out = run(
        "eval", "--eta2", "1.5", "--opd", "0", "--cos-theta", "1", "--eta3", "1.5", "--wavelength", "550", "--json"
    )
    row = json.loads(out.stdout)["points"][0]
    assert row["R"] == pytest.approx(0.04, abs=1e-15) and row["Rs"] == pytest.approx(row["Rp"])


def test_eval_points_csv(tmp_path):
    csv = tmp_path / "p.csv"
    csv.write_text("eta2,opd_nm,cos_theta,eta3,kappa3\n1.5,0,1,1.5,0\n2.9,232,0.8,2.7,2.8\n")
    out = run("eval", "--points", str(csv), "--space", "acescg", "--json")
    assert out.returncode == 0, out.stderr
    rows = json.loads(out.stdout)["points"]
    assert len(rows) == 2 and np.allclose(rows[0]["rgb"], 0.04, atol=1e-6)
    assert rows[1]["thickness_nm"] == pytest.approx(40.0)


def test_named_materials_on_the_command_line():
    out = run("eval", "--eta2", "2.9", "--thickness", "40", "--cos-theta", "0.8", "--base", "Fe", "--json")
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["points"][0]["base"] == "Fe"


@pytest.mark.parametrize(
    "args, named",
    [
        (["--eta2", "0", "--thickness", "1", "--cos-theta", "1", "--eta3", "1"], "eta2 = 0.0"),
        (["--eta2", "1.5", "--thickness", "1", "--cos-theta", "1", "--eta3", "1", "--kappa3", "-0.1"], "kappa3 = -0.1"),
        (["--eta2", "1.5", "--thickness", "-5", "--cos-theta", "1", "--eta3", "1"], "thickness_nm = -5.0"),
        (["--eta2", "1.5", "--thickness", "5", "--cos-theta", "1.5", "--eta3", "1"], "cos_theta = 1.5"),
        (["--eta2", "nan", "--thickness", "5", "--cos-theta", "1", "--eta3", "1"], "eta2 = nan"),
        (["--eta2", "1.5", "--thickness", "5", "--cos-theta", "1", "--base", "unobtainium"], "unobtainium"),
        (
            ["--eta2", "1.5", "--thickness", "5", "--cos-theta", "1", "--eta3", "1", "--wavelength", "900"],
            "wavelength_nm",
        ),
        (["--eta2", "1.5", "--cos-theta", "1", "--eta3", "1"], "thickness_nm or opd_nm"),
        (["--eta2", "1.5", "--thickness", "5", "--cos-theta", "1", "--eta3", "1", "--space", "srgb"], "--space"),
    ],
)
def test_bad_input_exits_2_with_one_line(args, named):
    out = run("eval", *args)
    assert out.returncode == 2
    assert out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and named in lines[0]


@pytest.mark.parametrize(
    "text, named",
    [
        ("eta2,opd_nm,cos_theta,eta3\n1.5,0,1\n", "line 2 has 3 fields"),
        ("eta2,opd_nm,cos_theta,eta3\n1.5,zero,1,1\n", "opd_nm = 'zero'"),
        ("eta2,opd_nm,cosine,eta3\n1.5,0,1,1\n", "column 'cosine'"),
        ("eta2,opd_nm,cos_theta,eta3\n", "at least one data row"),
    ],
)
def test_malformed_csv_exits_2(tmp_path, text, named):
    csv = tmp_path / "bad.csv"
    csv.write_text(text)
    out = run("eval", "--points", str(csv))
    assert out.returncode == 2 and named in out.stderr and len(out.stderr.strip().splitlines()) == 1


def test_python_api_raises_value_error():
    with pytest.raises(ValueError, match="kappa3"):
        FilmPoints.build(eta2=1.5, thickness_nm=1, cos_theta=1, eta3=1, kappa3=-1)
