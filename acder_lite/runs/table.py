"""Table I from our runs: episodes until the mean test success crosses the threshold.

`python -m acder_lite table --results results` reads every run under the folder
(`runs`), computes both statistics of every (task, method) cell (`report`: the mean
curve's first crossing with a bootstrap interval, and the per-seed crossings) and prints
them beside the paper's Table I, with the HER/ACDER ratios. The seed counts are read
against the plan file (`<results>/plan.toml`, or `--plan FILE`) where there is one.
`--results experiments/protocol-v1` reads the earlier runs the same way.

This module only renders the table (its text cells, markdown, HTML for the book) and
runs the CLI; reading run folders is `runs`', the statistics are `report`'s, and what
the book computes beside them for its sentences is `book.findings`'.
"""

from __future__ import annotations

import argparse
import html
import json
import math
import sys
from pathlib import Path

from acder_lite.config import TASK_PRESETS, Config, ConfigError
from acder_lite.stats.report import (
    CUT_WHY,
    PAPER_EPISODES_PER_EPOCH,
    CellStat,
    RatioStat,
    grid_cells,
    ratios,
    summarize,
)
from acder_lite.runs.read import load_runs, planned_cells
from acder_lite.words import count, plural

METHOD_LABELS = {
    "ddpg": "DDPG",
    "her": "DDPG+HER",
    "her-icm": "DDPG+HER+ICM",
    "her-per": "DDPG+HER+PER",
    "her-ebp": "DDPG+HER+EBP",
    "acder": "DDPG+ACDER",
    "acder-no-curiosity": "ACDER w/o curiosity",
    "acder-no-goal-factor": "ACDER w/o goal factor",
    "acder-no-start-states": "ACDER w/o start states",
    "acder-baselines-clip": "ACDER with Baselines' clip (protocol v1)",
    "sicm-normalised": "ACDER, S-ICM on normalised (o, g)",
    "sicm-raw": "ACDER, S-ICM on raw (o, g)",
    "sicm-raw-episode-goal": "ACDER, S-ICM on raw (o, g), "
    "restarts keep the episode's goal",
    "her-bonus": "DDPG+HER with a constant bonus",
    "acder-sincos": "ACDER, S-ICM on (sin, cos) of the angles",
}
"""How the paper names each method (folder names: methods,
and our experiments' names)."""

TASK_LABELS = {
    "FetchReach-v4": "Reach",
    "FetchPush-v4": "Push",
    "FetchPickAndPlace-v4": "Pick&Place",
    "FetchSlide-v4": "Slide",
    "FetchPushMultiStep-v0": "Multi-step Push",
}

HEADER = (
    "Task",
    "Method",
    "Seeds",
    "Mean curve",
    "95% interval (resamples crossing)",
    "Per seed: median (range), mean, crossed",
    "Paper",
)


def label(name: str) -> str:
    return METHOD_LABELS.get(name, name)


def task_label(env: str) -> str:
    return TASK_LABELS.get(env, env)


PROTOCOL_HEADER = (
    "Task",
    "Epochs",
    "Cycles an epoch",
    "Episodes an epoch",
    "Test episodes",
    "Threshold",
)


def protocol_rows(envs=("FetchReach-v4", "FetchPush-v4", "FetchPickAndPlace-v4")):
    """(header, rows): each task's training protocol as its preset resolves it (the
    budget in epochs, an epoch's cycles and training episodes over all workers, the
    test episodes of an evaluation, the success threshold Table I is read at)."""
    rows = []
    for env in envs:
        c = Config(env=env).resolve()
        rows.append(
            (
                task_label(env),
                c.epochs,
                c.cycles,
                c.episodes_per_epoch,
                f"{c.test_episodes} per worker",
                f"{c.success_threshold:.0%}",
            )
        )
    return PROTOCOL_HEADER, rows


def switch_rows(methods: list[str]) -> tuple[tuple, list[tuple]]:
    """(header, rows): each of `methods` with its switches (`config.METHODS`, in the
    order of ACDER's), a bool as yes / no and a choice ('sicm', 'none') as it is;
    names in backticks."""
    from acder_lite.config import METHODS

    keys = list(METHODS["acder"])

    def shown(v):
        return ("yes" if v else "no") if isinstance(v, bool) else v

    rows = [(f"`{m}`", *(shown(METHODS[m][k]) for k in keys)) for m in methods]
    return ("method", *(f"`{k}`" for k in keys)), rows


