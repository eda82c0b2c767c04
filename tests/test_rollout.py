"""The rollout: stepping the W envs in parallel threads gives the same run bit for
bit."""

import numpy as np
import pytest

from acder_lite.trainer import Trainer
from conftest import tiny_config


def _strip(rows):
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


@pytest.mark.parametrize(
    "env, method", [("FetchReach-v4", "her"), ("FetchPush-v4", "acder")]
)
def test_parallel_stepping_is_the_same_run(env, method):
    """Same seed and torch threads; only step_threads differs: every progress row and
    the whole replay buffer (MuJoCo states included) are equal. ACDER restarts episodes
    from stored states."""
    runs = []
    for step_threads in (1, 3):
        tr = Trainer(
            tiny_config(
                env=env,
                method=method,
                workers=3,
                epochs=2,
                cycles=2,
                step_threads=step_threads,
            )
        )
        assert (tr.pool is None) == (step_threads == 1)
        runs.append((_strip(tr.train(progress=False)), tr.buffer.arrays()))
    (rows_a, buf_a), (rows_b, buf_b) = runs
    assert rows_a == rows_b and len(rows_a) == 2
    for key in ("o", "ag", "g", "u", "state", "success"):
        np.testing.assert_array_equal(buf_a[key], buf_b[key], err_msg=key)


def test_step_threads_default_follows_threads():
    assert Trainer(tiny_config(threads=1)).pool is None
    tr = Trainer(tiny_config(threads=2, workers=2))
    assert tr.pool is not None and tr.pool._max_workers == 2
    assert Trainer(tiny_config(threads=2, workers=2, step_threads=1)).pool is None
