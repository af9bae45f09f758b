"""How a LUT's 4D grid is packed into one 2D image (docs/lut-format.md, "Packing").

Each (η3, κ3) node owns a tile n_cos texels wide (cos θ along x) and n_opd
texels high (D along y); tiles run along x by η3 and along y by κ3:

    x = i_eta3 · n_cos + i_cos,    y = i_kappa3 · n_opd + i_opd.

This module is the one Python statement of that formula: the plan's texel
parameters, the sampler, the header's packing record and its check all take
it from here. The kernel (kernels/airy.cl) receives n_cos, n_opd and the
width from it; the kernel and the shader templates (shaders/lutbake.*.in)
write the same two lines in their languages, and the tests hold both to it
(the kernel equals the numpy path on every texel; the includes return
``Lut.sample``'s numbers in glslang-checked GLSL and in three.js).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["TileLayout"]

_CHUNK_CELLS = 1 << 20   # a band of rows holds about this many texels (the integrators' memory bound)


@dataclass(frozen=True)
class TileLayout:
    """The packing of an (n_cos, n_opd, n_eta3, n_kappa3) grid: ``TileLayout(*spec.shape)``."""

    n_cos: int
    n_opd: int
    n_eta3: int
    n_kappa3: int

    @property
    def size(self) -> tuple:
        """(width, height) of the image in texels."""
        return self.n_eta3 * self.n_cos, self.n_kappa3 * self.n_opd

    def texel(self, cos_node, opd_node, eta3_node, kappa3_node):
        """Image (x, y) of grid node coordinates (arrays broadcast); the cos θ and D coordinates may be
        fractional, measured between texel centres, as a bilinear fetch takes them."""
        return eta3_node * self.n_cos + cos_node, kappa3_node * self.n_opd + opd_node

    def nodes(self, x, y) -> tuple:
        """(i_cos, i_opd, i_eta3, i_kappa3) of integer image coordinates (arrays broadcast)."""
        return x % self.n_cos, y % self.n_opd, x // self.n_cos, y // self.n_opd

    def row_chunks(self, chunk_cells: int = _CHUNK_CELLS) -> list:
        """Bands [y0, y1) of image rows, each about ``chunk_cells`` texels (at least one row)."""
        width, height = self.size
        rows = max(1, chunk_cells // width)
        return [(y, min(y + rows, height)) for y in range(0, height, rows)]

    def packing(self) -> dict:
        """The header's record of this packing (lutfile checks a read header against it)."""
        width, height = self.size
        return {"layout": "tiles", "width": width, "height": height, "tile_x": "cos_theta", "tile_y": "opd_nm",
                "tiles_x": "eta3", "tiles_y": "kappa3", "tile_width": self.n_cos, "tile_height": self.n_opd}
