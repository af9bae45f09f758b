"""The commands at points and the tables' headers: `lutbake eval` (lutbake/lut/evaluate.py), `sample`
(lutbake/lut/readout.py), `inspect` and `materials`; and the point flags and --points CSV they read.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator, Mapping
from typing import IO, TYPE_CHECKING, Any

import click

from lutbake.cli.options import (
    BadInput,
    backend_option,
    colour_options,
    echo_json,
    environment,
    progress_meter,
    progress_options,
)
from lutbake.io.names import INTERPOLATIONS

if TYPE_CHECKING:
    import numpy as np

    from lutbake.cli.options import F
    from lutbake.lut.sample import Atlas
    from lutbake.physics.points import FilmPoints


def point_options(f: F, named: bool = True) -> F:
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


def constant_point_options(f: F) -> F:
    """Point flags of commands that take constant indices only (sample)."""
    return point_options(f, named=False)


# (flag given, flag it contradicts, why): refused with one line rather than one silently winning.
_POINT_CONFLICTS = (
    ("eta2", "film", "the film index comes from --film"),
    ("eta3", "base", "the base index comes from --base"),
    ("kappa3", "base", "the base extinction comes from --base"),
)


def _refuse_conflicts(flags: Mapping[str, Any], conflicts: tuple[tuple[str, str, str], ...]) -> None:
    for a, b, why in conflicts:
        if flags.get(a) is not None and flags.get(b) not in (None, False):
            raise BadInput(f"--{a.replace('_', '-')} cannot be combined with --{b}: {why}")


def build_points(points_csv: str | None, defaults: Mapping[str, Any] | None = None, **flags: Any) -> FilmPoints:
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
def _open_points(points_csv: str) -> Iterator[IO[bytes]]:
    """The --points CSV as a binary stream (stdin for '-'), read line by line by points.read_csv_columns."""
    if points_csv == "-":
        if sys.stdin is None:
            raise BadInput("--points -: stdin is closed: pipe a CSV in or give a file")
        yield sys.stdin.buffer
        return
    try:
        stream = open(points_csv, "rb")  # noqa: SIM115  (closed by the with below; only opening is bad input)
    except OSError as exc:
        raise BadInput(
            f"--points {points_csv!r} cannot be read ({exc.strerror}): give a CSV file or '-' for stdin"
        ) from None
    with stream:
        yield stream


@click.command("eval")
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
@backend_option("With --fast: auto: OpenCL, else numpy with a warning.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
@progress_options
def eval_cmd(
    points_csv: str | None,
    space: str,
    observer: str,
    wavelength_nm: float | None,
    fast: bool,
    backend: str,
    as_json: bool,
    quiet: bool,
    force_progress: bool,
    **flags: Any,
) -> None:
    """Reflectance of film stacks: the converged spectral integral (ground truth), or --fast."""
    from lutbake.lut.evaluate import point_colours, point_reflectances

    points = build_points(points_csv, **flags)
    rows = _point_rows(points)
    if wavelength_nm is not None:
        if fast:
            raise BadInput("--fast computes colour; --wavelength reports R at one wavelength: give one")
        rs, rp, r, lam = point_reflectances(points, wavelength_nm)
        for row, a, b, c in zip(rows, rs, rp, r):
            row.update(wavelength_nm=lam, Rs=float(a), Rp=float(b), R=float(c))
    else:
        meter = progress_meter(f"eval {len(points)} points", quiet, force_progress)
        rgb, xyz, bound = point_colours(points, observer, space, fast, backend, meter, environment().device)
        meter.close()
        _warn_past_the_cap(bound)
        for row, a, b in zip(rows, rgb.tolist(), xyz.tolist()):
            row.update(rgb=a, xyz=b)
    doc = {"space": space, "observer": observer, "method": "fast" if fast else "ground truth", "points": rows}
    if as_json:
        echo_json(doc)
    else:
        _print_eval_table(rows)


def _warn_past_the_cap(bound: np.ndarray | None) -> None:
    from lutbake.lut.evaluate import CAPPED_WARNING_RGB

    if bound is not None and bound.max() > CAPPED_WARNING_RGB:
        click.echo(
            f"lutbake: warning: {int((bound > 0).sum())} points need more spectral nodes than the "
            f"cap allows; error bound up to {bound.max():.1e} (omit --fast for the ground truth)",
            err=True,
        )


def _point_rows(points: FilmPoints) -> list[dict[str, Any]]:
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


def _print_eval_table(rows: list[dict[str, Any]]) -> None:
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


@click.command("sample")
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
def sample_cmd(
    lut: str,
    points_csv: str | None,
    filter_bits: int | None,
    interpolation: str | None,
    material: str | None,
    as_json: bool,
    **flags: Any,
) -> None:
    """Sample a LUT or a scene atlas as a GPU would (reference sampler)."""
    from lutbake.lut.readout import TableReads

    reads = TableReads(lut, material, filter_bits, interpolation)
    given = [k for k in ("eta1", "eta2", "opd_nm", "eta3", "kappa3", "film", "base") if flags.get(k) is not None]
    if reads.is_atlas and given:
        raise BadInput(
            f"--{given[0].replace('_nm', '')} is not allowed with a scene atlas: the material "
            f"{material!r} fixes it; give --thickness and --angle/--cos-theta"
        )
    # the table's film (and a slice's base) unless given (Lut.sample refuses another)
    doc = reads.sample(build_points(points_csv, reads.film(), **flags))
    if as_json:
        echo_json(doc)
        return
    columns, outside = (
        (("cos_theta", "thickness_nm"), "outside the slice")
        if reads.is_atlas
        else (("cos_theta", "opd_nm", "eta3", "kappa3"), "outside the LUT")
    )
    for row in doc["points"]:
        note = "" if row["in_domain"] else f"  ({outside}: clamped)"
        click.echo(
            " ".join(f"{k}={row[k]:g}" for k in columns) + "  RGB " + " ".join(f"{v:.6f}" for v in row["rgb"]) + note
        )


@click.command("inspect")
@click.argument("lut", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the metadata as JSON.")
def inspect_cmd(lut: str, as_json: bool) -> None:
    """Show a LUT's or scene atlas's metadata (read from the EXR header alone)."""
    from lutbake.lut.sample import Atlas, load_table

    table = load_table(lut)
    if as_json:
        echo_json(table.meta)
    elif isinstance(table, Atlas):
        _print_atlas(lut, table)
    else:
        _print_lut(lut, table.meta)


def _print_lut(path: str, meta: Mapping[str, Any]) -> None:
    packing = meta["packing"]
    click.echo(f"{path}: {meta['format']} v{meta['format_version']} (lutbake {meta['lutbake_version']})")
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
        f"  image {packing['width']} x {packing['height']}: tiles of {packing['tile_x']} x {packing['tile_y']} "
        f"({packing['tile_width']} x {packing['tile_height']}), laid out by {packing['tiles_x']} x "
        f"{packing['tiles_y']}"
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


def _print_atlas(path: str, atlas: Atlas) -> None:
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


@click.command("materials")
@click.option("--json", "as_json", is_flag=True, help="Print the list as one JSON document.")
def materials_cmd(as_json: bool) -> None:
    """Named materials for --film/--base (any case) and the wavelengths their data cover."""
    from lutbake.physics.materials import catalogue

    rows = catalogue()
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
