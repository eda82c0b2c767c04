"""Reading the multi-step Push runs for chapter 9: the plan, each run's progress, the
chance level, and the rule that decides what runs after the 400-epoch ACDER run. The
chapter writes the sentences; this module only computes what they quote.

The chance level is the share of the env's resets that already put both blocks on
their targets (`pusher.start_on_targets`): an episode that starts so ends solved if
the arm leaves the blocks alone, so a test success near that share shows nothing
learnt. A rate is called above (below) chance only when its 95% Wilson interval lies
wholly above (below) it (`versus_chance`).

Two sets of runs: DDPG+HER and DDPG+ACDER at 40 epochs (a tenth of the paper's
budget), finished, in `SHORT_ROOT`; DDPG+ACDER at the paper's 400 epochs in
`LONG_ROOT`, which may be planned, in flight or finished when the chapter is built
(`run_state`). results/README.md's rule ("The paper's fourth claim at its own
budget") reads the 400-epoch run: `rule_reading`.

The chapter's flow: `task_plan` (what results/plan.toml plans, where, how far each
folder got); `read_runs`, `method_progress` and `chance_reading` (the 40-epoch runs
against chance); `replayed_starts` (their test episodes replayed without the policy);
`acder_parts` (what ACDER's parts did); `long_run`, `rule_reading`, `rule_chance`,
`block_means` and `same_first_rows` (the 400-epoch run). `plots.chance_panel` and
`plots.block_panels` draw the curves.
"""

from __future__ import annotations

import math
from pathlib import Path

from acder_lite.config import TASK_PRESETS
from acder_lite.envs.multistep import BLOCK_COLUMNS, ENV_ID, POOL_COLUMN
from acder_lite.stats.trial_stats import wilson_interval
from acder_lite.words import count

METHODS = {"her": "DDPG+HER", "acder": "DDPG+ACDER"}
"""The methods chapter 9 runs on the task, by run folder name, with their labels, in the
order the chapter reads them."""

SHORT_ROOT = "experiments/multistep-40"
"""Where the 40-epoch runs are, relative to the repository (its README says why)."""
LONG_ROOT = "results"
"""Where the runs at the paper's 400 epochs are, relative to the repository."""
RULE_LEVEL = 0.10
"""results/README.md's rule: the both-block test success that counts as clearly above
chance..."""
RULE_EVALUATIONS = 5
"""...when it holds at this many consecutive epoch evaluations."""
RUN_STATES = ("planned", "started", "in flight", "finished")
"""What a run folder holds (`run_state`): nothing; config.json but no evaluation yet;
evaluations but no done.json; done.json."""


def run_state(folder: str | Path) -> str:
    """One of `RUN_STATES` for a run folder: 'planned' (no folder), 'started' (no
    progress.csv yet), 'in flight' (progress.csv, no done.json: still training, or
    waiting between sessions) or 'finished' (done.json)."""
    folder = Path(folder)
    if (folder / "done.json").is_file():
        return "finished"
    if (folder / "progress.csv").is_file():
        return "in flight"
    return "started" if folder.is_dir() else "planned"


def task_plan(
    path, env: str = ENV_ID, labels: dict | None = None, root: Path | None = None
):
    """The cells of the plan file `path` (`plan.read_plan`) that run `env`, with a line
    for each: its method's label (`labels`, default `METHODS`), its seed, its epochs
    and their share of the paper's, its folder (relative to `root` when given) and its
    `run_state`, and why it is on hold if it is. Returns (cells, lines);
    ([], ["no plan: why"]) when the file cannot be read or is no plan."""
    from acder_lite.runs.plan import PlanError, read_plan

    labels = labels or METHODS
    try:
        cells = [c for c in read_plan(path) if c.env == env]
    except (OSError, PlanError) as err:
        return [], [f"no plan: {err}"]
    paper = TASK_PRESETS[env]["epochs"]
    lines = []
    for c in cells:
        name = labels.get(c.method, c.method)
        out = Path(c.out)
        if root is not None and Path(root).resolve() in out.resolve().parents:
            out = out.resolve().relative_to(Path(root).resolve())
        lines.append(
            f"{name:11s} seed {c.seed}: {count(c.epochs, 'epoch'):>10s} "
            f"({c.epochs / paper:4.0%} of the paper's)  {out}: {run_state(c.out)}"
            + (f"; on hold: {c.hold}" if c.hold else "")
        )
    return cells, lines


