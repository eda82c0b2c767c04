"""The sentences the book says about Table I and Fig. 4 (chapter 8's prose).

Each function reads `report`'s cells and ratios (CellStat, RatioStat) and says in words
what they show: the verdict on the paper's HER/ACDER ratio, the cells in the order of
their crossings, whether ACDER crosses first, our crossings beside the paper's, how far
the grid is. Numbers are written as Table I's cells write them (`table`: the paper's
names, episodes in its unit, the mean-curve text); the statistics themselves are
`report`'s. The ablations of Fig. 5 are `ablation_findings`', the experiments beside the
grid (a constant bonus, (sin, cos) of the angles, the readings) `experiment_findings`';
both order cells and place a cell that never crossed with `order_sentence` and `reached`
from here.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from acder_lite.stats.report import (
    CUT_WHY,
    FIG4_METHODS,
    PAPER_TABLE_I,
    SUCCESS_TOL,
    TASKS,
    CellStat,
    RatioStat,
    complete,
    grid_cells,
    learning_curves,
    paper_epochs,
    separated,
    threshold,
)
from acder_lite.runs.table import (
    METHOD_LABELS,
    TASK_LABELS,
    episodes,
    label,
    mean_text,
    ratio_interval_text,
    ratio_text,
    task_label,
    units,
)
from acder_lite.words import and_join, count, sentence


def ratio_sentence(r: RatioStat) -> str:
    """One sentence on the HER/ACDER ratio of one task. Where HER's mean curve ended
    without crossing but ACDER's crossed, the ratio is only bounded below (`r.bound`,
    HER's budget over ACDER's crossing), and the sentence says so."""
    paper = "" if r.paper is None else f"; the paper's is {r.paper:.1f}"
    where = task_label(r.env)
    if r.ours is None and r.bound is None:
        return f"on {where} there is no HER/ACDER ratio ({r.why}){paper}"
    if r.ours is None:
        return (
            f"on {where} {_her_not_within(r)} only bounded: more than "
            f"{r.bound:.1f}{ratio_interval_text(r)}{paper}"
        )
    return f"on {where} our HER/ACDER ratio is {ratio_text(r)}{paper}"


def verdict(
    rs: list[RatioStat],
    cells: list[CellStat] | None = None,
    coverage: dict[int, float] | None = None,
) -> str:
    """Whether the paper's HER/ACDER ratio lies inside our 95% interval, task by task,
    and what that says about its factor of five. With `cells` (the summaries the ratios
    come from), a task whose HER or ACDER cell still has planned seeds to come is named
    with its seed counts and the verdict is said to be provisional. A task whose ratio
    is only bounded below (HER not within budget, `RatioStat.bound`) is said apart: the
    bound, and whether the paper's ratio lies above it (then the runs cannot say) or not
    (then ACDER's advantage is larger here). On a task whose threshold is 100%, no
    resample crosses later than the cell's own mean curve, so the ratio's interval is
    capped (`_capped_sentence`); `coverage` (seeds -> `report.bootstrap_coverage`) says
    how often such an interval covers with that many seeds. Plain text, and no "above"
    or "below": the book's introduction quotes it away from chapter 8."""
    by = {(c.env, c.name): c for c in cells or []}
    text, partial = _verdict(rs, by, coverage or {}), _still_training(rs, cells or [])
    if not partial:
        return text
    return (
        f"So far ({'; '.join(partial)}): {text[:1].lower()}{text[1:]} "
        "Those cells are still training, so this can change."
    )


def _still_training(rs: list[RatioStat], cells: list[CellStat]) -> list[str]:
    """'Push: HER 3 of 5 seeds, ACDER 3 of 5' for each task with a ratio whose HER or
    ACDER cell has not ended all its planned seeds (`report.complete`)."""
    by = {(c.env, c.name): c for c in cells}
    out = []
    for r in rs:
        her, acder = by.get((r.env, "her")), by.get((r.env, "acder"))
        if not (_read(r) or _bounded(r)) or her is None or acder is None:
            continue
        if not (complete(her) and complete(acder)):
            # of the seeds planned, or without a plan the seeds read (trap: not `done`,
            # which would say "2 of 2" of a cell whose third seed is still training)
            counts = [
                f"{name} {c.done} of {max(c.planned or 0, c.n)}"
                for name, c in (("HER", her), ("ACDER", acder))
            ]
            seeds = "seed" if counts[0].endswith(" of 1") else "seeds"
            out.append(f"{task_label(r.env)}: {counts[0]} {seeds}, {counts[1]}")
    return out


def _read(r: RatioStat) -> bool:
    """Whether the verdict reads this task: our ratio, its interval and the paper's."""
    return not (r.ours is None or r.paper is None or r.low is None or math.isnan(r.low))


def _bounded(r: RatioStat) -> bool:
    """Whether the task's ratio is only bounded below (HER's mean curve ended without
    crossing, ACDER's crossed), with the paper's ratio to compare it to."""
    return r.ours is None and r.bound is not None and r.paper is not None


def _her_not_within(r: RatioStat) -> str:
    """Why a task's ratio is a bound, up to what is known of it."""
    return (
        f"DDPG+HER's mean curve does not reach {threshold(r.env):.0%} within its "
        "budget, so our HER/ACDER ratio is"
    )


def _bound_sentence(r: RatioStat, by: dict | None = None) -> str:
    """What a ratio bounded below says against the paper's: the bound on these seeds,
    the ratio's interval from below and, where every HER seed crossed on its own, the
    median of their crossings (`by`: the cells by (task, method))."""
    her, acder = (by or {}).get((r.env, "her")), (by or {}).get((r.env, "acder"))
    notes = []
    if her is not None and acder is not None:
        notes.append(f"{her.n} of DDPG+HER, {acder.n} of DDPG+ACDER")
    if r.low is not None and math.isfinite(r.low):
        notes.append(f"95% interval from {r.low:.1f}")
    if her is not None and her.n and her.k == her.n and her.seed_median is not None:
        notes.append(
            f"each DDPG+HER seed crossed on its own, at a median of "
            f"{units(her, her.seed_median)} episodes"
        )
    head = (
        f"On {task_label(r.env)} {_her_not_within(r)} bounded below by "
        f"{r.bound:.1f}" + (f" on these seeds ({'; '.join(notes)})" if notes else "")
    )
    if r.paper > r.bound:
        return head + (
            f"; the paper's {r.paper:.1f} lies above that bound, and the runs cannot "
            "say whether ACDER's advantage there is as large as the paper's."
        )
    return head + (
        f", which is above the paper's {r.paper:.1f}: there ACDER's advantage over HER "
        "is larger here than in the paper."
    )


def _capped_sentence(r: RatioStat, by: dict, coverage: dict[int, float]) -> str:
    """For a task read by the verdict whose threshold is 100% (a mean curve reaches it
    only where every seed it averages is at it, so no resample crosses later than the
    cell's own mean curve): the largest ratio a resample pair can give, HER's crossing
    over ACDER's fastest seed (a resample of that seed alone), the per-seed ratios, and
    the interval's coverage with that many seeds. '' elsewhere."""
    her, acder = by.get((r.env, "her")), by.get((r.env, "acder"))
    if her is None or acder is None or her.threshold < 1 or her.crossing is None:
        return ""
    fastest = [x for x in acder.seed_crossings if x is not None and x > 0]
    text = (
        f"On {task_label(r.env)} the threshold is {her.threshold:.0%}: no resample's "
        "mean curve crosses later than the cell's own, so the interval cannot extend "
        "to later crossings"
    )
    if fastest:
        cap = her.crossing / min(fastest)
        text += (
            f", and it could not contain a ratio above about {cap:.1f} (DDPG+HER's "
            "crossing over DDPG+ACDER's fastest seed)"
        )
        if r.paper is not None and cap < r.paper:
            text += f", below the paper's {r.paper:.1f}"
    if None not in (r.seed_ratio, r.seed_mean_ratio):
        text += (
            f". The per-seed ratios ({r.seed_ratio:.1f} of the medians, "
            f"{r.seed_mean_ratio:.1f} of the means) carry the verdict there as much as "
            "the interval"
        )
    ns = sorted({her.n, acder.n})
    if all(n in coverage for n in ns):
        said = " and ".join(f"{coverage[n]:.0%}" for n in ns)
        text += (
            f"; with {' and '.join(map(str, ns))} seeds such an interval covers "
            f"about {said} of the time (measured on synthetic seeds by "
            "report.bootstrap_coverage), not 95%"
        )
    return text + "."


def _verdict(
    rs: list[RatioStat], by: dict | None = None, coverage: dict | None = None
) -> str:
    by, coverage = by or {}, coverage or {}
    bounded = " ".join(_bound_sentence(r, by) for r in rs if _bounded(r))
    capped = " ".join(
        filter(None, (_capped_sentence(r, by, coverage) for r in rs if _read(r)))
    )
    read = [task_label(r.env) for r in rs if _read(r)]
    where = {"inside": [], "above": [], "below": []}
    for r in rs:
        if not _read(r):
            continue
        key = (
            "inside"
            if r.low <= r.paper <= r.high
            else "above"
            if r.paper > r.high
            else "below"
        )
        where[key].append(
            f"{task_label(r.env)} ({r.paper:.1f} against our {r.ours:.1f})"
        )
    if not any(where.values()):
        if bounded:
            return bounded
        return (
            "We cannot say yet whether the paper's factor of five reproduces: no task "
            "has both HER's and ACDER's mean curves past the threshold."
        )
    said = [f"{key} our 95% interval on {and_join(v)}" for key, v in where.items() if v]
    text = "The paper's HER/ACDER ratio lies " + "; ".join(said) + ". "
    # with a bounded task beside them, the tasks read are named: "every task with a
    # ratio" would take in the bounded one, which says something else
    scope = f"On {and_join(read)}" if bounded else "On every task with a ratio"
    there = " there" if bounded else ""
    if not where["inside"] and not where["below"]:
        text += (
            f"{scope}, ACDER's advantage over HER is smaller here than in the paper: "
            f"its factor of five does not reproduce{there}."
        )
    elif not where["above"] and not where["below"]:
        text += (
            "Our runs are consistent with the paper's factor "
            f"{scope[:1].lower()}{scope[1:]}."
        )
    else:
        text += "The paper's factor reproduces on some tasks and not on others."
    if capped:
        text += f" {capped}"
    return f"{text} {bounded}" if bounded else text


def after_colon(text: str) -> str:
    """A sentence of this module, `ablation_findings` or `experiment_findings` as it
    reads after a colon of the book's prose: its first word in lower case ('On Reach
    ...' -> 'on Reach ...'), unless that word is a name or an acronym ('DDPG+ACDER',
    'ACDER, ...', 'S-ICM' keep theirs)."""
    word = text.split(" ", 1)[0].rstrip(",:;.")
    names = {
        x.split(" ", 1)[0] for x in [*TASK_LABELS.values(), *METHOD_LABELS.values()]
    }
    ordinary = word[:1].isupper() and (word[1:].islower() or word == "A")
    return text[:1].lower() + text[1:] if ordinary and word not in names else text


def cut_texts(cells: list[CellStat]) -> tuple[str, str]:
    """How many runs were cut before their budget and how many cells' mean curves end,
    uncrossed, where one was (protocol v1): ('3 of its 20 runs', '1 of its 8 cells')."""
    runs = f"{sum(c.cut for c in cells)} of its {count(sum(c.n for c in cells), 'run')}"
    unread = sum(c.why == CUT_WHY for c in cells)
    return runs, f"{unread} of its {count(len(cells), 'cell')}"


def range_text(values) -> str:
    """'3', '3 to 5' for the distinct values; 'none' for no values."""
    v = sorted(set(values))
    return "none" if not v else str(v[0]) if len(v) == 1 else f"{v[0]} to {v[-1]}"


def paper_epochs_texts(env: str, episodes_per_epoch: float, budget: float) -> dict:
    """Table I's numbers on `env` in epochs (`report.paper_epochs`), as the book's
    texts: `fractional`, the numbers that are no whole number of the paper's epochs
    of 400 episodes ('DDPG+HER 2,240 (5.6 epochs)'); `in_ours`, every number in our
    epochs of `episodes_per_epoch` ('12.5, 5 and 15'); `over`, how many of those lie
    past `budget` epochs."""
    odd = {m: e for m, e in paper_epochs(env).items() if e != int(e)}
    ours = paper_epochs(env, episodes_per_epoch).values()
    return dict(
        fractional=and_join(
            [
                f"{label(m)} {PAPER_TABLE_I[m][env]:,} ({e:g} epochs)"
                for m, e in odd.items()
            ]
        ),
        in_ours=and_join([f"{e:g}" for e in ours]),
        over=str(sum(e > budget for e in ours)),
    )


def copies_sentence(runs: list[dict], root: str | Path | None = None) -> str:
    """Which runs the sweep copied from elsewhere (a plan group's `same_as`), by cell
    and source folder (relative to `root` if given), as one sentence; "" if none
    was copied."""
    by_cell: dict[tuple, list] = {}
    for r in runs:
        if r.get("same_as"):
            source = Path(r["same_as"]).parent
            if root is not None and source.is_relative_to(root):
                source = source.relative_to(root)
            key = (r["env"], r["name"], str(source))
            by_cell.setdefault(key, []).append(r["seed"])
    return sentence(
        [
            f"{label(name)}'s seed{'s' if len(seeds) > 1 else ''} "
            f"{and_join([str(s) for s in sorted(seeds)])} on {task_label(env)} "
            f"{'are the runs' if len(seeds) > 1 else 'is the run'} of `{source}`"
            for (env, name, source), seeds in sorted(by_cell.items())
        ]
    )


def _in_grid(cells: list[CellStat]) -> list[CellStat]:
    """The cells of Table I and Fig. 5 (`report.grid_cells`), in their order."""
    grid = set(grid_cells())
    return [c for c in cells if (c.env, c.name) in grid]


def grid_state(cells: list[CellStat]) -> str:
    """How far the grid is: cells with a finished seed, seeds finished of those planned
    (cells outside the grid, such as protocol v1's acder-baselines-clip, are not
    counted)."""
    cells = _in_grid(cells)
    started = sum(c.done > 0 for c in cells)
    done, unfinished = sum(c.done for c in cells), sum(c.unfinished for c in cells)
    planned = sum(c.planned or 0 for c in cells)
    text = (
        f"{started} of the {count(len(cells), 'cell')} of Table I and Fig. 5 (the "
        f"three tasks) {'has' if started == 1 else 'have'} at least one finished seed"
    )
    have = "has" if done == 1 else "have"
    text += (
        f"; {done} of the {planned} planned seeds {have} finished"
        if planned
        else f"; {count(done, 'seed')} {have} finished"
    )
    if unfinished:
        text += (
            f", {unfinished} more {'is' if unfinished == 1 else 'are'} "
            "training or interrupted"
        )
    held = sum(bool(c.hold) and c.n < (c.planned or 0) for c in cells)
    if held:
        text += (
            f", and {count(held, 'cell')} {'is' if held == 1 else 'are'} on hold "
            "until the readings below are in"
        )
    return text + "." + _to_come(cells)


def grid_caveat(cells: list[CellStat]) -> str:
    """What `grid_state`'s counts mean for the numbers that follow: final once every
    planned seed of the grid's cells has ended, else that a cell still to come says so
    and may change. Trap: a fixed sentence in the chapter went on promising cells "still
    to come" after the last run had finished."""
    cells = _in_grid(cells)
    if cells and not _to_come(cells) and all(c.planned for c in cells):
        return (
            "Every planned seed of the grid has finished, so no number below waits on "
            "a run still to come."
        )
    return (
        'A cell still to come says so in Table I ("not run yet", or how many of its '
        "seeds are still training), and its numbers may change as they finish."
    )


def _to_come(cells: list[CellStat]) -> str:
    """' Still to come: on Pick&Place, DDPG+HER+ICM (2 seeds unfinished), and
    DDPG+HER+PER and ... (not started).' from the cells with seeds not ended or planned
    seeds not started; '' when there are none."""
    parts = []
    for env in dict.fromkeys(c.env for c in cells):
        here = [c for c in cells if c.env == env]
        going = [
            f"{label(c.name)} ("
            + ", ".join(
                x
                for x in (
                    f"{count(c.unfinished, 'seed')} unfinished" if c.unfinished else "",
                    f"{(c.planned or 0) - c.n} not started"
                    if (c.planned or 0) > c.n
                    else "",
                )
                if x
            )
            + ")"
            for c in here
            if c.n and (c.unfinished or (c.planned or 0) > c.n)
        ]
        fresh = [label(c.name) for c in here if not c.n and c.planned]
        if fresh:
            going.append(f"{and_join(fresh)} (not started)")
        if going:
            parts.append(f"on {task_label(env)}, " + ", and ".join(going))
    return f" Still to come: {'; '.join(parts)}." if parts else ""


def order_sentence(cells: list[CellStat]) -> str:
    """The cells ordered by their mean curve's crossing (fewest episodes first); then
    those without one, with why ("not run yet: A, B" in one clause)."""
    crossed = sorted(
        (c for c in cells if c.crossing is not None), key=lambda c: c.crossing
    )
    chain = ""
    for i, c in enumerate(crossed):  # equal crossings are ties, not an order
        if i:
            chain += " = " if c.crossing == crossed[i - 1].crossing else " < "
        chain += f"{label(c.name)} {units(c, c.crossing)}{_unfinished(c)}"
    parts = [chain] if crossed else []
    parts += [
        f"{label(c.name)} {mean_text(c)}{_unfinished(c)}"
        for c in cells
        if c.crossing is None and c.n
    ]
    unrun = [label(c.name) for c in cells if not c.n]
    if unrun:
        parts.append("not run yet: " + ", ".join(unrun))
    return "; ".join(parts)


def _unfinished(c: CellStat) -> str:
    """' (2 of 2 seeds unfinished)' for a cell with seeds not ended (training or
    interrupted): its crossing may still move. '' otherwise."""
    if not c.unfinished:
        return ""
    return f" ({c.unfinished} of {count(c.n, 'seed')} unfinished)"


def unheld_sentence(cells: list[CellStat], runs: list[dict], share: float = 0.5) -> str:
    """Mean-curve crossings that do not hold: for each cell whose mean curve crosses and
    then lies below the threshold at `share` or more of its later evaluations (where
    every seed has a value), "<method>'s mean curve on <task> reaches 95% at epoch X and
    is below it at N of its M later evaluations". '' where no crossing is like that."""
    curves = learning_curves(runs)
    parts = []
    for c in cells:
        m = curves.get((c.env, c.name))
        if c.crossing is None or m is None:
            continue
        later = (m.x > c.crossing) & ~np.isnan(m.mean)
        below = int((later & (m.mean < c.threshold - SUCCESS_TOL)).sum())
        if later.any() and below >= share * later.sum():
            parts.append(
                f"{label(c.name)}'s mean curve on {task_label(c.env)} reaches "
                f"{c.threshold:.0%} at epoch {c.crossing:.1f}{_unfinished(c)} and is "
                f"below it at {below} of its {int(later.sum())} later evaluations"
            )
    return sentence(parts)


def first_sentence(cells: list[CellStat], tasks=TASKS, names=FIG4_METHODS) -> str:
    """Per task, whether DDPG+ACDER's mean curve crosses first among `names` in our
    runs; a method that crosses no later is named, with whether the readings' rule
    (`report.separated`) separates it from ACDER; cells still training or not run yet
    are named, as what can still change it."""
    parts = []
    for e in tasks:
        cs = {c.name: c for c in cells if c.env == e and c.name in names}
        a = cs.get("acder")
        if a is None or not cs:
            continue
        pending = [
            f"{label(c.name)} {'not run yet' if not c.n else 'unfinished'}"
            for c in cs.values()
            if not c.n or c.unfinished
        ]
        tail = f", with {and_join(pending)}" if pending else ""
        if reached(a) is None or a.crossing is None:
            parts.append(f"on {task_label(e)} DDPG+ACDER has not crossed{tail}")
            continue
        before = [
            c
            for c in cs.values()
            if c is not a and c.crossing is not None and c.crossing <= a.crossing
        ]
        if not before:
            parts.append(f"on {task_label(e)} DDPG+ACDER comes first{tail}")
            continue

        def how(c: CellStat) -> str:
            sep = separated(c, a)
            rule = (
                "the rule cannot be applied yet"
                if sep is None
                else "separated by the rule"
                if sep
                else "not separated by the rule"
            )
            when = "at the same point" if c.crossing == a.crossing else "earlier"
            return f"{label(c.name)} crosses {when} ({rule})"

        parts.append(
            f"on {task_label(e)} DDPG+ACDER does not come first: "
            f"{and_join([how(c) for c in before])}{tail}"
        )
    return sentence(parts) or "No task has a DDPG+ACDER cell yet."


def reached(c: CellStat) -> float | None:
    """Where a cell's mean curve reaches the threshold, for comparing cells: its
    crossing (epochs), inf for a cell whose seeds have all ended without one (later
    than any crossing), None while that is not known."""
    if c.crossing is not None:
        return c.crossing
    return math.inf if c.why == "not within budget" and complete(c) else None


def seed_ratio_sentence(rs: list[RatioStat]) -> str:
    """HER / ACDER read per seed (the ratio of the seeds' median crossings, then of
    their means) beside the paper's, for each task where both can be read."""
    parts = [
        f"on {task_label(r.env)} {r.seed_ratio:.1f} and {r.seed_mean_ratio:.1f}, "
        f"against the paper's {r.paper:.1f}"
        for r in rs
        if None not in (r.seed_ratio, r.seed_mean_ratio, r.paper)
    ]
    return "; ".join(parts) or "not readable yet on any task"


def _paper_place(c: CellStat) -> str:
    """' (inside our 95% interval, 8,960 – 11,120)', ' (above ...)', ' (below ...)':
    where Table I's number lies against the cell's interval, both in Table I's unit;
    '' without a paper number or an interval."""
    if c.paper is None or c.low is None or c.high is None or math.isnan(c.low):
        return ""
    lo, hi = c.paper_units(c.low), c.paper_units(c.high)
    where = "inside" if lo <= c.paper <= hi else "above" if c.paper > hi else "below"
    if math.isinf(lo):  # every resample beyond the budget
        span = episodes(lo)
    elif math.isinf(hi):
        span = f"{episodes(lo)} or later"
    else:
        span = f"{episodes(lo)} – {episodes(hi)}"
    return f" ({where} our 95% interval, {span})"


def beside_paper_sentence(cells: list[CellStat], tasks=TASKS) -> str:
    """Our HER and ACDER mean-curve crossings beside the paper's numbers, for each task
    where both cells are read (`reached`: crossed, or every seed ended without a
    crossing, which Table I's text says: "not within budget (100 epochs)"), each with
    where the paper's number lies against our 95% interval (`_paper_place`)."""
    by = {(c.env, c.name): c for c in cells}
    parts = []
    for e in tasks:
        h, a = by.get((e, "her")), by.get((e, "acder"))
        if h is None or a is None or None in (reached(h), reached(a)):
            continue
        parts.append(
            f"on {task_label(e)}, DDPG+HER {mean_text(h)} against the paper's "
            f"{h.paper:,}{_paper_place(h)} and DDPG+ACDER {mean_text(a)} against its "
            f"{a.paper:,}{_paper_place(a)}"
        )
    return sentence(parts) or (
        "No task has both HER's and ACDER's mean curves crossed or ended yet."
    )
