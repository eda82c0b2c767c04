"""Episode replay buffer: whole episodes in preallocated arrays (fixed capacity, FIFO).

Per step it keeps the observation, achieved and desired goal, action and the full MuJoCo
state (so any stored state can be restored exactly, for start-state selection); per
episode whether its last step succeeded. Index [e, t] is step t of stored episode e; o,
ag and state have T+1 entries (the final observation included), g and u have T.
"""

from __future__ import annotations

import numpy as np

KEYS = ("o", "ag", "g", "u", "state")


class EpisodeBuffer:
    def __init__(self, capacity_transitions: int, T: int, dims: dict[str, int]):
        self.T = T
        self.size = max(1, capacity_transitions // T)  # capacity in episodes
        self.o = np.empty((self.size, T + 1, dims["o"]), np.float32)
        self.ag = np.empty((self.size, T + 1, dims["g"]), np.float32)
        self.g = np.empty((self.size, T, dims["g"]), np.float32)
        self.u = np.empty((self.size, T, dims["u"]), np.float32)
        # float64: a state is written back with mj_setState and must reproduce the
        # physics exactly.
        self.state = np.empty((self.size, T + 1, dims["state"]), np.float64)
        self.success = np.zeros(self.size, bool)
        self.n = 0  # episodes stored (<= size)
        self.next = 0  # slot the next episode goes to
        self.total = 0  # episodes ever stored

    @property
    def n_transitions(self) -> int:
        return self.n * self.T

    def store(self, episodes: dict[str, np.ndarray]) -> np.ndarray:
        """Store a batch of episodes (arrays with a leading episode axis).
        Returns their slots."""
        k = episodes["o"].shape[0]
        idx = (self.next + np.arange(k)) % self.size
        for key in KEYS:
            getattr(self, key)[idx] = episodes[key]
        self.success[idx] = episodes["success"]
        self.next = int((self.next + k) % self.size)
        self.n = min(self.size, self.n + k)
        self.total += k
        return idx

    def arrays(self) -> dict[str, np.ndarray]:
        """Views of the filled part (no copy)."""
        d = {key: getattr(self, key)[: self.n] for key in KEYS}
        d["success"] = self.success[: self.n]
        return d

    def state_dict(self) -> dict:
        d = {key: getattr(self, key)[: self.n].copy() for key in KEYS}
        d.update(
            success=self.success[: self.n].copy(),
            n=self.n,
            next=self.next,
            total=self.total,
        )
        return d

    def load_state_dict(self, d: dict) -> None:
        self.n, self.next, self.total = int(d["n"]), int(d["next"]), int(d["total"])
        for key in KEYS:
            have, want = tuple(d[key].shape[1:]), tuple(getattr(self, key).shape[1:])
            # e.g. a checkpoint written before envs.STATE_SPEC grew or shrank
            if have != want:
                from acder_lite.io import CheckpointError

                raise CheckpointError(
                    f"the checkpoint's replay buffer holds {key} of shape {have} "
                    f"a step, this version stores {want}; "
                    "allowed: a checkpoint written by this version"
                )
            getattr(self, key)[: self.n] = d[key]
        self.success[: self.n] = d["success"]
