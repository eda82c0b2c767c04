"""Which precision the gradient step runs in (`--update-dtype auto` decides by timing
the update on this machine), on which device (`--device auto`: CUDA where there is
one), and how many CPUs a run or a sweep may use.

bfloat16 can help only where the CPU multiplies bfloat16 natively (AVX512-BF16 or AMX),
and even there not always: on some such CPUs the update ran 2-3x faster, on one it ran
slower; where it is emulated, many times slower (the machines and numbers:
experiments/speed/README.md, experiments/bf16/). So the flags are not a measurement:
`auto` times the update's own shapes in both precisions (`time_update`, about a
second) and takes bfloat16 only where it is at least `BF16_MIN_SPEEDUP` times faster;
without native bfloat16 it takes float32 without timing. `auto` never picks a precision
slower than float32 on the machine it runs on; asking for bfloat16 anyway works, with
one warning line where it is emulated.
"""

from __future__ import annotations

import os
import time


def native_bf16() -> tuple[bool, str]:
    """(whether the CPU has native bfloat16 matmul, what was found),
    from torch and /proc/cpuinfo."""
    import torch

    found = []
    for name, probe in (
        ("AVX512-BF16", "_is_avx512_bf16_supported"),
        ("AMX", "_is_amx_tile_supported"),
    ):
        # trap: private in torch, so absent in some versions
        fn = getattr(torch.cpu, probe, None)
        try:
            if fn is not None and fn():
                found.append(name)
        except RuntimeError:
            pass
    if not found:
        try:
            flags = open("/proc/cpuinfo").read()
        except OSError:
            flags = ""
        found = [
            name
            for name, flag in (("AVX512-BF16", "avx512_bf16"), ("AMX", "amx_bf16"))
            if flag in flags
        ]
    if found:
        return True, "the CPU has " + " and ".join(found)
    return False, "the CPU has neither AVX512-BF16 nor AMX (bfloat16 would be emulated)"


BF16_MIN_SPEEDUP = 1.2
"""`auto` takes bfloat16 only where the update measured at least this many times faster
in it than in float32. A margin, not 1.0: two timings of the same machine differ by
several percent (more while other runs hold the cores), and a choice that flipped
between two runs of one task would mix two computations in it."""

MEASURE_SECONDS = 1.0
"""About how long `time_update` times the two precisions, both together."""

UPDATE_IN_DIM, UPDATE_ACT_DIM = 32, 4
"""The input width of the timed networks (a Fetch task's observation and goal: 13 on
Reach, 28 on Push; `resolve` runs before any env is made) and the action's. The hidden
layers, hidden x hidden each, are most of the update's FLOPs."""

_MEASURED: dict = {}
"""(timer, rows, hidden, layers, threads) -> (float32 s, bfloat16 s): each shape is
timed once a process, so every `resolve` of one run (and of one sweep's task) reads the
same two timings and makes the same choice."""


def time_update(
    rows: int, hidden: int, layers: int, threads: int, seconds: float = MEASURE_SECONDS
) -> tuple[float, float]:
    """(float32 s, bfloat16 s): the median time of one update-shaped step in each
    precision, on `threads` torch threads (put back afterwards).

    The step is the update's forward and backward passes at its own shapes: actor and
    critic MLPs of `layers` hidden layers of `hidden` units (ReLU) on `rows` rows (the
    minibatch, batch_size x workers): the target's forward passes (no gradient), the
    critic's loss and the actor's loss through the critic, each backward; bfloat16 under
    CPU autocast, as `DDPG.update` runs it. Blocks of steps alternate between the two
    precisions (the first of each pair alternating too), so a busy machine slows both
    alike; the median of each is kept. Its tensors come from a generator of its own:
    the global torch generator, which seeds a run, is not drawn from."""
    import statistics

    import torch
    import torch.nn.functional as F

    gen = torch.Generator().manual_seed(0)

    def mlp(sizes):
        return [
            (
                (torch.randn(o, i, generator=gen) / i**0.5).requires_grad_(),
                torch.zeros(o, requires_grad=True),
            )
            for i, o in zip(sizes[:-1], sizes[1:])
        ]

    def forward(net, x):
        for k, (w, b) in enumerate(net):
            x = F.linear(x, w, b)
            x = x.relu() if k < len(net) - 1 else x
        return x.float()

    actor = mlp([UPDATE_IN_DIM] + [hidden] * layers + [UPDATE_ACT_DIM])
    critic = mlp([UPDATE_IN_DIM + UPDATE_ACT_DIM] + [hidden] * layers + [1])
    params = [t for net in (actor, critic) for layer in net for t in layer]
    x = torch.randn(rows, UPDATE_IN_DIM, generator=gen)
    u = torch.randn(rows, UPDATE_ACT_DIM, generator=gen)

    def step(bf16: bool) -> None:
        for t in params:
            t.grad = None
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
            with torch.no_grad():
                y = forward(critic, torch.cat([x, forward(actor, x).tanh()], 1))
            q_loss = (forward(critic, torch.cat([x, u], 1)) - y).pow(2).mean()
        q_loss.backward()
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
            pi = forward(actor, x).tanh()
            pi_loss = -forward(critic, torch.cat([x, pi], 1)).mean()
        pi_loss.backward()

    def block(bf16: bool, n: int) -> float:
        t = time.perf_counter()
        for _ in range(n):
            step(bf16)
        return (time.perf_counter() - t) / n

    saved = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        for bf16 in (False, True):  # the first call of a shape builds its kernels
            step(bf16)
        one = max(block(bf16, 1) for bf16 in (False, True))
        rounds = max(3, min(7, int(seconds / (2 * one)))) | 1  # odd: a true median
        n = max(1, round(seconds / (2 * rounds * one)))
        times = {False: [], True: []}
        for r in range(rounds):
            for bf16 in (r % 2 == 1, r % 2 == 0):
                times[bf16].append(block(bf16, n))
    finally:
        torch.set_num_threads(saved)
    return statistics.median(times[False]), statistics.median(times[True])


