"""How a glTF part is scored: its points, its colour as the engine serves it, and its truth, one function that
the bake's target check (lutbake/scene/gltf/routes.py) and the receipt (lutbake/scene/gltf/receipt.py) both
call, so that the bake never calls a part met that its receipt fails (issue 34 item 3).

A part's colour is per channel: channel c of the stack whose base is channel c's (η3, κ3) (a coloured
specular or metal: a slice per channel, or a texture-driven metal's 4D LUT read at each channel's F0).
Points: cos θ uniform in √cos θ, thickness uniform over the material's range, a texture-driven metal's F0
uniform up to each channel's reach.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from lutbake.modes.runtime.model import runtime_rgb
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour

__all__ = [
    "Bases",
    "base_f0",
    "PartColours",
    "Sampler",
    "SharedTruth",
    "film_points",
    "film_stacks",
    "part_colours",
    "per_channel",
    "served_materials",
    "served_rgb",
    "truth_rgb",
]

# A channel's base as FilmPoints.build keywords: {eta3, kappa3} (numbers or arrays) or {base: a name}.
Bases = dict[str, Any]
# RGB (P, 3) of film stacks: a table's sampler, the runtime table, or a ground truth.
Sampler = Callable[[FilmPoints], np.ndarray]


@dataclass
class PartColours:
    """One part at its points: each channel's base keywords and stack, the glTF material's F0 per channel,
    what the engine reads there (``served``) and the ``truth`` it is scored against."""

    bases: list[Bases]
    f0: list[Any]
    stacks: list[FilmPoints]
    served: np.ndarray
    truth: np.ndarray


def film_points(record: dict[str, Any], n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(cos θ, thickness nm) of a glTF material's ``n`` points: √cos θ and thickness uniform."""
    cos_t = rng.uniform(0.0, 1.0, n) ** 2
    d_lo, d_hi = record["thickness_nm"]
    return cos_t, rng.uniform(d_lo, d_hi, n)


def part_colours(
    film: float,
    info: dict[str, Any],
    sampler_of: Callable[[str], Sampler],
    points: tuple[np.ndarray, np.ndarray],
    rng: np.random.Generator,
    truth: Sampler,
) -> PartColours:
    """One part (a manifest source record's ``parts`` entry) at ``points`` (``film_points``): served through
    ``sampler_of(scene material name)``, the runtime table (route runtime) or its constant, per channel, and
    ``truth`` per channel."""
    bases, f0 = _bases(info, points[0].size, rng)
    stacks = film_stacks(film, *points, bases)
    return PartColours(bases, f0, stacks, served_rgb(info, sampler_of, stacks), per_channel(truth, stacks))


def _bases(info: dict[str, Any], n: int, rng: np.random.Generator) -> tuple[list[Bases], list[Any]]:
    """(FilmPoints.build base keywords per channel, the glTF material's F0 per channel): a texture-driven
    metal's F0 drawn uniform up to each channel's reach, mapped through the manifest's table."""
    if "material" in info:  # one base for every channel
        base = {"eta3": info["base"][0], "kappa3": info["base"][1]}
        return [base] * 3, info.get("f0") or [base_f0(info["base"][0], info["base"][1])] * 3
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
    bases = [unique.setdefault((e, k), {"eta3": e, "kappa3": k}) for e, k in zip(info["eta3"], info["kappa3"])]
    return bases, info["f0"]


def served_rgb(info: dict[str, Any], sampler_of: Callable[[str], Sampler], stacks: list[FilmPoints]) -> np.ndarray:
    """What the engine reads at the stacks, per channel: the constant of a part with nothing to bake, the
    runtime table (a part routed to it), or its scene materials' tables (one, or one per channel)."""
    if "constant" in info:  # vacuum over vacuum: nothing reflects
        return np.broadcast_to(np.asarray(info["constant"], float), (stacks[0].cos_theta.size, 3))
    if info.get("route") == "runtime":
        return per_channel(runtime_rgb, stacks)
    names = served_materials(info) * 3 if "material" in info else info["channels"]
    if len(set(names)) == 1:
        return per_channel(sampler_of(names[0]), stacks)
    return np.stack([sampler_of(name)(stacks[c])[:, c] for c, name in enumerate(names)], axis=-1)


