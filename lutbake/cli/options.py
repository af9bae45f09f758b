"""What the command modules share: the exit codes and the bad-input error, JSON output, and the click
options more than one command takes (colour, progress, the OpenCL device, a LUT's domain).

Imported by `lutbake --help`: nothing here imports the library's numeric modules at load time.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import IO, TYPE_CHECKING, Any, TypeVar

import click

from lutbake.io.names import INTERPOLATIONS, OBSERVERS, SPACES

if TYPE_CHECKING:
    from lutbake.cli.environment import Environment
    from lutbake.io.progress import AnyMeter as Meter


EXIT_GATE, EXIT_BAD_INPUT = 1, 2

# a click command's function, as an option decorator takes and returns it
F = TypeVar("F", bound=Callable[..., Any])


class BadInput(click.ClickException):
    exit_code = EXIT_BAD_INPUT

    def show(self, file: IO[Any] | None = None) -> None:
        from lutbake.io.names import terminal_text

        click.echo(f"lutbake: error: {terminal_text(self.message)}", err=True)


def echo_json(doc: object) -> None:
    from lutbake.io.strictjson import dumps

    click.echo(dumps(doc))


def environment() -> Environment:
    """The Environment the group read (lutbake/cli/environment.py)."""
    return click.get_current_context().obj


def colour_options(f: F) -> F:
    f = click.option(
        "--observer",
        type=click.Choice(list(OBSERVERS)),
        default="cie1931",
        show_default=True,
        help="CIE standard observer.",
    )(f)
    return click.option(
        "--space",
        type=click.Choice(list(SPACES)),
        default="rec709",
        show_default=True,
        help="Linear RGB working space.",
    )(f)


def progress_options(f: F) -> F:
    """--quiet / --progress: live progress on stderr, shown by default only on a terminal."""
    f = click.option(
        "--progress", "force_progress", is_flag=True, help="Show progress on stderr even when it is not a terminal."
    )(f)
    return click.option("--quiet", is_flag=True, help="No progress on stderr.")(f)


def progress_meter(label: str, quiet: bool, force_progress: bool) -> Meter:
    """The Meter for a command's progress flags (conflicting flags are refused)."""
    from lutbake.io.progress import meter

    return meter(label, show_progress(quiet, force_progress))


class MeterOnFirstUse:
    """A progress meter started by its first update (or its close) rather than at once, so that what the
    library prints before its first step (a fallback warning while it makes its integrator) comes first."""

    def __init__(self, label: str, quiet: bool, force_progress: bool) -> None:
        self.label, self.show = label, show_progress(quiet, force_progress)
        self.meter: Meter | None = None

    def _started(self) -> Meter:
        from lutbake.io.progress import meter

        self.meter = self.meter or meter(self.label, self.show)
        return self.meter

    def __call__(self, done: int, total: int | None = None, note: str = "") -> None:
        self._started()(done, total, note)

    def close(self, note: str = "done") -> None:
        self._started().close(note)


def show_progress(quiet: bool, force_progress: bool) -> bool | None:
    """progress.meter's ``show`` for the flags: False, True, or None (on a terminal only)."""
    if quiet and force_progress:
        raise BadInput("--quiet and --progress contradict each other: give one")
    return False if quiet else (True if force_progress else None)


def backend_option(help_text: str) -> Callable[[F], F]:
    """--backend: which integrator runs the kernel's work ('auto': OpenCL, else numpy with a warning)."""
    return click.option(
        "--backend", type=click.Choice(["auto", "opencl", "numpy"]), default="auto", show_default=True, help=help_text
    )


def _device_choice(ctx: click.Context, param: click.Parameter, selector: str | None) -> str | None:
    """--device, validated now; without it, the environment's choice ($LUTBAKE_DEVICE)."""
    if not selector:
        return ctx.obj.device if ctx.obj else None
    from lutbake.integrate.devices import device_label, find_device

    device_label(find_device(selector))
    return selector


device_option = click.option(
    "--device",
    metavar="N|KEY|TEXT",
    callback=_device_choice,
    is_eager=True,
    help="OpenCL device: its number or key in `lutbake devices` (pocl-system, pocl-pypi, intel-pypi), a "
    "runtime (pocl: the first PoCL that builds the kernel), or part of its name (default: the first "
    "device that builds the kernel and passes its self-check, PoCL first, the system's before "
    "PyPI's; PYOPENCL_CTX is honoured).",
)


def axis_option(flag: str, name: str) -> Callable[[F], F]:
    return click.option(
        flag,
        name,
        metavar="A:B:N[:SPACING[:NODES:SCALE]]",
        help=f"{name} axis: N nodes from A to B, uniform, or uniform in sqrt ('sqrt') or in the "
        "4th root ('root4') or in (value + 4th root)/2 ('uniform-root4'), or (eta3 only) "
        "'admittance': uniform in sqrt(eta3^2 - (eta1 sin theta1)^2), or 'sqrt-admittance': "
        "uniform in its square root. NODES:SCALE (opd, eta3, kappa3): the grazing corner's zoom "
        "(docs/lut-format.md). Omitted: that axis of the default set's first LUT, "
        "lutbake-eta2-1.33 (dielectric bases).",
    )


# The flags domain_options gives that lutbake.lut.domain.lut_spec takes.
DOMAIN_FLAGS = (
    "eta2",
    "eta1",
    "cos_theta",
    "opd_nm",
    "eta3",
    "kappa3",
    "space",
    "observer",
    "precision",
    "interpolation",
    "compute",
    "method",
    "samples_per_cycle",
)


def domain_options(f: F) -> F:
    """The flags that define a LUT: film, axes, colour, precision, method, backend, device."""
    opts = [
        click.option("--eta2", type=float, help="Film index (constant, real)."),
        click.option("--eta1", type=float, default=1.0, show_default=True, help="Ambient index."),
        axis_option("--cos-theta", "cos_theta"),
        axis_option("--opd", "opd_nm"),
        axis_option("--eta3", "eta3"),
        axis_option("--kappa3", "kappa3"),
        click.option(
            "--precision",
            type=click.Choice(["float", "half"]),
            default=None,
            help="Storage precision of the EXR (default: float; half for the default set).",
        ),
        click.option(
            "--interpolation",
            type=click.Choice(INTERPOLATIONS),
            default="cubic",
            show_default=True,
            help="How engines read the LUT, recorded in its header: cubic (256 texel reads) or "
            "linear (4 bilinear fetches); docs/lut-format.md#interpolation.",
        ),
        click.option(
            "--compute",
            type=click.Choice(["float64", "float32"]),
            default="float64",
            show_default=True,
            help="Arithmetic precision of the kernel.",
        ),
        click.option(
            "--method",
            type=click.Choice(["spectral"]),
            default="spectral",
            show_default=True,
            help="Integration method (exact spectral Airy reflectance).",
        ),
        click.option(
            "--samples-per-cycle",
            type=float,
            default=None,
            help="Spectral nodes per fringe-bandwidth cycle (default 3: measured |ΔRGB| ≤ 1.2e-6).",
        ),
        backend_option("auto: OpenCL (PoCL first), else numpy with a warning."),
        device_option,
    ]
    for opt in reversed(opts):
        f = opt(f)
    return colour_options(f)
