#!/bin/bash
# The book's videos: one episode of each trained ACDER policy (seed-0 runs of results/), rendered
# offline by MuJoCo's own renderer through headless EGL (Mesa on the CPU) from the Fetch tasks'
# camera, written as looping GIFs the browser plays without WebGL, plugins or a network:
#
#     experiments/videos/make.sh          # from anywhere; or `make videos`
#
# writes book/_static/videos/<task>-acder.gif and prints, per video, its size and the episode's
# outcome (experiments/videos/README.md records them). The episode: env seed 500 (a seed-0 run's
# first test env), or the next seed whose start is not already solved (acder_lite.book.video,
# first_unsolved_seed). About 15 s a video on one core. Needs Debian's libegl1 libegl-mesa0
# libgl1-mesa-dri libopengl0 (.ci/run installs them).
set -euo pipefail
cd "$(dirname "$0")/../.."
PY=${PY:-.venv/bin/python}
export MUJOCO_GL=${MUJOCO_GL:-egl}
OUT=book/_static/videos
mkdir -p "$OUT"
# Multi-step Push: the 40-epoch run (experiments/multistep-40/) until the 400-epoch run of
# results/ has finished.
for task in FetchReach-v4 FetchPush-v4 FetchPickAndPlace-v4 FetchPushMultiStep-v0; do
  run="results/$task/acder/seed0"
  [ -f "$run/done.json" ] || run="experiments/multistep-40/$task/acder/seed0"
  nice -n 10 "$PY" -m acder_lite.book.video "$run" "$OUT/$task-acder.gif"
done
