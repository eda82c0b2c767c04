"""Side measurement for experiments/speed:
in-place ReLU against today's, interleaved blocks."""

import time
from torch import nn
from common import args, warm_trainer

tr = warm_trainer(*args())
relus = [
    m
    for net in (
        tr.agent.actor,
        tr.agent.critic,
        tr.agent.actor_targ,
        tr.agent.critic_targ,
    )
    for m in net.modules()
    if isinstance(m, nn.ReLU)
]


def set_inplace(v):
    for m in relus:
        m.inplace = v


res = {False: [], True: []}
for _ in range(3):
    tr.update_step()
for rep in range(8):
    for v in (False, True):
        set_inplace(v)
        c = time.process_time()
        w = time.perf_counter()
        for _ in range(10):
            tr.update_step()
        res[v].append((time.process_time() - c) / 10 * 1e3)
import statistics as st

for v in res:
    print(
        "inplace",
        v,
        "cpu ms median",
        round(st.median(res[v]), 2),
        "min",
        round(min(res[v]), 2),
    )
