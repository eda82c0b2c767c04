#!/bin/bash
# What produced bench_compile.txt: `bench` of this checkout without and with
# --compile-update (Config.compile_update), alternating, 3 pairs at --threads 1, then 3
# at --threads 2, beside the grid's two cells (nice 10). Both sides are this checkout:
# the eager side computes as before the flag existed (../bit-identity/: all `same`).
# The compiled side compiles in bench's warm-up cycle, which is not timed (inductor's
# caches on, as they are by default: after the first run they hold the graphs, and a
# run's compile is mostly loading them; whole_run_s shows it). Usage, from this
# checkout's root:
#     PY=/path/to/.venv/bin/python experiments/speed/bench_compile.sh > experiments/speed/bench_compile.txt
set -euo pipefail
PY=$(realpath -ms "${PY:-.venv/bin/python}")
B="bench --env FetchPush-v4 --method her --workers 4 --update-dtype float32 --cycles 2"
for t in 1 2; do
  for i in 1 2 3; do
    for side in eager compiled; do
      flag=(); [ $side = compiled ] && flag=(--compile-update)
      s=$(date +%s)
      line=$("$PY" -m acder_lite $B --threads $t "${flag[@]}" 2>/dev/null | tail -2 | tr '\n' ' ')
      echo "$side threads=$t pair=$i whole_run_s=$(( $(date +%s) - s )): $line"
    done
  done
done
