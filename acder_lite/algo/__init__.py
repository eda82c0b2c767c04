"""The paper's algorithm, readable on its own: the networks (`core`), DDPG (`ddpg`),
HER's relabelling (`her`), the rewards of Eq. 4-6 (`rewards`), the curiosity models
S-ICM and ICM (`curiosity`, Eq. 8), the dynamic start states (`start_states`, Eq. 9),
the observation normaliser, the episode replay buffer, and the baselines'
prioritisers (PER, EBP:
`priority`).

Layer 1: imports only the top-level modules (`config`, `io`, ...), never a folder
above."""
