"""Small helpers for the book's notebooks: show a package function's source,
the budgets."""

from __future__ import annotations

import inspect


def show_source(obj, lines: tuple[int, int] | None = None):
    """Display the source of a package object (function, class,
    method) as highlighted code.

    The notebooks show the package's code this way instead of copying it, so the book
    and the package cannot drift apart.
    """
    from IPython.display import Markdown

    src = inspect.getsource(obj)
    if lines is not None:
        src = "\n".join(src.splitlines()[lines[0] : lines[1]])
    mod = inspect.getmodule(obj)
    where = f"{mod.__name__}.{getattr(obj, '__qualname__', '')}" if mod else ""
    return Markdown(f"`{where}`\n\n```python\n{src.rstrip()}\n```")


def budgets(fast: bool, trains: bool = True, **pairs) -> dict:
    """Pick each budget: `name=(full, fast)` -> value for this mode.

    Prints the table, and the precision `Config.update_dtype="auto"` picks on this CPU:
    the chapters train with the default, so a reader on another CPU sees why their
    numbers differ from the rendered book's in the later digits. A chapter that trains
    no network passes `trains=False` and gets the table only."""
    from .precision import choose_update_dtype

    chosen = {k: (v[1] if fast else v[0]) for k, v in pairs.items()}
    print(
        f"ACDER_FAST={int(fast)}: " + ", ".join(f"{k}={v}" for k, v in chosen.items())
    )
    if trains:
        dtype, why = choose_update_dtype("auto")
        print(f"network updates in {dtype} on this CPU ({why})")
    return chosen


def glue(name: str, value, display: bool = False):
    """`myst_nb.glue` for values quoted in prose, with display off.

    Numpy scalars become Python numbers first (numpy 2's repr, `np.float64(0.5)`, cannot
    be formatted by `{glue:text}` with a format spec). Strings become Markdown, to be
    pasted with `{glue:md}` (`{glue:text}` would show their quotes)."""
    import numpy as np
    from IPython.display import Markdown
    from myst_nb import glue as _glue

    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, str):
        value = Markdown(value)
    return _glue(name, value, display=display)


def run_progress(
    runs: list[dict],
    env: str,
    name: str,
    paper_epochs: int,
    paper_episodes_per_epoch: int = 400,
) -> list[dict]:
    """How far each seed of (env, name) got, for runs of `runs.load_runs`;
    [] when there is none.

    One dict per seed with an evaluation: seed, epoch and episodes at its last
    evaluation, its test success there and its best, the epochs its command planned, how
    it ended (`runs.how_ended`: None while there is no done.json), `share`, its
    training episodes over the paper's budget (`paper_epochs` epochs of
    `paper_episodes_per_epoch` episodes), and `tests`, `test_successes`: its test
    episodes and their successes over all its evaluations (`evaluation_counts`)."""
    from .runs import how_ended

    out = []
    for r in runs:
        if r["env"] != env or r["name"] != name or not r["rows"]:
            continue
        last = r["rows"][-1]
        epoch = last.get("epoch")
        k, n = evaluation_counts(r)
        out.append(
            dict(
                seed=r["seed"],
                epoch=epoch if isinstance(epoch, float) else None,
                episodes=last["episodes"],
                success=last["test_success"],
                best=max(x["test_success"] for x in r["rows"]),
                planned=r["planned_epochs"],
                ended=how_ended(r),
                share=last["episodes"] / (paper_epochs * paper_episodes_per_epoch),
                tests=n,
                test_successes=k,
            )
        )
    return out


def evaluation_counts(run: dict) -> tuple[int, int]:
    """(successes, episodes) of a run of `runs.load_runs` over all its evaluations:
    each evaluation is `test_episodes` episodes per worker (`Trainer.evaluate`), so
    its test success times that number is its count of successes."""
    cfg = run["config"]
    n = int(cfg["test_episodes"]) * int(cfg["workers"])
    k = sum(round(row["test_success"] * n) for row in run["rows"])
    return int(k), n * len(run["rows"])


def percent(share: float, digits: int = 3) -> str:
    """A share as the book writes it: '10%', '2.5%', '0.3%' (`digits` significant
    digits at most, no trailing zeros)."""
    return f"{100 * share:.{digits}g}%"


def percent_range(low: float, high: float, digits: int = 2) -> str:
    """An interval of shares with one number of decimals for both ends, enough for
    `digits` significant digits of the smaller nonzero one: '0.43% to 1.00%', not
    '0.43% to 1%'."""
    import math

    ends = [100 * abs(x) for x in (low, high) if x]  # a 0 end takes the other's
    places = digits - 1 - math.floor(math.log10(min(ends))) if ends else 0
    places = max(0, places)
    return f"{100 * low:.{places}f}% to {100 * high:.{places}f}%"


def vector_text(x, digits: int = 3) -> str:
    """A vector as the chapters print it: `digits` decimals, a space where the sign
    of a positive number goes (the columns line up) and no negative zero, which numpy
    prints for a tiny negative rounded away: '[ 1.363  0.000 -0.138]'."""
    import numpy as np

    values = np.round(np.asarray(x, dtype=float).ravel(), digits) + 0.0  # -0. -> 0.
    return "[" + " ".join(f"{v: .{digits}f}" for v in values) + "]"


