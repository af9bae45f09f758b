"""`lutbake blender`: the node groups and materials that render a scene bake in Blender
(lutbake/blender/library.py ``build_library``; docs/blender.md).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import click

from lutbake.cli.options import EXIT_GATE, echo_json, environment
from lutbake.io.names import terminal_text


@click.command("blender")
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
def blender_cmd(
    manifest: str | None,
    out: str,
    exact: str | None,
    runtime_table: str | None,
    blender: str | None,
    link: bool,
    verify: bool,
    as_json: bool,
) -> int:
    """Node groups that render a scene bake in Blender (Cycles and EEVEE): docs/blender.md."""
    from lutbake.blender.library import BlenderError, build_library
    from lutbake.io.names import terminal_text

    try:
        doc = build_library(
            manifest, out, blender or environment().blender, not link, exact, runtime_table, verify=verify
        )
    except BlenderError as exc:
        click.echo(f"lutbake: error: {terminal_text(str(exc))}", err=True)
        return EXIT_GATE
    verified = [v for k, v in doc.items() if k.startswith("verify") and v]
    for warning in doc["warnings"]:
        click.echo(f"lutbake: warning: {terminal_text(warning)}", err=True)
    if as_json:
        echo_json(doc)
    else:
        _print_library(doc, out, {"exact": exact, "runtime": runtime_table}, verified)
    return EXIT_GATE if not all(v["ok"] for v in verified) else 0


def _print_library(
    doc: Mapping[str, Any], out: str, tables: Mapping[str, str | None], verified: Sequence[Mapping[str, Any]]
) -> None:
    if doc["groups"]:
        click.echo(
            f"wrote {terminal_text(out)}: {len(doc['groups'])} node groups and materials "
            f"({terminal_text(', '.join(doc['groups'].values()))}); "
            f"working colour space {doc['working_space']} (a file that appends them must use it too)"
        )
    for kind, name in doc["osl_materials"].items():
        click.echo(
            terminal_text(
                f"wrote {out}: material {name!r} (OSL: Cycles with Open Shading Language on) reading {tables[kind]}"
            )
        )
    for v in verified:
        click.echo(
            f"{v['engine']} at {v['points']} probes: max |ΔRGB| {v['max_abs_rgb']:.1e} against lutbake "
            f"({'within' if v['ok'] else 'ABOVE'} {v['tolerance']:g})"
        )