def read_runs(where: Path, root: Path, warn=print) -> list[dict]:
    """The runs under `where` (`runs.load_runs`), [] when it is no folder; each folder
    it skips is passed to `warn` as one line, its path relative to `root`."""
    from acder_lite.runs.read import load_folder

    skipped = []
    runs = load_folder(where, warn=skipped.append)
    for line in skipped:
        warn(line.replace(str(root) + "/", ""))
    return runs


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
    from acder_lite.runs.read import how_ended

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


def method_progress(
    runs: list[dict], env: str = ENV_ID, labels: dict | None = None
) -> dict[str, list[dict]]:
    """`run_progress` of each method of `labels` (run folder name: label, default
    `METHODS`) on `env`, by folder name, against the paper's budget for the task
    (`TASK_PRESETS`' epochs of Table I's 400 episodes)."""
    from acder_lite.stats.report import PAPER_EPISODES_PER_EPOCH

    paper = TASK_PRESETS[env]["epochs"]
    return {
        n: run_progress(runs, env, n, paper, PAPER_EPISODES_PER_EPOCH)
        for n in labels or METHODS
    }


def evaluation_counts(run: dict) -> tuple[int, int]:
    """(successes, episodes) of a run of `runs.load_runs` over all its evaluations
    (`evaluation_successes`, summed)."""
    wins, n = evaluation_successes(run)
    return int(sum(wins)), n * len(wins)


def evaluation_successes(run: dict) -> tuple[list[int], int]:
    """(per evaluation its successes, the test episodes of one evaluation) of a run of
    `runs.load_runs`: `test_episodes` per worker (`Trainer.evaluate`), so an
    evaluation's test success times their number is its count of successes."""
    cfg = run["config"]
    n = int(cfg["test_episodes"]) * int(cfg["workers"])
    return [round(row["test_success"] * n) for row in run["rows"]], n


def versus_chance(k: int, n: int, chance: float, z: float = 1.96) -> str:
    """'above', 'below' or 'at': where k successes in n trials stand against a chance
    rate, by the Wilson interval of k/n (z = 1.96: 95%; `trial_stats.wilson_interval`):
    above when the whole interval lies above `chance`, below when it lies below."""
    lo, hi = wilson_interval(k, n, z)
    return "above" if lo > chance else "below" if hi < chance else "at"


def chance_reading(
    progress: dict[str, list[dict]], solved: int, resets: int
) -> dict[str, dict]:
    """Each method's test successes of `method_progress` (its seeds pooled) over all
    their evaluations beside the chance level, `solved` of `resets` env resets that
    start solved: by method, dict(k, n, rate (k/n), low and high (its 95% Wilson
    interval), verdict (`versus_chance`: 'above', 'at' or 'below'), chance). Methods
    without a run are left out."""
    chance = solved / resets
    out = {}
    for name, seeds in progress.items():
        if not seeds:
            continue
        k = sum(s["test_successes"] for s in seeds)
        n = sum(s["tests"] for s in seeds)
        lo, hi = wilson_interval(k, n)
        out[name] = dict(
            k=k,
            n=n,
            rate=k / n,
            low=lo,
            high=hi,
            verdict=versus_chance(k, n, chance),
            chance=chance,
        )
    return out


