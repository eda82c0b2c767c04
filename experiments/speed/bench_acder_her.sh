#!/bin/bash
# What produced bench_acder_her.txt (2026-12-01, beside the grid's two niced cells): her then
# acder, 4 pairs, at --threads 1, from the checkout's root.
set -euo pipefail
cd "$(dirname "$0")/../.."
B="bench --env FetchPush-v4 --workers 4 --update-dtype float32 --cycles 2 --threads 1"
for i in 1 2 3 4; do
  for m in her acder; do
    echo "$m $(.venv/bin/python -m acder_lite $B --method $m 2>/dev/null | tail -1)"
  done
done
