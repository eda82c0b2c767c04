import numpy as np

from acder_lite.algo.buffer import EpisodeBuffer
from acder_lite.algo.start_states import StartStateSelector, select_candidate


def _buffer():
    T = 5
    buf = EpisodeBuffer(1000, T, dict(o=2, g=3, u=4, state=6))
    n = 6
    eps = dict(
        o=np.zeros((n, T + 1, 2)),
        ag=np.zeros((n, T + 1, 3)),
        g=np.zeros((n, T, 3)),
        u=np.zeros((n, T, 4)),
        state=np.zeros((n, T + 1, 6)),
        success=np.array([True, False, True, False, False, True]),
    )
    eps["state"][:] = (
        np.arange(n)[:, None, None] * 100 + np.arange(T + 1)[None, :, None]
    )
    eps["g"][:] = np.arange(n)[:, None, None]
    buf.store(eps)
    return buf


def test_select_candidate_only_successful_and_largest():
    r = np.array([0.9, 0.5, 0.7, 0.1])
    assert (
        select_candidate(r, np.array([False, True, True, False])) == 2
    )  # 0.9 is from a failure
    assert select_candidate(r, np.array([False, False, False, False])) is None


def test_selector_pool_holds_successful_states_with_max_reward():
    buf = _buffer()
    sel = StartStateSelector(pool_size=3, alpha0=0.8)
    rng = np.random.default_rng(0)
    for _ in range(50):
        ep = rng.integers(0, 6, 16)
        t = rng.integers(0, 5, 16)
        r = rng.random(16)
        row = sel.offer(dict(ep=ep, t=t), r, buf)
        ok = buf.success[ep]
        if ok.any():
            assert row == np.flatnonzero(ok)[np.argmax(r[ok])]
            cand = sel.pool[-1]
            assert buf.success[int(cand["state"][0] // 100)]  # a successful episode
            np.testing.assert_array_equal(
                cand["state"], buf.state[ep[row], t[row] + 1]
            )  # s_{t+1}
            assert cand["r_int"] == r[row]
            # the goal of the candidate's own step (_buffer: episode e's goal is e)
            np.testing.assert_array_equal(cand["goal"], buf.g[ep[row], t[row]])
            assert (cand["goal"] == cand["state"][0] // 100).all()
    assert len(sel.pool) == 3


def test_draw_follows_alpha():
    buf = _buffer()
    sel = StartStateSelector(pool_size=5, alpha0=0.8)
    rng = np.random.default_rng(1)
    assert sel.draw(rng) is None  # empty pool: normal reset
    sel.offer(dict(ep=np.array([0]), t=np.array([2])), np.array([0.3]), buf)
    sel.set_success_rate(1.0)  # alpha = 0.3
    draws = [sel.draw(rng) is not None for _ in range(4000)]
    assert abs(np.mean(draws) - 0.3) < 0.03
    sel.alpha0 = 0.0
    sel.set_success_rate(0.0)
    assert all(sel.draw(rng) is None for _ in range(100))


def test_offer_reads_the_episode_success_it_is_given():
    """`offer` takes per-row episode success (Config.candidate_success); by default
    the buffer's success at the last step."""
    buf = _buffer()  # episodes 0, 2 and 5 succeeded at their last step
    batch = dict(ep=np.array([1, 2, 3]), t=np.array([0, 1, 2]))
    r = np.array([0.9, 0.1, 0.5])
    assert StartStateSelector(3, 0.8).offer(batch, r, buf) == 1  # only episode 2
    ok = np.array([True, True, True])  # e.g. 'any': every episode counts
    sel = StartStateSelector(3, 0.8)
    assert sel.offer(batch, r, buf, ok) == 0
    np.testing.assert_array_equal(sel.pool[-1]["state"], buf.state[1, 1])


def test_draw_picks_uniformly_among_the_pool():
    """With alpha = 1 every draw is a pool candidate, each of 3 with probability 1/3
    (3,000 draws: sd 0.0086 a share)."""
    buf = _buffer()
    sel = StartStateSelector(pool_size=5, alpha0=0.8)
    for e in (0, 2, 5):  # the successful episodes, one candidate each
        sel.offer(dict(ep=np.array([e]), t=np.array([1])), np.array([0.3]), buf)
    assert len(sel.pool) == 3
    sel.alpha = 1.0
    rng = np.random.default_rng(2)
    picked = [int(sel.draw(rng)["state"][0] // 100) for _ in range(3000)]
    share = np.bincount(picked, minlength=6)[[0, 2, 5]] / 3000
    assert share.sum() == 1.0
    np.testing.assert_allclose(share, 1 / 3, atol=0.04)
