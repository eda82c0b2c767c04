"""Side measurement for experiments/speed (profile_bf16.txt): where a bfloat16 update's
time goes, torch.profiler's table of 20 updates (FetchPush `her`, one thread unless
given). Wall time under the profiler: on a busy machine read it as shares, not
milliseconds. Run from the repository root on a CPU with native bfloat16."""

import sys

from torch.profiler import ProfilerActivity, profile

sys.path.insert(0, "experiments/speed")
from common import args, warm_trainer  # noqa: E402

tr = warm_trainer(*args())
tr.cfg.update_dtype = "bfloat16"
for _ in range(5):
    tr.update_step()
with profile(activities=[ProfilerActivity.CPU]) as p:
    for _ in range(20):
        tr.update_step()
print(p.key_averages().table(sort_by="self_cpu_time_total", row_limit=15))
