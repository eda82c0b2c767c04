"""Chapter 5's readings of Eq. 6's factor (acder_lite.book.factor_report), from values
worked by hand: the factor of actions pointing at the goal, away from it, across it and
at the action box's corners. The figures of them: test_plots.py."""

import numpy as np
import pytest

from acder_lite.book import factor_report as F

GOAL = np.array([0.1, 0.0, 0.0])  # the chapter's: ahead of the gripper along +x


def test_action_is_a_unit_vector_turned_by_azimuth_and_elevation():
    np.testing.assert_allclose(F.action(0, 0), [1, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(F.action(90, 0), [0, 1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(F.action(180, 0), [-1, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(F.action(0, 90), [0, 0, 1, 0], atol=1e-15)
    s = np.sqrt(0.5)
    np.testing.assert_allclose(F.action(45, 45), [0.5, 0.5, s, 0], atol=1e-15)


def test_rotated_actions_at_the_goal_1_across_1_25_away_1_5():
    """Eq. 6 is 1 + angle / (2 pi): 1 pointing at the goal, 1.25 at right angles, 1.5
    pointing away; linear in the angle in between."""
    line = F.rotated_actions(GOAL, azimuth=[-180, -90, -45, 0, 30, 90, 180])
    np.testing.assert_allclose(line["angle"], [180, 90, 45, 0, 30, 90, 180])
    want = [1.5, 1.25, 1 + 45 / 360, 1.0, 1 + 30 / 360, 1.25, 1.5]
    np.testing.assert_allclose(line["lam"], want, atol=1e-12)
    full = F.rotated_actions(GOAL)  # the chapter's line: a degree a step
    assert len(full["lam"]) == 361
    assert full["angle"][[0, 180, 360]].tolist() == [180, 0, 180]
    np.testing.assert_allclose(full["lam"], 1 + full["angle"] / 360, atol=1e-12)


def test_angle_to_goal_by_hand_and_for_a_goal_off_the_axis():
    u = np.array([[1, 0, 0, 0.3], [0, -2, 0, 0], [-1, 0, 0, 0], [1, 1, 0, 0]])
    np.testing.assert_allclose(F.angle_to_goal(GOAL, u), [0, 90, 180, 45], atol=1e-6)
    # a goal along +y: the same actions, measured against it
    goal_y = np.array([0.0, 0.3, 0.0])
    np.testing.assert_allclose(F.angle_to_goal(goal_y, u), [90, 180, 90, 45], atol=1e-6)


def test_random_actions_one_draw_from_the_box_their_factor_and_angle():
    rand = F.random_actions(GOAL, 500, np.random.default_rng(3))
    u = np.random.default_rng(3).uniform(-1, 1, (500, 4))  # the same single draw
    np.testing.assert_array_equal(rand["u"], u)
    # the factor is Eq. 6 of the angle to the goal (the gripper component ignored)
    np.testing.assert_allclose(rand["lam"], 1 + rand["angle"] / 360, atol=1e-9)
    assert 1 <= rand["lam"].min() and rand["lam"].max() <= 1.5


def test_corner_factors_from_eq_6_by_hand():
    """(1, 1, 1) makes an angle arccos(1/sqrt 3) = 54.74 deg with +x, (-1, 1, 1) its
    supplement 125.26 deg: factors 1.1520 and 1.3480, summing to 2.5."""
    lam = F.corner_factors(GOAL)
    to = 1 + np.arccos(1 / np.sqrt(3)) / (2 * np.pi)
    np.testing.assert_allclose(lam, [to, 2.5 - to], atol=1e-12)
    assert lam[0] == pytest.approx(1.1520, abs=1e-4)
    assert lam[1] == pytest.approx(1.3480, abs=1e-4)


def test_random_actions_crowd_near_the_corner_factors_not_at_their_mean():
    """The module's trap, as chapter 5's text reads its histogram: uniform actions fill
    a cube, so more of their factors lie near the corner directions' factors than near
    their mean, 1.25 (the chapter's own draw, 2,000 actions with seed 0, and a large
    one)."""
    corners = F.corner_factors(GOAL)
    for n, seed in [(2000, 0), (200_000, 1)]:
        lam = F.random_actions(GOAL, n, np.random.default_rng(seed))["lam"]

        def near(x):
            return np.mean(np.abs(lam - x) < 0.025)

        assert lam.mean() == pytest.approx(1.25, abs=0.005)
        assert min(near(corners[0]), near(corners[1])) > 1.3 * near(1.25)
