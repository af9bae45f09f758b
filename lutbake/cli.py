"""The `lutbake` command line: parse flags, call the library, print.

Exit codes: 0 success; 1 a check or gate failed; 2 bad input (one line on
stderr naming the value and what is allowed; nothing written).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click
import numpy as np

from . import __version__
from .colorimetry import OBSERVERS, SPACES

EXIT_GATE, EXIT_BAD_INPUT = 1, 2


class BadInput(click.ClickException):
    exit_code = EXIT_BAD_INPUT

    def show(self, file=None):
        click.echo(f"lutbake: error: {self.message}", err=True)


def main(argv=None):
    """Entry point: turn ValueError and click usage errors into one-line exit-2 errors."""
    try:
        rv = cli.main(args=argv, prog_name="lutbake", standalone_mode=False)
    except click.exceptions.Abort:
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


if __name__ == "__main__":  # pragma: no cover
    main()
