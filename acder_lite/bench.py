"""`python -m acder_lite bench`: what an episode costs, simulation against training.

All figures are measured in the same run (this machine is noisy): random-action simulation per
episode, full training per episode (collection + 40 updates per cycle + target update, after a
warm-up cycle), the update step's achieved GFLOP/s (FLOPs counted by torch's FlopCounterMode) and
the machine's fp32 matmul GFLOP/s at the update's layer shape, on the same threads.
"""
from __future__ import annotations

import time

import numpy as np
import torch


def matmul_gflops(threads: int, m: int = 1024, k: int = 256, n: int = 256, seconds: float = 1.0) -> float:
    """fp32 GFLOP/s of (m x k) @ (k x n), the shape of a hidden layer on one minibatch."""
    torch.set_num_threads(threads)
    a, b, out = torch.randn(m, k), torch.randn(k, n), torch.empty(m, n)
    for _ in range(20):
        torch.mm(a, b, out=out)
    reps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        for _ in range(50):
            torch.mm(a, b, out=out)
        reps += 50
    return 2 * m * k * n * reps / (time.perf_counter() - t0) / 1e9


def update_flops(trainer) -> float:
    from torch.utils.flop_counter import FlopCounterMode
    with FlopCounterMode(display=False) as fc:
        trainer.update_step()
    return float(fc.get_total_flops())


def run_bench(args) -> int:
    from .config import Config
    from .trainer import Trainer, run_episodes
    cfg = Config(env=args.env, method=args.method, workers=args.workers, threads=args.threads, seed=0)
    tr = Trainer(cfg)
    W, T = cfg.workers, tr.T
    rng = np.random.default_rng(0)

    def rand_act(o, g):
        return rng.uniform(-1, 1, (o.shape[0], tr.dims["u"])).astype(np.float32)

    # simulation alone (random actions, same stepping code as training)
    run_episodes(tr.envs, rand_act, T)
    t0 = time.perf_counter()
    n_sim = 0
    while time.perf_counter() - t0 < 2.0:
        run_episodes(tr.envs, rand_act, T)
        n_sim += W
    sim_ms = (time.perf_counter() - t0) / n_sim * 1e3

    tr.train_cycle()  # warm-up: fills the buffer, allocators, thread pools
    t0 = time.perf_counter()
    for _ in range(args.cycles):
        tr.train_cycle()
    train_ms = (time.perf_counter() - t0) / (args.cycles * W * cfg.episodes_per_cycle) * 1e3

    flops = update_flops(tr)
    for _ in range(3):
        tr.update_step()
    blocks = []  # median of 5 blocks of 20 updates: this machine is noisy
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(20):
            tr.update_step()
        blocks.append((time.perf_counter() - t0) / 20)
    upd_s = float(np.median(blocks))
    upd_gflops = flops / upd_s / 1e9
    mm = matmul_gflops(args.threads)
    print(f"env={cfg.env} method={cfg.method} workers={W} threads={args.threads} "
          f"minibatch={cfg.batch_size * W} update_ms={upd_s * 1e3:.1f} update_gflop={flops / 1e9:.2f} "
          f"update_share_of_matmul={upd_gflops / mm:.2f}")
    print(f"bench: sim_ms_per_episode={sim_ms:.1f} train_ms_per_episode={train_ms:.1f} "
          f"ratio={train_ms / sim_ms:.2f} update_gflops={upd_gflops:.1f} matmul_gflops={mm:.1f}")
    return 0
