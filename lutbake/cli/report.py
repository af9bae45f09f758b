"""The commands that measure: `lutbake report` (lutbake/scene/reports.py: which report a file gets),
`sweep` and `tune` (lutbake/quality/sweep.py, refine.py, over a domain lutbake/lut/domain.py builds) and
`check` (lutbake/quality/check.py).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from lutbake.cli.options import (
    EXIT_GATE,
    MeterOnFirstUse,
    backend_option,
    device_option,
    domain_options,
    echo_json,
    environment,
    progress_meter,
    progress_options,
)

if TYPE_CHECKING:
    from lutbake.cli.options import F
    from lutbake.quality.refine import Trial


@click.command("report")
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
def report_cmd(
    lut: str,
    n_points: int,
    seed: int,
    out_dir: str | None,
    max_de: float | None,
    no_approximations: bool,
    search_budget: int | None,
    as_json: bool,
    quiet: bool,
    force_progress: bool,
) -> int:
    """How wrong a LUT or scene atlas is: ΔE00 against the ground truth at held-out points, max searched."""
    from lutbake.scene.reports import open_report

    report = open_report(lut, out_dir, max_de)
    meter = progress_meter(f"report {Path(lut).name}", quiet, force_progress)
    if report.kind == "gltf":
        receipts = report.run(n_points, seed, progress=meter)
        meter.close()
        return _print_receipts(receipts, out_dir, as_json)
    summary = report.run(n_points, seed, not no_approximations, search_budget, meter, environment().device)
    meter.close()
    gate_failed = max_de is not None and not summary["gate"]["passed"]
    if as_json:
        echo_json(summary)
    else:
        _print_summary(summary, report.kind)
        if out_dir:
            click.echo(f"report in {out_dir}/{'summary.json' if report.kind == 'atlas' else 'report.html'}")
        if max_de is not None:
            p99 = summary["lut_error"]["de00_p99"]
            click.echo(
                f"gate p99 ΔE00 {p99:.3f} {'>' if gate_failed else '<='} {max_de:g}: "
                f"{'FAIL' if gate_failed else 'pass'}"
            )
    return EXIT_GATE if gate_failed else 0


def _print_summary(summary: Mapping[str, Any], kind: str) -> None:
    """The error table (the LUT's or atlas's row, then the approximations' or the slices'), the runtime
    paths' costs, and where the searched max lies (a runtime table: ``_print_runtime``)."""
    if kind == "runtime":
        _print_runtime(summary)
        return
    rows = summary["slices"] if kind == "atlas" else summary["approximations"]
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


def _print_runtime(summary: Mapping[str, Any]) -> None:
    """Per base box: the held-out points' p99 and max, each search's max with where it sits, the box's
    searched max (the larger search's)."""

    def where(at: Mapping[str, float]) -> str:
        return " ".join(f"{k}={v:.5g}" for k, v in at.items())

    click.echo(f"runtime table {summary['content_hash']}: ΔE00 against the ground truth (η1 = 1)")
    for name, b in summary["boxes"].items():
        h = b["held_out"]
        click.echo(f"{name}: held-out p99 {h['p99']:.3f} max {h['max']:.3f} ({h['points']} random points)")
        for search in ("box", "ridge"):
            s = b[search]
            click.echo(
                f"  {search} search: ΔE00 {s['max']:.4f} at {where(s['at'])} ({s['evaluations']} evaluations, "
                f"{s['found_by']})"
            )
        click.echo(f"  searched max: ΔE00 {b['max']:.4f} at {where(b['at'])} ({b['evaluations']} evaluations)")


def _print_receipts(receipts: Mapping[str, Any], out_dir: str | None, as_json: bool) -> int:
    """`report OUT/ASSET.json`: the receipts of a glTF bake (lutbake/scene/gltf/receipt.py); exit 1 when
    --max-de's gate fails."""
    from lutbake.scene.gltf.receipt import served_by

    gate = receipts.get("gate")
    failed = gate is not None and not gate["passed"]
    if as_json:
        echo_json(receipts)
        return EXIT_GATE if failed else 0
    for r in receipts["materials"]:
        p99 = {
            part + (f" ({served_by(p)})" if p.get("route") == "runtime" else ""): {
                k: c["de00_p99"] for k, c in p["de00"].items()
            }
            for part, p in r["parts"].items()
        }
        costs = "; ".join(
            f"{part}: served p99 {c['baked']:.2f}, three.js p99 {c['threejs']:.2f} (three.js vs glTF's model "
            f"{c['threejs_vs_gltf_model']:.2f}; glTF's model vs the physics {c['gltf_model_vs_physics']:.2f})"
            for part, c in p99.items()
        )
        click.echo(f"material {r['gltf_index']} {r['name']!r}: {costs or r['why_not']}")
    if out_dir:
        click.echo(f"receipts in {out_dir}/receipts.html and receipts.json")
    if gate is not None:
        verdict = f"{'>' if failed else '<='} {gate['max_de']:g}: {'FAIL' if failed else 'pass'}"
        click.echo(f"gate: worst served p99 ΔE00 {gate['de00_p99']:.3f} {verdict}")
    return EXIT_GATE if failed else 0


