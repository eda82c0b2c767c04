"""Prioritised replay for the paper's baselines: HER+PER and HER+EBP.

- PER: Schaul et al. 2016, "Prioritized Experience Replay", proportional variant
  (Sec. 3.3, Alg. 1) over single transitions, with a sum tree; importance weights
  (Sec. 3.4).
- EBP: Zhao & Tresp 2018, "Energy-Based Hindsight Experience Prioritization" (CoRL),
  which samples whole episodes in proportion to the trajectory energy of the object
  (their Eq. 1-5), following their code
  (github.com/ruizhaogit/EnergyBasedPrioritization, baselines/her/replay_buffer.py
  `ReplayBufferEnergy`, her.py `make_sample_her_transitions_energy`).

Both index episodes by their `EpisodeBuffer` slot; slots fill 0..size-1 in order (FIFO),
so the stored episodes are always slots 0..n-1. Everything is vectorised numpy: no
Python loop over samples.
"""

from __future__ import annotations

import numpy as np


class SumTree:
    """Binary sum tree in one float64 array (Schaul et al. 2016, Appendix B.2.1).

    Root at index 1, leaf i at index `cap + i` (cap = capacity rounded up to a power of
    2), node k holds the sum of its children 2k, 2k+1. `update` and `find` loop over the
    tree depth only.
    """

    def __init__(self, capacity: int):
        self.capacity = int(capacity)
        self._cap = 1 << max(0, (self.capacity - 1).bit_length())
        self._depth = self._cap.bit_length() - 1
        self.tree = np.zeros(2 * self._cap, np.float64)

    def update(self, idx: np.ndarray, priority: np.ndarray) -> None:
        """Set leaves `idx` to `priority` (broadcast).
        For a repeated index the last write wins."""
        idx = np.asarray(idx, np.int64).reshape(-1)
        priority = np.broadcast_to(
            np.asarray(priority, np.float64).reshape(-1), idx.shape
        )
        if idx.size == 0:
            return
        if np.any((idx < 0) | (idx >= self.capacity)):
            raise IndexError(f"SumTree index out of range [0, {self.capacity})")
        if np.any(~np.isfinite(priority) | (priority < 0)):
            raise ValueError("SumTree priorities must be finite and >= 0")
        # Keep the last occurrence of each index (numpy does not promise an order for
        # repeated indices in fancy assignment).
        uniq, first_in_rev = np.unique(idx[::-1], return_index=True)
        node = uniq + self._cap
        self.tree[node] = priority[::-1][first_in_rev]
        for _ in range(self._depth):  # repeated parents get the same value: harmless
            node = node >> 1
            self.tree[node] = self.tree[2 * node] + self.tree[2 * node + 1]

    def total(self) -> float:
        return float(self.tree[1])

    def leaves(self) -> np.ndarray:
        """View of the leaf priorities 0..capacity-1."""
        return self.tree[self._cap : self._cap + self.capacity]

    def find(self, values: np.ndarray) -> np.ndarray:
        """Leaf i with prefix(i) <= v < prefix(i) + p_i for each v
        (prefix = sum of leaves < i).

        Values are clipped into [0, total). A zero-priority leaf is never returned while
        total > 0.
        """
        v = np.asarray(values, np.float64).reshape(-1)
        total = self.tree[1]
        v = np.clip(v, 0.0, np.nextafter(total, 0.0)) if total > 0 else np.zeros_like(v)
        node = np.ones(v.shape, np.int64)
        for _ in range(self._depth):
            left = self.tree[2 * node]
            right = v >= left
            v = v - np.where(right, left, 0.0)
            node = 2 * node + right
        leaf = node - self._cap
        # Float rounding can, very rarely, walk into an empty right sibling: step back
        # left.
        bad = self.tree[node] <= 0
        if total > 0 and np.any(bad):
            nz = np.flatnonzero(self.leaves() > 0)
            leaf[bad] = nz[np.clip(np.searchsorted(nz, leaf[bad]) - 1, 0, None)]
        return leaf

    def _rebuild(self) -> None:
        for level in range(self._depth - 1, -1, -1):
            k = np.arange(1 << level, 2 << level)
            self.tree[k] = self.tree[2 * k] + self.tree[2 * k + 1]

    def state_dict(self) -> dict:
        return {"capacity": self.capacity, "leaves": self.leaves().copy()}

    def load_state_dict(self, d: dict) -> None:
        if int(d["capacity"]) != self.capacity:
            raise ValueError(f"SumTree capacity {d['capacity']} != {self.capacity}")
        self.tree[:] = 0.0
        self.tree[self._cap : self._cap + self.capacity] = d["leaves"]
        self._rebuild()


