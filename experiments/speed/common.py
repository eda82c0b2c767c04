"""What the speed scripts share: their arguments and a trainer past its first cycle.

`X.py [method] [threads]` (defaults her, 1): FetchPush-v4, 4 workers, seed 0, float32,
the reproduction grid's cell at that method.
"""

import sys

from acder_lite.config import Config
from acder_lite.train.trainer import Trainer


def args() -> tuple[str, int]:
    """(method, threads) from the command line."""
    method = sys.argv[1] if len(sys.argv) > 1 else "her"
    threads = int(sys.argv[2]) if len(sys.argv) > 2 else 1
    return method, threads


def warm_trainer(method: str, threads: int, **config) -> Trainer:
    """A FetchPush trainer after one training cycle (buffer filled, networks trained
    once), so every timed update is a steady-state one. `config`: more Config fields."""
    cfg = Config(
        env="FetchPush-v4",
        method=method,
        workers=4,
        threads=threads,
        seed=0,
        update_dtype="float32",
        **config,
    )
    tr = Trainer(cfg)
    tr.train_cycle()
    return tr
