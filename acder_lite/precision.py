"""Which precision the gradient step runs in (`--update-dtype auto` decides from the
CPU), on which device (`--device auto`: CUDA where there is one), and how many CPUs
a run or a sweep may use.

bfloat16 helps only where the CPU multiplies bfloat16 natively (AVX512-BF16 or AMX):
there the update step measured 2-3x faster. Without those instructions PyTorch emulates
it, and this machine measured it 17x *slower* (experiments/bf16/). `auto` never picks a
precision slower than float32 on the machine it runs on; asking for bfloat16 anyway
works, with one warning line.
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


def choose_update_dtype(requested: str, device: str = "cpu") -> tuple[str, str]:
    """('float32' or 'bfloat16', why) for `Config.update_dtype` = requested ('auto' or a
    dtype), on the resolved `device`. On CUDA `auto` keeps float32: the CPU probe says
    nothing about a GPU, and bfloat16 there is unmeasured here."""
    if requested != "auto":
        return requested, "asked for"
    if device != "cpu":
        return "float32", f"auto: the update runs on {device} (bfloat16: CPUs only)"
    native, why = native_bf16()
    return ("bfloat16" if native else "float32"), f"auto: {why}"


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
