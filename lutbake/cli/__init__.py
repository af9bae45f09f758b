"""The `lutbake` command line: parse flags, call the library, print.

Exit codes: 0 success; 1 a check or gate failed; 2 bad input (one line on
stderr naming the value and what is allowed; nothing written).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from dataclasses import replace
from pathlib import Path

from lutbake.io.signals import (
    STOP_SIGNALS,
    exit_status,
    interrupted_at_start_up,
    message,
    raise_interrupted,
    set_handler,
)

for _signum in STOP_SIGNALS:
    set_handler(_signum, interrupted_at_start_up)  # until main() runs

import click  # noqa: E402  (after the start-up SIGINT handler)

from lutbake.errors import OpenCLUnavailable  # noqa: E402
from lutbake.io.names import ADMITTANCE_SPACINGS, INTERPOLATIONS, OBSERVERS, SPACES  # noqa: E402

EXIT_GATE, EXIT_BAD_INPUT = 1, 2


class BadInput(click.ClickException):
    exit_code = EXIT_BAD_INPUT

    def show(self, file=None):
        click.echo(f"lutbake: error: {self.message}", err=True)


def main(argv=None):
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


def _flush(stream) -> None:
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
}


def _in_flags(exc: Exception) -> str:
    """The error's one line, with library parameter names shown as the flags that set them."""
    from lutbake.errors import ParameterError

    return exc.render(FLAG_OF_PARAMETER) if isinstance(exc, ParameterError) else str(exc)


def _quiet_broken_pipe():
    """The reader went away (`lutbake inspect X | head -1`): not an error. Point stdout at
    /dev/null so the interpreter's final flush does not fail again."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)


def _print_version(ctx, param, value):
    if value and not ctx.resilient_parsing:
        from lutbake import __version__

        click.echo(f"lutbake, version {__version__}")
        ctx.exit()


@click.group()
@click.option(
    "--version",
    is_flag=True,
    expose_value=False,
    is_eager=True,
    callback=_print_version,
    help="Show the version and exit.",
)
def cli():
    """Bake thin-film iridescence (exact spectral Airy summation) into EXR LUTs."""


def colour_options(f):
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


def progress_options(f):
    """--quiet / --progress: live progress on stderr, shown by default only on a terminal."""
    f = click.option(
        "--progress", "force_progress", is_flag=True, help="Show progress on stderr even when it is not a terminal."
    )(f)
    return click.option("--quiet", is_flag=True, help="No progress on stderr.")(f)


def progress_meter(label, quiet, force_progress):
    """The Meter for a command's progress flags (conflicting flags are refused)."""
    from lutbake.io.progress import meter

    return meter(label, show_progress(quiet, force_progress))


def show_progress(quiet, force_progress):
    """progress.meter's ``show`` for the flags: False, True, or None (on a terminal only)."""
    if quiet and force_progress:
        raise BadInput("--quiet and --progress contradict each other: give one")
    return False if quiet else (True if force_progress else None)


