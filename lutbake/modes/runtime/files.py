"""The runtime table as files: one RGBA half EXR, a JSON sidecar, GLSL and HLSL includes.

What the table holds and its header are made here; lutbake/tables/ writes and reads the files as it does
every table's (the header's schema: tables/headers.py) and renders the includes (tables/includes.py).

Image layout (docs/engines.md, "Runtime table"): U_c(X, w) − W_c of transform.py, W_c = Ŵ_c(0) the
channel's white (the table holds the departure from it: half floats keep ~11 bits of it, not of U). Tiles
of NODES × NODES texels (columns Re w, scanlines Im w, both from −1 to 1); the tile of slice pair j
(j = 0 … SLICES − 2) of channel c holds slices j and j + 1 as (Re, Im, Re, Im), so one bilinear read
gives both slices and the shader interpolates between them. Channel c's tiles fill a band of
BAND_ROWS tile rows, TILES_PER_ROW to a row, bands R, G, B from the top.

The same inputs give the same bytes (ZIP compression, no time or machine in the header); across machines
the float64 build may differ in the last bits, so a half texel can round the other way (the table is
generated, not committed: `lutbake runtime-table`).
"""

from __future__ import annotations

import functools
import hashlib
import json
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np

from lutbake import __version__
from lutbake.modes.runtime.transform import NODES, SLICES, X_MAX_NM, ZOOM_NM, transform_table
from lutbake.spectral.fourier import NU0_PER_NM
from lutbake.tables.headers import RUNTIME_FORMAT, RUNTIME_FORMAT_VERSION
from lutbake.tables.lutfile import read_lut, write_table_set

__all__ = [
    "RUNTIME_FORMAT",
    "RUNTIME_FORMAT_VERSION",
    "TILES_PER_ROW",
    "BAND_ROWS",
    "RuntimeTable",
    "stored_table",
    "write_runtime_table",
    "read_runtime_table",
]

TILES_PER_ROW = 32
BAND_ROWS = -(-(SLICES - 1) // TILES_PER_ROW)  # tile rows per channel band


@dataclass(frozen=True)
class RuntimeTable:
    """The table as an engine holds it: ``image`` (height, width, 4) float, the stored half values."""

    meta: dict
    image: np.ndarray

    def tile_origin(self, pair: int, channel: int) -> tuple[int, int]:
        """(x, y) texel of node (0, 0) of slice pair ``pair`` in channel band ``channel`` (scanlines from
        the top)."""
        row = pair // TILES_PER_ROW + channel * BAND_ROWS
        return (pair % TILES_PER_ROW) * NODES, row * NODES


def _image(u: np.ndarray, white: np.ndarray) -> np.ndarray:
    """(height, width, 4) float64 image of U − W (u: (3, SLICES, NODES, NODES) complex)."""
    v = u - white[:, None, None, None]
    image = np.zeros((3 * BAND_ROWS * NODES, TILES_PER_ROW * NODES, 4))
    for c in range(3):
        for j in range(SLICES - 1):
            row, col = j // TILES_PER_ROW + c * BAND_ROWS, j % TILES_PER_ROW
            tile = np.stack([v[c, j].real, v[c, j].imag, v[c, j + 1].real, v[c, j + 1].imag], axis=-1)
            image[row * NODES : (row + 1) * NODES, col * NODES : (col + 1) * NODES] = tile
    return image


def _white(observer: str, space: str) -> np.ndarray:
    """W_c = Ŵ_c(0) = ∫ w_c dλ (1 for every channel: the weights are normalized to white)."""
    from lutbake.physics.colorimetry import colorimetry

    cm = colorimetry(observer, space)
    return np.trapezoid(cm.rgb_table, cm.wavelength_nm.astype(float), axis=1)


def _metadata(observer: str, space: str, exact: np.ndarray, stored: np.ndarray, white: np.ndarray) -> dict:
    digest = hashlib.sha256(
        json.dumps(
            [__version__, RUNTIME_FORMAT_VERSION, observer, space, X_MAX_NM, ZOOM_NM, SLICES, NODES, TILES_PER_ROW]
        ).encode()
    )
    height, width, _ = stored.shape
    illuminant = "D65" if space != "acescg" else "ACES white (CIE daylight series)"
    return {
        "format": RUNTIME_FORMAT,
        "format_version": RUNTIME_FORMAT_VERSION,
        "lutbake_version": __version__,
        "content_hash": digest.hexdigest()[:16],
        "observer": observer,
        "illuminant": illuminant,
        "space": space,
        "encoding": "linear",
        "precision": "half",
        "channels": ["R", "G", "B", "A"],
        "table": {
            "quantity": "U_c(X, w) - W_c: (1 - z) sum_m z^(m-1) A_c(m X), A_c(x) = W_c(x) exp(-2 pi i nu0 x)",
            "x_max_nm": X_MAX_NM,
            "x_spacing": "sqrt",
            "slices": SLICES,
            "nodes": NODES,
            "zoom_nm": ZOOM_NM,
            "nu0_per_nm": NU0_PER_NM,
            "white": [float(v) for v in white],
            "tiles_per_row": TILES_PER_ROW,
            "band_rows": BAND_ROWS,
            "width": width,
            "height": height,
            "layout": "tile (pair j, channel c) at column j mod tiles_per_row, tile row j div tiles_per_row "
            "+ c band_rows; texel (Re V_j, Im V_j, Re V_j+1, Im V_j+1), Re w along x, Im w "
            "along scanlines, both -1 to 1",
        },
        "error": {"storage_max": float(np.abs(stored - exact).max())},
    }


@functools.lru_cache(maxsize=4)
def stored_table(observer: str = "cie1931", space: str = "rec709") -> RuntimeTable:
    """The table `runtime-table` writes, as stored (half), without the file."""
    white = _white(observer, space)
    exact = _image(transform_table(observer, space), white)
    stored = exact.astype(np.float16)
    return RuntimeTable(_metadata(observer, space, exact, stored, white), stored.astype(np.float32))


def write_runtime_table(out_path: str | PathLike[str], observer: str = "cie1931", space: str = "rec709") -> dict:
    """Write NAME.exr, NAME.json, NAME.glsl and NAME.hlsl as one set; return the metadata."""
    from lutbake.lut.bake import _check_writable

    out_path = Path(out_path)
    _check_writable(out_path)
    table = stored_table(observer, space)
    write_table_set(out_path, table.image, table.meta, table.meta["precision"])
    return table.meta


def read_runtime_table(path: str | PathLike[str]) -> RuntimeTable:
    """The table as stored, its header checked against its schema before its pixels are read (ValueError
    names the file and what is wrong)."""
    meta, image = read_lut(path, (RUNTIME_FORMAT,))
    return RuntimeTable(meta, image.astype(np.float32))
