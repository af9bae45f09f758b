"""How a LUT's 4D grid is packed into one 2D image (docs/lut-format.md, "Packing").

Each (η3, κ3) node owns a tile n_cos texels wide (cos θ along x) and n_opd
texels high (D along y). The tiles run along x by one of η3, κ3 (``tiles_x``)
and along y by the other:

    tiles_x "eta3":   x = i_eta3 · n_cos + i_cos,    y = i_kappa3 · n_opd + i_opd
    tiles_x "kappa3": x = i_kappa3 · n_cos + i_cos,  y = i_eta3 · n_opd + i_opd   (format v6)

A file is packed by η3 along x, as every format before v6 was, unless that image passes MAX_SIDE texels
a side and the other order does not (``TileLayout.for_grid``): a grid dense in D and κ3 (a film over a
low-loss metal) then still fits the textures GPUs load. The integrators always work in the η3 order
(``compute``) and the bake re-tiles to the file's order before writing (``retile``).

This module is the one Python statement of that formula: the plan's texel
parameters, the sampler, the header's packing record and its check all take
it from here. The kernel (kernels/airy.cl) receives n_cos, n_opd and the
width from it; the kernel and the shader templates (shaders/lutbake.*.in)
write the same lines in their languages, and the tests hold both to it
(the kernel equals the numpy path on every texel; the includes return
``Lut.sample``'s numbers in glslang-checked GLSL and in three.js).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np

__all__ = ["TileLayout", "TILE_ORDERS", "MAX_SIDE"]

_CHUNK_CELLS = 1 << 20  # a band of rows holds about this many texels (the integrators' memory bound)
TILE_ORDERS = ("eta3", "kappa3")  # the axis whose nodes lay the tiles along x
MAX_SIDE = 4096  # texels a side nearly every WebGL2 device loads (docs/engines.md)
_Index = np.ndarray | int  # node or texel indices: arrays (broadcast) or one integer
_Coord = np.ndarray | float  # cos θ and D node coordinates, which may be fractional


@dataclass(frozen=True)
class TileLayout:
    """The packing of an (n_cos, n_opd, n_eta3, n_kappa3) grid: ``TileLayout(*spec.shape)`` (η3 along x),
    or ``TileLayout.for_grid(spec.shape)``, a file's order."""

    n_cos: int
    n_opd: int
    n_eta3: int
    n_kappa3: int
    tiles_x: str = "eta3"

    @classmethod
    def for_grid(cls, shape: tuple[int, int, int, int], max_side: int = MAX_SIDE) -> TileLayout:
        """The file's packing of a grid: η3 along x unless that image passes ``max_side`` a side and κ3
        along x does not."""
        n_cos, n_opd, n_eta3, n_kappa3 = shape
        by_eta3, by_kappa3 = cls(n_cos, n_opd, n_eta3, n_kappa3), cls(n_cos, n_opd, n_eta3, n_kappa3, "kappa3")
        return by_kappa3 if max(by_eta3.size) > max_side >= max(by_kappa3.size) else by_eta3

    @property
    def compute(self) -> TileLayout:
        """The same grid in the integrators' order (η3 along x)."""
        return TileLayout(self.n_cos, self.n_opd, self.n_eta3, self.n_kappa3)

    @property
    def _tiles(self) -> tuple[int, int]:
        """(tiles along x, tiles along y)."""
        return (self.n_eta3, self.n_kappa3) if self.tiles_x == "eta3" else (self.n_kappa3, self.n_eta3)

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of the image in texels."""
        along_x, along_y = self._tiles
        return along_x * self.n_cos, along_y * self.n_opd

    @overload
    def texel(self, cos_node: int, opd_node: int, eta3_node: int, kappa3_node: int) -> tuple[int, int]: ...
    @overload
    def texel(
        self, cos_node: _Coord, opd_node: _Coord, eta3_node: _Index, kappa3_node: _Index
    ) -> tuple[np.ndarray, np.ndarray]: ...
    def texel(
        self, cos_node: _Coord, opd_node: _Coord, eta3_node: _Index, kappa3_node: _Index
    ) -> tuple[_Coord, _Coord]:
        """Image (x, y) of grid node coordinates (arrays broadcast); the cos θ and D coordinates may be
        fractional, measured between texel centres, as a bilinear fetch takes them."""
        tile_x, tile_y = (eta3_node, kappa3_node) if self.tiles_x == "eta3" else (kappa3_node, eta3_node)
        return tile_x * self.n_cos + cos_node, tile_y * self.n_opd + opd_node

    @overload
    def nodes(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...
    @overload
    def nodes(self, x: np.ndarray | int, y: np.ndarray | int) -> tuple[_Index, _Index, _Index, _Index]: ...
    def nodes(self, x: np.ndarray | int, y: np.ndarray | int) -> tuple[_Index, _Index, _Index, _Index]:
        """(i_cos, i_opd, i_eta3, i_kappa3) of integer image coordinates (arrays broadcast)."""
        tile_x, tile_y = x // self.n_cos, y // self.n_opd
        i_eta3, i_kappa3 = (tile_x, tile_y) if self.tiles_x == "eta3" else (tile_y, tile_x)
        return x % self.n_cos, y % self.n_opd, i_eta3, i_kappa3

    def row_chunks(self, chunk_cells: int = _CHUNK_CELLS) -> list[tuple[int, int]]:
        """Bands [y0, y1) of image rows, each about ``chunk_cells`` texels (at least one row)."""
        width, height = self.size
        rows = max(1, chunk_cells // width)
        return [(y, min(y + rows, height)) for y in range(0, height, rows)]

    def retile(self, image: np.ndarray, source: TileLayout) -> np.ndarray:
        """``image`` (height, width, channels), packed by ``source`` (the same grid), packed by this layout."""
        along_x, along_y = source._tiles
        grid = image.reshape(along_y, self.n_opd, along_x, self.n_cos, -1)
        if source.tiles_x != self.tiles_x:  # (tile_y, D, tile_x, cos) → the tile axes swapped
            grid = grid.transpose(2, 1, 0, 3, 4)
        width, height = self.size
        return np.ascontiguousarray(grid.reshape(height, width, -1))

    def packing(self) -> dict[str, str | int]:
        """The header's record of this packing (lutfile checks a read header against it)."""
        width, height = self.size
        tiles_y = TILE_ORDERS[1 - TILE_ORDERS.index(self.tiles_x)]
        return {
            "layout": "tiles",
            "width": width,
            "height": height,
            "tile_x": "cos_theta",
            "tile_y": "opd_nm",
            "tiles_x": self.tiles_x,
            "tiles_y": tiles_y,
            "tile_width": self.n_cos,
            "tile_height": self.n_opd,
        }
