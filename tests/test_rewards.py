"""Eq. 4, 5-6 (and their sum, the shaped reward) and 9 against values worked
out by hand."""

import math

import numpy as np
import pytest

from acder_lite.algo.rewards import (
    goal_oriented_factor,
    goal_oriented_reward,
    intrinsic_reward,
    shaped_reward,
)
from acder_lite.algo.start_states import novel_start_ratio


def test_eq4_intrinsic_reward_below_at_and_above_the_clip():
    s2 = np.zeros((3, 2))
    pred = np.array(
        [
            [0.3, 0.4],  # 1/2 * (0.09 + 0.16) = 0.125 < eta
            [1.0, 0.0],  # 1/2 * 1 = 0.5 = eta
            [2.0, 2.0],
        ]
    )  # 1/2 * 8 = 4 > eta -> eta
    np.testing.assert_allclose(intrinsic_reward(pred, s2, eta=0.5), [0.125, 0.5, 0.5])
    assert intrinsic_reward(s2, s2, 0.8).tolist() == [
        0.0,
        0.0,
        0.0,
    ]  # a perfect prediction: 0
    assert intrinsic_reward(pred, s2, 0.05).max() == 0.05  # Reach's eta


@pytest.mark.parametrize(
    "action,expected",
    [
        ([1.0, 0.0, 0.0], 1.0),  # towards the goal: angle 0
        ([-2.0, 0.0, 0.0], 1.5),  # away from it: angle pi
        ([0.0, 3.0, 0.0], 1.25),  # perpendicular: pi/2
        ([1.0, 1.0, 0.0], 1.125),  # 45 degrees: (pi/4)/(2 pi) + 1
        (
            [0.0, 0.0, 0.0],
            1.25,
        ),  # no direction: pi/2 by convention (book/departures.md, departure 11)
    ],
)
def test_eq6_goal_oriented_factor(action, expected):
    lam = goal_oriented_factor(
        np.array([0.1, 0.2, 0.3]), np.array([0.6, 0.2, 0.3]), np.array(action + [0.7])
    )
    assert lam == pytest.approx(expected)


def test_eq6_batch_and_gripper_component_only():
    pos = np.zeros((3, 3))
    goal = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    act = np.array(
        [[1.0, 0, 0, -1.0], [0, -1.0, 0, 1.0], [1.0, 0, 0, 1.0]]
    )  # 4th component ignored
    np.testing.assert_allclose(goal_oriented_factor(pos, goal, act), [1.0, 1.5, 1.25])
    np.testing.assert_allclose(
        goal_oriented_factor(pos, pos, act), [1.25] * 3
    )  # at the goal
    # Eq. 5: the factor scales the HER reward in {-1, 0}
    np.testing.assert_allclose(
        goal_oriented_reward(np.array([-1.0, 0.0, -1.0]), np.array([1.5, 1.5, 1.0])),
        [-1.5, 0.0, -1.0],
    )


def _shaped_rows():
    """Five rows, the gripper at the origin, the goal at x = 1; the action's gripper
    part decides the angle (its 4th component, the fingers, is ignored)."""
    pos = np.zeros((5, 3))
    goal = np.tile([1.0, 0.0, 0.0], (5, 1))
    act = np.array(
        [
            [2.0, 0, 0, 1],  # towards the goal: lambda 1
            [-1.0, 0, 0, 1],  # away: 1.5
            [0, 1.0, 0, -1],  # perpendicular: 1.25
            [-1.0, 0, 0, 0],  # away, but not relabelled: 1
            [-1.0, 0, 0, 0],
        ]
    )  # away and relabelled, with r_her = 0: lambda 1.5 times 0
    r_her = np.array([-1.0, -1.0, -1.0, -1.0, 0.0], np.float32)
    relabelled = np.array([True, True, True, False, True])
    return r_her, relabelled, pos, goal, act


