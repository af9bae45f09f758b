"""`lutbake bake` (one LUT, the default set, or a scene's set from a TOML scene or a glTF asset) and
`lutbake plan` (what a scene bake would bake): flags parsed here, the work in lutbake/lut/sets.py,
lutbake/lut/domain.py, lutbake/scene/source.py, lutbake/scene/bake.py and lutbake/scene/documents.py.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from lutbake.cli.options import (
    DOMAIN_FLAGS,
    EXIT_GATE,
    BadInput,
    domain_options,
    echo_json,
    progress_meter,
    progress_options,
    show_progress,
)
from lutbake.io.names import terminal_text

if TYPE_CHECKING:
    from lutbake.cli.options import F, Meter
    from lutbake.lut.bake import BakeResult
    from lutbake.scene.model import Scene

DEFAULT_OUT_DIR = "lutbake-luts"
# flag → parameter: what sets a LUT's film and axes (a scene or glTF file sets them instead)
_AXIS_FLAGS = {
    "--eta2": "eta2",
    "--cos-theta": "cos_theta",
    "--opd": "opd_nm",
    "--eta3": "eta3",
    "--kappa3": "kappa3",
}


def scene_source_options(f: F) -> F:
    """--gltf, --metal-mapping and --route: a glTF asset as the scene's source (docs/gltf.md)."""
    f = click.option(
        "--route",
        "routes",
        multiple=True,
        metavar="MATERIAL=runtime|bake",
        help="With --gltf: serve a glTF material (name or index) from the runtime table, unbaked, or bake it "
        "(over its extras.lutbake.route); repeatable.",
    )(f)
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


@click.command("bake")
@domain_options
@click.option(
    "--scene", type=click.Path(dir_okay=False), help="Scene manifest (TOML): bake what it needs into --out DIR."
)
@scene_source_options
@click.option("--force", is_flag=True, help="With --scene or --gltf: recompute every slice and LUT.")
@click.option(
    "--for",
    "for_target",
    type=click.Choice(["web"]),
    default=None,
    help="With --gltf: write only the web set (what a three.js page loads: the manifest, EXR tables, GLSL "
    "includes); no HLSL, LUT headers or cache (docs/gltf.md, What to ship).",
)
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
    scene: str | None,
    gltf: str | None,
    metal_mapping: str | None,
    routes: tuple[str, ...],
    force: bool,
    for_target: str | None,
    out: str | None,
    named_film: str | None,
    named_base: str | None,
    as_json: bool,
    backend: str,
    device: str | None,
    **flags: Any,
) -> int | None:
    """Bake the spectral Airy reflectance over (cos θ, D, η3, κ3) into an EXR LUT.

    Without --eta2, bakes the default LUT set into a folder. Named materials
    (--base Cu, --film water) are baked through a scene manifest: --scene.
    """
    quiet, force_progress, max_memory_gib = flags.pop("quiet"), flags.pop("force_progress"), flags.pop("max_memory_gib")
    if named_film or named_base:
        flag = f"--base {named_base}" if named_base else f"--film {named_film}"
        raise BadInput(
            f"bake has no {flag}: a LUT bakes constant indices (--eta2, --eta3 A:B:N); named materials "
            f"are baked through a scene manifest: lutbake bake --scene FILE.toml --out DIR (docs/scene.md)"
        )
    if scene or gltf:
        given = [f for f, name in _AXIS_FLAGS.items() if flags[name] is not None]
        if given:
            flag = "--scene" if scene else "--gltf"
            raise BadInput(f"{given[0]} cannot be combined with {flag}: the {flag[2:]} file sets films and axes")
        if for_target and not gltf:
            raise BadInput("--for web applies to --gltf bakes only")
        source = _scene_source(scene, gltf, metal_mapping, routes)
        meter = progress_meter("bake scene", quiet, force_progress)
        return _bake_scene(source, out, force, backend, device, as_json, meter, for_target == "web")
    if force:
        raise BadInput("--force applies to --scene and --gltf bakes only (a LUT bake always recomputes)")
    if metal_mapping is not None:
        raise BadInput("--metal-mapping applies to --gltf only")
    run = {"backend": backend, "memory_limit_gib": max_memory_gib, "device": device}
    imports_s = _library_imports()
    if flags["eta2"] is None:
        if any(flags[name] for name in ("cos_theta", "opd_nm", "eta3", "kappa3")):
            raise BadInput("axis flags need --eta2 (or omit them all to bake the default set)")
        from lutbake.lut.sets import bake_default_set

        folder = Path(out or DEFAULT_OUT_DIR)
        settings = {k: v for k, v in flags.items() if k not in ("eta2", "cos_theta", "opd_nm", "eta3", "kappa3")}
        results = bake_default_set(folder, show_progress=show_progress(quiet, force_progress), **run, **settings)
    else:
        from lutbake.lut.domain import lut_spec
        from lutbake.lut.sets import bake_luts

        if out is None:
            raise BadInput("--out FILE.exr is required with --eta2")
        jobs = [(Path(out), lut_spec(**{k: flags[k] for k in DOMAIN_FLAGS}))]
        results = bake_luts(jobs, jobs[0][0].name, show_progress=show_progress(quiet, force_progress), **run)
    _print_bakes(results, as_json, imports_s)
    if flags["eta2"] is None and not as_json:
        click.echo(f"default LUT set in {folder}/")
    return None


