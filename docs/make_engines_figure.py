"""Render docs/img/engines.png: the same films on a sphere in three.js (WebGPURenderer), Babylon.js and
PlayCanvas, each with its stock KHR_materials_iridescence term and with lutbake's runtime table, beside the
ground truth at the parameters each pixel used.

Each tile is the film's linear RGB Fresnel term as the engine computed it per pixel (the drop-ins' `output:
'fresnel'`, read back as float; tests/engines/test_web_engines.py and test_webgpu_engine.py check the same
renders; three.js r187, Babylon.js 9.28.0 and PlayCanvas 2.23.3 as pinned in engine/package.json, headless
Chromium: WebGPU and WebGL2 on SwiftShader), shown with one exposure per row (the row's label gives it) and
the sRGB curve. The ground truth is
lutbake's spectral integration at the (cos θ, thickness, film index) the lutbake tile's pixels used.

Rerun: (cd engine && npm ci) && python docs/make_engines_figure.py   (needs node and Debian's chromium)
"""

import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "tests")]
from runtime_contract import runtime_table_files  # noqa: E402  (the suite's helpers, found through the path above)
from web_engines import OWN_MODES, render_spheres, sphere_material  # noqa: E402

from lutbake.modes.exact import base_rgb  # noqa: E402
from lutbake.quality.runtime_accuracy import truth  # noqa: E402

OUT = ROOT / "docs" / "img" / "engines.png"
SIZE = 128  # pixels per tile
ENGINES = [("webgpu", "three.js WebGPU"), ("babylon", "Babylon.js"), ("playcanvas", "PlayCanvas")]
# (label, material, exposure)
ROWS = [
    ("soap film 480 nm on glass", sphere_material("soap", 1.33, 1.5, 0.0, (480, 480)), 4.0),
    ("oil film 350 nm on water", sphere_material("oil", 1.5, 1.33, 0.0, (350, 350)), 4.0),
    ("oxide film 150 nm on copper", sphere_material("oxide", 2.0, *base_rgb("Cu"), (150, 150)), 1.0),
]
LABEL_W, HEADER_H = 190, 34


def srgb(linear: np.ndarray) -> np.ndarray:
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def tile(rgb: np.ndarray, covered: np.ndarray, exposure: float) -> Image.Image:
    """A size² tile: the term × exposure through the sRGB curve where the sphere is, black elsewhere."""
    pixels = np.where(covered[..., None], srgb(exposure * rgb), 0.0)
    return Image.fromarray(np.round(255 * pixels).astype(np.uint8))


def engine_tiles(engine: str, folder: Path) -> tuple[list, list]:
    """Per row: (stock, lutbake) tiles, and the lutbake render's (rgb, parameters, covered) for the truth."""
    spec = {"materials": [m for _, m, _ in ROWS], "modes": ["runtime", OWN_MODES[engine]], "size": SIZE}
    spec.update(stride=SIZE * SIZE, image=True, stretch=1)  # a round sphere in every engine
    result = render_spheres(engine, spec, runtime_table_files(), folder)
    cells = {(c["material"], c["mode"]): c for c in result["cells"]}
    tiles, lutbake = [], []
    for k, (_, _, exposure) in enumerate(ROWS):
        pair = []
        for mode in (OWN_MODES[engine], "runtime"):
            image = np.array(cells[k, mode]["image"], float).reshape(SIZE, SIZE, 4)
            pair.append(tile(image[..., :3], image[..., 3] > 0, exposure))
        tiles.append(pair)
        params = np.array(cells[k, "runtime"]["parameters"], float).reshape(SIZE, SIZE, 4)
        lutbake.append((params[..., :3], params[..., 3] > 0))
    return tiles, lutbake


def truth_tile(material: dict, params: np.ndarray, covered: np.ndarray, exposure: float) -> Image.Image:
    cos, d, eta2 = (params[..., i][covered] for i in range(3))
    n = cos.size
    base = (
        (material["metal"]["eta"], material["metal"]["kappa"])
        if "metal" in material
        else ([material["ior"]] * 3, [0.0] * 3)
    )
    eta3, kappa3 = (np.tile(np.asarray(v, float), (n, 1)) for v in base)
    rgb = np.zeros((SIZE, SIZE, 3))
    rgb[covered] = truth(cos, d, eta2, eta3, kappa3)
    return tile(rgb, covered, exposure)


def main() -> None:
    columns, truths = [], []
    with tempfile.TemporaryDirectory() as folder:
        for engine, name in ENGINES:
            tiles, lutbake = engine_tiles(engine, Path(folder))
            columns += [(f"{name}\nstock", [t[0] for t in tiles]), (f"{name}\nlutbake", [t[1] for t in tiles])]
            truths = truths or lutbake
    ground = [truth_tile(m, *truths[k], e) for k, (_, m, e) in enumerate(ROWS)]
    columns = [("ground truth\n(spectral)", ground), *columns]
    figure = Image.new("RGB", (LABEL_W + SIZE * len(columns), HEADER_H + SIZE * len(ROWS)), (24, 24, 24))
    draw = ImageDraw.Draw(figure)
    font = ImageFont.load_default(12)
    for c, (title, tiles) in enumerate(columns):
        x = LABEL_W + c * SIZE
        draw.multiline_text(
            (x + SIZE / 2, HEADER_H / 2), title, fill=(220, 220, 220), font=font, anchor="mm", align="center"
        )
        for r, t in enumerate(tiles):
            figure.paste(t, (x, HEADER_H + r * SIZE))
    for r, (label, _, exposure) in enumerate(ROWS):
        draw.multiline_text(
            (8, HEADER_H + r * SIZE + SIZE / 2),
            f"{label}\nFresnel term x {exposure:g}",
            fill=(220, 220, 220),
            font=font,
            anchor="lm",
        )
    tmp = OUT.with_suffix(".tmp.png")
    figure.save(tmp, optimize=True)
    tmp.replace(OUT)
    print(f"wrote {OUT.relative_to(ROOT)} ({figure.width} x {figure.height})")


if __name__ == "__main__":
    main()