def test_shaped_reward_by_hand():
    """r = lambda * r_her + r_i (Eq. 4-6): lambda on the relabelled rows only,
    r_i added to all."""
    r_her, h, pos, goal, act = _shaped_rows()
    r, lam = shaped_reward(r_her, h, pos, goal, act)
    np.testing.assert_allclose(lam, [1.0, 1.5, 1.25, 1.0, 1.5])
    np.testing.assert_allclose(r, [-1.0, -1.5, -1.25, -1.0, 0.0])
    r_int = np.array([0.1, 0.2, 0.3, 0.4, 0.05], np.float32)
    r, lam = shaped_reward(r_her, h, pos, goal, act, r_int)
    np.testing.assert_allclose(lam, [1.0, 1.5, 1.25, 1.0, 1.5])
    np.testing.assert_allclose(r, [-0.9, -1.3, -0.95, -0.6, 0.05], rtol=1e-6)
    assert r.dtype == np.float32 and r.shape == (5,)


def test_shaped_reward_without_the_goal_factor():
    r_her, h, pos, goal, act = _shaped_rows()
    r, lam = shaped_reward(r_her, h, pos, goal, act, goal_factor=False)
    np.testing.assert_array_equal(lam, np.ones(5))
    np.testing.assert_array_equal(r, r_her)
    r, _ = shaped_reward(
        r_her, h, pos, goal, act, np.full(5, 0.5, np.float32), goal_factor=False
    )
    np.testing.assert_allclose(r, r_her + 0.5)
    r, lam = shaped_reward(
        r_her, np.zeros(5, bool), pos, goal, act
    )  # nothing relabelled: lambda 1
    np.testing.assert_array_equal(lam, np.ones(5))


def test_eq9_novel_start_ratio():
    e10 = 10 * math.e
    assert novel_start_ratio(0.0, 0.8) == pytest.approx(0.8 - 0.5 / e10)  # 0.78161
    assert novel_start_ratio(0.5, 0.8) == pytest.approx(
        0.8 - 0.5 / math.sqrt(e10)
    )  # 0.70410
    assert novel_start_ratio(1.0, 0.8) == pytest.approx(0.3)
    assert novel_start_ratio(1.0, 0.7) == pytest.approx(0.2)
    assert novel_start_ratio(1.0, 0.2) == 0.0  # clipped at 0
    assert novel_start_ratio(0.0, 0.8) == pytest.approx(0.78161, abs=1e-5)
    # Config.alpha_base, another reading of 10e (departure 14): 0.8 - 0.5 / 10 at
    # success 0, 0.8 - 0.5 / sqrt(10) at 0.5, and the same 0.3 at success 1
    assert novel_start_ratio(0.0, 0.8, base=10.0) == pytest.approx(0.75)
    assert novel_start_ratio(0.5, 0.8, 10.0) == pytest.approx(0.8 - 0.5 / 10**0.5)
    assert novel_start_ratio(1.0, 0.8, 10.0) == pytest.approx(0.3)


def test_eq4_reward_and_eq8_loss_measure_the_same_error():
    """Eq. 4's error (numpy, `intrinsic_reward`) and Eq. 8's (torch, `SICM.errors`)
    are computed in two places: a change to one (a mean over the dimensions, no 1/2)
    must fail here rather than split S-ICM's loss from the reward it ranks by."""
    import torch

    from acder_lite.algo.curiosity import SICM

    torch.manual_seed(0)
    s, a, s2 = torch.randn(64, 13), torch.randn(64, 4), torch.randn(64, 13)
    model = SICM(13, 4)
    with torch.no_grad():
        loss_rows, pred = model.errors(s, a, s2)
    reward = intrinsic_reward(pred.numpy(), s2.numpy(), eta=math.inf)  # no clip
    np.testing.assert_allclose(reward, loss_rows.numpy(), rtol=1e-5)
    assert reward.min() > 0.5  # the 13-D errors of an untrained model: not all at 0
