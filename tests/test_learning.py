"""Short learning runs: each method learns FetchReach-v4 with one worker
within 300 episodes.

Same code path as the paper protocol, with W = 1 (20 updates of 256 per episode cost the
same as the 4-worker protocol's 40 of 1024 per 8 episodes), and epochs of 50 cycles
(Reach's preset is Baselines' 10): 3 epochs are 300 episodes. The stop rule with
patience 1 ends the run at the first evaluation (every 5 cycles = 10 episodes, on 10
test episodes) with test success >= 0.9.
"""

import pytest

from acder_lite.config import Config
from acder_lite.train.trainer import Trainer


@pytest.mark.parametrize(
    "method",
    [
        "her",
        "acder",
        "acder-no-curiosity",
        "acder-no-goal-factor",
        "acder-no-start-states",
        "her-icm",
        "her-per",
    ],
)
def test_learns_fetch_reach_within_300_episodes(method):
    cfg = Config(
        env="FetchReach-v4",
        method=method,
        seed=0,
        workers=1,
        epochs=3,
        cycles=50,
        eval_every_cycles=5,
        test_episodes=10,
        success_threshold=0.9,
        stop_patience=1,
        threads=1,
    )
    tr = Trainer(cfg)
    rows = tr.train(progress=False)
    best = max(r["test_success"] for r in rows)
    reached = [r["episodes"] for r in rows if r["test_success"] >= 0.9]
    assert reached and reached[0] <= 300, (
        f"{method}: best test success {best} in {rows[-1]['episodes']} episodes"
    )
    assert tr.stop_reason == "success held" and rows[-1]["episodes"] == reached[0]