class PrioritizedReplay:
    """Schaul et al. 2016, proportional variant, over transitions
    (episode slot e, step t) -> leaf e*T + t.

    Leaf priority P_i^alpha with P_i = |delta_i| + eps
    (Sec. 3.3, "p_i = |delta_i| + epsilon"); sampling probability
    P(i) = P_i^alpha / sum_k P_k^alpha (Eq. 1). New transitions get the largest raw
    priority seen so far (Alg. 1 line 6; 1.0 at start), raised to alpha, as in
    Baselines.

    Importance weights (Sec. 3.4): w_i = (N * P(i))^-beta / max_j w_j with N the number
    of stored transitions. `weight_norm="global"` (default) takes max_j over all stored
    transitions, i.e. uses the smallest stored priority, as Baselines'
    PrioritizedReplayBuffer and Zhao & Tresp's PER baseline do (a second, min tree);
    `weight_norm="batch"` takes it over the minibatch.
    """

    def __init__(
        self,
        n_episodes_capacity: int,
        T: int,
        alpha: float = 0.6,
        eps: float = 1e-6,
        weight_norm: str = "global",
    ):
        if weight_norm not in ("global", "batch"):
            raise ValueError("weight_norm must be 'global' or 'batch'")
        self.size, self.T = int(n_episodes_capacity), int(T)
        self.alpha, self.eps, self.weight_norm = float(alpha), float(eps), weight_norm
        self.tree = SumTree(self.size * self.T)
        # min tree stored as a SumTree-shaped array: same layout, min instead of sum.
        self._min = np.full(2 * self.tree._cap, np.inf)
        self.max_priority = 1.0
        self.n = 0  # stored episodes (slots 0..n-1)

    @property
    def n_transitions(self) -> int:
        return self.n * self.T

    def _set(self, leaf: np.ndarray, p_alpha: np.ndarray) -> None:
        self.tree.update(leaf, p_alpha)
        if self.weight_norm == "global":
            node = np.unique(leaf) + self.tree._cap
            val = self.tree.tree[node]
            self._min[node] = np.where(val > 0, val, np.inf)
            for _ in range(self.tree._depth):
                node = node >> 1
                self._min[node] = np.minimum(
                    self._min[2 * node], self._min[2 * node + 1]
                )

    def _leaves(self, ep: np.ndarray, t: np.ndarray) -> np.ndarray:
        return np.asarray(ep, np.int64).reshape(-1) * self.T + np.asarray(
            t, np.int64
        ).reshape(-1)

    def add_episodes(self, slots: np.ndarray) -> None:
        """All T transitions of each (new or overwritten) slot
        get max_priority^alpha."""
        slots = np.asarray(slots, np.int64).reshape(-1)
        if slots.size == 0:
            return
        leaf = (slots[:, None] * self.T + np.arange(self.T)).reshape(-1)
        self._set(leaf, np.full(leaf.shape, self.max_priority**self.alpha))
        self.n = max(self.n, int(slots.max()) + 1)

    def sample(self, rng: np.random.Generator, batch_size: int, beta: float):
        """Stratified: one uniform draw in each of `batch_size` equal segments of the
        total (Schaul et al., Appendix B.2.1; their Alg. 1 only says j ~ P(j)).

        Returns (ep, t, weights): int64, int64, float32 importance weights (see class
        docstring).
        """
        total = self.tree.total()
        if self.n == 0 or total <= 0:
            raise ValueError("PrioritizedReplay.sample: nothing stored")
        seg = total / batch_size
        leaf = self.tree.find((np.arange(batch_size) + rng.random(batch_size)) * seg)
        p = self.tree.tree[leaf + self.tree._cap] / total
        N = self.n_transitions
        w = (N * p) ** (-beta)
        if self.weight_norm == "global":
            w_max = (N * self._min[1] / total) ** (-beta)
        else:
            w_max = w.max()
        return leaf // self.T, leaf % self.T, (w / w_max).astype(np.float32)

    def update(self, ep: np.ndarray, t: np.ndarray, td_error: np.ndarray) -> None:
        """Priority P = |td| + eps, stored as P^alpha;
        repeated (ep, t): the last one wins."""
        raw = np.abs(np.asarray(td_error, np.float64).reshape(-1)) + self.eps
        self._set(self._leaves(ep, t), raw**self.alpha)
        if raw.size:
            self.max_priority = max(self.max_priority, float(raw.max()))

    def state_dict(self) -> dict:
        return {
            "tree": self.tree.state_dict(),
            "max_priority": self.max_priority,
            "n": self.n,
            "alpha": self.alpha,
            "eps": self.eps,
            "T": self.T,
        }

    def load_state_dict(self, d: dict) -> None:
        if int(d["T"]) != self.T:
            raise ValueError(f"PrioritizedReplay T {d['T']} != {self.T}")
        self.tree.load_state_dict(d["tree"])
        self.max_priority, self.n = float(d["max_priority"]), int(d["n"])
        self.alpha, self.eps = float(d["alpha"]), float(d["eps"])
        cap = self.tree._cap
        self._min[:] = np.inf
        leaves = self.tree.tree[cap : cap + self.tree.capacity]
        self._min[cap : cap + self.tree.capacity] = np.where(leaves > 0, leaves, np.inf)
        for level in range(self.tree._depth - 1, -1, -1):
            k = np.arange(1 << level, 2 << level)
            self._min[k] = np.minimum(self._min[2 * k], self._min[2 * k + 1])


