"""Side measurement (moves floats: not for the code path): how far the float32 update
step is from the floor its matrix multiplies set, and what one critic pass for both
losses buys, interleaved, on one thread.

`floor_ab.py [method] [threads] [reps]` (defaults her, 1, 12). Warm FetchPush trainers
(common.py: 4 workers, minibatch 1024, float32), `torch.set_num_threads(threads)`,
then blocks of 10 updates, the variants in turn, `reps` times: CPU time
(process_time) per update, medians, and each variant's ratio to eager.

The variants:
- `eager`: `Trainer.update_step` as it is (sampling and batch building included);
- `one-critic-pass`: `update_step` with `DDPG.update` replaced by one critic pass of
  2048 rows ([x, u] then [x, pi]) for both losses and one backward of
  loss_q + loss_pi. The critic's Linears are `RowsLinear`, whose backward takes the
  weight and bias gradients from the first 1024 rows only (the critic loss's) and the
  input gradient for all rows (the pi rows' reaches the actor). Its gradients are
  checked against the eager update's on one batch before the timing;
- `gemm-floor`: only the matrix multiplies of one update: every aten mm/addmm/bmm
  call the real `update_step` makes (recorded under a `TorchDispatchMode`: op, shapes,
  strides, so the same transposed and expanded layouts), replayed in order with
  `out=` on preallocated tensors. addmm keeps its bias (its broadcast copy is part of
  the call). Its FLOPs are checked against FlopCounterMode's count of the update;
- `gemm-nobias`: the same calls with every addmm made an mm (no bias copy): the bare
  GEMMs;
- `gemm-shared`: the `gemm-floor` calls in the update's own memory layout (recorded
  data_ptrs): a weight read by its forward and backward matmul, a layer's input read
  again for its weight gradient, memory the allocator handed out again, are one buffer
  as in the update, so the operands' cache traffic is the update's (`gemm-floor` gives
  every call its own operands and output: about 3x the memory);
- `batch-only`: `sample_batch`, `batch_tensors` and `rewards`, the part of
  `update_step` outside `DDPG.update`;
- `big-matmul`: the update's FLOPs as (1024x256)@(256x256) matmuls (the shape bench's
  `matmul_gflops` times), so its time is the update at that shape's rate, in CPU time
  and interleaved with the others. bench's own figure (`matmul_gflops`, wall time) is
  printed too, before and after the blocks.

After the blocks, each distinct matmul of the floor is timed alone (CPU time, rounds
of 50 calls, median; its operands stay in cache, unlike in the update): its ms an
update and its rate against the big matmul's.
"""

import statistics as st
import sys
import time
from collections import Counter

import torch
from torch import nn
from torch.utils._python_dispatch import TorchDispatchMode
from torch.utils.flop_counter import FlopCounterMode

from acder_lite.algo import ddpg as D
from acder_lite.cli.bench import matmul_gflops, update_flops
from common import args, warm_trainer

method, threads = args()
reps = int(sys.argv[3]) if len(sys.argv) > 3 else 12
torch.set_num_threads(threads)
aten = torch.ops.aten
MATMULS = {aten.mm.default, aten.addmm.default, aten.bmm.default}
BIG = (1024, 256, 256)  # bench's matmul_gflops shape: (m x k) @ (k x n)


# ----- the floor: every matmul of the real update, recorded and replayed
class RecordMatmuls(TorchDispatchMode):
    """Records each mm/addmm/bmm call in `calls`: (op, (shape, stride) of each tensor
    argument, its scalar keyword arguments: addmm's beta, alpha), and in `ptrs` the
    data_ptr of each argument and of its output (contiguous, as the op allocates it)."""

    def __init__(self):
        super().__init__()
        self.calls, self.ptrs = [], []

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        out = func(*args, **kwargs)
        if func in MATMULS:
            layout = tuple((tuple(a.shape), a.stride()) for a in args)
            assert all(a.dtype == torch.float32 for a in args), func
            assert out.is_contiguous(), func
            self.calls.append((func, layout, tuple(sorted(kwargs.items()))))
            self.ptrs.append(tuple(a.data_ptr() for a in args) + (out.data_ptr(),))
        return out


def mnk(func, layout):
    """(batch, m, k, n) of one call: out = (m x k) @ (k x n)."""
    a, b = layout[-2][0], layout[-1][0]
    if func is aten.bmm.default:
        return a[0], a[1], a[2], b[2]
    return 1, a[0], a[1], b[1]


def flops(func, layout):
    bt, m, k, n = mnk(func, layout)
    return 2 * bt * m * k * n


