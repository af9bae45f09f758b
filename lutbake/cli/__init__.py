"""The `lutbake` command line: parse flags, call the library, print (README.md; docs/api.md: the Python API
behaves as it does).

Exit codes: 0 success; 1 a check or gate failed; 2 bad input (one line on
stderr naming the value and what is allowed; nothing written).

Stages, a module each: ``environment`` (Environment: the environment, read once, here, and handed to the
commands as values), ``options`` (the exit codes, BadInput and the flags more than one command takes),
then one module per group of commands (bake.py: bake and plan; points.py: eval, sample, inspect,
materials; report.py: report, sweep, tune, check; tables.py: runtime-table and exact-table; blender.py;
devices.py), loaded on first use: `lutbake --help` imports click and the command modules, none of the
library's numeric modules. Public names: ``main`` (the entry point) and ``cli`` (the click group).
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Sequence
from typing import IO, Any, NoReturn

from lutbake.io.signals import (
    STOP_SIGNALS,
    exit_status,
    hold_stop_signals_in_extension_imports,
    interrupted_at_start_up,
    message,
    raise_interrupted,
    set_handler,
)

for _signum in STOP_SIGNALS:
    set_handler(_signum, interrupted_at_start_up)  # until main() runs
hold_stop_signals_in_extension_imports()  # a stop inside a C extension's initialisation waits for its end

import click  # noqa: E402  (after the start-up SIGINT handler)

from lutbake.cli.environment import Environment  # noqa: E402
from lutbake.cli.options import EXIT_BAD_INPUT, BadInput  # noqa: E402
from lutbake.errors import OpenCLUnavailable  # noqa: E402

__all__ = ["main", "cli"]


def main(argv: Sequence[str] | None = None) -> NoReturn:
    """Entry point: turn ValueError and click usage errors into one-line exit-2 errors.

    The context is driven directly rather than through ``cli.main``, which maps a
    closed pipe to exit 1; a reader that stops early is not a failure here (exit 0).
    """
    for signum in STOP_SIGNALS:  # unwind like Ctrl-C: half-written sets are discarded (lutbake/io/signals.py)
        set_handler(signum, raise_interrupted)
    args = sys.argv[1:] if argv is None else list(argv)
    try:
        with cli.make_context("lutbake", args) as ctx:
            rv = cli.invoke(ctx)
        _flush(sys.stdout)
    except click.exceptions.Exit as exc:  # --help, --version
        sys.exit(exc.exit_code)
    except (click.exceptions.Abort, KeyboardInterrupt) as exc:
        # Files were cleaned up as the exception unwound. Leave without interpreter finalization:
        # an interrupt that landed inside a library's import can make Python re-raise SIGINT at exit
        # (seen: killed by SIGINT instead of exit 130 when Ctrl-C hit matplotlib's first start-up).
        click.echo("\n" + message(getattr(exc, "signum", signal.SIGINT)), err=True)
        _flush(sys.stdout)
        _flush(sys.stderr)
        os._exit(exit_status(exc))
    except click.exceptions.NoArgsIsHelpError as exc:  # bare `lutbake`: the help, not an error line
        click.echo(exc.ctx.get_help())
        sys.exit(0)
    except click.ClickException as exc:
        if isinstance(exc, click.UsageError):
            exc = BadInput(exc.format_message().replace("\n", " "))
        exc.show()
        sys.exit(exc.exit_code)
    except BrokenPipeError:
        _quiet_broken_pipe()
        sys.exit(0)
    except (ValueError, OSError) as exc:
        BadInput(_in_flags(exc)).show()
        sys.exit(EXIT_BAD_INPUT)
    except OpenCLUnavailable as exc:  # --backend opencl (or --fast with it) where no device runs the kernel
        BadInput(f"OpenCL cannot run the kernel here ({exc}): use --backend auto or numpy").show()
        sys.exit(EXIT_BAD_INPUT)
    sys.exit(rv or 0)


def _flush(stream: IO[str] | None) -> None:
    """Flush ``stream`` unless it is closed (`lutbake inspect X >&-`: Python then sets it to None)."""
    if stream is not None:
        stream.flush()


# The library's parameter names (errors.ParameterError) as this command line spells them.
FLAG_OF_PARAMETER = {
    "cos_theta": "--cos-theta",
    "opd_nm": "--opd",
    "eta1": "--eta1",
    "eta2": "--eta2",
    "eta3": "--eta3",
    "kappa3": "--kappa3",
    "film": "--film NAME",
    "base": "--base NAME",
    "thickness_nm": "--thickness",
    "out_path": "--out",
    "out_dir": "--out",
    "fast": "--fast",
    "compute": "--compute",
    "memory_limit_gib": "--max-memory-gib",
    "device": "--device",
    "tolerance": "--tolerance",
    "max_terms": "--max-terms",
    "blender": "--blender",
    "exact": "--exact",
    "runtime_table": "--runtime-table",
    "max_de": "--max-de",
    "n_points": "--points",
    "routes": "--route",
    "material": "--material",
    "filter_bits": "--filter-bits",
    "interpolation": "--interpolation",
    "scene_path": "--scene",
    "gltf_path": "--gltf",
    "metal_mapping": "--metal-mapping",
}


def _in_flags(exc: Exception) -> str:
    """The error's one line, with library parameter names shown as the flags that set them."""
    from lutbake.errors import ParameterError

    return exc.render(FLAG_OF_PARAMETER) if isinstance(exc, ParameterError) else str(exc)


def _quiet_broken_pipe() -> None:
    """The reader went away (`lutbake inspect X | head -1`): not an error. Point stdout at
    /dev/null so the interpreter's final flush does not fail again."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)


def _print_version(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    if value and not ctx.resilient_parsing:
        from lutbake import __version__

        click.echo(f"lutbake, version {__version__}")
        ctx.exit()


class LazyGroup(click.Group):
    """A group whose commands are imported on first use: ``lazy`` maps a command's name to
    "module:function" (a module of this package and its click command)."""

    def __init__(self, *args: Any, lazy: dict[str, str], **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.lazy = lazy

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(self.lazy)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self.lazy:
            return None
        from importlib import import_module

        module, name = self.lazy[cmd_name].split(":")
        return getattr(import_module(f"{__name__}.{module}"), name)


COMMANDS = {
    "bake": "bake:bake_cmd",
    "plan": "bake:plan_cmd",
    "eval": "points:eval_cmd",
    "sample": "points:sample_cmd",
    "inspect": "points:inspect_cmd",
    "materials": "points:materials_cmd",
    "report": "report:report_cmd",
    "sweep": "report:sweep_cmd",
    "tune": "report:tune_cmd",
    "check": "report:check_cmd",
    "runtime-table": "tables:runtime_table_cmd",
    "exact-table": "tables:exact_table_cmd",
    "blender": "blender:blender_cmd",
    "devices": "devices:devices_cmd",
}


@click.group(cls=LazyGroup, lazy=COMMANDS)
@click.option(
    "--version",
    is_flag=True,
    expose_value=False,
    is_eager=True,
    callback=_print_version,
    help="Show the version and exit.",
)
@click.pass_context
def cli(ctx: click.Context) -> None:
    """Bake thin-film iridescence (exact spectral Airy summation) into EXR LUTs."""
    if ctx.obj is None:  # the environment, read once, before a command parses its flags
        ctx.obj = Environment.read(os.environ)
    ctx.obj.apply()
