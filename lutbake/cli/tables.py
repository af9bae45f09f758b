"""`lutbake runtime-table` and `exact-table`: the runtime modes' tables and their includes
(lutbake/modes/runtime/files.py, lutbake/modes/exact.py write them; each checks its own output path).
"""

from __future__ import annotations

from typing import Any

import click

from lutbake.cli.options import colour_options, echo_json
from lutbake.io.names import terminal_text


@click.command("exact-table")
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
def exact_table_cmd(
    space: str,
    observer: str,
    out: str,
    precision: str,
    tolerance: float | None,
    max_terms: int | None,
    as_json: bool,
) -> None:
    """Write the exact runtime mode's table (Fourier transform of the colour weights) and its includes.

    Shaders call lutbake_exact(table, cos θ, d, η1, η2, η3, κ3): the exact series per pixel, any
    film and base index, no LUT domain (docs/engines.md).
    """
    from lutbake.modes.exact import write_exact_table

    given: dict[str, Any] = {k: v for k, v in {"tolerance": tolerance, "max_terms": max_terms}.items() if v is not None}
    meta = write_exact_table(out, observer, space, precision, **given)
    if as_json:
        echo_json(meta)
        return
    table = meta["table"]
    click.echo(
        f"wrote {terminal_text(out)} ({table['texels']} texels, step {table['step_nm']:g} nm "
        f"to {table['x_max_nm']:g} nm, "
        f"{precision}; interpolation ≤ {meta['error']['interpolation_bound']:.1e}, "
        f"storage ≤ {meta['error']['storage_max']:.1e}) with .json, .glsl, .hlsl"
    )


@click.command("runtime-table")
@colour_options
@click.option("--out", "out", type=click.Path(), required=True, help="FILE.exr (with FILE.json, .glsl, .hlsl).")
@click.option("--json", "as_json", is_flag=True, help="Print the table's metadata as JSON.")
def runtime_table_cmd(space: str, observer: str, out: str, as_json: bool) -> None:
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
        f"wrote {terminal_text(out)} ({table['width']}×{table['height']} RGBA half texels, {table['slices']} slices of "
        f"{table['nodes']}² to X {table['x_max_nm']:g} nm) with .json, .glsl, .hlsl"
    )
