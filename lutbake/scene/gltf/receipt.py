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
from lutbake.modes.runtime.model import runtime_rgb
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.metals import MAPPINGS, conductor
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour

__all__ = ["RECEIPT_FILES", "gltf_receipts", "write_receipts"]

RECEIPT_FILES = ("receipts.json", "receipts.html")

# A channel's base as FilmPoints.build keywords: {eta3, kappa3} (numbers or arrays) or {base: a name}.
Bases = dict[str, Any]


def gltf_receipts(
    manifest_path: str | PathLike[str],
    n_points: int = 300,
    seed: int = 0,
    max_de: float | None = None,
    progress: Progress = no_progress,
) -> dict[str, Any]:
    """The receipts of the glTF bake whose manifest is ``manifest_path`` (ValueError if it is not one), with
    ``gate`` {max_de, worst p99, passed} when ``max_de`` is given; ``progress`` (done, total, note) after
    each material."""
    path = Path(manifest_path)
    manifest = read_scene_manifest(path)  # typed (the source records too) and sealed
    source = manifest.get("source")
    if not isinstance(source, dict) or source.get("kind") != "gltf":
        raise ValueError(f"{str(path)!r} is not the manifest of a glTF bake (lutbake bake --gltf)")
    rng = np.random.default_rng(seed)
    rows = []
    for k, record in enumerate(source["materials"]):
        rows.append(_receipt(record, manifest, path.parent, n_points, rng))
        progress(k + 1, len(source["materials"]), f"material {record['gltf_index']}")
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


