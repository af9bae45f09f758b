"""tables: the files of every table lutbake writes, the 4D LUT, a scene's atlas, the exact mode's table and
the runtime table, told apart by their header's ``format`` (docs/lut-format.md).

Stages, lowest first: headers (each kind's schema and the header checks: ``KINDS``, ``exr_header``,
``check_structure``, ``check_metadata``) → exr (pixel rows in and out: ``exr_rows``, ``write_image``,
``read_pixels``) → includes (the GLSL, HLSL and OSL renderer: ``shader_includes``, ``osl_source``,
``atlas_includes``) → lutfile (a table's file set, written as one and read back bounded: ``write_table_set``,
``write_companions``, ``read_lut``); atlas (a scene's slices packed and described: ``pack_atlas``,
``atlas_header``, ``slice_entry``, ``write_atlas``). What each table holds is computed above, in lutbake/lut/
and lutbake/modes/, which import this package (never the other way).
"""
