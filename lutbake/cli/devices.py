"""`lutbake devices`: every OpenCL device, whether it builds the kernel and passes its self-check, and its
rate (lutbake/lut/survey.py).
"""

from __future__ import annotations

import click

from lutbake.cli.options import echo_json, environment


@click.command("devices")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
@click.option(
    "--icd-folder",
    is_flag=True,
    help="Write a vendor folder registering Intel's CPU runtime (the cpu extra) beside the system's runtimes, "
    "in lutbake's cache folder, and print its path: export OCL_ICD_VENDORS=$(lutbake devices --icd-folder).",
)
def devices_cmd(as_json: bool, icd_folder: bool) -> None:
    """OpenCL devices: does each build the kernel and pass its self-check, and how fast is it."""
    from lutbake.io.usercache import writable_folder
    from lutbake.lut.survey import survey, vendor_folder

    env = environment()
    if icd_folder:
        click.echo(vendor_folder(writable_folder(), env.system_vendors))
        return
    doc = survey(env.device)
    if as_json:
        echo_json(doc)
        return
    for row in doc["devices"]:
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
            click.echo(
                f"    {row['cells_per_second']:.3g} cells/s (float64, {doc['throughput_cells']} cells over D 0–3000 nm)"
            )
    if doc["unregistered_intel"]:
        click.echo(
            f"Intel's OpenCL CPU runtime ({doc['unregistered_intel']}) is installed but not registered: "
            "export OCL_ICD_VENDORS=$(lutbake devices --icd-folder) to use it"
        )
