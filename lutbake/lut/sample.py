"""Reference sampler: what a GPU returns when it samples a lutbake LUT or scene atlas.

It reads only the EXR (metadata from its header) and follows the shader
includes step by step: each axis value → its warp (η3's "admittance" warp at
the point's own cos θ1) → a continuous node coordinate clamped to [0, N − 1];
then the header's interpolation rule (lutbake/grid/interpolation.py). Cubic: 4
Catmull-Rom taps per axis, 256 texels read exactly, the sum clamped to the
range of those texels. Linear: (cos θ, D) through
hardware bilinear filtering inside a tile (texel centres, clamp-to-edge
addressing), the four tiles around (η3, κ3) blended with manual lerps. An atlas slice is one
bilinear fetch inside its material's rect. ``filter_bits`` quantizes the
bilinear weights as fixed-function texture units do (8 bits on many GPUs);
None uses exact weights. Rows are scanlines counted from the top of the EXR;
the includes map them to each API's texture coordinates (docs/lut-format.md).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from os import PathLike
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.grid.interpolation import cubic_taps, mirrors_low_end
from lutbake.grid.layout import TileLayout
from lutbake.grid.spec import axis_from_header
from lutbake.physics.points import FilmPoints
from lutbake.tables.headers import ATLAS_FORMAT, FORMAT
from lutbake.tables.lutfile import read_lut

if TYPE_CHECKING:
    from lutbake.grid.axis import Axis
    from lutbake.grid.spec import BakeSpec

__all__ = ["Lut", "Atlas", "load_table"]


@dataclass
class Lut:
    """A 4D LUT as an engine samples it: the reference for what a shader include must return.

    ``sample`` interpolates in each axis's own coordinate (√cos θ, D, η3's spacing, √κ3) by the
    header's rule: clamped Catmull-Rom ('cubic', 256 texel reads) or the GPU's bilinear fetches
    ('linear', 4 per sample); docs/lut-format.md#interpolation.

    Attributes
    ----------
    meta : dict
        The EXR header's metadata (axes, constants η1 and η2, space, observer, integrator, ...).
    image : numpy.ndarray
        (height, width, 3) texels as stored (float16 or float32), linear RGB.

    Examples
    --------
    >>> import lutbake
    >>> axes = (lutbake.Axis("cos_theta", 0.0, 1.0, 24, "sqrt"), lutbake.Axis("opd_nm", 0.0, 1200.0, 96),
    ...         lutbake.Axis("eta3", 1.0, 1.5, 6, "admittance"), lutbake.Axis("kappa3", 0.0, 0.5, 2))
    >>> _ = lutbake.bake_lut(lutbake.BakeSpec(eta2=1.33, axes=axes), "soap.exr")
    >>> lut = lutbake.Lut.load("soap.exr")
    >>> [(a.name, a.count) for a in lut.axes], lut.eta2
    ([('cos_theta', 24), ('opd_nm', 96), ('eta3', 6), ('kappa3', 2)], 1.33)
    >>> soap = lutbake.FilmPoints.build(eta2=1.33, thickness_nm=300.0, angle_deg=45.0, eta3=1.0)
    >>> rgb = lut.sample(soap)
    >>> bool(abs(rgb - lutbake.reference_rgb(soap)).max() < 0.01)
    True
    >>> lut.sample(lutbake.FilmPoints.build(eta2=1.5, thickness_nm=300.0, cos_theta=1.0, eta3=1.0))
    Traceback (most recent call last):
    ...
    lutbake.errors.ParameterError: eta2 1.5 differs from the LUT's eta2 = 1.33
    """

    meta: dict
    image: np.ndarray | None  # (height, width, 3), as stored; None: a grid without texels (``in_memory``)

    @classmethod
    def load(cls, path: str | PathLike[str]) -> Lut:
        """Read a LUT EXR (refused in one line when it is not a complete, valid lutbake LUT)."""
        meta, image = read_lut(path)
        return cls(meta, image)

    @classmethod
    def in_memory(cls, spec: BakeSpec, image: np.ndarray | None) -> Lut:
        """The LUT of ``spec`` whose texels are ``image`` (as stored, packed as the integrators pack it:
        ``spec.layout``), without a file: what tune scores. With ``image`` None it has the grid's axes and
        coordinates but nothing to sample (what a search over the grid's domain needs)."""
        return cls(
            {
                "axes": [a.describe() for a in spec.axes],
                "interpolation": spec.interpolation,
                "constants": {"eta1": spec.eta1, "eta2": spec.eta2},
                "space": spec.space,
                "observer": spec.observer,
                "packing": spec.layout.packing(),
            },
            image,
        )

    @property
    def axes(self) -> list[Axis]:
        return [axis_from_header(a) for a in self.meta["axes"]]

    @property
    def layout(self) -> TileLayout:
        """How the image packs the grid (the header's packing record)."""
        n_cos, n_opd, n_eta3, n_kappa3 = (a["count"] for a in self.meta["axes"])
        return TileLayout(n_cos, n_opd, n_eta3, n_kappa3, tiles_x=self.meta["packing"]["tiles_x"])

    @property
    def eta1(self) -> float:
        return self.meta["constants"]["eta1"]

    @property
    def eta2(self) -> float:
        return self.meta["constants"]["eta2"]

    def coordinates(self, stack: FilmPoints) -> tuple[np.ndarray, ...]:
        """The stacks' LUT coordinates in axis order (cos θ1, D, η3, κ3), broadcast; a stack of another
        film than the LUT's (η1, η2, constant indices) is refused (ParameterError)."""
        stack.require("LUT", film=None, base=None, eta1=self.eta1, eta2=self.eta2)
        return np.broadcast_arrays(stack.cos_theta, stack.opd_nm, stack.eta3, stack.kappa3)

    def in_domain(self, stack: FilmPoints) -> np.ndarray:
        """True where every coordinate lies inside the LUT's axis ranges."""
        ok: bool | np.ndarray = True
        for axis, v in zip(self.axes, self.coordinates(stack)):
            ok = ok & (v >= axis.lo) & (v <= axis.hi)
        return np.asarray(ok)

    def node_coords(self, stack: FilmPoints) -> list[np.ndarray]:
        """Continuous node coordinates in [0, N − 1] per axis (clamped, like the shaders)."""
        values = self.coordinates(stack)
        return [
            np.asarray(np.clip(axis.to_unit(v, values[0], self.eta1), 0.0, 1.0) * (axis.count - 1))
            for axis, v in zip(self.axes, values)
        ]

    @property
    def interpolation(self) -> str:
        """The header's interpolation rule ('cubic' or 'linear'; files before format v3 are linear)."""
        return self.meta.get("interpolation", "linear")

    def sample(self, stack: FilmPoints, filter_bits: int | None = None, interpolation: str | None = None) -> np.ndarray:
        """Linear RGB (…, 3) of film stacks of the LUT's film (``FilmPoints``, fields broadcast), by the
        header's interpolation rule (or ``interpolation``). ``filter_bits`` applies to linear reads only:
        cubic reads take texels exactly."""
        f = self.node_coords(stack)
        if (interpolation or self.interpolation) == "cubic":
            return self._cubic(f)
        return self._linear(f, filter_bits)

    def _texels(self) -> np.ndarray:
        """The image, or ValueError for a LUT made without one (``in_memory(spec, None)``)."""
        if self.image is None:
            raise ValueError("this LUT was made without texels (Lut.in_memory(spec, None)): nothing to sample")
        return self.image

    def _linear(self, f: list[np.ndarray], filter_bits: int | None) -> np.ndarray:
        """(cos θ, D) by hardware bilinear inside the 4 tiles around (η3, κ3), then 3 lerps."""
        f_cos, f_opd, f_eta3, f_kappa3 = f
        layout = self.layout
        i_e, t_e = _lower_node(f_eta3, layout.n_eta3)
        i_k, t_k = _lower_node(f_kappa3, layout.n_kappa3)
        corners = {}
        for de in (0, 1):
            for dk in (0, 1):  # (cos θ, D) bilinear within the tile of η3 node i_e + de, κ3 node i_k + dk
                x, y = layout.texel(f_cos, f_opd, i_e + de, i_k + dk)
                corners[de, dk] = _bilinear(self._texels(), x, y, filter_bits)
        lower = _lerp(corners[0, 0], corners[1, 0], t_e)
        upper = _lerp(corners[0, 1], corners[1, 1], t_e)
        return _lerp(lower, upper, t_k)

    def _cubic(self, f: list[np.ndarray]) -> np.ndarray:
        """Clamped Catmull-Rom in all four axes (lutbake/grid/interpolation.py): 4⁴ texel reads, summed tile
        by tile, then clamped per channel to the range of the texels read."""
        axes = self.axes
        layout = self.layout
        zoomed = any(a.corner for a in axes)
        taps = [cubic_taps(fi, a.count, mirrors_low_end(a.spacing, a.lo, zoomed)) for fi, a in zip(f, axes)]
        nodes = [[np.clip(first + k, 0, a.count - 1) for k in range(4)] for (first, _), a in zip(taps, axes)]
        out = np.zeros(f[0].shape + (3,))
        low, high = np.full_like(out, np.inf), np.full_like(out, -np.inf)
        for k in itertools.product(range(4), repeat=4):
            weight = np.prod([w[..., j] for (_, w), j in zip(taps, k)], axis=0)[..., None]
            x, y = layout.texel(*(n[j] for n, j in zip(nodes, k)))
            texel = self._texels()[y, x].astype(np.float64)
            out += weight * texel
            low, high = np.minimum(low, texel), np.maximum(high, texel)
        return np.clip(out, low, high)


@dataclass
class Atlas:
    """A scene atlas: one (cos θ, thickness) slice per rect, each serving named materials.

    ``sample(material, stack)`` is one bilinear fetch in the material's rect, at (√cos θ, thickness)
    node coordinates: what the scene's include returns.

    Examples
    --------
    >>> import lutbake
    >>> _ = open("steel.toml", "w").write('''
    ... [materials.oxide]
    ... film = 2.9
    ... thickness_nm = [10, 70]
    ... base = "Fe"
    ... ''')
    >>> _ = lutbake.bake_scene(lutbake.load_scene("steel.toml"), "baked")
    >>> atlas = lutbake.Atlas.load("baked/steel.exr")
    >>> list(atlas.materials)
    ['oxide']
    >>> oxide = lutbake.FilmPoints.build(**atlas.film_stack("oxide"), thickness_nm=40.0, cos_theta=0.8)
    >>> rgb = atlas.sample("oxide", oxide)
    >>> bool(abs(rgb - lutbake.reference_rgb(oxide)).max() < 0.01)
    True
    """

    meta: dict
    image: np.ndarray  # (height, width, 3), as stored

    @classmethod
    def load(cls, path: str | PathLike[str]) -> Atlas:
        """Read a scene atlas EXR (refused in one line when it is not a valid lutbake atlas)."""
        meta, image = read_lut(path, (ATLAS_FORMAT,))
        return cls(meta, image)

    @property
    def materials(self) -> dict:
        """Material name → its slice's description in the header (rect, axes, film, base)."""
        return {name: s for s in self.meta["slices"] for name in s["materials"]}

    def slice_of(self, material: str) -> dict:
        if material not in self.materials:
            raise ValueError(f"material {material!r} is not in this atlas: allowed {', '.join(self.materials)}")
        return self.materials[material]

    def film_stack(self, material: str) -> dict:
        """FilmPoints.build keywords for the material's ambient, film and base (named or constant)."""
        s = self.slice_of(material)
        film = {"film": s["film"]} if isinstance(s["film"], str) else {"eta2": s["film"]}
        base = {"base": s["base"]} if isinstance(s["base"], str) else dict(zip(("eta3", "kappa3"), s["base"]))
        return {"eta1": self.meta["eta1"], **film, **base}

    def coordinates(self, material: str, stack: FilmPoints) -> tuple[np.ndarray, ...]:
        """The stacks' slice coordinates (cos θ1, thickness in nm), broadcast; a stack of another ambient,
        film or base than the material's is refused (ParameterError)."""
        stack.require(f"material {material!r}", **{"film": None, "base": None, **self.film_stack(material)})
        return np.broadcast_arrays(stack.cos_theta, stack.thickness_nm)

    def in_domain(self, material: str, stack: FilmPoints) -> np.ndarray:
        th = self.slice_of(material)["axes"]["thickness_nm"]
        c, t = self.coordinates(material, stack)
        return np.asarray((c >= 0) & (c <= 1) & (t >= th["min"]) & (t <= th["max"]))

    def sample(self, material: str, stack: FilmPoints, filter_bits: int | None = None) -> np.ndarray:
        """Linear RGB (…, 3) of film stacks of the material: node coordinates (√cos θ, thickness) clamped
        to the rect, one bilinear fetch."""
        s = self.slice_of(material)
        x0, y0, w, h = s["rect"]
        lo, hi = s["axes"]["thickness_nm"]["min"], s["axes"]["thickness_nm"]["max"]
        cos_theta, thickness_nm = self.coordinates(material, stack)
        fx = np.sqrt(np.clip(cos_theta, 0.0, 1.0)) * (w - 1)
        fy = np.clip((thickness_nm - lo) / (hi - lo), 0.0, 1.0) * (h - 1) if h > 1 else np.zeros_like(fx)
        return _bilinear(self.image, x0 + fx, y0 + fy, filter_bits)


def load_table(path: str | PathLike[str]) -> Lut | Atlas:
    """A Lut or an Atlas, whichever the EXR holds."""
    meta, image = read_lut(path, (FORMAT, ATLAS_FORMAT))
    return (Atlas if meta["format"] == ATLAS_FORMAT else Lut)(meta, image)


def _bilinear(image: np.ndarray, x: np.ndarray, y: np.ndarray, filter_bits: int | None) -> np.ndarray:
    """Hardware bilinear at texel-space (x, y) measured between texel centres, clamp-to-edge."""
    h, w, _ = image.shape
    x0, y0 = np.floor(x), np.floor(y)
    ax, ay = x - x0, y - y0
    if filter_bits:
        scale = float(1 << filter_bits)
        ax, ay = np.round(ax * scale) / scale, np.round(ay * scale) / scale
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)

    def tap(y: np.ndarray, x: np.ndarray) -> np.ndarray:  # gather first, widen only the taps (not the whole image)
        return image[y, x].astype(np.float64)

    top = _lerp(tap(y0, x0), tap(y0, x1), ax)
    bottom = _lerp(tap(y1, x0), tap(y1, x1), ax)
    return _lerp(top, bottom, ay)


def _lower_node(f: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    i = np.minimum(np.floor(f), count - 2).astype(np.int64)
    return i, f - i


def _lerp(a: np.ndarray, b: np.ndarray, t: npt.ArrayLike) -> np.ndarray:
    t = np.asarray(t, float)[..., None]
    return a * (1.0 - t) + b * t
