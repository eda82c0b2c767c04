"""A checkpoint.pt written the old way (numpy arrays pickled) and the new way (arrays as
tensors, `io.arrays_as_tensors`), alternating: wall and CPU time, file size, and whether
the new file loads back to the same state bit for bit.

    .venv/bin/python experiments/speed/checkpoint_ab.py RUN/checkpoint.pt [ROUNDS]

The files go to a temporary folder beside the checkpoint (the same disk), and are
written as the trainer writes them (`io.save_torch`: a temporary file, fsync, rename).
"""

import os
import sys
import tempfile
import time

import numpy as np
import torch

from acder_lite.io import arrays_as_tensors, load_torch, save_torch


def same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)
    if isinstance(a, torch.Tensor):
        return a.dtype == b.dtype and torch.equal(a, b)
    return a == b or (a != a and b != b)


def main() -> None:
    path = sys.argv[1]
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    state = load_torch(path)
    arrays = sum(
        v.nbytes for v in state["buffer"].values() if isinstance(v, np.ndarray)
    )
    print(f"{path}: replay buffer arrays {arrays / 1e6:.0f} MB")
    with tempfile.TemporaryDirectory(dir=os.path.dirname(os.path.abspath(path))) as d:
        for r in range(rounds):
            for kind, obj in (("old", state), ("new", arrays_as_tensors(state))):
                out = os.path.join(d, f"{kind}.pt")
                t, c = time.perf_counter(), time.process_time()
                save_torch(out, obj)
                wall, cpu = time.perf_counter() - t, time.process_time() - c
                size = os.path.getsize(out) / 1e6
                times = f"wall {wall:.2f} s, cpu {cpu:.2f} s"
                print(f"round {r} {kind}: {times}, {size:.0f} MB")
        t = time.perf_counter()
        back = load_torch(os.path.join(d, "new.pt"))
        print(
            f"new file loaded in {time.perf_counter() - t:.1f} s;",
            "the same state bit for bit" if same(state, back) else "DIFFERENT",
        )


if __name__ == "__main__":
    main()
