"""The sentences chapter 8 says about the experiments beside the grid (experiments/).

Each experiment tests one setting against the grid's cells by a rule its README fixed
before the runs, and each function here reads `report`'s cells (CellStat) of one and
says in words what the rule makes of them: the constant-bonus control
(experiments/constant-bonus/: `bonus_sentence`, how large the curiosity bonus is by the
end, read off the grid's own runs; `control_sentence` and `control_found`, the constant
alone against DDPG+HER and DDPG+HER+ICM), the (sin, cos) run (experiments/sicm-sincos/:
`sincos_sentence`) and the readings of S-ICM's input (experiments/readings/:
`readings_decisions` and `choice_sentence`, the readings' rule `report.choose` in
words). The cells in order of their crossings and where a cell that never crossed
stands are `findings`' (`order_sentence`, `reached`); numbers are written as Table I's
cells write them (`table`).

Traps: a cell whose seeds all ended without a crossing is later than every crossing
(`findings.reached`), and its crossing, beyond the budget, lies inside another cell's
interval only if that interval reaches beyond the budget too. A rule is applied only
once every planned seed of its cells has ended; until then a cell is read as far as it
got, and said to be. `choice_sentence` can decide early where the challenger's own
bound (`report.choose`, `CellStat.earliest`) says it cannot cross first.
"""

from __future__ import annotations

import math

from acder_lite.config import TASK_PRESETS
from acder_lite.book.findings import order_sentence, reached
from acder_lite.stats.report import (
    TAIL_EVALUATIONS,
    CellStat,
    choose,
    column_tail,
    complete,
    seed_level,
    separated,
)
from acder_lite.runs.table import episodes, label, task_label, units
from acder_lite.words import and_join, count, sentence


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
        eta = TASK_PRESETS[env]["eta"]
        vals = [
            f"{label(n)} {v:.2g} ({v / eta:.0%} of η){_so_far(runs, env, n)}"
            for n, v in vals
            if v is not None
        ]
        if vals:
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
        }.get(tuple(inside), "")
        places = " and ".join(
            f"{'inside' if i else 'beyond'} {label(c.name)}'s 95% interval"
            for i, c in zip(inside, (her, icm))
        )
        text += (
            f" The constant's mean curve does not reach {bonus.threshold:.0%} within "
            f"its budget, so the constant alone saves{saved}. Beyond the budget, its "
            f"crossing lies {places}"
        )
        if rule:
            return text + f": {rule}. {control_found(her, icm, bonus)}".rstrip()
        return text + f". {control_found(her, icm, bonus, open_rule=True)}".rstrip()
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
    found = control_found(her, icm, bonus)
    return f"{text} {found}" if found else text


def _seed_values(c: CellStat) -> list[float] | None:
    """A cell's seed crossings (epochs), inf for a seed that ended without one; None
    while a seed has not ended (its crossing is not known)."""
    if c.unfinished or not c.n:
        return None
    return [math.inf if x is None else x for x in c.seed_crossings]


def _seeds_text(c: CellStat, v: list[float]) -> str:
    """'at 15,333 and 19,600 episodes, and 1 not within budget'."""
    at = [units(c, x) for x in sorted(v) if math.isfinite(x)]
    never = sum(math.isinf(x) for x in v)
    text = f"at {and_join(at)} episodes" if at else ""
    if never:
        text += f"{', and ' if at else ''}{never} not within budget"
    return text


def control_found(
    her: CellStat, icm: CellStat, bonus: CellStat, open_rule: bool = False
) -> str:
    """What the constant-bonus control found, seed by seed: whether every seed of the
    constant crosses later than every seed of DDPG+HER (it slowed HER), earlier than
    every seed of DDPG+HER+ICM, between the two, or overlapping. `open_rule`: the rule
    written before the runs named no outcome for this placement, and the sentence says
    so.
    '' while a seed of the three has not ended."""
    v = {c.name: _seed_values(c) for c in (her, icm, bonus)}
    if None in v.values():
        return ""
    b, h, i = v[bonus.name], v[her.name], v[icm.name]
    seeds = (
        f"the constant's seeds {_seeds_text(bonus, b)}; {label(her.name)}'s "
        f"{_seeds_text(her, h)}"
    )
    if min(b) > max(h):
        never = " or not within its budget" if max(b) == math.inf else ""
        said = (
            f"Every seed of the constant crosses later than every seed of "
            f"{label(her.name)}{never} ({seeds}), so the constant slowed it"
        )
    elif max(b) < min(i):
        said = (
            f"Every seed of the constant crosses earlier than every seed of "
            f"{label(icm.name)} ({seeds})"
        )
    elif min(b) >= min(i) and max(b) <= max(h):
        said = (
            f"The constant's seeds lie between the fastest seed of {label(icm.name)} "
            f"and the slowest of {label(her.name)} ({seeds})"
        )
    else:
        said = f"The constant's seeds overlap the others' ({seeds})"
    if open_rule:
        said += "; the rule, written before the runs, named no outcome for this case"
    return said + "."


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
