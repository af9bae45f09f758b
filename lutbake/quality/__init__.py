"""How wrong a table is, and what makes it right: measurement, reports, refinement (docs/reports.md).

Stages, a module each: ``worstcase`` (find_worst: a searched maximum over a box), ``measure`` (held-out
points, ErrorStats and ``score``, ``search_max`` and ``search_slice``: the tools every measurement shares),
``report`` (``report_lut``, ``report_atlas``, ``write_report``: `lutbake report`), ``figures`` (its ΔE00
maps and swatches), ``refine`` (``tune``, ``refine``: the smallest grid that meets a target), ``sweep``
(error against cost over LUT variants) and ``check`` (``run_checks``: every path at its stiff and extreme
cases against an independent reference).
"""
