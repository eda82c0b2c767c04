#!/bin/bash
# How often each finished run's policy turns the block through an Euler angle's wrap
# (diagnose.angle_wraps), on 40 deterministic test episodes (seed 12345), one JSON per run:
#
#     experiments/angle-wraps/run.sh      # from the checkout's root; skips runs already read
#
# Reads every finished run (done.json) with a block: the grid's Push and Pick&Place cells
# and the readings, constant-bonus and S-ICM (sin, cos) runs on Push. Writes
# experiments/angle-wraps/<the run's folder>.json, e.g. .../results/FetchPush-v4/her/seed0.json.
set -euo pipefail
cd "$(dirname "$0")/../.."
PY=${PY:-.venv/bin/python}
OUT=experiments/angle-wraps
for run in results/FetchPush-v4/*/seed* results/FetchPickAndPlace-v4/*/seed* \
           experiments/readings/FetchPush-v4/*/seed* experiments/constant-bonus/FetchPush-v4/*/seed* \
           experiments/sicm-sincos/FetchPush-v4/*/seed*; do
  [ -f "$run/done.json" ] && [ -f "$run/policy.pt" ] || continue
  json=$OUT/$run.json
  [ -f "$json" ] && continue
  mkdir -p "$(dirname "$json")"
  nice -n 5 "$PY" -m acder_lite diagnose "$run" --episodes 40 --seed 12345 --json "$json" > /dev/null
  echo "$json"
done
