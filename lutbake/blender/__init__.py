"""Blender from lutbake: a scene bake's node-group library, and renders held to what lutbake samples
(docs/blender.md).

``library`` (``write_library``, ``verify_library``, ``verify_osl``: `lutbake blender`) finds Blender and runs
two scripts inside it, which import nothing of lutbake: ``nodes`` (the node groups and materials, built
from ``programs``: what a manifest asks for and each read as a node program, which numpy evaluates too)
and ``probe`` (probe planes rendered and measured).
"""
