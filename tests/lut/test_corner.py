"""The grazing corner's zoom (LUT format v5, docs/lut-format.md#the-grazing-corner).

At cos θ1 → 0 over a film D → 0 on a base η3 → η1, κ3 → 0 the Airy reflectance is a function of the
ratios D/cos θ1, (η3² − η1²)/cos² θ1 and κ3/cos² θ1 only, so no grid in (cos θ1, D, η3, κ3) can follow
it. These tests hold the zoomed node coordinate to its definition and the physics it relies on: the
coordinate inverts, it has a limit at cos θ1 = 0 (the column the bake writes there is the limit of the
ground truth along each node's curve, checked by scaling cos θ1 down a hundredfold with the ratios
fixed), and a small zoomed LUT follows the truth into the corner where an unzoomed one of the same size
cannot."""

import numpy as np
import pytest

import lutbake
from lutbake.errors import ParameterError
from lutbake.grid.spec import Axis, BakeSpec
from lutbake.grid.texels import CORNER_COS
from lutbake.lut.sample import Lut
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_rgb

ETA2 = 1.33


def _axes(zoom: bool, counts=(20, 40, 10, 10)):
    corner = (lambda nodes, scale: (nodes, scale)) if zoom else (lambda nodes, scale: ())
    return (
        Axis("cos_theta", 0.0, 1.0, counts[0], "uniform-root4" if zoom else "sqrt"),
        Axis("opd_nm", 0.0, 1500.0, counts[1], "sqrt", corner(8, 30.0)),
        Axis("eta3", 1.0, 2.5, counts[2], "sqrt-admittance", corner(4, 1.0)),
        Axis("kappa3", 0.0, 1.0, counts[3], "root4", corner(4, 1.0)),
    )


def _stack(cos_theta, opd_nm, eta3, kappa3):
    arrays = np.broadcast_arrays(*(np.asarray(v, float) for v in (cos_theta, opd_nm, eta3, kappa3)))
    return FilmPoints.texels(
        eta1=1.0, eta2=ETA2, cos_theta=arrays[0], opd_nm=arrays[1], eta3=arrays[2], kappa3=arrays[3]
    )


@pytest.mark.parametrize("axis", _axes(True)[1:], ids=lambda a: a.name)
@pytest.mark.parametrize("cos_theta", [1e-3, 0.05, 0.5, 1.0])
def test_zoomed_coordinate_inverts_and_increases(axis, cos_theta):
    u = np.linspace(0.0, 1.0, 201)
    v = axis.from_unit(u, cos_theta)
    assert np.all(np.diff(v) > 0) and v[0] == pytest.approx(axis.lo) and v[-1] == pytest.approx(axis.hi)
    assert np.abs(axis.to_unit(v, cos_theta) - u).max() < 1e-9


@pytest.mark.parametrize("axis", _axes(True)[1:], ids=lambda a: a.name)
def test_at_grazing_the_zoom_is_a_step_onto_its_share(axis):
    """cos θ1 = 0: every value past the low end has an infinite ratio (H = 1), the low end too (lutbake's
    truth reflects totally there): the coordinate never falls below the share β = nodes/(N − 1)."""
    beta = axis.corner[0] / (axis.count - 1)
    v = np.linspace(axis.lo, axis.hi, 50)
    u = axis.to_unit(v, 0.0)
    assert u[0] == pytest.approx(beta) and np.all(u >= beta - 1e-15)


def test_a_corner_zoom_needs_the_corner_in_the_domain():
    base = _axes(True)
    with pytest.raises(ParameterError, match="corner zoom needs A = eta1"):
        BakeSpec(eta2=ETA2, axes=base[:2] + (Axis("eta3", 1.2, 2.5, 10, "sqrt-admittance", (4, 1.0)),) + base[3:])
    with pytest.raises(ParameterError, match="cos_theta range must start at 0"):
        BakeSpec(eta2=ETA2, axes=(Axis("cos_theta", 0.1, 1.0, 8, "sqrt"),) + base[1:])
    with pytest.raises(ParameterError, match="corner nodes 9 is not allowed"):
        BakeSpec(eta2=ETA2, axes=base[:2] + (Axis("eta3", 1.0, 2.5, 10, "sqrt-admittance", (9, 1.0)),) + base[3:])
    with pytest.raises(ParameterError, match="has no grazing corner"):
        BakeSpec(eta2=ETA2, axes=(Axis("cos_theta", 0.0, 1.0, 8, "sqrt", (2, 1.0)),) + base[1:])