def episodes(x: float | None) -> str:
    """Episodes as '11,600'; inf as 'beyond budget', None as '–'."""
    if x is None:
        return "–"
    return "beyond budget" if math.isinf(x) else f"{round(x):,}"


def seeds_text(c: CellStat) -> str:
    """'3 done / 5 planned', '2 done, 1 unfinished', '0 done / 5 planned (on hold)',
    ..."""
    parts = [f"{c.done} done"]
    if c.unfinished:
        parts.append(f"{c.unfinished} unfinished")
    text = ", ".join(parts)
    if c.cut:
        text += f" ({c.cut} cut)"
    if c.planned is not None:
        text += f" / {c.planned} planned"
        if c.hold and c.n < c.planned:
            text += " (on hold)"
    return text


def units(c: CellStat, epochs: float | None) -> str:
    """Epochs in Table I's unit, with our own episodes in brackets where an
    epoch is not 400."""
    text = episodes(c.paper_units(epochs))
    if (
        epochs is not None
        and math.isfinite(epochs)
        and c.episodes_per_epoch not in (None, PAPER_EPISODES_PER_EPOCH)
    ):
        text += f" (ours {episodes(c.our_episodes(epochs))})"
    return text


def mean_text(c: CellStat) -> str:
    """The mean-curve crossing, or why there is none."""
    if c.crossing is not None:
        text = units(c, c.crossing)
    elif c.why == "not yet" and c.evaluated_epochs is not None:
        text = f"not yet (evaluated to epoch {c.evaluated_epochs:g}"
        if c.earliest is not None and c.earliest > c.evaluated_epochs:
            # what the seeds so far rule out (report.earliest_crossing)
            text += (
                "; cannot cross within budget"
                if math.isinf(c.earliest)
                else f"; not before {units(c, c.earliest)}"
            )
        text += ")"
    elif c.why == "not within budget" and c.budget_epochs:
        text = (
            f"not within budget ({c.budget_epochs:g} {plural(c.budget_epochs, 'epoch')}"
        )
        paper = TASK_PRESETS.get(c.env, {}).get("epochs")  # the paper's budget
        if paper and c.budget_epochs < paper:  # a shorter run cannot say "never"
            text += f" of the paper's {paper:g}"
        text += ")"
    elif c.why == CUT_WHY and c.evaluated_epochs is not None:
        text = f"{c.why} (epoch {c.evaluated_epochs:g})"
    else:
        text = c.why
    if c.bf16:
        text += " · bfloat16 update" + (
            "" if c.bf16 == c.n else f" in {c.bf16} of {c.n} seeds"
        )
    return text


def interval_span(c: CellStat) -> str:
    """The 95% interval of the crossing in Table I's unit: '2,800 – 3,200',
    '– (one seed)', '–' (no runs)."""
    if c.boot is None or c.low is None:
        return "–"
    if c.n == 1:
        return "– (one seed)"

    def bound(x: float) -> str:
        # a resample that has not crossed yet may still cross while a seed trains, and
        # one whose seed's curve was cut was never given the budget
        if math.isinf(x) and c.unfinished:
            return "not yet"
        if math.isinf(x) and c.cut:
            return "cut short"
        return episodes(c.paper_units(x))  # Table I's unit

    low, high = bound(c.low), bound(c.high)
    # "not yet – not yet" says one thing twice: no resample has crossed yet
    return low if low == high else f"{low} – {high}"


def interval_text(c: CellStat) -> str:
    """`interval_span` with the share of bootstrap resamples that cross, where there
    is an interval: '2,800 – 3,200 (100%)'."""
    span = interval_span(c)
    if c.boot is None or c.low is None or c.n == 1:
        return span
    return f"{span} ({c.share_crossing:.0%})"


