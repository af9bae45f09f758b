"""What each OpenCL runtime holds in memory: the runtime itself, and a buffer through its life.

    python bench/bench_runtime_memory.py [--devices KEY ...] [--alone] [--json FILE]

Per device (default: every one whose kernel builds), in its own process: resident MiB (VmRSS) after
lutbake's imports, after pyopencl's, once every runtime is registered (the loader dlopens each
runtime's library), after the kernel is built on the device, and after its self-check: what a bake
measures as its runtime (``BakeSpec.memory``'s ``runtime``). Then a 256 MiB buffer through its life,
as the bake uses buffers: created, written by a kernel, read back into a host array, released, and a
COPY_HOST_PTR buffer of that size beside its host array. --alone also measures PyPI's PoCL with the
vendor folder empty (OCL_ICD_VENDORS: no system runtime, no Intel runtime registered). Result:
docs/devices.md#memory.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

BUFFER_MIB = 256


def child(key: str) -> None:
    """Measure ``key``'s stages and a buffer's life in this process; print one JSON line."""
    from lutbake.lut.bake import resident_bytes

    def mib():
        return round(resident_bytes() / 2**20, 1)

    stages = {"imports": mib()}
    from lutbake.integrate import devices, program
    from lutbake.integrate import opencl as integrate

    cl = devices.import_pyopencl()
    stages["pyopencl"] = mib()
    found = devices.opencl_devices()
    stages["registered"] = mib()
    device = devices.find_device(key)
    program.built_program(device, "float64")
    stages["built"] = mib()
    integrate.OpenCLBackend("float64", device=key)
    stages["self_checked"] = mib()
    print(
        json.dumps(
            {
                "key": key,
                "label": devices.device_label(device),
                "devices_registered": len(found),
                "stages_mib": stages,
                "buffer_mib": _buffer_life(cl, device, mib),
            }
        )
    )


def _buffer_life(cl, device, mib) -> dict:
    """Resident MiB, less the runtime's, at each step of a BUFFER_MIB buffer's life."""
    import numpy as np

    ctx = cl.Context([device])
    queue = cl.CommandQueue(ctx)
    fill = cl.Kernel(
        cl.Program(ctx, "__kernel void fill(__global float *x) { x[get_global_id(0)] = 1.0f; }").build(), "fill"
    )
    count = BUFFER_MIB << 18  # floats
    base = mib()
    steps = {}
    buffer = cl.Buffer(ctx, cl.mem_flags.READ_WRITE, count * 4)
    steps["created"] = mib() - base
    fill(queue, (count,), None, buffer)
    queue.finish()
    steps["written_by_a_kernel"] = mib() - base
    host = np.empty(count, np.float32)
    cl.enqueue_copy(queue, host, buffer)
    steps["read_back_to_a_host_array"] = mib() - base
    buffer.release()
    steps["released"] = mib() - base
    copied = cl.Buffer(ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=host)
    queue.finish()
    steps["copy_host_ptr_beside_its_array"] = mib() - base
    copied.release()
    return {name: round(value, 1) for name, value in steps.items()}


def measure(key: str, env=None) -> dict:
    proc = subprocess.run(
        [sys.executable, __file__, "--child", key], capture_output=True, text=True, env={**os.environ, **(env or {})}
    )
    if proc.returncode:
        raise SystemExit(proc.stderr)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child")
    ap.add_argument("--devices", nargs="+")
    ap.add_argument("--alone", action="store_true")
    ap.add_argument("--json")
    args = ap.parse_args()
    if args.child:
        child(args.child)
        return
    from bench_b1 import devices

    rows = [measure(key) for key in args.devices or devices()]
    if args.alone:
        with tempfile.TemporaryDirectory() as empty:
            rows.append({**measure("pocl-pypi", {"OCL_ICD_VENDORS": empty}), "alone": True})
    text = json.dumps(rows, indent=2)
    print(text)
    if args.json:
        Path(args.json).write_text(text + "\n")


if __name__ == "__main__":
    main()
