"""jointid.plots: matplotlib figures (they take and return Figure objects; no pyplot state)."""
