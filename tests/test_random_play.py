"""Chapter 1's random arm (acder_lite.book.random_play): what a random policy's episodes
count, drawn from the caller's generator."""

import numpy as np
import pytest


def test_random_episode_stats_draws_from_the_callers_generator():
    """Chapter 1's random-policy episodes: `workers` envs seeded from `seed`, actions
    drawn from the generator passed in, which it advances (the chapter measures its
    tasks in turn from one generator)."""
    from acder_lite.envs import fetch as E
    from acder_lite.book.random_play import EPISODE_STATS, episode_stats
    from acder_lite.book.random_play import random_episode_stats, random_policy
    from acder_lite.train.rollout import run_episodes

    rng = np.random.default_rng(0)
    first = random_episode_stats("FetchReach-v4", 5, rng, workers=2)
    second = random_episode_stats("FetchReach-v4", 5, rng, workers=2)
    assert set(first) == {*EPISODE_STATS, "dist"}
    assert first["success"].shape == (4,) and first["dist"].shape == (4, 50)
    assert first["moved"].all()  # Reach's achieved goal is the gripper: it moves
    assert np.array_equal(first["earned"], first["success"] & ~first["start"])
    # the same episodes by hand, the draws continuing across the two calls
    by_hand, act = [], random_policy(np.random.default_rng(0))
    for _ in range(2):
        envs = [E.make_env("FetchReach-v4", seed=100 + i) for i in range(2)]
        for _ in range(2):
            by_hand.append(episode_stats(run_episodes(envs, act, 50), envs[0]))
    for got, rounds in ((first, by_hand[:2]), (second, by_hand[2:])):
        assert np.array_equal(got["dist"], np.concatenate([p["dist"] for p in rounds]))
    assert not np.array_equal(first["dist"], second["dist"])  # not drawn afresh
    u = random_policy(np.random.default_rng(1))(np.zeros((3, 10)), None)
    assert u.shape == (3, 4) and np.abs(u).max() <= 1.0
    with pytest.raises(ValueError, match="workers <= episodes"):
        random_episode_stats("FetchReach-v4", 1, rng, workers=2)


def test_episode_stats_on_hand_made_episodes():
    """Chapter 1's counts: solved at the reset, earned, near at some step, moved."""
    from acder_lite.envs import fetch as E
    from acder_lite.book.random_play import EPISODE_STATS, episode_stats

    env = E.make_env("FetchPush-v4", seed=0)
    g = np.zeros((3, 2, 3))
    ag = np.zeros((3, 3, 3))
    ag[0] += [0.01, 0, 0]  # starts on the goal and stays: solved at step 0
    ag[1] = [[0.3, 0, 0], [0.02, 0, 0], [0.3, 0, 0]]  # passes near, moves, ends off
    ag[2] = [[0.3, 0, 0], [0.3, 0, 0], [0.005, 0, 0]]  # earned at the last step
    ep = dict(ag=ag, g=g, success=np.array([1.0, 0.0, 1.0]))
    s = episode_stats(ep, env)
    assert set(EPISODE_STATS) <= set(s) and s["dist"].shape == (3, 2)
    assert s["start"].tolist() == [True, False, False]
    assert s["earned"].tolist() == [False, False, True]
    assert s["any_step"].tolist() == [True, True, True]
    assert s["moved"].tolist() == [False, True, True]
    env.close()


def test_random_policy_draws_each_entry_uniform_in_minus_one_to_one():
    """The random arm's actions are `rng.uniform(-1, 1)` row by row: the whole action
    box, negative entries too, not only its positive half."""
    from acder_lite.book.random_play import random_policy

    u = random_policy(np.random.default_rng(7))(np.zeros((200, 10)), None)
    np.testing.assert_array_equal(
        u, np.random.default_rng(7).uniform(-1.0, 1.0, (200, 4))
    )
    assert u.min() < -0.9 and u.max() > 0.9  # 800 draws reach both ends of the box
