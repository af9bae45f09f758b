"""Render docs/img/hero.png: lit spheres of the default LUTs and two baked scenes, drawn by three.js in
headless Chromium through the shipped GLSL includes (engine/page.js), i.e. what an engine shows.

Rerun: (cd engine && npm ci) && python docs/make_hero.py   (needs node and Debian's chromium)
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
from make_accuracy import bake_default_luts  # noqa: E402
from make_scene_examples import bake_example  # noqa: E402

LUT_CALL = "lutbake_sample(lut, {c}, cos_theta, 2.0 * {c}.eta2 * thickness_nm, {eta3}, {kappa3})"
ATLAS_CALL = "lutbake_atlas_sample(lut, {c}, cos_theta, thickness_nm)"
# (label, file without suffix, GLSL call, thickness range in nm)
SPHERES = [
    (
        "soap film (η2 1.33)",
        "luts/lutbake-eta2-1.33",
        LUT_CALL.format(c="LUTBAKE_ETA2_1_33", eta3=1.0, kappa3=0.0),
        (250, 750),
    ),
    (
        "oil on water (η2 1.5)",
        "luts/lutbake-eta2-1.50",
        LUT_CALL.format(c="LUTBAKE_ETA2_1_50", eta3=1.33, kappa3=0.0),
        (150, 550),
    ),
    (
        "oxide on steel (η2 2.0)",
        "luts/lutbake-eta2-2.00-metal",
        LUT_CALL.format(c="LUTBAKE_ETA2_2_00_METAL", eta3=2.9, kappa3=3.0),
        (20, 140),
    ),
    (
        "scene: soap bubble",
        "docs/scenes/soap-bubble/soap-bubble",
        ATLAS_CALL.format(c="LUTBAKE_SOAP_BUBBLE_SOAP"),
        (100, 1000),
    ),
    (
        "scene: tempered steel (Fe)",
        "docs/scenes/tempered-steel/tempered-steel",
        ATLAS_CALL.format(c="LUTBAKE_TEMPERED_STEEL_STEEL_WERNER"),
        (10, 70),
    ),
]


def main():
    bake_default_luts()
    for scene in ("soap-bubble", "tempered-steel"):
        bake_example(scene)
    spheres = [
        {
            "label": label,
            "exr": f"/{stem}.exr",
            "include": f"/{stem}.glsl",
            "sample": call,
            "thickness": list(thickness),
        }
        for label, stem, call, thickness in SPHERES
    ]
    out = ROOT / "docs" / "img" / "hero.png"
    with tempfile.TemporaryDirectory() as tmp:
        job = Path(tmp) / "spheres.json"
        job.write_text(json.dumps(spheres))
        proc = subprocess.run(["node", str(ROOT / "engine" / "harness.mjs"), "view", str(job), str(out)], cwd=ROOT)
    if proc.returncode:
        sys.exit(proc.returncode)
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
