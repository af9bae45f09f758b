"""lutbake's edges with the file system and the process: bounded readers, atomic writers, the user's cache,
progress and signals (docs/lut-format.md, "Guarantees" and "Readers and their bounds"; docs/api.md,
"Process state").

Modules, each serving every stage above: ``names`` (the observer, space, interpolation and spacing names and
shader- and terminal-safe forms of a name, importing nothing: ``OBSERVERS``, ``SPACES``, ``INTERPOLATIONS``,
``ADMITTANCE_SPACINGS``, ``shader_identifier``, ``shader_comment``, ``shader_string``, ``terminal_text``),
``documents`` (JSON and TOML read from regular files, bounded in size, nesting and integers:
``open_regular``, ``read_bytes``, ``read_text``, ``load_json``, ``load_toml``, ``MAX_NESTING``),
``manifest`` (the scene manifest's one typed, bounded, sealed reader: ``read_scene_manifest``,
``manifest_hash``, ``sealed``), ``strictjson`` (JSON written with non-finite numbers as null: ``dumps``,
``finite_or_none``), ``fileset`` (output files committed as one journaled unit: ``open_set``, ``FileSet``,
``recover``, ``pending_commit``, ``refuse_overwriting_inputs``, ``sha256_file``, ``journal_path``,
``remove_stale_temporaries``, ``MAX_JOURNAL_BYTES``), ``usercache`` (arrays computed once per machine:
``cached_arrays``, ``use_folder``, ``default_folder``, ``writable_folder``), ``progress`` (the ``Progress``
callback every long call takes and the command line's ``Meter``: ``meter``, ``no_progress``,
``format_seconds``) and ``signals`` (SIGINT, SIGTERM and SIGHUP as a clean unwind, for the command line
only: ``Interrupted``, ``STOP_SIGNALS``, ``exit_status``, ``set_handler``, ``stop_signals_held``,
``raise_interrupted``, ``interrupted_at_start_up``, ``hold_stop_signals_in_extension_imports``) and ``cores``
(the default size of a pool of worker threads: ``usable_cores``).
"""
