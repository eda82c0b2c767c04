#!/bin/bash
# What produced bench_split.txt: `bench` before (BASE, a detached worktree of the commit
# before the change) and after (this checkout), alternating, at --threads 2 then 1, with
# the grid's two cells running beside it at nice 19 (the bench at nice 0 gets about 96% of
# both cores then: measured with two spinning processes). Usage, from this checkout's root:
#     git worktree add --detach /work/base-010 010ff51
#     experiments/speed/bench_split.sh /work/base-010 > experiments/speed/bench_split.txt
set -euo pipefail
BASE=${1:?usage: bench_split.sh BASE_WORKTREE}
PY=$(realpath -ms "${PY:-.venv/bin/python}")
AFTER=$(pwd)
B="bench --env FetchPush-v4 --workers 4 --update-dtype float32 --cycles 2"
for t in 2 1; do
  for i in 1 2 3; do
    for side in before after; do
      dir=$AFTER; [ $side = before ] && dir=$BASE
      line=$(cd "$dir" && "$PY" -m acder_lite $B --method her --threads $t 2>/dev/null | tail -2 | tr '\n' ' ')
      echo "$side threads=$t her: $line"
    done
  done
done