def per_beta(progress: float, beta0: float) -> float:
    """Importance-sampling exponent annealed linearly from beta0 to 1 (Schaul et al.
    2016, Sec. 3.4); `progress` in [0, 1] is the fraction of training done (clipped)."""
    return float(beta0 + (1.0 - beta0) * min(1.0, max(0.0, float(progress))))


def trajectory_energy(
    ag: np.ndarray,
    dt: float,
    w_potential: float = 1.0,
    w_kinetic: float = 1.0,
    clip_energy: float = 0.5,
    g: float = 9.81,
    m: float = 1.0,
) -> np.ndarray:
    """Trajectory energy of the object (Zhao & Tresp 2018, Eq. 1-5), shape (n,).

    `ag`: the objects' positions along each episode, (n, T+1, 3k) for k objects (the
    multi-step push has 2; their energies add, see below). For steps k = 1..T (as their
    `ReplayBufferEnergy.store_episode`), for one object:
      potential  U_k = m g (z_k - z_0)                (height relative to the start)
      kinetic    K_k = 0.5 m |(p_k - p_{k-1}) / dt|^2 (backward finite difference)
      total      E_k = w_potential U_k + w_kinetic K_k, and E_0 = 0
                 (start height, at rest)
      transition dE_k = clip(E_k - E_{k-1}, 0, clip_energy)
    and the trajectory energy is sum_k dE_k. Matches their code, where the first
    transition is E_1 itself. Their code hard-codes dt = 0.04 (Fetch: 20 substeps of
    2 ms; `env.unwrapped.dt`), g = 9.81, m = 1; the rotational term (hand tasks only)
    is left out. clip_energy = 0.5 is their Fetch setting (README); their CLI default
    is 999.
    """
    ag = np.asarray(ag, np.float64)
    if ag.ndim != 3 or ag.shape[2] < 3 or ag.shape[2] % 3 or ag.shape[1] < 2:
        raise ValueError(
            f"trajectory_energy: ag must be (n, T+1, 3k), k objects, got {ag.shape}"
        )
    # k objects (the multi-step push has 2): the objects' energies are added step by
    # step, and only the sum's increments are clipped, so the result is at most the sum
    # of the objects' own trajectory energies; one object is exactly the single-object
    # formula
    pos = ag.reshape(ag.shape[0], ag.shape[1], -1, 3)
    potential = m * g * (pos[:, 1:, :, 2] - pos[:, :1, :, 2]).sum(axis=2)
    velocity = np.diff(pos, axis=1) / dt
    kinetic = 0.5 * m * np.sum(velocity**2, axis=3).sum(axis=2)
    total = w_potential * potential + w_kinetic * kinetic
    dE = np.diff(total, axis=1, prepend=0.0)
    return np.clip(dE, 0.0, clip_energy).sum(axis=1)