def per_seed_text(c: CellStat) -> str:
    if not c.n:
        return "–"
    # a seed still training may cross; one that ended without crossing never will,
    # and then the slowest seed and the mean are "not crossed" for good
    never = sum(x is None and e for x, e in zip(c.seed_crossings, c.seed_ended))
    settled = not c.unfinished or never > 0
    # the median (np.median: the upper middle value counts) is inf for good once
    # that many seeds ended uncrossed
    median_settled = not c.unfinished or never >= c.n - c.n // 2

    def one(x, final=not c.unfinished):
        if x is None or math.isinf(x):
            return "not crossed" if final else "not yet"
        return episodes(c.paper_units(x))

    median = one(c.seed_median, median_settled)
    if c.n == 1 or c.k == 0:  # one value, or none crossed: the median says it all
        return f"{median}, {c.k}/{c.n}"
    return (
        f"{median} ({one(c.seed_low)} – {one(c.seed_high, settled)}), "
        f"mean {one(c.seed_mean, settled)}, {c.k}/{c.n}"
    )


def table_rows(cells: list[CellStat]) -> tuple[tuple, list[tuple]]:
    """(header, rows) of Table I: one row per cell."""
    rows = [
        (
            task_label(c.env),
            f"{label(c.name)} (`{c.name}`)",
            seeds_text(c),
            mean_text(c),
            interval_text(c),
            per_seed_text(c),
            episodes(c.paper),
        )
        for c in cells
    ]
    return HEADER, rows


BOOK_HEADER = ("Task", "Method", "Ours: mean curve, 95% interval", "Paper")
"""Table I as the book shows it: the columns a reader compares (`book_rows`)."""

DETAIL_HEADER = ("Task", "Method", "Seeds", "Resamples crossing", HEADER[5])
"""The rest of `HEADER`'s columns, per cell (`detail_rows`)."""


def _first_of_task(cells: list[CellStat]) -> list[str]:
    """Each row's task label, only where the task changes ('' below it)."""
    envs = [c.env for c in cells]
    return [
        task_label(e) if i == 0 or envs[i - 1] != e else "" for i, e in enumerate(envs)
    ]


def ours_text(c: CellStat) -> str:
    """The book's Table I cell of ours: the mean-curve crossing, then (on a line of
    its own) the 95% interval and how many seeds are still training."""
    nbsp = "\u00a0"  # a narrow column breaks lines between these words, not inside
    lines = [mean_text(c).replace("(ours ", f"(ours{nbsp}")]
    span = interval_span(c).replace(" – ", f"{nbsp}–{nbsp}")
    if span != "–":
        lines.append("one seed: no interval" if c.n == 1 else f"95%: {span}")
    if c.unfinished:
        lines.append(f"{c.unfinished} of {count(c.n, 'seed')} still training")
    elif c.hold and c.planned is not None and c.n < c.planned:
        lines.append("on hold")
    return "\n".join(lines)


def book_rows(cells: list[CellStat]) -> tuple[tuple, list[tuple]]:
    """(header, rows) of Table I as the book shows it: task (once per task), method,
    ours (`ours_text`) and the paper's. `detail_rows` has the other columns of
    `table_rows`, so every fact of the full table is in one of the two."""
    rows = [
        (t, label(c.name), ours_text(c), episodes(c.paper))
        for t, c in zip(_first_of_task(cells), cells)
    ]
    return BOOK_HEADER, rows


def detail_rows(cells: list[CellStat]) -> tuple[tuple, list[tuple]]:
    """(header, rows) of the per-seed detail below the book's Table I: seeds against
    the plan, the share of resamples crossing, each seed's own crossing."""
    rows = [
        (
            t,
            f"`{c.name}`",
            seeds_text(c),
            "–" if interval_span(c).startswith("–") else f"{c.share_crossing:.0%}",
            per_seed_text(c),
        )
        for t, c in zip(_first_of_task(cells), cells)
    ]
    return DETAIL_HEADER, rows


def book_html(cells: list[CellStat], title: str, caption: str = "") -> str:
    """Table I (or another set of cells) for the book: `book_rows` with its caption,
    then `detail_rows` in a collapsed <details> below it."""
    main = to_html(*book_rows(cells), caption=(title, caption))
    detail = to_html(*detail_rows(cells))
    summary = (
        f"{title}, per seed: seeds finished against the plan, the share of bootstrap "
        "resamples that cross, each seed's own first crossing"
    )
    return f"{main}<details><summary>{html.escape(summary)}</summary>{detail}</details>"


