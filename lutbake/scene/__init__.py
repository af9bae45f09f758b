"""Scene bakes: a scene's materials baked into one file set, each job grown until it meets its target
(docs/scene.md, docs/gltf.md).

Stages, a module each: a source (``toml``: ``load_scene``; ``gltf``: ``load_gltf_scene``, an asset's
iridescent materials, and their receipts) makes the scene model (``model``: Scene, SceneMaterial);
``plan`` (``plan_scene``) makes its jobs: 2D slices and 4D LUTs; ``slices`` integrates a slice and
``jobs`` refines slices and tunes LUTs to the target; ``cache`` keeps what unchanged jobs yielded; ``bake``
(``bake_scene``) runs the plan and writes the atlas, includes, LUTs and manifest together.
"""
