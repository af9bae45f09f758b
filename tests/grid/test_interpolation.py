"""The cubic rule (lutbake/grid/interpolation.py) against an independent statement of it: pad the 4D grid
with its ghost nodes explicitly (mirror at the low end of a √ axis from 0, quadratic extrapolation
elsewhere), apply the textbook Catmull-Rom formula to the padded grid, and clamp to the range of the
4⁴ real nodes the read takes. Also the properties the rule is chosen for: it returns node values at
nodes, reproduces quadratics in the node coordinate exactly, never overshoots the texels it reads, and
beats linear reads of the same texels on a real LUT."""

import itertools

import numpy as np
import pytest

import lutbake
from lutbake.grid.interpolation import cubic_taps
from lutbake.grid.layout import TileLayout
from lutbake.grid.spec import Axis, BakeSpec
from lutbake.lut.sample import Lut
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints

SHAPE = (6, 7, 5, 4)


def _axes(shape, spacings):
    """Axes of ``shape``; a spacing 'X+corner' zooms into the grazing corner (1 node, scale 50; η3 then
    starts at η1 = 1, as the zoom needs)."""
    names, spans = ("cos_theta", "opd_nm", "eta3", "kappa3"), ((0.0, 1.0), (0.0, 900.0), (1.2, 2.4), (0.0, 3.0))
    out = []
    for n, (lo, hi), c, s in zip(names, spans, shape, spacings):
        spacing, _, corner = s.partition("+")
        out.append(Axis(n, 1.0 if corner and n == "eta3" else lo, hi, c, spacing, (1, 50.0) if corner else ()))
    return tuple(out)


def _lut(grid, axes):
    """A LUT in memory whose node (i, j, k, l) holds grid[i, j, k, l] (float64 texels)."""
    spec = BakeSpec(eta2=1.5, axes=axes)
    layout = TileLayout(*spec.shape)
    width, height = layout.size
    image = np.zeros((height, width, 3))
    idx = np.meshgrid(*(np.arange(n) for n in spec.shape), indexing="ij")
    x, y = layout.texel(*idx)
    image[y, x] = grid
    return Lut.in_memory(spec, image)


def _stack(values):
    """Film stacks of the test LUTs' film (η2 1.5 in air) at axis values (cos θ, D, η3, κ3)."""
    return FilmPoints.texels(
        eta1=1.0, eta2=1.5, cos_theta=values[0], opd_nm=values[1], eta3=values[2], kappa3=values[3]
    )


def _padded(grid, mirror):
    """The grid with one ghost node before and after every axis, as the rule defines them."""
    for axis in range(4):
        g = np.moveaxis(grid, axis, 0)
        low = g[1] if mirror[axis] else 3 * g[0] - 3 * g[1] + g[2]
        high = 3 * g[-1] - 3 * g[-2] + g[-3]
        grid = np.moveaxis(np.concatenate([low[None], g, high[None]]), 0, axis)
    return grid


def _catmull_rom(padded, f):
    """Textbook Catmull-Rom at node coordinates f (one point), on the padded grid (offset 1)."""
    taps = []
    for fi, n in zip(f, padded.shape[:4]):
        i = min(int(np.floor(fi)), n - 4)  # the cell's lower node (padded index i + 1)
        t = fi - i
        taps.append(
            (
                i,
                [
                    0.5 * (-t + 2 * t * t - t**3),
                    0.5 * (2 - 5 * t * t + 3 * t**3),
                    0.5 * (t + 4 * t * t - 3 * t**3),
                    0.5 * (t**3 - t * t),
                ],
            )
        )
    total = np.zeros(3)
    for k in itertools.product(range(4), repeat=4):
        w = np.prod([taps[a][1][k[a]] for a in range(4)])
        total += w * padded[tuple(taps[a][0] + k[a] for a in range(4))]
    return total


def _stencil_range(grid, f):
    """Per channel (min, max) of the 4 × 4 × 4 × 4 real nodes a read takes (docs/lut-format.md): per axis
    nodes lower − 1 … lower + 2, moved inside the grid at its ends (0 … 3 in the first cell, N − 4 … N − 1
    in the last)."""
    cut = []
    for fi, n in zip(f, grid.shape[:4]):
        lower = min(int(np.floor(fi)), n - 2)
        first = min(max(lower - 1, 0), n - 4)
        cut.append(slice(first, first + 4))
    block = grid[tuple(cut)].reshape(-1, 3)
    return block.min(axis=0), block.max(axis=0)


