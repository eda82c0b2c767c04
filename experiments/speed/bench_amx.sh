#!/bin/bash
# What produced bench_amx.txt (2026-12-02): the first machine of these sessions whose CPU has
# native bfloat16 (Intel Xeon with AVX512-BF16 and AMX). Does `--update-dtype auto` pick a
# precision that is faster than float32 here (issue 17's target), and by how much?
# The grid's two niced cells ran beside every line (the bench itself is not niced).
# Usage: bash experiments/speed/bench_amx.sh > experiments/speed/bench_amx.txt
# The same script, later that day on the second such machine (an AMD EPYC with AVX512-BF16
# and no AMX), wrote bench_amd_bf16.txt.
PY=${PY:-.venv/bin/python}
B="bench --env FetchPush-v4 --workers 4 --cycles 2"
grep -o -w -E "avx512_bf16|amx_bf16" /proc/cpuinfo | sort -u | tr '\n' ' '; echo
for i in 1 2; do
  for m in her acder; do
    echo "== $m threads=1 --update-dtype both (round $i)"
    $PY -m acder_lite $B --method $m --threads 1 --update-dtype both 2>/dev/null | tail -3
    echo "== $m threads=1 --update-dtype auto (round $i)"
    $PY -m acder_lite $B --method $m --threads 1 --update-dtype auto 2>/dev/null | tail -2
  done
done
