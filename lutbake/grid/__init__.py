"""The grid a LUT is baked on: what is baked, where its texels are, and what it costs (docs/lut-format.md).

Stages, a module each: ``axis`` (Axis: one axis's nodes, its spacings and corner zoom; ``parse_axis``,
``validate_axis``, ``axis_from_header``), ``spec`` (BakeSpec: the film, the four axes and the settings that
determine a LUT's bytes), ``layout`` (TileLayout: the 4D grid packed into one 2D image), ``texels`` (the
node values and the bands of image rows a bake works in), ``truncation`` (the spectral rule each texel
needs and its truncation bound), ``memory`` (the budget: peak memory and time before any work) and
``interpolation`` (the cubic rule's taps, shared by the sampler and the shader includes).
"""
