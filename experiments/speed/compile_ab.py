"""Side measurement (moves floats: not for the code path): torch.compile of the update
step against eager, interleaved, on one thread.

`compile_ab.py [method] [threads] [reps] [variant ...]` (defaults her, 1, 8, all of
them). One warm FetchPush
trainer per variant (common.py: 4 workers, minibatch 1024, float32), each compiled in
memory (nothing on disk changes), then blocks of 10 `update_step`s, the variants in
turn, `reps` times: CPU time (process_time) and wall time per update, medians, and
each variant's ratio to eager. Compilation is timed cold (the inductor caches are off,
so a second run compiles again rather than loading what the first one wrote).

The variants:
- `mlp`: the networks' `nn.Sequential`s compiled (actor, critic, their targets and the
  critic's frozen view), inductor defaults (the first measurement, 1.41x slower);
- `losses`: `compute_loss_q` and `compute_loss_pi` compiled (forward, and through
  AOTAutograd their backward), inductor defaults;
- `losses-dp`: the same with AOTAutograd's default partitioner instead of the min-cut
  one. Why: through the frozen critic the actor's backward needs only ReLU's masks, so
  min-cut saves them as bool tensors, and inductor's vectorised bool store measured
  17x slower than eager's `x <= 0` on this AVX2 EPYC (1024x256: 5.9 ms against
  0.34 ms; 6.5 ms a ReLU in the profile). The default partitioner saves the ReLU
  outputs and recomputes the mask inside the fused backward kernel;
- `losses-dp-cppwrapper`: the same with inductor's C++ wrapper (the graph's calls
  made from C++ instead of Python).

Not a variant: `max_autotune` generated the very same code as `losses-dp` (MKL's
`addmm`/`mm` for every matmul): inductor's C++ GEMM templates need the weights as
constants (`use_cpp_gemm_template`'s `require_constant_mat2`, i.e. frozen inference
graphs), never so in training.
"""

import os
import statistics as st
import sys
import time

os.environ["TORCHINDUCTOR_FORCE_DISABLE_CACHES"] = "1"  # cold compiles, every run

import torch  # noqa: E402
from torch._functorch.partitioners import default_partition  # noqa: E402
from torch._inductor.custom_graph_pass import CustomPartitionerFn  # noqa: E402

from acder_lite.algo import ddpg as D  # noqa: E402
from common import args, warm_trainer  # noqa: E402

method, threads = args()
reps = int(sys.argv[3]) if len(sys.argv) > 3 else 8


class DefaultPartition(CustomPartitionerFn):
    """AOTAutograd's default partitioner (save what the forward computed)."""

    def __call__(self, gm, joint_inputs, **kw):
        kw.pop("compiler", None)
        return default_partition(gm, joint_inputs, **kw)

    def uuid(self):
        return "default_partition"


def compiled_losses(agent, options):
    """`agent.update` with both loss functions compiled (the module's globals swapped
    for the call: one thread, so no other update sees them)."""
    lq = torch.compile(D.compute_loss_q, dynamic=False, options=options)
    lp = torch.compile(D.compute_loss_pi, dynamic=False, options=options)

    def update(batch, clip_return, weights=None):
        q, p = D.compute_loss_q, D.compute_loss_pi
        D.compute_loss_q, D.compute_loss_pi = lq, lp
        try:
            return D.DDPG.update(agent, batch, clip_return, weights)
        finally:
            D.compute_loss_q, D.compute_loss_pi = q, p

    agent.update = update


def make(name):
    tr = warm_trainer(method, threads)
    a = tr.agent
    if name == "mlp":
        for net in (a.actor, a.critic, a.actor_targ, a.critic_targ, a.critic_frozen):
            net.net = torch.compile(net.net, dynamic=False)
    elif name == "losses":
        compiled_losses(a, None)
    elif name == "losses-dp":
        compiled_losses(a, {"custom_partitioner_fn": DefaultPartition()})
    elif name == "losses-dp-cppwrapper":
        compiled_losses(
            a, {"custom_partitioner_fn": DefaultPartition(), "cpp_wrapper": True}
        )
    elif name != "eager":
        sys.exit(f"compile_ab.py: unknown variant {name!r}")
    return tr


names = ["eager"] + (
    sys.argv[4:] or ["mlp", "losses", "losses-dp", "losses-dp-cppwrapper"]
)
trainers = {}
print(f"torch {torch.__version__}, {method}, threads {threads}", flush=True)
for name in names:
    tr = make(name)
    w, c = time.perf_counter(), time.process_time()
    for _ in range(3):
        tr.update_step()
    print(
        f"{name:19s} compile + first 3 updates: wall {time.perf_counter() - w:.1f} s,"
        f" this process's CPU {time.process_time() - c:.1f} s",
        flush=True,
    )
    trainers[name] = tr
cpu = {n: [] for n in names}
wall = {n: [] for n in names}
for _ in range(reps):
    for name, tr in trainers.items():
        w, c = time.perf_counter(), time.process_time()
        for _ in range(10):
            tr.update_step()
        cpu[name].append((time.process_time() - c) / 10 * 1e3)
        wall[name].append((time.perf_counter() - w) / 10 * 1e3)
for name in names:
    mc, mw = st.median(cpu[name]), st.median(wall[name])
    print(
        f"{name:19s} ms/update CPU {mc:6.2f} wall {mw:6.2f}   / eager: CPU "
        f"{mc / st.median(cpu['eager']):.3f} wall {mw / st.median(wall['eager']):.3f}"
        f"   CPU blocks {' '.join(f'{x:.1f}' for x in cpu[name])}",
        flush=True,
    )
