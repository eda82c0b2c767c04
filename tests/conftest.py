import os
import subprocess
import sys

import pytest

from acder_lite.config import Config

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def tiny_config(**kw) -> Config:
    """A configuration small enough for a unit test; same code path as the paper protocol."""
    base = dict(env="FetchReach-v4", method="her", workers=1, epochs=2, cycles=3, updates_per_cycle=4,
                batch_size=32, test_episodes=1, hidden=32, sicm_hidden=32, buffer_size=20_000, threads=1)
    base.update(kw)
    return Config(**base)


def run_cli(*args, timeout=300, **kw):
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([sys.executable, "-m", "acder_lite", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=ROOT, env=env, **kw)


@pytest.fixture
def cli():
    return run_cli
