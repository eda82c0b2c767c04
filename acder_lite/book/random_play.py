"""Chapter 1's random arm: what a uniformly random policy's episodes on a Fetch task
come to (success, solved at the reset, earned, near the goal at some step, moved). The
chapter words the tasks against each other by hand and asserts what it says."""

from __future__ import annotations

EPISODE_STATS = {
    "success": "success at the last step",
    "start": "already solved at step 0",
    "earned": "success, not solved at step 0",
    "any_step": "within 5 cm at some step",
    "moved": "achieved goal moved > 1 cm",
}
"""What `episode_stats` counts per episode, in words (chapter 1's legend)."""


def episode_stats(ep: dict, env) -> dict:
    """Per episode of `rollout.run_episodes`' output `ep` on `env`'s task (arrays with a
    leading episode axis): the `EPISODE_STATS` as bools, and `dist`, the achieved goal's
    distance to the goal at steps 1..T. 'moved': the achieved goal ever more than 1 cm
    from where it started; 'start': the reset itself within the distance threshold."""
    import numpy as np

    start = env.compute_reward(ep["ag"][:, 0], ep["g"][:, 0], None) == 0
    dist = np.linalg.norm(ep["ag"][:, 1:] - ep["g"], axis=-1)
    moved = np.linalg.norm(ep["ag"] - ep["ag"][:, :1], axis=-1).max(axis=1) > 0.01
    succ = ep["success"].astype(bool)
    return dict(
        success=succ,
        start=start,
        earned=succ & ~start,
        any_step=(dist < env.distance_threshold).any(axis=1),
        moved=moved,
        dist=dist,
    )


def random_policy(rng, action_dim: int = 4):
    """A uniformly random policy for `rollout.run_episodes`: `act(o, g)` draws one
    action a row of `o` from `rng`, each entry uniform in [-1, 1]."""
    return lambda o, g: rng.uniform(-1.0, 1.0, (len(o), action_dim))


def random_episode_stats(
    env_id: str, episodes: int, rng, workers: int = 4, seed: int = 100
) -> dict:
    """`episode_stats` of a uniformly random policy (`random_policy(rng)`) on `env_id`
    over `episodes // workers` rounds of `rollout.run_episodes`, each stepping
    `workers` envs together (seeded `seed`, `seed + 1`, ...): one array a key, the
    rounds' episodes concatenated (`episodes // workers * workers` of them).

    Trap: the actions are drawn from the caller's `rng`, which this advances. Chapter 1
    measures its tasks in turn from one generator, so a task's draws follow the ones
    before it: measure them in the same order with the same generator for its
    numbers."""
    import numpy as np

    from acder_lite.envs import fetch as E
    from acder_lite.train.rollout import run_episodes

    if not 1 <= workers <= episodes:
        raise ValueError(
            f"episodes={episodes}, workers={workers}: allowed 1 <= workers <= episodes"
        )
    envs = [E.make_env(env_id, seed=seed + i) for i in range(workers)]
    act, horizon = random_policy(rng), E.horizon(env_id)
    try:
        per = [
            episode_stats(run_episodes(envs, act, horizon), envs[0])
            for _ in range(episodes // workers)
        ]
    finally:
        for env in envs:
            env.close()
    return {key: np.concatenate([p[key] for p in per]) for key in per[0]}
