"""How long the cells a sweep has left will take, read off the runs it has finished.

`sweep --dry-run` ends with this estimate. Per cell to run or resume: the epochs it has
left (its budget, less the epochs its progress.csv already holds), times the seconds an
epoch that the finished runs of its task and method took (the median over them of wall_s
/ epochs at their last row: one cell of a sweep, one thread, beside the other cells; of
its task's runs where the method has none). Two totals:

- **budget**: every cell runs its whole budget, an upper bound;
- **as finished**: every cell stops at the epoch where the finished runs of its task and
  method stopped (their median; the budget where none has finished yet), the stop rule
  being what ends most runs early.

A task with no finished run has no timing: its cells are counted apart, not guessed.
Wall-clock seconds are the machine's as it was while those runs trained; another
machine, or one cell alone on it, gives other times. The totals are cell-hours: hours of
one cell on one thread, as the finished runs ran (core-hours at `--threads 1`).
"""

from __future__ import annotations

import statistics
from collections import defaultdict

from .config import Config
from .runs import RunError, read_progress, read_run


def finished_timings(folders) -> tuple[dict, dict]:
    """From finished run folders: (seconds an epoch, epochs at the end), each a median
    keyed by (task, method); the seconds also by task alone, for a method with no
    finished run. Folders that cannot be read are passed over."""
    per_epoch, ended = defaultdict(list), defaultdict(list)
    for d in folders:
        try:
            run = read_run(d)
        except RunError:
            continue
        last = run["rows"][-1] if run["rows"] else {}
        epoch, wall = last.get("epoch"), last.get("wall_s")
        # a copy (`same_as`) would count its source twice
        if not run["done"] or run["same_as"] or not _positive(epoch, wall):
            continue
        secs = float(wall) / float(epoch)
        per_epoch[run["env"], run["method"]].append(secs)
        per_epoch[run["env"]].append(secs)
        ended[run["env"], run["method"]].append(float(epoch))
    med = lambda d: {k: statistics.median(v) for k, v in d.items()}
    return med(per_epoch), med(ended)


def _positive(*values) -> bool:
    try:
        return all(float(v) > 0 for v in values)
    except (TypeError, ValueError):
        return False


def epochs_done(folder) -> float:
    """The epochs a run folder's progress.csv holds (0 for none)."""
    try:
        rows = read_progress(folder / "progress.csv")
    except (OSError, RunError):
        return 0.0
    epoch = rows[-1].get("epoch") if rows else None
    return float(epoch) if _positive(epoch) else 0.0


def estimate(cells, options: dict | None = None) -> dict:
    """The estimate for a sweep's cells (`plan.Cell`s with their actions set): hours
    to budget and as finished, the cells counted, the cells of untimed tasks and those
    on hold. `options`: the sweep's own Config fields (`--epochs`, ...), over each
    cell's."""
    done = [
        c.out for c in cells if c.action == "skip" and (c.out / "done.json").exists()
    ]
    per_epoch, ended = finished_timings(done)
    out = dict(cells=0, budget_h=0.0, finished_h=0.0, untimed=defaultdict(int))
    out["held"] = sum(c.action == "skip" and bool(c.hold) for c in cells)
    for c in cells:
        if c.action not in ("run", "resume"):
            continue
        if c.env not in per_epoch:
            out["untimed"][c.env] += 1
            continue
        budget = (
            Config(**{**c.options, **(options or {}), "env": c.env, "method": c.method})
            .resolve()
            .epochs
        )
        have = epochs_done(c.out)
        stop = min(ended.get((c.env, c.method), budget), budget)
        secs = per_epoch.get((c.env, c.method), per_epoch[c.env])
        out["cells"] += 1
        out["budget_h"] += max(budget - have, 0) * secs / 3600
        out["finished_h"] += max(stop - have, 0) * secs / 3600
    out["untimed"] = dict(out["untimed"])
    return out


def sentence(est: dict, jobs: int) -> str:
    """The estimate as the line `sweep --dry-run` ends with."""
    cells = lambda n: f"{n} cell" + ("" if n == 1 else "s")
    text = (
        f"time left: {cells(est['cells'])}, {est['finished_h']:.1f} cell-hours as the "
        f"finished runs of their task and method ended ({est['budget_h']:.1f} if each "
        f"runs its budget); {jobs} at a time, {est['finished_h'] / jobs:.1f}-"
        f"{est['budget_h'] / jobs:.1f} hours"
    )
    if est["untimed"]:
        text += "; not timed (no finished run of the task): " + ", ".join(
            f"{env} ({cells(n)})" for env, n in sorted(est["untimed"].items())
        )
    if est["held"]:
        text += f"; on hold, not counted: {cells(est['held'])}"
    return text