def _receipt(
    record: dict[str, Any], manifest: dict[str, Any], folder: Path, n: int, rng: np.random.Generator
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
    cos_t = rng.uniform(0.0, 1.0, n) ** 2
    d_lo, d_hi = record["thickness_nm"]
    thickness = rng.uniform(d_lo, d_hi, n)
    for part, info in record["parts"].items():
        bases, baked, f0 = _part(info, manifest, folder, record["film"], cos_t, thickness, rng)
        stacks = _stacks(record["film"], cos_t, thickness, bases)
        truth = _per_channel(lambda s: reference_colour(s).values, stacks)
        threejs, model = _gltf_model(record["film"], cos_t, thickness, f0)
        costs: dict[str, Mapping[str, float | str]] = {
            "baked": _stats(baked, truth),
            "threejs": _stats(threejs, truth),
            "threejs_vs_gltf_model": _stats(threejs, model),
            "gltf_model_vs_physics": _stats(model, truth),
        }
        if info.get("mapping") in MAPPINGS:
            other = next(m for m in MAPPINGS if m != info["mapping"])
            costs["other_mapping"] = {
                "mapping": other,
                **_stats(_other_truth(info, other, record["film"], cos_t, thickness, bases), truth),
            }
        row["parts"][part] = {**{k: v for k, v in info.items() if k != "table"}, "de00": costs}
    return row


def _part(
    info: dict[str, Any],
    manifest: dict[str, Any],
    folder: Path,
    eta2: float,
    cos_t: np.ndarray,
    thickness: np.ndarray,
    rng: np.random.Generator,
) -> tuple[list[Bases], np.ndarray, list[Any]]:
    """(base keywords per channel, what the engine reads, the glTF material's F0 per channel) of one part at
    the points."""
    bases, f0 = _bases(info, cos_t.size, rng)
    return bases, _served_rgb(info, manifest, folder, _stacks(eta2, cos_t, thickness, bases)), f0


def _bases(info: dict[str, Any], n: int, rng: np.random.Generator) -> tuple[list[Bases], list[Any]]:
    """(FilmPoints.build base keywords per channel, the glTF material's F0 per channel): a texture-driven
    metal's F0 drawn uniform up to each channel's reach, mapped through the manifest's table."""
    if "material" in info:  # one base for every channel
        base = {"eta3": info["base"][0], "kappa3": info["base"][1]}
        return [base] * 3, info.get("f0") or [_f0(info["base"][0], info["base"][1])] * 3
    if info.get("texture"):
        table = info["table"]
        f0 = [rng.uniform(0.0, top, n) for top in info["f0_max"]]
        return [
            {"eta3": np.interp(f, table["f0"], table["eta3"]), "kappa3": np.interp(f, table["f0"], table["kappa3"])}
            for f in f0
        ], f0
    if info.get("mapping") == "named":
        return [{"base": info["named"]}] * 3, info["f0"]
    unique: dict[tuple[float, float], Bases] = {}
    return [unique.setdefault((e, k), {"eta3": e, "kappa3": k}) for e, k in zip(info["eta3"], info["kappa3"])], info[
        "f0"
    ]


def _served_rgb(info: dict[str, Any], manifest: dict[str, Any], folder: Path, stacks: list[FilmPoints]) -> np.ndarray:
    """What the engine reads at the stacks, per channel: the runtime table (a part routed to it), the 4D LUT,
    or the atlas slice(s)."""
    if "constant" in info:  # vacuum over vacuum: nothing reflects
        return np.broadcast_to(np.asarray(info["constant"], float), (stacks[0].cos_theta.size, 3))
    if info.get("route") == "runtime":
        return _per_channel(runtime_rgb, stacks)
    names = [info["material"]] * 3 if "material" in info else info["channels"]
    entries = [manifest["materials"][name] for name in names]
    if entries[0]["kind"] == "lut":
        return _per_channel(Lut.load(folder / entries[0]["file"]).sample, stacks)
    atlas = Atlas.load(folder / entries[0]["file"])
    if len(set(names)) == 1:
        return _per_channel(lambda s: atlas.sample(names[0], s), stacks)
    return np.stack([atlas.sample(name, stacks[c])[:, c] for c, name in enumerate(names)], axis=-1)


def _f0(eta: Any, kappa: Any) -> Any:
    """Normal-incidence reflectance under air of a base η + iκ."""
    return ((eta - 1.0) ** 2 + kappa**2) / ((eta + 1.0) ** 2 + kappa**2)


def _gltf_model(eta2: float, cos_t: np.ndarray, thickness: np.ndarray, f0: list[Any]) -> tuple[np.ndarray, np.ndarray]:
    """(three.js's term, KHR_materials_iridescence's model as written) at the glTF material's F0 per channel.
    Both read only F0 from the base; a base η3 = 1, κ3 = 2√(F0/(1 − F0)) carries any F0 < 1 inside lutbake's
    domain (F0 clamped to 0.9999, as three.js clamps it)."""
    bases: dict[int, Bases] = {}
    per_channel = []
    for value in f0:
        if id(value) not in bases:
            clipped = np.clip(np.asarray(value, float), 0.0, 0.9999)
            bases[id(value)] = {"eta3": 1.0, "kappa3": 2.0 * np.sqrt(clipped / (1.0 - clipped))}
        per_channel.append(bases[id(value)])
    stacks = _stacks(eta2, cos_t, thickness, per_channel)
    model = _per_channel(lambda s: khr_iridescence_rgb(s, as_specified=True), stacks)
    return _per_channel(khr_iridescence_rgb, stacks), model


def _other_truth(
    info: dict[str, Any], mapping: str, eta2: float, cos_t: np.ndarray, thickness: np.ndarray, bases: list[Bases]
) -> np.ndarray:
    """The ground truth with each channel's F0 mapped by ``mapping`` instead."""
    other: dict[int, Bases] = {}
    for b in bases:
        if id(b) not in other:
            f0 = ((b["eta3"] - 1.0) ** 2 + b["kappa3"] ** 2) / ((b["eta3"] + 1.0) ** 2 + b["kappa3"] ** 2)
            eta, kappa, _ = conductor(np.atleast_1d(f0), mapping)
            other[id(b)] = {
                "eta3": eta if np.ndim(b["eta3"]) else eta[0],
                "kappa3": kappa if np.ndim(b["kappa3"]) else kappa[0],
            }
    stacks = _stacks(eta2, cos_t, thickness, [other[id(b)] for b in bases])
    return _per_channel(lambda s: reference_colour(s).values, stacks)


def _stacks(eta2: float, cos_t: np.ndarray, thickness: np.ndarray, bases: list[Bases]) -> list[FilmPoints]:
    """One FilmPoints per channel; channels sharing a base (the same dict) share one object."""
    built: dict[int, FilmPoints] = {}
    for b in bases:
        if id(b) not in built:
            built[id(b)] = FilmPoints.build(eta2=eta2, cos_theta=cos_t, thickness_nm=thickness, **b)
    return [built[id(b)] for b in bases]


def _per_channel(colour: Callable[[FilmPoints], np.ndarray], stacks: list[FilmPoints]) -> np.ndarray:
    """RGB with channel c from ``colour(stacks[c])`` (one evaluation when the stacks are one)."""
    if all(s is stacks[0] for s in stacks):
        return colour(stacks[0])
    return np.stack([colour(s)[:, c] for c, s in enumerate(stacks)], axis=-1)


def _stats(rgb: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    de = delta_e00(rgb, truth)
    return {"de00_p99": float(np.percentile(de, 99)), "de00_max": float(de.max()), "de00_mean": float(de.mean())}


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
                "<table><tr><th>part</th><th>mapping</th><th>baked p99 / max</th>"
                "<th>three.js p99 / max</th><th>three.js vs glTF's model</th><th>glTF's model vs the physics</th>"
                "<th>other mapping p99 / max</th></tr>"
            )
            for name, p in r["parts"].items():
                cells = [
                    f"{c['de00_p99']:.2f} / {c['de00_max']:.2f}" if c else ""
                    for c in (p["de00"].get(k) for k in _HTML_COLUMNS)
                ]
                parts.append(
                    f"<tr><td>{esc(name)}</td><td>{esc(str(p.get('mapping', 'ior')))}</td>"
                    + "".join(f"<td>{c}</td>" for c in cells)
                    + "</tr>"
                )
            parts.append("</table>")
    return "\n".join(parts) + "\n"
