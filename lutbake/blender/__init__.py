"""Blender from lutbake: a scene bake's node-group library, and renders held to what lutbake samples
(docs/blender.md).

Stages, a module each, in data-flow order: ``programs`` (``read_manifest``: SceneReads of SliceRead and
LutRead, what a manifest asks for; each read as a node program, ``slice_program``, ``lut_program``,
``bilinear_program``, ``read_program``, which numpy evaluates too: NumpyGraph, ``evaluate``); ``nodes``
(a script Blender runs, importing nothing of lutbake: the node groups and materials built from those
programs, and the OSL materials); ``library`` (``find_blender``, ``write_library``, ``build_library``:
`lutbake blender`; ``verify_library``, ``verify_osl``, ``render_probes``; BlenderError), which finds
Blender, runs the scripts in it and compares their renders; ``probe`` (a script Blender runs: probe
planes rendered and measured).
"""