@pytest.mark.parametrize(
    "spacings",
    [
        ("sqrt", "uniform", "uniform", "sqrt"),
        ("root4", "sqrt", "sqrt", "root4"),
        ("uniform",) * 4,
        ("sqrt", "uniform", "sqrt-admittance", "sqrt"),
        ("sqrt", "sqrt+corner", "sqrt-admittance+corner", "root4+corner"),
    ],
)
def test_cubic_reads_match_the_padded_textbook_rule(spacings):
    """Mirrored ghosts exactly where an axis is √- or ¼-power-spaced from 0 (cos θ, κ3 here; D's √
    axis from 0 too; η3's starts at 1.2, so it extrapolates; its admittance nodes follow each point's
    own cos θ, as do the corner zoom's nodes of D, η3 and κ3)."""
    rng = np.random.default_rng(3)
    axes = _axes(SHAPE, spacings)
    mirror = [a.spacing in ("sqrt", "root4") and a.lo == 0.0 and not any(b.corner for b in axes) for a in axes]
    grid = rng.normal(size=SHAPE + (3,))
    lut = _lut(grid, axes)
    f = rng.uniform(0, 1, (300, 4)) * (np.array(SHAPE) - 1)
    f[:40] = np.round(f[:40])  # nodes, ends included
    f[40:80, 0] = rng.uniform(0, 1, 40)  # first and last cells of every axis
    f[80:120, 1] = SHAPE[1] - 1 - rng.uniform(0, 1, 40)
    if any(a.corner for a in axes):  # at cos θ1 = 0 the zoom is a step (no value has a node coordinate below
        f[:, 0] = np.maximum(f[:, 0], 0.2)  # it), and near it η3 − η1 ∝ cos² θ1 outruns float64's η3 (f ≥ 0.2)
    cos_theta = axes[0].from_unit(f[:, 0] / (axes[0].count - 1))
    values = [a.from_unit(f[:, i] / (a.count - 1), cos_theta) for i, a in enumerate(axes)]
    got = lut.sample(_stack(values))
    padded = _padded(grid, mirror)
    unclamped = np.array([_catmull_rom(padded, p) for p in f])
    want = np.array([np.clip(u, *_stencil_range(grid, p)) for u, p in zip(unclamped, f)])
    assert np.abs(got - want).max() < 1e-10
    # The control: the linear rule is another function of the same texels (the clamp acts: below).
    assert np.abs(lut.sample(_stack(values), interpolation="linear") - want).max() > 0.1


def test_cubic_reads_are_continuous_where_a_weight_reaches_zero():
    """At the last node (t = 1) three taps of an axis weigh 0; 1e-6 inside they weigh ~1e-6. The read must
    not jump there (a clamp to the non-zero weights' texels jumped by the other axes' overshoot: 2e-4 on a
    default metal LUT, where a GPU's float32 node coordinate lands 1e-5 short of the node)."""
    axes = _axes(SHAPE, ("uniform",) * 4)
    rng = np.random.default_rng(11)
    grid = rng.normal(size=SHAPE + (3,))
    lut = _lut(grid, axes)
    f = rng.uniform(0, 1, (200, 4)) * (np.array(SHAPE) - 1)
    on = f.copy()
    on[:, 0] = SHAPE[0] - 1
    near = on.copy()
    near[:, 0] -= 1e-6
    reads = [lut.sample(_stack([a.from_unit(g[:, i] / (a.count - 1)) for i, a in enumerate(axes)])) for g in (on, near)]
    assert np.abs(reads[0] - reads[1]).max() < 1e-4


def test_cubic_reads_stay_within_the_texels_they_read_where_catmull_rom_overshoots():
    """A step (1 at cos θ node 0, 0 beyond; R at grazing over a base matching the ambient): plain
    Catmull-Rom dips to −0.074 in the second cell (the issue's read at cos θ 0.001, D 0); clamped reads
    stay in [0, 1] and equal the unclamped sum wherever it lies inside."""
    axes = _axes(SHAPE, ("uniform",) * 4)
    grid = np.zeros(SHAPE + (3,))
    grid[0] = 1.0
    lut = _lut(grid, axes)
    f0 = np.linspace(0.0, 3.0, 301)
    rng = np.random.default_rng(9)
    f = np.column_stack([f0, *(rng.uniform(0, n - 1, f0.size) for n in SHAPE[1:])])
    values = [a.from_unit(f[:, i] / (a.count - 1)) for i, a in enumerate(axes)]
    got = lut.sample(_stack(values))
    unclamped = np.array([_catmull_rom(_padded(grid, [False] * 4), p) for p in f])
    assert unclamped.min() < -0.07  # the overshoot being fixed
    assert got.min() >= 0.0 and got.max() <= 1.0
    inside = np.all((unclamped >= 0) & (unclamped <= 1), axis=1)
    assert np.abs(got - unclamped)[inside].max() < 1e-12
    clamped = np.array([np.clip(u, *_stencil_range(grid, p)) for u, p in zip(unclamped, f)])
    assert np.abs(got - clamped).max() < 1e-12