def _library_imports() -> float:
    """Import the bake's library modules (numpy and lutbake's numeric stages; pyopencl loads with the
    integrator, in a bake's ``compile_s``): their wall time, s, for `bake --json`."""
    started = time.perf_counter()
    import lutbake.lut.domain
    import lutbake.lut.sets  # noqa: F401

    return time.perf_counter() - started


def _print_bakes(results: Sequence[BakeResult], as_json: bool, imports_s: float) -> None:
    """Each LUT's line (a warning beside it when texels past the spectral node cap err visibly), or one JSON
    (each LUT's row with its stages, lutbake/lut/pipeline.py, the set's summed (``set``) and the library's
    ``imports_s``)."""
    from lutbake.lut.evaluate import CAPPED_WARNING_RGB
    from lutbake.lut.sets import summary, totals

    rows = [summary(r) for r in results]
    if as_json:
        echo_json({"luts": rows, "imports_s": imports_s, "set": totals(results)})
        return
    for row in rows:
        click.echo(
            f"wrote {terminal_text(str(row['path']))} ({row['cells']} cells, {row['seconds']:.2f} s, "
            f"{row['cells_per_second']:.3g} cells/s on {row['device']}, "
            f"spectral error ≤ {row['spectral_error_rgb_max']:.1e})"
        )
        if row["capped_error_rgb_max"] > CAPPED_WARNING_RGB:
            click.echo(
                f"lutbake: warning: {row['capped_texels']} texels need more spectral nodes than the "
                f"cap allows; measured error up to {row['capped_error_rgb_max']:.1e} "
                f"(bound {row['truncation_bound']:.1e}, recorded in the LUT)",
                err=True,
            )


def _scene_source(
    scene_path: str | None, gltf: str | None, metal_mapping: str | None, routes: tuple[str, ...] = ()
) -> Scene:
    """The scene model from its one source; what its glTF mapping could not honour goes to stderr, a line each."""
    from lutbake.io.names import terminal_text
    from lutbake.scene.source import load_scene_source, source_warnings

    scene = load_scene_source(scene_path, gltf, metal_mapping, routes)
    for line in source_warnings(scene):
        click.echo(f"lutbake: warning: {terminal_text(line)}", err=True)
    return scene


