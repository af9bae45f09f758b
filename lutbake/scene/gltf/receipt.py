"""The receipt of a glTF bake: per glTF material, what was read, how it was mapped, and what each
choice costs in ΔE00 against the spectral ground truth (`lutbake report OUT/ASSET.json`, docs/gltf.md).

For each used iridescent material, at held-out points (cos θ uniform in √cos θ, thickness uniform
over the material's range, for a texture-driven metal F0 uniform up to each channel's reach):

* ``baked``: what the engine samples (the atlas slice, or the 4D LUT read at the mapping table's
  (η3, κ3)) against the ground truth of the same film over the same base;
* ``threejs``: three.js's own iridescence (approximations.khr_iridescence_rgb, fed the glTF material's
  F0) against that ground truth: what the material shows without lutbake; split in two, so that neither
  is blamed for the other's error: ``threejs_vs_gltf_model`` (three.js against KHR_materials_iridescence's
  model as its text writes it, at the same F0) and ``gltf_model_vs_physics`` (that model against the
  ground truth over the mapped base: the model's approximations and the metal mapping's departure);
* ``other_mapping`` (metals mapped ``fitted`` or ``threejs``): the ground truth under the other
  mapping against this one's: what the mapping choice alone changes.

A metal part's colour is per channel: channel c of the stack whose base is channel c's (η3, κ3).
``gate``: the largest ``baked`` p99 of any part against ``max_de`` (`report --max-de`).
"""

from __future__ import annotations

import html
from collections.abc import Callable, Mapping
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from lutbake.io.manifest import read_scene_manifest
from lutbake.io.progress import Progress, no_progress
from lutbake.io.strictjson import dumps
from lutbake.lut.sample import Atlas, Lut
from lutbake.modes.approximations import khr_iridescence_rgb
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.metals import MAPPINGS, conductor
from lutbake.scene.gltf.scoring import (
    Bases,
    Sampler,
    SharedTruth,
    base_f0,
    film_points,
    film_stacks,
    part_colours,
    per_channel,
    truth_rgb,
)

__all__ = ["RECEIPT_FILES", "gltf_receipts", "served_by", "write_receipts"]

RECEIPT_FILES = ("receipts.json", "receipts.html")
# Points whose truth one batch of consecutive materials integrates together (SharedTruth): ~32 sphere-grid
# materials at 1,000 points and two stacks each, enough to keep every core's chunks busy, few enough that
# progress moves every few seconds and the batch's colours stay a few MB.
_POINTS_PER_BATCH = 65_536


