#!/bin/bash
# Tiny seeded runs of every method (FetchPush; ACDER on the multi-step Push too) with the code
# of the checkout this script sits in, into OUT. Run it before a change and after, then
# compare.py says, run by run, whether the change moved a float.
#
#     /tmp/old/experiments/bit-identity/runs.sh /tmp/before  # a worktree of the old commit
#     experiments/bit-identity/runs.sh /tmp/after            # this checkout, with the change
# (both from this checkout's root, whose .venv they use)
#     .venv/bin/python experiments/bit-identity/compare.py /tmp/before /tmp/after
set -euo pipefail
OUT=$(realpath -m "${1:?usage: runs.sh OUT}")
# the interpreter: $PY, else the venv of the folder it is called from (a worktree of the
# old commit has no .venv of its own); absolute, since the next line changes folder
PY=$(realpath -ms "${PY:-.venv/bin/python}")  # -s: a venv's python is a symlink
[ -x "$PY" ] || { echo "runs.sh: no Python at $PY; set PY=/path/to/.venv/bin/python" >&2; exit 2; }
cd "$(dirname "$0")/../.."  # the checkout's root: `python -m` imports its acder_lite
# acder-wide-clip: in runs this short, Baselines' target clip [-1/(1-gamma), 0] maps the
# targets of most rows to 0 (S-ICM's untrained errors put r_int at eta = 0.8), so the
# networks of `acder` do not see a change of the intrinsic reward; the wide clip lets them.
for env in FetchPush-v4 FetchPushMultiStep-v0; do
  for m in her her-icm her-per her-ebp acder acder-wide-clip ddpg acder-no-curiosity \
           acder-no-goal-factor acder-no-start-states acder-simplified; do
    [ "$env" = FetchPushMultiStep-v0 ] && [ "${m%-wide-clip}" != acder ] && continue
    d=$OUT/$env/$m
    rm -rf "$d"
    extra=()
    [ "$m" = acder-wide-clip ] && extra=(--target-clip wide)
    [ "$m" = acder-simplified ] && extra=(--obs simplified)
    method=${m%-wide-clip}; method=${method%-simplified}
    nice -n 5 "$PY" -m acder_lite train --env "$env" --method "$method" --seed 3 \
      --out "$d" --workers 2 --cycles 2 --updates-per-cycle 3 --test-episodes 2 \
      --batch-size 32 --hidden 32 --buffer-size 5000 --stop-patience 0 --epochs 2 \
      --threads 1 --update-dtype float32 --quiet "${extra[@]}" > /dev/null
  done
done
