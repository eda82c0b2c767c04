#!/bin/bash
# The rule by which we end a run that reached the threshold but does not hold it: at the first
# epoch boundary at least GAP episodes (default 1,200, three epochs of 400) after the run first
# reached THRESHOLD (default 0.95), unless the early stop has ended it before. Table I counts
# the first crossing, which this cannot change; only the tail of the run's curve is lost.
# Usage, from the repository root, while the run trains:
#   results/scripts/end_when_hovering.sh results/FetchPush-v4/her-icm/seed0 [THRESHOLD] [GAP]
set -euo pipefail
run=${1:?run folder}
thr=${2:-0.95}
gap=${3:-1200}
until [ -f "$run/progress.csv" ]; do sleep 30; done
while true; do
  [ -f "$run/done.json" ] && { echo "end_when_hovering: $run has ended by itself"; exit 0; }
  # first crossing (episodes; empty if none yet), by the function that makes Table I
  first=$(.venv/bin/python -c "import sys; from acder_lite.table import read_progress, episodes_to_threshold as f
e = f(read_progress(sys.argv[1]), float(sys.argv[2])); print('' if e is None else int(e))" "$run/progress.csv" "$thr")
  if [ -n "$first" ]; then
    per=$(.venv/bin/python -c "import json,sys; c=json.load(open(sys.argv[1]))['config']; print(c['cycles']*c['episodes_per_cycle']*c['workers'])" "$run/config.json")
    epoch=$(( (first + gap + per - 1) / per ))
    echo "end_when_hovering: $run first reached $thr at $first episodes; ending at epoch $epoch unless it stops before"
    exec results/scripts/end_at_epoch.sh "$run" "$epoch"
  fi
  sleep 60
done
