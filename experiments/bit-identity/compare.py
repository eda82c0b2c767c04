"""Compare two sets of runs made by runs.sh, bit for bit: progress.csv without its
timing column, and every tensor and number of policy.pt. One line a run, `same` or
`DIFF` with what differs (a key only one policy.pt has is named: a new field moves no
float, but it is a difference); exit code 1 if any differs.

`--new-columns a,b,...` ignores those progress.csv columns where only the AFTER run has
them (a change that records something more); the line of such a run says which it
ignored. Every other column, and a named column both runs have, is compared as before.

usage: .venv/bin/python experiments/bit-identity/compare.py BEFORE AFTER
       [--new-columns a,b,...]
"""

import argparse
import csv
import sys
from pathlib import Path

import numpy as np
import torch

TIMING = {"wall_s"}


def flat(obj, prefix=""):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from flat(v, f"{prefix}{k}.")
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            yield from flat(v, f"{prefix}{i}.")
    else:
        yield prefix, obj


def rows(path: Path) -> list[dict]:
    with open(path) as f:
        return [
            {k: v for k, v in r.items() if k not in TIMING} for r in csv.DictReader(f)
        ]


def equal(v, w) -> bool:
    """Bit for bit; NaN equals NaN (the same NaN written twice is no change)."""
    if torch.is_tensor(v):
        if not (torch.is_tensor(w) and v.shape == w.shape and v.dtype == w.dtype):
            return False
        if torch.equal(v, w):
            return True
        both_nan = v.isnan() & w.isnan() if v.is_floating_point() else False
        return bool(((v == w) | both_nan).all())
    try:
        a, b = np.asarray(v), np.asarray(w)
        return bool(np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"))
    except Exception:  # values numpy cannot hold (None, strings of other lengths)
        return v == w


def header(path: Path) -> list[str]:
    with open(path) as f:
        return next(csv.reader(f), [])


def ignored_columns(a: Path, b: Path, new_columns=()) -> list[str]:
    """The `new_columns` that run `b`'s progress.csv has and run `a`'s has not."""
    before, after = header(a / "progress.csv"), header(b / "progress.csv")
    return [c for c in after if c in set(new_columns) and c not in before]


def differences(a: Path, b: Path, new_columns=()) -> list[str]:
    """What differs between run folders `a` and `b` ([] if nothing); progress.csv
    columns named in `new_columns` that only `b` has are left out."""
    if not (b / "progress.csv").exists():
        return ["no run"]
    skip = set(ignored_columns(a, b, new_columns))
    after = [
        {k: v for k, v in r.items() if k not in skip} for r in rows(b / "progress.csv")
    ]
    out = [] if rows(a / "progress.csv") == after else ["progress.csv"]
    pa = dict(flat(torch.load(a / "policy.pt", weights_only=False)))
    pb = dict(flat(torch.load(b / "policy.pt", weights_only=False)))
    out += [f"policy.pt {k} only in one" for k in sorted(set(pa) ^ set(pb))]
    out += [
        f"policy.pt {k}" for k in sorted(set(pa) & set(pb)) if not equal(pa[k], pb[k])
    ]
    return out


def main(before: Path, after: Path, new_columns=()) -> int:
    names = {p.parent.relative_to(before) for p in before.rglob("progress.csv")}
    if not names:
        print(f"compare.py: no runs under {before}", file=sys.stderr)
        return 2
    bad = 0
    for run in sorted(
        {p.parent.relative_to(after) for p in after.rglob("progress.csv")}
    ):
        if run not in names:
            print(f"DIFF {run}: only in {after}")
            bad += 1
    for p in sorted(before.rglob("progress.csv")):
        run = p.parent.relative_to(before)
        diff = differences(p.parent, after / run, new_columns)
        more = f" (+{len(diff) - 3} more)" if len(diff) > 3 else ""
        skipped = (
            ignored_columns(p.parent, after / run, new_columns)
            if (after / run / "progress.csv").exists()
            else []
        )
        note = f" (new columns ignored: {', '.join(skipped)})" if skipped else ""
        print(
            f"DIFF {run}: {', '.join(diff[:3])}{more}{note}"
            if diff
            else f"same {run}{note}"
        )
        bad += bool(diff)
    return 1 if bad else 0


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument(
        "--new-columns",
        default="",
        help="comma-separated progress.csv columns to ignore where only AFTER has them",
    )
    args = ap.parse_args()
    named = [c for c in args.new_columns.split(",") if c]
    sys.exit(main(args.before, args.after, named))
