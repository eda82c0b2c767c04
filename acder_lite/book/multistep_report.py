"""Reading the multi-step Push runs for chapter 9: progress per method, the chance
level, the sentences the chapter glues.

The chance level is the share of the env's resets that already put both blocks on
their targets (`pusher.start_on_targets`): an episode that starts so ends solved if
the arm leaves the blocks alone, so a test success near that share shows nothing
learnt. A rate is called above (below) chance only when its 95% Wilson interval lies
wholly above (below) it (`versus_chance`).

The chapter's flow: `task_plan` and `plan_words` (what results/plan.toml plans),
`read_runs` and `method_progress` (how far each seed got), `runs_words` (the outcome
against the threshold and chance), `starts_note` and `acder_note` (the test episodes
replayed, what ACDER's parts did); `plots.chance_panel` draws the curves.
"""

from __future__ import annotations

from pathlib import Path

from acder_lite.book.utils import percent, percent_range
from acder_lite.config import TASK_PRESETS
from acder_lite.envs.multistep import ENV_ID
from acder_lite.stats.trial_stats import wilson_interval
from acder_lite.words import and_join, count

METHODS = {"her": "DDPG+HER", "acder": "DDPG+ACDER"}
"""The methods chapter 9 runs on the task, by run folder name, with their labels, in the
order the chapter reads them."""

NOTHING_YET = "There is nothing to plot yet."
"""`runs_words`' outcome while no method has an evaluation."""


def task_plan(path, env: str = ENV_ID, labels: dict | None = None):
    """The cells of the plan file `path` (`plan.read_plan`) that run `env`, with a line
    for each: its method's label (`labels`, default `METHODS`), its seed, its epochs
    and their share of the paper's, and why it is on hold if it is. Returns (cells,
    lines); ([], ["no plan: why"]) when the file cannot be read or is no plan."""
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
        lines.append(
            f"{name:11s} seed {c.seed}: {count(c.epochs, 'epoch')} "
            f"({c.epochs / paper:.0%} of the paper's)"
            + (f"; on hold: {c.hold}" if c.hold else "")
        )
    return cells, lines


def plan_words(cells: list, env: str = ENV_ID) -> dict[str, str]:
    """What the chapter glues about the planned `cells` of `env` (`task_plan`):
    plan_epochs, the most epochs a cell plans (0 without cells); plan_share, their
    share of the paper's; plan_seeds ("seed 0", "seeds 0, 1 and 2", "no seed yet");
    seeds_note, what that many seeds make of a curve."""
    most = max((c.epochs for c in cells), default=0)
    seeds = sorted({c.seed for c in cells})
    n = len(seeds)
    words = f"seed{'s' if n > 1 else ''} " + and_join([str(s) for s in seeds])
    return dict(
        plan_epochs=f"{most}",
        plan_share=f"{most / TASK_PRESETS[env]['epochs']:.0%}",
        plan_seeds=words if seeds else "no seed yet",
        seeds_note=(
            f"With {n} seeds a curve is a mean of few draws"
            if n > 1
            else "With one seed a curve is one draw"
            if n == 1
            else "With no seed planned there is no curve yet"
        ),
    )


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


def runs_words(
    progress: dict[str, list[dict]],
    where: Path,
    solved: int,
    resets: int,
    labels: dict | None = None,
    env: str = ENV_ID,
) -> dict[str, str]:
    """The chapter's sentences on the runs of `method_progress` (by folder name; its
    labels `labels`, default `METHODS`): runs_outcome, whether any reached the
    threshold (`best_sentence`) and where each method stands against chance, `solved`
    of `resets` resets (`chance_sentence`), or `NOTHING_YET`; runs_note, each method's
    `progress_sentence` (a folder under `where`, results/<env>, tells a run started
    from one not run yet), then the outcome."""
    from acder_lite.stats.report import threshold

    labels = labels or METHODS
    paper = TASK_PRESETS[env]["epochs"]
    sentences = [
        progress_sentence(label, progress[n], paper, (where / n).is_dir())
        for n, label in labels.items()
    ]
    labelled = {label: progress[n] for n, label in labels.items()}
    best = best_sentence(labelled, threshold(env))
    outcome = f"{best} {chance_sentence(labelled, solved, resets)}" if best else ""
    outcome = outcome or NOTHING_YET
    return dict(runs_outcome=outcome, runs_note=" ".join(sentences + [outcome]))


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
    return f"Runs of {and_join(hit)} reached the {threshold:.0%} threshold."


def versus_chance(k: int, n: int, chance: float, z: float = 1.96) -> str:
    """'above', 'below' or 'at': where k successes in n trials stand against a chance
    rate, by the Wilson interval of k/n (z = 1.96: 95%; `trial_stats.wilson_interval`):
    above when the whole interval lies above `chance`, below when it lies below."""
    lo, hi = wilson_interval(k, n, z)
    return "above" if lo > chance else "below" if hi < chance else "at"


def chance_sentence(progress: dict[str, list[dict]], solved: int, resets: int) -> str:
    """Each method's test successes of `run_progress` (by label, its seeds pooled) over
    all their evaluations, beside the chance level: the share of `resets` env resets
    that start solved (`solved` of them). A rate is called above (below) chance only
    when its 95% Wilson interval lies wholly above (below) that share
    (`versus_chance`). "" when there is no run."""
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
    (`pusher.solved_test_starts`). Says how many started so, its successes, and at
    how many evaluations the two counts are equal."""
    wins, n = evaluation_successes(run)
    same = sum(int(w == int(x)) for w, x in zip(wins, solved))
    return (
        f"{label} seed {run['seed']}: {int(sum(solved)):,} of its "
        f"{n * len(wins):,} test episodes started with both blocks on their targets, "
        f"and it had {sum(wins):,} successes; the two counts are equal at {same} of "
        f"its {len(wins)} evaluations."
    )


def starts_note(runs: list[dict], labels: dict | None = None) -> str:
    """`solved_starts_sentence` of each run with an evaluation, in the order of
    `labels` (run folder name: label, default `METHODS`; other folders last, by their
    name), its test starts replayed from the trainer's test seeds
    (`pusher.solved_test_starts`); "There is no run to replay yet." without one."""
    from acder_lite.book.pusher import solved_test_starts

    labels = labels or METHODS
    order = {name: i for i, name in enumerate(labels)}  # DDPG+HER first
    notes = []
    for r in sorted(runs, key=lambda r: order.get(r["name"], len(order))):
        if r["rows"]:  # no evaluation: nothing to replay (and reshape(0, -1) fails)
            solved = solved_test_starts(r["config"], len(r["rows"]))
            label = labels.get(r["name"], r["name"])
            notes.append(solved_starts_sentence(r, label, solved))
    return " ".join(notes) or "There is no run to replay yet."


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


def acder_note(runs: list[dict], chance: float) -> str:
    """`acder_parts_sentence` of each DDPG+ACDER run (folder "acder") with an
    evaluation, in the order of `runs`, with where its test successes over all its
    evaluations stand against `chance` (`versus_chance`); "There is no DDPG+ACDER run
    to read yet." when none has a row late enough for `acder_parts`."""
    notes = []
    for r in runs:
        if r["name"] == "acder" and r["rows"]:
            verdict = versus_chance(*evaluation_counts(r), chance)
            notes.append(
                acder_parts_sentence(acder_parts(r["rows"]), verdict, r["seed"])
            )
    return " ".join(filter(None, notes)) or "There is no DDPG+ACDER run to read yet."
