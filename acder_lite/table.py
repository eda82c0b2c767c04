"""Table I of the paper from our runs: training episodes until a test-success threshold.

`python -m acder_lite table --results results/` reads every `progress.csv` (with its `config.json`)
under the results folder and prints, per method and task, the mean ± std over seeds of the first
`episodes` value at which `test_success` reached the task's threshold, how many seeds reached it,
and the paper's number beside it. `learning_curves` averages the same runs for the book's plots.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import shlex
import sys
from pathlib import Path

import numpy as np

TASKS = ("FetchReach-v4", "FetchPush-v4", "FetchPickAndPlace-v4")
"""The paper's three tasks, in the column order of Table I."""

PAPER_THRESHOLDS = {"FetchReach-v4": 1.0, "FetchPush-v4": 0.95, "FetchPickAndPlace-v4": 0.95}
"""Test success rate each column of Table I counts episodes to (Reach 100%, Push and Pick&Place 95%)."""

PAPER_TABLE_I: dict[str, dict[str, int | None]] = {
    "her": {"FetchReach-v4": 2240, "FetchPush-v4": 11600, "FetchPickAndPlace-v4": 33600},
    "her-icm": {"FetchReach-v4": 2400, "FetchPush-v4": 9800, "FetchPickAndPlace-v4": 29800},
    "her-per": {"FetchReach-v4": 1440, "FetchPush-v4": 7800, "FetchPickAndPlace-v4": 17400},
    "her-ebp": {"FetchReach-v4": None, "FetchPush-v4": 7200, "FetchPickAndPlace-v4": 17200},
    "acder": {"FetchReach-v4": 400, "FetchPush-v4": 2200, "FetchPickAndPlace-v4": 5200},
}
"""Table I: episodes until the threshold, per method (our names) and task; None is the paper's '–'."""

METHOD_LABELS = {
    "ddpg": "DDPG", "her": "DDPG+HER", "her-icm": "DDPG+HER+ICM", "her-per": "DDPG+HER+PER",
    "her-ebp": "DDPG+HER+EBP", "acder": "DDPG+ACDER",
    "acder-no-curiosity": "ACDER w/o curiosity", "acder-no-goal-factor": "ACDER w/o goal factor",
    "acder-no-start-states": "ACDER w/o start states",
    "acder-baselines-clip": "ACDER, Baselines' target clip",
}
"""How the paper names each method."""

TASK_LABELS = {"FetchReach-v4": "Reach", "FetchPush-v4": "Push", "FetchPickAndPlace-v4": "Pick&Place",
               "FetchSlide-v4": "Slide"}

SUCCESS_TOL = 1e-9
"""Slack when comparing a success rate with a threshold (a mean of 40 ones may print as 0.9999999)."""


def _order(seq, canonical):
    return sorted(seq, key=lambda x: (canonical.index(x) if x in canonical else len(canonical), x))


def _num(s: str):
    try:
        return float(s)
    except (TypeError, ValueError):
        return s


def read_progress(path: str | Path) -> list[dict]:
    """The rows of a progress.csv, numeric fields as floats (empty fields stay '')."""
    with open(path, newline="") as f:
        return [{k: _num(v) for k, v in row.items()} for row in csv.DictReader(f)]


def episodes_to_threshold(rows: list[dict], threshold: float) -> float | None:
    """The first `episodes` value (in row order) at which `test_success` >= threshold; None if never."""
    for row in rows:
        s = row.get("test_success")
        if isinstance(s, (int, float)) and not math.isnan(s) and s >= threshold - SUCCESS_TOL:
            return float(row["episodes"])
    return None


def _budget(cfg: dict) -> float | None:
    """Training episodes a run may use: epochs * cycles * episodes_per_cycle * workers."""
    try:
        return float(cfg["epochs"] * cfg["cycles"] * cfg["episodes_per_cycle"] * cfg["workers"])
    except (KeyError, TypeError):
        return None


def _epochs_option(command: str) -> int | None:
    """N of `--epochs N` (or `--epochs=N`) in a command line; None if absent or unreadable."""
    try:
        toks = shlex.split(command)
    except ValueError:
        return None
    for i, t in enumerate(toks):
        v = toks[i + 1] if t == "--epochs" and i + 1 < len(toks) else t[9:] if t.startswith("--epochs=") else None
        if v is not None:
            return int(v) if v.isdigit() else None
    return None