@pytest.fixture(scope="module")
def zoomed(tmp_path_factory):
    path = tmp_path_factory.mktemp("corner") / "zoomed.exr"
    spec = BakeSpec(eta2=ETA2, axes=_axes(True))
    lutbake.bake_lut(spec, path)
    return spec, Lut.load(path)


def test_the_grazing_column_is_the_limit_of_the_truth(zoomed):
    """Column cos θ1 = 0 holds, per node below the share, the colour in the limit cos θ1 → 0 at the ratios
    the format assigns that node (H = u/β, so ρ = (1 − u/β)^−4 − 1 per zoomed axis), here reached ten
    times closer to grazing than the bake evaluates it (closer still, η3 − η1 ∝ cos² θ1 would fall below
    float64's resolution of η3); the nodes at or past the share hold 1."""
    spec, lut = zoomed
    n_cos, n_opd, n_eta3, n_kappa3 = spec.shape
    i_opd, i_eta3, i_kappa3 = (
        i.ravel() for i in np.meshgrid(np.arange(n_opd), np.arange(n_eta3), np.arange(n_kappa3), indexing="ij")
    )
    x, y = spec.layout.texel(0, i_opd, i_eta3, i_kappa3)
    texels = lut.image[y, x].astype(float)
    (_, opd), (_, eta3), (_, kappa3) = (a.corner for a in spec.axes[1:])
    nodes = [a.corner[0] for a in spec.axes[1:]]
    inside = (i_opd < nodes[0]) & (i_eta3 < nodes[1]) & (i_kappa3 < nodes[2])
    rho = [(1.0 - i[inside] / m) ** -4.0 - 1.0 for i, m in zip((i_opd, i_eta3, i_kappa3), nodes)]
    c = CORNER_COS / 10.0
    limit = reference_rgb(
        _stack(c, rho[0] * opd * c, np.sqrt(1.0 + rho[1] * eta3 * c * c), rho[2] * kappa3 * c * c / 2.0)
    )
    assert np.abs(texels[inside] - limit).max() < 2e-3
    assert np.all(texels[~inside] == 1.0)


def _corner_points(n, seed):
    """Points near the corner: cos θ1 log-uniform 1e-7–1e-2, each ratio log-uniform 1e-2–1e2 or 0."""
    rng = np.random.default_rng(seed)
    c = 10 ** rng.uniform(-7, -2, n)
    ratios = [np.where(rng.random(n) < 0.2, 0.0, 10 ** rng.uniform(-2, 2, n)) for _ in range(3)]
    return _stack(c, ratios[0] * 30.0 * c, np.sqrt(1.0 + ratios[1] * c * c), ratios[2] * c * c / 2.0)


def test_a_zoomed_lut_follows_the_truth_into_the_corner(zoomed, tmp_path):
    """The same small grid without the zoom errs by the whole jump next to the corner (ΔE00 tens at half the
    points); with it, by what a grid this coarse errs anywhere."""
    _, lut = zoomed
    plain = tmp_path / "plain.exr"
    lutbake.bake_lut(BakeSpec(eta2=ETA2, axes=_axes(False)), plain)
    points = _corner_points(1500, seed=4)
    truth = reference_rgb(points)
    de_zoomed = delta_e00(lut.sample(points), truth)
    de_plain = delta_e00(Lut.load(plain).sample(points), truth)
    assert np.percentile(de_plain, 50) > 10.0  # measured 19.6 (p90 92)
    assert np.percentile(de_zoomed, 50) < 1.0 and np.percentile(de_zoomed, 90) < 4.0 and de_zoomed.max() < 20.0
    # measured p50 0.50, p90 2.8, max 13.9 on this coarse grid (the default set's grids: docs/accuracy.md)