def progress_sentence(
    label: str, seeds: list[dict], paper_epochs: int, started: bool = False
) -> str:
    """`run_progress` in words: "DDPG+HER: not run yet." (or, with `started`, a run
    folder exists but holds no evaluation yet) or, per seed, the epoch reached (of those
    planned), its share of the paper's budget and the test success at that last
    epoch."""
    if not seeds:
        return f"{label}: {'started, no evaluation yet' if started else 'not run yet'}."
    parts = []
    for s in seeds:
        epoch = (
            f"epoch {s['epoch']:g}"
            if s["epoch"] is not None
            else f"{s['episodes']:,.0f} episodes"
        )
        planned = f" of the {s['planned']} planned" if s["planned"] else ""
        state = {None: "still running (no done.json yet)"}.get(
            s["ended"], f"ended: {s['ended']}"
        )
        parts.append(
            f"seed {s['seed']} reached {epoch}{planned} ({percent(s['share'])} of the "
            f"paper's budget of {paper_epochs} epochs), test success "
            f"{s['success']:.2f} at its last epoch (best {s['best']:.2f}); {state}"
        )
    return f"{label}: " + "; ".join(parts) + "."


def best_sentence(progress: dict[str, list[dict]], threshold: float) -> str:
    """Whether runs of `run_progress` (by label) reached `threshold` at an evaluation,
    in one sentence; "" when there is no run."""
    best = {
        lab: max(s["best"] for s in seeds) for lab, seeds in progress.items() if seeds
    }
    if not best:
        return ""
    hit = [lab for lab, v in best.items() if v >= threshold]
    if not hit:
        return f"No run reached the {threshold:.0%} threshold at any evaluation."
    return f"Runs of {', '.join(hit)} reached the {threshold:.0%} threshold."


def versus_chance(k: int, n: int, chance: float, z: float = 1.96) -> str:
    """'above', 'below' or 'at': where k successes in n trials stand against a chance
    rate, by the Wilson interval of k/n (z = 1.96: 95%; `robust.wilson_interval`):
    above when the whole interval lies above `chance`, below when it lies below."""
    from .robust import wilson_interval

    lo, hi = wilson_interval(k, n, z)
    return "above" if lo > chance else "below" if hi < chance else "at"


def chance_sentence(progress: dict[str, list[dict]], solved: int, resets: int) -> str:
    """Each method's test successes of `run_progress` (by label, its seeds pooled) over
    all their evaluations, beside the chance level: the share of `resets` env resets
    that start solved (`solved` of them). A rate is called above (below) chance only
    when its 95% Wilson interval lies wholly above (below) that share
    (`versus_chance`). "" when there is no run."""
    from .robust import wilson_interval

    chance = solved / resets
    counts = {
        lab: (sum(s["test_successes"] for s in seeds), sum(s["tests"] for s in seeds))
        for lab, seeds in progress.items()
        if seeds
    }
    if not counts:
        return ""
    each, verdict = [], {}
    for lab, (k, n) in counts.items():
        lo, hi = wilson_interval(k, n)
        each.append(
            f"{lab} succeeded in {k:,} of {n:,} test episodes ({percent(k / n, 2)}; "
            f"95% interval {percent_range(lo, hi)})"
        )
        verdict.setdefault(versus_chance(k, n, chance), []).append(lab)
    words = {
        "at": "at chance, as many successes as episodes that start solved would give",
        "above": "above chance",
        "below": "below chance, fewer successes than the episodes that start solved",
    }
    said = [
        f"{' and '.join(labs)} {'is' if len(labs) == 1 else 'are'} {words[v]}"
        for v in ("above", "at", "below")
        if (labs := verdict.get(v))
    ]
    return (
        f"Over all their evaluations {' and '.join(each)}. Both blocks already start "
        f"on their targets in {percent(chance, 2)} of the env's resets ({solved:,} of "
        f"{resets:,}, no step taken): taking a rate as above or below that chance "
        "level only when its 95% Wilson interval lies wholly above or below it, "
        f"{'; '.join(said)}."
    )


def solved_starts_sentence(run: dict, label: str, solved) -> str:
    """One run of `runs.load_runs` beside its replayed test starts: `solved`, per
    evaluation, how many of its test episodes started with the task already solved
    (`multistep.solved_test_starts`). Says how many started so, its successes, and at
    how many evaluations the two counts are equal."""
    n = int(run["config"]["test_episodes"]) * int(run["config"]["workers"])
    wins = [round(row["test_success"] * n) for row in run["rows"]]
    same = sum(int(w == int(x)) for w, x in zip(wins, solved))
    return (
        f"{label} seed {run['seed']}: {int(sum(solved)):,} of its "
        f"{n * len(wins):,} test episodes started with both blocks on their targets, "
        f"and it had {sum(wins):,} successes; the two counts are equal at {same} of "
        f"its {len(wins)} evaluations."
    )


