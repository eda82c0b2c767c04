import numpy as np
import pytest

from acder_lite.envs.fetch import make_env
from acder_lite.algo.her import sample_her_transitions


@pytest.fixture(scope="module")
def episodes():
    """Hand-made episodes whose achieved goals encode (episode, step), so a relabelled
    goal says exactly where it came from."""
    n, T = 30, 50
    ag = np.zeros((n, T + 1, 3), np.float32)
    ag[..., 0] = np.arange(n)[:, None]
    ag[..., 1] = np.arange(T + 1)[None, :]
    g = np.full((n, T, 3), -7.0, np.float32)
    o = np.zeros((n, T + 1, 5), np.float32)
    u = np.zeros((n, T, 4), np.float32)
    return dict(o=o, ag=ag, g=g, u=u)


def test_relabelled_goals_come_from_a_later_step_of_the_same_episode(episodes):
    rng = np.random.default_rng(0)
    env = make_env("FetchReach-v4", seed=0)
    b = sample_her_transitions(episodes, 20_000, 0.8, env.compute_reward, rng)
    h = b["her"]
    assert np.all(b["g"][h, 0] == b["ep"][h])  # same episode
    assert np.all(b["g"][h, 1] > b["t"][h])  # strictly later step
    assert np.all(b["g"][h, 1] <= 50)
    # exactly the achieved goal at future_t, the step the sampler reports
    ag = episodes["ag"][b["ep"][h], b["future_t"][h]]
    np.testing.assert_array_equal(b["g"][h], ag)
    assert np.all(b["g"][~h] == -7.0)  # the others keep their goal
    # relabel ratio 0.8 = 1 - 1/(1+k), k=4; 5 sigma of a binomial proportion
    sigma = np.sqrt(0.8 * 0.2 / 20_000)
    assert abs(h.mean() - 0.8) < 5 * sigma
    # every later step is reachable, including the final achieved goal ag[T]
    assert set(np.unique(b["future_t"][b["t"] == 0])) == set(range(1, 51))


def test_rewards_match_compute_reward():
    env = make_env("FetchPush-v4", seed=1)
    rng = np.random.default_rng(1)
    n, T = 4, 50
    ag = rng.uniform(0, 0.2, (n, T + 1, 3)).astype(np.float32)
    g = rng.uniform(0, 0.2, (n, T, 3)).astype(np.float32)
    eps = dict(
        o=np.zeros((n, T + 1, 2), np.float32),
        ag=ag,
        g=g,
        u=np.zeros((n, T, 4), np.float32),
    )
    b = sample_her_transitions(eps, 4000, 0.8, env.compute_reward, rng)
    d = np.linalg.norm(b["ag2"] - b["g"], axis=-1)
    np.testing.assert_array_equal(b["r"], -(d > 0.05).astype(np.float32))
    np.testing.assert_array_equal(b["r"], env.compute_reward(b["ag2"], b["g"], None))
    assert (b["r"] == 0).any() and (b["r"] == -1).any()
    # a relabelled goal taken from the very next step is always a success
    nxt = b["her"] & (b["future_t"] == b["t"] + 1)
    assert np.all(b["r"][nxt] == 0)


def test_no_her_when_future_p_is_zero(episodes):
    b = sample_her_transitions(
        episodes, 1000, 0.0, lambda a, g, i: np.zeros(len(a)), np.random.default_rng(2)
    )
    assert not b["her"].any() and np.all(b["g"] == -7.0)


def test_given_indices_choose_the_transitions(episodes):
    """Prioritised replay passes (episode, step) pairs: the rows are exactly those
    transitions (their achieved goals encode where they came from), and a relabelled
    row's goal still comes from a later step of its own episode."""
    env = make_env("FetchReach-v4", seed=0)
    ep, t = np.array([3, 7, 29, 3]), np.array([0, 49, 10, 48])
    b = sample_her_transitions(
        episodes, 4, 0.8, env.compute_reward, np.random.default_rng(0), ep, t
    )
    np.testing.assert_array_equal(b["ag"][:, :2], np.stack([ep, t], 1))
    np.testing.assert_array_equal(b["ag2"][:, :2], np.stack([ep, t + 1], 1))
    np.testing.assert_array_equal(b["ep"], ep)
    np.testing.assert_array_equal(b["t"], t)
    h = b["her"]
    assert np.all(b["g"][h, 0] == ep[h]) and np.all(b["g"][h, 1] > t[h])


def test_future_step_is_uniform_over_the_later_steps(episodes):
    """future_t is uniform on t+1..T: from t = 0 on 1..50 (chi-square over the 50 steps
    below its 0.999 quantile for 49 degrees of freedom, 85.35); from t = 49 always 50
    (ag[T], the final achieved goal); from t = 48, 49 or 50 half each."""
    rng = np.random.default_rng(5)

    def future(t, n):
        ep, t = np.zeros(n, np.int64), np.full(n, t)
        b = sample_her_transitions(
            episodes, n, 1.0, lambda a, g, i: np.zeros(len(a)), rng, ep, t
        )
        assert b["her"].all()
        np.testing.assert_array_equal(b["g"][:, 1], b["future_t"])  # the step used
        return b["future_t"]

    n = 50_000
    counts = np.bincount(future(0, n), minlength=51)
    assert counts[0] == 0 and counts.sum() == n and counts.size == 51
    chi2 = (((counts[1:] - n / 50) ** 2) / (n / 50)).sum()
    assert chi2 < 85.35
    assert set(future(49, 2000)) == {50}
    last = future(48, 20_000)
    assert set(last) == {49, 50}
    assert abs((last == 50).mean() - 0.5) < 0.02  # sd 0.0035


@pytest.mark.parametrize(
    "method, replay_k, future_p",
    [("her", 4, 0.8), ("her", 2, 2 / 3), ("acder", 4, 0.8), ("ddpg", 4, 0.0)],
)
def test_future_p_follows_replay_k_and_the_method(method, replay_k, future_p):
    """future_p = 1 - 1/(1 + replay_k) with HER (0.8 at k = 4, 2/3 at k = 2); DDPG
    relabels nothing. Read after resolve(): the method's switches are filled there."""
    from acder_lite.config import Config

    cfg = Config(method=method, replay_k=replay_k).resolve()
    assert cfg.future_p == pytest.approx(future_p, abs=1e-15)


def test_ddpg_minibatches_keep_their_own_goals():
    from acder_lite.train.trainer import Trainer

    from conftest import tiny_config

    tr = Trainer(tiny_config(method="ddpg", epochs=1, cycles=1))
    tr.train_cycle()
    b = tr.sample_batch()
    assert b["her"].size == 32 and not b["her"].any()
    np.testing.assert_array_equal(b["g"], tr.buffer.g[b["ep"], b["t"]])
