#!/bin/bash
# S-ICM on a run's replay buffer: the share of rows at Eq. 4's clip, and of the start-state
# candidates, whose step turns the block through an Euler angle's wrap. Finished runs keep no
# checkpoint, but a run in flight at the end of a session was committed with its packed
# checkpoint (`pack`); this takes one from git history and runs `diagnose` on it (its replay
# buffer is re-simulated first: about 15 minutes for 10,000 episodes on one core):
#
#     experiments/angle-wraps/buffer.sh COMMIT RUN    # from the checkout's root
#     experiments/angle-wraps/buffer.sh b169a40 results/FetchPush-v4/acder-no-goal-factor/seed2
#
# writes experiments/angle-wraps/buffer/<RUN>@<COMMIT>.json (and .txt, what diagnose printed).
set -euo pipefail
cd "$(dirname "$0")/../.."
COMMIT=${1:?usage: buffer.sh COMMIT RUN}
RUN=${2:?usage: buffer.sh COMMIT RUN}
PY=${PY:-.venv/bin/python}
out=experiments/angle-wraps/buffer/$RUN@$COMMIT
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
git archive "$COMMIT" "$RUN" | tar -x -C "$tmp"
mkdir -p "$(dirname "$out")"
nice -n 5 "$PY" -m acder_lite diagnose "$tmp/$RUN" --batches 40 --json "$tmp/d.json" \
  | sed "s|$tmp/||" > "$tmp/d.txt"
"$PY" - "$tmp/d.json" "$RUN" > "$out.json" <<'PYEOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["run"] = sys.argv[2]  # the run's folder in the repository, not the scratch copy
print(json.dumps(d, indent=1))
PYEOF
mv "$tmp/d.txt" "$out.txt"
echo "$out.json"
