"""The 400-epoch run repeats the 40-epoch run: its first 40 progress rows equal this
folder's in every column both files have, but the timing (`wall_s`). Prints `same` or
each row and column that differs; exit code 1 on a difference, 2 when the long run has
fewer rows yet.

usage: .venv/bin/python experiments/multistep-40/first_rows.py [SHORT_RUN LONG_RUN]
"""

import csv
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
RUN = "FetchPushMultiStep-v0/acder/seed0"


def rows(run: Path) -> list[dict]:
    with open(run / "progress.csv") as f:
        return list(csv.DictReader(f))


def main(argv: list[str]) -> int:
    short, long = (
        map(Path, argv)
        if argv
        else (ROOT / "experiments/multistep-40" / RUN, ROOT / "results" / RUN)
    )
    if not (long / "progress.csv").is_file():
        print(f"{long}: no progress.csv yet; the long run has not finished an epoch")
        return 2
    a, b = rows(short), rows(long)
    if len(b) < len(a):
        print(
            f"{long}: {len(b)} rows, fewer than the {len(a)} to compare; run it longer"
        )
        return 2
    diffs = [
        f"epoch {x['epoch']}: {k} {x[k]} != {y[k]}"
        for x, y in zip(a, b)
        for k in x.keys() & y.keys() - {"wall_s"}
        if x[k] != y[k]
    ]
    print("\n".join(diffs) or f"same: the first {len(a)} rows of {long}")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