def _bake_scene(
    scene: Scene,
    out: str | None,
    force: bool,
    backend: str,
    device: str | None,
    as_json: bool,
    meter: Meter,
    for_web: bool = False,
) -> int:
    from lutbake.scene.bake import bake_scene
    from lutbake.scene.documents import bake_summary

    if out is None:
        raise BadInput("--out DIR is required with --scene or --gltf")
    # checks every output before it makes the folder
    result = bake_scene(scene, out, force, backend, meter, device, for_web)
    meter.close("up to date" if result.up_to_date else "done")
    if as_json:
        echo_json(bake_summary(result))
    elif result.up_to_date:
        click.echo(terminal_text(f"{scene.path}: up to date in {out}/ (nothing written)"))
    else:
        click.echo(
            terminal_text(
                f"{scene.path}: computed {len(result.computed)}, reused {len(result.reused)}, "
                f"wrote {len(result.written)} files to {out}/ in {result.seconds:.1f} s"
            )
        )
    if result.ship and not as_json:
        _print_shipping(result.ship, out)
    for line in result.routes:
        click.echo(terminal_text(f"lutbake: {scene.file_name}: {line}"), err=True)
    if not result.unmet:
        return 0
    reached = ", ".join(
        f"{name} p99 ΔE00 {r['de00_p99']:.3f} (bound {r['de00_p99_bound']:.3f})" for name, r in result.unmet.items()
    )
    click.echo(
        f"lutbake: target p99 ΔE00 ≤ {scene.max_de:g} not met (at the resolution cap, or on a part's composed "
        f"colour): {reached} (written; see docs/scene.md, docs/gltf.md)",
        err=True,
    )
    return EXIT_GATE


def _print_shipping(ship: dict[str, Any], out: str) -> None:
    """Two lines: the web set (with the page's modules and the runtime table where a part needs it), and the
    build artefacts, each with what it is for."""
    runtime = ship["runtime_table_parts"]
    table = f"; and the runtime table (lutbake runtime-table --out DIR): {runtime} part(s) use it" if runtime else ""
    click.echo(
        terminal_text(
            f"ship for the web (what engine/lutbake-gltf.js fetches): {', '.join(ship['web'])} in {out}/, with "
            f"the page's modules {', '.join(ship['page_modules'])}{table}"
        )
    )
    by_role: dict[str, list[str]] = {}
    for name, why in ship["build"].items():
        by_role.setdefault(why, []).append(name)
    if by_role:
        named = "; ".join(f"{', '.join(names)}: {why}" for why, names in by_role.items())
        click.echo(terminal_text(f"build artefacts (no page loads them): {named}"))
    if ship.get("removed"):
        click.echo(terminal_text(f"removed the earlier bake's build artefacts: {', '.join(ship['removed'])}"))


@click.command("plan")
@click.option(
    "--scene", "scene_path", type=click.Path(dir_okay=False), default=None, help="Scene manifest (TOML) to plan."
)
@scene_source_options
@click.option("--json", "as_json", is_flag=True, help="Print the plan as one JSON document.")
def plan_cmd(
    scene_path: str | None, gltf: str | None, metal_mapping: str | None, routes: tuple[str, ...], as_json: bool
) -> None:
    """What `bake --scene` or `bake --gltf` would bake: slices, axes, counts, bytes, and time (bakes nothing).

    The time is measured now, here: the integrator's start-up, a few slice jobs refined for real, one glTF 4D
    job run for real (refined, its max searched), the composed-colour checks (docs/gltf.md, How long). For a
    glTF asset, each part's route where it is known before the bake.
    """
    from lutbake.io.progress import format_seconds
    from lutbake.scene.documents import plan_document

    scene = _scene_source(scene_path, gltf, metal_mapping, routes)
    doc = plan_document(scene)
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
        route_text = "".join(
            f"; {part} → {r['route']} ({r['by']}{'; the runtime table if ' + r['unless'] if 'unless' in r else ''})"
            for part, r in row["routes"].items()
        )
        click.echo(f"  glTF material {row['gltf_index']} {row['name']!r}: {served}{route_text}")
    total = sum(j["truth_seconds_estimate"] for j in doc["jobs"])
    click.echo(
        f"total {doc['bytes_start_total']} bytes at the starting counts (slices grow until the target "
        f"holds); a generic 4D LUT would take {doc['generic_4d_bytes']} bytes"
    )
    click.echo(
        f"time ~{format_seconds(doc['estimate_seconds'])} to bake here, measured just now: start-up "
        f"{format_seconds(doc['startup_s'])}, slices {format_seconds(doc['slices_s'])} ("
        f"{len(doc['sampled_slice_jobs'])} refined now, their mean times the count), 4D LUTs "
        f"{format_seconds(doc['luts_s'])} ({len(doc['sampled_lut_jobs'])} run now, times the count), "
        f"composed-colour checks {format_seconds(doc['checks_s'])} (of it "
        f"~{format_seconds(total)} of ground truth at {doc['seconds_per_truth_point'] * 1e3:.1f} ms per point)"
    )
