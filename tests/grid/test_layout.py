"""The tile packing (lutbake/grid/layout.py) against its definition in docs/lut-format.md, stated independently here."""

import numpy as np

from lutbake.grid.layout import TileLayout


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


def test_kappa3_order_lays_kappa3_tiles_along_x():
    """docs/lut-format.md (format v6): tiles along x by κ3, along y by η3; every texel one node and back."""
    layout = TileLayout(n_cos=3, n_opd=4, n_eta3=5, n_kappa3=2, tiles_x="kappa3")
    width, height = layout.size
    assert (width, height) == (6, 20)
    y, x = np.mgrid[0:height, 0:width]
    nodes = layout.nodes(x, y)
    for got, want in zip(nodes, (x % 3, y % 4, y // 4, x // 3)):
        np.testing.assert_array_equal(got, want)
    back = layout.texel(*nodes)
    np.testing.assert_array_equal(back[0], x)
    np.testing.assert_array_equal(back[1], y)
    assert layout.packing()["tiles_x"] == "kappa3" and layout.packing()["tiles_y"] == "eta3"


def test_retile_moves_every_node_to_its_texel_in_the_other_order():
    by_eta3 = TileLayout(3, 4, 5, 2)
    by_kappa3 = TileLayout(3, 4, 5, 2, tiles_x="kappa3")
    width, height = by_eta3.size
    image = np.random.default_rng(0).uniform(size=(height, width, 3))
    moved = by_kappa3.retile(image, by_eta3)
    assert moved.shape == (*by_kappa3.size[::-1], 3)
    idx = np.meshgrid(*(np.arange(n) for n in (3, 4, 5, 2)), indexing="ij")
    x, y = by_eta3.texel(*idx)
    x2, y2 = by_kappa3.texel(*idx)
    np.testing.assert_array_equal(moved[y2, x2], image[y, x])
    np.testing.assert_array_equal(by_eta3.retile(moved, by_kappa3), image)
    np.testing.assert_array_equal(by_eta3.retile(image, by_eta3), image)


def test_a_file_tiles_by_kappa3_only_where_eta3_passes_the_side_and_kappa3_fits():
    assert TileLayout.for_grid((46, 104, 24, 24)).tiles_x == "eta3"  # 1104 × 2496
    assert TileLayout.for_grid((32, 176, 18, 28)).tiles_x == "kappa3"  # 576 × 4928 → 896 × 3168
    assert TileLayout.for_grid((4, 40, 2, 30), max_side=1000).size == (120, 80)
    assert TileLayout.for_grid((64, 128, 80, 40)).tiles_x == "eta3"  # neither fits: as before


def _tall_spec():
    """A grid whose η3 packing is 4,800 rows (300 D × 16 κ3 nodes): its file tiles by κ3 (48 × 600)."""
    from lutbake.grid.spec import Axis, BakeSpec

    return BakeSpec(
        eta2=2.0,
        axes=(
            Axis("cos_theta", 0.0, 1.0, 3, "sqrt"),
            Axis("opd_nm", 0.0, 3000.0, 300, "sqrt"),
            Axis("eta3", 0.02, 4.0, 2, "sqrt"),
            Axis("kappa3", 1.5, 9.0, 16, "root4"),
        ),
    )


def test_a_lut_past_4096_rows_is_written_by_kappa3_and_reads_as_its_grid(tmp_path):
    """The file (format v6) holds each node where the κ3 order puts it, and Lut.sample, cubic and linear,
    returns what the same texels return packed by η3."""
    import lutbake
    from lutbake.lut.sample import Lut

    spec = _tall_spec()
    lutbake.bake_lut(spec, tmp_path / "tall.exr")
    lut = Lut.load(tmp_path / "tall.exr")
    assert lut.meta["format_version"] == 6 and lut.meta["packing"]["tiles_x"] == "kappa3"
    assert lut.image.shape == (600, 48, 3)
    by_eta3 = Lut.in_memory(spec, spec.layout.retile(lut.image, lut.layout))
    rng = np.random.default_rng(4)
    n = 3000
    stack = lutbake.FilmPoints.build(
        eta2=2.0,
        cos_theta=rng.uniform(0.0, 1.0, n),
        opd_nm=rng.uniform(0.0, 3000.0, n),
        eta3=rng.uniform(0.02, 4.0, n),
        kappa3=rng.uniform(1.5, 9.0, n),
    )
    np.testing.assert_array_equal(lut.sample(stack), by_eta3.sample(stack))  # cubic: the same texels, same sums
    # linear: the bilinear weights come from x, y in another tile, equal to rounding
    np.testing.assert_allclose(
        lut.sample(stack, interpolation="linear"), by_eta3.sample(stack, interpolation="linear"), rtol=0, atol=1e-12
    )
    # the texel of a node is the node's colour: the corner node (cos θ 1, D 3000, η3 4, κ3 1.5) by the truth
    node = lutbake.FilmPoints.build(eta2=2.0, cos_theta=1.0, opd_nm=3000.0, eta3=4.0, kappa3=1.5)
    x, y = lut.layout.texel(2, 299, 1, 0)
    assert (x, y) == (2, 599)
    np.testing.assert_allclose(lut.image[y, x], lutbake.reference_rgb(node)[0], atol=2e-3)


def test_the_memory_estimate_holds_the_whole_image_where_the_file_retiles():
    spec = _tall_spec()
    assert spec.precision == "float" and spec.memory()["retile"] == spec.cells * 9 * 4
    assert "retile" not in _with_kappa3_count(spec, 2).memory()


def _with_kappa3_count(spec, n_kappa3):
    from dataclasses import replace

    return replace(spec, axes=spec.axes[:3] + (spec.axes[3].resized(n_kappa3),))


def test_a_header_tiling_by_kappa3_needs_format_6(tmp_path):
    """A v6 file relabelled version 5 (whose readers know only η3 along x) is refused by that field."""
    import json

    import pytest
    from hostile_cases import write_exr

    import lutbake
    from lutbake.tables.lutfile import read_lut

    lutbake.bake_lut(_tall_spec(), tmp_path / "tall.exr")
    meta, image = read_lut(tmp_path / "tall.exr")
    meta["format_version"] = 5
    write_exr(tmp_path / "v5.exr", json.dumps(meta), image)
    with pytest.raises(ValueError, match="packing.tiles_x"):
        read_lut(tmp_path / "v5.exr")
