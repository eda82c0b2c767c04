"""Run folders on disk: what a run writes (`runfiles`), packed checkpoints (`packed`),
the grid's plan file (`plan`, `same_as`), reading finished runs (`read`), Table I
assembled from them (`table`), the grid's time left (`grid_time`) and the angle-wrap
count of a run's replay buffer (`wraps`).

Layer 4: imports `algo`, `envs`, `stats` and the top-level modules."""
