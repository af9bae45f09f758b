"""The `lutbake` command line: parse flags, call the library, print.

Exit codes: 0 success; 1 a check or gate failed; 2 bad input (one line on
stderr naming the value and what is allowed; nothing written).
"""

from __future__ import annotations

import signal
import sys

from . import interrupted_at_start_up, set_sigint_handler

set_sigint_handler(interrupted_at_start_up)  # until main() runs

import json  # noqa: E402  (after the start-up SIGINT handler)
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import click  # noqa: E402
import numpy as np  # noqa: E402

from . import __version__  # noqa: E402
from .colorimetry import OBSERVERS, SPACES  # noqa: E402

EXIT_GATE, EXIT_BAD_INPUT = 1, 2


class BadInput(click.ClickException):
    exit_code = EXIT_BAD_INPUT

    def show(self, file=None):
        click.echo(f"lutbake: error: {self.message}", err=True)


def main(argv=None):
    """Entry point: turn ValueError and click usage errors into one-line exit-2 errors."""
    set_sigint_handler(signal.default_int_handler)
    try:
        rv = cli.main(args=argv, prog_name="lutbake", standalone_mode=False)
    except (click.exceptions.Abort, KeyboardInterrupt):
        click.echo("lutbake: interrupted", err=True)
        sys.exit(130)
    except click.ClickException as exc:
        if isinstance(exc, click.UsageError):
            exc = BadInput(exc.format_message().replace("\n", " "))
        exc.show()
        sys.exit(exc.exit_code)
    except (ValueError, OSError) as exc:
        BadInput(str(exc)).show()
        sys.exit(EXIT_BAD_INPUT)
    sys.exit(rv or 0)


@click.group()
@click.version_option(__version__, prog_name="lutbake")
def cli():
    """Bake thin-film iridescence (exact spectral Airy summation) into EXR LUTs."""


def colour_options(f):
    f = click.option("--observer", type=click.Choice(list(OBSERVERS)), default="cie1931",
                     show_default=True, help="CIE standard observer.")(f)
    return click.option("--space", type=click.Choice(list(SPACES)), default="rec709",
                        show_default=True, help="Linear RGB working space.")(f)


