"""Does this checkout still train a finished run's first epochs, float for float?

    .venv/bin/python experiments/bit-identity/same_as_check.py RUN [--epochs N]

Trains RUN's own recorded command (config.json's `command`, with `--out` sent to a
temporary folder) with this checkout until its progress.csv has N rows (default 2),
stops it, and compares those rows with RUN's, every column but `wall_s`. Prints `same`
or the first row and column that differ (exit 1). The evidence behind a plan group's
`same_as` (acder_lite/runs/same_as.py): a finished run is the grid cell's run when the
configs agree and the code still computes the same floats.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shlex
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with open(path) as f:
        return list(csv.DictReader(f))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run", type=Path)
    p.add_argument("--epochs", type=int, default=2, help="rows to compare (default 2)")
    args = p.parse_args()
    command = json.loads((args.run / "config.json").read_text())["command"]
    argv = shlex.split(command)[3:]  # after "python -m acder_lite"
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run"
        argv[argv.index("--out") + 1] = str(out)
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        proc = subprocess.Popen(
            [sys.executable, "-m", "acder_lite", *argv, "--quiet"],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            while len(rows(out / "progress.csv")) < args.epochs:
                if proc.poll() is not None:
                    print(
                        f"train ended (rc {proc.returncode}) before {args.epochs} rows"
                    )
                    return 2
                time.sleep(5)
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
                proc.wait()
        ours, theirs = rows(out / "progress.csv"), rows(args.run / "progress.csv")
    print(f"{args.run}: {' '.join(argv[:8])} ...")
    for i in range(args.epochs):
        for key in theirs[i]:
            if key != "wall_s" and ours[i].get(key) != theirs[i][key]:
                here, there = ours[i].get(key), theirs[i][key]
                print(f"DIFF row {i + 1} {key}: {here} here, {there} there")
                return 1
    print(f"same: {args.epochs} rows, every column but wall_s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
