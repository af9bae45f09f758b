"""How wrong a table is, and what makes it right: measurement, reports, refinement (docs/reports.md).

Stages, a module each, in data-flow order: ``worstcase`` (SearchAxis, ``find_worst``: a searched maximum
over a box), ``measure`` (held-out points, ErrorStats and ``score``, ``search_max`` and ``search_slice``:
the tools every measurement shares), ``report`` (LutReport, ``report_lut``, ``report_atlas``, ``gate``,
``write_report``: `lutbake report`), ``figures`` (its ΔE00 maps and swatches, ``pareto_plot``),
``summaries`` (``lut_summary``, ``atlas_summary``: a report scored, gated and written, as the command
runs it), ``refine`` (``tune``, ``refine``: the smallest grid that meets a target), ``sweep`` (error
against cost over LUT variants), ``runtime_accuracy`` (the runtime table's ΔE00 over its domain:
``truth``, ``stress_points``, ``searched_worst``; docs/engines.md) and ``check`` (``run_checks``,
``check_fast_path``: every path at its stiff and extreme cases against an independent reference,
docs/stability.md).
"""