def ratio_text(r: RatioStat) -> str:
    """The ratio table's cell of one task: '2.0 [1.8 – 3.5]', '> 3.2 (HER not within
    budget) [2.0 – ∞]' where only a lower bound is known, else why there is none."""
    if r.ours is not None:
        text = f"{r.ours:.1f}"
    elif r.bound is not None:
        text = f"> {r.bound:.1f} ({r.why})"
    else:
        return r.why
    return text + ratio_interval_text(r)


def ratio_interval_text(r: RatioStat) -> str:
    """' [1.8 – 3.5]', the ratio's 95% interval as the ratio table writes it; '' where
    there is none."""
    if r.low is None or math.isnan(r.low):
        return ""
    # both ends may be inf (HER never crossing in every resample pair)
    lo, hi = ("∞" if math.isinf(x) else f"{x:.1f}" for x in (r.low, r.high))
    return f" [{lo} – {hi}]"


def ratio_rows(rs: list[RatioStat]) -> tuple[tuple, list[tuple]]:
    """(header, rows) of the HER/ACDER ratios: ours (mean curve with its 95%
    interval; the per-seed medians' and means' ratios) and the paper's."""
    header = ("HER / ACDER episodes",) + tuple(task_label(r.env) for r in rs)
    return header, [
        ("ours: mean curve [95% interval]",) + tuple(ratio_text(r) for r in rs),
        ("ours: per-seed medians",)
        + tuple("–" if r.seed_ratio is None else f"{r.seed_ratio:.1f}" for r in rs),
        ("ours: per-seed means",)
        + tuple(
            "–" if r.seed_mean_ratio is None else f"{r.seed_mean_ratio:.1f}" for r in rs
        ),
        ("paper",) + tuple("–" if r.paper is None else f"{r.paper:.1f}" for r in rs),
    ]


def to_markdown(header, rows) -> str:
    """A markdown table (for the terminal and README files)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(x) for x in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def to_html(header, rows, caption: tuple[str, str] | None = None) -> str:
    """The same table as HTML: the book renders it as a table (myst-nb shows a markdown
    output's pipes as text, since its markdown outputs are CommonMark, which has no
    tables). A cell's line breaks ("\\n") become <br>; `caption`, (title, text), is
    written above the table, the title in bold."""

    def cell(tag, x):
        text = html.escape(str(x))
        while text.count("`") >= 2:  # `name` -> <code>name</code>
            text = text.replace("`", "<code>", 1).replace("`", "</code>", 1)
        text = text.replace("\n", "<br>")
        return f"<{tag}>{text}</{tag}>"

    head = "".join(cell("th", h) for h in header)
    body = "".join(
        "<tr>" + "".join(cell("td", x) for x in row) + "</tr>" for row in rows
    )
    top = ""
    if caption:
        title, text = (html.escape(x) for x in caption)
        # above the table (the theme puts captions below), and a gap above it
        top = (
            '<caption style="caption-side: top; text-align: left; padding-top: 1.5em">'
            f"<strong>{title}.</strong> {text[:1].upper() + text[1:]}</caption>"
        )
    return f"<table>{top}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


CAPTION = (
    "Training episodes until the mean test success over seeds first reaches the "
    "threshold (Reach 100%, 95% on the other tasks): the mean curve at the epoch "
    "evaluations, linearly interpolated, a seed stopped by the stop rule carrying its "
    "last 5 evaluations' mean forward; in Table I's unit of 400 episodes an epoch "
    "(where our epoch holds fewer, our own episodes in brackets); for a cell still "
    "training, how far its mean curve reaches and, where its seeds so far rule out an "
    "earlier crossing, the earliest one it can still make ('not before'). Beside it a "
    "95% bootstrap interval over seeds (resampled with replacement; the share of "
    "resamples whose mean curve crosses; 'beyond budget' where more than 2.5% never "
    "cross, 'not yet' where they may still, a seed being in training, 'cut short' "
    "where a seed's curve was cut before its budget) and each seed's own first "
    "crossing (median, range, mean)."
)


def markdown(cells: list[CellStat]) -> str:
    """Table I and the ratios as the `table` command prints them."""
    out = CAPTION + "\n\n" + to_markdown(*table_rows(cells))
    rs = ratios(cells)
    if rs:
        out += "\n" + to_markdown(*ratio_rows(rs))
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `python -m acder_lite table`."""
    parser.add_argument(
        "--results",
        default="results",
        help="a folder of runs: <env>/<name>/seed<k>/ (a cell per <name>), or run "
        "folders of any other name (a cell each), or one run folder (default: results)",
    )
    parser.add_argument(
        "--plan",
        default=None,
        metavar="FILE",
        help="plan file for the planned seed counts "
        "(default: RESULTS/plan.toml if present)",
    )
    parser.add_argument(
        "--format",
        choices=("markdown", "json"),
        default="markdown",
        help="markdown (default) or the cells and ratios as JSON",
    )
    parser.add_argument(
        "--resamples",
        type=int,
        default=None,
        help="bootstrap resamples per cell (default: 2000)",
    )


