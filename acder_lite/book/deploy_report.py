"""Chapter 10's reading of the runs it benches: where each came from, how it trained

Chapter 10 benches two ACDER policies a task, seed 0: the full state's, the grid's run
(results/<task>/acder/seed0) or, until that has finished, the protocol-v1 run that
stands in for it (`STAND_IN`), and the simplified state's (experiments/deploy/).
`policies` finds each one's folder (`runs.finished_run`) and `policy_lines` lists them.
From those folders and what `runs.read_run` read of them (progress.csv, config.json,
done.json) this module writes the chapter's words: `full_state_sentence`,
`training_rows` (a table under `TRAINING_HEADER`, a row a policy, from
`training_facts`) and `lengths_sentence`; for its scene of a perturbed rollout and the
export, `scene_label` picks the policy, `scene_sentence` says how its episode went and
`policy_clips` reads the clips the export bakes in.

Traps: each run ended by its own stop rule or budget, so a task's two columns need not
have trained as long, and a difference between them is then one of training too
(`lengths_sentence` says which). A run's threshold and patience are read from the run
(done.json's stop rule, else its config.json) before today's defaults; where it first
reached the threshold is read between evaluations (`report.first_crossing`). A
stand-in is told by its folder's prefix: `STAND_IN` must be the path, relative to the
repo, that the chapter gives `finished_run`.
"""

from __future__ import annotations

from acder_lite.config import Config
from acder_lite.runs.table import task_label
from acder_lite.words import and_join, count, plural


STAND_IN = "experiments/protocol-v1/"
"""Where chapter 10's full-state column finds a policy while the grid's own run
(results/<task>/acder/seed0) has not finished: the protocol-v1 run of the same method
and seed."""


def policies(root, tasks) -> dict[str, dict[str, str | None]]:
    """Chapter 10's two ACDER policies of each of `tasks`, seed 0, as {task: {"full
    state": folder, "simplified state": folder}}: each the folder, relative to `root`,
    of a finished run (`runs.finished_run`), or None (not trained yet). The full
    state's is the grid's run (results/<task>/acder/seed0), else its `STAND_IN`; the
    simplified state's is experiments/deploy/<task>/acder-simplified/seed0."""
    from acder_lite.runs.read import finished_run

    return {
        env: {
            "full state": finished_run(
                root,
                f"results/{env}/acder/seed0",
                f"{STAND_IN}{env}/acder/seed0",  # until the grid's run has finished
            ),
            "simplified state": finished_run(
                root, f"experiments/deploy/{env}/acder-simplified/seed0"
            ),
        }
        for env in tasks
    }


def policy_lines(folders: dict[str, dict[str, str | None]]) -> list[str]:
    """A line a policy of `policies`' answer: its task, its column and its folder, or
    'not trained yet'."""
    return [
        f"{env:22s} {label:17s} {folder or 'not trained yet'}"
        for env, cols in folders.items()
        for label, folder in cols.items()
    ]


def full_state_sentence(folders: dict[str, str | None]) -> str:
    """Where each task's full-state policy comes from, in words (chapter 10): `folders`
    maps a task to the folder `runs.finished_run` chose, relative to the repo, or None
    (none finished). A folder under `STAND_IN` stands in for the grid's own run."""
    by: dict[str, list[str]] = {"grid": [], "stand-in": [], "none": []}
    for env, folder in folders.items():
        if folder is None:
            key = "none"
        else:
            key = "stand-in" if folder.startswith(STAND_IN) else "grid"
        by[key].append(task_label(env))
    if not by["stand-in"] and not by["none"]:
        return "Every task's full-state policy is the grid's own run."
    parts = []
    if by["grid"]:
        parts.append(
            f"on {and_join(by['grid'])} the full-state policy is the grid's run"
        )
    if by["stand-in"]:
        parts.append(
            f"on {and_join(by['stand-in'])} the grid's run has not finished, and the "
            "protocol-v1 run of the same method and seed stands in for it (chapter 8 "
            "says what differs)"
        )
    if by["none"]:
        parts.append(f"on {and_join(by['none'])} no full-state policy has finished")
    text = "; ".join(parts)
    return text[:1].upper() + text[1:] + "."


def _trained(run: dict) -> str:
    """'19 epochs (7,600 episodes)': how far a run of `runs.read_run` got."""
    last = run["rows"][-1]
    ep, n = last["epoch"], int(last["episodes"])
    return f"{ep:g} {plural(ep, 'epoch')} ({count(n, 'episode')})"