def replayed_starts(run: dict) -> dict:
    """A run of `runs.load_runs` beside its test episodes' starts, replayed from the
    trainer's test seeds without the policy (`pusher.solved_test_starts`): `solved`,
    its test episodes that start with both blocks on their targets; `successes`, its
    test successes; `tests`, its test episodes; `equal`, the evaluations at which the
    two counts are equal, of `evaluations`; `more` and `fewer`, those at which the run
    had more (fewer) successes than solved starts; `per_evaluation`, the pairs
    (solved, successes) evaluation by evaluation."""
    from acder_lite.book.pusher import solved_test_starts

    wins, n = evaluation_successes(run)
    solved = [int(x) for x in solved_test_starts(run["config"], len(wins))]
    return dict(
        solved=sum(solved),
        successes=sum(wins),
        tests=n * len(wins),
        equal=sum(int(w == s) for w, s in zip(wins, solved)),
        more=sum(int(w > s) for w, s in zip(wins, solved)),
        fewer=sum(int(w < s) for w, s in zip(wins, solved)),
        evaluations=len(wins),
        per_evaluation=list(zip(solved, wins)),
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


def long_run(folder: str | Path) -> dict:
    """The 400-epoch run in `folder`: dict(state, `run_state`; run, its
    `runs.read_run`, or None while it has no evaluation; epoch, its last evaluation's
    epoch (0 without one); planned, the epochs its command plans (None without a
    run); versions, config.json's "versions" (the libraries and, where recorded, the
    CPU: {} without a run))."""
    import json

    from acder_lite.runs.read import read_run

    state = run_state(folder)
    run = read_run(folder) if state in ("in flight", "finished") else None
    if run is not None and not run["rows"]:
        run = None
    epoch = (run["rows"][-1].get("epoch") or 0.0) if run else 0.0
    versions = {}
    if run is not None:
        versions = json.loads((Path(folder) / "config.json").read_text())
        versions = versions.get("versions") or {}
    return dict(
        state=state,
        run=run,
        epoch=epoch,
        planned=run["planned_epochs"] if run else None,
        versions=versions,
    )


def rule_reading(
    rows: list[dict], level: float = RULE_LEVEL, evaluations: int = RULE_EVALUATIONS
) -> dict:
    """results/README.md's rule on a run's progress rows: its test success (both
    blocks) at or above `level` at `evaluations` consecutive evaluations. dict(met,
    whether it has held so; met_at, the epoch of the evaluation that first completed
    such a streak, else None; longest, the longest streak of evaluations at or above
    `level`; streak, the one running at the last row; best, the highest test success
    (0 without rows); evaluations, the rows read)."""
    longest = streak = 0
    met_at = None
    for r in rows:
        streak = streak + 1 if r["test_success"] >= level else 0
        longest = max(longest, streak)
        if met_at is None and streak >= evaluations:
            met_at = r.get("epoch")
    return dict(
        met=longest >= evaluations,
        met_at=met_at,
        longest=longest,
        streak=streak,
        best=max((r["test_success"] for r in rows), default=0.0),
        evaluations=len(rows),
    )


def rule_chance(
    chance: float,
    tests: int,
    level: float = RULE_LEVEL,
    evaluations: int = RULE_EVALUATIONS,
) -> tuple[float, float]:
    """How likely luck alone meets the rule: a policy whose every test episode succeeds
    with probability `chance` (no learning) reaches `level` at one evaluation of
    `tests` episodes with the binomial probability of at least ceil(level * tests)
    successes; at `evaluations` consecutive (independent) evaluations, its power.
    Returns (one evaluation, that many in a row)."""
    k = math.ceil(level * tests - 1e-9)
    one = sum(
        math.comb(tests, j) * chance**j * (1 - chance) ** (tests - j)
        for j in range(k, tests + 1)
    )
    return one, one**evaluations


def block_means(rows: list[dict], last: int | None = None) -> dict:
    """The mean of each per-block column (`BLOCK_COLUMNS`, then `POOL_COLUMN`) that
    `rows` have, over the last `last` rows (all of them without `last`), NaNs left out
    (the pool's share is NaN while the pool is empty; a column of NaNs only is NaN),
    with `first` and `last`, the epochs averaged over; {} when the rows have none of
    these columns (the 40-epoch runs)."""
    rows = rows[-last:] if last else rows
    cols = [c for c in BLOCK_COLUMNS + (POOL_COLUMN,) if rows and c in rows[0]]
    if not cols:
        return {}
    out = {}
    for c in cols:
        xs = [float(r[c]) for r in rows if not math.isnan(float(r[c]))]
        out[c] = sum(xs) / len(xs) if xs else math.nan
    return dict(out, first=rows[0].get("epoch"), last=rows[-1].get("epoch"))


def same_first_rows(short: list[dict], long: list[dict], skip=("wall_s",)) -> list:
    """Where the long run's progress rows differ from the short run's, over the rows
    both have (the short run's number at most) and the columns both have but `skip`
    (the timing): [(epoch, column, short's value, long's)], [] when they agree (NaN
    equals NaN). The 400-epoch run repeats the 40-epoch one's floats for 40 epochs
    (experiments/multistep-40/README.md), on a CPU of the same kind."""

    def same(a, b):
        both_nan = isinstance(a, float) and isinstance(b, float)
        return a == b or (both_nan and math.isnan(a) and math.isnan(b))

    return [
        (a.get("epoch"), k, a[k], b[k])
        for a, b in zip(short, long)
        for k in sorted(a.keys() & b.keys() - set(skip))
        if not same(a[k], b[k])
    ]
