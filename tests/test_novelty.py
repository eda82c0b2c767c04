"""Chapter 4's reading of familiar against unseen transitions (acder_lite.book.novelty):
S-ICM's errors on whole episodes, the sets and their shares at the clip, and the
start-state rule's criterion on them, from numbers worked by hand. The figures of them:
test_plots.py."""

import numpy as np
import pytest
import torch

from acder_lite.book import novelty as N
from acder_lite.train.trainer import Trainer

from conftest import tiny_config


def _push_trainer(**kw):
    return Trainer(tiny_config(env="FetchPush-v4", method="acder", **kw))


@pytest.mark.parametrize("sicm_input", ["normalised", "raw"])
def test_episode_errors_are_eq4_of_each_step(sicm_input):
    from acder_lite.algo.rewards import intrinsic_reward
    from acder_lite.train.rollout import run_episodes

    tr = _push_trainer(sicm_input=sicm_input)
    ep = run_episodes(tr.envs, tr.explore_act, tr.T)
    err = N.episode_errors(tr, ep)
    assert err.shape == (len(tr.envs), tr.T)
    clipped = N.episode_errors(tr, ep, eta=tr.cfg.eta)
    np.testing.assert_allclose(clipped, np.minimum(err, tr.cfg.eta))
    # one step by hand, through the trainer's own inputs
    b = dict(o=ep["o"][:1, 3], o2=ep["o"][:1, 4], g=ep["g"][:1, 3], u=ep["u"][:1, 3])
    tb = tr.batch_tensors(b)
    s, s2 = tr.curiosity_inputs(b, tb)
    with torch.no_grad():
        want = intrinsic_reward(tr.curiosity(s, tb["u"]).numpy(), s2.numpy(), np.inf)
    np.testing.assert_allclose(err[0, 3], want[0], rtol=1e-6)


@pytest.mark.parametrize(
    "familiar, new, keeps",
    [
        (0.6, 0.9, False),  # both above a half
        (0.4, 0.6, False),  # most new errors tie at the clip
        (0.6, 0.4, False),
        (0.5, 0.5, True),  # a half is not most
        (0.0, 0.0, True),  # no error reaches it: it still ranks every state
        (0.0, 0.01, True),  # a few reach it
    ],
)
def test_keeps_gap_where_most_errors_fall_below(familiar, new, keeps):
    """The start-state rule's criterion (chapter 8, departure 6): a clip that most
    errors of either set reach makes their r^i a tie; one that none reaches still
    ranks every state."""
    assert N.keeps_gap(familiar, new) is keeps


def test_episode_errors_need_sicm():
    from acder_lite.config import ConfigError
    from acder_lite.train.rollout import run_episodes

    tr = Trainer(tiny_config(method="her"))
    ep = run_episodes(tr.envs, tr.explore_act, tr.T)
    with pytest.raises(ConfigError, match="no S-ICM"):
        N.episode_errors(tr, ep)


def test_error_sets_put_the_buffers_first_episodes_first_then_the_given_ones():
    from acder_lite.train.rollout import run_episodes

    trs = {inp: _push_trainer(sicm_input=inp) for inp in ("normalised", "raw")}
    for t in trs.values():
        t.train_cycle()  # a filled buffer, a trained model
    tr = trs["raw"]
    eps = {
        "new exploration": run_episodes(tr.envs, tr.explore_act, tr.T),
        "still": run_episodes(tr.envs, lambda o, g: np.zeros((len(o), 4)), tr.T),
    }
    sets = N.error_sets(trs, eps, familiar=2)
    assert list(sets) == ["normalised", "raw"]
    for inp, t in trs.items():
        assert list(sets[inp]) == [N.FAMILIAR, "new exploration", "still"]
        assert sets[inp][N.FAMILIAR].shape == (2, t.T)
        buf = t.buffer.arrays()
        own = {k: buf[k][:2] for k in ("o", "g", "u")}  # the first two stored
        np.testing.assert_array_equal(sets[inp][N.FAMILIAR], N.episode_errors(t, own))
        np.testing.assert_array_equal(
            sets[inp]["still"], N.episode_errors(t, eps["still"])
        )
    # the same episodes, seen through each model's own input: different errors
    assert not np.allclose(sets["raw"]["still"], sets["normalised"]["still"])


