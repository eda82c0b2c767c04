"""The sentences chapter 8 says about Fig. 5: ACDER's ablations against full ACDER.

`ablation_sentence` checks the paper's reading of Fig. 5 on one task from `report`'s
cells (CellStat): every ablation crosses later than full ACDER, and which of them still
cross before DDPG+HER; `separated_sentence` says which ablations the readings' rule
(`report.separated`) separates from full ACDER, task by task. The cells in order of
their crossings and where a cell that never crossed stands are `findings`'
(`order_sentence`, `reached`); numbers are written as Table I's cells write them
(`table`).

Traps: a cell whose seeds all ended without a crossing counts as later than every
crossing (`findings.reached`). The paper's reading is confirmed or contradicted only
where the rule separates an ablation from full ACDER. At a 100% threshold a mean curve
crosses only where every seed is at it at once, so an ablation of fewer seeds than full
ACDER is favoured (departure 29; the sentence names it, and given the runs reads full
ACDER on its seeds alone, `report.cell_on_seeds`), and an interval cannot extend to
later crossings, so the rule tests one side only.
"""

from __future__ import annotations

import math

from acder_lite.book.findings import order_sentence, reached
from acder_lite.stats.report import (
    ABLATIONS,
    TASKS,
    CellStat,
    cell_on_seeds,
    separated,
    threshold,
)
from acder_lite.runs.table import label, mean_text, task_label
from acder_lite.words import and_join, count, sentence


def ablation_sentence(
    cells: list[CellStat], env: str, runs: list[dict] | None = None
) -> str:
    """Fig. 5's claims checked on one task: every ablation slower than ACDER, and
    (curiosity, start states) still faster than HER. A cell that ended without crossing
    counts as later than every crossing (`reached`). At a 100% threshold an ablation
    with fewer seeds than ACDER is named: its mean curve needs fewer seeds at 100% at
    once (departure 29); given the `runs`, full ACDER's mean curve on those seeds alone
    is read too (`report.cell_on_seeds`), the like-for-like comparison."""
    by = {c.name: c for c in cells if c.env == env}
    where = task_label(env)
    acder, her = by.get("acder"), by.get("her")
    abl = [by[n] for n in ABLATIONS if n in by and reached(by[n]) is not None]
    if acder is None or reached(acder) is None or not abl:
        return (
            f"On {where} the ablations cannot be compared yet "
            f"({order_sentence([by[n] for n in ('acder',) + ABLATIONS if n in by])})."
        )
    full = reached(acder)
    slower = [label(c.name) for c in abl if reached(c) > full]
    faster = [
        label(c.name) for c in abl if reached(c) < full or reached(c) == full < math.inf
    ]
    neither = [label(c.name) for c in abl if reached(c) == full == math.inf]
    text = (
        f"On {where}, ordered by the mean curve: "
        f"{order_sentence([by[n] for n in ('her', 'acder') + ABLATIONS if n in by])}. "
    )
    text += (
        f"Crosses later than full ACDER (mean curves): {and_join(slower)}"
        if slower
        else "No ablation crosses later than full ACDER (mean curves)"
    )
    if faster:
        text += f"; no later: {and_join(faster)}"
    if neither:
        text += f"; like full ACDER, not within the budget: {and_join(neither)}"
    # the paper's reading (each ablation slower) is confirmed or contradicted only
    # where the readings' rule separates the two cells
    sep = [c for c in abl if separated(c, acder)]
    agree = [label(c.name) for c in sep if reached(c) > full]
    disagree = [label(c.name) for c in sep if reached(c) < full]
    if agree or disagree:
        said = [f"later, as in the paper: {and_join(agree)}" if agree else ""]
        said.append(
            f"earlier, unlike the paper: {and_join(disagree)}" if disagree else ""
        )
        text += ". Separated from full ACDER by the rule below, " + "; ".join(
            x for x in said if x
        )
    if her is not None and reached(her) is not None:
        beat = [label(c.name) for c in abl if reached(c) < reached(her)]
        text += f". Crosses before DDPG+HER (mean curves): {and_join(beat)}"
    fewer = [c for c in abl if c.n < acder.n]
    if acder.threshold >= 1 and fewer:
        text += (
            f". At a {acder.threshold:.0%} threshold a mean curve crosses only where "
            "every seed is at it at once, so fewer seeds favour a cell: "
            + and_join([f"{label(c.name)} ({count(c.n, 'seed')})" for c in fewer])
            + f" against full ACDER's {acder.n}; the table's per-seed crossings "
            "compare them more fairly"
        )
        common = sorted(set.intersection(*(set(c.seeds) for c in fewer)), key=str)
        same = cell_on_seeds(runs or [], env, "acder", common) if common else None
        if same is not None:
            text += (
                f", and so does full ACDER's mean curve on their seeds "
                f"({', '.join(map(str, common))}) alone: {mean_text(same)}"
            )
    return text + "."


def separated_sentence(cells: list[CellStat], tasks=TASKS) -> str:
    """Which ablations the readings' rule (`report.separated`: each crossing outside
    the other's 95% interval) separates from full ACDER, task by task; a task is left
    out, and named as such, until every planned seed of its ablations and of ACDER has
    ended."""
    by = {(c.env, c.name): c for c in cells}
    parts, waiting, read = [], [], []
    for e in tasks:
        if (e, "acder") not in by or any((e, n) not in by for n in ABLATIONS):
            continue
        rule = {n: separated(by[e, n], by[e, "acder"]) for n in ABLATIONS}
        if None in rule.values():
            waiting.append(task_label(e))
            continue
        parts.append(
            f"on {task_label(e)}: " + and_join([label(n) for n, s in rule.items() if s])
        )
        read.append(e)
    if not parts:
        return "No task has all its ablations finished yet."
    capped = [task_label(e) for e in read if threshold(e) >= 1]
    if capped:
        parts[-1] += (
            f". On {and_join(capped)} the threshold is 100%, where an interval cannot "
            "extend to later crossings: a later crossing always lies outside the "
            "earlier one's interval, so only one side of the rule is tested"
        )
    if not waiting:
        return sentence(parts)
    return (
        f"{sentence(parts)} {and_join(waiting)} "
        f"{'is' if len(waiting) == 1 else 'are'} left out until "
        "the seeds of its ablations and of full ACDER have all ended."
    )