def test_at_the_corner_itself_the_read_matches_the_truth(zoomed):
    """Exactly at cos θ1 = 0 the truth reflects totally; at any cos θ1 > 0 a stack with no film over the
    ambient itself reflects nothing: the zoomed read gives both."""
    _, lut = zoomed
    at = _stack([0.0, 0.0, 1e-9, 1e-3], [0.0, 5.0, 0.0, 0.0], 1.0, 0.0)
    np.testing.assert_allclose(lut.sample(at), reference_rgb(at), atol=1e-6)


def test_blender_node_groups_refuse_a_zoomed_axis():
    """Blender's node groups read scene and glTF bakes, whose LUTs never zoom; a zoomed axis reaching them is
    refused by name rather than read as its plain spacing (which would be wrong by the zoom)."""
    from lutbake.blender.programs import _axis_coordinate

    axis = _axes(True)[1].describe()
    with pytest.raises(ValueError, match="opd_nm: the grazing corner's zoom"):
        _axis_coordinate(None, 0.0, axis, None)


def test_the_command_line_takes_a_zoom_and_prints_what_it_takes():
    """A:B:N:SPACING:NODES:SCALE on D, η3 or κ3; ``Axis.flag`` (what `tune` prints) parses back to the axis."""
    from lutbake.grid.spec import parse_axis

    axis = parse_axis("opd_nm", "0:1500:80:sqrt:20:100")
    assert axis == Axis("opd_nm", 0.0, 1500.0, 80, "sqrt", (20, 100.0))
    for a in _axes(True):
        assert parse_axis(a.name, a.flag()) == a


def _cli(args, cwd):
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "lutbake.cli", *args], capture_output=True, text=True, cwd=cwd)


def test_a_bad_zoom_is_one_line_exit_2_and_nothing_written(tmp_path):
    out = _cli(["bake", "--eta2", "1.33", "--opd", "0:1500:8:sqrt:9:100", "--out", "x.exr"], tmp_path)
    assert out.returncode == 2 and "corner nodes 9 is not allowed" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and not any(tmp_path.iterdir())


def test_default_axes_drop_their_zoom_where_the_domain_leaves_out_the_corner(tmp_path):
    """`--cos-theta 0.2:1:8` leaves grazing out: the default D, η3 and κ3 axes then bake without their zoom
    (a format v4 file) instead of refusing axes the user did not give."""
    out = _cli(
        ["bake", "--eta2", "1.33", "--cos-theta", "0.2:1:8", "--opd", "0:1500:16:sqrt", "--out", "x.exr"], tmp_path
    )
    assert out.returncode == 0, out.stderr
    meta = Lut.load(tmp_path / "x.exr").meta
    assert meta["format_version"] == 4 and not any("corner" in a for a in meta["axes"])


@pytest.mark.parametrize("integrator, tolerance", [("direct", 1e-9), ("series", 1e-5)])
def test_kernel_equals_numpy_on_a_zoomed_grid(kernel_device, integrator, tolerance):
    """Under a zoom D and κ3 differ per cos θ1 node: the kernel reads them per (node, cos θ1 node), the numpy path
    per texel (plan.cell_params). The kernel's direct rule equals numpy's on every texel, the cos θ1 = 0 column
    included; its series differs from that rule by the rule's own spectral error (2.3e-6 measured here, at
    normal incidence), where a texel read at another node would differ by ~0.1."""
    from lutbake.lut.bake import bake_array

    spec = BakeSpec(eta2=ETA2, axes=_axes(True, counts=(6, 12, 6, 6)))
    numpy_grid = bake_array(spec, "numpy")
    assert np.max(np.abs(bake_array(spec, "opencl", integrator, kernel_device) - numpy_grid)) <= tolerance