def planned_epochs(config_json: dict) -> int | None:
    """The epochs a run was started with, from its config.json (the whole file, not only "config").

    A run ended at an epoch by `train --resume DIR --epochs N` (results/scripts/end_at_epoch.sh)
    has N in its config, so the plan is read from the first command: its `--epochs`, else the
    config's value if no resume changed it, else the Config default the command fell back on.
    """
    first = _epochs_option(config_json.get("command", ""))
    if first is not None:
        return first
    if all(_epochs_option(r.get("command", "")) is None for r in config_json.get("resumes", [])):
        return config_json.get("config", {}).get("epochs")
    from .config import Config
    return Config.__dataclass_fields__["epochs"].default


def load_runs(results_dir: str | Path) -> list[dict]:
    """Every run under `results_dir` that has a progress.csv.

    Each run is a dict: env, method, seed (from config.json's "config", else from the path
    `<env>/<method>/seed<k>`), dir, rows (see `read_progress`), budget (training episodes of the
    config's epochs, which an ended run's resume may have lowered; the last `episodes` value if
    config.json lacks the fields), planned_epochs (see `planned_epochs`; None without config.json),
    done (done.json present).
    Sorted by (env, method, seed).
    """
    runs = []
    for path in sorted(Path(results_dir).rglob("progress.csv")):
        d = path.parent
        cfg, planned = {}, None
        if (d / "config.json").exists():
            with open(d / "config.json") as f:
                whole = json.load(f)
            cfg, planned = whole.get("config", {}), planned_epochs(whole)
        rows = [r for r in read_progress(path) if isinstance(r.get("episodes"), float)]
        seed = cfg.get("seed")
        if seed is None:
            seed = int(d.name[4:]) if d.name.startswith("seed") and d.name[4:].isdigit() else d.name
        budget = _budget(cfg)
        if budget is None and rows:
            budget = max(r["episodes"] for r in rows)
        runs.append(dict(env=cfg.get("env", d.parent.parent.name), method=cfg.get("method", d.parent.name),
                         seed=seed, dir=str(d), rows=rows, budget=budget, planned_epochs=planned,
                         done=(d / "done.json").exists(),
                         update_dtype=cfg.get("update_dtype", "float32")))  # absent before it existed
    runs.sort(key=lambda r: (r["env"], r["method"], str(r["seed"])))
    return runs


def how_ended(run: dict, thresholds: dict[str, float] = PAPER_THRESHOLDS) -> str | None:
    """Why a run of `load_runs` ended, from its done.json: "early stop" (the success held),
    "full budget", "hovering" (it reached its task's threshold and was ended at an epoch after
    it: by `Config.stop_gap_episodes`, or by `train --resume DIR --epochs N` as
    results/scripts/end_when_hovering.sh does) or "cut short" (ended that way before it reached
    the threshold, e.g. when a session ran out). None while there is no done.json.
    """
    p = Path(run["dir"]) / "done.json"
    if not p.exists():
        return None
    done = json.loads(p.read_text())
    if done.get("stop_reason") == "gap after first success":  # Config.stop_gap_episodes
        return "hovering"
    if done.get("stopped_early"):
        return "early stop"
    planned = run.get("planned_epochs")
    if planned is None or done.get("epochs", planned) >= planned:
        return "full budget"
    reached = episodes_to_threshold(run["rows"], thresholds.get(run["env"], 1.0)) is not None
    return "hovering" if reached else "cut short"


def _bf16_seeds(seeds: list[dict]) -> int:
    """How many runs of `load_runs` took their gradient step in bfloat16 (`Config.update_dtype`)."""
    return sum(r.get("update_dtype") == "bfloat16" for r in seeds)


def _is_running(run: dict, last: float) -> bool:
    """No done.json and the last evaluation is before the planned budget: the run is still going."""
    return (not run.get("done")) and run.get("budget") is not None and last < run["budget"]


