"""The habits that keep the house readable, checked as the suite runs (pyproject.toml holds each tool's
settings): ruff's lint and format, mypy, import-linter's layers (no import runs back up a stage), every
public function annotated, and the sizes past which a module, class or function wants cutting at a seam."""

import ast
import subprocess
import sys

import pytest
from conftest import ROOT

PACKAGE = ROOT / "lutbake"
# scripts Blender runs in its own Python (bpy, no stubs), importing nothing of lutbake
BLENDER_SCRIPTS = {PACKAGE / "blender" / "nodes.py", PACKAGE / "blender" / "probe.py"}
LIMITS = {"module": 500, "class": 150, "function": 60}  # lines of code, docstrings not counted


def _tool(*args):
    return subprocess.run([sys.executable, "-m", *args], cwd=ROOT, capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize(
    "command",
    [
        ("ruff", "check", "lutbake", "tests", "bench", "docs"),
        ("ruff", "format", "--check", "lutbake", "tests", "bench", "docs"),
        ("mypy",),
        ("importlinter.cli",),
    ],
    ids=["ruff-check", "ruff-format", "mypy", "import-linter"],
)
def test_tool_passes(command):
    out = _tool(*command)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]


def _modules():
    return [p for p in sorted(PACKAGE.rglob("*.py")) if p not in BLENDER_SCRIPTS]


def _public(tree):
    """(qualified name, def) of every public function and method: no leading underscore on it or its class."""
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and not node.name.startswith("_"):
            yield node.name, node
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for item in node.body:
                if isinstance(item, ast.FunctionDef) and (not item.name.startswith("_") or item.name == "__init__"):
                    yield f"{node.name}.{item.name}", item


def _unannotated(fn) -> list:
    args = fn.args
    params = [*args.posonlyargs, *args.args, *args.kwonlyargs, *filter(None, (args.vararg, args.kwarg))]
    missing = [a.arg for a in params if a.annotation is None and a.arg not in ("self", "cls")]
    return missing + (["return"] if fn.returns is None and fn.name != "__init__" else [])


def test_public_functions_are_fully_annotated():
    gaps = []
    for path in _modules():
        for name, fn in _public(ast.parse(path.read_text())):
            missing = _unannotated(fn)
            if missing:
                gaps.append(f"{path.relative_to(ROOT)}:{fn.lineno} {name}: {', '.join(missing)}")
    assert not gaps, f"{len(gaps)} public functions miss annotations:\n" + "\n".join(gaps[:60])


def _code_lines(node) -> int:
    """Lines of ``node`` not counting the docstrings of it and of what it defines."""
    docstrings = set()
    for n in ast.walk(node):
        if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and ast.get_docstring(n):
            first = n.body[0]
            docstrings.update(range(first.lineno, first.end_lineno + 1))
    start = getattr(node, "lineno", 1)
    end = getattr(node, "end_lineno", None) or max((getattr(n, "end_lineno", 0) or 0) for n in ast.walk(node))
    return sum(1 for line in range(start, end + 1) if line not in docstrings)


def test_modules_classes_and_functions_stay_short():
    """Past these a piece wants cutting at a seam (issue 33): modules 500, classes 150, functions 60 lines."""
    over = []
    for path in _modules():
        tree = ast.parse(path.read_text())
        if _code_lines(tree) > LIMITS["module"]:
            over.append(f"{path.relative_to(ROOT)}: module {_code_lines(tree)}")
        for node in ast.walk(tree):
            kind = (
                "class"
                if isinstance(node, ast.ClassDef)
                else "function"
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
                else None
            )
            if kind and _code_lines(node) > LIMITS[kind]:
                over.append(f"{path.relative_to(ROOT)}:{node.lineno} {kind} {node.name} {_code_lines(node)}")
    assert not over, "\n".join(over)
