#!/bin/bash
# Snapshot `diagnose` of a training run after every checkpoint (once an epoch), so that the
# start-state pool and S-ICM's clip share can be followed over a run (checkpoints themselves are
# not committed). The protocol-v1 runs' diagnose/ folders were written this way; it works on any
# run folder. Usage, from the repository root, while the run trains:
#   experiments/protocol-v1/scripts/watch_diagnose.sh results/FetchPush-v4/acder/seed0
# Writes <run>/diagnose/<episodes>.json; stops when the run has written done.json.
run=$1
mkdir -p "$run/diagnose"
last=""
while true; do
  if [ -f "$run/checkpoint.pt" ]; then
    m=$(stat -c %Y "$run/checkpoint.pt")
    if [ "$m" != "$last" ]; then
      last=$m
      tmp=$(mktemp "$run/diagnose/.snap.XXXXXX")
      if .venv/bin/python -m acder_lite diagnose "$run" --batches 10 --json "$tmp" > /dev/null; then
        ep=$(.venv/bin/python -c "import json,sys; print(json.load(open(sys.argv[1]))['episodes'])" "$tmp")
        mv "$tmp" "$run/diagnose/$(printf %06d "$ep").json"
      else
        rm -f "$tmp"
      fi
    fi
  fi
  [ -f "$run/done.json" ] && break
  sleep 30
done
