#!/bin/bash
# End a training run at an epoch boundary, keeping everything up to that epoch's checkpoint.
# Used for runs that first reached the threshold but hover just below it, so that the early stop
# (10 evaluations in a row at or above it) would let them run to the budget while other cells wait.
# Usage, from the repository root, while the run trains:
#   results/scripts/end_at_epoch.sh results/FetchPush-v4/her-ebp/seed0 25
# Waits for the checkpoint of epoch EPOCH, interrupts the run (SIGINT: it keeps that checkpoint;
# a sweep that started it reports "interrupted" and goes on), then ends it with
#   python -m acder_lite train --resume RUN --epochs EPOCH --threads 1 --quiet
# which records the resume in config.json and writes policy.pt and done.json.
set -euo pipefail
run=${1:?run folder}
epoch=${2:?epoch}
cycles=$(.venv/bin/python -c "import json,sys; print(json.load(open(sys.argv[1]))['config']['cycles'])" "$run/config.json")
target=$((epoch * cycles))
ckpt_cycle() {  # the cycle a checkpoint was saved at (memory-mapped: cheap for a large buffer)
  .venv/bin/python -c "import torch, sys; print(torch.load(sys.argv[1], map_location='cpu', weights_only=False, mmap=True)['progress']['cycle'])" "$run/checkpoint.pt" 2>/dev/null || echo -1
}
last=""
while true; do
  if [ -f "$run/done.json" ]; then
    echo "end_at_epoch: $run has already ended (done.json)"
    exit 0
  fi
  m=$(stat -c %Y "$run/checkpoint.pt" 2>/dev/null || echo 0)
  if [ "$m" != "$last" ]; then  # read the checkpoint only when a new one has been written
    last=$m
    c=$(ckpt_cycle)
    [ "$c" -eq "$target" ] && break
    if [ "$c" -gt "$target" ]; then
      echo "end_at_epoch: $run is past epoch $epoch (checkpoint at cycle $c); choose a later epoch" >&2
      exit 2
    fi
  fi
  sleep 10
done
pid=$(pgrep -f "acder_lite train .*(--resume|--out) $run( |$)" || true)
if [ -n "$pid" ]; then
  kill -INT $pid
  while kill -0 $pid 2>/dev/null; do sleep 1; done
fi
.venv/bin/python -m acder_lite train --resume "$run" --epochs "$epoch" --threads 1 --quiet
