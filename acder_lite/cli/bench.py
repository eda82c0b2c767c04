"""`python -m acder_lite bench`: what an episode costs, simulation against training.

All figures are measured in the same run (this machine is noisy): random-action
simulation per episode, full training per episode (collection + 40 updates per cycle +
target update, after a warm-up cycle), the update step's achieved GFLOP/s (FLOPs counted
by torch's FlopCounterMode) and the machine's matmul GFLOP/s at the update's layer
shape, in the update's precision, on the same threads. `--update-dtype both` also times
the update step and whole training cycles in float32 and bfloat16 (interleaved, so both
see the same machine) and prints the two ratios: the update's alone, and the end-to-end
one per training episode that decides how long a run takes. The line before the last
says what `--update-dtype auto` picks for this update here, and why (its two timings).

The last line also gives the limit the hardware sets and how close training comes to it:
`limit_ms_per_episode` = simulation per episode (the W envs stepped in parallel on the
given threads, as training steps them) + the update FLOPs of one episode
(updates_per_cycle / (W x episodes_per_cycle) updates) at the measured matmul rate;
`share_of_limit` = limit / train (1 is the limit itself; 0.8 is training at 1.25x it).
`grid_cpu_ms_per_episode` is what one training episode costs a sweep in CPU time (all
threads' time, process_time), the protocol's end-of-epoch evaluation included: the
figure that decides a grid's core-hours. An update faster than its own reference matmul
(`update_share_of_matmul` above 1) means the matmul was timed on a busy machine: one
warning line on stderr says the limit is not to be trusted.

`--compile-update` times the update with its losses under torch.compile
(`Config.compile_update`); they compile in the warm-up cycle, which is not timed.

`--device cuda` (or auto on a machine with CUDA) times training with the networks on the
GPU; the matmul rate is the GPU's then, and each timed block ends in a synchronisation.
"""

from __future__ import annotations

import sys
import time

import numpy as np
import torch


MAX_CYCLES = 1000
"""The most timed cycles a bench takes: 1000 are 20 of Push's epochs (8000 training
episodes, hours here), long past where the time per episode has settled. Trap: a huge
--cycles ran for ever."""


def sync(device) -> None:
    """Wait for the device's queued work (CUDA is asynchronous; the CPU has none)."""
    if torch.device(device).type == "cuda":
        torch.cuda.synchronize(device)


def matmul_gflops(
    threads: int,
    m: int = 1024,
    k: int = 256,
    n: int = 256,
    seconds: float = 1.0,
    device="cpu",
    dtype: str = "float32",
) -> float:
    """GFLOP/s of (m x k) @ (k x n) in `dtype`, the shape of a hidden layer on one
    minibatch.

    Trap: a bfloat16 update is held to the bfloat16 rate (on a CPU with AMX it is
    several times float32's); at float32's, its share of the limit reads above 1."""
    torch.set_num_threads(threads)
    kw = dict(device=device, dtype=getattr(torch, dtype))
    a, b = torch.randn(m, k, **kw), torch.randn(k, n, **kw)
    out = torch.empty(m, n, **kw)
    for _ in range(20):
        torch.mm(a, b, out=out)
    sync(device)
    reps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        for _ in range(50):
            torch.mm(a, b, out=out)
        sync(device)
        reps += 50
    return 2 * m * k * n * reps / (time.perf_counter() - t0) / 1e9


def update_flops(trainer) -> float:
    """FLOPs of one update step, counted with both losses in this thread.

    Trap: FlopCounterMode sees only the thread that entered it; with `split_update`
    the actor's loss runs in a second one and would go uncounted. Compiled losses
    (`compile_update`) are counted in their eager form, the same matmuls: under the
    counter's dispatch mode torch.compile would compile them again."""
    from torch.utils.flop_counter import FlopCounterMode

    from acder_lite.algo.ddpg import compute_loss_pi, compute_loss_q

    agent = trainer.agent
    saved = agent.actor_thread, agent.loss_q, agent.loss_pi
    agent.actor_thread, agent.loss_q, agent.loss_pi = (
        None,
        compute_loss_q,
        compute_loss_pi,
    )
    try:
        with FlopCounterMode(display=False) as fc:
            trainer.update_step()
    finally:
        agent.actor_thread, agent.loss_q, agent.loss_pi = saved
    return float(fc.get_total_flops())


