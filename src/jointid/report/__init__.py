"""jointid.report: self-contained HTML reports."""
