"""The sentences the book says about the measured cells (chapter 8's prose).

Each function reads `report`'s cells and ratios (CellStat, RatioStat) and says in words
what they show: the verdict on the paper's HER/ACDER ratio, the cells in the order of
their crossings, the readings' rule applied to two cells, the controls (a constant
bonus, (sin, cos) of the angles), the ablations against full ACDER, how far the grid
is. Numbers are written as Table I's cells write them (`table`: the paper's names,
episodes in its unit, the mean-curve text); the statistics themselves are `report`'s.
"""

from __future__ import annotations

import math
from pathlib import Path

from .config import TASK_PRESETS
from .report import (
    ABLATIONS,
    CUT_WHY,
    PAPER_TABLE_I,
    TAIL_EVALUATIONS,
    TASKS,
    CellStat,
    RatioStat,
    cell_on_seeds,
    choose,
    column_tail,
    complete,
    grid_cells,
    paper_epochs,
    seed_level,
    separated,
    threshold,
)
from .table import (
    episodes,
    label,
    mean_text,
    ratio_interval_text,
    ratio_text,
    task_label,
    units,
)
from .words import and_join, count


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


def verdict(rs: list[RatioStat], cells: list[CellStat] | None = None) -> str:
    """Whether the paper's HER/ACDER ratio lies inside our 95% interval, task by task,
    and what that says about its factor of five. With `cells` (the summaries the ratios
    come from), a task whose HER or ACDER cell still has planned seeds to come is named
    with its seed counts and the verdict is said to be provisional. A task whose ratio
    is only bounded below (HER not within budget, `RatioStat.bound`) is said apart: the
    bound, and whether the paper's ratio lies above it (then the runs cannot say) or not
    (then ACDER's advantage is larger here)."""
    text, partial = _verdict(rs), _still_training(rs, cells or [])
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
            counts = [
                f"{name} {c.done} of {c.planned if c.planned is not None else c.done}"
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


def _bound_sentence(r: RatioStat) -> str:
    """What a ratio bounded below says against the paper's."""
    head = (
        f"On {task_label(r.env)} {_her_not_within(r)} only known to be more than "
        f"{r.bound:.1f}"
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


def _verdict(rs: list[RatioStat]) -> str:
    bounded = " ".join(_bound_sentence(r) for r in rs if _bounded(r))
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
    return f"{text} {bounded}" if bounded else text


def sentence(parts: list[str]) -> str:
    """Clauses joined by '; ' as one sentence: first letter upper case,
    a full stop at the end."""
    text = "; ".join(p for p in parts if p)
    return (
        text[:1].upper() + text[1:] + ("." if text and not text.endswith(".") else "")
    )


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
    texts: `fractional`, the numbers that are no whole number of the paper's epochs of
    400 episodes ('HER 1,000 (2.5 epochs)'); `in_ours`, every number in our epochs of
    `episodes_per_epoch` ('12.5, 5 and 15'); `over`, how many of those lie past
    `budget` epochs."""
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


def grid_state(cells: list[CellStat]) -> str:
    """How far the grid is: cells with a finished seed, seeds finished of those planned
    (cells outside the grid, such as protocol v1's acder-baselines-clip, are not
    counted)."""
    grid = set(grid_cells())
    cells = [c for c in cells if (c.env, c.name) in grid]
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
    return text + "."


def bonus_sentence(
    runs: list[dict], envs, names=("her-icm", "acder"), last: int = TAIL_EVALUATIONS
) -> str:
    """How large the curiosity bonus is by the end, per task: the mean r_i of the
    minibatches (progress.csv's r_int_mean) over each seed's `last` evaluations,
    averaged over seeds (`report.column_tail`), beside the clip eta of Eq. 4. A value
    near eta says most transitions get the clip: nearly a constant added to every
    reward, not a ranking of states by novelty. A cell with seeds not ended yet (a run
    whose `ended` is None) is read as far as they got, and said to be: "0.67 so far
    (2 of its 2 seeds unfinished)"."""
    parts = []
    for env in envs:
        vals = [(n, column_tail(runs, env, n, "r_int_mean", last)) for n in names]
        vals = [
            f"{label(n)} {v:.2f}{_so_far(runs, env, n)}"
            for n, v in vals
            if v is not None
        ]
        if vals:
            eta = TASK_PRESETS[env]["eta"]
            parts.append(f"on {task_label(env)} (clip η = {eta}): {', '.join(vals)}")
    return sentence(parts) or "No curiosity method has an evaluation yet."


def _so_far(runs: list[dict], env: str, name: str) -> str:
    """' so far (1 of its 3 seeds unfinished)' for a cell with runs not ended (`ended`
    None: training or interrupted), '' otherwise."""
    mine = [r for r in runs if r["env"] == env and r["name"] == name]
    k = sum("ended" in r and r["ended"] is None for r in mine)
    return f" so far ({k} of its {count(len(mine), 'seed')} unfinished)" if k else ""


def control_sentence(her: CellStat, icm: CellStat, bonus: CellStat) -> str:
    """The curiosity control read off the runs (experiments/constant-bonus/): the
    crossings of DDPG+HER, DDPG+HER+ICM and DDPG+HER with a constant bonus
    (`Config.reward_bonus`) in order, the share of ICM's gain over HER that the constant
    alone gives, (HER - bonus) / (HER - ICM) in episodes, and where the constant's
    crossing lies against the other two's 95% intervals."""
    cells = [her, icm, bonus]
    text = f"Ordered by the mean curve: {order_sentence(cells)}."
    if reached(bonus) == math.inf and None not in (her.crossing, icm.crossing):
        gain = her.crossing - icm.crossing
        saved = (
            f" none of the {units(icm, gain)} episodes {label(icm.name)} saves over "
            f"{label(her.name)}"
            if gain > 0
            else f" nothing ({label(icm.name)} is no faster than {label(her.name)})"
        )
        # a crossing beyond the budget lies inside an interval only if that interval
        # reaches beyond the budget too
        inside = [c.high is not None and math.isinf(c.high) for c in (her, icm)]
        rule = {
            (True, False): "the shift does not explain ICM's gain, which is its own",
            (False, True): "the shift explains ICM's gain",
        }.get(tuple(inside), "the rule fixed before its runs leaves it open")
        places = " and ".join(
            f"{'inside' if i else 'beyond'} {label(c.name)}'s 95% interval"
            for i, c in zip(inside, (her, icm))
        )
        return text + (
            f" The constant's mean curve does not reach {bonus.threshold:.0%} within "
            f"its budget, so the constant alone saves{saved}. Beyond the budget, its "
            f"crossing lies {places}: {rule}."
        )
    if any(c.crossing is None for c in cells):
        return text + " The three can be compared once each mean curve has crossed."
    gain = her.crossing - icm.crossing
    if gain <= 0:
        return text + (
            f" {label(icm.name)} is no faster than {label(her.name)} here, so there "
            "is no gain of curiosity for the constant to explain."
        )
    saved = her.crossing - bonus.crossing
    text += (
        f" Of {label(icm.name)}'s {units(icm, gain)} episodes saved over "
        f"{label(her.name)}, the constant alone saves {units(bonus, saved)}: "
        f"{saved / gain:.0%}."
    )

    def against(c: CellStat) -> str:
        inside = c.low is not None and c.low <= bonus.crossing <= c.high
        return f"{'inside' if inside else 'outside'} {label(c.name)}'s"

    text += f" Its crossing lies {against(her)} 95% interval and {against(icm)}" + (
        f" ({bonus.done} of {count(bonus.planned, 'seed')} finished)."
        if bonus.planned and bonus.done < bonus.planned
        else "."
    )
    return text


def sincos_sentence(acder: CellStat, sincos: CellStat) -> str:
    """The (sin, cos) experiment read off the runs by the rule its README fixed before
    they started (experiments/sicm-sincos/): the two mean curves' crossings in order,
    then `report.separated` (each crossing outside the other's 95% interval) once both
    cells have all their planned seeds."""
    text = f"Ordered by the mean curve: {order_sentence([acder, sincos])}."
    if reached(sincos) == math.inf and complete(acder) and acder.crossing is not None:
        # the rule with a crossing beyond the budget: outside ACDER's interval unless
        # that reaches beyond the budget too; ACDER's outside (sin, cos)'s unless that
        # starts at or before ACDER's crossing
        apart = (
            acder.high is not None
            and not math.isinf(acder.high)
            and (sincos.low is None or acder.crossing < sincos.low)
        )
        return text + (
            f" With (sin, cos) the mean curve does not reach {sincos.threshold:.0%} "
            "within its budget; "
            + (
                f"the runs separate them: {label(acder.name)} crosses first."
                if apart
                else "the runs do not separate them: a crossing lies inside the "
                "other's 95% interval."
            )
        )
    sep = separated(acder, sincos)
    if sep is None:
        left = (
            f" ({sincos.done} of {count(sincos.planned, 'seed')} of "
            f"{label(sincos.name)} finished)"
            if sincos.planned
            else ""
        )
        return text + (
            " The rule is applied once both cells have all their planned seeds and a "
            f"crossing with an interval{left}."
        )
    if not sep:
        return text + (
            " The runs do not separate them: a crossing lies inside the other's 95% "
            "interval."
        )
    first = min((acder, sincos), key=lambda c: c.crossing)
    return text + f" The runs separate them: {label(first.name)} crosses first."


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
        chain += f"{label(c.name)} {units(c, c.crossing)}"
    parts = [chain] if crossed else []
    parts += [
        f"{label(c.name)} {mean_text(c)}" for c in cells if c.crossing is None and c.n
    ]
    unrun = [label(c.name) for c in cells if not c.n]
    if unrun:
        parts.append("not run yet: " + ", ".join(unrun))
    return "; ".join(parts)


def readings_decisions(norm: CellStat, raw: CellStat, goal: CellStat) -> dict:
    """The readings' two decisions in words, as experiments/readings/README.md fixes
    them: (a) `norm` against (b) `raw`, the paper's eta values deciding where the runs
    do not separate them; then the winner against (c) `goal`, the default (a fresh
    goal) deciding likewise. dict(choice, goal_choice: `choice_sentence`s; decided:
    whether the second rule has been applied)."""
    chosen, _ = choose(norm, raw, "sicm-raw")
    winner = raw if chosen in (None, "sicm-raw") else norm
    return dict(
        choice=choice_sentence(norm, raw, "sicm-raw", "the paper's eta values"),
        goal_choice=choice_sentence(
            winner, goal, winner.name, "the default, a fresh goal"
        ),
        decided=choose(winner, goal, winner.name)[0] is not None,
    )


def choice_sentence(a: CellStat, b: CellStat, fallback: str, why: str) -> str:
    """What the readings' rule (`report.choose`) makes of `a` and `b`, in words: the
    two crossings, which lies inside the other's interval, the setting chosen
    (`fallback`, for `why`, where the runs do not separate them)."""
    chosen, sep = choose(a, b, fallback)
    if chosen is not None and sep is None:  # decided by b's bound (report.choose)
        n = max(b.planned or 0, b.n)
        level = seed_level(n, b.threshold)
        when = (
            "within its budget"
            if math.isinf(b.earliest)
            else f"before {units(b, b.earliest)} episodes"
        )
        return (
            f"The mean curve of {label(b.name)} cannot cross {when}: a mean of "
            f"{count(n, 'seed')} reaches {b.threshold:.0%} only where every seed is "
            f"at {level:.0%} "
            f"or more, and its seeds so far get there no earlier. {label(a.name)} "
            f"crossed at {units(a, a.crossing)}, so {label(b.name)} cannot cross "
            f"first, whatever its {count(n - b.done, 'seed')} still to finish "
            f"{'does' if n - b.done == 1 else 'do'}, and the rule keeps "
            f"{label(a.name)}."
        )
    if chosen is None:
        return (
            f"The rule cannot be applied yet: {label(a.name)} or {label(b.name)} "
            "has no mean-curve crossing with an interval."
        )

    def span(c: CellStat) -> str:
        low = episodes(c.paper_units(c.low))
        if math.isinf(c.high):
            return f"{low} or later"
        return f"{low} – {episodes(c.paper_units(c.high))}"

    def where(c: CellStat, other: CellStat) -> str:
        inside = other.low <= c.crossing <= other.high
        return (
            f"{units(c, c.crossing)} {'inside' if inside else 'outside'} {span(other)}"
        )

    said = (
        f"The mean curves cross at {units(a, a.crossing)} episodes ({label(a.name)}) "
        f"and {units(b, b.crossing)} ({label(b.name)}); against the other's 95% "
        f"interval, {where(a, b)} and {where(b, a)}"
    )
    if not sep:
        return (
            f"{said}: the runs do not separate them, so the rule falls back on {why}: "
            f"{label(chosen)}."
        )
    return f"{said}: the runs separate them, and {label(chosen)} crosses first."


def reached(c: CellStat) -> float | None:
    """Where a cell's mean curve reaches the threshold, for comparing cells: its
    crossing (epochs), inf for a cell whose seeds have all ended without one (later
    than any crossing), None while that is not known."""
    if c.crossing is not None:
        return c.crossing
    return math.inf if c.why == "not within budget" and complete(c) else None


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
        f"Slower than full ACDER, as in the paper: {and_join(slower)}"
        if slower
        else "No ablation is slower than full ACDER"
    )
    if faster:
        text += f"; as fast or faster, unlike the paper: {and_join(faster)}"
    if neither:
        text += f"; like full ACDER, not within the budget: {and_join(neither)}"
    if her is not None and reached(her) is not None:
        beat = [label(c.name) for c in abl if reached(c) < reached(her)]
        text += f". Faster than DDPG+HER: {and_join(beat)}"
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
    parts, waiting = [], []
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
    if not parts:
        return "No task has all its ablations finished yet."
    if not waiting:
        return sentence(parts)
    return (
        f"{sentence(parts)} {and_join(waiting)} "
        f"{'is' if len(waiting) == 1 else 'are'} left out until "
        "the seeds of its ablations and of full ACDER have all ended."
    )


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


def beside_paper_sentence(cells: list[CellStat], tasks=TASKS) -> str:
    """Our HER and ACDER mean-curve crossings beside the paper's numbers, for each task
    where both cells are read (`reached`: crossed, or every seed ended without a
    crossing, which Table I's text says: "not within budget (100 epochs)")."""
    by = {(c.env, c.name): c for c in cells}
    parts = []
    for e in tasks:
        h, a = by.get((e, "her")), by.get((e, "acder"))
        if h is None or a is None or None in (reached(h), reached(a)):
            continue
        parts.append(
            f"on {task_label(e)}, DDPG+HER {mean_text(h)} against the paper's "
            f"{h.paper:,} and DDPG+ACDER {mean_text(a)} against its {a.paper:,}"
        )
    return sentence(parts) or (
        "No task has both HER's and ACDER's mean curves crossed or ended yet."
    )