def read_planned(args, root: Path) -> dict:
    """The plan's seed counts, or {} (with one line on stderr if RESULTS/plan.toml
    cannot be read). A --plan FILE that cannot be read is an error (ConfigError)."""
    from acder_lite.runs.plan import PlanError

    plan = Path(args.plan) if args.plan else root / "plan.toml"
    if args.plan and not plan.is_file():
        what = "is a folder" if plan.is_dir() else "does not exist"
        raise ConfigError(
            f"table: --plan {str(plan)!r} {what}; allowed: a plan file (TOML), or "
            "no --plan for RESULTS/plan.toml if there is one"
        )
    if not plan.exists():
        return {}
    try:
        return planned_cells(plan, root)
    except PlanError as e:
        if args.plan:
            raise ConfigError(f"table: --plan: {e}") from None
        print(f"table: {e}; seed counts are the seeds found", file=sys.stderr)
        return {}


def run(args) -> int:
    """Print Table I from the runs under --results;
    2 with a one-line error if none can be read."""
    for name in ("results", "plan"):  # Path("") is ".": read as this folder (or none)
        if getattr(args, name) == "":
            print(
                f"error: table: --{name} '' is empty; allowed: a "
                + ("folder of runs" if name == "results" else "plan file (TOML)"),
                file=sys.stderr,
            )
            return 2
    root = Path(args.results)
    if args.resamples is not None and args.resamples < 1:
        print(
            f"error: table: --resamples={args.resamples} is not allowed: "
            "an integer >= 1",
            file=sys.stderr,
        )
        return 2
    if not root.is_dir():
        what = "is a file" if root.exists() else "does not exist"
        print(
            f"error: table: results folder {str(root)!r} {what}; allowed: a folder of "
            "runs (<env>/<name>/seed<k>/ as the grid has them, or run folders of any "
            "name) or one run folder",
            file=sys.stderr,
        )
        return 2
    skipped: list[str] = []
    runs = load_runs(root, warn=skipped.append)
    if not runs:
        why = (
            f" ({count(len(skipped), 'folder')} skipped, first: {skipped[0]})"
            if skipped
            else "; allowed: a folder of runs written by train or sweep "
            "(<env>/<name>/seed<k>/, or run folders of any name) or one run folder"
        )
        print(
            f"error: table: no readable run under {str(root)!r}{why}", file=sys.stderr
        )
        return 2
    for line in skipped:
        print(f"table: {line}", file=sys.stderr)
    planned = read_planned(args, root)
    grid = grid_cells()
    found = {(r["env"], r["name"]) for r in runs} | set(planned)
    kw = {} if args.resamples is None else dict(n_boot=args.resamples)
    cells = summarize(runs, planned, cells=grid if found & set(grid) else None, **kw)
    if args.format == "json":
        print(
            json.dumps(
                dict(
                    cells=[c.to_dict() for c in cells],
                    ratios=[r.to_dict() for r in ratios(cells)],
                ),
                indent=2,
            )
        )
    else:
        print(markdown(cells), end="")
    return 0
