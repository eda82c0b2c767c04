"""Training: the policy and the parallel episodes (`rollout`), and the trainer, whose
`update_step` is one ACDER update read top to bottom (`trainer`).

Layer 5: imports every layer below it."""
