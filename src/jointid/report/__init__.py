"""jointid.report: self-contained HTML reports.

The main API, re-exported here (imported on first use)::

    from jointid.report import Section, Table, render_report
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {".html": ("render_report", "Section", "Table")},
    submodules=("html",),
)