def summarize(runs: list[dict], thresholds: dict[str, float] = PAPER_THRESHOLDS) -> list[dict]:
    """Per (method, task) with a threshold: episodes-to-threshold over seeds, beside the paper.

    Each row: method, env, threshold, n (seeds), k (seeds that reached it), episodes (per seed,
    None where never reached), mean and std (over the k seeds that reached it, std with ddof=1,
    0 for one seed; None when k = 0), budget (largest planned budget among the seeds), paper
    (Table I's number, None if absent), so_far (largest episodes evaluated by a seed), best (best
    test success of any seed, None without evaluations) and running (seeds still training: no
    done.json and last evaluation before the budget); pending counts the running seeds that have not
    reached the threshold yet (they may still change mean and std); bf16 counts the seeds whose
    gradient step ran in bfloat16 (`Config.update_dtype`). Rows in Table I's order.
    """
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in runs:
        if r["env"] in thresholds:
            groups.setdefault((r["method"], r["env"]), []).append(r)
    methods = _order({m for m, _ in groups}, list(METHOD_LABELS))
    envs = _order({e for _, e in groups}, list(TASKS))
    out = []
    for m in methods:
        for e in envs:
            if (m, e) not in groups:
                continue
            seeds = groups[(m, e)]
            eps = [episodes_to_threshold(r["rows"], thresholds[e]) for r in seeds]
            hit = np.array([x for x in eps if x is not None], dtype=float)
            budgets = [r["budget"] for r in seeds if r["budget"] is not None]
            last = [max((x["episodes"] for x in r["rows"]), default=0.0) for r in seeds]
            best = [x["test_success"] for r in seeds for x in r["rows"]
                    if isinstance(x.get("test_success"), float) and not math.isnan(x["test_success"])]
            out.append(dict(
                method=m, env=e, threshold=thresholds[e], n=len(seeds), k=len(hit),
                seeds=[r["seed"] for r in seeds], episodes=eps,
                mean=float(hit.mean()) if len(hit) else None,
                std=float(hit.std(ddof=1)) if len(hit) > 1 else (0.0 if len(hit) else None),
                budget=max(budgets) if budgets else None,
                paper=PAPER_TABLE_I.get(m, {}).get(e),
                so_far=max(last, default=0.0), best=max(best, default=None),
                running=sum(_is_running(r, x) for r, x in zip(seeds, last)),
                bf16=_bf16_seeds(seeds),
                pending=sum(_is_running(r, x) and e_ is None for r, x, e_ in zip(seeds, last, eps))))
    return out


def _int(x: float | None) -> str:
    return "–" if x is None else f"{round(x):,}"


def _cell(row: dict | None, paper: int | None, has_paper_row: bool) -> str:
    tail = f" · paper {_int(paper)}" if has_paper_row else ""
    if row is not None and row.get("bf16"):  # said in the cell: the rest of the table is float32
        which = "" if row["bf16"] == row["n"] else f" in {row['bf16']} of {row['n']} seeds"
        tail = f" · bfloat16 update{which}" + tail
    if row is None:
        return "–" if has_paper_row and paper is None else "not run" + tail
    if row["k"] == 0:
        if row.get("running"):
            best = "" if row.get("best") is None else f", best {row['best']:.2f}"
            return (f"not yet: {_int(row['so_far'])} of {_int(row['budget'])} so far{best} "
                    f"(0/{row['n']}, {row['running']} running)" + tail)
        return f"not reached in {_int(row['budget'])} (0/{row['n']})" + tail
    pending = f", {row['pending']} running" if row.get("pending") else ""
    # one seed has no spread: "± 0" would read as seeds that agree
    spread = f" ± {_int(row['std'])}" if row["k"] > 1 else ""
    return f"{_int(row['mean'])}{spread} ({row['k']}/{row['n']}{pending})" + tail


def _ratio(her: dict | None, acder: dict | None) -> str:
    """HER's episodes over ACDER's; '> x' when HER never reached it (a lower bound from its budget)."""
    if her is None or acder is None:
        return "not run"
    if acder["k"] == 0:
        return "–"
    if her["k"] == 0:
        # a lower bound: the budget if HER has finished, the episodes so far if it is still running
        bound = her.get("so_far") if her.get("running") else her["budget"]
        return f"> {bound / acder['mean']:.1f}" if bound else "–"
    ratio = f"{her['mean'] / acder['mean']:.1f}"
    if her["k"] < her["n"] and not acder.get("pending"):
        ratio = "≥ " + ratio  # the seeds that never reached it would only raise HER's mean
    if her.get("pending") or acder.get("pending"):
        ratio += " so far"  # seeds still training may move either mean
    return ratio