def point_options(f, named=True):
    """Point flags shared by eval and sample (``named``: the --film/--base material flags)."""
    opts = [
        click.option(
            "--points",
            "points_csv",
            type=click.Path(dir_okay=False, allow_dash=True),
            help="CSV of points, '-' for stdin (columns eta1, eta2, thickness_nm|opd_nm, "
            "cos_theta|angle_deg, eta3, kappa3; flags fill columns not given).",
        ),
        click.option("--eta1", type=float, default=None, help="Ambient index (default 1.0)."),
        click.option("--eta2", type=float, help="Film index (real)."),
        click.option("--thickness", "thickness_nm", type=float, help="Film thickness d (nm)."),
        click.option("--opd", "opd_nm", type=float, help="D = 2·η2·d (nm)."),
        click.option("--cos-theta", "cos_theta", type=float, help="cos θ1 in the ambient."),
        click.option("--angle", "angle_deg", type=float, help="θ1 in degrees."),
        click.option("--eta3", type=float, help="Base index, real part."),
        click.option("--kappa3", type=float, default=None, help="Base extinction κ3 ≥ 0 (default 0)."),
    ]
    if named:
        opts += [
            click.option("--film", help="Named film material, any case (`lutbake materials` lists them)."),
            click.option("--base", help="Named base material, any case (e.g. Fe, cu, silver)."),
        ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def constant_point_options(f):
    """Point flags of commands that take constant indices only (sample)."""
    return point_options(f, named=False)


# (flag given, flag it contradicts, why): refused with one line rather than one silently winning.
_POINT_CONFLICTS = (
    ("eta2", "film", "the film index comes from --film"),
    ("eta3", "base", "the base index comes from --base"),
    ("kappa3", "base", "the base extinction comes from --base"),
)


def _refuse_conflicts(flags, conflicts):
    for a, b, why in conflicts:
        if flags.get(a) is not None and flags.get(b) not in (None, False):
            raise BadInput(f"--{a.replace('_', '-')} cannot be combined with --{b}: {why}")


def build_points(points_csv, defaults=None, **flags):
    """FilmPoints from the point flags and --points CSV; ``defaults`` (a LUT's or material's film) fill
    what neither gives."""
    from lutbake.physics.points import FilmPoints

    _refuse_conflicts(flags, _POINT_CONFLICTS)
    given = {k: v for k, v in flags.items() if v is not None}
    if points_csv:
        with _open_points(points_csv) as stream:
            return FilmPoints.from_csv(stream, defaults, **given)
    return FilmPoints.build(**{**(defaults or {}), **given})


@contextlib.contextmanager
def _open_points(points_csv):
    """The --points CSV as a binary stream (stdin for '-'), read line by line by points.read_csv_columns."""
    if points_csv == "-":
        if sys.stdin is None:
            raise BadInput("--points -: stdin is closed: pipe a CSV in or give a file")
        yield sys.stdin.buffer
        return
    try:
        stream = open(points_csv, "rb")
    except OSError as exc:
        raise BadInput(
            f"--points {points_csv!r} cannot be read ({exc.strerror}): give a CSV file or '-' for stdin"
        ) from None
    with stream:
        yield stream


def echo_json(doc):
    from lutbake.io.strictjson import dumps

    click.echo(dumps(doc))


@cli.command("eval")
@point_options
@colour_options
@click.option(
    "--wavelength", "wavelength_nm", type=float, help="Report Rs, Rp, R at one wavelength (nm) instead of colour."
)
@click.option(
    "--fast",
    is_flag=True,
    help="Batch path: the bake's integrator (OpenCL kernel) instead of the converged ground truth; "
    "|ΔRGB| ≤ 3e-6 below the spectral node cap; constant indices only.",
)
@click.option(
    "--backend",
    type=click.Choice(["auto", "opencl", "numpy"]),
    default="auto",
    show_default=True,
    help="With --fast: auto: OpenCL, else numpy with a warning.",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
@progress_options
def eval_cmd(points_csv, space, observer, wavelength_nm, fast, backend, as_json, quiet, force_progress, **flags):
    """Reflectance of film stacks: the converged spectral integral (ground truth), or --fast."""
    from lutbake.physics.points import check_value
    from lutbake.spectral.reference import spectral_reflectance

    points = build_points(points_csv, **flags)
    rows = _point_rows(points)
    if wavelength_nm is not None:
        if fast:
            raise BadInput("--fast computes colour; --wavelength reports R at one wavelength: give one")
        lam = check_value("wavelength_nm", wavelength_nm)
        rs, rp, r = (v[:, 0] for v in spectral_reflectance(points, lam))
        for row, a, b, c in zip(rows, rs, rp, r):
            row.update(wavelength_nm=float(lam[0]), Rs=float(a), Rp=float(b), R=float(c))
    else:
        rgb, xyz = _eval_colours(
            points, observer, space, fast, backend, progress_meter(f"eval {len(points)} points", quiet, force_progress)
        )
        for row, a, b in zip(rows, rgb.tolist(), xyz.tolist()):
            row.update(rgb=a, xyz=b)
    doc = {"space": space, "observer": observer, "method": "fast" if fast else "ground truth", "points": rows}
    if as_json:
        echo_json(doc)
    else:
        _print_eval_table(rows)


def _eval_colours(points, observer, space, fast, backend, meter):
    from lutbake.integrate.batch import fast_colours, truth_colours

    if not fast:
        rgb, xyz = truth_colours(points, observer, space, meter)
        meter.close()
        return rgb, xyz
    rgb, xyz, bound = fast_colours(points, observer, space, backend, meter)
    meter.close()
    if bound.max() > CAPPED_WARNING:
        click.echo(
            f"lutbake: warning: {int((bound > 0).sum())} points need more spectral nodes than the "
            f"cap allows; error bound up to {bound.max():.1e} (omit --fast for the ground truth)",
            err=True,
        )
    return rgb, xyz


def _point_rows(points):
    """One dict per point (columns converted to Python floats once, not per element)."""
    cols = {
        "eta1": points.eta1.tolist(),
        "eta2": [points.film.name] * len(points) if points.film else points.eta2.tolist(),
        "thickness_nm": points.thickness_nm.tolist(),
        "cos_theta": points.cos_theta.tolist(),
    }
    if points.base:
        cols["base"] = [points.base.name] * len(points)
    else:
        cols.update(eta3=points.eta3.tolist(), kappa3=points.kappa3.tolist())
    return [dict(zip(cols, values)) for values in zip(*cols.values())]


def _print_eval_table(rows):
    for row in rows:
        inputs = " ".join(
            f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
            for k, v in row.items()
            if k not in ("rgb", "xyz", "Rs", "Rp", "R")
        )
        if "rgb" in row:
            rgb = " ".join(f"{v:.6f}" for v in row["rgb"])
            xyz = " ".join(f"{v:.6f}" for v in row["xyz"])
            click.echo(f"{inputs}  RGB {rgb}  XYZ {xyz}")
        else:
            click.echo(f"{inputs}  Rs {row['Rs']:.9f}  Rp {row['Rp']:.9f}  R {row['R']:.9f}")


DEFAULT_OUT_DIR = "lutbake-luts"
CAPPED_WARNING = 1e-4  # |ΔRGB| measured at texels past the spectral node cap


def axis_option(flag, name):
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


def _use_device(ctx, param, selector):
    """--device: validate the selector now and make it this process's default device."""
    if selector:
        import os

        from lutbake.integrate.devices import device_label, find_device

        device_label(find_device(selector))
        os.environ["LUTBAKE_DEVICE"] = selector
    return selector


device_option = click.option(
    "--device",
    metavar="N|KEY|TEXT",
    callback=_use_device,
    expose_value=False,
    is_eager=True,
    help="OpenCL device: its number or key in `lutbake devices` (pocl-system, pocl-pypi, intel-pypi), a "
    "runtime (pocl: the first PoCL that builds the kernel), or part of its name (default: the first "
    "device that builds the kernel and passes its self-check, PoCL first, the system's before "
    "PyPI's; PYOPENCL_CTX is honoured).",
)


def domain_options(f):
    """The flags that define a LUT: film, axes, colour, precision, method, backend."""
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
        click.option(
            "--backend",
            type=click.Choice(["auto", "opencl", "numpy"]),
            default="auto",
            show_default=True,
            help="auto: OpenCL (PoCL first), else numpy with a warning.",
        ),
        device_option,
    ]
    for opt in reversed(opts):
        f = opt(f)
    return colour_options(f)


def domain_spec(
    eta2,
    eta1,
    cos_theta,
    opd_nm,
    eta3,
    kappa3,
    space,
    observer,
    precision,
    interpolation,
    compute,
    method,
    samples_per_cycle,
    default_precision="float",
):
    """BakeSpec from domain flags; axes not given take the default set's first LUT's (dielectric bases)."""
    from lutbake.errors import ParameterError
    from lutbake.grid.spec import BakeSpec, parse_axis
    from lutbake.lut.bake import default_specs

    if eta2 is None:
        raise BadInput("--eta2 is required (the film index)")
    given = {"cos_theta": cos_theta, "opd_nm": opd_nm, "eta3": eta3, "kappa3": kappa3}
    template = next(iter(default_specs().values())).axes
    axes = tuple(parse_axis(a.name, given[a.name]) if given[a.name] else _default_axis(a, eta1) for a in template)
    extra = {} if samples_per_cycle is None else {"samples_per_cycle": samples_per_cycle}

    def spec(axes):
        return BakeSpec(
            eta2=eta2,
            eta1=eta1,
            axes=axes,
            space=space,
            observer=observer,
            precision=precision or default_precision,
            interpolation=interpolation,
            compute=compute,
            method=method,
            **extra,
        )

    try:
        return spec(axes)
    except ParameterError:  # the default axes' corner zoom needs the corner in the given domain; without it
        return spec(tuple(a if given[a.name] else replace(a, corner=()) for a in axes))  # (or raise what else)


def _default_axis(axis, eta1: float):
    """A default axis as is, except η3's admittance spacing under an ambient above its low end (where
    that spacing is undefined): uniform there, without the corner zoom (which starts at η3 = η1)."""
    if axis.spacing in ADMITTANCE_SPACINGS and axis.lo < eta1:
        return replace(axis, spacing="uniform", corner=())
    return axis


def scene_source_options(f):
    """--gltf and --metal-mapping: a glTF asset as the scene's source (docs/gltf.md)."""
    f = click.option(
        "--metal-mapping",
        default=None,
        metavar="fitted|threejs|FILE.json",
        help="With --gltf: how a metal's base colour becomes η3 + iκ3 (default fitted; a JSON file "
        "names a lutbake material per glTF material).",
    )(f)
    return click.option(
        "--gltf",
        type=click.Path(dir_okay=False),
        default=None,
        help="glTF asset (.gltf/.glb): bake what its KHR_materials_iridescence materials need.",
    )(f)


@cli.command("bake")
@domain_options
@click.option(
    "--scene", type=click.Path(dir_okay=False), help="Scene manifest (TOML): bake what it needs into --out DIR."
)
@scene_source_options
@click.option("--force", is_flag=True, help="With --scene or --gltf: recompute every slice and LUT.")
@click.option(
    "--out",
    "out",
    type=click.Path(),
    default=None,
    help=f"FILE.exr for one LUT; a folder for the default set (default ./{DEFAULT_OUT_DIR}).",
)
@click.option("--film", "named_film", hidden=True)
@click.option("--base", "named_base", hidden=True)
@progress_options
@click.option("--json", "as_json", is_flag=True, help="Print one JSON summary.")
@click.option(
    "--max-memory-gib",
    type=click.FloatRange(0.5, 4096),
    default=8.0,
    show_default=True,
    help="Refuse grids whose estimated peak memory exceeds this (docs/lut-format.md, Limits).",
)
def bake_cmd(
    eta2,
    eta1,
    cos_theta,
    opd_nm,
    eta3,
    kappa3,
    space,
    observer,
    precision,
    interpolation,
    compute,
    method,
    samples_per_cycle,
    backend,
    scene,
    gltf,
    metal_mapping,
    force,
    out,
    named_film,
    named_base,
    quiet,
    force_progress,
    as_json,
    max_memory_gib,
):
    """Bake the spectral Airy reflectance over (cos θ, D, η3, κ3) into an EXR LUT.

    Without --eta2, bakes the default LUT set into a folder. Named materials
    (--base Cu, --film water) are baked through a scene manifest: --scene.
    """
    from lutbake.lut.bake import default_specs

    if named_film or named_base:
        flag = f"--base {named_base}" if named_base else f"--film {named_film}"
        raise BadInput(
            f"bake has no {flag}: a LUT bakes constant indices (--eta2, --eta3 A:B:N); named materials "
            f"are baked through a scene manifest: lutbake bake --scene FILE.toml --out DIR (docs/scene.md)"
        )
    axis_flags = {"--eta2": eta2, "--cos-theta": cos_theta, "--opd": opd_nm, "--eta3": eta3, "--kappa3": kappa3}
    if scene or gltf:
        given = [f for f, v in axis_flags.items() if v is not None]
        if given:
            flag = "--scene" if scene else "--gltf"
            raise BadInput(f"{given[0]} cannot be combined with {flag}: the {flag[2:]} file sets films and axes")
        return _bake_scene(
            load_scene_source(scene, gltf, metal_mapping),
            out,
            force,
            backend,
            as_json,
            progress_meter("bake scene", quiet, force_progress),
        )
    if force:
        raise BadInput("--force applies to --scene and --gltf bakes only (a LUT bake always recomputes)")
    if metal_mapping is not None:
        raise BadInput("--metal-mapping applies to --gltf only")
    flags = dict(
        eta2=eta2,
        eta1=eta1,
        cos_theta=cos_theta,
        opd_nm=opd_nm,
        eta3=eta3,
        kappa3=kappa3,
        space=space,
        observer=observer,
        precision=precision,
        interpolation=interpolation,
        compute=compute,
        method=method,
        samples_per_cycle=samples_per_cycle,
    )
    if eta2 is None:
        if any((cos_theta, opd_nm, eta3, kappa3)):
            raise BadInput("axis flags need --eta2 (or omit them all to bake the default set)")
        folder = Path(out or DEFAULT_OUT_DIR)
        if folder.suffix.lower() == ".exr":
            raise BadInput(f"--out {str(folder)!r}: the default set goes into a folder, not one .exr")
        common = dict(
            eta1=eta1, space=space, observer=observer, interpolation=interpolation, compute=compute, method=method
        )
        if samples_per_cycle is not None:
            common["samples_per_cycle"] = samples_per_cycle
        jobs = [
            (folder / f"{name}.exr", replace(spec, **common))
            for name, spec in default_specs(precision or "half").items()
        ]
        for _, spec in jobs:
            spec.check_budget(max_memory_gib)
        target = _folder_for(folder)  # then bake_set checks every member's path before any work
    else:
        if out is None:
            raise BadInput("--out FILE.exr is required with --eta2")
        jobs, target = [(Path(out), domain_spec(**flags))], contextlib.nullcontext()
    set_name = "lutbake-default-set" if eta2 is None else jobs[0][0].name
    with target:
        results = _bake_jobs(jobs, set_name, backend, quiet, force_progress, max_memory_gib)
    summary = [_bake_summary(r) for r in results]
    if as_json:
        echo_json({"luts": summary})
        return
    for row in summary:
        click.echo(
            f"wrote {row['path']} ({row['cells']} cells, {row['seconds']:.2f} s, "
            f"{row['cells_per_second']:.3g} cells/s on {row['device']}, "
            f"spectral error ≤ {row['spectral_error_rgb_max']:.1e})"
        )
        if row["capped_error_rgb_max"] > CAPPED_WARNING:
            click.echo(
                f"lutbake: warning: {row['capped_texels']} texels need more spectral nodes than the "
                f"cap allows; measured error up to {row['capped_error_rgb_max']:.1e} "
                f"(bound {row['truncation_bound']:.1e}, recorded in the LUT)",
                err=True,
            )
    if eta2 is None:
        click.echo(f"default LUT set in {jobs[0][0].parent}/")


def load_scene_source(scene_path, gltf, metal_mapping):
    """The scene model from exactly one source, a scene file (TOML) or a glTF asset; the glTF
    mapping's warnings go to stderr, one line each."""
    if bool(scene_path) == bool(gltf):
        raise BadInput("give exactly one of --scene FILE.toml or --gltf ASSET.gltf|.glb")
    if scene_path:
        if metal_mapping is not None:
            raise BadInput("--metal-mapping applies to --gltf only")
        from lutbake.scene.toml import load_scene

        return load_scene(scene_path)
    from lutbake.scene.gltf.materials import load_gltf_scene

    scene = load_gltf_scene(gltf, metal_mapping or "fitted")
    for line in scene.source["asset_warnings"] + [w for r in scene.source["materials"] for w in r["warnings"]]:
        click.echo(f"lutbake: warning: {scene.file_name}: {line}", err=True)
    return scene


def _bake_scene(scene, out, force, backend, as_json, meter):
    from lutbake.scene.bake import bake_scene

    if out is None:
        raise BadInput("--out DIR is required with --scene or --gltf")
    if Path(out).suffix.lower() == ".exr":
        raise BadInput(f"--out {out!r}: a scene bakes into a folder")
    result = bake_scene(scene, out, force, backend, meter)  # checks every output before it makes the folder
    meter.close("up to date" if result.up_to_date else "done")
    doc = {
        "out": str(result.out_dir),
        "up_to_date": result.up_to_date,
        "computed": result.computed,
        "reused": result.reused,
        "written": [str(p) for p in result.written],
        "seconds": result.seconds,
        "target_unmet": result.unmet,
        "device": result.device,
    }
    if as_json:
        echo_json(doc)
    elif result.up_to_date:
        click.echo(f"{scene.path}: up to date in {out}/ (nothing written)")
    else:
        click.echo(
            f"{scene.path}: computed {len(result.computed)}, reused {len(result.reused)}, "
            f"wrote {len(result.written)} files to {out}/ in {result.seconds:.1f} s"
        )
    if result.unmet:
        reached = ", ".join(
            f"{name} p99 ΔE00 {r['de00_p99']:.3f} (bound {r['de00_p99_bound']:.3f})" for name, r in result.unmet.items()
        )
        click.echo(
            f"lutbake: target p99 ΔE00 ≤ {scene.max_de:g} not met at the resolution cap: {reached} "
            "(written; see docs/scene.md)",
            err=True,
        )
        return EXIT_GATE
    return 0


@cli.command("plan")
@click.option(
    "--scene", "scene_path", type=click.Path(dir_okay=False), default=None, help="Scene manifest (TOML) to plan."
)
@scene_source_options
@click.option("--json", "as_json", is_flag=True, help="Print the plan as one JSON document.")
def plan_cmd(scene_path, gltf, metal_mapping, as_json):
    """What `bake --scene` or `bake --gltf` would bake: slices, axes, counts, bytes, and time (bakes nothing).

    The time is the ground truth at each job's held-out points, the bulk of a scene bake, at a
    rate measured now, here; the grids themselves go through the bake's integrator.
    """
    from lutbake.io.progress import format_seconds
    from lutbake.scene.plan import plan_scene, truth_rate

    scene = load_scene_source(scene_path, gltf, metal_mapping)
    plan = plan_scene(scene)
    rate = truth_rate(plan)
    doc = plan.describe(rate)
    doc["seconds_per_truth_point"] = rate
    if gltf:
        from lutbake.scene.gltf.materials import material_rows

        doc["gltf_materials"] = material_rows(scene, plan)
    if as_json:
        echo_json(doc)
        return
    s = doc["settings"]
    click.echo(
        f"{scene.path}: {s['space']} / {s['observer']}, ambient η1 {s['eta1']:g}, {s['precision']}, "
        f"target p99 ΔE00 ≤ {s['max_de']:g}"
    )
    for job in doc["jobs"]:
        shape = " × ".join(str(c) for c in job["counts"])
        click.echo(
            f"  {job['id']}: {job['kind']} {shape} for {', '.join(job['materials'])} — "
            f"{job['bytes_start']} bytes, ~{format_seconds(job['truth_seconds_estimate'])} of ground truth"
        )
    for row in doc.get("gltf_materials", []):
        served = row["slice"] or row["lut"] or f"nothing: {row['why_not']}"
        click.echo(f"  glTF material {row['gltf_index']} {row['name']!r}: {served}")
    total = sum(j["truth_seconds_estimate"] for j in doc["jobs"])
    click.echo(
        f"total {doc['bytes_start_total']} bytes at the starting counts (slices grow until the target "
        f"holds); a generic 4D LUT would take {doc['generic_4d_bytes']} bytes"
    )
    click.echo(
        f"time ~{format_seconds(total)} of ground truth at the held-out points, from {rate * 1e3:.1f} ms per "
        "point measured on this machine just now, plus the integration and the OpenCL start-up"
    )


def _make_folder(folder: Path):
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BadInput(f"--out folder {str(folder)!r} cannot be created: {exc.strerror}") from None


@contextlib.contextmanager
def _folder_for(folder: Path):
    """The --out folder, made if missing, and removed again if it is still empty when the block fails
    (a device that cannot run, an interrupt): a failed bake leaves nothing behind."""
    made = not folder.exists()
    _make_folder(folder)
    try:
        yield
    except BaseException:
        if made:
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise


_PROGRESS_BANDS = 32  # bands per bake: the first lands within ~2 s and the ETA settles early


def _bake_jobs(jobs, set_name, backend, quiet, force_progress, max_memory_gib):
    """Bake (path, spec) jobs as one file set (all committed or none), band by band; a progress line per
    LUT shows rows done and the ETA from the measured rate."""
    from lutbake.io.progress import meter as make_meter
    from lutbake.lut.bake import bake_set

    show = show_progress(quiet, force_progress)

    def options(path, spec):
        width, height = spec.image_size
        rows_per_band = min(spec.row_chunks()[0][1], -(-height // _PROGRESS_BANDS))  # never above the memory bound
        meter, done = None, 0

        def on_band(rows, total):  # called with 0 rows when this LUT's bake starts: its clock starts then
            nonlocal meter, done
            meter = meter or make_meter(f"baking {path.name}", show)
            done += rows
            meter(done, total, "rows" if done else "measuring the spectral rule's error at probe cells")
            if done == total:
                meter.close()

        return {"on_band": on_band, "chunk_cells": rows_per_band * width}

    return bake_set([(path, spec, options(path, spec)) for path, spec in jobs], set_name, backend, max_memory_gib)


def _bake_summary(result):
    return {
        "path": str(result.path),
        "cells": result.cells,
        "seconds": result.seconds,
        "cells_per_second": result.cells_per_second,
        "backend": result.backend,
        "device": result.device,
        "spectral_error_rgb_max": result.spectral_error_rgb_max,
        "capped_texels": result.capped_texels,
        "truncation_bound": result.truncation_bound,
        "capped_error_rgb_max": result.capped_error_rgb_max,
    }


@cli.command("exact-table")
@colour_options
@click.option("--out", "out", type=click.Path(), required=True, help="FILE.exr (with FILE.json, .glsl, .hlsl).")
@click.option(
    "--precision",
    type=click.Choice(["float", "half"]),
    default="float",
    show_default=True,
    help="Storage precision of the table (half: ~5e-4 per value, see docs/engines.md).",
)
@click.option(
    "--tolerance", type=float, default=None, help="The includes' default truncation tolerance in |ΔRGB| (default 1e-4)."
)
@click.option("--max-terms", type=int, default=None, help="The includes' default term cap (default 64).")
@click.option("--json", "as_json", is_flag=True, help="Print the table's metadata as JSON.")
def exact_table_cmd(space, observer, out, precision, tolerance, max_terms, as_json):
    """Write the exact runtime mode's table (Fourier transform of the colour weights) and its includes.

    Shaders call lutbake_exact(table, cos θ, d, η1, η2, η3, κ3): the exact series per pixel, any
    film and base index, no LUT domain (docs/engines.md).
    """
    from lutbake.modes.exact import DEFAULT_MAX_TERMS, DEFAULT_TOLERANCE, write_exact_table

    if Path(out).suffix.lower() != ".exr":
        raise BadInput(f"--out {out!r} must end in .exr")
    meta = write_exact_table(
        out,
        observer,
        space,
        precision,
        DEFAULT_TOLERANCE if tolerance is None else tolerance,
        DEFAULT_MAX_TERMS if max_terms is None else max_terms,
    )
    if as_json:
        echo_json(meta)
        return
    table = meta["table"]
    click.echo(
        f"wrote {out} ({table['texels']} texels, step {table['step_nm']:g} nm to {table['x_max_nm']:g} nm, "
        f"{precision}; interpolation ≤ {meta['error']['interpolation_bound']:.1e}, "
        f"storage ≤ {meta['error']['storage_max']:.1e}) with .json, .glsl, .hlsl"
    )


@cli.command("runtime-table")
@colour_options
@click.option("--out", "out", type=click.Path(), required=True, help="FILE.exr (with FILE.json, .glsl, .hlsl).")
@click.option("--json", "as_json", is_flag=True, help="Print the table's metadata as JSON.")
def runtime_table_cmd(space, observer, out, as_json):
    """Write the runtime table and its includes: any film, any base, 6 bilinear reads per pixel.

    Shaders call lutbake_iridescence(table, cos θ, d, η1, η2, η3, κ3) or lutbake_iridescence_rgb(…, η3
    and κ3 per channel): the film's linear RGB Fresnel term (docs/engines.md).
    """
    from lutbake.modes.runtime import write_runtime_table

    meta = write_runtime_table(out, observer, space)
    if as_json:
        echo_json(meta)
        return
    table = meta["table"]
    click.echo(
        f"wrote {out} ({table['width']}×{table['height']} RGBA half texels, {table['slices']} slices of "
        f"{table['nodes']}² to X {table['x_max_nm']:g} nm) with .json, .glsl, .hlsl"
    )


@cli.command("blender")
@click.argument("manifest", type=click.Path(dir_okay=False), required=False)
@click.option("--out", "out", type=click.Path(), required=True, help="LIB.blend: the node groups and materials.")
@click.option(
    "--exact",
    type=click.Path(dir_okay=False),
    default=None,
    help="An exact-table EXR: add material 'lutbake exact' (OSL, Cycles), any film and base.",
)
@click.option(
    "--runtime-table",
    "runtime_table",
    type=click.Path(dir_okay=False),
    default=None,
    help="A runtime-table EXR: add material 'lutbake runtime' (OSL, Cycles), any film and base.",
)
@click.option(
    "--blender",
    default=None,
    help="A Blender executable, or a Python with bpy (default: $LUTBAKE_BLENDER, then blender on PATH).",
)
@click.option("--link", is_flag=True, help="Reference the EXRs by relative path instead of packing them.")
@click.option(
    "--verify",
    is_flag=True,
    help="Render every material in Cycles at probe angles; exit 1 if "
    "any differs from `lutbake sample` (the OSL materials: their numpy evaluation) by more than 1e-3.",
)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
def blender_cmd(manifest, out, exact, runtime_table, blender, link, verify, as_json):
    """Node groups that render a scene bake in Blender (Cycles and EEVEE): docs/blender.md."""
    from lutbake.blender.library import BlenderError, verify_library, verify_osl, write_library

    tables = {"exact": exact, "runtime": runtime_table}
    try:
        doc = write_library(manifest, out, blender, pack=not link, exact=exact, runtime_table=runtime_table)
        checks = {
            "verify": lambda: verify_library(manifest, out, doc["blender"]) if manifest else None,
            **{
                f"verify_{kind}": lambda kind=kind: verify_osl(out, kind, tables[kind], doc["blender"])
                for kind in doc["osl_materials"]
            },
        }
        doc.update({key: check() for key, check in checks.items()} if verify else {})
    except BlenderError as exc:
        click.echo(f"lutbake: error: {exc}", err=True)
        return EXIT_GATE
    verified = [v for k, v in doc.items() if k.startswith("verify") and v]
    if as_json:
        echo_json(doc)
    else:
        if doc["groups"]:
            click.echo(
                f"wrote {out}: {len(doc['groups'])} node groups and materials ({', '.join(doc['groups'].values())}); "
                f"working colour space {doc['working_space']} (a file that appends them must use it too)"
            )
        for kind, name in doc["osl_materials"].items():
            click.echo(
                f"wrote {out}: material {name!r} (OSL: Cycles with Open Shading Language on) reading {tables[kind]}"
            )
        for v in verified:
            click.echo(
                f"{v['engine']} at {v['points']} probes: max |ΔRGB| {v['max_abs_rgb']:.1e} against lutbake "
                f"({'within' if v['ok'] else 'ABOVE'} {v['tolerance']:g})"
            )
    return EXIT_GATE if not all(v["ok"] for v in verified) else 0


@cli.command("inspect")
@click.argument("lut", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the metadata as JSON.")
def inspect_cmd(lut, as_json):
    """Show a LUT's or scene atlas's metadata (read from the EXR header alone)."""
    from lutbake.lut.sample import Atlas, load_table

    table = load_table(lut)
    meta = table.meta
    if as_json:
        echo_json(meta)
        return
    if isinstance(table, Atlas):
        _print_atlas(lut, table)
        return
    packing = meta["packing"]
    click.echo(f"{lut}: {meta['format']} v{meta['format_version']} (lutbake {meta['lutbake_version']})")
    click.echo(f"  film eta2 = {meta['constants']['eta2']!r}, ambient eta1 = {meta['constants']['eta1']!r}")
    click.echo(
        f"  {meta['space']} linear RGB, {meta['observer']}, illuminant {meta['illuminant']}, "
        f"{meta['precision']} storage, {meta['compute']} compute"
    )
    for a in meta["axes"]:
        click.echo(
            f"  axis {a['name']:<9} [{a['min']!r}, {a['max']!r}] x {a['count']} ({a['spacing']}, unit {a['unit']})"
        )
    click.echo(
        f"  image {packing['width']} x {packing['height']}: tiles of {packing['tile_x']} x {packing['tile_y']}"
        f" ({packing['tile_width']} x {packing['tile_height']}), laid out by {packing['tiles_x']} x {packing['tiles_y']}"
    )
    spectral = meta["spectral"]
    click.echo(
        f"  spectral: {spectral['rule']}, {spectral['counts'][0]}-{spectral['counts'][-1]} nodes per texel, "
        f"measured error |ΔRGB| ≤ {spectral['error_rgb_max']:.1e}"
    )
    if spectral.get("capped_texels"):
        click.echo(
            f"  past the node cap: {spectral['capped_texels']} texels, bound |ΔRGB| ≤ "
            f"{spectral['truncation_bound_rgb']:.1e}, measured ≤ {spectral['capped_error_rgb_max']:.1e}"
        )
    if "integrator" in meta:
        mix = meta["integrator"]
        closed = (
            f", poles' closed form at {mix['closed_form_texels']} (bound ≤ {mix['closed_form_bound_rgb_max']:.1e})"
            if "closed_form_texels" in mix
            else ""
        )
        click.echo(
            f"  integrator: Fourier series at {mix['series_texels']} texels (bound |ΔRGB| ≤ "
            f"{mix['series_bound_rgb_max']:.1e}){closed}, direct rule at {mix['direct_texels']}"
        )
    click.echo(f"  content hash {meta['content_hash']}")


@cli.command("materials")
@click.option("--json", "as_json", is_flag=True, help="Print the list as one JSON document.")
def materials_cmd(as_json):
    """Named materials for --film/--base (any case) and the wavelengths their data cover."""
    from lutbake.physics.materials import ALIASES, material

    rows, pages = [], set()
    for name, page in ALIASES.items():  # short names come first; long ones are their aliases
        if page in pages:
            continue
        pages.add(page)
        mat = material(name)
        rows.append(
            {
                "name": name,
                "aliases": [a for a, p in ALIASES.items() if p == page and a != name],
                "source": "refractiveindex.info " + "/".join(page),
                "covered_nm": list(mat.covered_nm),
                "held_constant_nm": [list(span) for span in mat.extrapolated_nm],
            }
        )
    if as_json:
        echo_json({"materials": rows, "also": "any refractiveindex.info page as shelf/book/page"})
        return
    for r in rows:
        aliases = f" ({', '.join(r['aliases'])})" if r["aliases"] else ""
        lo, hi = r["covered_nm"]
        held = (
            "; held constant over " + ", ".join(f"{a:.0f}–{b:.0f} nm" for a, b in r["held_constant_nm"])
            if r["held_constant_nm"]
            else ""
        )
        click.echo(f"{r['name']:<8}{aliases:<14} {r['source']}, data {lo:.0f}–{hi:.0f} nm{held}")
    click.echo("Names match in any case; any refractiveindex.info page works as shelf/book/page.")


@cli.command("sample")
@click.argument("lut", type=click.Path())
@constant_point_options
@click.option(
    "--filter-bits",
    type=click.IntRange(1, 24),
    default=None,
    help="Quantize bilinear weights as a GPU texture unit does (e.g. 8).",
)
@click.option(
    "--interpolation",
    type=click.Choice(INTERPOLATIONS),
    default=None,
    help="Read a 4D LUT by this rule instead of its header's (docs/lut-format.md#interpolation).",
)
@click.option("--material", help="With a scene atlas: the material whose slice to sample.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
def sample_cmd(lut, points_csv, filter_bits, interpolation, material, as_json, **flags):
    """Sample a LUT or a scene atlas as a GPU would (reference sampler)."""
    from lutbake.lut.sample import Atlas, load_table

    table = load_table(lut)
    if isinstance(table, Atlas):
        return _sample_atlas(lut, table, material, points_csv, filter_bits, as_json, flags)
    if material is not None:
        raise BadInput(f"--material {material!r} is for scene atlases; {lut!r} is a 4D LUT")
    interpolation = interpolation or table.interpolation
    if filter_bits is not None and interpolation == "cubic":
        raise BadInput(
            f"--filter-bits {filter_bits} applies to linear reads; {lut!r} is read cubic "
            f"(texel reads without filtering): add --interpolation linear"
        )
    # the LUT's film unless given (Lut.sample refuses another)
    points = build_points(points_csv, {"eta1": table.eta1, "eta2": table.eta2}, **flags)
    rgb = table.sample(points, filter_bits, interpolation)
    inside = table.in_domain(points)
    opd = points.opd_nm
    rows = []
    for i in range(len(points)):
        rows.append(
            {
                "cos_theta": float(points.cos_theta[i]),
                "opd_nm": float(opd[i]),
                "eta3": float(points.eta3[i]),
                "kappa3": float(points.kappa3[i]),
                "rgb": rgb[i].tolist(),
                "in_domain": bool(inside[i]),
            }
        )
    if as_json:
        echo_json({"lut": str(lut), "space": table.meta["space"], "interpolation": interpolation, "points": rows})
        return
    _echo_samples(rows, ("cos_theta", "opd_nm", "eta3", "kappa3"), "outside the LUT")


def _echo_samples(rows, columns, outside):
    for row in rows:
        note = "" if row["in_domain"] else f"  ({outside}: clamped)"
        click.echo(
            " ".join(f"{k}={row[k]:g}" for k in columns) + "  RGB " + " ".join(f"{v:.6f}" for v in row["rgb"]) + note
        )


def _print_atlas(path, atlas):
    meta = atlas.meta
    height, width, _ = atlas.image.shape
    click.echo(f"{path}: {meta['format']} v{meta['format_version']}, scene hash {meta['scene_hash'][:16]}")
    click.echo(
        f"  {meta['space']} linear RGB, {meta['observer']}, {meta['precision']} storage, "
        f"ambient eta1 = {meta['eta1']!r}, image {width} x {height}"
    )
    for name, s in atlas.materials.items():
        th = s["axes"]["thickness_nm"]
        click.echo(
            f"  material {name}: rect {s['rect']} (cos_theta sqrt x {s['rect'][2]}, thickness_nm "
            f"[{th['min']!r}, {th['max']!r}] x {th['count']}), film {s['film']}, base {s['base']}"
        )


def _sample_atlas(path, atlas, material, points_csv, filter_bits, as_json, flags):
    """Sample one material's slice at (cos θ, thickness); the film and base come from the atlas."""
    if material is None:
        raise BadInput(f"--material is required with a scene atlas: allowed {', '.join(atlas.materials)}")
    atlas.slice_of(material)  # an unknown name fails here, naming the allowed ones
    given = [k for k in ("eta1", "eta2", "opd_nm", "eta3", "kappa3", "film", "base") if flags.get(k) is not None]
    if given:
        raise BadInput(
            f"--{given[0].replace('_nm', '')} is not allowed with a scene atlas: the material "
            f"{material!r} fixes it; give --thickness and --angle/--cos-theta"
        )
    points = build_points(points_csv, atlas.film_stack(material), **flags)
    rgb = atlas.sample(material, points, filter_bits)
    inside = atlas.in_domain(material, points)
    rows = [
        {"cos_theta": float(c), "thickness_nm": float(t), "rgb": v.tolist(), "in_domain": bool(i)}
        for c, t, v, i in zip(points.cos_theta, points.thickness_nm, rgb, inside)
    ]
    if as_json:
        echo_json({"atlas": str(path), "material": material, "space": atlas.meta["space"], "points": rows})
        return
    _echo_samples(rows, ("cos_theta", "thickness_nm"), "outside the slice")


@cli.command("report")
@click.argument("lut", type=click.Path())
@click.option(
    "--points",
    "n_points",
    type=click.IntRange(10, 1_000_000),
    default=1000,
    show_default=True,
    help="Held-out points: half uniform over the domain, half at centres of random cells "
    "(where interpolation error peaks; `sweep`/`tune` score uniform points only).",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the held-out points.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), help="Folder for report.html, PNGs, summary.json.")
@click.option("--max-de", type=float, default=None, help="Gate: exit 1 when p99 ΔE00 exceeds this.")
@click.option("--no-approximations", is_flag=True, help="Skip the engine-approximation rows.")
@click.option(
    "--search-budget",
    type=click.IntRange(100, 10_000_000),
    default=None,
    help="Evaluations of each row's worst-case search (its max is searched over the whole domain); "
    "default 20000 for a LUT, 2000 per slice of a scene atlas (searched against the ground truth).",
)
@click.option("--json", "as_json", is_flag=True, help="Print the summary as one JSON document.")
@progress_options
def report_cmd(lut, n_points, seed, out_dir, max_de, no_approximations, search_budget, as_json, quiet, force_progress):
    """How wrong a LUT or scene atlas is: ΔE00 against the ground truth at held-out points, max searched."""
    from lutbake.lut.sample import Atlas, load_table
    from lutbake.quality.report import REPORT_FILES, SEARCH_BUDGET, SLICE_SEARCH_BUDGET, gate, report_lut, write_report

    if max_de is not None and not max_de > 0:
        raise BadInput(f"--max-de {max_de!r} is not allowed: must be a number > 0")
    if out_dir:
        refuse_overwriting_inputs({"LUT": lut}, [Path(out_dir) / name for name in REPORT_FILES])
    if Path(lut).suffix.lower() == ".json":  # a glTF bake's manifest: one receipt per glTF material
        return _gltf_receipts(lut, n_points, seed, out_dir, as_json)
    table = load_table(lut)
    meter = progress_meter(f"report {Path(lut).name}", quiet, force_progress)
    if isinstance(table, Atlas):
        summary = gate(
            _atlas_summary(table, lut, n_points, seed, out_dir, search_budget or SLICE_SEARCH_BUDGET), max_de
        )
        rows = summary["slices"]
    else:
        rep = report_lut(
            lut,
            n_points,
            seed,
            approximations=not no_approximations,
            progress=meter,
            search_budget=search_budget or SEARCH_BUDGET,
        )
        summary = write_report(rep, out_dir, max_de=max_de, progress=meter) if out_dir else gate(rep.summary(), max_de)
        rows = summary["approximations"]
    meter.close()
    p99 = summary["lut_error"]["de00_p99"]
    gate_failed = max_de is not None and not summary["gate"]["passed"]
    if as_json:
        echo_json(summary)
    else:
        _print_error_rows([summary["lut_error"]] + rows, summary)
        if summary.get("runtime_paths"):
            from lutbake.modes.runtime.costs import cost_table_text

            click.echo(cost_table_text(summary["runtime_paths"]))
        worst = summary["lut_error"]["worst_case"]
        where = " ".join(
            f"{k}={worst[k]:.5g}" for k in ("cos_theta", "opd_nm", "thickness_nm", "eta3", "kappa3") if k in worst
        )
        click.echo(
            f"max is searched over the whole domain ({worst['budget']} evaluations a row); the largest: "
            f"ΔE00 {worst['de00_max']:.3f} at {where} ({worst['found_by']}; the held-out points' largest "
            f"{worst['held_out_max']:.3f})"
        )
        if out_dir:
            click.echo(f"report in {out_dir}/{'summary.json' if isinstance(table, Atlas) else 'report.html'}")
        if max_de is not None:
            click.echo(
                f"gate p99 ΔE00 {p99:.3f} {'>' if gate_failed else '<='} {max_de:g}: "
                f"{'FAIL' if gate_failed else 'pass'}"
            )
    return EXIT_GATE if gate_failed else 0


def _gltf_receipts(manifest, n_points, seed, out_dir, as_json):
    """`report OUT/ASSET.json`: the receipts of a glTF bake (lutbake/scene/gltf/receipt.py), as JSON and HTML in --out."""
    from lutbake.scene.gltf.receipt import gltf_receipts, write_receipts

    receipts = gltf_receipts(manifest, min(n_points, 1000), seed)
    if out_dir:
        write_receipts(receipts, out_dir)
    if as_json:
        echo_json(receipts)
        return 0
    for r in receipts["materials"]:
        costs = "; ".join(
            f"{part}: baked p99 {p['de00']['baked']['de00_p99']:.2f}, three.js p99 "
            f"{p['de00']['threejs']['de00_p99']:.2f}"
            for part, p in r["parts"].items()
        )
        click.echo(f"material {r['gltf_index']} {r['name']!r}: {costs or r['why_not']}")
    if out_dir:
        click.echo(f"receipts in {out_dir}/receipts.html and receipts.json")
    return 0


def _atlas_summary(atlas, path, n_points, seed, out_dir, search_budget) -> dict:
    """Per-slice ΔE00 of a scene atlas as stored; summary.json in out_dir when given."""
    from lutbake.io.strictjson import dumps
    from lutbake.quality.report import REPORT_FILES, report_atlas
    from lutbake.tables.lutfile import write_text_atomic

    summary = report_atlas(atlas, path, n_points, seed, search_budget)
    if out_dir:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        write_text_atomic(Path(out_dir) / REPORT_FILES[0], dumps(summary) + "\n")
    return summary


def refuse_overwriting_inputs(inputs: dict, outputs) -> None:
    """Exit 2 when a file a command would write is one of its inputs (``inputs``: what to call it → path),
    the same file by any path or hard link, before anything is written."""
    for what, path in inputs.items():
        for out in outputs:
            if _same_file(Path(path), Path(out)):
                raise BadInput(
                    f"{what} {str(path)!r} would be overwritten by the output {str(out)!r}: write the output elsewhere"
                )


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist (yet): compare where they would be
        return a.resolve() == b.resolve()


def _print_error_rows(rows, summary):
    kinds = " + ".join(f"{n} {k}" for k, n in summary.get("point_kinds", {}).items())
    click.echo(
        f"ΔE00 against the ground truth at {summary['points']} held-out points" + (f" ({kinds})" if kinds else "")
    )
    click.echo(f"  {'method':<26}{'mean':>8}{'p50':>8}{'p95':>8}{'p99':>8}{'max':>8}{'max|ΔRGB|':>11}")
    for r in rows:
        click.echo(
            f"  {r['name']:<26}{r['de00_mean']:8.3f}{r['de00_p50']:8.3f}{r['de00_p95']:8.3f}"
            f"{r['de00_p99']:8.3f}{r['de00_max']:8.3f}{r['rgb_abs_max']:11.2e}"
        )


def search_budget_option(default: int):
    """--search-budget of sweep and tune: evaluations of each searched max (report.search_max)."""
    return click.option(
        "--search-budget",
        type=click.IntRange(100, 10_000_000),
        default=default,
        show_default=True,
        help="Evaluations of each searched max (over the whole domain).",
    )


def held_out_options(default_points: int, help_text: str):
    """--points/--seed of sweep and tune."""

    def options(f):
        f = click.option("--seed", type=int, default=0, show_default=True, help="Seed of the held-out points.")(f)
        return click.option(
            "--points",
            "n_points",
            type=click.IntRange(10, 1_000_000),
            default=default_points,
            show_default=True,
            help=help_text,
        )(f)

    return options


@cli.command("sweep")
@domain_options
@click.option(
    "--out", "out_dir", type=click.Path(file_okay=False), required=True, help="Folder for sweep.json and pareto.png."
)
@held_out_options(
    600,
    "Held-out points, uniform over the domain (no cell centres: the variants' grids differ), "
    "so p99 reads lower than `report`'s on the same LUT.",
)
@search_budget_option(5000)
@click.option("--json", "as_json", is_flag=True, help="Print the rows as one JSON document.")
@progress_options
def sweep_cmd(out_dir, n_points, seed, search_budget, as_json, quiet, force_progress, backend, **flags):
    """Error against bake time and bytes over LUT variants of one domain, plus engine approximations."""
    from lutbake.quality.sweep import sweep

    meter = progress_meter("sweep", quiet, force_progress)
    doc = sweep(domain_spec(**flags), out_dir, n_points, seed, backend, progress=meter, search_budget=search_budget)
    meter.close()
    if as_json:
        echo_json(doc)
        return
    click.echo(f"p99 ΔE00 at {doc['points']} {doc['point_kind']} held-out points (`report` adds cell centres)")
    click.echo(f"  {'variant':<26}{'shape':>16}{'p99 ΔE00':>10}{'bake s':>9}{'bytes':>11}{'ns/eval':>9}")
    for r in doc["rows"]:
        lut_cols = (
            f"{r['shape']:>16}{r['de00_p99']:10.3f}{r['bake_seconds']:9.2f}{r['bytes']:11d}{'':>9}"
            if r["kind"] == "lut"
            else f"{'(no LUT)':>16}{r['de00_p99']:10.3f}{'':>9}{'':>11}{r['ns_per_eval']:9.0f}"
        )
        click.echo(f"  {r['name']:<26}{lut_cols}")
    click.echo(f"Pareto plot in {out_dir}/pareto.png")


@cli.command("tune")
@domain_options
@click.option("--max-de", type=float, required=True, help="Target p99 ΔE00, as `report --max-de` gates it.")
@held_out_options(
    1000, "Held-out points per trial, as `report` scores them: half uniform, half at centres of the trial grid's cells."
)
@search_budget_option(20000)
@click.option("--json", "as_json", is_flag=True, help="Print the rounds and result as one JSON document.")
@progress_options
def tune_cmd(max_de, n_points, seed, search_budget, as_json, quiet, force_progress, backend, **flags):
    """Smallest per-axis counts whose p99 ΔE00 meets --max-de (exit 1 if not reached).

    Each accepted round is printed as it happens (with --json: one document at the end).
    """
    from lutbake.quality.refine import tune, tune_document

    if not max_de > 0:
        raise BadInput(f"--max-de {max_de!r} is not allowed: must be a number > 0")
    meter = progress_meter("tune", quiet, force_progress)

    def print_round(trial):
        r = trial.row()
        meter.clear()
        click.echo(
            f"  {r['shape']:>16}  p99 ΔE00 {r['de00_p99']:.3f}  bound {r['de00_p99_bound']:.3f}  "
            f"bake {r['bake_seconds']:.2f} s  {r['bytes']} bytes"
        )

    if not as_json:
        click.echo(
            f"p99 ΔE00 at {n_points} held-out points (half at each trial grid's cell centres) and the bound "
            f"the target holds (the 99.73th percentile: a fresh report's p99 stays below it at 99 % of "
            f"seeds), round by round (bytes: the texture as stored):"
        )
    spec = domain_spec(**flags)
    result = tune(
        spec,
        max_de,
        n_points,
        seed,
        backend,
        progress=meter,
        on_round=None if as_json else print_round,
        search_budget=search_budget,
    )
    meter.close()
    doc = tune_document(spec, result)
    if as_json:
        echo_json(doc)
    else:
        from lutbake.grid.spec import axis_from_header

        best = doc["result"]
        axes = " ".join(
            f"--{n} {axis_from_header(a).flag()}" for n, a in zip(("cos-theta", "opd", "eta3", "kappa3"), doc["axes"])
        )
        state = "met" if result.met else "NOT met"
        click.echo(
            f"target p99 ΔE00 ≤ {max_de:g} {state}: {axes} --interpolation {doc['interpolation']} "
            f"(p99 {best['de00_p99']:.3f}, bound {best['de00_p99_bound']:.3f}, searched max "
            f"{best['de00_max']:.3f}, bake {best['bake_seconds']:.2f} s, {best['bytes']} bytes)"
        )
    return 0 if result.met else EXIT_GATE


@cli.command("check")
@click.option(
    "--backend",
    type=click.Choice(["auto", "opencl", "numpy"]),
    default="auto",
    show_default=True,
    help="Integrator checked: auto: OpenCL, else numpy with a warning.",
)
@device_option
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
@progress_options
def check_cmd(backend, as_json, quiet, force_progress):
    """Stiff and extreme cases: every path finite and accurate (exit 1 on any failure)."""
    from lutbake.integrate.opencl import backend as make_backend
    from lutbake.quality.check import run_checks

    fast = make_backend(backend)  # one backend: one fallback warning, the device named below
    device = fast.device
    meter = progress_meter("check", quiet, force_progress)
    results = run_checks(fast, progress=meter)
    meter.close()
    failed = [r for r in results if not r.passed]
    if as_json:
        echo_json({"passed": not failed, "device": device, "checks": [r.as_dict() for r in results]})
    else:
        click.echo(f"fast path on {device}")
        group = None
        for r in results:
            if r.group != group:
                group = r.group
                click.echo(f"{group}:")
            mark = "PASS" if r.passed else "FAIL"
            click.echo(
                f"  {mark} {r.name}: value {r.value:.9g}, reference {r.reference:.9g}, "
                f"error {r.error:.2e} (tolerance {r.tolerance:.1e}){'; ' + r.note if r.note else ''}"
            )
        click.echo(f"{len(results) - len(failed)} passed, {len(failed)} failed")
    return EXIT_GATE if failed else 0


@cli.command("devices")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
@click.option(
    "--icd-folder",
    is_flag=True,
    help="Write a vendor folder registering Intel's CPU runtime (the cpu extra) beside the system's runtimes, "
    "in lutbake's cache folder, and print its path: export OCL_ICD_VENDORS=$(lutbake devices --icd-folder).",
)
def devices_cmd(as_json, icd_folder):
    """OpenCL devices: does each build the kernel and pass its self-check, and how fast is it."""
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.integrate.icd import SYSTEM_VENDORS, intel_vendor_folder, unregistered_intel
    from lutbake.integrate.survey import survey_devices

    if icd_folder:
        from lutbake.io.usercache import _folder

        cache = _folder()
        if cache is None:
            raise ValueError("no writable cache folder for the vendor folder (set LUTBAKE_CACHE_DIR)")
        click.echo(intel_vendor_folder(cache, Path(os.environ.get("OPENCL_VENDOR_PATH") or SYSTEM_VENDORS)))
        return

    probe = BakeSpec(
        eta2=1.5,
        axes=(
            Axis("cos_theta", 0.0, 1.0, 32, "sqrt"),
            Axis("opd_nm", 0.0, 3000.0, 128),
            Axis("eta3", 1.0, 3.0, 4),
            Axis("kappa3", 0.0, 5.0, 4, "sqrt"),
        ),
    )
    rows, unregistered = survey_devices(probe), unregistered_intel()
    if as_json:
        echo_json(
            {"throughput_cells": probe.cells, "devices": rows, "unregistered_intel": unregistered and str(unregistered)}
        )
        return
    for row in rows:
        if row["index"] is None:
            click.echo(f"no OpenCL device: {row['error']}")
            continue
        head = f"{row['index']} {row['key']}: {row['label']}{' (default)' if row['default'] else ''}"
        builds = [compute for compute in ("float64", "float32") if row[compute]["builds"]]
        if not builds and row["float64"]["error"] == row["float32"]["error"]:  # one reason: one line
            click.echo(f"{head}: {row['float64']['error']}")
            continue
        click.echo(head)
        for compute in ("float64", "float32"):
            r = row[compute]
            state = (
                f"builds, self-check |ΔR| {r['self_check_error']:.1e}" if r["builds"] else f"not usable: {r['error']}"
            )
            click.echo(f"    {compute}: {state}")
        if "cells_per_second" in row:
            click.echo(f"    {row['cells_per_second']:.3g} cells/s (float64, {probe.cells} cells over D 0–3000 nm)")
    if unregistered:
        click.echo(
            f"Intel's OpenCL CPU runtime ({unregistered}) is installed but not registered: "
            "export OCL_ICD_VENDORS=$(lutbake devices --icd-folder) to use it"
        )