def describe(func, layout):
    """`addmm 1024x256 @ 256x256, N N +bias`: N row-major, T transposed, E expanded."""

    def tag(shape, stride):
        if 0 in stride:
            return "E"
        if stride[-1] == 1 and stride[-2] >= max(1, shape[-1]):
            return "N"
        return "T" if stride[-2] == 1 else "S"

    bt, m, k, n = mnk(func, layout)
    s = f"{func.overloadpacket.__name__:5s} {m}x{k} @ {k}x{n}"
    s += (f" b{bt}" if bt > 1 else "") + ", " + " ".join(tag(*t) for t in layout[-2:])
    return s + (" +bias" if func is aten.addmm.default else "")


def extent(shape, stride):
    """Elements from a tensor's first to its last, plus one."""
    return 1 + sum((d - 1) * s for d, s in zip(shape, stride))


def out_shape(func, layout):
    bt, m, _, n = mnk(func, layout)
    return (bt, m, n) if func is aten.bmm.default else (m, n)


def shared_memory(calls, ptrs):
    """A view for each operand and output of `calls`, laid out as the recorded ones
    were: address ranges that overlapped (a weight read by its forward and backward
    matmul, a layer's input read again for its weight gradient, memory the allocator
    handed out again) are one buffer, each tensor at its recorded offset in it (and
    alignment mod 64 bytes). Returns ([(args, out)] a call, MiB in all)."""
    spans = []  # (first byte, end, shape, stride) of every tensor
    for (func, layout, _), p in zip(calls, ptrs):
        for (shape, stride), ptr in zip(layout + ((out_shape(func, layout), None),), p):
            stride = stride or torch.empty(shape, device="meta").stride()
            spans.append((ptr, ptr + 4 * extent(shape, stride), shape, stride))
    merged = []  # [first byte, end] of each buffer
    for lo, hi, *_ in sorted(spans):
        if merged and lo < merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    bufs = []
    for lo, hi in merged:
        b = torch.randn((hi - lo) // 4 + 16)  # normal values: no denormals
        bufs.append((lo, hi, b, (lo - b.data_ptr()) % 64 // 4))
    views = iter(
        next(
            b.as_strided(shape, stride, off + (ptr - lo) // 4)
            for lo, hi, b, off in bufs
            if lo <= ptr < hi
        )
        for ptr, _, shape, stride in spans
    )
    out = [([next(views) for _ in layout], next(views)) for _, layout, _ in calls]
    return out, sum(hi - lo for lo, hi in merged) / 2**20


def replay_fn(calls, bias=True, ptrs=None):
    """One update's matmuls on preallocated tensors of the recorded layouts: each its
    own (normal values), or with `ptrs` in the recorded memory layout
    (`shared_memory`). `bias` False: addmm made an mm. Returns (run, MiB in all)."""
    if ptrs is None:

        def tensor(shape, stride):
            return torch.randn(extent(shape, stride)).as_strided(shape, stride)

        memory = [
            ([tensor(*t) for t in layout], torch.empty(out_shape(func, layout)))
            for func, layout, _ in calls
        ]
        mib = sum(
            4 * (sum(extent(*t) for t in layout) + o.numel())
            for (_, layout, _), (_, o) in zip(calls, memory)
        )
        mib /= 2**20
    else:
        memory, mib = shared_memory(calls, ptrs)
    steps = []
    for (func, _, kw), (xs, out) in zip(calls, memory):
        if func is aten.addmm.default and bias:
            steps.append((torch.addmm, xs, dict(kw, out=out)))
        elif func is aten.bmm.default:
            steps.append((torch.bmm, xs, dict(out=out)))
        else:  # mm, or addmm without its bias
            steps.append((torch.mm, xs[-2:], dict(out=out)))

    def run():
        for f, a, kw in steps:
            f(*a, **kw)

    return run, mib


# ----- one critic pass for both losses
class RowsLinear(torch.autograd.Function):
    """x @ W.T + b for all rows; backward: the input gradient of all rows, the weight
    and bias gradients from the first `n` rows only."""

    @staticmethod
    def forward(ctx, x, weight, bias, n):
        ctx.save_for_backward(x, weight)
        ctx.n = n
        return torch.addmm(bias, x, weight.t())

    @staticmethod
    def backward(ctx, dy):
        x, weight = ctx.saved_tensors
        n = ctx.n
        dx = dy.mm(weight) if ctx.needs_input_grad[0] else None
        return dx, dy[:n].t().mm(x[:n]), dy[:n].sum(0), None


def one_pass_grads(agent, batch, clip_return, weights=None):
    """Both losses of `DDPG.update` (float32) with one 2048-row critic pass, and one
    backward of their sum: the critic's gradients are loss_q's (rows [x, u]), the
    actor's loss_pi's (rows [x, pi]). Returns (loss_q, loss_pi, td)."""
    cfg, actor, critic = agent.cfg, agent.actor, agent.critic
    x, n = batch["x"], batch["x"].shape[0]
    with torch.no_grad():
        q_next = agent.critic_targ(batch["x2"], agent.actor_targ(batch["x2"]))
        y = (batch["r"] + cfg.gamma * q_next).clamp_(*clip_return)
    pi = actor(x)
    h = torch.cat(
        [
            torch.cat([x, batch["u"] / critic.max_u], dim=-1),
            torch.cat([x, pi / critic.max_u], dim=-1),
        ]
    )
    for m in critic.net:
        h = (
            RowsLinear.apply(h, m.weight, m.bias, n)
            if isinstance(m, nn.Linear)
            else m(h)
        )
    q_all = h.squeeze(-1)
    td = y - q_all[:n]
    sq = td.pow(2)
    loss_q = sq.mean() if weights is None else (weights * sq).mean()
    loss_pi = -q_all[n:].mean() + cfg.action_l2 * (pi / actor.max_u).pow(2).mean()
    agent.q_opt.zero_grad(set_to_none=True)
    agent.pi_opt.zero_grad(set_to_none=True)
    (loss_q + loss_pi).backward()
    return loss_q, loss_pi, td.detach()


def eager_grads(agent, batch, clip_return, weights=None):
    """`DDPG.update`'s two backward passes (one thread, float32), without the steps."""
    cfg = agent.cfg
    loss_q, td = D.compute_loss_q(
        agent.critic,
        agent.actor_targ,
        agent.critic_targ,
        batch,
        cfg.gamma,
        clip_return,
        weights,
    )
    agent.q_opt.zero_grad(set_to_none=True)
    loss_q.backward()
    loss_pi = D.compute_loss_pi(agent.actor, agent.critic_frozen, batch, cfg.action_l2)
    agent.pi_opt.zero_grad(set_to_none=True)
    loss_pi.backward()
    return loss_q, loss_pi, td.detach()


def one_pass_update(agent):
    def update(batch, clip_return, weights=None):
        loss_q, loss_pi, td = one_pass_grads(agent, batch, clip_return, weights)
        agent.q_opt.step()
        agent.pi_opt.step()
        return dict(critic_loss=loss_q.detach(), actor_loss=loss_pi.detach(), td=td)

    return update


def batch_of(tr):
    """What `update_step` hands `DDPG.update`: (batch tensors, PER weights or None)."""
    batch = tr.sample_batch()
    tb = tr.batch_tensors(batch)
    r, _ = tr.shaped_rewards(batch, tr.curiosity_step(batch, tb))
    tb["r"] = torch.from_numpy(r)
    w = batch["weights"]
    return tb, None if w is None else torch.from_numpy(w)


def params(agent):
    return list(agent.actor.parameters()) + list(agent.critic.parameters())


print(
    f"torch {torch.__version__}, {method}, threads {threads}, reps {reps}", flush=True
)
mm_before = matmul_gflops(threads)
eager = warm_trainer(method, threads)
onepass = warm_trainer(method, threads)
for tr in (eager, onepass):
    assert not tr.agent.cfg.split and tr.agent.cfg.update_dtype == "float32"

# the gradient check, on one batch, before either trainer is timed
a = onepass.agent
tb, w = batch_of(onepass)
lq_e, lp_e, td_e = (t.detach() for t in eager_grads(a, tb, onepass.clip_return, w))
g_e = [p.grad.clone() for p in params(a)]
lq_o, lp_o, td_o = (t.detach() for t in one_pass_grads(a, tb, onepass.clip_return, w))
g_o = [p.grad.clone() for p in params(a)]
diff = max(float((x - y).abs().max()) for x, y in zip(g_e, g_o))
close = all(torch.allclose(y, x, rtol=1e-5, atol=1e-6) for x, y in zip(g_e, g_o))
same = all(torch.equal(x, y) for x, y in zip(g_e, g_o))
print(
    f"one-critic-pass gradients against eager's, one batch, {len(g_e)} tensors: "
    f"allclose(rtol 1e-5, atol 1e-6) {close}, bit-equal {same}, max abs diff "
    f"{diff:.3g} (largest |grad| {max(float(x.abs().max()) for x in g_e):.3g}); "
    f"loss_q diff {float(lq_o - lq_e):.3g}, loss_pi diff {float(lp_o - lp_e):.3g}, "
    f"td max abs diff {float((td_o - td_e).abs().max()):.3g}",
    flush=True,
)
a.q_opt.zero_grad(set_to_none=True)
a.pi_opt.zero_grad(set_to_none=True)
onepass.agent.update = one_pass_update(onepass.agent)

# the floor: the real update's matmuls, and the FLOPs three ways
with RecordMatmuls() as rec:
    eager.update_step()
calls = rec.calls
floor_flops = sum(flops(f, lay) for f, lay, _ in calls)
real_flops = update_flops(eager)  # FlopCounterMode over one real update_step
gemm_floor, mib_floor = replay_fn(calls)
gemm_nobias, _ = replay_fn(calls, bias=False)
gemm_shared, mib_shared = replay_fn(calls, ptrs=rec.ptrs)
with FlopCounterMode(display=False) as fc:
    gemm_floor()
with FlopCounterMode(display=False) as fc1:
    onepass.update_step()
ops = Counter(f.overloadpacket.__name__ for f, *_ in calls)
print(
    f"matmul calls in one update: {len(calls)} "
    f"({', '.join(f'{k} {v}' for k, v in ops.items())})"
    f"; FLOPs: recorded shapes {floor_flops / 1e9:.4f} G, FlopCounterMode of the real "
    f"update {real_flops / 1e9:.4f} G, of the replay {fc.get_total_flops() / 1e9:.4f} "
    f"G: equal {floor_flops == real_flops == fc.get_total_flops()}; "
    f"one-critic-pass update {fc1.get_total_flops() / 1e9:.4f} G; operands and "
    f"outputs: gemm-floor {mib_floor:.1f} MiB, gemm-shared {mib_shared:.1f} MiB",
    flush=True,
)

k_big = round(floor_flops / (2 * BIG[0] * BIG[1] * BIG[2]))
big_a, big_b = torch.randn(BIG[0], BIG[1]), torch.randn(BIG[1], BIG[2])
big_out = torch.empty(BIG[0], BIG[2])


def big_matmul():
    for _ in range(k_big):
        torch.mm(big_a, big_b, out=big_out)


variants = {
    "eager": eager.update_step,
    "one-critic-pass": onepass.update_step,
    "gemm-floor": gemm_floor,
    "gemm-nobias": gemm_nobias,
    "gemm-shared": gemm_shared,
    "batch-only": lambda: batch_of(eager),
    "big-matmul": big_matmul,
}
block_flops = {k: floor_flops for k in ("gemm-floor", "gemm-nobias", "gemm-shared")}
block_flops["big-matmul"] = k_big * 2 * BIG[0] * BIG[1] * BIG[2]
for f in variants.values():  # warm: allocator, MKL's buffers
    for _ in range(3):
        f()
cpu = {n: [] for n in variants}
for _ in range(reps):
    for name, f in variants.items():
        c = time.process_time()
        for _ in range(10):
            f()
        cpu[name].append((time.process_time() - c) / 10 * 1e3)
mm_after = matmul_gflops(threads)
med = {n: st.median(v) for n, v in cpu.items()}
big_rate = block_flops["big-matmul"] / med["big-matmul"] / 1e6
print(
    f"bench's matmul_gflops (wall, 1 s, {BIG[0]}x{BIG[1]} @ {BIG[1]}x{BIG[2]}): "
    f"before {mm_before:.1f}, after {mm_after:.1f}; big-matmul in the blocks (CPU): "
    f"{big_rate:.1f} GFLOP/s, {k_big} matmuls an update",
    flush=True,
)
for name in variants:
    ratio = med[name] / med["eager"]
    line = f"{name:15s} ms/update CPU {med[name]:6.2f}   / eager {ratio:.3f}"
    if name in ("eager", "one-critic-pass"):
        fl = real_flops if name == "eager" else fc1.get_total_flops()
        line += f"   GFLOP/s {fl / med[name] / 1e6:5.1f}"
        line += f" = {fl / med[name] / 1e6 / big_rate:.3f} of big-matmul"
    elif name in block_flops:
        r = block_flops[name] / med[name] / 1e6
        line += f"   GFLOP/s {r:5.1f} = {r / big_rate:.3f} of big-matmul"
    print(f"{line}   CPU blocks {' '.join(f'{x:.1f}' for x in cpu[name])}", flush=True)

# each distinct matmul of the floor alone
groups = Counter((f, lay, kw) for f, lay, kw in calls)
fns = {g: replay_fn([g])[0] for g in groups}
alone = {g: [] for g in groups}
for _ in range(5):
    for g, f in fns.items():
        c = time.process_time()
        for _ in range(50):
            f()
        alone[g].append((time.process_time() - c) / 50 * 1e3)
print(
    "each matmul alone (CPU, median of 5 rounds of 50): calls an update, ms an update, "
    "GFLOP/s, share of big-matmul",
    flush=True,
)
total = 0.0
for g, n in sorted(groups.items(), key=lambda gn: -st.median(alone[gn[0]]) * gn[1]):
    t = st.median(alone[g])
    total += n * t
    r = flops(g[0], g[1]) / t / 1e6
    print(
        f"  {describe(g[0], g[1]):38s} x{n:2d} {n * t:6.2f} ms {r:6.1f} "
        f"{r / big_rate:.3f}",
        flush=True,
    )
print(f"  sum {total:.2f} ms (gemm-floor in the blocks: {med['gemm-floor']:.2f} ms)")
