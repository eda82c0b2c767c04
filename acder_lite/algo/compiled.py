"""The opt-in compiled update (`Config.compile_update`): the two DDPG losses under
torch.compile (inductor), each one graph for its forward and, through AOTAutograd, one
for its backward.

Imported only when the setting is on: the default update never reaches torch.compile.
Inductor keeps every matmul in MKL (`addmm`/`mm`, as eager) and fuses what lies between
them (bias and ReLU, the ReLU masks into the backward's bias sums, the losses'
reductions), so the floats move by rounding only (the fused ops sum in another order).

Trap: inductor's default (min-cut) partitioner makes the actor's loss save ReLU's masks
as bool tensors (through the frozen critic the backward needs no activation but the
mask), and inductor's vectorised bool store can be far slower than eager's `x <= 0` (on
an AVX2 CPU it made the whole compiled update slower than eager: experiments/speed/,
`compile_ab.py` and its README). AOTAutograd's default partitioner saves the ReLU
outputs instead and recomputes each mask inside the fused backward kernel.
"""

from __future__ import annotations

import torch
from torch._functorch.partitioners import default_partition
from torch._inductor.custom_graph_pass import CustomPartitionerFn, get_hash_for_files


class DefaultPartition(CustomPartitionerFn):
    """AOTAutograd's default partitioner, as inductor's custom one: the forward saves
    what it computed that the backward reads (no bool masks, above)."""

    def __call__(self, gm, joint_inputs, **kwargs):
        kwargs.pop("compiler", None)  # min-cut's argument; default_partition has none
        return default_partition(gm, joint_inputs, **kwargs)

    def uuid(self):  # inductor's cache key: this file
        return get_hash_for_files((__file__,))


def compile_loss(fn):
    """`fn` (`ddpg.compute_loss_q` or `compute_loss_pi`) compiled: static shapes (the
    minibatch never changes), one graph or an error (fullgraph), the default
    partitioner. The first call compiles: about 25 s of wall time for the two losses
    here, a few seconds from inductor's on-disk cache."""
    return torch.compile(
        fn,
        dynamic=False,
        fullgraph=True,
        options={"custom_partitioner_fn": DefaultPartition()},
    )
