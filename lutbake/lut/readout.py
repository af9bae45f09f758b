"""A LUT or a scene atlas read at points as `lutbake sample` reads it, each read with its in-domain flag.

A 4D LUT is read by its header's interpolation rule unless another is asked for; quantized filter weights
(``filter_bits``, as a GPU texture unit's) apply to linear reads only. An atlas is read in one material's
slice, which fixes the ambient, film and base: only cos θ and the thickness vary. Points outside the
domain are clamped to it, as an engine's sampler clamps, and flagged.
"""

from __future__ import annotations

from os import PathLike

from lutbake.errors import ParameterError
from lutbake.lut.sample import Atlas, load_table
from lutbake.physics.points import FilmPoints

__all__ = ["TableReads"]


class TableReads:
    """The reads of one table file (``path``: a LUT's or an atlas's EXR), checked before any point is read:
    an atlas needs ``material`` (one of its materials), a LUT takes none; ``filter_bits`` on a LUT read
    cubic is refused (ParameterError).

    >>> import lutbake
    >>> spec = lutbake.BakeSpec(eta2=1.5, axes=(lutbake.Axis("cos_theta", 0.0, 1.0, 4),
    ...     lutbake.Axis("opd_nm", 0.0, 600.0, 8), lutbake.Axis("eta3", 1.0, 2.0, 2),
    ...     lutbake.Axis("kappa3", 0.0, 1.0, 2)))
    >>> _ = lutbake.bake_lut(spec, "film.exr")
    >>> reads = TableReads("film.exr")
    >>> points = FilmPoints.build(**reads.film(), thickness_nm=100.0, cos_theta=[1.0, 0.5], eta3=[1.5, 2.5])
    >>> doc = reads.sample(points)
    >>> doc["interpolation"], [row["in_domain"] for row in doc["points"]]
    ('cubic', [True, False])
    >>> TableReads("film.exr", filter_bits=8)
    Traceback (most recent call last):
    ...
    lutbake.errors.ParameterError: filter_bits 8 applies to linear reads; 'film.exr' is read cubic (texel reads \
without filtering): add interpolation linear
    """

    def __init__(
        self,
        path: str | PathLike[str],
        material: str | None = None,
        filter_bits: int | None = None,
        interpolation: str | None = None,
    ):
        self.path, self.table, self.material, self.filter_bits = path, load_table(path), material, filter_bits
        if isinstance(self.table, Atlas):
            if material is None:
                raise ParameterError(
                    "{material} is required with a scene atlas: allowed {names}", names=", ".join(self.table.materials)
                )
            self.table.slice_of(material)  # an unknown name fails here, naming the allowed ones
            return
        if material is not None:
            raise ParameterError(
                "{material} {name} is for scene atlases; {path} is a 4D LUT", name=repr(material), path=repr(path)
            )
        self.interpolation = interpolation or self.table.interpolation
        if filter_bits is not None and self.interpolation == "cubic":
            raise ParameterError(
                "{filter_bits} {bits} applies to linear reads; {path} is read cubic (texel reads without "
                "filtering): add {interpolation} linear",
                bits=filter_bits,
                path=repr(path),
            )

    @property
    def is_atlas(self) -> bool:
        return isinstance(self.table, Atlas)

    def film(self) -> dict:
        """``FilmPoints.build`` keywords the table fixes: a LUT's ambient and film, a slice's and its base."""
        if isinstance(self.table, Atlas):
            return self.table.film_stack(self._atlas_material())
        return {"eta1": self.table.eta1, "eta2": self.table.eta2}

    def sample(self, points: FilmPoints) -> dict:
        """The document `sample --json` prints: the table, its space, and per point its coordinates, RGB and
        whether it lies inside the table's domain."""
        if isinstance(self.table, Atlas):
            return self._sample_atlas(self.table, points)
        rgb = self.table.sample(points, self.filter_bits, self.interpolation)
        inside = self.table.in_domain(points)
        columns = {
            "cos_theta": points.cos_theta.tolist(),
            "opd_nm": points.opd_nm.tolist(),
            "eta3": points.eta3.tolist(),
            "kappa3": points.kappa3.tolist(),
        }
        rows = [
            {**dict(zip(columns, values)), "rgb": v.tolist(), "in_domain": bool(i)}
            for *values, v, i in zip(*columns.values(), rgb, inside)
        ]
        space = self.table.meta["space"]
        return {"lut": str(self.path), "space": space, "interpolation": self.interpolation, "points": rows}

    def _atlas_material(self) -> str:
        """The material read in an atlas (required when the reads were made)."""
        if self.material is None:
            raise ValueError("an atlas is read in a material")  # __init__ refused an atlas without one
        return self.material

    def _sample_atlas(self, atlas: Atlas, points: FilmPoints) -> dict:
        material = self._atlas_material()
        rgb = atlas.sample(material, points, self.filter_bits)
        inside = atlas.in_domain(material, points)
        rows = [
            {"cos_theta": float(c), "thickness_nm": float(t), "rgb": v.tolist(), "in_domain": bool(i)}
            for c, t, v, i in zip(points.cos_theta, points.thickness_nm, rgb, inside)
        ]
        return {"atlas": str(self.path), "material": material, "space": atlas.meta["space"], "points": rows}
