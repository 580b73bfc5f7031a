"""jointid.report: self-contained HTML reports.

The main API, re-exported here (imported on first use)::

    from jointid.report import Section, Table, render_report

* :mod:`.html` -- ``render_report``, ``Section``, ``Table`` (the page);
* :mod:`.identification` -- ``identification_report`` (``jointid identify``, ``experiment``);
* :mod:`.command_reports` -- ``update_report``, ``direct_report`` (``jointid update``, ``direct``).
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".html": ("render_report", "Section", "Table"),
        ".identification": ("identification_report", "trust_items"),
        ".command_reports": ("update_report", "direct_report"),
    },
    submodules=("html", "identification", "command_reports"),
)