def to_markdown(summary: list[dict], envs=None, methods=None) -> str:
    """A markdown Table I (ours beside the paper's) and the HER/ACDER ratio per task.

    Columns are the tasks (rows the methods) present in `summary`, or all of `envs` (`methods`)
    when given, e.g. `TASKS` and `PAPER_TABLE_I` for the paper's full table: cells without runs
    then read "not run".
    """
    if not summary and envs is None and methods is None:
        return "_No runs with a paper threshold._\n"
    by = {(r["method"], r["env"]): r for r in summary}
    methods = _order(set(methods) | {r["method"] for r in summary} if methods is not None
                     else {r["method"] for r in summary}, list(METHOD_LABELS))
    envs = _order(set(envs) | {r["env"] for r in summary} if envs is not None
                  else {r["env"] for r in summary}, list(TASKS))
    thr = {e: PAPER_THRESHOLDS.get(e, float("nan")) for e in envs}
    thr.update({r["env"]: r["threshold"] for r in summary})
    head = [f"{TASK_LABELS.get(e, e)} ({thr[e]:.0%})" for e in envs]
    lines = ["Training episodes until the test success rate first reaches the threshold: mean ± std "
             "over the seeds that reached it (seeds reached / seeds run) · the paper's Table I.", "",
             "| Method | " + " | ".join(head) + " |",
             "|---|" + "---|" * len(envs)]
    for m in methods:
        cells = [_cell(by.get((m, e)), PAPER_TABLE_I.get(m, {}).get(e), m in PAPER_TABLE_I) for e in envs]
        lines.append(f"| {METHOD_LABELS.get(m, m)} (`{m}`) | " + " | ".join(cells) + " |")
    def _budget_of(e):
        b = max((r["budget"] for r in summary if r["env"] == e and r["budget"]), default=None)
        return "not run" if b is None and not any(r["env"] == e for r in summary) else _int(b)
    budgets = [f"{TASK_LABELS.get(e, e)} {_budget_of(e)}" for e in envs]
    lines += ["", "Budget (training episodes per run, largest over methods): " + ", ".join(budgets) + ".",
              "", "| HER / ACDER episodes | " + " | ".join(TASK_LABELS.get(e, e) for e in envs) + " |",
              "|---|" + "---|" * len(envs)]
    ours = [_ratio(by.get(("her", e)), by.get(("acder", e))) for e in envs]
    paper = []
    for e in envs:
        h, a = PAPER_TABLE_I["her"].get(e), PAPER_TABLE_I["acder"].get(e)
        paper.append(f"{h / a:.1f}" if h and a else "–")
    lines += ["| ours | " + " | ".join(ours) + " |", "| paper | " + " | ".join(paper) + " |"]
    return "\n".join(lines) + "\n"


def seed_crossings(runs: list[dict], env: str, methods, levels=(0.5, 0.9, 0.95), labels: dict | None = None) -> str:
    """A markdown table, one row per run of `methods` on `env`: the episodes at which its test
    success first reached each of `levels` ("not yet" while it trains, "never" once it has ended).

    Table I keeps only the last level and the mean over seeds; this is where one sees whether two
    methods differ by when learning takes off (0.5) or by how long the last stretch takes.
    `labels` names the methods (default `METHOD_LABELS`, else the method itself).
    """
    labels = METHOD_LABELS if labels is None else labels
    rows = [r for r in runs if r["env"] == env and r["method"] in methods]
    rows.sort(key=lambda r: (list(methods).index(r["method"]), str(r["seed"])))
    lines = ["| method | seed | " + " | ".join(f"{x:.0%}" for x in levels) + " | evaluated to |",
             "|---|---|" + "---|" * len(levels) + "---|"]
    for r in rows:
        last = max((x["episodes"] for x in r["rows"]), default=0.0)
        missing = "not yet" if _is_running(r, last) else "never"
        cells = [episodes_to_threshold(r["rows"], x) for x in levels]
        lines.append(f"| {labels.get(r['method'], r['method'])} | {r['seed']} | "
                     + " | ".join(missing if c is None else _int(c) for c in cells)
                     + f" | {_int(last)}{' (training)' if missing == 'not yet' else ''} |")
    return "\n".join(lines) + "\n"