ACDER_PARTS = ("pool_size", "alpha", "novel_start_share", "train_success")
ACDER_PARTS += ("r_int_mean", "lambda_mean")
"""The progress.csv columns `acder_parts` averages: what ACDER's parts did."""


def acder_parts(rows: list[dict], first_epoch: float = 2.0) -> dict:
    """The mean of each `ACDER_PARTS` column over a run's progress rows from epoch
    `first_epoch` on (at the first evaluation the start pool is still filling), with
    `first` and `last`, the epochs averaged over; {} when no row is that late."""
    late = [r for r in rows if (r.get("epoch") or 0) >= first_epoch]
    if not late:
        return {}
    out = {k: sum(float(r[k]) for r in late) / len(late) for k in ACDER_PARTS}
    return dict(out, first=late[0]["epoch"], last=late[-1]["epoch"])


def acder_parts_sentence(parts: dict, verdict: str, seed=None) -> str:
    """`acder_parts` of a run (of seed `seed`, if given) in words, with what its test
    success shows beside the chance level (`versus_chance`'s 'above', 'at' or
    'below'); "" for no parts. Unicode, not maths: glued Markdown renders no $...$."""
    if not parts:
        return ""
    p = parts
    who = "Averaged" if seed is None else f"Seed {seed}, averaged"
    head = (
        f"{who} over epochs {p['first']:g} to {p['last']:g}: its start pool held "
        f"{p['pool_size']:.0f} candidates, taken from minibatch rows of training "
        f"episodes that ended in success ({percent(p['train_success'], 2)} of them "
        f"did); Eq. 9's α was {p['alpha']:.2f} and "
        f"{percent(p['novel_start_share'], 2)} of its training episodes restarted from "
        "a pooled state. Curiosity's reward averaged "
        f"{p['r_int_mean']:.4f} a transition, beside the -λ of every step short of "
        f"success (λ averaged {p['lambda_mean']:.2f})."
    )
    tail = {
        "at": " The parts were at work, changing where and on what it trained, but "
        "its test success stayed at chance: nothing it learnt shows at test.",
        "above": " Its test success is above chance: it learnt something that shows "
        "at test.",
        "below": " Its test success is below chance: fewer successes than the "
        "episodes that start solved would give.",
    }
    return head + tail[verdict]


def seed_crossings(
    runs: list[dict], env: str, name: str, threshold: float
) -> list[dict]:
    """Each seed's first evaluation at or above `threshold`
    (`report.episodes_to_threshold`, no interpolation), for runs of `runs.load_runs`; []
    when (env, name) has no run with rows.

    One dict per seed, in seed order: seed, `hit` (training episodes at the first
    crossing, None if never), `best` test success and `episodes` at the last
    evaluation. A single seed's crossing is what chapter 7 tabulates; Table I's
    statistic is the crossing of the mean curve instead."""
    from .report import episodes_to_threshold

    mine = [r for r in runs if r["env"] == env and r["name"] == name and r["rows"]]
    out = []
    for r in sorted(mine, key=lambda r: r["seed"]):
        rows = r["rows"]
        hit = episodes_to_threshold(rows, threshold)
        best = max(x["test_success"] for x in rows)
        last = rows[-1]["episodes"]
        out.append(dict(seed=r["seed"], hit=hit, best=best, episodes=last))
    return out


def crossing_text(s: dict) -> str:
    """One seed of `seed_crossings` in a few words: 'seed 0: 4,000', or 'seed 1: not
    reached (best 0.90 in 10,000)'."""
    if s["hit"] is not None:
        return f"seed {s['seed']}: {s['hit']:,.0f}"
    return (
        f"seed {s['seed']}: not reached (best {s['best']:.2f} in {s['episodes']:,.0f})"
    )


EPISODE_STATS = {
    "success": "success at the last step",
    "start": "already solved at step 0",
    "earned": "success, not solved at step 0",
    "any_step": "within 5 cm at some step",
    "moved": "achieved goal moved > 1 cm",
}
"""What `episode_stats` counts per episode, in words (chapter 1's legend)."""


def episode_stats(ep: dict, env) -> dict:
    """Per episode of `rollout.run_episodes`' output `ep` on `env`'s task (arrays with a
    leading episode axis): the `EPISODE_STATS` as bools, and `dist`, the achieved goal's
    distance to the goal at steps 1..T. 'moved': the achieved goal ever more than 1 cm
    from where it started; 'start': the reset itself within the distance threshold."""
    import numpy as np

    start = env.compute_reward(ep["ag"][:, 0], ep["g"][:, 0], None) == 0
    dist = np.linalg.norm(ep["ag"][:, 1:] - ep["g"], axis=-1)
    moved = np.linalg.norm(ep["ag"] - ep["ag"][:, :1], axis=-1).max(axis=1) > 0.01
    succ = ep["success"].astype(bool)
    return dict(
        success=succ,
        start=start,
        earned=succ & ~start,
        any_step=(dist < env.distance_threshold).any(axis=1),
        moved=moved,
        dist=dist,
    )
