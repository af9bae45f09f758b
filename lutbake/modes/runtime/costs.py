"""Error against cost for every runtime path: the table `lutbake report` prints beside its ΔE00 rows.

Per path: ΔE00 p99 and max (the report's own rows, at its held-out points), texture reads per pixel,
SPIR-V arithmetic per pixel (glslang + spirv-opt -O, scalar-weighted; the figure that carries to a GPU),
bytes on the GPU, and the wall time relative to three.js's evalIridescence measured in one SwiftShader
page. The cost figures are costs.json, written by `python bench/bench_runtime_cost.py` on the machine
named in it (tests hold its static figures to what the compilers give now); a LUT's bytes are its own.
"""

from __future__ import annotations

import functools
import html
import json
from importlib import resources

__all__ = ["path_costs", "cost_rows", "cost_table_text", "cost_table_html"]

# report row → measured path (a LUT row by its interpolation rule)
_PATH_OF_ROW = {
    "belcour-barla-2017": "belcour-barla-2017",
    "khr-iridescence-threejs": "three",
    "lutbake-exact-mode": "exact",
    "lutbake-runtime": "runtime",
    "lut-linear-reads": "lut-linear",
}


@functools.lru_cache(maxsize=1)
def path_costs() -> dict:
    """costs.json: {"measured": provenance, "paths": {path: figures}}."""
    return json.loads(resources.files("lutbake.modes.runtime").joinpath("costs.json").read_text())


def cost_rows(summary: dict, lut_texels: int) -> list:
    """One row per ΔE00 row of a LUT report summary (the LUT's image ``lut_texels`` texels): its error and
    what the path costs per pixel."""
    costs = path_costs()["paths"]
    lut_bytes = lut_texels * 8  # RGBA half, as three.js's EXRLoader uploads it
    rows = []
    for r in [summary["lut_error"]] + summary["approximations"]:
        path = _PATH_OF_ROW.get(r["name"], f"lut-{summary['interpolation']}")
        c = costs[path]
        reads = c["reads"]
        if path == "exact" and summary.get("exact_mode_terms"):
            reads = f"{reads} (mean {1 + 4 * summary['exact_mode_terms']['mean']:.1f})"
        rows.append(
            {
                "name": r["name"],
                "path": path,
                "de00_p99": r["de00_p99"],
                "de00_max": r["de00_max"],
                "reads_per_pixel": reads,
                "spirv_arithmetic": c["spirv_arithmetic"],
                "gpu_bytes": lut_bytes if path.startswith("lut") else c["gpu_bytes"],
                "swiftshader_x_three": c["swiftshader_x_three"],
            }
        )
    return rows


def cost_table_text(rows: list) -> str:
    """The rows as the command line prints them."""
    lines = [
        f"cost per pixel (SPIR-V: glslang + spirv-opt -O; SwiftShader: one page, {path_costs()['measured']['where']})",
        f"  {'method':<26}{'p99':>7}{'max':>7}  {'reads':<30}{'SPIR-V ops':<20}{'GPU MiB':>8}{'×three':>8}",
    ]
    for r in rows:
        swiftshader = "—" if r["swiftshader_x_three"] is None else f"{r['swiftshader_x_three']:.2f}"
        lines.append(
            f"  {r['name']:<26}{r['de00_p99']:7.3f}{r['de00_max']:7.3f}  {r['reads_per_pixel']:<30}"
            f"{str(r['spirv_arithmetic']):<20}{r['gpu_bytes'] / 2**20:8.2f}{swiftshader:>8}"
        )
    return "\n".join(lines)


def cost_table_html(rows: list | None) -> str:
    """The rows as report.html shows them (nothing without rows: a report without the approximations)."""
    if not rows:
        return ""
    head = (
        "<h2>Error and cost per pixel of every runtime path</h2><table><tr><th>method</th><th>p99</th>"
        "<th>max</th><th>reads</th><th>SPIR-V ops</th><th>GPU MiB</th><th>× three.js (SwiftShader)</th></tr>"
    )
    body = "".join(
        f"<tr><td>{html.escape(r['name'])}</td><td>{r['de00_p99']:.3f}</td><td>{r['de00_max']:.3f}</td>"
        f"<td>{html.escape(r['reads_per_pixel'])}</td><td>{html.escape(str(r['spirv_arithmetic']))}</td>"
        f"<td>{r['gpu_bytes'] / 2**20:.2f}</td><td>{_or_dash(r['swiftshader_x_three'])}</td></tr>"
        for r in rows
    )
    note = html.escape(
        f"Reads and SPIR-V: glslang + spirv-opt -O. SwiftShader: {path_costs()['measured']['where']} "
        f"({path_costs()['measured']['by']})."
    )
    return f"{head}{body}</table><p>{note}</p>"


def _or_dash(value: object) -> object:
    """A cell's value, or an em dash where it was not measured."""
    return "—" if value is None else value
