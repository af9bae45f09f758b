"""The glTF scene source: a glTF 2.0 asset's KHR_materials_iridescence materials as a scene, and the
receipts of its bake (docs/gltf.md).

Stages, a module each: ``asset`` (``read_gltf``, GltfAsset: the asset's JSON read by the specification,
bounded, never its geometry or images), ``materials`` (``load_gltf_scene``: the used iridescent materials
mapped to the scene model, metals through a metal mapping; ``material_rows``: what serves each, for
`lutbake plan`) and ``receipt`` (``gltf_receipts``, ``write_receipts``: per material, what each choice
costs in ΔE00 against the spectral ground truth, for `lutbake report`).
"""