def sets_by_hand():
    return {
        "normalised": {
            N.FAMILIAR: np.array([[0.01, 0.05], [0.5, 0.9]]),
            N.NEW: np.array([[0.8, 1.0], [2.0, 0.02]]),
            "scripted": np.array([[3.0, 4.0], [5.0, 6.0]]),
        },
        "raw": {
            N.FAMILIAR: np.array([[1e-3, 2e-3], [3e-3, 4e-3]]),
            N.NEW: np.array([[0.06, 1e-3], [2e-3, 3e-3]]),
            "scripted": np.array([[0.1, 0.2], [0.3, 0.4]]),
        },
    }


def test_medians_and_shares_at_the_clip_count_errors_at_or_above_eta():
    sets = sets_by_hand()
    med = N.medians(sets)
    assert list(med) == ["normalised", "raw"]
    assert med["normalised"] == pytest.approx([0.275, 0.9, 4.5])
    assert med["raw"] == pytest.approx([0.0025, 0.0025, 0.25])
    at = N.shares_at(sets, [0.05, 0.8])
    # 0.05 and 0.8 themselves count: Eq. 4 pays them the full eta
    np.testing.assert_array_equal(at["normalised"][N.FAMILIAR], [0.75, 0.25])
    np.testing.assert_array_equal(at["normalised"][N.NEW], [0.75, 0.75])
    np.testing.assert_array_equal(at["raw"]["scripted"], [1.0, 0.0])
    kept = N.shares_at(sets, [0.8], names=(N.NEW, N.FAMILIAR))
    assert [list(s) for s in kept.values()] == [[N.NEW, N.FAMILIAR]] * 2


def test_clip_shares_table_and_readings_of_the_paper_etas():
    sat = N.clip_shares(sets_by_hand(), (0.05, 0.8))
    assert list(sat) == [
        (inp, k, x) for inp in ("normalised", "raw") for k in ("fam", "new")
        for x in (0.05, 0.8)
    ]  # fmt: skip
    assert sat["normalised", "new", 0.8] == 0.75 and sat["raw", "new", 0.05] == 0.25
    head, rows = N.clip_table(sat)
    assert head == [
        "share at the clip",
        "familiar, eta = 0.05",
        "new, eta = 0.05",
        "familiar, eta = 0.8",
        "new, eta = 0.8",
    ]
    assert rows == [
        ["normalised", "75%", "75%", "25%", "75%"],
        ["raw", "0%", "25%", "0%", "0%"],
    ]
    # normalised: 75% of the new errors tie at eta = 0.8; raw: a quarter at 0.05
    assert N.gaps_kept(sat) == {"normalised": False, "raw": True}
    sat["raw", "new", 0.05] = 0.6  # raw fails at 0.05 only: one eta is enough
    assert N.gaps_kept(sat) == {"normalised": False, "raw": False}


def test_ratio_table_puts_each_median_over_the_familiar_one():
    med = {"normalised": [0.2, 0.3, 2.0], "raw": [0.004, 0.004, 0.5]}
    head, rows = N.ratio_table(med, [N.FAMILIAR, N.NEW, "scripted"])
    assert head == ["median / familiar median", N.FAMILIAR, N.NEW, "scripted"]
    assert rows == [["normalised", "1", "1.5", "10"], ["raw", "1", "1", "125"]]


def test_rollout_halves_leave_out_the_turn_and_count_errors_at_each_inputs_eta():
    e = np.array([0.1, 0.2, 0.9, 5.0, 5.0, 0.8, 0.7, 2.0])  # explore 3, turn 2, sweep
    got = N.rollout_halves(
        {"raw": e, "normalised": e}, {"raw": 0.8, "normalised": 0.05}, 3, 2
    )
    assert list(got) == [
        ("raw", "explore"),
        ("raw", "sweep"),
        ("normalised", "explore"),
        ("normalised", "sweep"),
    ]
    assert got["raw", "explore"] == pytest.approx((0.2, 1 / 3))
    # 0.8 itself is at the clip: Eq. 4 pays it the full eta
    assert got["raw", "sweep"] == pytest.approx((0.8, 2 / 3))
    assert got["normalised", "sweep"] == pytest.approx((0.8, 1.0))
