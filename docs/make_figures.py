"""Figures for README and docs, from the shipped LUTs (rerun: python docs/make_figures.py).

hero.png: reflected colour over view angle (x) and film OPD D (y) for a soap
film in air, oil on water and oxide on steel, each read from luts/ through
the reference sampler (what a GPU returns), sRGB-encoded for display with a
per-panel exposure (its 95th-percentile value maps to 1) so faint soap
colours stay visible.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from lutbake.figures import display_srgb  # noqa: E402
from lutbake.sample import Lut  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
PANELS = [
    ("soap film in air (η2 1.33 | air)", "lutbake-eta2-1.33.exr", 1.0, 0.0),
    ("oil on water (η2 1.50 | 1.33)", "lutbake-eta2-1.50.exr", 1.33, 0.0),
    ("oxide on steel (η2 2.0 | 2.7 + 2.8i)", "lutbake-eta2-2.00.exr", 2.7, 2.8),
]


def main():
    cos_theta = np.linspace(1.0, 0.0, 240)[None, :]
    opd = np.linspace(0.0, 3000.0, 300)[:, None]
    fig, axes = plt.subplots(1, 3, figsize=(12, 4.2), constrained_layout=True)
    for ax, (title, name, eta3, kappa3) in zip(axes, PANELS):
        lut = Lut.load(ROOT / "luts" / name)
        rgb = lut.sample(cos_theta, opd, eta3, kappa3)
        exposure = 1.0 / np.percentile(rgb.max(axis=-1), 95)
        angle = np.degrees(np.arccos(cos_theta[0]))
        ax.imshow(display_srgb(rgb, exposure), origin="lower", aspect="auto",
                  extent=[angle[0], angle[-1], opd[0, 0], opd[-1, 0]])
        ax.set_title(f"{title}\nexposure ×{exposure:.1f}", fontsize=10)
        ax.set_xlabel("view angle θ1 (degrees)")
    axes[0].set_ylabel("optical path difference D = 2·η2·d (nm)")
    out = ROOT / "docs" / "img" / "hero.png"
    fig.savefig(out, dpi=90)
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
