"""The documents the scene commands print: `plan`'s (what a scene bake would bake, and how long its
ground truth would take here) and `bake --scene`/`--gltf`'s summary of a bake.
"""

from __future__ import annotations

import time
from typing import Any

from lutbake.integrate.opencl import backend as make_backend
from lutbake.scene.bake import SceneResult
from lutbake.scene.estimate import time_estimate
from lutbake.scene.model import Scene

__all__ = ["plan_document", "bake_summary"]


def plan_document(scene: Scene) -> dict[str, Any]:
    """`plan --json`: the scene's plan (``ScenePlan.describe``) with each job's ground-truth seconds at the
    rate measured now on this machine (``seconds_per_truth_point``), the bake's seconds here by stage
    (``estimate_seconds``: lutbake/scene/estimate.py), and for a glTF scene what each of its materials is
    served by (``gltf_materials``). Writes nothing."""
    from lutbake.scene.plan import plan_scene, truth_rate

    start = time.perf_counter()  # the integrator first, as in the bake: its start-up includes OpenCL's
    integrator = make_backend("auto")
    startup_s = time.perf_counter() - start
    plan = plan_scene(scene)
    rate = truth_rate(plan)
    doc = plan.describe(rate)
    doc["seconds_per_truth_point"] = rate
    doc.update(time_estimate(plan, integrator, startup_s))
    if scene.source is not None:
        from lutbake.scene.gltf.materials import material_rows

        doc["gltf_materials"] = material_rows(scene, plan)
    return doc


def bake_summary(result: SceneResult) -> dict[str, Any]:
    """`bake --scene --json`: the folder, whether it was up to date, the jobs computed and reused, the files
    written, wall seconds, the materials whose target was not met at the resolution cap, the parts routed to
    the runtime table (a line each: the material and why), the device, and a glTF bake's web set and build
    artefacts (``ship``)."""
    return {
        "out": str(result.out_dir),
        "up_to_date": result.up_to_date,
        "computed": result.computed,
        "reused": result.reused,
        "written": [str(p) for p in result.written],
        "seconds": result.seconds,
        "target_unmet": result.unmet,
        "routed_to_runtime": result.routes,
        "ship": result.ship,
        "device": result.device,
    }
