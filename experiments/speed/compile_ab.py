"""Side measurement (moves floats: not for the code path):
torch.compile of the four MLPs."""

import time
import torch
from common import args, warm_trainer

method, threads = args()


def make():
    return warm_trainer(method, threads)


eager, comp = make(), make()
t0 = time.perf_counter()
for net in (
    comp.agent.actor,
    comp.agent.critic,
    comp.agent.actor_targ,
    comp.agent.critic_targ,
):
    net.net = torch.compile(net.net, dynamic=False)
for _ in range(3):
    comp.update_step()
print("compile+first updates s", round(time.perf_counter() - t0, 1), flush=True)
for _ in range(3):
    eager.update_step()
res = {"eager": [], "compiled": []}
for rep in range(8):
    for name, tr in (("eager", eager), ("compiled", comp)):
        c = time.process_time()
        for _ in range(10):
            tr.update_step()
        res[name].append((time.process_time() - c) / 10 * 1e3)
import statistics as st

m = {k: st.median(v) for k, v in res.items()}
print(
    {k: round(v, 2) for k, v in m.items()},
    "ratio compiled/eager",
    round(m["compiled"] / m["eager"], 3),
)