def choose_update_dtype(
    requested: str,
    device: str = "cpu",
    *,
    rows: int = 1024,
    hidden: int = 256,
    layers: int = 3,
    threads: int = 1,
    timer=None,
) -> tuple[str, str]:
    """('float32' or 'bfloat16', why) for `Config.update_dtype` = requested ('auto' or a
    dtype), on the resolved `device`, for an update of `rows` x `hidden` x `layers` on
    `threads` torch threads (`Config.resolve` passes the run's; the defaults are a
    default run's: 256 x 4 workers, 256 x 3, two threads split into one each).

    On a CPU, `auto` times the update in both precisions (`timer`, default
    `time_update`, each shape once a process) and takes bfloat16 only at
    `BF16_MIN_SPEEDUP` or more; on a CPU without native bfloat16 it takes float32
    without timing. On CUDA `auto` keeps float32: bfloat16 there is unmeasured here.
    `why` is one line with the two timings and the choice."""
    if requested != "auto":
        return requested, "asked for"
    if device != "cpu":
        return "float32", f"auto: the update runs on {device} (bfloat16: CPUs only)"
    native, found = native_bf16()
    if not native:
        return "float32", f"auto: {found}: float32, not timed"
    timer = time_update if timer is None else timer
    key = (timer, rows, hidden, layers, threads)
    if key not in _MEASURED:
        _MEASURED[key] = timer(rows, hidden, layers, threads)
    f32, bf16 = _MEASURED[key]
    speedup = f32 / bf16
    dtype = "bfloat16" if speedup >= BF16_MIN_SPEEDUP else "float32"
    return dtype, (
        f"auto: {found}; the update ({rows} rows, {layers}x{hidden} hidden, "
        f"{threads} {'thread' if threads == 1 else 'threads'}) measured float32 "
        f"{f32 * 1e3:.2f} ms, bfloat16 {bf16 * 1e3:.2f} ms: {speedup:.2f}x, "
        f"{'at least' if dtype == 'bfloat16' else 'under'} {BF16_MIN_SPEEDUP}x: {dtype}"
    )


def bf16_cost(n: int = 1024, d: int = 256, reps: int = 20) -> float:
    """How many times slower a (n x d) @ (d x d) matmul is in bfloat16 than in float32,
    measured now (interleaved, the minimum of `reps` each: a few tenths of a second)."""
    import torch

    a32, b32 = torch.randn(n, d), torch.randn(d, d)
    a16, b16 = a32.bfloat16(), b32.bfloat16()
    best = {"float32": float("inf"), "bfloat16": float("inf")}
    for _ in range(reps):
        for key, (a, b) in (("float32", (a32, b32)), ("bfloat16", (a16, b16))):
            t = time.perf_counter()
            a @ b
            best[key] = min(best[key], time.perf_counter() - t)
    return best["bfloat16"] / best["float32"]


def warning_if_slow(update_dtype: str) -> str | None:
    """One warning line when bfloat16 runs on a CPU without native bfloat16,
    with its measured cost."""
    if update_dtype != "bfloat16":
        return None
    native, why = native_bf16()
    if native:
        return None
    return (
        f"warning: update_dtype='bfloat16' on a CPU without native bfloat16 ({why}): "
        f"a matmul measured {bf16_cost():.1f}x slower than float32 here; "
        "--update-dtype auto picks float32"
    )


def choose_device(requested: str) -> tuple[str, str]:
    """('cpu' or 'cuda', why) for `Config.device` = requested ('auto', 'cpu' or 'cuda').

    Raises ValueError (one line: the field, what is allowed) for 'cuda' without CUDA: a
    run that silently fell back to the CPU would take hours where its reader planned
    minutes.
    """
    import torch

    has_cuda = torch.cuda.is_available()
    if requested == "cpu":
        return "cpu", "asked for"
    if requested == "cuda":
        if not has_cuda:
            raise ValueError(
                f"device='cuda' is not allowed: this torch "
                f"({torch.__version__}) sees no CUDA device; "
                "allowed: 'auto' or 'cpu'"
            )
        return "cuda", "asked for"
    if has_cuda:
        return "cuda", f"auto: CUDA is available ({torch.cuda.get_device_name(0)})"
    return "cpu", f"auto: no CUDA device (torch {torch.__version__})"


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity mask where the OS has one)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def threads_warning(threads: int, cpus: int | None = None) -> str | None:
    """One line for a run asking for more threads than it has CPUs, else None. Trap:
    torch and the env-stepping threads then take turns on the cores, and every
    barrier of a matmul waits for a descheduled thread: slower than `cpus` threads."""
    cpus = usable_cpus() if cpus is None else cpus
    if threads <= cpus:
        return None
    return (
        f"warning: threads={threads} is more than the {cpus} CPUs this process may "
        f"use; the run will be slower than with --threads {cpus}"
    )
