"""Hostile EXR and process cases that tests/cli/test_hostile_files.py and test_hostile_readers.py share: the CLI
in a fresh process and its verdict, and EXRs written or patched byte by byte."""

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np

CASE_SECONDS = 60


def run_cli(args, cwd: Path, env=None, stdin=subprocess.DEVNULL, **popen):
    """The CLI in a fresh process; (exit code, stdout, stderr), failing past CASE_SECONDS."""
    proc = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", *args],
        cwd=cwd,
        env={**os.environ, **(env or {})},
        stdin=stdin,
        capture_output=True,
        text=True,
        timeout=CASE_SECONDS,
        **popen,
    )
    return proc.returncode, proc.stdout, proc.stderr


def assert_verdict(rc, out, err, expected):
    assert rc in expected, (rc, err)
    assert "Traceback" not in out + err and "Exception ignored" not in err, err
    if rc == 2:
        assert len(err.strip().splitlines()) == 1 and err.startswith("lutbake: error: "), err


def write_like(path: Path, image: np.ndarray, meta, channels: str = "RGB"):
    """An EXR of ``image`` (half or float ``channels`` as its dtype) with ``meta`` as its metadata."""
    import Imath
    import OpenEXR

    kind = Imath.PixelType.HALF if image.dtype == np.float16 else Imath.PixelType.FLOAT
    header = OpenEXR.Header(image.shape[1], image.shape[0])
    header["channels"] = {c: Imath.Channel(Imath.PixelType(kind)) for c in channels}
    header["lutbake.metadata"] = json.dumps(meta).encode()
    out = OpenEXR.OutputFile(str(path), header)
    out.writePixels({c: np.ascontiguousarray(image[:, :, i]).tobytes() for i, c in enumerate(channels)})
    out.close()


def patched_attribute(data: bytes, name: str, kind: str, value: bytes) -> bytes:
    """``data`` (an EXR) with attribute ``name``'s value replaced by ``value`` (same size)."""
    key = name.encode() + b"\0" + kind.encode() + b"\0"
    at = data.index(key) + len(key)
    (size,) = struct.unpack("<i", data[at : at + 4])
    assert len(value) == size
    return data[: at + 4] + value + data[at + 4 + size :]
