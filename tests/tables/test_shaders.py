"""The generated GLSL and HLSL includes compile (glslang, to SPIR-V), alone and several in one shader."""

import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import pytest
from shader_compile import ATLAS_CALL, GLSL_MAIN, HLSL_MAIN, LUT_CALL, compile_shader, validate_shader

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.lut.bake import bake
from lutbake.scene.bake import bake_scene
from lutbake.scene.toml import load_scene
from lutbake.tables.includes import warn_texture_size


def _wrapped(tmp_path, includes, call: str, hlsl: bool, version="#version 450\n") -> Path:
    main = (HLSL_MAIN if hlsl else GLSL_MAIN).replace("CALL", call)
    source = ("" if hlsl else version) + "".join(p.read_text() for p in includes) + main
    out = tmp_path / ("shader.hlsl" if hlsl else "shader.frag")
    out.write_text(source)
    return out


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shaders")
    axes = (
        Axis("cos_theta", 0.0, 1.0, 8, "sqrt"),
        Axis("opd_nm", 0.0, 1000.0, 8),
        Axis("eta3", 1.0, 2.0, 2),
        Axis("kappa3", 0.0, 1.0, 2, "sqrt"),
    )
    bake(BakeSpec(eta2=1.4, axes=axes), folder / "lut.exr")
    admittance = (*axes[:2], Axis("eta3", 1.0, 2.0, 3, "admittance"), axes[3])  # the other sampler path
    bake(BakeSpec(eta2=2.0, axes=admittance), folder / "2nd-lut.exr")
    scene = folder / "scene.toml"
    scene.write_text(
        textwrap.dedent("""
        [scene]
        max_de = 3.0
        [materials.film_a]
        film = 1.33
        thickness_nm = [200, 300]
        base = 1.0
        """)
    )
    bake_scene(load_scene(scene), folder / "scene")
    return folder


@pytest.mark.parametrize("hlsl", [False, True])
def test_lut_include_compiles(baked, tmp_path, hlsl):
    include = baked / ("lut.hlsl" if hlsl else "lut.glsl")
    out = compile_shader(_wrapped(tmp_path, [include], LUT_CALL[hlsl].format(ident="LUTBAKE_LUT"), hlsl), hlsl)
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.mark.parametrize("hlsl", [False, True])
def test_scene_atlas_include_compiles(baked, tmp_path, hlsl):
    include = baked / "scene" / ("scene.hlsl" if hlsl else "scene.glsl")
    call = ATLAS_CALL[hlsl].format(ident="LUTBAKE_SCENE_FILM_A")
    out = compile_shader(_wrapped(tmp_path, [include], call, hlsl), hlsl)
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.mark.parametrize("hlsl", [False, True])
@pytest.mark.parametrize("scanline0_at_v0", [None, "0", "1"])
def test_two_luts_and_an_atlas_compile_in_one_shader(baked, tmp_path, hlsl, scanline0_at_v0):
    suffix = "hlsl" if hlsl else "glsl"
    includes = [baked / f"lut.{suffix}", baked / f"2nd-lut.{suffix}", baked / "scene" / f"scene.{suffix}"]
    call = " + ".join(
        [
            LUT_CALL[hlsl].format(ident="LUTBAKE_LUT"),
            LUT_CALL[hlsl].format(ident="LUTBAKE_2ND_LUT"),
            ATLAS_CALL[hlsl].format(ident="LUTBAKE_SCENE_FILM_A"),
        ]
    )
    defines = [] if scanline0_at_v0 is None else [f"-DLUTBAKE_SCANLINE0_AT_V0={scanline0_at_v0}"]
    out = compile_shader(_wrapped(tmp_path, includes, call, hlsl), hlsl, defines)
    assert out.returncode == 0, out.stdout + out.stderr


def test_includes_compile_as_glsl_es_300_without_default_precision(baked, tmp_path):
    """WebGL2's language with no `precision` statement: every declaration in the includes carries its own."""
    includes = [baked / "lut.glsl", baked / "2nd-lut.glsl", baked / "scene" / "scene.glsl"]
    call = (
        LUT_CALL[False].format(ident="LUTBAKE_2ND_LUT") + " + " + ATLAS_CALL[False].format(ident="LUTBAKE_SCENE_FILM_A")
    )
    source = _wrapped(tmp_path, includes, call, False, "#version 300 es\n").read_text()
    source = source.replace("layout(binding = 0) ", "").replace("layout(binding = 1) ", "")
    es = tmp_path / "es.frag"
    es.write_text(source.replace("layout(location = 0) in", "in"))
    out = validate_shader(es)
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_compiler_rejects_a_broken_shader(tmp_path):
    bad = tmp_path / "bad.frag"
    bad.write_text("#version 450\nfloat broken( {\n")
    assert compile_shader(bad, hlsl=False).returncode != 0


def test_the_compiler_rejects_a_missing_precision_in_glsl_es(tmp_path):
    bad = tmp_path / "bad.frag"
    bad.write_text("#version 300 es\nfloat f(float x) { return x; }\nvoid main() {}\n")
    assert validate_shader(bad).returncode != 0


def test_includes_name_their_constants_per_lut(baked):
    text = (baked / "2nd-lut.glsl").read_text()
    assert "const LutbakeLut LUTBAKE_2ND_LUT = LutbakeLut(" in text
    assert text.rstrip().endswith("1.0, 2.0, 1.0);")  # eta1, eta2 and cubic (its interpolation) as constants
    assert "LUTBAKE_MIN" not in text  # no unprefixed global that a second include would redefine


def test_a_texture_larger_than_8192_warns():
    with pytest.warns(UserWarning, match="8192"):
        warn_texture_size(512, 8193, "big.exr")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_texture_size(8192, 8192, "ok.exr")


def test_bake_warns_above_8192_texels(tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "lutbake.cli",
            "bake",
            "--quiet",
            "--eta2",
            "1.4",
            "--cos-theta",
            "0:1:2",
            "--opd",
            "0:100:2",
            "--eta3",
            "1:2:4100",
            "--kappa3",
            "0:1:2",
            "--out",
            str(tmp_path / "wide.exr"),
        ],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    assert "8200×4 texels exceeds 8192" in out.stderr
