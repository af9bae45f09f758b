"""The command line's layout: one module per group of commands, loaded on first use; `--help` loads none of
the library's numeric modules; the environment is read once, at the edge, and passed down."""

import json
import os
import subprocess
import sys
from pathlib import Path

import click
import pytest

from lutbake.cli import COMMANDS, cli
from lutbake.cli.environment import Environment

ROOT = Path(__file__).resolve().parents[2]

_IMPORTED = """
import json, sys
from lutbake.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print(json.dumps(sorted(m for m in ("numpy", "pyopencl", "colour", "lutbake.lut", "lutbake.cli.bake")
                        if m in sys.modules)), file=sys.stderr)
"""


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_each_command_loads_from_its_module(name):
    command = cli.get_command(click.Context(cli), name)
    assert isinstance(command, click.Command) and command.name == name
    assert command.callback.__module__ == f"lutbake.cli.{COMMANDS[name].split(':')[0]}"


@pytest.mark.parametrize(
    "args, loaded",
    [(["--help"], ["lutbake.cli.bake"]), (["bake", "--help"], ["lutbake.cli.bake"]), (["inspect", "--help"], [])],
)
def test_help_loads_no_numeric_module(args, loaded):
    """`lutbake --help` lists every command (their modules load) and a command's --help loads its own; neither
    imports numpy, pyopencl, colour-science or the library's stages."""
    done = subprocess.run([sys.executable, "-c", _IMPORTED, *args], capture_output=True, text=True, cwd=ROOT)
    assert json.loads(done.stderr.strip().splitlines()[-1]) == loaded


def test_the_device_comes_from_the_flag_else_the_environment_and_is_passed_down(monkeypatch):
    """`check` hands its library call the --device selector, else $LUTBAKE_DEVICE, else $PYOPENCL_CTX (as a
    selector pyopencl's rules read); the environment is left as it was (the command line once wrote --device
    into it)."""
    import lutbake.integrate.devices
    import lutbake.quality.check as check

    seen = []
    monkeypatch.setattr(
        check, "check_fast_path", lambda backend, progress, device: seen.append(device) or check.CheckRun("d", [])
    )
    monkeypatch.setattr(lutbake.integrate.devices, "find_device", lambda selector: selector)
    monkeypatch.setattr(lutbake.integrate.devices, "device_label", lambda device: device)
    monkeypatch.delenv("LUTBAKE_DEVICE", raising=False)
    for args in (["check", "--device", "named"], ["check"]):  # the flag's choice ends with its command
        assert cli.main(args, standalone_mode=False) == 0
    assert "LUTBAKE_DEVICE" not in os.environ
    monkeypatch.setenv("LUTBAKE_DEVICE", "from-the-environment")
    for args in (["check"], ["check", "--device", "named"]):
        assert cli.main(args, standalone_mode=False) == 0
    monkeypatch.delenv("LUTBAKE_DEVICE")
    monkeypatch.setenv("PYOPENCL_CTX", "0:1")
    assert cli.main(["check"], standalone_mode=False) == 0
    assert seen == ["named", None, "from-the-environment", "named", "0:1"]
    assert isinstance(seen[-1], lutbake.integrate.devices.PyopenclCtx)


def test_empty_variables_count_as_unset():
    assert Environment.read({"LUTBAKE_CACHE_DIR": "", "XDG_CACHE_HOME": "", "LUTBAKE_DEVICE": ""}) == Environment()
