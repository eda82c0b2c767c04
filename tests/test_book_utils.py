"""The book's helpers for every chapter (acder_lite.book_utils): the budgets, how
shares and vectors are written, chapter 1's random-policy episodes."""

import pytest

from acder_lite.book_utils import budgets, vector_text


def test_budgets_of_a_chapter_that_trains_nothing_print_no_precision(capsys):
    assert budgets(False, trains=False, resets=(10, 2)) == {"resets": 10}
    assert capsys.readouterr().out.splitlines() == ["ACDER_FAST=0: resets=10"]


def test_percent_drops_trailing_zeros():
    from acder_lite.book_utils import percent

    assert [percent(x) for x in (0.1, 0.025, 0.003, 1.0, 0.12345)] == [
        "10%",
        "2.5%",
        "0.3%",
        "100%",
        "12.3%",
    ]


def test_percent_range_gives_both_ends_the_same_decimals():
    from acder_lite.book_utils import percent_range

    assert percent_range(0.0043, 0.01) == "0.43% to 1.00%"
    assert percent_range(0.12, 0.3449) == "12% to 34%"
    assert percent_range(0.0, 0.0093) == "0.00% to 0.93%"
    assert percent_range(0.00038, 0.0093) == "0.038% to 0.930%"


def test_vector_text_prints_no_negative_zero():
    assert vector_text([1.3634, -0.0001, -0.1384]) == "[ 1.363  0.000 -0.138]"
    assert vector_text([[-0.0, 0.26]], digits=1) == "[ 0.0  0.3]"


def test_random_episode_stats_draws_from_the_callers_generator():
    """Chapter 1's random-policy episodes: `workers` envs seeded from `seed`, actions
    drawn from the generator passed in, which it advances (the chapter measures its
    tasks in turn from one generator)."""
    import numpy as np

    from acder_lite import envs as E
    from acder_lite.book_utils import EPISODE_STATS, episode_stats
    from acder_lite.book_utils import random_episode_stats, random_policy
    from acder_lite.rollout import run_episodes

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


def test_success_rank_ties_rates_that_print_alike():
    from acder_lite.book_utils import success_rank

    # 2.0% and 2.00004% print alike: a tie, though push > reach as floats
    assert success_rank(0.0200004, 0.02) == (
        "The success rates do not even tell Push from Reach"
    )
    assert success_rank(0.03, 0.02) == "The success rates even rank Push above Reach"
    assert success_rank(0.02, 0.03) == "The success rates rank Reach above Push"


def test_live_ended_names_the_runs_that_stopped_and_a_stop_rule_that_could_not():
    from acder_lite.book_utils import live_ended

    both = {"acder": (40, None), "her": (36, None)}
    assert live_ended(both, 5, 5) == "both ran the full 40 episodes"
    assert live_ended(both, 4, 5) == (
        "both ran the full 40 episodes (each run's 4 evaluations: the stop rule"
        " needs 5)"
    )
    ends = {"acder": (24, "success held"), "her": (40, "budget")}
    assert live_ended(ends, 12, 5) == (
        "acder stopped early, after 24 episodes (success held); her stopped early,"
        " after 40 episodes (budget)"
    )