def _rank(x: np.ndarray, method: str) -> np.ndarray:
    """scipy.stats.rankdata (1-based) for method in dense, min, average,
    without scipy."""
    uniq, inv, counts = np.unique(x, return_inverse=True, return_counts=True)
    if method == "dense":
        return inv.astype(np.float64) + 1
    # 0-based position of each value's first
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    if method == "min":
        return first[inv].astype(np.float64) + 1
    return first[inv] + (counts[inv] + 1) / 2.0  # average


class EnergyPrioritizer:
    """Trajectories sampled with probability proportional to their energy (Zhao & Tresp;
    their 'none' rank method): P(e) = (s_e + eps) / sum, s_e = E_e^(1/temperature').

    Their code samples with p ~ s^(1/(temperature + 0.01)) (default temperature 1, so an
    exponent of 1/1.01) and has no eps (an all-zero buffer gives NaN). Here
    `temperature=None` (default) means exponent 1 (exactly proportional); pass
    `temperature=1.0` (`Config.ebp_temperature`) to reproduce their exponent.
    `rank_method` in {"none", "dense", "min", "average"} reproduces their rank options:
    s_e = rank(E_e) - 1 over the stored episodes (the lowest-energy episode then has
    only eps). Each sampled episode's time step is drawn uniformly by the HER sampler,
    as in theirs.
    """

    def __init__(
        self,
        n_episodes_capacity: int,
        eps: float = 1e-6,
        temperature: float | None = None,
        rank_method: str = "none",
    ):
        if rank_method not in ("none", "dense", "min", "average"):
            raise ValueError("rank_method must be one of none, dense, min, average")
        self.size, self.eps = int(n_episodes_capacity), float(eps)
        self.temperature, self.rank_method = temperature, rank_method
        self.energy = np.zeros(self.size, np.float64)
        self.n = 0
        self._cdf = None

    def add_episodes(self, slots: np.ndarray, energy: np.ndarray) -> None:
        slots = np.asarray(slots, np.int64).reshape(-1)
        if slots.size == 0:
            return
        energy = np.broadcast_to(
            np.asarray(energy, np.float64).reshape(-1), slots.shape
        )
        if np.any(~np.isfinite(energy) | (energy < 0)):
            raise ValueError("EnergyPrioritizer: energies must be finite and >= 0")
        self.energy[slots] = energy
        self.n = max(self.n, int(slots.max()) + 1)
        self._cdf = None

    def probabilities(self) -> np.ndarray:
        """Sampling probability of stored slots 0..n-1."""
        e = self.energy[: self.n]
        s = e if self.rank_method == "none" else _rank(e, self.rank_method) - 1.0
        if self.temperature is not None:
            s = s ** (1.0 / (self.temperature + 1e-2))
        s = s + self.eps
        return s / s.sum()

    def sample_episodes(self, rng: np.random.Generator, batch_size: int) -> np.ndarray:
        if self.n == 0:
            raise ValueError("EnergyPrioritizer.sample_episodes: nothing stored")
        if self._cdf is None:
            self._cdf = np.cumsum(self.probabilities())
        u = rng.random(batch_size) * self._cdf[-1]
        return np.minimum(np.searchsorted(self._cdf, u, side="right"), self.n - 1)

    def state_dict(self) -> dict:
        return {"energy": self.energy[: self.n].copy(), "n": self.n}

    def load_state_dict(self, d: dict) -> None:
        self.n = int(d["n"])
        self.energy[:] = 0.0
        self.energy[: self.n] = d["energy"]
        self._cdf = None
