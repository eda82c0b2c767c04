#!/bin/bash
# Write RUN/motion.json for every finished run on a task with an object (done.json and policy.pt):
# how its final policy moves the object over 80 test episodes (test-env seed 12345), the numbers
# chapter 8's motion table shows. Runs that already have one are skipped. Usage, from the
# repository root:  results/scripts/motion_all.sh [results]
root=${1:-results}
for d in "$root"/FetchPush-v4/*/seed* "$root"/FetchPickAndPlace-v4/*/seed*; do
  [ -f "$d/done.json" ] && [ -f "$d/policy.pt" ] || continue
  [ -f "$d/motion.json" ] && continue
  .venv/bin/python -m acder_lite diagnose "$d" --episodes 80 --json "$d/motion.json" > /dev/null && echo "wrote $d/motion.json"
done
