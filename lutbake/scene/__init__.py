"""Scene bakes: a scene's materials baked into one file set, each job grown until it meets its target
(docs/scene.md, docs/gltf.md).

Stages, a module each, in data-flow order: a source (``toml``: ``load_scene``; ``gltf``:
``load_gltf_scene``, an asset's iridescent materials, and their receipts; ``source``:
``load_scene_source``, ``source_warnings``, whichever of the two a command names) makes the scene model
(``model``: Scene, SceneMaterial, ``check_material_names``); ``plan`` (``plan_scene``: ScenePlan,
SceneJob, ``truth_rate``) makes its jobs: 2D slices and 4D LUTs; ``slices`` (SliceStack,
``integrate_slice``, ``slice_colour``) integrates a slice and ``jobs`` (``refine_slice``, ``tuned_lut``)
refines slices and tunes LUTs to the target; ``cache`` (SceneCache) keeps what unchanged jobs yielded;
``bake`` (``bake_scene``: SceneResult) runs the plan and writes the atlas, includes, LUTs and manifest
together. Then what the commands print: ``documents`` (``plan_document``, ``bake_summary``) and
``reports`` (``open_report``, FileReport: which report `lutbake report` makes of a file).
"""
