"""Dynamic initial-state selection (paper, section IV-B; Eq. 9).

From each training minibatch, the transitions of episodes that ended in success are
kept; the one with the largest intrinsic reward becomes a candidate start state (its
full MuJoCo state after the transition, and the episode's goal). New episodes restart
from a candidate with probability alpha; the stored goal is used only with
`restart_goal='episode'`, by default a restarted episode gets a fresh goal.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np


def novel_start_ratio(
    success_rate: float, alpha0: float, base: float = 10 * math.e
) -> float:
    """Eq. 9: alpha = alpha0 - 0.5 * (10e)^(success_rate - 1), clipped to [0, 1].

    `10e` is read as 10 times Euler's number, the default `base`
    (`Config.alpha_base`, book/departures.md, departure 14). With alpha0 = 0.8: 0.782
    at success 0, 0.704 at 0.5, 0.3 at 1.
    """
    return float(min(1.0, max(0.0, alpha0 - 0.5 * base ** (success_rate - 1.0))))


def select_candidate(r_int: np.ndarray, episode_success: np.ndarray) -> int | None:
    """Row of the minibatch with the largest intrinsic reward among rows whose
    episode succeeded.

    None when no row comes from a successful episode. Trap: r_int is clipped at eta
    (Eq. 4); on S-ICM's normalised inputs (protocol v1) a quarter of the eligible rows
    on Push sat at the clip, so the maximum was usually a tie (on raw inputs, the
    default, few rows reach it). argmax takes the first tied row, and since minibatch
    rows are in random order, a random one (`python -m acder_lite diagnose RUN` shows
    how often).
    """
    ok = np.flatnonzero(episode_success)
    if ok.size == 0:
        return None
    return int(ok[np.argmax(r_int[ok])])


class StartStateSelector:
    """A pool of the most recent candidates;
    `draw` picks the start of each new episode."""

    def __init__(self, pool_size: int, alpha0: float, base: float = 10 * math.e):
        self.pool: deque = deque(maxlen=pool_size)
        self.alpha0, self.base = alpha0, base
        self.alpha = novel_start_ratio(0.0, alpha0, base)

    def set_success_rate(self, success_rate: float) -> None:
        self.alpha = novel_start_ratio(success_rate, self.alpha0, self.base)

    def offer(
        self,
        batch: dict,
        r_int: np.ndarray,
        buffer,
        episode_success: np.ndarray | None = None,
    ) -> int | None:
        """Add the minibatch's best candidate (if any) to the pool; returns its row.

        `episode_success`: per row, whether its episode counts as a success; by default
        success at the episode's last step, as the buffer keeps it
        (`Config.candidate_success`, departure 16).
        """
        if episode_success is None:
            episode_success = buffer.success[batch["ep"]]
        row = select_candidate(r_int, episode_success)
        if row is not None:
            e, t = int(batch["ep"][row]), int(batch["t"][row])
            self.pool.append(
                dict(
                    state=buffer.state[e, t + 1].copy(),
                    goal=buffer.g[e, t].copy(),
                    r_int=float(r_int[row]),
                )
            )
        return row

    def draw(self, rng: np.random.Generator) -> dict | None:
        """With probability alpha a uniformly chosen pool candidate,
        else None (normal reset).

        The uniform number is drawn every time, so the random stream does not depend on
        the pool.
        """
        u, k = rng.random(), rng.integers(0, 1 << 30)
        if self.pool and u < self.alpha:
            return self.pool[int(k % len(self.pool))]
        return None

    def state_dict(self) -> dict:
        return dict(pool=list(self.pool), alpha=self.alpha)

    def load_state_dict(self, d: dict) -> None:
        self.pool.clear()
        self.pool.extend(d["pool"])
        self.alpha = d["alpha"]