def learning_curves(runs: list[dict]) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Test success per (env, method) on one episodes axis: (episodes, mean, std, n).

    The axis is the union of the seeds' evaluation points; each seed is linearly interpolated
    between its own evaluations and left out (n drops) outside them, except that a finished run
    that stopped early (done.json, last evaluation before its budget) keeps its last value up to
    its budget. std is over the seeds present (ddof=0).
    """
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in runs:
        if r["rows"]:
            groups.setdefault((r["env"], r["method"]), []).append(r)
    out = {}
    for key, seeds in sorted(groups.items()):
        curves = []
        for r in seeds:
            x = np.array([row["episodes"] for row in r["rows"]], dtype=float)
            y = np.array([row["test_success"] if isinstance(row.get("test_success"), float) else np.nan
                          for row in r["rows"]], dtype=float)
            keep = ~np.isnan(y)
            x, y = x[keep], y[keep]
            order = np.argsort(x, kind="stable")
            x, y = x[order], y[order]
            if len(x) and r.get("done") and r.get("budget") and x[-1] < r["budget"]:
                x, y = np.append(x, r["budget"]), np.append(y, y[-1])
            if len(x):
                curves.append((x, y))
        if not curves:
            continue
        grid = np.unique(np.concatenate([x for x, _ in curves]))
        ys = np.full((len(curves), len(grid)), np.nan)
        for i, (x, y) in enumerate(curves):
            inside = (grid >= x[0]) & (grid <= x[-1])
            ys[i, inside] = np.interp(grid[inside], x, y)
        n = (~np.isnan(ys)).sum(axis=0)
        mean = np.nansum(ys, axis=0) / n
        std = np.sqrt(np.nansum((ys - mean) ** 2, axis=0) / n)
        out[key] = (grid, mean, std, n)
    return out


def mean_curve_crossings(runs: list[dict], thresholds: dict[str, float] = PAPER_THRESHOLDS) -> list[dict]:
    """Table I read the other way: the first episode at which the *mean* curve over seeds reaches
    the threshold, with every seed present at that point (`learning_curves`; a run that has ended
    holds its last value up to the largest budget among its seeds).

    The paper does not say which reading its Table I uses; a figure read off Fig. 4's mean curve
    is the later of the two, since every seed must be near the threshold at once. Each row:
    method, env, threshold, n (seeds), episodes (None if the mean never got there with all seeds
    present), running (seeds still training), bf16 (seeds with a bfloat16 gradient step),
    ended_short (seeds ended before their budget after their own first crossing, "hovering" in
    `how_ended`: they hold a last value that may sit below the threshold, so a mean curve that
    never got there says less than one over full budgets), paper.
    """
    counts: dict[tuple[str, str], list[dict]] = {}
    for r in runs:
        if r["env"] in thresholds and r["rows"]:
            counts.setdefault((r["env"], r["method"]), []).append(r)
    out = []
    for (e, m), seeds in counts.items():
        # A run that has ended (done.json) holds its last value to the group's largest budget,
        # so a run cut short (`train --resume DIR --epochs N`) still counts as present.
        end = max((r["budget"] or 0.0 for r in seeds), default=0.0)
        held = [dict(r, budget=max(end, r["budget"] or 0.0)) if r["done"] else r for r in seeds]
        x, mean, _, n = learning_curves(held)[(e, m)]
        hit = np.flatnonzero((n == len(seeds)) & (mean >= thresholds[e] - SUCCESS_TOL))
        last = [max(row["episodes"] for row in r["rows"]) for r in seeds]
        out.append(dict(method=m, env=e, threshold=thresholds[e], n=len(seeds),
                        episodes=float(x[hit[0]]) if len(hit) else None,
                        running=sum(_is_running(r, l) for r, l in zip(seeds, last)),
                        bf16=_bf16_seeds(seeds),
                        ended_short=sum(how_ended(r, thresholds) == "hovering" for r in seeds),
                        paper=PAPER_TABLE_I.get(m, {}).get(e)))
    out.sort(key=lambda r: (list(METHOD_LABELS).index(r["method"]) if r["method"] in METHOD_LABELS
                            else len(METHOD_LABELS), r["method"], list(TASKS).index(r["env"])))
    return out


def mean_curve_markdown(rows: list[dict], methods=None) -> str:
    """`mean_curve_crossings` as a markdown table (ours · paper) with the HER/ACDER ratio.

    Rows are `methods` when given (a method without runs reads "not run", or "–" where the paper
    has no number either), else the methods present in `rows`.
    """
    if methods is not None:
        rows = [r for r in rows if r["method"] in methods]
    if not rows:
        return "_No runs with a paper threshold._\n"
    envs = _order({r["env"] for r in rows}, list(TASKS))
    names = set(methods) if methods is not None else {r["method"] for r in rows}
    by = {(r["method"], r["env"]): r for r in rows}

    def cell(r, m, e):
        if r is None:
            return "–" if m in PAPER_TABLE_I and e in PAPER_TABLE_I[m] and PAPER_TABLE_I[m][e] is None else "not run"
        bf16 = "" if not r.get("bf16") else ("bfloat16 update" if r["bf16"] == r["n"] else f"{r['bf16']} in bfloat16")
        if r["episodes"] is None:
            notes = [bf16] if bf16 else []
            if r["running"]:
                word = "not yet"
            elif r.get("ended_short"):
                # the seeds crossed one by one and were ended (gap rule) holding a value below it
                word = "not before the runs ended"
                notes.insert(0, f"{r['ended_short']} of {r['n']} ended soon after their own first crossing")
            else:
                word = "never"
            return word + (f" ({'; '.join(notes)})" if notes else "")
        return f"{_int(r['episodes'])} ({r['n']} seed{'s' if r['n'] > 1 else ''}{', ' + bf16 if bf16 else ''})"

    lines = ["Training episodes until the mean test success over seeds (all seeds present) first "
             "reaches the threshold · the paper's Table I.", "",
             "| Method | " + " | ".join(f"{TASK_LABELS.get(e, e)} ({PAPER_THRESHOLDS[e]:.0%})" for e in envs) + " |",
             "|---|" + "---|" * len(envs)]
    for m in _order(names, list(METHOD_LABELS)):
        cells = []
        for e in envs:
            paper = PAPER_TABLE_I.get(m, {}).get(e)
            cells.append(cell(by.get((m, e)), m, e) + (f" · paper {_int(paper)}" if paper else ""))
        lines.append(f"| {METHOD_LABELS.get(m, m)} (`{m}`) | " + " | ".join(cells) + " |")
    ratios = []
    for e in envs:
        h, a = by.get(("her", e)), by.get(("acder", e))
        ok = h and a and h["episodes"] and a["episodes"]
        ratios.append(f"{h['episodes'] / a['episodes']:.1f}" if ok else "–")
    lines += ["", "| HER / ACDER, mean curve | " + " | ".join(TASK_LABELS.get(e, e) for e in envs) + " |",
              "|---|" + "---|" * len(envs), "| ours | " + " | ".join(ratios) + " |"]
    return "\n".join(lines) + "\n"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `python -m acder_lite table`."""
    parser.add_argument("--results", default="results", help="root of <env>/<method>/seed<k> (default: results)")
    parser.add_argument("--format", choices=("markdown", "json"), default="markdown",
                        help="markdown (default) or the summary rows as JSON")


def run(args) -> int:
    """Print Table I from the runs under --results; 2 with a one-line error if there are none."""
    root = Path(args.results)
    if not root.is_dir():
        print(f"error: table: results folder {str(root)!r} does not exist", file=sys.stderr)
        return 2
    runs = load_runs(root)
    if not runs:
        print(f"error: table: no progress.csv under {str(root)!r}; allowed: a folder of "
              "<env>/<method>/seed<k> runs written by train or sweep", file=sys.stderr)
        return 2
    summary = summarize(runs)
    if args.format == "json":
        print(json.dumps(summary, indent=2))
    else:
        print(to_markdown(summary), end="")
        print()
        print(mean_curve_markdown(mean_curve_crossings(runs)), end="")
    return 0
