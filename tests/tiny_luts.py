"""Tiny LUTs baked in a moment with the numpy backend, for tests of files, sets and readers rather than of
accuracy: one LUT (a_lut), and a set of three for bake_set (tiny_jobs)."""

from pathlib import Path

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.lut.bake import bake


def a_lut(folder: Path) -> Path:
    """FOLDER/lut.exr (+ .json, .glsl, .hlsl): η2 1.4 over a 4 × 4 × 2 × 2 grid."""
    axes = (
        Axis("cos_theta", 0.0, 1.0, 4),
        Axis("opd_nm", 0.0, 500.0, 4),
        Axis("eta3", 1.0, 2.0, 2),
        Axis("kappa3", 0.0, 1.0, 2),
    )
    bake(BakeSpec(eta2=1.4, axes=axes), folder / "lut.exr", backend="numpy")
    return folder / "lut.exr"


def tiny_jobs(folder: Path, eta1: float = 1.0, prefix: str = "lut") -> list:
    """Three tiny LUTs (films η2 1.33, 1.5, 2.0 under ``eta1``) for bake_set."""
    axes = (
        Axis("cos_theta", 0.0, 1.0, 4),
        Axis("opd_nm", 0.0, 1000.0, 4),
        Axis("eta3", 1.1, 2.0, 2),
        Axis("kappa3", 0.0, 1.0, 2),
    )
    return [
        (folder / f"{prefix}-{eta2}.exr", BakeSpec(eta2=eta2, eta1=eta1, axes=axes), {}) for eta2 in (1.33, 1.5, 2.0)
    ]
