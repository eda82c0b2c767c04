"""Hindsight Experience Replay, "future" strategy
(Andrychowicz et al. 2017; Baselines' sampler).

A share `future_p` = 1 - 1/(1+k) of a minibatch (0.8 for k = 4) gets its goal replaced
by the achieved goal of a later step of the same episode; rewards are recomputed with
the env's own `compute_reward`. Vectorised: no Python loop over samples.
"""

from __future__ import annotations

import numpy as np


def sample_her_transitions(
    episodes: dict[str, np.ndarray],
    batch_size: int,
    future_p: float,
    reward_fn,
    rng: np.random.Generator,
    ep_idx: np.ndarray | None = None,
    t_idx: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Sample `batch_size` transitions (s_t, a_t, g, s_{t+1}, r) from stored episodes.

    `episodes` holds arrays o, ag (n, T+1, .), g, u (n, T, .). Episodes and steps are
    uniform unless given (`ep_idx`, `t_idx`: prioritised replay chooses them). Returned
    arrays: o, o2, ag, ag2, g, u, r, plus the indices ep, t, future_t and the boolean
    mask `her` of relabelled rows.
    """
    n, T = episodes["u"].shape[:2]
    ep = rng.integers(0, n, batch_size) if ep_idx is None else np.asarray(ep_idx)
    t = rng.integers(0, T, batch_size) if t_idx is None else np.asarray(t_idx)
    her = rng.random(batch_size) < future_p
    # A later step: t+1 .. T (ag has T+1 entries, ag[T] is the final achieved goal).
    future_t = t + 1 + (rng.random(batch_size) * (T - t)).astype(np.int64)
    g = episodes["g"][ep, t].copy()
    g[her] = episodes["ag"][ep[her], future_t[her]]
    ag2 = episodes["ag"][ep, t + 1]
    r = np.asarray(reward_fn(ag2, g, None), dtype=np.float32)
    return dict(
        o=episodes["o"][ep, t],
        o2=episodes["o"][ep, t + 1],
        ag=episodes["ag"][ep, t],
        ag2=ag2,
        g=g,
        u=episodes["u"][ep, t],
        r=r,
        ep=ep,
        t=t,
        future_t=future_t,
        her=her,
    )