def gltf_receipts(
    manifest_path: str | PathLike[str],
    n_points: int = 300,
    seed: int = 0,
    max_de: float | None = None,
    progress: Progress = no_progress,
    shared_truth: bool = True,
) -> dict[str, Any]:
    """The receipts of the glTF bake whose manifest is ``manifest_path`` (ValueError if it is not one), with
    ``gate`` {max_de, worst p99, passed} when ``max_de`` is given; ``progress`` (done, total, note) after
    each batch's materials. ``shared_truth``: consecutive materials' ground truth integrated together, once
    per distinct stack (False: once per part and mapping, as each part asks; the same receipts to rounding,
    bench/bench_receipts.py)."""
    path = Path(manifest_path)
    manifest = read_scene_manifest(path)  # typed (the source records too) and sealed
    source = manifest.get("source")
    if not isinstance(source, dict) or source.get("kind") != "gltf":
        raise ValueError(f"{str(path)!r} is not the manifest of a glTF bake (lutbake bake --gltf)")
    rng = np.random.default_rng(seed)
    sampler_of = _manifest_samplers(manifest, path.parent)
    records = source["materials"]
    per_batch = max(1, _POINTS_PER_BATCH // (2 * n_points))
    rows: list[dict[str, Any]] = []
    for start in range(0, len(records), per_batch):
        batch = records[start : start + per_batch]
        rows += _batch_receipts(batch, sampler_of, n_points, rng, shared_truth)
        for done, record in enumerate(batch, start + 1):
            progress(done, len(records), f"material {record['gltf_index']}")
    receipts = {
        "asset": source["asset"],
        "manifest": path.name,
        "metal_mapping": source["metal_mapping"],
        "points_per_part": n_points,
        "materials": rows,
    }
    if max_de is not None:
        worst = max((p["de00"]["baked"]["de00_p99"] for r in rows for p in r["parts"].values()), default=0.0)
        receipts["gate"] = {"max_de": max_de, "de00_p99": worst, "passed": worst <= max_de}
    return receipts


def _batch_receipts(
    batch: list[dict[str, Any]], sampler_of: Callable[[str], Sampler], n: int, rng: np.random.Generator, shared: bool
) -> list[dict[str, Any]]:
    """The receipts of consecutive materials. Shared: a first pass at the same points (the generator's state
    replayed) records every stack whose truth they need, one SharedTruth integration serves them all."""
    if not shared:
        return [_receipt(record, sampler_of, n, rng, truth_rgb) for record in batch]
    truth = SharedTruth()
    state = rng.bit_generator.state
    for record in batch:
        _receipt(record, sampler_of, n, rng, truth.record)
    truth.integrate()
    rng.bit_generator.state = state
    return [_receipt(record, sampler_of, n, rng, truth.colour) for record in batch]


def _receipt(
    record: dict[str, Any], sampler_of: Callable[[str], Sampler], n: int, rng: np.random.Generator, truth: Sampler
) -> dict[str, Any]:
    row: dict[str, Any] = {
        k: record.get(k)
        for k in ("gltf_index", "name", "used_by", "film", "thickness_nm", "metalness", "why_not", "warnings")
    }
    row["read"] = record["read"]
    row["defaults"] = sorted(k for k, v in record["read"].items() if isinstance(v, dict) and v["default"])
    row["parts"] = {}
    if record["film"] is None:
        return row
    cos_t, thickness = points = film_points(record, n, rng)
    for part, info in record["parts"].items():
        colours = part_colours(record["film"], info, sampler_of, points, rng, truth)
        bases, f0 = colours.bases, colours.f0
        threejs, model = _gltf_model(record["film"], cos_t, thickness, f0)
        costs: dict[str, Mapping[str, float | str]] = {
            "baked": _stats(colours.served, colours.truth),
            "threejs": _stats(threejs, colours.truth),
            "threejs_vs_gltf_model": _stats(threejs, model),
            "gltf_model_vs_physics": _stats(model, colours.truth),
        }
        if info.get("mapping") in MAPPINGS:
            other = next(m for m in MAPPINGS if m != info["mapping"])
            costs["other_mapping"] = {
                "mapping": other,
                **_stats(_other_truth(other, record["film"], cos_t, thickness, bases, truth), colours.truth),
            }
        row["parts"][part] = {**{k: v for k, v in info.items() if k != "table"}, "de00": costs}
    return row


def _manifest_samplers(manifest: dict[str, Any], folder: Path) -> Callable[[str], Sampler]:
    """Scene material name -> its table's sampler, each file beside the manifest loaded once."""
    loaded: dict[str, Atlas | Lut] = {}

    def sampler_of(name: str) -> Sampler:
        entry = manifest["materials"][name]
        if entry["file"] not in loaded:
            loaded[entry["file"]] = (Lut if entry["kind"] == "lut" else Atlas).load(folder / entry["file"])
        table = loaded[entry["file"]]
        return table.sample if isinstance(table, Lut) else lambda stack: table.sample(name, stack)

    return sampler_of


def _gltf_model(eta2: float, cos_t: np.ndarray, thickness: np.ndarray, f0: list[Any]) -> tuple[np.ndarray, np.ndarray]:
    """(three.js's term, KHR_materials_iridescence's model as written) at the glTF material's F0 per channel.
    Both read only F0 from the base; a base η3 = 1, κ3 = 2√(F0/(1 − F0)) carries any F0 < 1 inside lutbake's
    domain (F0 clamped to 0.9999, as three.js clamps it)."""
    bases: dict[int, Bases] = {}
    channel_bases = []
    for value in f0:
        if id(value) not in bases:
            clipped = np.clip(np.asarray(value, float), 0.0, 0.9999)
            bases[id(value)] = {"eta3": 1.0, "kappa3": 2.0 * np.sqrt(clipped / (1.0 - clipped))}
        channel_bases.append(bases[id(value)])
    stacks = film_stacks(eta2, cos_t, thickness, channel_bases)
    model = per_channel(lambda s: khr_iridescence_rgb(s, as_specified=True), stacks)
    return per_channel(khr_iridescence_rgb, stacks), model


def _other_truth(
    mapping: str,
    eta2: float,
    cos_t: np.ndarray,
    thickness: np.ndarray,
    bases: list[Bases],
    truth: Sampler,
) -> np.ndarray:
    """The ground truth with each channel's F0 mapped by ``mapping`` instead."""
    other: dict[int, Bases] = {}
    for b in bases:
        if id(b) not in other:
            eta, kappa, _ = conductor(np.atleast_1d(base_f0(b["eta3"], b["kappa3"])), mapping)
            other[id(b)] = {
                "eta3": eta if np.ndim(b["eta3"]) else eta[0],
                "kappa3": kappa if np.ndim(b["kappa3"]) else kappa[0],
            }
    stacks = film_stacks(eta2, cos_t, thickness, [other[id(b)] for b in bases])
    return per_channel(truth, stacks)


def _stats(rgb: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    de = delta_e00(rgb, truth)
    return {"de00_p99": float(np.percentile(de, 99)), "de00_max": float(de.max()), "de00_mean": float(de.mean())}


def served_by(part: dict[str, Any]) -> str:
    """What serves a part and, where the bake or the user chose it, why."""
    if "constant" in part:
        return "the constant 0 (nothing to bake)"
    route = "the runtime table" if part.get("route") == "runtime" else "the bake's tables"
    why = part.get("route_why") or (f"forced by {part['route_by']}" if part.get("route_by") else "")
    return f"{route} ({why})" if why else route


_HTML_COLUMNS = ("baked", "threejs", "threejs_vs_gltf_model", "gltf_model_vs_physics", "other_mapping")


def write_receipts(receipts: dict[str, Any], out_dir: str | PathLike[str]) -> None:
    """receipts.json and receipts.html in ``out_dir``, both rendered before either is written, committed as
    one set (neither appears without the other)."""
    from lutbake.io.fileset import open_set

    texts = dict(zip(RECEIPT_FILES, (dumps(receipts) + "\n", _html(receipts)), strict=True))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with open_set(out, RECEIPT_FILES[0]) as files:
        for name, text in texts.items():
            files.temp(out / name).write_text(text)


def _html(receipts: dict[str, Any]) -> str:
    esc = html.escape
    parts = [
        f"<!doctype html><meta charset=utf-8><title>lutbake receipts: {esc(receipts['asset'])}</title>",
        "<style>body{font:14px sans-serif;margin:2em}td,th{padding:2px 8px;text-align:left}"
        "table{border-collapse:collapse;margin-bottom:1.5em}tr:nth-child(even){background:#f3f3f3}</style>",
        f"<h1>{esc(receipts['asset'])}: one receipt per glTF material</h1>",
        f"<p>ΔE00 against the spectral ground truth at {receipts['points_per_part']} held-out points per part; "
        f"metal mapping {esc(receipts['metal_mapping'])}; three.js's error split into three.js against "
        "KHR_materials_iridescence's model at the same F0, and that model against the physics (docs/gltf.md).</p>",
    ]
    if "gate" in receipts:
        gate = receipts["gate"]
        verdict = "pass" if gate["passed"] else "FAIL"
        parts.append(f"<p>gate: worst served p99 ΔE00 {gate['de00_p99']:.3f} against {gate['max_de']:g}: {verdict}</p>")
    for r in receipts["materials"]:
        parts.append(f"<h2>material {r['gltf_index']}: {esc(r['name'] or '(unnamed)')}</h2>")
        read = ", ".join(
            f"{esc(k)} = {esc(str(v['value'] if isinstance(v, dict) else v))}"
            + (" (default)" if isinstance(v, dict) and v["default"] else "")
            for k, v in r["read"].items()
        )
        parts.append(f"<p>read: {read}</p>")
        if r["why_not"]:
            parts.append(f"<p>not baked: {esc(r['why_not'])}</p>")
        for w in r["warnings"]:
            parts.append(f"<p>warning: {esc(w)}</p>")
        if r["parts"]:
            parts.append(
                "<table><tr><th>part</th><th>mapping</th><th>served by</th><th>served p99 / max</th>"
                "<th>three.js p99 / max</th><th>three.js vs glTF's model</th><th>glTF's model vs the physics</th>"
                "<th>other mapping p99 / max</th></tr>"
            )
            for name, p in r["parts"].items():
                cells = [
                    f"{c['de00_p99']:.2f} / {c['de00_max']:.2f}" if c else ""
                    for c in (p["de00"].get(k) for k in _HTML_COLUMNS)
                ]
                parts.append(
                    f"<tr><td>{esc(name)}</td><td>{esc(str(p.get('mapping', 'ior')))}</td><td>{esc(served_by(p))}</td>"
                    + "".join(f"<td>{c}</td>" for c in cells)
                    + "</tr>"
                )
            parts.append("</table>")
    return "\n".join(parts) + "\n"
