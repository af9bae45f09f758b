"""The 4D LUT: a film's spec baked into an EXR file set, and read back as an engine reads it
(docs/lut-format.md).

Stages, a module each: ``domain`` (``lut_spec``: a film's BakeSpec over the axes given, the others the
default set's) → ``bake`` (``bake``, ``bake_set``, ``write_lut``, ``bake_array``, ``BakeResult``,
``default_specs``, ``metadata``, ``spectral_error``, ``lut_members``: a spec through an integrator into a
LUT's files, its error probed first) → ``sets`` (``bake_default_set``, ``bake_luts``, ``default_set_jobs``,
``summary``, ``DEFAULT_SET_NAME``: `lutbake bake`'s sets, in progress bands) → ``sample`` (``Lut``,
``Atlas``, ``load_table``: the reference sampler, what a shader include returns) → ``readout``
(``TableReads``: `lutbake sample`'s reads, each flagged in or out of the domain); beside them ``evaluate``
(``point_colours``, ``point_reflectances``, ``CAPPED_WARNING_RGB``: `lutbake eval`'s points by the ground
truth or the bake's integrator) and ``survey`` (``survey``, ``vendor_folder``, ``THROUGHPUT_PROBE``:
`lutbake devices`).
"""
