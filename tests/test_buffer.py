"""The replay buffer's FIFO eviction (Baselines' ring buffer, book/departures.md,
departure 25: a replay buffer of 10^6 transitions per worker): once full, a new
episode overwrites the
oldest one."""

import numpy as np

from acder_lite.algo.buffer import EpisodeBuffer


def _episodes(first: int, k: int, T: int) -> dict:
    """k episodes numbered first.. ; every entry of episode e holds e."""
    e = np.arange(first, first + k, dtype=np.float64)

    def full(steps, dim):
        return np.broadcast_to(e[:, None, None], (k, steps, dim)).copy()

    return dict(
        o=full(T + 1, 2),
        ag=full(T + 1, 3),
        g=full(T, 3),
        u=full(T, 4),
        state=full(T + 1, 5),
        success=(e % 2 == 0),
    )


def test_a_full_buffer_overwrites_its_oldest_episodes_first():
    """Capacity 15 transitions of T = 5: 3 episodes. Storing episodes 0, 1, then
    2, 3, then 4 puts them in slots [0, 1], [2, 0], [1]: episode 3 replaces
    episode 0 (the oldest) and 4 replaces 1, so the buffer holds 3, 4, 2 with their
    success flags, n stays 3 and `total` counts 5."""
    T = 5
    buf = EpisodeBuffer(15, T, dict(o=2, g=3, u=4, state=5))
    assert buf.size == 3
    assert buf.store(_episodes(0, 2, T)).tolist() == [0, 1]
    assert buf.store(_episodes(2, 2, T)).tolist() == [2, 0]
    assert buf.store(_episodes(4, 1, T)).tolist() == [1]
    assert (buf.n, buf.next, buf.total, buf.n_transitions) == (3, 2, 5, 15)
    a = buf.arrays()
    for key in ("o", "ag", "g", "u", "state"):
        np.testing.assert_array_equal(a[key][:, 0, 0], [3.0, 4.0, 2.0], err_msg=key)
    assert a["success"].tolist() == [False, True, True]


def test_n_counts_every_episode_of_a_batch():
    """A batch of k episodes adds k to n (W workers store W at once), until the
    capacity caps it: with 3 slots, n is 2 after episodes 0-1 and 3 after 2-3."""
    buf = EpisodeBuffer(15, 5, dict(o=2, g=3, u=4, state=5))
    buf.store(_episodes(0, 2, 5))
    assert (buf.n, buf.next, buf.total) == (2, 2, 2)
    assert buf.arrays()["o"].shape[0] == 2
    buf.store(_episodes(2, 2, 5))
    assert (buf.n, buf.next, buf.total) == (3, 1, 4)


def test_a_loaded_buffer_goes_on_as_the_saved_one():
    """state_dict / load_state_dict of a buffer that has wrapped around: episodes 3,
    4, 2 in slots 0-2 (successes False, True, True), next slot 2. A fresh buffer that
    loads it holds the same arrays and success flags, and its next episode (5) goes
    to slot 2, over episode 2 (the oldest), not to slot n % size = 0."""
    T, dims = 5, dict(o=2, g=3, u=4, state=5)
    buf = EpisodeBuffer(15, T, dims)
    for first, k in ((0, 2), (2, 2), (4, 1)):
        buf.store(_episodes(first, k, T))
    new = EpisodeBuffer(15, T, dims)
    new.load_state_dict(buf.state_dict())
    assert (new.n, new.next, new.total) == (3, 2, 5)
    assert new.arrays()["success"].tolist() == [False, True, True]
    assert new.store(_episodes(5, 1, T)).tolist() == [2]
    np.testing.assert_array_equal(new.arrays()["o"][:, 0, 0], [3.0, 4.0, 5.0])
