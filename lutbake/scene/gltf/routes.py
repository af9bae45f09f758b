"""Which route serves each part of a glTF bake: the bake's own tables, or the runtime table when they cannot
meet the target (issue 34 item 3, docs/gltf.md "Routes").

After the jobs run, every part is checked on the colour the engine composes, by the receipt's own scoring
(lutbake/scene/gltf/scoring.py: ``part_colours``) at `report`'s 1,000 points, held to the bound a fresh
report's p99 stays under at 99 % of seeds (quality.refine.p99_bound): a part whose channels come from
different slices, or from a 4D LUT read at each channel's F0, can miss where each slice meets it. A single
slice's part takes its slice's own verdict (refined on a superset of the receipt's points). A part that
misses is routed to the runtime table (``route`` runtime, ``route_by`` auto, ``route_why``), checked there,
and printed one line each; a named metal has no (η3, κ3) for the table and stays baked, unmet.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from lutbake.physics.colorimetry import delta_e00
from lutbake.quality.refine import REPORT_POINTS, p99_bound
from lutbake.scene.gltf.scoring import Sampler, film_points, part_colours, served_materials
from lutbake.scene.model import Scene

__all__ = ["choose_routes", "composed_parts", "planned_routes", "route_lines", "source_unmet", "CHECK_SEED"]

CHECK_SEED = 0  # the bake's check points: fixed, so the same inputs give the same routes and bytes
AUTO = "auto"


def choose_routes(
    scene: Scene,
    met: Callable[[str], bool],
    sampler_of: Callable[[str], Sampler],
    truth_of: Callable[[float], Sampler],
    rerefine: Callable[[list[str], float], set[str]] | None = None,
) -> set[str]:
    """Check every baked part of ``scene``'s glTF source (``met(scene material)``: its job's own verdict;
    ``sampler_of``: what the engine reads; ``truth_of(film η2)``: the bake's integrator's colour), recording
    ``target_check`` on the parts checked on their composed colour and routing the misses to the runtime
    table; the scene materials no longer served by the bake. A part of slices whose composed colour misses,
    that would go to the runtime table, first has its slices refined once more (``rerefine(scene materials,
    factor)``: each slice to its reached bound times ``factor`` < 1, within its resolution cap; the scene
    materials whose slices changed) and is checked again, and so is every part that reads a slice it changed."""
    assert scene.source is not None  # a glTF scene's
    routed: set[str] = set()
    changes: list[set[str]] = []  # the scene materials each re-refinement changed, in order
    checked_at: dict[int, int] = {}  # a composed part's: how many re-refinements its check saw

    def tracked(names: list[str], factor: float) -> None:
        assert rerefine is not None  # called only where given
        changes.append(rerefine(names, factor))

    for record, info in _baked_parts(scene.source):
        if _composed(info):
            check = _check(record, info, sampler_of, truth_of(record["film"]), scene.max_de)
            if not check["met"] and rerefine and _reroutable(info) and not info.get("texture"):
                check = _rerefined(record, info, check, sampler_of, truth_of(record["film"]), scene.max_de, tracked)
            info["target_check"], checked_at[id(info)] = check, len(changes)
            why = None if check["met"] else _composed_why(check, scene.max_de)
        else:
            missed = [m for m in served_materials(info) if not met(m)]
            why = f"its slice {missed[0]} misses p99 ΔE00 {scene.max_de:g} at the resolution cap" if missed else None
        if why is None or not _reroutable(info):
            continue
        info.update(route="runtime", route_by=AUTO, route_why=why)
        info["target_check"] = _check(record, info, sampler_of, truth_of(record["film"]), scene.max_de)
        routed.update(served_materials(info))
    for record, info in _baked_parts(scene.source):  # checked before a slice it reads was refined again
        later = set().union(*changes[checked_at.get(id(info), len(changes)) :])
        if later & set(served_materials(info)):
            kept = {k: v for k, v in info["target_check"].items() if k == "rerefined"}
            info["target_check"] = {**_check(record, info, sampler_of, truth_of(record["film"]), scene.max_de), **kept}
    return routed


def _reroutable(info: dict[str, Any]) -> bool:
    """Whether a miss sends the part to the runtime table: not forced to the bake, not a named metal (no (η3,
    κ3) for the table); those stay, unmet if they miss."""
    return info.get("route") != "bake" and info.get("mapping") != "named"


def _rerefined(
    record: dict[str, Any],
    info: dict[str, Any],
    check: dict[str, Any],
    sampler_of: Callable[[str], Sampler],
    truth: Sampler,
    max_de: float,
    rerefine: Callable[[list[str], float], None],
) -> dict[str, Any]:
    """The check again after the part's slices are refined once more, each to the bound it reached times the
    factor by which the composed bound missed the target (target / bound: the composed colour's error follows
    its slices' interpolation error); the check records that re-refinement (``rerefined``: the factor, the
    composed p99 and bound before)."""
    factor = max_de / check["de00_p99_bound"]
    rerefine(list(dict.fromkeys(served_materials(info))), factor)
    before = {k: check[k] for k in ("de00_p99", "de00_p99_bound")}
    return {**_check(record, info, sampler_of, truth, max_de), "rerefined": {"slice_factor": factor, **before}}


def _baked_parts(source: dict[str, Any]) -> Iterator[tuple[dict[str, Any], dict[str, Any]]]:
    """(material record, part) of every part the bake serves."""
    for record in source["materials"]:
        for info in record["parts"].values() if record["film"] is not None else ():
            if info.get("route") != "runtime" and "constant" not in info:
                yield record, info


def composed_parts(source: dict[str, Any]) -> list[tuple[dict[str, Any], dict[str, Any]]]:
    """(material record, part) of the baked parts whose colour is composed per channel from different tables or
    bases: a texture-driven metal's 4D LUT, or a slice per channel."""
    return [(record, info) for record, info in _baked_parts(source) if _composed(info)]


