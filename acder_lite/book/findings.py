"""What the runs show, computed for chapter 8 and its appendix "Results in detail".

`report` reads Table I's statistic off the runs (CellStat per task and method,
RatioStat per task); this module answers the questions the two pages ask of those
statistics, as numbers, names and decisions: which runs have finished
(`finished_runs`), where the paper's number lies against our interval
(`paper_place`, `ratio_place`), which methods cross before ACDER
(`crossed_before`), what the readings' rule makes of each ablation against full ACDER
(`rule_against`), whether a crossing holds (`below_after_crossing`), where one cell's
seeds fall among two others' (`seed_placement`), how the curiosity bonus grows over a
run (`bonus_over_run`) and which runs the sweep copied (`copied_runs`). It writes no
sentences: the pages are written by hand, glue these values into their prose and
assert each claim beside it.

Trap: a cell whose seeds have all ended without a crossing is later than every
crossing (`reached` gives it inf), but a cell with seeds still to come is not yet
anywhere (None): its crossing may still move.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from acder_lite.stats.report import (
    ABLATIONS,
    FIG4_METHODS,
    SUCCESS_TOL,
    TAIL_EVALUATIONS,
    CellStat,
    RatioStat,
    complete,
    learning_curves,
    separated,
)


def finished_runs(runs: list[dict]) -> list[dict]:
    """The runs that have ended (done.json): a seed still training, or interrupted, is
    left out, so a page reads only what will not change."""
    return [r for r in runs if r.get("ended") is not None]


def reached(c: CellStat) -> float | None:
    """Where a cell's mean curve reaches the threshold, for comparing cells: its
    crossing (epochs), inf for a cell whose seeds have all ended without one (later
    than any crossing), None while that is not known."""
    if c.crossing is not None:
        return c.crossing
    return math.inf if c.why == "not within budget" and complete(c) else None


def _place(x: float, low: float, high: float) -> str:
    return "inside" if low <= x <= high else "above" if x > high else "below"


def paper_place(c: CellStat) -> str | None:
    """Where Table I's number lies against the cell's 95% interval, both in Table I's
    unit: 'inside', 'above' (the paper needed more episodes than our interval allows)
    or 'below'; None without a paper number or an interval."""
    if c.paper is None or c.low is None or c.high is None or math.isnan(c.low):
        return None
    return _place(c.paper, c.paper_units(c.low), c.paper_units(c.high))


def ratio_place(r: RatioStat) -> str | None:
    """Where the paper's HER/ACDER ratio lies against our ratio's 95% interval:
    'inside', 'above' or 'below' (ends count as inside); None without both."""
    if r.paper is None or r.low is None or r.high is None or math.isnan(r.low):
        return None
    return _place(r.paper, r.low, r.high)


def crossed_before(
    cells: list[CellStat], env: str, name: str = "acder", among=FIG4_METHODS
) -> list[str] | None:
    """The methods of `among` on `env` whose mean curve reaches the threshold before
    `name`'s, in order of their crossing; a cell whose seeds all ended without a
    crossing counts as later than every crossing (`reached`), and one with seeds still
    to come is placed by its crossing so far. None while `name`'s cell, or one of the
    others, is not placed at all (no crossing, and seeds to come)."""
    by = {c.name: c for c in cells if c.env == env}
    if name not in by or reached(by[name]) is None:
        return None
    others = [by[n] for n in among if n in by and n != name]
    if any(reached(c) is None for c in others):
        return None
    mine = reached(by[name])
    return [c.name for c in sorted(others, key=reached) if reached(c) < mine]


def rule_against(
    cells: list[CellStat], env: str, names=ABLATIONS, reference: str = "acder"
) -> dict[str, bool | None]:
    """The readings' rule (`report.separated`: each crossing outside the other's 95%
    interval) for each of `names` on `env` against `reference`: True (separated),
    False (not), None (not yet: seeds to come, or no crossing with an interval)."""
    by = {c.name: c for c in cells if c.env == env}
    ref = by[reference]
    return {n: separated(by[n], ref) for n in names if n in by}


def below_after_crossing(c: CellStat, runs: list[dict]) -> tuple[int, int] | None:
    """Whether a crossing holds: (how many of the mean curve's evaluations after its
    crossing lie below the threshold, how many evaluations come after it), counting
    only where every seed has a value. None where the cell has no crossing."""
    m = learning_curves(runs).get((c.env, c.name))
    if c.crossing is None or m is None:
        return None
    later = (m.x > c.crossing) & ~np.isnan(m.mean)
    below = later & (m.mean < c.threshold - SUCCESS_TOL)
    return int(below.sum()), int(later.sum())


def _seed_values(c: CellStat) -> list[float] | None:
    """A cell's seed crossings (epochs), inf for a seed that ended without one; None
    while a seed has not ended or none is planned to come."""
    if c.unfinished or not c.n or not complete(c):
        return None
    return [math.inf if x is None else x for x in c.seed_crossings]


def seed_placement(c: CellStat, slow: CellStat, fast: CellStat) -> str | None:
    """Where the seeds of `c` fall, seed by seed, against the seeds of a `slow` and a
    `fast` cell (e.g. the constant-bonus control against DDPG+HER and DDPG+HER+ICM):
    'after slow' (every seed of `c` crosses later than every seed of `slow`, or never),
    'before fast' (earlier than every seed of `fast`), 'between' (from `fast`'s fastest
    to `slow`'s slowest) or 'overlap'. None while a seed of the three is still to
    come."""
    v, s, f = _seed_values(c), _seed_values(slow), _seed_values(fast)
    if v is None or s is None or f is None:
        return None
    if min(v) > max(s):
        return "after slow"
    if max(v) < min(f):
        return "before fast"
    if min(v) >= min(f) and max(v) <= max(s):
        return "between"
    return "overlap"


def bonus_over_run(
    runs: list[dict],
    env: str,
    name: str,
    first: int = 3,
    last: int = TAIL_EVALUATIONS,
    column: str = "r_int_mean",
) -> list[tuple[float, float]]:
    """How the curiosity bonus of a minibatch (progress.csv's `r_int_mean`) changes
    over each seed of (env, name): (its lowest value in the first `first`
    evaluations, its mean over the last `last`), one pair a seed that has the column,
    in the runs' order."""
    out = []
    for r in runs:
        if (r["env"], r["name"]) != (env, name):
            continue
        vals = [
            row[column]
            for row in r["rows"]
            if isinstance(row.get(column), float) and not math.isnan(row[column])
        ]
        if vals:
            out.append((min(vals[:first]), float(np.mean(vals[-last:]))))
    return out


def copied_runs(runs: list[dict], root: str | Path | None = None) -> dict:
    """The runs the sweep copied from another folder instead of training them (a plan
    group's `same_as`): {(env, name, source folder): [seeds]}, the source relative to
    `root` where it lies below it. Empty when none was copied."""
    out: dict[tuple, list] = {}
    for r in runs:
        if r.get("same_as"):
            source = Path(r["same_as"]).parent
            if root is not None and source.is_relative_to(root):
                source = source.relative_to(root)
            out.setdefault((r["env"], r["name"], str(source)), []).append(r["seed"])
    return {k: sorted(v) for k, v in sorted(out.items())}