def test_cubic_reads_return_nodes_and_reproduce_quadratics():
    axes = _axes(SHAPE, ("uniform",) * 4)
    u = np.meshgrid(*(np.arange(n, dtype=float) for n in SHAPE), indexing="ij")

    def quadratic(c):
        return (0.3 + c[0] - 0.2 * c[1] + 0.05 * c[0] * c[3] + 0.1 * c[2] ** 2 - 0.07 * c[1] * c[2])[
            ..., None
        ] * np.ones(3)

    lut = _lut(quadratic(u), axes)
    rng = np.random.default_rng(5)
    f = rng.uniform(0, 1, (500, 4)) * (np.array(SHAPE) - 1)
    values = [a.from_unit(f[:, i] / (a.count - 1)) for i, a in enumerate(axes)]
    assert np.abs(lut.sample(_stack(values)) - quadratic(f.T)).max() < 1e-12
    assert np.abs(lut.sample(_stack(values), interpolation="linear") - quadratic(f.T)).max() > 1e-2  # control


@pytest.mark.parametrize("count", [2, 3, 4, 9])
def test_weights_sum_to_one_and_taps_stay_on_the_grid(count):
    f = np.linspace(0, count - 1, 97)
    for mirror in (False, True):
        first, w = cubic_taps(f, count, mirror)
        assert np.allclose(w.sum(axis=-1), 1.0, atol=1e-12)
        taps = first[:, None] + np.arange(4)
        assert np.all((w == 0) | ((taps >= 0) & (taps <= count - 1)))  # clamped taps weigh nothing


def test_cubic_reads_beat_linear_reads_of_the_same_texels(tmp_path):
    """A small real LUT scored at random points against the ground truth: on the same stored bytes
    the cubic rule's error is a fraction of the linear rule's."""
    axes = (
        Axis("cos_theta", 0.0, 1.0, 12, "sqrt"),
        Axis("opd_nm", 0.0, 1200.0, 40),
        Axis("eta3", 1.0, 2.0, 6, "admittance"),
        Axis("kappa3", 0.0, 1.0, 5, "sqrt"),
    )
    lutbake.bake_lut(BakeSpec(eta2=1.4, axes=axes, precision="half"), tmp_path / "lut.exr")
    lut = Lut.load(tmp_path / "lut.exr")
    assert lut.interpolation == "cubic"
    rng = np.random.default_rng(8)
    n = 2000
    stack = lutbake.FilmPoints.build(
        eta2=1.4,
        cos_theta=rng.uniform(0, 1, n),
        thickness_nm=rng.uniform(0, 1200, n) / 2.8,
        eta3=rng.uniform(1, 2, n),
        kappa3=rng.uniform(0, 1, n),
    )
    truth = lutbake.reference_rgb(stack)
    cubic, linear = (delta_e00(lut.sample(stack, interpolation=m), truth) for m in ("cubic", "linear"))
    assert np.percentile(cubic, 99) < 0.5 * np.percentile(linear, 99)
    assert cubic.mean() < 0.5 * linear.mean()


def test_sample_command_reads_by_the_header_or_the_given_rule(tmp_path):
    """`lutbake sample` follows the header (cubic), --interpolation linear overrides it, and
    --filter-bits (a property of bilinear fetches) is refused for cubic reads with exit 2."""
    import json
    import subprocess
    import sys

    axes = (
        Axis("cos_theta", 0.0, 1.0, 6, "sqrt"),
        Axis("opd_nm", 0.0, 900.0, 8),
        Axis("eta3", 1.2, 2.4, 4),
        Axis("kappa3", 0.0, 1.0, 4, "sqrt"),
    )
    path = tmp_path / "lut.exr"
    lutbake.bake_lut(BakeSpec(eta2=1.5, axes=axes), path)
    point = ["--opd", "333", "--cos-theta", "0.37", "--eta3", "1.61", "--kappa3", "0.2", "--json"]

    def run(*extra):
        return subprocess.run(
            [sys.executable, "-m", "lutbake.cli", "sample", str(path), *point, *extra], capture_output=True, text=True
        )

    lut = Lut.load(path)
    stack = FilmPoints.build(eta2=1.5, opd_nm=333.0, cos_theta=0.37, eta3=1.61, kappa3=0.2)
    for extra, rule in (((), "cubic"), (("--interpolation", "linear"), "linear")):
        out = run(*extra)
        doc = json.loads(out.stdout)
        assert out.returncode == 0 and doc["interpolation"] == rule
        assert np.allclose(doc["points"][0]["rgb"], lut.sample(stack, interpolation=rule)[0], rtol=0, atol=1e-12)
    refused = run("--filter-bits", "8")
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1 and "--filter-bits 8" in refused.stderr
    assert run("--filter-bits", "8", "--interpolation", "linear").returncode == 0