def _composed(info: dict[str, Any]) -> bool:
    """Whether a part's colour is composed per channel: a texture-driven metal, or a slice per channel."""
    return bool(info.get("texture")) or len(set(served_materials(info))) > 1


def planned_routes(record: dict[str, Any]) -> dict[str, dict[str, str]]:
    """What `plan` knows of each part's route before the bake: {part: {route, by, unless}}: a constant or a
    forced route (``--route``, extras) is final, and so is a named metal's bake (no (η3, κ3) for the table); any
    other part the bake serves stays baked ``unless`` its check misses (its composed colour, or its slice at the
    resolution cap; then the runtime table serves it), which only the bake can tell."""
    routes = {}
    for name, info in record["parts"].items() if record["film"] is not None else ():
        if "constant" in info:
            routes[name] = {"route": "constant", "by": "stack"}
        elif "route_by" in info:
            routes[name] = {"route": info["route"], "by": info["route_by"]}
        elif not _reroutable(info):  # a named metal: no (η3, κ3) for the table, so it stays baked
            routes[name] = {"route": "bake", "by": AUTO}
        else:
            miss = "its composed colour (a table per channel)" if _composed(info) else "its slice"
            routes[name] = {"route": "bake", "by": AUTO, "unless": f"{miss} misses the target"}
    return routes


def _check(
    record: dict[str, Any], info: dict[str, Any], sampler_of: Callable[[str], Sampler], truth: Sampler, max_de: float
) -> dict[str, Any]:
    """The part's composed colour scored as the receipt scores it, at REPORT_POINTS points of CHECK_SEED."""
    rng = np.random.default_rng(CHECK_SEED)
    colours = part_colours(record["film"], info, sampler_of, film_points(record, REPORT_POINTS, rng), rng, truth)
    de = delta_e00(colours.served, colours.truth)
    bound = p99_bound(de)
    return {
        "served_by": info.get("route", "bake"),
        "points": REPORT_POINTS,
        "de00_p99": float(np.percentile(de, 99)),
        "de00_p99_bound": bound,
        "met": bound <= max_de,
    }


def _composed_why(check: dict[str, Any], max_de: float) -> str:
    again = (
        f", after its slices were refined once more to {check['rerefined']['slice_factor']:.3f} of their error"
        if "rerefined" in check
        else ""
    )
    return (
        f"its composed colour (a table per channel) reaches p99 ΔE00 {check['de00_p99']:.3f} (bound "
        f"{check['de00_p99_bound']:.3f} at {check['points']:,} points) > the target {max_de:g}{again}"
    )


def route_lines(source: dict[str, Any] | None) -> list[str]:
    """One line per part the bake routed to the runtime table: the glTF material, the part, why."""
    if source is None or source.get("kind") != "gltf":
        return []
    return [
        f"materials[{r['gltf_index']}] {str(r['name'] or '')!r}: the {name} part is served by the runtime table: "
        f"{info['route_why']}"
        for r in source["materials"]
        for name, info in r["parts"].items()
        if info.get("route_by") == AUTO
    ]


def source_unmet(source: dict[str, Any] | None) -> dict[str, dict[str, float]]:
    """Parts whose composed check missed on the route that serves them: {label: p99, bound}."""
    if source is None or source.get("kind") != "gltf":
        return {}
    unmet = {}
    for r in source["materials"]:
        for name, info in r["parts"].items():
            check = info.get("target_check", {"met": True})
            if not check["met"]:
                label = f"materials[{r['gltf_index']}] {str(r['name'] or '')!r} {name} part"
                unmet[label] = {k: check[k] for k in ("de00_p99", "de00_p99_bound")}
    return unmet
