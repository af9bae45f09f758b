"""The hostile-input contract (issue 16), run on the command line in-process: a case's exit code is 0, 1 or 2, it
prints no traceback and no NaN, and on exit 2 it prints one stderr line and writes nothing. With the tiny
bake's flags (TINY) and a writer of raw EXR files that lutbake's writer would refuse to make (write_exr)."""

import hashlib
import re
import signal
from pathlib import Path

import numpy as np
import pytest

from lutbake import cli

TINY = [
    "--cos-theta",
    "0:1:4",
    "--opd",
    "0:1000:4",
    "--eta3",
    "1:2:2",
    "--kappa3",
    "0:1:2",
    "--backend",
    "numpy",
    "--quiet",
]
CASE_SECONDS = 120


def tree_digests(folder: Path) -> dict:
    """Every path under ``folder`` → SHA-256 of a file, or "dir"."""
    return {
        str(p.relative_to(folder)): (hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir")
        for p in sorted(folder.rglob("*"))
    }


class _Timeout(Exception):
    pass


def _alarm(signum: int, frame: object) -> None:
    raise _Timeout()


def run_case(
    argv: list,
    folder: Path,
    capfd: pytest.CaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
    expected: set,
    check_unchanged: bool = True,
) -> tuple:
    """Run the CLI in-process in ``folder``; assert the hostile-table contract; return (rc, out, err)."""
    monkeypatch.chdir(folder)
    before = tree_digests(folder)
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CASE_SECONDS)
    try:
        cli.main(argv)
        rc = 0
    except SystemExit as exc:
        rc = exc.code if isinstance(exc.code, int) else 1
    except _Timeout:
        pytest.fail(f"{argv} ran past {CASE_SECONDS} s")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    out, err = capfd.readouterr()
    assert rc in (0, 1, 2), (argv, rc, err)
    assert rc in expected, (argv, rc, err)
    assert "Traceback" not in err + out
    assert not re.search(r"\bnan\b", out.lower()), out  # a word: "illuminant" contains n-a-n
    if rc == 2:
        assert len(err.strip().splitlines()) == 1, err
        assert err.startswith("lutbake: error: ")
        if check_unchanged:
            assert tree_digests(folder) == before, "a failing command wrote or changed files"
    return rc, out, err


def write_exr(path: Path, meta_text: str | None, image: np.ndarray) -> None:
    """An RGB float EXR with ``meta_text`` as its lutbake.metadata attribute (None: no attribute)."""
    import Imath
    import OpenEXR

    height, width, _ = image.shape
    header = OpenEXR.Header(width, height)
    header["channels"] = {c: Imath.Channel(Imath.PixelType(Imath.PixelType.FLOAT)) for c in "RGB"}
    if meta_text is not None:
        header["lutbake.metadata"] = meta_text.encode()
    out = OpenEXR.OutputFile(str(path), header)
    out.writePixels({c: np.ascontiguousarray(image[:, :, i], np.float32).tobytes() for i, c in enumerate("RGB")})
    out.close()
