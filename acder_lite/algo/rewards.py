"""ACDER's rewards: the intrinsic curiosity reward (Eq.
4) and the goal-oriented factor (Eq. 5-6).

Numpy in, numpy out, so that a reader (and a test) can evaluate them on hand-made
arrays; the trainer calls the same functions on each minibatch.
"""

from __future__ import annotations

import numpy as np

ZERO_NORM = 1e-8
"""Below this norm a vector has no direction; the angle is taken as pi/2
(lambda = 1.25)."""


def intrinsic_reward(
    pred_next: np.ndarray, next_state: np.ndarray, eta: float
) -> np.ndarray:
    """Eq. 4: r^i_t = clip(1/2 * ||F(s_t, a_t) - s_{t+1}||_2^2, 0, eta),
    one value per row.

    `pred_next` is S-ICM's prediction F(s_t, a_t), `next_state` the actual s_{t+1} (both
    the (o, g) S-ICM sees, `Config.sicm_input`), shapes (B, D). Returns shape (B,). The
    trainer calls this on every minibatch (ICM's reward too, on its features).
    """
    err = np.asarray(pred_next, np.float64) - np.asarray(next_state, np.float64)
    return np.clip(0.5 * np.sum(err * err, axis=-1), 0.0, eta)


def goal_oriented_factor(
    agent_pos: np.ndarray, goal: np.ndarray, action: np.ndarray
) -> np.ndarray:
    """Eq. 6: lambda_r = arccos(cos<s^a_t g^h, a_t>) / (2 pi) + 1, in [1, 1.5].

    `agent_pos` is s^a_t (the gripper position), `goal` the (relabelled) goal g^h,
    `action` the gripper displacement (the first 3 action components), all shape (B, 3)
    or (3,). An action pointing at the goal gives 1, one pointing away 1.5, a
    perpendicular one 1.25; so does a zero vector (departure 11: the angle is pi/2 when
    either norm is below 1e-8).
    """
    to_goal = np.asarray(goal, np.float64) - np.asarray(agent_pos, np.float64)
    a = np.asarray(action, np.float64)[..., :3]
    na = np.linalg.norm(a, axis=-1)
    ng = np.linalg.norm(to_goal, axis=-1)
    ok = (na >= ZERO_NORM) & (ng >= ZERO_NORM)
    cos = np.sum(a * to_goal, axis=-1) / np.where(ok, na * ng, 1.0)
    angle = np.where(ok, np.arccos(np.clip(cos, -1.0, 1.0)), np.pi / 2)
    return angle / (2 * np.pi) + 1.0


def goal_factor_target(goal: np.ndarray, achieved: np.ndarray) -> np.ndarray:
    """The 3-D goal g^h that Eq. 6 measures the action's angle against, shape (B, 3).

    One object (3-D goals): the goal itself. Several (the multi-step push's 6-D goals,
    object k at [3k, 3k+3)): the target of the object now farthest from its own, the one
    still to be pushed (our choice; the paper names no rule for it). `achieved` is the
    objects' position at step t.
    """
    goal = np.asarray(goal)
    if goal.shape[-1] == 3:
        return goal
    k = goal.shape[-1] // 3
    g = goal.reshape(-1, k, 3)
    far = np.argmax(
        np.linalg.norm(g - np.asarray(achieved).reshape(-1, k, 3), axis=-1), axis=1
    )
    return g[np.arange(len(g)), far]


def goal_oriented_reward(r_her: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Eq. 5: r^{e*}_t = lambda_r * r(s_t, a_t, g^h)."""
    return lam * r_her


def shaped_reward(
    r_her: np.ndarray,
    relabelled: np.ndarray,
    agent_pos: np.ndarray,
    goal: np.ndarray,
    action: np.ndarray,
    r_int: np.ndarray | None = None,
    goal_factor: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """The reward the critic learns from: r = lambda * r_her + r_i (Eq. 4-6).
    Returns (r, lambda).

    lambda is Eq. 6 on the rows HER relabelled (`relabelled`, the goal is g^h) and 1 on
    the others (their goal is the episode's own: Eq. 5 is written for hindsight goals),
    or 1 everywhere with `goal_factor` off; with `Config.goal_factor_rows="all"` the
    trainer passes every row as `relabelled`. `r_int` (Eq. 4) is added where given. The
    trainer, chapter 5 and the tests all call this one function.
    """
    r_her = np.asarray(r_her, np.float32)
    lam = np.ones_like(r_her)
    if goal_factor:
        h = np.asarray(relabelled, bool)
        lam[h] = goal_oriented_factor(agent_pos[h], goal[h], action[h])
    r = goal_oriented_reward(r_her, lam)
    if r_int is not None:
        r = r + r_int
    return r.astype(np.float32), lam