def point_options(f):
    """Point flags shared by eval and sample."""
    opts = [
        click.option("--points", "points_csv", type=click.Path(dir_okay=False),
                     help="CSV of points (columns eta1, eta2, thickness_nm|opd_nm, cos_theta|angle_deg, eta3, kappa3)."),
        click.option("--eta1", type=float, default=None, help="Ambient index (default 1.0)."),
        click.option("--eta2", type=float, help="Film index (real)."),
        click.option("--thickness", "thickness_nm", type=float, help="Film thickness d (nm)."),
        click.option("--opd", "opd_nm", type=float, help="D = 2·η2·d (nm)."),
        click.option("--cos-theta", "cos_theta", type=float, help="cos θ1 in the ambient."),
        click.option("--angle", "angle_deg", type=float, help="θ1 in degrees."),
        click.option("--eta3", type=float, help="Base index, real part."),
        click.option("--kappa3", type=float, default=None, help="Base extinction κ3 ≥ 0 (default 0)."),
        click.option("--film", help="Named film material (e.g. water, SiO2)."),
        click.option("--base", help="Named base material (e.g. Fe, Cu, Ag)."),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def build_points(points_csv, **flags):
    from .points import FilmPoints

    given = {k: v for k, v in flags.items() if v is not None}
    if points_csv:
        path = Path(points_csv)
        if not path.is_file():
            raise ValueError(f"--points {points_csv!r} is not a readable file")
        return FilmPoints.from_csv(path.read_text(), **given)
    return FilmPoints.build(**given)


def echo_json(doc):
    click.echo(json.dumps(doc, indent=2, sort_keys=False))


@cli.command("eval")
@point_options
@colour_options
@click.option("--wavelength", "wavelength_nm", type=float,
              help="Report Rs, Rp, R at one wavelength (nm) instead of colour.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
def eval_cmd(points_csv, space, observer, wavelength_nm, as_json, **flags):
    """Ground-truth reflectance of film stacks (converged spectral integral)."""
    from .points import check_value
    from .reference import reference_colour, spectral_reflectance

    points = build_points(points_csv, **flags)
    rows = _point_rows(points)
    if wavelength_nm is not None:
        lam = check_value("wavelength_nm", wavelength_nm)
        rs, rp, r = (v[:, 0] for v in spectral_reflectance(points, lam))
        for row, a, b, c in zip(rows, rs, rp, r):
            row.update(wavelength_nm=float(lam[0]), Rs=float(a), Rp=float(b), R=float(c))
    else:
        rgb = reference_colour(points, observer, space, "rgb").values
        xyz = reference_colour(points, observer, space, "xyz").values
        for row, a, b in zip(rows, rgb, xyz):
            row.update(rgb=a.tolist(), xyz=b.tolist())
    doc = {"space": space, "observer": observer, "points": rows}
    if as_json:
        echo_json(doc)
    else:
        _print_eval_table(rows)


def _point_rows(points):
    rows = []
    for i in range(len(points)):
        row = {"eta1": float(points.eta1[i]),
               "eta2": points.film.name if points.film else float(points.eta2[i]),
               "thickness_nm": float(points.thickness_nm[i]),
               "cos_theta": float(points.cos_theta[i])}
        if points.base:
            row["base"] = points.base.name
        else:
            row.update(eta3=float(points.eta3[i]), kappa3=float(points.kappa3[i]))
        rows.append(row)
    return rows


def _print_eval_table(rows):
    for row in rows:
        inputs = " ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                          for k, v in row.items() if k not in ("rgb", "xyz", "Rs", "Rp", "R"))
        if "rgb" in row:
            rgb = " ".join(f"{v:.6f}" for v in row["rgb"])
            xyz = " ".join(f"{v:.6f}" for v in row["xyz"])
            click.echo(f"{inputs}  RGB {rgb}  XYZ {xyz}")
        else:
            click.echo(f"{inputs}  Rs {row['Rs']:.9f}  Rp {row['Rp']:.9f}  R {row['R']:.9f}")


DEFAULT_OUT_DIR = "lutbake-luts"
CAPPED_WARNING = 1e-4  # |ΔRGB| measured at texels past the spectral node cap


def axis_option(flag, name):
    return click.option(flag, name, metavar="A:B:N[:sqrt]",
                        help=f"{name} axis: N nodes from A to B (uniform, or uniform in sqrt).")


def _use_device(ctx, param, selector):
    """--device: validate the selector now and make it this process's default device."""
    if selector:
        import os

        from .integrate import device_label, find_device

        device_label(find_device(selector))
        os.environ["LUTBAKE_DEVICE"] = selector
    return selector


device_option = click.option(
    "--device", metavar="N|KEY|TEXT", callback=_use_device, expose_value=False, is_eager=True,
    help="OpenCL device: its number or key in `lutbake devices`, or part of its name (default: the "
         "first that builds the kernel and passes its self-check; PYOPENCL_CTX is honoured).")


def domain_options(f):
    """The flags that define a LUT: film, axes, colour, precision, method, backend."""
    opts = [
        click.option("--eta2", type=float, help="Film index (constant, real)."),
        click.option("--eta1", type=float, default=1.0, show_default=True, help="Ambient index."),
        axis_option("--cos-theta", "cos_theta"),
        axis_option("--opd", "opd_nm"),
        axis_option("--eta3", "eta3"),
        axis_option("--kappa3", "kappa3"),
        click.option("--precision", type=click.Choice(["float", "half"]), default=None,
                     help="Storage precision of the EXR (default: float; half for the default set)."),
        click.option("--compute", type=click.Choice(["float64", "float32"]), default="float64", show_default=True,
                     help="Arithmetic precision of the kernel."),
        click.option("--method", type=click.Choice(["spectral"]), default="spectral", show_default=True,
                     help="Integration method (exact spectral Airy reflectance)."),
        click.option("--samples-per-cycle", type=float, default=None,
                     help="Spectral nodes per fringe-bandwidth cycle (default 3: measured |ΔRGB| ≤ 1.2e-6)."),
        click.option("--backend", type=click.Choice(["auto", "opencl", "numpy"]), default="auto",
                     show_default=True, help="auto: OpenCL (PoCL first), else numpy with a warning."),
        device_option,
    ]
    for opt in reversed(opts):
        f = opt(f)
    return colour_options(f)


def domain_spec(eta2, eta1, cos_theta, opd_nm, eta3, kappa3, space, observer, precision, compute, method,
                samples_per_cycle, default_precision="float"):
    """BakeSpec from domain flags; axes not given take the default set's."""
    from .bake import default_specs
    from .plan import BakeSpec, parse_axis

    if eta2 is None:
        raise BadInput("--eta2 is required (the film index)")
    given = {"cos_theta": cos_theta, "opd_nm": opd_nm, "eta3": eta3, "kappa3": kappa3}
    template = next(iter(default_specs().values())).axes
    axes = tuple(parse_axis(a.name, given[a.name]) if given[a.name] else a for a in template)
    extra = {} if samples_per_cycle is None else {"samples_per_cycle": samples_per_cycle}
    return BakeSpec(eta2=eta2, eta1=eta1, axes=axes, space=space, observer=observer,
                    precision=precision or default_precision, compute=compute, method=method, **extra)


@cli.command("bake")
@domain_options
@click.option("--scene", type=click.Path(dir_okay=False), help="Scene manifest (TOML): bake what it needs into --out DIR.")
@click.option("--force", is_flag=True, help="With --scene: recompute every slice and LUT.")
@click.option("--out", "out", type=click.Path(), default=None,
              help=f"FILE.exr for one LUT; a folder for the default set (default ./{DEFAULT_OUT_DIR}).")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON summary.")
@click.option("--max-memory-gib", type=click.FloatRange(0.5, 4096), default=8.0, show_default=True,
              help="Refuse grids whose estimated peak memory exceeds this (docs/lut-format.md, Limits).")
def bake_cmd(eta2, eta1, cos_theta, opd_nm, eta3, kappa3, space, observer, precision, compute, method,
             samples_per_cycle, backend, scene, force, out, quiet, as_json, max_memory_gib):
    """Bake the spectral Airy reflectance over (cos θ, D, η3, κ3) into an EXR LUT.

    Without --eta2, bakes the default LUT set into a folder.
    """
    from .bake import default_specs

    if scene:
        return _bake_scene(scene, out, force, backend, as_json)
    flags = dict(eta2=eta2, eta1=eta1, cos_theta=cos_theta, opd_nm=opd_nm, eta3=eta3, kappa3=kappa3,
                 space=space, observer=observer, precision=precision, compute=compute, method=method,
                 samples_per_cycle=samples_per_cycle)
    if eta2 is None:
        if any((cos_theta, opd_nm, eta3, kappa3)):
            raise BadInput("axis flags need --eta2 (or omit them all to bake the default set)")
        folder = Path(out or DEFAULT_OUT_DIR)
        if folder.suffix.lower() == ".exr":
            raise BadInput(f"--out {str(folder)!r}: the default set goes into a folder, not one .exr")
        common = dict(eta1=eta1, space=space, observer=observer, compute=compute, method=method)
        if samples_per_cycle is not None:
            common["samples_per_cycle"] = samples_per_cycle
        jobs = [(folder / f"{name}.exr", replace(spec, **common))
                for name, spec in default_specs(precision or "half").items()]
        for _, spec in jobs:
            spec.check_budget(max_memory_gib)
        _make_folder(folder)
    else:
        if out is None:
            raise BadInput("--out FILE.exr is required with --eta2")
        jobs = [(Path(out), domain_spec(**flags))]
    results = [_bake_one(path, spec, backend, quiet or as_json, max_memory_gib) for path, spec in jobs]
    summary = [_bake_summary(r) for r in results]
    if as_json:
        echo_json({"luts": summary})
        return
    for row in summary:
        click.echo(f"wrote {row['path']} ({row['cells']} cells, {row['seconds']:.2f} s, "
                   f"{row['cells_per_second']:.3g} cells/s on {row['device']}, "
                   f"spectral error ≤ {row['spectral_error_rgb_max']:.1e})")
        if row["capped_error_rgb_max"] > CAPPED_WARNING:
            click.echo(f"lutbake: warning: {row['capped_texels']} texels need more spectral nodes than the "
                       f"cap allows; measured error up to {row['capped_error_rgb_max']:.1e} "
                       f"(bound {row['truncation_bound']:.1e}, recorded in the LUT)", err=True)
    if eta2 is None:
        click.echo(f"default LUT set in {jobs[0][0].parent}/")


def _bake_scene(scene_path, out, force, backend, as_json):
    from .atlas import bake_scene, check_scene_outputs
    from .scene import load_scene

    if out is None:
        raise BadInput("--out DIR is required with --scene")
    if Path(out).suffix.lower() == ".exr":
        raise BadInput(f"--out {out!r}: a scene bakes into a folder")
    scene = load_scene(scene_path)
    check_scene_outputs(Path(out), scene)
    _make_folder(Path(out))
    result = bake_scene(scene, out, force, backend)
    doc = {"out": str(result.out_dir), "up_to_date": result.up_to_date, "computed": result.computed,
           "reused": result.reused, "written": [str(p) for p in result.written], "seconds": result.seconds,
           "target_unmet": result.unmet}
    if as_json:
        echo_json(doc)
    elif result.up_to_date:
        click.echo(f"{scene_path}: up to date in {out}/ (nothing written)")
    else:
        click.echo(f"{scene_path}: computed {len(result.computed)}, reused {len(result.reused)}, "
                   f"wrote {len(result.written)} files to {out}/ in {result.seconds:.1f} s")
    if result.unmet:
        reached = ", ".join(f"{name} p99 ΔE00 {p99:.3f}" for name, p99 in result.unmet.items())
        click.echo(f"lutbake: target p99 ΔE00 ≤ {scene.max_de:g} not met at the resolution cap: {reached} "
                   "(written; see docs/scene.md)", err=True)
        return EXIT_GATE
    return 0


@cli.command("plan")
@click.option("--scene", "scene_path", type=click.Path(dir_okay=False), required=True)
@click.option("--json", "as_json", is_flag=True)
def plan_cmd(scene_path, as_json):
    """What `bake --scene` would bake: slices, axes, counts, bytes, estimated time (bakes nothing)."""
    from .atlas import plan_scene
    from .scene import load_scene

    doc = plan_scene(load_scene(scene_path)).describe()
    if as_json:
        echo_json(doc)
        return
    s = doc["settings"]
    click.echo(f"{scene_path}: {s['space']} / {s['observer']}, ambient η1 {s['eta1']:g}, {s['precision']}, "
               f"target p99 ΔE00 ≤ {s['max_de']:g}")
    for job in doc["jobs"]:
        shape = " × ".join(str(c) for c in job["counts"])
        click.echo(f"  {job['id']}: {job['kind']} {shape} for {', '.join(job['materials'])} — "
                   f"{job['bytes_start']} bytes, ~{job['seconds_estimate']:.1f} s")
    click.echo(f"total {doc['bytes_start_total']} bytes at the starting counts (slices grow until the target "
               f"holds); a generic 4D LUT would take {doc['generic_4d_bytes']} bytes")


def _make_folder(folder: Path):
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BadInput(f"--out folder {str(folder)!r} cannot be created: {exc.strerror}") from None


def _bake_one(path, spec, backend, quiet, max_memory_gib):
    from .bake import bake

    show = not quiet and sys.stderr.isatty()
    if not show:
        return bake(spec, path, backend, memory_limit_gib=max_memory_gib)
    with click.progressbar(length=spec.image_size[1], label=f"baking {path.name}", file=sys.stderr) as bar:
        return bake(spec, path, backend, on_band=lambda rows, total: bar.update(rows),
                    memory_limit_gib=max_memory_gib)


def _bake_summary(result):
    return {"path": str(result.path), "cells": result.cells, "seconds": result.seconds,
            "cells_per_second": result.cells_per_second, "backend": result.backend, "device": result.device,
            "spectral_error_rgb_max": result.spectral_error_rgb_max,
            "capped_texels": result.capped_texels, "truncation_bound": result.truncation_bound,
            "capped_error_rgb_max": result.capped_error_rgb_max}


@cli.command("inspect")
@click.argument("lut", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the metadata as JSON.")
def inspect_cmd(lut, as_json):
    """Show a LUT's or scene atlas's metadata (read from the EXR header alone)."""
    from .sample import Atlas, load_table

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
    click.echo(f"  {meta['space']} linear RGB, {meta['observer']}, illuminant {meta['illuminant']}, "
               f"{meta['precision']} storage, {meta['compute']} compute")
    for a in meta["axes"]:
        click.echo(f"  axis {a['name']:<9} [{a['min']!r}, {a['max']!r}] x {a['count']} ({a['spacing']}, unit {a['unit']})")
    click.echo(f"  image {packing['width']} x {packing['height']}: tiles of {packing['tile_x']} x {packing['tile_y']}"
               f" ({packing['tile_width']} x {packing['tile_height']}), laid out by {packing['tiles_x']} x {packing['tiles_y']}")
    spectral = meta["spectral"]
    click.echo(f"  spectral: {spectral['rule']}, {spectral['counts'][0]}-{spectral['counts'][-1]} nodes per texel, "
               f"measured error |ΔRGB| ≤ {spectral['error_rgb_max']:.1e}")
    click.echo(f"  content hash {meta['content_hash']}")


@cli.command("sample")
@click.argument("lut", type=click.Path())
@point_options
@click.option("--filter-bits", type=click.IntRange(1, 24), default=None,
              help="Quantize bilinear weights as a GPU texture unit does (e.g. 8).")
@click.option("--material", help="With a scene atlas: the material whose slice to sample.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
def sample_cmd(lut, points_csv, filter_bits, material, as_json, **flags):
    """Sample a LUT or a scene atlas as a GPU would (reference sampler)."""
    from .sample import Atlas, load_table

    table = load_table(lut)
    if isinstance(table, Atlas):
        return _sample_atlas(lut, table, material, points_csv, filter_bits, as_json, flags)
    if material is not None:
        raise BadInput(f"--material {material!r} is for scene atlases; {lut!r} is a 4D LUT")
    for name, value in (("eta1", table.eta1), ("eta2", table.eta2)):
        if flags.get(name) is not None and flags[name] != value:
            raise BadInput(f"--{name} {flags[name]!r} differs from the LUT's {name} = {value!r}")
        flags[name] = value
    if flags.get("film") or flags.get("base"):
        raise BadInput("named materials cannot be sampled from a constant-index LUT; give --eta3/--kappa3")
    points = build_points(points_csv, **flags)
    opd = 2.0 * table.eta2 * points.thickness_nm
    rgb = table.sample(points.cos_theta, opd, points.eta3, points.kappa3, filter_bits)
    inside = table.in_domain(points.cos_theta, opd, points.eta3, points.kappa3)
    rows = []
    for i in range(len(points)):
        rows.append({"cos_theta": float(points.cos_theta[i]), "opd_nm": float(opd[i]),
                     "eta3": float(points.eta3[i]), "kappa3": float(points.kappa3[i]),
                     "rgb": rgb[i].tolist(), "in_domain": bool(inside[i])})
    if as_json:
        echo_json({"lut": str(lut), "space": table.meta["space"], "points": rows})
        return
    _echo_samples(rows, ("cos_theta", "opd_nm", "eta3", "kappa3"), "outside the LUT")


def _echo_samples(rows, columns, outside):
    for row in rows:
        note = "" if row["in_domain"] else f"  ({outside}: clamped)"
        click.echo(" ".join(f"{k}={row[k]:g}" for k in columns) + "  RGB "
                   + " ".join(f"{v:.6f}" for v in row["rgb"]) + note)


def _print_atlas(path, atlas):
    meta = atlas.meta
    height, width, _ = atlas.image.shape
    click.echo(f"{path}: {meta['format']} v{meta['format_version']}, scene hash {meta['scene_hash'][:16]}")
    click.echo(f"  {meta['space']} linear RGB, {meta['observer']}, {meta['precision']} storage, "
               f"ambient eta1 = {meta['eta1']!r}, image {width} x {height}")
    for name, s in atlas.materials.items():
        th = s["axes"]["thickness_nm"]
        click.echo(f"  material {name}: rect {s['rect']} (cos_theta sqrt x {s['rect'][2]}, thickness_nm "
                   f"[{th['min']!r}, {th['max']!r}] x {th['count']}), film {s['film']}, base {s['base']}")


def _sample_atlas(path, atlas, material, points_csv, filter_bits, as_json, flags):
    """Sample one material's slice at (cos θ, thickness); the film and base come from the atlas."""
    if material is None:
        raise BadInput(f"--material is required with a scene atlas: allowed {', '.join(atlas.materials)}")
    atlas.slice_of(material)  # an unknown name fails here, naming the allowed ones
    given = [k for k in ("eta1", "eta2", "opd_nm", "eta3", "kappa3", "film", "base") if flags.get(k) is not None]
    if given:
        raise BadInput(f"--{given[0].replace('_nm', '')} is not allowed with a scene atlas: the material "
                       f"{material!r} fixes it; give --thickness and --angle/--cos-theta")
    points = build_points(points_csv, **{**flags, **atlas.film_stack(material)})
    rgb = atlas.sample(material, points.cos_theta, points.thickness_nm, filter_bits)
    inside = atlas.in_domain(material, points.cos_theta, points.thickness_nm)
    rows = [{"cos_theta": float(c), "thickness_nm": float(t), "rgb": v.tolist(), "in_domain": bool(i)}
            for c, t, v, i in zip(points.cos_theta, points.thickness_nm, rgb, inside)]
    if as_json:
        echo_json({"atlas": str(path), "material": material, "space": atlas.meta["space"], "points": rows})
        return
    _echo_samples(rows, ("cos_theta", "thickness_nm"), "outside the slice")


@cli.command("report")
@click.argument("lut", type=click.Path())
@click.option("--points", "n_points", type=click.IntRange(10, 1_000_000), default=1000, show_default=True,
              help="Held-out points (half uniform, half at cell centres).")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--out", "out_dir", type=click.Path(file_okay=False), help="Folder for report.html, PNGs, summary.json.")
@click.option("--max-de", type=float, default=None, help="Gate: exit 1 when p99 ΔE00 exceeds this.")
@click.option("--no-approximations", is_flag=True, help="Skip the engine-approximation rows.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as one JSON document.")
def report_cmd(lut, n_points, seed, out_dir, max_de, no_approximations, as_json):
    """How wrong a LUT or scene atlas is: ΔE00 against the ground truth at held-out points."""
    from .report import report_lut, write_report
    from .sample import Atlas, load_table

    if max_de is not None and not max_de > 0:
        raise BadInput(f"--max-de {max_de!r} is not allowed: must be a number > 0")
    table = load_table(lut)
    if isinstance(table, Atlas):
        summary = _atlas_summary(table, lut, n_points, seed, out_dir)
        rows = summary["slices"]
    else:
        rep = report_lut(lut, n_points, seed, approximations=not no_approximations)
        summary = write_report(rep, out_dir) if out_dir else rep.summary()
        rows = summary["approximations"]
    p99 = summary["lut_error"]["de00_p99"]
    gate_failed = max_de is not None and p99 > max_de
    if max_de is not None:
        summary["gate"] = {"max_de00_p99": max_de, "passed": not gate_failed}
    if as_json:
        echo_json(summary)
    else:
        _print_error_rows([summary["lut_error"]] + rows, summary["points"])
        for w in summary.get("worst_points", [])[:1]:
            click.echo(f"worst: ΔE00 {w['de00']:.3f} at cos_theta={w['cos_theta']:.4f} opd_nm={w['opd_nm']:.1f} "
                       f"eta3={w['eta3']:.3f} kappa3={w['kappa3']:.3f} ({w['kind']})")
        if out_dir:
            click.echo(f"report in {out_dir}/{'summary.json' if isinstance(table, Atlas) else 'report.html'}")
        if max_de is not None:
            click.echo(f"gate p99 ΔE00 {p99:.3f} {'>' if gate_failed else '<='} {max_de:g}: "
                       f"{'FAIL' if gate_failed else 'pass'}")
    return EXIT_GATE if gate_failed else 0


def _atlas_summary(atlas, path, n_points, seed, out_dir) -> dict:
    """Per-slice ΔE00 of a scene atlas as stored; summary.json in out_dir when given."""
    from .lutfile import write_text_atomic
    from .report import report_atlas

    summary = report_atlas(atlas, path, n_points, seed)
    if out_dir:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        write_text_atomic(Path(out_dir) / "summary.json", json.dumps(summary, indent=2) + "\n")
    return summary


def _print_error_rows(rows, n_points):
    click.echo(f"ΔE00 against the ground truth at {n_points} held-out points")
    click.echo(f"  {'method':<26}{'mean':>8}{'p50':>8}{'p95':>8}{'p99':>8}{'max':>8}{'max|ΔRGB|':>11}")
    for r in rows:
        click.echo(f"  {r['name']:<26}{r['de00_mean']:8.3f}{r['de00_p50']:8.3f}{r['de00_p95']:8.3f}"
                   f"{r['de00_p99']:8.3f}{r['de00_max']:8.3f}{r['rgb_abs_max']:11.2e}")


@cli.command("sweep")
@domain_options
@click.option("--out", "out_dir", type=click.Path(file_okay=False), required=True,
              help="Folder for sweep.json and pareto.png.")
@click.option("--points", "n_points", type=click.IntRange(10, 1_000_000), default=600, show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--json", "as_json", is_flag=True)
def sweep_cmd(out_dir, n_points, seed, as_json, backend, **flags):
    """Error against bake time and bytes over LUT variants of one domain, plus engine approximations."""
    from .sweep import sweep

    doc = sweep(domain_spec(**flags), out_dir, n_points, seed, backend)
    if as_json:
        echo_json(doc)
        return
    click.echo(f"  {'variant':<26}{'shape':>16}{'p99 ΔE00':>10}{'bake s':>9}{'bytes':>11}{'ns/eval':>9}")
    for r in doc["rows"]:
        lut_cols = (f"{r['shape']:>16}{r['de00_p99']:10.3f}{r['bake_seconds']:9.2f}{r['bytes']:11d}{'':>9}"
                    if r["kind"] == "lut" else f"{'(no LUT)':>16}{r['de00_p99']:10.3f}{'':>9}{'':>11}{r['ns_per_eval']:9.0f}")
        click.echo(f"  {r['name']:<26}{lut_cols}")
    click.echo(f"Pareto plot in {out_dir}/pareto.png")


@cli.command("tune")
@domain_options
@click.option("--max-de", type=float, required=True, help="Target p99 ΔE00.")
@click.option("--points", "n_points", type=click.IntRange(10, 1_000_000), default=600, show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--json", "as_json", is_flag=True)
def tune_cmd(max_de, n_points, seed, as_json, backend, **flags):
    """Smallest per-axis counts whose p99 ΔE00 meets --max-de (exit 1 if not reached)."""
    from .sweep import tune

    if not max_de > 0:
        raise BadInput(f"--max-de {max_de!r} is not allowed: must be a number > 0")
    result = tune(domain_spec(**flags), max_de, n_points, seed, backend)
    if as_json:
        echo_json(result)
    else:
        for r in result["rounds"]:
            click.echo(f"  {r['shape']:>16}  p99 ΔE00 {r['de00_p99']:.3f}  bake {r['bake_seconds']:.2f} s  {r['bytes']} bytes")
        best = result["result"]
        axes = " ".join(f"--{n} {a['min']:g}:{a['max']:g}:{a['count']}{':sqrt' if a['spacing'] == 'sqrt' else ''}"
                        for n, a in zip(("cos-theta", "opd", "eta3", "kappa3"), result["axes"]))
        state = "met" if result["met"] else "NOT met"
        click.echo(f"target p99 ΔE00 ≤ {max_de:g} {state}: {axes} "
                   f"(p99 {best['de00_p99']:.3f}, bake {best['bake_seconds']:.2f} s, {best['bytes']} bytes)")
    return 0 if result["met"] else EXIT_GATE


@cli.command("check")
@click.option("--backend", type=click.Choice(["auto", "opencl", "numpy"]), default="auto", show_default=True,
              help="Fast path to check: auto (OpenCL, else numpy), opencl or numpy.")
@device_option
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
def check_cmd(backend, as_json):
    """Stiff and extreme cases: every path finite and accurate (exit 1 on any failure)."""
    from .check import run_checks
    from .integrate import backend as make_backend

    device = make_backend(backend).device
    results = run_checks(backend)
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
            click.echo(f"  {mark} {r.name}: value {r.value:.9g}, reference {r.reference:.9g}, "
                       f"error {r.error:.2e} (tolerance {r.tolerance:.1e}){'; ' + r.note if r.note else ''}")
        click.echo(f"{len(results) - len(failed)} passed, {len(failed)} failed")
    return EXIT_GATE if failed else 0


@cli.command("devices")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
def devices_cmd(as_json):
    """OpenCL devices: does each build the kernel and pass its self-check, and how fast is it."""
    from .integrate import survey_devices
    from .plan import Axis, BakeSpec

    probe = BakeSpec(eta2=1.5, axes=(Axis("cos_theta", 0.0, 1.0, 32, "sqrt"), Axis("opd_nm", 0.0, 3000.0, 128),
                                     Axis("eta3", 1.0, 3.0, 4), Axis("kappa3", 0.0, 5.0, 4, "sqrt")))
    rows = survey_devices(probe)
    if as_json:
        echo_json({"throughput_cells": probe.cells, "devices": rows})
        return
    for row in rows:
        if row["index"] is None:
            click.echo(f"no OpenCL device: {row['error']}")
            continue
        mark = " (default)" if row["default"] else ""
        click.echo(f"{row['index']} {row['key']}: {row['label']}{mark}")
        for compute in ("float64", "float32"):
            r = row[compute]
            state = (f"builds, self-check |ΔR| {r['self_check_error']:.1e}" if r["builds"]
                     else f"not usable: {r['error']}")
            click.echo(f"    {compute}: {state}")
        if "cells_per_second" in row:
            click.echo(f"    {row['cells_per_second']:.3g} cells/s (float64, {probe.cells} cells over D 0–3000 nm)")


if __name__ == "__main__":  # pragma: no cover
    main()
