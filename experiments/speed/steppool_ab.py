"""The W envs' stepping three ways, interleaved in one process (this machine is noisy):
sequential, one executor task per env (the rollout before `rollout.StepPool`), and
`StepPool`. FetchPush, 4 envs, 2 threads, random actions, one thread of torch; prints ms
per episode of each, 8 rounds, and the medians. Run from the repository root:
`.venv/bin/python experiments/speed/steppool_ab.py`."""

import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import torch

from acder_lite.envs import fetch as E
from acder_lite.train.rollout import StepPool, run_episodes

torch.set_num_threads(1)
envs = [E.make_env("FetchPush-v4", seed=i) for i in range(4)]
rng = np.random.default_rng(0)


def act(o, g):
    return rng.uniform(-1, 1, (o.shape[0], 4)).astype(np.float32)


class PerEnvTasks:
    """The old way: `executor.map` over the envs at every step."""

    def __init__(self, n):
        self.ex = ThreadPoolExecutor(n)

    def run(self, fn, items):
        list(self.ex.map(fn, items))


ways = dict(sequential=None, per_env_tasks=PerEnvTasks(2), step_pool=StepPool(2))
ms = {k: [] for k in ways}
for _ in range(8):
    for k, pool in ways.items():
        t = time.perf_counter()
        run_episodes(envs, act, 50, pool=pool)
        ms[k].append((time.perf_counter() - t) * 1e3 / len(envs))
for k, v in ms.items():
    rounds = " ".join(f"{x:.1f}" for x in v)
    print(f"{k:14s} ms/episode {rounds}  median {np.median(v):.1f}")
