"""Fixtures of the CLI's hostile-input tests."""

import pytest


@pytest.fixture(scope="module")
def good_files(tmp_path_factory):
    """A tiny LUT, a one-material scene atlas and an exact table, baked once."""
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.lut.bake import bake
    from lutbake.modes.exact import write_exact_table
    from lutbake.scene.bake import bake_scene
    from lutbake.scene.toml import load_scene

    folder = tmp_path_factory.mktemp("good")
    axes = (
        Axis("cos_theta", 0.0, 1.0, 4),
        Axis("opd_nm", 0.0, 1000.0, 4),
        Axis("eta3", 1.0, 2.0, 2),
        Axis("kappa3", 0.0, 1.0, 2),
    )
    bake(BakeSpec(eta2=1.5, axes=axes), folder / "lut.exr", "numpy")
    (folder / "s.toml").write_text(
        "[scene]\nmax_de = 5.0\n[materials.soap]\nfilm = 1.33\nthickness_nm = [200, 300]\nbase = 1.0\n"
    )
    bake_scene(load_scene(folder / "s.toml"), folder / "scene", backend="numpy")
    write_exact_table(folder / "exact.exr")
    return {"lut": folder / "lut.exr", "atlas": folder / "scene" / "s.exr", "exact": folder / "exact.exr"}
