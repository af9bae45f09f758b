"""The runtime modes an engine runs instead of, or beside, a 4D LUT, evaluated in numpy as the shader
includes compute them (docs/engines.md).

Stages, a module each: ``exact`` (the exact mode: the Fourier series summed per pixel from a 1D table of
Ŵ; ``write_exact_table``, ``read_exact_table``, ``stored_table``, ``exact_colour``, ``exact_mode``,
``exact_mode_rgb``, ``ExactTable``, ``ExactResult``, ``base_rgb``, ``table_samples``) → ``runtime/`` (the
runtime table: any film, any base, six reads; ``write_runtime_table``, ``read_runtime_table``,
``stored_table``, ``runtime_colour``, ``runtime_rgb``, ``RuntimeTable``) → ``approximations`` (the
approximations engines ship, Belcour & Barla 2017 and KHR_materials_iridescence as three.js runs it, and
``APPROXIMATIONS``: every runtime path the reports score beside a LUT, by name).
"""
