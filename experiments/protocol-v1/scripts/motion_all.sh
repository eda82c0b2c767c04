#!/bin/bash
# Write RUN/motion.json for every finished run on a task with an object (done.json and policy.pt):
# how its final policy moves the object over 80 test episodes (test-env seed 12345). The
# protocol-v1 runs' motion.json files were written this way. Runs that already have one are
# skipped. Usage, from the repository root:
#   experiments/protocol-v1/scripts/motion_all.sh [ROOT]     (ROOT default: experiments/protocol-v1)
root=${1:-experiments/protocol-v1}
for d in "$root"/FetchPush-v4/*/seed* "$root"/FetchPickAndPlace-v4/*/seed*; do
  [ -f "$d/done.json" ] && [ -f "$d/policy.pt" ] || continue
  [ -f "$d/motion.json" ] && continue
  .venv/bin/python -m acder_lite diagnose "$d" --episodes 80 --json "$d/motion.json" > /dev/null && echo "wrote $d/motion.json"
done