def run_bench(args) -> int:
    from acder_lite.config import Config
    from acder_lite.train.rollout import run_episodes
    from acder_lite.train.trainer import Trainer

    from acder_lite.config import ConfigError

    if not 1 <= args.cycles <= MAX_CYCLES:  # before the Config: bench's own option
        raise ConfigError(
            f"cycles={args.cycles} is not allowed: an integer in [1, {MAX_CYCLES}] "
            "(each a training cycle: its W x 2 episodes and 40 updates)"
        )
    both = args.update_dtype == "both"
    cfg = Config(
        env=args.env,
        method=args.method,
        workers=args.workers,
        threads=args.threads,
        seed=0,
        update_dtype="float32" if both else args.update_dtype,
        device=getattr(args, "device", "auto"),
        compile_update=getattr(args, "compile_update", False),
    )
    tr = Trainer(cfg)
    cfg = (
        tr.cfg
    )  # the resolved copy the trainer reads: its update_dtype is switched below
    dev = tr.device
    W, T = cfg.workers, tr.T
    rng = np.random.default_rng(0)

    def rand_act(o, g):
        return rng.uniform(-1, 1, (o.shape[0], tr.dims["u"])).astype(np.float32)

    # simulation alone (random actions, the same stepping code and threads as training)
    run_episodes(tr.envs, rand_act, T, pool=tr.pool)
    t0 = time.perf_counter()
    n_sim = 0
    while time.perf_counter() - t0 < 2.0:
        run_episodes(tr.envs, rand_act, T, pool=tr.pool)
        n_sim += W
    sim_ms = (time.perf_counter() - t0) / n_sim * 1e3

    dtypes = ("float32", "bfloat16") if both else (cfg.update_dtype,)
    tr.train_cycle()  # warm-up: fills the buffer, allocators, thread pools
    cycle_s = {dt: 0.0 for dt in dtypes}
    cycle_cpu = {dt: 0.0 for dt in dtypes}
    for _ in range(args.cycles):
        # whole cycles, alternating the precision, so both see the same machine
        for dt in dtypes:
            cfg.update_dtype = dt
            t0, c0 = time.perf_counter(), time.process_time()
            tr.train_cycle()
            sync(dev)
            cycle_s[dt] += time.perf_counter() - t0
            cycle_cpu[dt] += time.process_time() - c0
    per_cycle = W * cfg.episodes_per_cycle
    train = {dt: s / (args.cycles * per_cycle) * 1e3 for dt, s in cycle_s.items()}
    train_ms = train[dtypes[0]]
    cfg.update_dtype = dtypes[0]
    c0 = time.process_time()
    # one end-of-epoch evaluation, shared by the epoch's training episodes
    tr.evaluate()
    eval_cpu_ms = (time.process_time() - c0) * 1e3 / (cfg.cycles * per_cycle)
    grid_cpu_ms = cycle_cpu[dtypes[0]] / (args.cycles * per_cycle) * 1e3 + eval_cpu_ms

    flops = update_flops(tr)
    # median of 5 blocks of 20 updates: this machine is noisy
    blocks = {dt: [] for dt in dtypes}
    for dt in dtypes:
        cfg.update_dtype = dt
        for _ in range(3):
            tr.update_step()
    for _ in range(5):
        for dt in dtypes:  # interleaved, so both see the same machine
            cfg.update_dtype = dt
            sync(dev)
            t0 = time.perf_counter()
            for _ in range(20):
                tr.update_step()
            sync(dev)
            blocks[dt].append((time.perf_counter() - t0) / 20)
    cfg.update_dtype = dtypes[0]
    upd = {dt: float(np.median(b)) for dt, b in blocks.items()}
    upd_s = upd[dtypes[0]]
    upd_gflops = flops / upd_s / 1e9
    mm = matmul_gflops(args.threads, device=dev, dtype=dtypes[0])
    updates_per_episode = cfg.updates_per_cycle / per_cycle
    limit_ms = sim_ms + updates_per_episode * flops / (mm * 1e9) * 1e3
    print(
        f"env={cfg.env} method={cfg.method} workers={W} threads={args.threads} "
        f"device={dev} "
        f"minibatch={cfg.batch_size * W} update_dtype={dtypes[0]} "
        f"compile_update={int(cfg.compile_update)} "
        f"update_ms={upd_s * 1e3:.1f} "
        f"update_gflop={flops / 1e9:.2f} update_share_of_matmul={upd_gflops / mm:.2f}"
    )
    if both:
        print(
            f"update_ms float32={upd['float32'] * 1e3:.1f} "
            f"bfloat16={upd['bfloat16'] * 1e3:.1f} "
            f"speedup={upd['float32'] / upd['bfloat16']:.2f}"
        )
        print(
            f"train_ms_per_episode float32={train['float32']:.1f} "
            f"bfloat16={train['bfloat16']:.1f} "
            f"speedup={train['float32'] / train['bfloat16']:.2f} "
            "(the bench line below is float32's)"
        )
    # what `--update-dtype auto` picks for this update here (the timing `resolve` made
    # if auto was asked for: each shape is timed once a process)
    from acder_lite.precision import choose_update_dtype

    auto, why = choose_update_dtype(
        "auto",
        cfg.device,
        rows=cfg.batch_size * W,
        hidden=cfg.hidden,
        layers=cfg.layers,
        threads=cfg.torch_threads,
    )
    print(f"auto picks update_dtype={auto} here: {why.removeprefix('auto: ')}")
    print(
        f"bench: sim_ms_per_episode={sim_ms:.1f} train_ms_per_episode={train_ms:.1f} "
        f"ratio={train_ms / sim_ms:.2f} update_gflops={upd_gflops:.1f} "
        f"matmul_gflops={mm:.1f} "
        f"limit_ms_per_episode={limit_ms:.1f} share_of_limit={limit_ms / train_ms:.2f} "
        f"grid_cpu_ms_per_episode={grid_cpu_ms:.1f}"
    )
    if upd_gflops > mm:  # no update outruns its own big matmul on an idle machine
        print(
            f"bench: warning: update_share_of_matmul={upd_gflops / mm:.2f} is above 1: "
            "the reference matmul was timed while something else held the cores, so "
            "limit_ms_per_episode and share_of_limit are not to be trusted; run bench "
            "again on an idle machine",
            file=sys.stderr,
        )
    return 0
