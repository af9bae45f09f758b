"""The public Python API: docs/api.md's example, each public name's doctest, no process-state changes."""

import doctest
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import lutbake

ROOT = Path(__file__).resolve().parents[1]
PUBLIC = [name for name in lutbake.__all__ if name != "__version__"]


def _run_doctests(text: str, name: str, globs=None):
    test = doctest.DocTestParser().get_doctest(text, dict(globs or {}), name, name, 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    runner.run(test)
    return runner.summarize(verbose=False), len(test.examples)


def test_api_page_python_example_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "api.md").read_text(), re.S)
    assert blocks, "docs/api.md has no Python example"
    result, examples = _run_doctests("".join(blocks), "docs/api.md")
    assert examples >= 5 and result.failed == 0
    assert {p.name for p in tmp_path.iterdir()} >= {"soap.exr", "soap.json", "soap.glsl", "soap.hlsl"}


@pytest.mark.parametrize("name", PUBLIC)
def test_public_name_is_documented_with_a_passing_example(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    obj = getattr(lutbake, name)
    doc = obj.__doc__ or ""
    assert "Examples\n" in doc and ">>> " in doc, f"lutbake.{name} has no Examples section"
    result, examples = _run_doctests(doc, f"lutbake.{name}")
    assert examples and result.failed == 0


# The modules behind the command line's commands (docs/api.md, "The Python API behaves as the command line
# does"): the examples in their docstrings run.
COMMAND_MODULES = [
    "lutbake.lut.domain",
    "lutbake.lut.sets",
    "lutbake.lut.evaluate",
    "lutbake.lut.readout",
    "lutbake.scene.source",
    "lutbake.scene.reports",
    "lutbake.quality.refine",
    "lutbake.physics.materials",
    "lutbake.io.fileset",
    "lutbake.io.usercache",
    "lutbake.cli.environment",
]


@pytest.mark.parametrize("module", COMMAND_MODULES)
def test_the_command_lines_library_calls_run_their_examples(module, tmp_path, monkeypatch):
    import importlib

    monkeypatch.chdir(tmp_path)
    result = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert result.attempted and result.failed == 0


def test_every_library_call_docs_api_names_exists():
    import importlib

    text = (ROOT / "docs" / "api.md").read_text()
    table = text[text.index("| command | the library call |") : text.index("## Units and conventions")]
    names = set(re.findall(r"`(lutbake(?:\.\w+)+)", table))
    assert len(names) >= 12
    for name in names:
        module, _, attr = name.rpartition(".")
        assert hasattr(importlib.import_module(module), attr), name


def test_every_public_name_is_in_docs_api():
    text = (ROOT / "docs" / "api.md").read_text()
    missing = [name for name in PUBLIC if f"`{name}" not in text]
    assert not missing


def test_public_names_survive_their_modules_being_imported():
    """A package attribute named like a submodule is replaced when the submodule loads: none is."""
    import importlib
    import types

    for module in {m if isinstance(m, str) else m[0] for m in lutbake._API.values()}:
        importlib.import_module(f"lutbake.{module}")
    assert not [n for n in PUBLIC if isinstance(getattr(lutbake, n), types.ModuleType)]


def test_unknown_attribute_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_name"):
        lutbake.no_such_name  # noqa: B018


_PROBE = """
import json, os, signal, sys, tempfile
before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
import lutbake
imported = sorted(m for m in ("numpy", "pyopencl", "colour", "matplotlib") if m in sys.modules)
spec = lutbake.BakeSpec(eta2=1.5, axes=(lutbake.Axis("cos_theta", 0, 1, 4), lutbake.Axis("opd_nm", 0, 800, 8),
                                        lutbake.Axis("eta3", 1, 2, 2), lutbake.Axis("kappa3", 0, 1, 2)))
baked = lutbake.bake_lut(spec, os.path.join(sys.argv[1], "x.exr"))
report = lutbake.report_lut(baked.path, n_points=40, search_budget=2000)
lutbake.write_report(report, os.path.join(sys.argv[1], "report"))
after = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
print(json.dumps({"imported_by_import": imported, "handlers_kept": before == after,
                  "matplotlib_backend": sys.modules["matplotlib"].get_backend(),
                  "icd_env": os.environ.get("OCL_ICD_VENDORS"), "device": baked.device,
                  "temp": sorted(os.listdir(tempfile.gettempdir()))}))
"""


def test_library_use_changes_no_process_state(tmp_path):
    """Importing lutbake loads nothing heavy; a bake and a report leave signal handlers, the environment,
    matplotlib's backend and the temporary folder as they were (lutbake registers no OpenCL runtime:
    OCL_ICD_VENDORS stays unset)."""
    temp = tmp_path / "tmp"
    temp.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("OCL_ICD_VENDORS", "LUTBAKE_DEVICE")}
    env.update(TMPDIR=str(temp), PYTHONPATH=str(ROOT), MPLBACKEND="svg")  # a report must not switch it
    proc = subprocess.run(
        [sys.executable, "-c", _PROBE, str(tmp_path)], env=env, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    seen = json.loads(proc.stdout)
    assert seen == {
        "imported_by_import": [],
        "handlers_kept": True,
        "matplotlib_backend": "svg",
        "icd_env": None,
        "device": seen["device"],
        "temp": [],
    }
    assert (tmp_path / "x.exr").is_file()


@pytest.mark.parametrize(
    "call, message",
    [
        (
            lambda: lutbake.FilmPoints.build(thickness_nm=100.0, cos_theta=1.0, eta3=1.5),
            "eta2 is missing: give eta2 or film",
        ),
        (
            lambda: lutbake.FilmPoints.build(film="SiO2", opd_nm=100.0, cos_theta=1.0, eta3=1.5),
            "opd_nm needs a constant eta2; with film give thickness_nm",
        ),
        (
            lambda: lutbake.bake_lut(lutbake.default_specs()["lutbake-eta2-1.50"], "lut.txt"),
            "out_path 'lut.txt' must end in .exr",
        ),
    ],
)
def test_library_errors_name_parameters_not_flags(call, message, tmp_path, monkeypatch):
    """The library speaks Python names; the command line shows the same line with its flags
    (tests/cli/test_hostile.py checks the CLI's side)."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError) as caught:
        call()
    assert str(caught.value) == message
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    "old, names",
    [
        ("plan", ["Axis", "BakeSpec"]),
        ("points", ["FilmPoints"]),
        ("reference", ["reference_colour", "reference_rgb"]),
        ("bake", ["BakeResult", "default_specs"]),
        ("sample", ["Atlas", "Lut"]),
        ("report", ["report_lut", "write_report"]),
        ("scene_toml", ["load_scene"]),
        ("gltf_scene", ["load_gltf_scene"]),
        ("scene_plan", ["plan_scene"]),
        ("scene_bake", ["bake_scene"]),
        ("check", ["run_checks"]),
    ],
)
def test_public_names_keep_their_former_import_paths(old, names):
    """`from lutbake.plan import Axis` (the flat layout's paths) gives the same objects, with a warning naming
    the new path; run in a fresh process so the warning is not already spent."""
    script = (
        f"import warnings; warnings.simplefilter('error')\n"
        f"try:\n    import lutbake.{old}\nexcept DeprecationWarning as w:\n    print(w)\n"
        f"warnings.simplefilter('ignore')\nimport lutbake, lutbake.{old} as m\n"
        f"print(all(getattr(m, n) is getattr(lutbake, n) for n in {names!r}))"
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT)
    warning, same = out.stdout.strip().splitlines()
    assert warning.startswith(f"lutbake.{old} is lutbake.") and same == "True", out.stderr
