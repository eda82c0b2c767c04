"""`Config.compile_update` end to end, in one process: two FetchPush trainers
(common.py: 4 workers, minibatch 1024, float32), eager and compiled, whole training
cycles in turn (8 episodes of collection, 40 updates, the target update), `reps`
rounds after a warm-up cycle each (the compiled one compiles in it). Prints CPU time
(process_time) and wall time per training episode, by round and the medians, and the
paired ratios.

`compile_cycles_ab.py [method] [threads] [reps]` (defaults her, 1, 8)."""

import statistics as st
import sys
import time

from common import args, warm_trainer

method, threads = args()
reps = int(sys.argv[3]) if len(sys.argv) > 3 else 8
trainers = {}
for name in ("eager", "compiled"):
    w = time.perf_counter()
    trainers[name] = warm_trainer(method, threads, compile_update=name == "compiled")
    print(f"{name}: warm-up cycle {time.perf_counter() - w:.1f} s wall", flush=True)
per_cycle = 4 * trainers["eager"].cfg.episodes_per_cycle
cpu = {k: [] for k in trainers}
wall = {k: [] for k in trainers}
for r in range(reps):
    for name, tr in trainers.items() if r % 2 == 0 else reversed(trainers.items()):
        w, c = time.perf_counter(), time.process_time()
        tr.train_cycle()
        cpu[name].append((time.process_time() - c) / per_cycle * 1e3)
        wall[name].append((time.perf_counter() - w) / per_cycle * 1e3)
    print(
        f"round {r}: CPU ms/episode eager {cpu['eager'][-1]:.1f} compiled "
        f"{cpu['compiled'][-1]:.1f}; wall {wall['eager'][-1]:.1f} "
        f"{wall['compiled'][-1]:.1f}",
        flush=True,
    )
for label, d in (("CPU", cpu), ("wall", wall)):
    paired = [c / e for c, e in zip(d["compiled"], d["eager"])]
    print(
        f"{label} ms per training episode: eager median {st.median(d['eager']):.1f}, "
        f"compiled {st.median(d['compiled']):.1f}; paired ratios compiled/eager "
        f"{' '.join(f'{x:.2f}' for x in paired)}, median {st.median(paired):.3f}"
    )
