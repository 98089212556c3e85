"""blockqc's own RFM-affine block adjustment: geometry, solver, synthetic block, outputs (§RC)."""
