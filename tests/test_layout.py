"""The tile packing (layout.py) against its definition in docs/lut-format.md, stated independently here."""

import numpy as np

from lutbake.layout import TileLayout


def test_every_texel_is_one_grid_node_and_back():
    layout = TileLayout(n_cos=3, n_opd=4, n_eta3=5, n_kappa3=2)
    width, height = layout.size
    assert (width, height) == (15, 8)
    y, x = np.mgrid[0:height, 0:width]
    nodes = layout.nodes(x, y)
    # docs/lut-format.md: cos θ fastest along x inside a tile, tiles along x by η3; D along y, tiles by κ3.
    expected = (x % 3, y % 4, x // 3, y // 4)
    for got, want in zip(nodes, expected):
        np.testing.assert_array_equal(got, want)
    back = layout.texel(*nodes)
    np.testing.assert_array_equal(back[0], x)
    np.testing.assert_array_equal(back[1], y)
    assert len({tuple(n) for n in np.stack([a.ravel() for a in nodes], axis=1)}) == width * height


def test_row_chunks_cover_every_row_once_within_the_cell_bound():
    layout = TileLayout(32, 128, 16, 16)
    chunks = layout.row_chunks(chunk_cells=10_000)
    rows = np.concatenate([np.arange(y0, y1) for y0, y1 in chunks])
    np.testing.assert_array_equal(rows, np.arange(layout.size[1]))
    assert all((y1 - y0) * layout.size[0] <= max(10_000, layout.size[0]) for y0, y1 in chunks)
