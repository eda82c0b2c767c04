"""Numbers from curves, no files: Table I's statistic (the mean curve's crossing, the
bootstrap over seeds, per-seed crossings: `report`) and the trial statistics of the
robustness tests (Wilson intervals: `trial_stats`).

Layer 3: imports the top-level modules only."""
