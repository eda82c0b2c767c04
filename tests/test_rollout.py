"""The rollout: stepping the W envs in parallel threads gives the same run bit for
bit; so does a run on two threads (envs stepped and losses computed at once) against one
on one thread."""

import threading

import numpy as np
import pytest
import torch

from acder_lite.train.rollout import StepPool
from acder_lite.train.trainer import Trainer
from conftest import assert_same_run, tiny_config


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
    assert tr.pool is not None and tr.pool.n == 2
    assert Trainer(tiny_config(threads=2, workers=2, step_threads=1)).pool is None


def test_step_pool_runs_every_item_once_in_n_threads():
    pool = StepPool(3)
    seen = {}

    def fn(i):
        seen.setdefault(i, []).append(threading.current_thread().name)

    pool.run(fn, list(range(7)))
    assert sorted(seen) == list(range(7)) and all(len(v) == 1 for v in seen.values())
    # the caller's own share is every n-th item; the rest ran in the helpers
    main = threading.current_thread().name
    assert [i for i, v in seen.items() if v == [main]] == [0, 3, 6]
    assert all(v[0].startswith("step") for i, v in seen.items() if i % 3)
    pool.run(fn, [0])  # fewer items than threads: the caller steps it alone
    assert seen[0] == [main, main]


def test_step_pool_reraises_an_error_of_any_share():
    def fn(i):
        if i == 1:  # thread 1's share
            raise RuntimeError("env 1 failed")

    with pytest.raises(RuntimeError, match="env 1 failed"):
        StepPool(2).run(fn, [0, 1, 2, 3])
    with pytest.raises(ValueError, match="n >= 2"):
        StepPool(1)


@pytest.mark.parametrize("method", ["acder", "her-per"])
def test_two_threads_are_the_one_thread_run(method):
    """threads=2 (envs stepped in two threads, the two losses at once on one intra-op
    thread each) against threads=1: every progress row, the replay buffer, every
    weight and the random stream are equal (conftest.assert_same_run). PER's priorities
    come from the critic thread's TD errors."""
    runs = []
    for threads in (1, 2):
        cfg = tiny_config(
            env="FetchPush-v4", method=method, workers=2, hidden=64, threads=threads
        )
        tr = Trainer(cfg)
        assert cfg.split == (threads == 2) and torch.get_num_threads() == 1
        assert (tr.agent.actor_thread is None) == (threads == 1)
        tr.train(progress=False)
        runs.append(tr)
    assert len(runs[0].rows) == 2
    assert_same_run(*runs)


def test_split_update_follows_threads():
    from acder_lite.config import Config

    assert not Config(threads=1).split and Config(threads=2).split
    assert Config(threads=2).torch_threads == 1 and Config(threads=5).torch_threads == 2
    off = Config(threads=2, split_update="off")
    assert not off.split and off.torch_threads == 2
    assert Config(threads=1, split_update="on").torch_threads == 1
    # a config.json written before the setting existed is the run it was: one thread
    assert Config.from_dict(dict(threads=2)).split_update == "off"


def test_bench_counts_the_flops_of_both_loss_threads():
    from acder_lite.cli.bench import update_flops

    flops = {}
    for threads in (1, 2):
        tr = Trainer(tiny_config(env="FetchPush-v4", threads=threads))
        tr.train_cycle()  # a filled buffer to sample from
        flops[threads] = update_flops(tr)
        assert (tr.agent.actor_thread is None) == (threads == 1)  # put back
    assert flops[1] == flops[2] > 0


def test_bench_matmul_rate_is_measured_in_the_updates_precision(monkeypatch):
    """A bfloat16 update is held to the bfloat16 matmul rate, not float32's (on a CPU
    with AMX the two differ several times, and share_of_limit read above 1)."""
    from acder_lite.cli import bench

    seen = []
    mm = torch.mm

    def spy(a, b, **kw):
        seen.append((a.dtype, b.dtype))
        return mm(a, b, **kw)

    monkeypatch.setattr(bench.torch, "mm", spy)
    for dtype in ("float32", "bfloat16"):
        seen.clear()
        assert bench.matmul_gflops(1, m=64, k=32, n=32, seconds=0.01, dtype=dtype) > 0
        assert set(seen) == {(getattr(torch, dtype),) * 2}


def test_run_episodes_records_what_the_envs_did():
    """run_episodes against the envs' own rules, not against itself: success is the
    env's reward of the last achieved goal (0 within 5 cm); an env given a stored start
    is marked novel and begins from that state's observation; every stored state
    restores the observation stored beside it."""
    from acder_lite.envs import fetch as E
    from acder_lite.train.rollout import run_episodes

    envs = [E.make_env("FetchPush-v4", seed=s) for s in (0, 1, 2)]
    rng = np.random.default_rng(0)

    def act(o, g):
        return rng.uniform(-1, 1, (len(o), 4)).astype(np.float32)

    first = run_episodes(envs, act, 10)
    stored = dict(state=first["state"][1, 7].copy(), goal=None)
    ep = run_episodes(envs, act, 10, starts=lambda i: stored if i == 1 else None)
    assert ep["novel"].tolist() == [False, True, False]
    np.testing.assert_array_equal(ep["o"][1, 0], first["o"][1, 7])
    for i, env in enumerate(envs):
        r = env.unwrapped.compute_reward(ep["ag"][i, 10], ep["g"][i, 9], None)
        assert ep["success"][i] == (r == 0)
        for t in (0, 5, 10):
            E.set_state(env, ep["state"][i, t])
            o = env.unwrapped._get_obs()["observation"].astype(np.float32)
            np.testing.assert_array_equal(o, ep["o"][i, t])  # stored as float32


def test_run_episodes_success_is_the_last_steps(monkeypatch):
    """`success` is the env's verdict at the last step only: an env that succeeds at
    every step but the last reads as failed, one that succeeds at the last step only
    as a success. The verdicts are scripted: an env succeeds at a step whose action's
    first component is above 0."""
    from acder_lite.envs import fetch as E
    from acder_lite.train.rollout import run_episodes

    step = E.step
    monkeypatch.setattr(E, "step", lambda env, a: (step(env, a)[0], bool(a[0] > 0)))
    envs = [E.make_env("FetchReach-v4", seed=s) for s in (0, 1)]
    T, t = 5, iter(range(5))

    def act(o, g):
        x = 0.5 if next(t) == T - 1 else -0.5  # > 0 at the last step only
        return np.array([[x, 0, 0, 0], [-x, 0, 0, 0]], np.float32)

    ep = run_episodes(envs, act, T)
    assert ep["success"].tolist() == [True, False]


@pytest.mark.parametrize("threads", [1, 2])
def test_run_episodes_asks_for_the_starts_in_env_order(threads):
    """`starts` draws from the trainer's one random stream (`Trainer._start`), so env
    i must get the i-th draw, with or without a StepPool: the draws come in env order
    0, 1, 2."""
    from acder_lite.envs import fetch as E
    from acder_lite.train.rollout import run_episodes

    envs = [E.make_env("FetchReach-v4", seed=s) for s in range(3)]
    asked = []

    def starts(i):
        asked.append(i)
        return None

    pool = StepPool(threads) if threads > 1 else None
    run_episodes(envs, lambda o, g: np.zeros((len(o), 4), np.float32), 2, starts, pool)
    assert asked == [0, 1, 2]
