"""The real engine the tests drive: three.js (pinned in engine/package-lock.json) in Debian's headless Chromium,
through engine/harness.mjs, and the shipped loaders' set check (engine/check-set.mjs). A missing engine fails
the test that needs it, saying what to install; it is never skipped."""

import fcntl
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ENGINE = ROOT / "engine"
CHROMIUM = Path(os.environ.get("LUTBAKE_CHROMIUM", "/usr/bin/chromium"))


def _install_pinned_engine() -> None:
    """`npm ci` in engine/ when its node_modules is missing: the lockfile pins every package. Under a
    lock on engine/, so test processes running side by side (pytest-xdist) install it once."""
    if shutil.which("npm") is None:
        return
    with open(ENGINE / ".npm-ci.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if _missing_packages():
            subprocess.run(["npm", "ci", "--no-audit", "--no-fund"], cwd=ENGINE, capture_output=True, timeout=600)


def _missing_packages() -> list[str]:
    """The pinned packages (engine/package.json) not installed in engine/node_modules: a checkout that gained an
    engine since its last `npm ci` installs again."""
    pinned = json.loads((ENGINE / "package.json").read_text())["dependencies"]
    return [name for name in pinned if not (ENGINE / "node_modules" / name / "package.json").is_file()]


def require_engine() -> None:
    """Fail (never skip) with what to install; in CI (CI=true) a missing engine is a failed check."""
    _install_pinned_engine()
    missing = []
    if shutil.which("node") is None:
        missing.append("node and npm (apt-get install nodejs npm)")
    if not CHROMIUM.is_file():
        missing.append(f"Debian's chromium at {CHROMIUM} (apt-get install chromium)")
    if _missing_packages():
        missing.append(f"the pinned {', '.join(_missing_packages())} (cd engine && npm ci failed)")
    if missing:
        context = (
            "CI=true: the real-engine check must run"
            if os.environ.get("CI") == "true"
            else "the real-engine check needs them"
        )
        pytest.fail(f"{context}; install {'; '.join(missing)}", pytrace=False)


def run_harness(command: str, folder: Path, jobs: list | dict, timeout: int = 600) -> dict:
    """`node engine/harness.mjs COMMAND jobs.json result.json` in one Chromium run, ``jobs`` (a list of jobs, or
    one page's spec) written into ``folder``: the result document (its "results" in the jobs' order)."""
    (folder / "jobs.json").write_text(json.dumps(jobs))
    proc = subprocess.run(
        ["node", str(ENGINE / "harness.mjs"), command, str(folder / "jobs.json"), str(folder / "result.json")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=timeout,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    return json.loads((folder / "result.json").read_text())


def run_jobs(folder: Path, jobs: dict) -> dict:
    """`harness.mjs evaluate` on named jobs ({name: job}): {name: that job's result}."""
    return dict(zip(jobs, run_harness("evaluate", folder, list(jobs.values()))["results"]))


def engine_accepts(folder: Path, pairs: list) -> list:
    """engine/check-set.mjs (the shipped three.js loaders' check) on (EXR, include) pairs: True where it
    loads the pair, False where it refuses it."""
    require_engine()
    args = [str(folder / name) for pair in pairs for name in pair]
    out = subprocess.run(["node", str(ENGINE / "check-set.mjs"), *args], capture_output=True, text=True, timeout=120)
    return [json.loads(line)["ok"] for line in out.stdout.splitlines()]