def training_facts(run: dict) -> dict:
    """How a run of chapter 10 trained (`run`: `runs.read_run` of its folder, with at
    least one row), as phrases: `crossed`, where its test-success curve over training
    episodes, read between evaluations (`report.first_crossing`), first reaches its
    stop rule's threshold ('first reached 0.95 at 1,000 episodes'); `ended`, how it
    ended (`runs.how_ended`) and, unless by the stop rule, its last test success
    ('stopped once it had held 0.95 for 5 evaluations, after 7 epochs (2,800
    episodes)')."""
    from acder_lite.stats.report import first_crossing, threshold
    from acder_lite.runs.read import how_ended

    rule = (run["done_info"] or {}).get("stop_rule") or {}
    cfg = run["config"]
    thr = float(
        rule.get("success_threshold")
        or cfg.get("success_threshold")
        or threshold(run["env"])
    )
    patience = rule.get("patience", cfg.get("stop_patience"))
    if patience is None:
        patience = Config().stop_patience
    x = [r["episodes"] for r in run["rows"]]
    y = [r["test_success"] for r in run["rows"]]
    hit = first_crossing(x, y, thr)
    crossed = (
        f"first reached {thr:.2f} at {hit:,.0f} episodes"
        if hit is not None
        else f"never reached {thr:.2f}"
    )
    trained, last = _trained(run), run["rows"][-1]["test_success"]
    held = f"held {thr:.2f} for {count(patience, 'evaluation')}"
    ended = how_ended(run)
    if ended == "early stop":
        tail = f"stopped once it had {held}, after {trained}"
    elif ended == "full budget":
        tail = (
            f"never {held}: it used its whole budget, {trained}, and ended at "
            f"{last:.2f}"
        )
    elif ended is None:
        tail = f"is still training ({trained} so far, at {last:.2f})"
    else:
        tail = f"ended before its budget after {trained}, at {last:.2f}"
    return dict(crossed=crossed, ended=tail)


TRAINING_HEADER = ("Task", "Policy", "Test success", "The run")
"""Columns of `training_rows`."""


def training_rows(runs: dict[str, dict[str, dict | None]]) -> list[tuple]:
    """Chapter 10's runs as table rows ({task: {column label: run or None}}), one per
    policy (`training_facts`), the task named on its first row only; for
    `table.to_html` with `TRAINING_HEADER`."""
    rows = []
    for env, cols in runs.items():
        for k, (label, run) in enumerate(cols.items()):
            task = task_label(env) if k == 0 else ""
            if run is None or not run["rows"]:
                rows.append((task, label, "–", "not trained yet"))
                continue
            f = training_facts(run)
            rows.append((task, label, f["crossed"], f["ended"]))
    return rows


def lengths_sentence(env: str, runs: dict[str, dict | None]) -> str:
    """Whether a task's columns ({column label: `runs.read_run` or None}) trained
    for as many episodes, in one sentence."""
    task = task_label(env)
    if any(r is None or not r["rows"] for r in runs.values()):
        return f"Not every {task} column is trained: there are no lengths to compare."
    episodes = {r["rows"][-1]["episodes"] for r in runs.values()}
    if len(episodes) == 1:
        (n,) = episodes
        trained = {_trained(r) for r in runs.values()}
        # as many episodes in epochs of another size: the episodes alone are the same
        one = trained.pop() if len(trained) == 1 else count(int(n), "episode")
        return f"The {task} policies trained as long, {one} each."
    each = ", ".join(
        f"the {label.replace(' ', '-')} one {_trained(r)}" for label, r in runs.items()
    )
    return (
        f"The {task} policies did not train as long: {each}, so a difference between "
        "their columns is one of training as well as of state."
    )


SCENE_ORDER = ("simplified state", "full state")
"""The columns chapter 10's scene takes its policy from, the first trained one: the
paper deployed simplified-state policies."""


def scene_label(columns: dict[str, str | None]) -> str | None:
    """The column label of the policy chapter 10's scene shows, from one task's
    `policies` entry ({column label: run folder or None}): the first of `SCENE_ORDER`
    with a trained run, or None (no scene)."""
    return next((k for k in SCENE_ORDER if columns.get(k)), None)


def scene_sentence(env: str, label: str | None, success: bool | None) -> str:
    """Chapter 10's sentence under its scene of task `env`: whether the policy of
    column `label` (`scene_label`; None: there is no scene) succeeds in the episode
    shown."""
    if label is None:
        return (
            f"No {task_label(env)} policy has finished training, so there is no scene."
        )
    verb = "succeeds" if success else "fails"
    return f"The {label.replace(' ', '-')} policy {verb} in this episode."


def policy_clips(pol: dict | None) -> tuple[float, float]:
    """The clips an export bakes in, (observation clip, normaliser clip), as a policy
    dict (`robust.load_policy`) records them; for None (no policy trained yet), the
    training defaults (`Config.clip_obs`, `Config.norm_clip`)."""
    if pol is None:
        return Config().clip_obs, Config().norm_clip
    return pol["clip_obs"], pol["norm"]["clip"]
