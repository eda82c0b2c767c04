"""Side measurement for experiments/speed:
the update step taken apart, CPU time per phase."""

import time
import torch
from acder_lite.algo.ddpg import compute_loss_q, compute_loss_pi
from common import args, warm_trainer

tr = warm_trainer(*args())
cfg = tr.cfg
for _ in range(3):
    tr.update_step()
N = 30
acc = {}


def t(name, f):
    c = time.process_time()
    r = f()
    acc[name] = acc.get(name, 0) + time.process_time() - c
    return r


ag = tr.agent
for _ in range(N):
    batch = t("sample_batch", tr.sample_batch)
    tb = t("batch_tensors", lambda: tr.batch_tensors(batch))
    r_int = t("curiosity step", lambda: tr.curiosity_step(batch, tb))
    r, _ = t("shaped rewards", lambda: tr.shaped_rewards(batch, r_int))
    tb["r"] = torch.from_numpy(r)
    with torch.no_grad():
        t("target fwd", lambda: ag.critic_targ(tb["x2"], ag.actor_targ(tb["x2"])))
    ql, td = t(
        "q loss fwd (incl target)",
        lambda: compute_loss_q(
            ag.critic, ag.actor_targ, ag.critic_targ, tb, cfg.gamma, tr.clip_return
        ),
    )
    ag.q_opt.zero_grad(set_to_none=True)
    t("q backward", ql.backward)
    ag.critic.requires_grad_(False)
    pl = t(
        "pi loss fwd", lambda: compute_loss_pi(ag.actor, ag.critic, tb, cfg.action_l2)
    )
    ag.pi_opt.zero_grad(set_to_none=True)
    t("pi backward", pl.backward)
    ag.critic.requires_grad_(True)
    t("adam q", ag.q_opt.step)
    t("adam pi", ag.pi_opt.step)
    t("float()", lambda: (float(ql.detach()), float(pl.detach())))
    c = time.process_time()
    tr.update_step()
    acc["FULL update_step"] = acc.get("FULL update_step", 0) + time.process_time() - c
tot = sum(v for k, v in acc.items() if k not in ("target fwd", "FULL update_step"))
for k, v in acc.items():
    print(f"{k:28s} {v / N * 1e3:7.2f} ms")
print(f"{'sum of phases':28s} {tot / N * 1e3:7.2f} ms")
from acder_lite.cli.bench import update_flops

print("gflop", update_flops(tr) / 1e9)