def _print_error_rows(rows: Sequence[Mapping[str, Any]], summary: Mapping[str, Any]) -> None:
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


def search_budget_option(default: int) -> Callable[[F], F]:
    """--search-budget of sweep and tune: evaluations of each searched max (report.search_max)."""
    return click.option(
        "--search-budget",
        type=click.IntRange(100, 10_000_000),
        default=default,
        show_default=True,
        help="Evaluations of each searched max (over the whole domain).",
    )


def held_out_options(default_points: int, help_text: str) -> Callable[[F], F]:
    """--points/--seed of sweep and tune."""

    def options(f: F) -> F:
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


@click.command("sweep")
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
def sweep_cmd(
    out_dir: str,
    n_points: int,
    seed: int,
    search_budget: int,
    as_json: bool,
    quiet: bool,
    force_progress: bool,
    backend: str,
    device: str | None,
    **flags: Any,
) -> None:
    """Error against bake time and bytes over LUT variants of one domain, plus engine approximations."""
    from lutbake.lut.domain import lut_spec
    from lutbake.quality.sweep import sweep

    meter = progress_meter("sweep", quiet, force_progress)
    doc = sweep(lut_spec(**flags), out_dir, n_points, seed, backend, meter, search_budget, device)
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


@click.command("tune")
@domain_options
@click.option("--max-de", type=float, required=True, help="Target p99 ΔE00, as `report --max-de` gates it.")
@held_out_options(
    1000, "Held-out points per trial, as `report` scores them: half uniform, half at centres of the trial grid's cells."
)
@search_budget_option(20000)
@click.option("--json", "as_json", is_flag=True, help="Print the rounds and result as one JSON document.")
@progress_options
def tune_cmd(
    max_de: float,
    n_points: int,
    seed: int,
    search_budget: int,
    as_json: bool,
    quiet: bool,
    force_progress: bool,
    backend: str,
    device: str | None,
    **flags: Any,
) -> int:
    """Smallest per-axis counts whose p99 ΔE00 meets --max-de (exit 1 if not reached).

    Each accepted round is printed as it happens (with --json: one document at the end).
    """
    from lutbake.lut.domain import lut_spec
    from lutbake.quality.refine import check_max_de, tune, tune_document

    check_max_de(max_de)
    meter = progress_meter("tune", quiet, force_progress)

    def print_round(trial: Trial) -> None:
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
    spec = lut_spec(**flags)
    rounds = None if as_json else print_round
    result = tune(
        spec,
        max_de,
        n_points,
        seed,
        backend,
        progress=meter,
        on_round=rounds,
        search_budget=search_budget,
        device=device,
    )
    meter.close()
    doc = tune_document(spec, result)
    if as_json:
        echo_json(doc)
    else:
        _print_tuned(doc, max_de, result.met)
    return 0 if result.met else EXIT_GATE


def _print_tuned(doc: Mapping[str, Any], max_de: float, met: bool) -> None:
    from lutbake.grid.spec import axis_from_header

    best = doc["result"]
    axes = " ".join(
        f"--{n} {axis_from_header(a).flag()}" for n, a in zip(("cos-theta", "opd", "eta3", "kappa3"), doc["axes"])
    )
    click.echo(
        f"target p99 ΔE00 ≤ {max_de:g} {'met' if met else 'NOT met'}: {axes} --interpolation {doc['interpolation']} "
        f"(p99 {best['de00_p99']:.3f}, bound {best['de00_p99_bound']:.3f}, searched max "
        f"{best['de00_max']:.3f}, bake {best['bake_seconds']:.2f} s, {best['bytes']} bytes)"
    )


@click.command("check")
@backend_option("Integrator checked: auto: OpenCL, else numpy with a warning.")
@device_option
@click.option("--json", "as_json", is_flag=True, help="Print one JSON document.")
@progress_options
def check_cmd(backend: str, device: str | None, as_json: bool, quiet: bool, force_progress: bool) -> int:
    """Stiff and extreme cases: every path finite and accurate (exit 1 on any failure)."""
    from lutbake.quality.check import check_fast_path

    meter = MeterOnFirstUse("check", quiet, force_progress)  # started once the fast path is made
    checked = check_fast_path(backend, meter, device)
    meter.close()
    results = checked.results
    if as_json:
        echo_json(checked.document())
        return 0 if checked.passed else EXIT_GATE
    click.echo(f"fast path on {checked.device}")
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
    failed = sum(not r.passed for r in results)
    click.echo(f"{len(results) - failed} passed, {failed} failed")
    return 0 if checked.passed else EXIT_GATE
