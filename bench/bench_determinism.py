"""How far two machines' files can differ: the same sets written with two OpenBLAS kernels on this machine.

    python bench/bench_determinism.py [--json bench/determinism-result.json]

OpenBLAS picks a kernel per CPU (SSE3 … AVX-512) that sums in its own order; `OPENBLAS_CORETYPE=Prescott`
forces its SSE3 kernel, which any x86-64 CPU runs, so one machine shows what two would write. Each run
gets a fresh user cache (its colour and transform tables are BLAS results too). Written both ways: the
exact table (`lutbake exact-table`) and the default LUT lutbake-eta2-1.50. Reported per set: whether the
bytes are equal, texels that differ and the largest difference in units in the last place, and the
largest difference of a header number relative to max(|a|, |b|, 1) (docs/design-notes.md#determinism
states the contract: 1 ULP and 1e-12).
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
KERNELS = {"chosen for this CPU": {}, "SSE3 (Prescott)": {"OPENBLAS_CORETYPE": "Prescott"}}
DEFAULT_LUT = (
    "import sys; from lutbake.lut.bake import default_specs, bake; "
    "bake(default_specs()['lutbake-eta2-1.50'], sys.argv[1])"
)
SETS = {"exact table": ["-m", "lutbake", "exact-table", "--out"], "lutbake-eta2-1.50": ["-c", DEFAULT_LUT]}


def write(args, out: Path, env: dict) -> None:
    subprocess.run(
        [sys.executable, *args, str(out)],
        check=True,
        capture_output=True,
        cwd=ROOT,
        env={**os.environ, **env, "PYTHONPATH": str(ROOT)},
    )


def header_numbers(a, b, path="") -> list:
    """(path, relative difference) of every number that differs between two JSON documents."""
    if isinstance(a, dict):
        return [d for k in a for d in header_numbers(a[k], b[k], f"{path}.{k}")]
    if isinstance(a, list):
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in header_numbers(x, y, f"{path}[{i}]")]
    if isinstance(a, float) and a != b:
        return [(path.lstrip("."), abs(a - b) / max(abs(a), abs(b), 1.0))]
    return []


def compare(files: dict) -> dict:
    from lutbake.tables.headers import ATLAS_FORMAT, EXACT_FORMAT, FORMAT
    from lutbake.tables.lutfile import read_lut

    (meta_a, image_a), (meta_b, image_b) = (read_lut(p, (FORMAT, ATLAS_FORMAT, EXACT_FORMAT)) for p in files.values())
    bits = np.int16 if image_a.dtype == np.float16 else np.int32
    ulps = np.abs(image_a.view(bits).astype(np.int64) - image_b.view(bits))
    numbers = header_numbers(meta_a, meta_b)
    a, b = files.values()
    return {
        "exr_bytes_equal": a.read_bytes() == b.read_bytes(),
        "texels": int(image_a.shape[0] * image_a.shape[1]),
        "values": int(image_a.size),
        "values_differing": int((ulps > 0).sum()),
        "max_ulps": int(ulps.max()),
        "header_numbers_differing": [{"field": f, "relative": r} for f, r in numbers],
        "includes_equal": all(
            a.with_suffix(s).read_bytes() == b.with_suffix(s).read_bytes() for s in (".glsl", ".hlsl")
        ),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write the results here")
    opts = parser.parse_args()
    import numpy

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, args in SETS.items():
            files = {}
            for kernel, env in KERNELS.items():
                folder = Path(tmp) / f"{name}-{kernel}".replace(" ", "_")
                folder.mkdir()
                files[kernel] = folder / "set.exr"
                write(args, files[kernel], {**env, "LUTBAKE_CACHE_DIR": str(folder / "cache")})
            rows.append({"set": name, **compare(files)})
            print(json.dumps(rows[-1]))
    simd = numpy._core._multiarray_umath.__cpu_features__
    doc = {
        "machine": platform.processor() or platform.machine(),
        "cpu": next(
            (
                line.split(":", 1)[1].strip()
                for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")
            ),
            "?",
        ),
        "numpy": numpy.__version__,
        "numpy_avx512": bool(simd.get("AVX512F")),
        "kernels": list(KERNELS),
        "sets": rows,
    }
    if opts.json:
        opts.json.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