def served_materials(part: dict[str, Any]) -> list[str]:
    """The scene materials serving one part: its one ``material``, or its ``channels``."""
    return [part["material"]] if "material" in part else list(part["channels"])


def base_f0(eta: Any, kappa: Any) -> Any:
    """Normal-incidence reflectance under air of a base η + iκ."""
    return ((eta - 1.0) ** 2 + kappa**2) / ((eta + 1.0) ** 2 + kappa**2)


def film_stacks(eta2: float, cos_t: np.ndarray, thickness: np.ndarray, bases: list[Bases]) -> list[FilmPoints]:
    """One FilmPoints per channel; channels sharing a base (the same dict) share one object."""
    built: dict[int, FilmPoints] = {}
    for b in bases:
        if id(b) not in built:
            built[id(b)] = FilmPoints.build(eta2=eta2, cos_theta=cos_t, thickness_nm=thickness, **b)
    return [built[id(b)] for b in bases]


def per_channel(colour: Sampler, stacks: list[FilmPoints]) -> np.ndarray:
    """RGB with channel c from ``colour(stacks[c])`` (one evaluation when the stacks are one)."""
    if all(s is stacks[0] for s in stacks):
        return colour(stacks[0])
    return np.stack([colour(s)[:, c] for c, s in enumerate(stacks)], axis=-1)


def truth_rgb(stack: FilmPoints) -> np.ndarray:
    """The ground truth (spectral/reference.py) of film stacks: RGB (P, 3)."""
    return reference_colour(stack).values


class SharedTruth:
    """The ground truth of many parts' stacks, integrated together and once per distinct stack (same film,
    base and points): ``record`` notes a stack (and returns zeros in its place), ``integrate`` runs one
    reference_colour per film and base over every stack noted since, ``colour`` returns a noted stack's
    truth. A stack's truth does not depend on the others integrated with it (each point converges on its
    own), up to the rounding of where its points fall in the chunks (vectorized loops, ~1e-16).

    Counts, for the bench: ``stacks`` recorded, ``integrated`` (distinct), ``points`` integrated."""

    def __init__(self) -> None:
        self._pending: dict[tuple[Any, ...], FilmPoints] = {}
        self._done: dict[tuple[Any, ...], np.ndarray] = {}
        self.stacks = self.integrated = self.points = 0

    def record(self, stack: FilmPoints) -> np.ndarray:
        self.stacks += 1
        key = _stack_key(stack)
        if key not in self._done:
            self._pending.setdefault(key, stack)
        return np.zeros((len(stack), 3))

    def integrate(self) -> None:
        by_material: dict[tuple[Any, ...], list[tuple[Any, ...]]] = {}
        for key in self._pending:
            by_material.setdefault(key[:2], []).append(key)  # the film's and base's names
        for keys in by_material.values():
            stacks = [self._pending[k] for k in keys]
            values = truth_rgb(_joined(stacks))
            ends = np.cumsum([len(s) for s in stacks])
            self._done.update(zip(keys, np.split(values, ends[:-1]), strict=True))
            self.integrated += len(stacks)
            self.points += int(ends[-1])
        self._pending.clear()

    def colour(self, stack: FilmPoints) -> np.ndarray:
        return self._done[_stack_key(stack)]


_FIELDS = ("eta1", "eta2", "eta3", "kappa3", "cos_theta", "thickness_nm")


def _stack_key(stack: FilmPoints) -> tuple[Any, ...]:
    """What a stack's truth depends on: its named film and base (by name) and every field's values."""
    names = tuple(m.name if m is not None else None for m in (stack.film, stack.base))
    return names + tuple(np.ascontiguousarray(getattr(stack, f), float).tobytes() for f in _FIELDS)


def _joined(stacks: list[FilmPoints]) -> FilmPoints:
    """Stacks of one film and base as one."""
    fields = {f: np.concatenate([np.broadcast_to(getattr(s, f), (len(s),)) for s in stacks]) for f in _FIELDS}
    return FilmPoints(**fields, film=stacks[0].film, base=stacks[0].base)
