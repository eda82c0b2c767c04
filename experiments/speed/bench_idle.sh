#!/bin/bash
# What produced bench_idle.txt: issue 17's targets measured on an idle machine (the grid's
# sweep stopped for the length of this script; it resumes from its checkpoints). `bench`
# at the commit where its limit and grid-CPU fields appeared (BASE: 39aea41, the issue's
# "today") and at this checkout, alternating in ABBA order, at --threads 2 then 1; then
# this checkout's `her` and `acder` at --threads 1, alternating. Usage, from this
# checkout's root:
#     git worktree add --detach /work/before-bench 39aea41
#     experiments/speed/bench_idle.sh /work/before-bench > experiments/speed/bench_idle.txt
set -euo pipefail
BASE=${1:?usage: bench_idle.sh BASE_WORKTREE}
PY=$(realpath -ms "${PY:-.venv/bin/python}")
AFTER=$(pwd)
B="bench --env FetchPush-v4 --workers 4 --update-dtype float32 --cycles 3"
one() {  # side method threads
  local dir=$AFTER
  [ "$1" = before ] && dir=$BASE
  line=$(cd "$dir" && PYTHONPATH="$dir" "$PY" -m acder_lite $B --method "$2" \
    --threads "$3" 2>/dev/null | tail -2 | tr '\n' ' ')
  echo "$1 threads=$3 $2: $line"
}
echo "# $(date -u +%FT%TZ) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs);" \
  "before = $(git -C "$BASE" rev-parse --short HEAD), after = $(git rev-parse --short HEAD)"
for t in 2 1; do
  for order in "before after" "after before" "before after" "after before"; do
    for side in $order; do one "$side" her "$t"; done
  done
done
for order in "her acder" "acder her" "her acder"; do
  for m in $order; do one after "$m" 1; done
done
