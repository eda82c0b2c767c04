"""Chapter 9's evidence about FetchPushMultiStep-v0, nothing learnt: a scripted pusher
that solves the task (so it is solvable in 100 steps), a uniformly random arm's
success, and which episodes start with the blocks already on their targets (the
chance level of test success).

The task itself is `acder_lite.envs.multistep`; this module only runs it."""

from __future__ import annotations

import numpy as np

from acder_lite.envs.fetch import make_env, run_env_seeds, successes
from acder_lite.envs.multistep import ENV_ID, MAX_EPISODE_STEPS, block_distances
from acder_lite.train.rollout import run_episodes

PUSH_BEHIND = 0.065
"""Scripted pusher: the gripper centre's distance behind the block centre while pushing
(half a block and the fingers)."""
PUSH_LIFT = 0.07
"""Scripted pusher: height above the blocks while moving round one."""
PUSH_DONE = 0.02
"""Scripted pusher: a block within this distance (metres, in xy) of its target is left
alone; the pusher takes the first block farther than this."""


def scripted_push(o: np.ndarray, g: np.ndarray, height_offset: float) -> np.ndarray:
    """One action of a scripted pusher (nothing learnt), for one observation vector `o`
    (40) and goal `g` (6), re-planned every step: take the first block more than
    `PUSH_DONE` from its target, get behind it on the line target -> block (flying
    above the blocks whenever it moves to a new spot), lower to the block's height
    (`height_offset`, the env's), push; then the other block. It shows the task can be
    solved in 100 steps (tests/test_multistep.py, chapter 9)."""
    # the full observation only, not a selection
    if o.shape != (40,) or g.shape != (6,):
        raise ValueError(f"scripted_push: o (40,) and g (6,), got {o.shape}, {g.shape}")
    grip = o[:3]
    ag, g = o[3:9].reshape(2, 3), g.reshape(2, 3)  # object{0,1}_pos (OBS_LAYOUT)
    todo = [i for i in range(2) if np.linalg.norm(ag[i, :2] - g[i, :2]) > PUSH_DONE]
    a = np.zeros(4)
    if not todo:
        return a
    b, t = ag[todo[0], :2], g[todo[0], :2]
    u = (t - b) / max(np.linalg.norm(t - b), 1e-9)
    rel = grip[:2] - b
    along = rel @ u
    perp = np.linalg.norm(rel - along * u)
    h, behind = height_offset, b - PUSH_BEHIND * u
    low = h - 0.005
    if along < -0.035 and perp < 0.012 and grip[2] < low + 0.02:  # in place: push
        off_line = behind - grip[:2]  # ... and stay on the line
        a[:2] = (t - (PUSH_BEHIND - 0.02) * u - grip[:2]) * 10
        a[:2] += off_line - (off_line @ u) * u
        a[2] = (low - grip[2]) * 10
    elif np.linalg.norm(grip[:2] - behind) < 0.01:  # above the spot: lower
        a[:2], a[2] = (behind - grip[:2]) * 10, (low - grip[2]) * 10
    elif grip[2] < h + PUSH_LIFT - 0.02:  # lift (first clear of the blocks)
        near = np.linalg.norm(ag[:, :2] - grip[:2], axis=1).min() < 0.07
        a[:2], a[2] = (0.0 if near else (behind - grip[:2]) * 10), 1.0
    else:  # fly to the spot
        a[:2], a[2] = (behind - grip[:2]) * 10, (h + PUSH_LIFT - grip[2]) * 10
    return np.clip(a, -1, 1)


def scripted_pusher(height_offset: float):
    """`scripted_push` as a policy of batched (o, g), as `rollout.run_episodes` and
    `viz.record_rollout` call one: (W, 40), (W, 6) -> (W, 4)."""
    return lambda o, g: np.stack(
        [scripted_push(oi, gi, height_offset) for oi, gi in zip(o, g)]
    )


def pusher_successes(seeds, horizon: int = MAX_EPISODE_STEPS) -> np.ndarray:
    """Whether the scripted pusher (`scripted_pusher`) has both blocks on their targets
    at the last step, one bool per seed: the first `rollout.run_episodes` episode of an
    env made with that seed. Chapter 9's evidence that the task is solvable."""

    envs = [make_env(ENV_ID, seed=s) for s in seeds]
    ep = run_episodes(envs, scripted_pusher(envs[0].height_offset), horizon)
    for e in envs:
        e.close()
    return ep["success"]


def random_counts(episodes: int, seed: int = 0, workers: int = 4) -> dict:
    """A uniformly random arm's episodes (rounded down to a multiple of `workers`),
    stepped as training steps them: dict(episodes, success = the share with both blocks
    on their targets at the last step, one = the share with at least one there, and
    n_success, n_one: the same as counts of episodes)."""

    rng = np.random.default_rng(seed)
    envs = [make_env(ENV_ID, seed=100 + i) for i in range(workers)]
    threshold = envs[0].distance_threshold
    succ, one = [], []
    act = lambda o, g: rng.uniform(-1.0, 1.0, (len(o), 4))  # noqa: E731
    for _ in range(episodes // workers):
        ep = run_episodes(envs, act, MAX_EPISODE_STEPS)
        succ.append(ep["success"])
        last = block_distances(ep["ag"][:, -1], ep["g"][:, -1])
        one.append((last < threshold).any(axis=1))
    for e in envs:
        e.close()
    succ, one = np.concatenate(succ), np.concatenate(one)
    return dict(
        episodes=succ.size,
        success=succ.mean(),
        one=one.mean(),
        n_success=int(succ.sum()),
        n_one=int(one.sum()),
    )


def start_on_targets(seeds, resets: int) -> dict:
    """Which episodes start already solved: for an env made with each seed of `seeds`
    (`envs.make_env`, whose seeding reset is not counted), `resets` further resets, no
    step. dict(both: both blocks within distance_threshold of their targets at reset,
    the env's own success rule `envs.successes`; one: at least one block so), bool
    arrays (resets, len(seeds)) in reset order; and each: each block so, bool
    (resets, len(seeds), 2).

    A policy that never moves a block succeeds on the `both` episodes and on no other:
    the chance level of test success (chapter 9)."""

    envs = [make_env(ENV_ID, seed=s) for s in seeds]
    both = np.zeros((resets, len(envs)), bool)
    each = np.zeros(both.shape + (2,), bool)
    for t in range(resets):
        for i, env in enumerate(envs):
            obs, _ = env.reset()
            ag, g = obs["achieved_goal"], obs["desired_goal"]
            both[t, i] = successes(env, ag, g)
            each[t, i] = block_distances(ag, g) < env.distance_threshold
    for env in envs:
        env.close()
    return dict(both=both, one=each.any(axis=-1), each=each)


def solved_test_starts(config: dict, evaluations: int) -> np.ndarray:
    """For a run of this task with `config` (config.json's "config": seed, workers,
    test_episodes), how many of each evaluation's test episodes start with both blocks
    on their targets, for its first `evaluations` evaluations (`Trainer.evaluate`
    resets each test env `test_episodes` times per evaluation, and nothing else draws
    from their random streams). Shape (evaluations,)."""

    seeds = run_env_seeds(config["seed"], config["workers"], test=True)
    both = start_on_targets(seeds, evaluations * config["test_episodes"])["both"]
    return both.reshape(evaluations, -1).sum(axis=1)
