"""Run a grid of (env, method, seed) runs as Ray tasks: on a local Ray, or on a cluster.

`python -m acder_lite sweep --envs FetchReach-v4 --methods her acder --seeds 0 1
--results R` trains one cell per task into `R/<env>/<method>/seed<k>`; `sweep --plan
results/plan.toml` runs the cells a plan file declares
(`acder_lite.runs.plan.read_plan`): the same command every session.

Each cell is one Ray task reserving `--threads` CPUs, so Ray packs as many runs as fit.
The task decides when it starts what its folder needs: nothing (`done.json`),
`train --resume` (a `checkpoint.pt`, or a `checkpoint.packed/` from another machine:
`acder_lite.runs.packed`) or a fresh `train --out`; so Ray's own retry after
a lost worker (killed process, lost node) resumes the run from its last checkpoint, and
the trainer's determinism makes the result equal to an uninterrupted run's. A plan's
`same_as` cell is not trained at all: the sweep copies the finished run it names, once
the two configs are checked equal (`acder_lite.runs.same_as`). Training
runs in the task's own worker process, which reports its pid in the first line it writes
to `train.log`. Ctrl-C cancels the running tasks: each stops at once and keeps its last
end-of-epoch checkpoint; the same command continues. A local sweep hands Ray only as
many cells as run at once (`CellQueue`), in the plan's order, and reads a plan file
again whenever a cell ends, so a hold deleted from the file takes effect without a
restart.

Without `--address` the sweep starts a local Ray of its own (nothing to set up) and
stops it at the end; with `--address auto` or `--address HOST:PORT`, run on a node of a
running cluster, it joins that cluster, where the results folder must be shared storage
that every node sees at the same path (`acder_lite.cli.cluster`). Trap: a local Ray
cannot be kept on the loopback interface: Ray 2.60 turns 127.0.0.1 into the node's own
address (`services.resolve_ip_for_localhost`) and its gRPC servers listen on every
interface; what guards them is the token authentication that Ray turns on by default for
a Ray that `ray.init` starts.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import shlex
import sys
import time
from pathlib import Path

from acder_lite.cli import cluster
from acder_lite.runs import grid_time, same_as
from acder_lite.config import MAX_THREADS, THREADS_ALLOWED, Config, ConfigError
from acder_lite.io import file_in_the_way, probe_write
from acder_lite.precision import usable_cpus
from acder_lite.runs.plan import (
    Cell,
    PlanError,
    cell_state,
    check_names,
    check_pairs,
    plan,
    read_plan,
)
from acder_lite.words import count

EXIT_INTERRUPTED = 130
"""Return code after Ctrl-C (128 + SIGINT), as a shell reports it."""

MAX_RETRIES = 3
"""Ray's retries of a cell whose worker process died
(each retry resumes from the checkpoint)."""

LOCK = ".sweep.lock"
"""A run folder's lock file: held (flock) by the task training into it, so two sweeps
never write one folder; the kernel releases it when the process dies."""


# ----- the options

_PASSED = (
    "epochs",
    "workers",
    "eval_every_cycles",
    "success_threshold",
    "stop_patience",
    "stop_gap_episodes",
)
"""Sweep options that are Config fields, passed to every cell's train."""


class _Once(argparse.Action):
    """An option that may be given once: a second one is refused. Trap: argparse's
    store let it replace the first without a word (`--train-args '--cycles 2'
    --train-args '--batch-size 16'` trained the task's preset cycles)."""

    def __call__(self, parser, namespace, values, option_string=None):
        seen = f"_{self.dest}_given"
        if getattr(namespace, seen, False):
            raise argparse.ArgumentError(
                self,
                f"given twice ({getattr(namespace, self.dest)!r}, then {values!r}); "
                "allowed: once, with all its options in one quoted string",
            )
        setattr(namespace, seen, True)
        setattr(namespace, self.dest, values)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `python -m acder_lite sweep`."""
    parser.add_argument(
        "--plan",
        default=None,
        metavar="FILE",
        help="a plan file (TOML, see `acder_lite.runs.plan.read_plan`), e.g. "
        "results/plan.toml, instead of --envs/--methods/--seeds",
    )
    parser.add_argument(
        "--envs",
        nargs="+",
        default=None,
        metavar="ENV",
        help="tasks, e.g. FetchReach-v4 FetchPush-v4",
    )
    parser.add_argument(
        "--methods",
        nargs="+",
        default=None,
        metavar="METHOD",
        help="rows of the method table, e.g. her acder",
    )
    parser.add_argument("--seeds", nargs="+", type=int, default=None, metavar="N")
    parser.add_argument(
        "--results",
        default=None,
        help="root of <env>/<method>/seed<k> (default: results); not with --plan, "
        "whose cells go under the plan file's folder or a group's root",
    )
    parser.add_argument(
        "--address",
        default=None,
        help="join a running Ray cluster from one of its nodes: 'auto' or HOST:PORT "
        "(the head's GCS port; if the cluster uses token authentication, also "
        "RAY_AUTH_MODE=token); default: start a local Ray for this sweep",
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=None,
        help="local Ray: runs at once (default: cores // threads); "
        "ignored on a cluster",
    )
    parser.add_argument(
        "--threads",
        type=int,
        default=1,
        help=f"CPUs each cell reserves, and its torch threads, at most {MAX_THREADS} "
        "(default: 1)",
    )
    parser.add_argument("--epochs", type=int, default=None, help="passed to train")
    parser.add_argument("--workers", type=int, default=None, help="passed to train")
    parser.add_argument(
        "--eval-every-cycles", type=int, default=None, help="passed to train"
    )
    parser.add_argument(
        "--success-threshold", type=float, default=None, help="passed to train"
    )
    parser.add_argument(
        "--stop-patience", type=int, default=None, help="passed to train"
    )
    parser.add_argument(
        "--stop-gap-episodes", type=int, default=None, help="passed to train"
    )
    parser.add_argument(
        "--train-args",
        action=_Once,
        default="",
        metavar="'ARGS'",
        help="more options for train, one quoted string: --train-args='--cycles 2'",
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="print what each cell would do (run / resume / skip) and exit",
    )


def passed_options(args) -> dict:
    """The Config fields the sweep's own options set (`_PASSED`), those given."""
    return {
        name: getattr(args, name) for name in _PASSED if getattr(args, name) is not None
    }


def check_args(args) -> str | None:
    """The first problem with the options, as one line, or None.
    Fills the default of jobs. Config's verdict on them, cell by cell, is
    `check_cells` (after planning: a plan's pairs are in its file)."""
    grid = [args.envs, args.methods, args.seeds]
    # "" was no --results (results/), no --address (a local Ray), or "." for --plan
    for name, allowed in (
        ("plan", "a plan file"),
        ("results", "a folder"),
        ("address", "'auto' or HOST:PORT"),
    ):
        if getattr(args, name) == "":
            return f"--{name} '' is empty; allowed: {allowed}"
    if args.plan is not None:
        if any(x is not None for x in grid):
            return (
                "--plan FILE and --envs/--methods/--seeds "
                "exclude each other; allowed: one of them"
            )
        if args.results is not None:  # it would be ignored: say so instead
            return (
                "--plan FILE and --results exclude each other: a plan's cells go "
                "under the plan file's folder, or under a group's `root`"
            )
    elif any(x is None for x in grid):
        return "--envs, --methods and --seeds are required (or --plan FILE)"
    else:
        problem = check_names(*grid, dashes="--")
        if problem:
            return problem
        problem = check_pairs(args.envs, args.methods)
        if problem:  # EBP on Reach: no cell to skip silently
            return (
                f"--envs x --methods: {problem}; a grid with gaps is a plan "
                "file (--plan), one group per gapless grid"
            )
    if not 1 <= args.threads <= MAX_THREADS:  # Ray reserves them: no node has more
        return f"--threads={args.threads} is not allowed: {THREADS_ALLOWED}"
    if args.jobs is None:
        args.jobs = max(1, usable_cpus() // args.threads)
    if args.jobs < 1:
        return f"--jobs={args.jobs} is not allowed: an integer >= 1"
    try:
        extra = shlex.split(args.train_args or "")
    except ValueError as e:
        return f"--train-args cannot be parsed: {e}"
    # --out=DIR too: after the cell's own --out, it sent every cell to DIR
    if any(a.split("=", 1)[0] in ("--out", "--resume") for a in extra):
        return (
            "--train-args may not hold --out or --resume; the sweep sets them per cell"
        )
    problem = _train_options(extra)
    return problem if isinstance(problem, str) else None


_OWN = {
    **{name: "--" + name.replace("_", "-") for name in _PASSED},
    "threads": "--threads",
}
"""The Config fields sweep has an option of its own for, and that option."""


def _train_options(extra: list[str]) -> dict | str:
    """--train-args as train reads them: the Config fields they set, or the problem as
    one line (an option train has not, one of the cell's own: env, method, seed, or
    one of sweep's own: `_OWN`).

    Trap: train reads --train-args after the sweep's options, so a duplicate there won
    silently (`--epochs 3 --train-args '--epochs 5'` trained 5), and a --threads there
    left Ray reserving the sweep's --threads CPUs a cell."""
    from acder_lite.cli.train import UsageError, base_parser, given_options

    if any(a in ("-h", "--help") for a in extra):
        return "--train-args may not hold --help; see `train --help`"
    try:
        targs = base_parser().parse_args(["train", *extra, "--out", "-"])
    except UsageError as e:
        return (
            f"--train-args: {re.sub(r'^python -m acder_lite( train)?: ', '', str(e))}"
        )
    given = given_options(targs)
    own = [k for k in ("env", "method", "seed") if k in given]
    if own:
        return (
            f"--train-args may not hold --{own[0]}; the sweep sets it per cell "
            "(--envs, --methods, --seeds or the plan)"
        )
    dup = [k for k in _OWN if k in given]
    if dup:
        return (
            f"--train-args may not hold {_OWN[dup[0]]}: it is sweep's own "
            f"{_OWN[dup[0]]}; allowed: sweep {_OWN[dup[0]]} alone"
        )
    return given


def check_cells(cells: list[Cell], args) -> str | None:
    """The sweep's own options, then --train-args, checked by Config on every
    (env, method, plan config) of the grid, before any cell starts (else every cell
    would fail in its train.log): the first problem, as one line naming the pair.
    Call after `check_args`.

    Trap: checked on ENV_IDS[0] (FetchReach-v4) instead, a --train-args option valid
    on every task of the grid was refused (--sicm-angles sincos on Push), and one
    refused by a task of the grid but not Reach's would fail in every such cell."""
    given = _train_options(shlex.split(args.train_args or ""))
    if isinstance(given, str):
        return given
    seen = set()
    for c in cells:
        key = (c.env, c.method, repr(sorted(c.options.items())))
        if key in seen:
            continue
        seen.add(key)
        problem = _overrides_plan(c, passed_options(args), given)
        if problem:
            return problem
        for prefix, extra in (("", {}), ("--train-args: ", given)):
            try:
                Config(
                    **{**cell_options(c, args), **extra},
                    env=c.env,
                    method=c.method,
                    seed=c.seed,
                ).resolve()
            except ConfigError as e:
                return f"{prefix}{e}; on the pair ({c.env}, {c.method})"
    return None


def _overrides_plan(cell: Cell, passed: dict, given: dict) -> str | None:
    """A sweep option (`passed`) or a --train-args one (`given`) that sets a field of
    the cell's plan `config` to another value, as one line. Trap: the sweep's options
    came after the plan's in train's command line and won without a word (a plan's
    `epochs = 40` trained `sweep --epochs`'s 5); the plan is the grid's record."""
    for options, how in ((passed, ""), (given, " in --train-args")):
        for name, value in options.items():
            if name in cell.options and cell.options[name] != value:
                return (
                    f"--{name.replace('_', '-')} {value!r}{how} differs from the "
                    f"plan's config {name} = {cell.options[name]!r} of {cell.name}; "
                    f"allowed: the plan's value, or no --{name.replace('_', '-')} "
                    "(change the plan file)"
                )
    return None


def check_folders(cells: list[Cell]) -> str | None:
    """A run folder that cannot be one (it, or a folder above it, is a file; or it is
    inside another run's folder: `runs.run_folder_above`), as one line."""
    from acder_lite.runs.read import run_folder_above

    looked = set()
    for c in cells:
        p = file_in_the_way(c.out)
        if p:
            return (
                f"results folder {p!r} is a file; "
                "allowed: a folder (or a path not yet there)"
            )
        if c.out.parent in looked:  # the cells of one <env>/<method> share it
            continue
        looked.add(c.out.parent)
        above = run_folder_above(c.out)
        if above:
            return (
                f"results folder {str(c.out)!r} is inside the run folder "
                f"{str(above[0])!r} (it holds {above[1]}); allowed: a results folder "
                "outside every run folder"
            )
    return None


def check_writable(cells: list[Cell]) -> str | None:
    """A folder the cells to train or copy cannot be written in, as one line: for each
    such cell the nearest folder there above its run folder (the one it is, or is to
    be, made in), probed once with a file made and removed (`io.probe_write`). Trap:
    the dry run said "1 to run" of a results root no file can be made in (/proc/x;
    os.access says yes to root), and each cell then failed. Not the run folder
    itself: a resumed cell's may be training at that moment."""
    probed = set()
    for c in cells:
        if c.action == "skip":
            continue
        folder = next(p for p in c.out.parents if p.is_dir())
        if folder in probed:
            continue
        probed.add(folder)
        try:
            probe_write(str(folder))
        except OSError as e:
            return (
                f"results folder {str(folder)!r} cannot be written ({e.strerror}), "
                f"where {c.name} is to go; allowed: a folder you can write to"
            )
    return None


class CellQueue:
    """The cells still to start, in the plan's order, handed out so that at most
    `limit` run at once (None: all at once, for a cluster's own scheduler).

    Trap: handing a local Ray every cell at once lets Ray order them, and a cell that
    Ray retries after a lost worker goes behind every queued one (seen here: the plan's
    order lost for hours). A local sweep hands Ray only as many cells as it runs, so a
    retry starts at once and the plan's order holds.

    `replan` (a plan file's `read_plan`, or None) is called by `reread` whenever a cell
    ends: a hold deleted from the file starts its cells in their place in the plan,
    without a restart; a hold added keeps the group's unstarted cells back.
    """

    def __init__(self, cells: list[Cell], limit: int | None, replan=None):
        self.waiting = list(cells)
        self.limit, self.replan = limit, replan
        self.started: set[Path] = set()
        self.problem = ""
        """Why the plan could not be read the last time (`reread`; "" once it could):
        the sweep ends with it, exit 2, if the file is still wrong at its end."""

    def take(self, running: int) -> list[Cell]:
        """The cells to start now, with `running` cells already running."""
        n = len(self.waiting) if self.limit is None else max(0, self.limit - running)
        out, self.waiting = self.waiting[:n], self.waiting[n:]
        self.started.update(c.out for c in out)
        return out

    def reread(self) -> str:
        """Read the plan again (if there is one); the cells not started yet become the
        plan's runnable ones. Returns what changed, in one line ("" if nothing)."""
        if self.replan is None:
            return ""
        try:
            cells = self.replan()
            self.problem = check_folders(cells) or ""
        except PlanError as e:
            self.problem = str(e)
        if self.problem:
            # the running cells go on, the cells planned before stay queued
            return (
                f"plan not read again ({self.problem}); the queue stays as it was "
                "(fix the plan: it is read again when a cell ends)"
            )
        before = {c.out for c in self.waiting}
        self.waiting = [
            c for c in cells if c.action != "skip" and c.out not in self.started
        ]
        after = {c.out for c in self.waiting}
        added = [c.name for c in self.waiting if c.out not in before]
        dropped = len(before - after)
        parts = []
        if added:
            more = ", ..." if len(added) > 3 else ""
            parts.append(
                f"{count(len(added), 'cell')} now to run ({', '.join(added[:3])}{more})"
            )
        if dropped:
            parts.append(f"{count(dropped, 'cell')} no longer to run")
        return "plan read again: " + "; ".join(parts) if parts else ""


def cell_options(cell: Cell, args) -> dict:
    """The Config fields a cell trains with beyond env, method and seed: its plan
    group's, the sweep's own options (`passed_options`) and --threads (which a plan's
    config may not set: `plan.read_plan` refuses it)."""
    return {**cell.options, **passed_options(args), "threads": args.threads}


def train_argv(cell: Cell, args, resume: bool) -> list[str]:
    """The `acder_lite train` arguments of one cell: its options,
    the sweep's, --train-args.

    A resumed cell gets `--resume DIR` and the same options as a fresh one: train
    accepts a changed epochs/threads/stop option and refuses (exit 2, in train.log) any
    other change. A fresh cell whose precision is 'auto' gets the one the sweep decided
    for its task (`decide_update_dtypes`) as `--update-dtype`.
    """
    argv = [
        "train",
        "--env",
        cell.env,
        "--method",
        cell.method,
        "--seed",
        str(cell.seed),
    ]
    argv += ["--resume", str(cell.out)] if resume else ["--out", str(cell.out)]
    options = cell_options(cell, args)
    decided = None if resume else decided_dtype(cell, args)
    if decided:  # a resumed cell keeps the precision its checkpoint records
        options["update_dtype"] = decided[0]
    for name, value in options.items():
        if isinstance(value, bool):  # a Config flag (compile_update): given or not
            argv += ["--" + name.replace("_", "-")] if value else []
            continue
        argv += ["--" + name.replace("_", "-"), str(value)]
    return argv + shlex.split(args.train_args or "") + ["--quiet"]


def decide_update_dtypes(cells: list[Cell], args) -> list[str]:
    """Decide `--update-dtype auto` once per task, in the driver, for the fresh cells
    ('run') about to start: the grid's rule is one precision per task, and cells that
    each timed the update for themselves, on cores their neighbours keep busy, could
    split a task between two. The decision is `Config.resolve`'s for the task's first
    such cell (`precision.choose_update_dtype`: the update timed in both precisions),
    kept in `args.update_dtypes` ({env: (dtype, why)}), which `train_argv` passes to
    each fresh cell of the task. Tasks decided already keep their decision; no decision
    where the cell's plan fixes the precision (results/plan.toml: float32) or
    --train-args sets it. Returns a line to say for each task decided now."""
    decided = vars(args).setdefault("update_dtypes", {})
    given = _train_options(shlex.split(args.train_args or ""))
    if not isinstance(given, dict) or "update_dtype" in given:
        return []
    lines = []
    for c in cells:
        if (
            c.action != "run"
            or c.env in decided
            or c.options.get("update_dtype", "auto") != "auto"
        ):
            continue
        try:
            cfg = cell_config(c, args, given)
        except ConfigError:  # `check_cells` says so
            continue
        decided[c.env] = (cfg.update_dtype, cfg.update_dtype_why)
        n = sum(
            x.env == c.env
            and x.action == "run"
            and x.options.get("update_dtype", "auto") == "auto"
            for x in cells
        )
        lines.append(
            f"update_dtype {cfg.update_dtype} for {c.env}'s "
            f"{count(n, 'new cell')} ({cfg.update_dtype_why})"
        )
    return lines


def cell_config(cell: Cell, args, given: dict) -> Config:
    """The resolved config this sweep gives `cell`: its plan group's fields and the
    sweep's options (`cell_options`), then the --train-args fields `given`
    (`check_cells` refuses one that sets a field the plan sets). ConfigError if
    invalid."""
    return Config(
        **{**cell_options(cell, args), **given},
        env=cell.env,
        method=cell.method,
        seed=cell.seed,
    ).resolve()


def decided_dtype(cell: Cell, args) -> tuple[str, str] | None:
    """(dtype, why) the sweep decided for `cell`'s task if the cell's precision is
    'auto' (`decide_update_dtypes`), else None."""
    if cell.options.get("update_dtype", "auto") != "auto":
        return None
    return getattr(args, "update_dtypes", {}).get(cell.env)


IGNORED_WHEN_DONE = (*same_as.NEUTRAL_FIELDS, "update_dtype_why", "device_why")
"""Config fields a finished cell's config.json may differ in without a note
(`config_differences`): `same_as.NEUTRAL_FIELDS` (speed only), and the two `_why`
fields, which say why `resolve` chose update_dtype and device (each value is
compared itself; a reason such as 'asked for' against 'auto: ...' is no setting)."""

SICM_ONLY = ("sicm_input", "sicm_angles")
"""Config fields only S-ICM reads (`Trainer.curiosity_inputs`): compared only for a
method with S-ICM. Trap: sicm_input's default became 'raw' after the readings
(protocol v2's first decision), and the grid's HER runs on Push, trained before that,
recorded 'normalised', which HER never reads: every sweep flagged them."""


def config_differences(cell: Cell, args) -> str:
    """How a finished cell's config.json differs from the config this sweep would give
    the cell (its plan group's fields, the sweep's options, --train-args), compared as
    `same_as.check` does but for `IGNORED_WHEN_DONE` and, on a method without S-ICM,
    `SICM_ONLY`: '' if in nothing, else one clause ('its config differs: epochs 2
    (this sweep: 50)')."""
    given = _train_options(shlex.split(args.train_args or ""))
    try:
        ours = cell_config(cell, args, given if isinstance(given, dict) else {})
    except ConfigError:  # `check_cells` says so
        return ""
    try:
        theirs = same_as.read_resolved(cell.out)
    except (OSError, ValueError, KeyError, TypeError, ConfigError) as e:
        return f"its config.json cannot be read to compare ({type(e).__name__})"
    ignored = set(IGNORED_WHEN_DONE)
    if ours.switches.get("curiosity") != "sicm":
        ignored |= set(SICM_ONLY)
    diffs = [
        f"{name} {other!r} (this sweep: {mine!r})"
        for name, other, mine in same_as.differences(ours.to_dict(), theirs, ignored)
    ]
    if not diffs:
        return ""
    more = f" and {len(diffs) - 3} more" if len(diffs) > 3 else ""
    return "its config differs: " + ", ".join(diffs[:3]) + more


def note_config_differences(cells: list[Cell], args) -> None:
    """Add to the note of each finished cell (skipped: 'already complete') how its
    config.json differs from the config this sweep would give it; still a skip."""
    for c in cells:
        if c.action == "skip" and c.note == "already complete":
            why = config_differences(c, args)
            if why:
                c.note += f"; {why}"


def copy_cell(cell: Cell, args) -> str:
    """Copy a 'copy' cell's `same_as` run into its folder once it is checked against the
    cell's whole config (the plan's fields, the sweep's options and --threads); returns
    'copied' or 'FAILED: why' (one line)."""
    if args.train_args:
        return (
            "FAILED: a same_as cell cannot be checked against --train-args; "
            "allowed: no --train-args"
        )
    try:
        config = Config(
            **cell_options(cell, args), env=cell.env, method=cell.method, seed=cell.seed
        ).resolve()
    except ConfigError as e:
        return f"FAILED: {e}"
    verdict, why = same_as.check(config.to_dict(), cell.source)
    if verdict != "copy":
        return f"FAILED: {why}"
    same_as.copy_run(
        cell.source,
        cell.out,
        dict(
            run=os.path.relpath(cell.source, cell.out),  # portable: from this folder
            compared="every Config field but " + ", ".join(same_as.NEUTRAL_FIELDS),
            by="sweep: a plan group's same_as",
        ),
    )
    return "copied"


# ----- the task (runs in a Ray worker process)


def train_cell(cell: Cell, args) -> dict:
    """Train one cell in this process: fresh, resumed or skipped,
    decided now from its folder.

    stdout and stderr go to `DIR/train.log`, whose first line of each attempt names this
    pid. Returns dict(status, pid, attempts, log_tail).
    """
    import fcntl
    from acder_lite.cli.train import base_parser, run_main

    cell.out.mkdir(parents=True, exist_ok=True)
    lock = open(cell.out / LOCK, "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return dict(
            status="skipped: another sweep trains into this folder",
            pid=os.getpid(),
            attempts=0,
            log_tail="",
        )
    state = cell_state(cell.out)
    if state == "done":
        return dict(status="done", pid=os.getpid(), attempts=0, log_tail="")
    if state == "orphan":
        return dict(
            status="FAILED: progress.csv without checkpoint.pt; "
            "remove the folder to start over",
            pid=os.getpid(),
            attempts=0,
            log_tail="",
        )
    argv = train_argv(cell, args, resume=state == "interrupted")
    log_path = cell.out / "train.log"
    with open(log_path, "a") as log, _redirected(log):
        print(
            f"# {time.strftime('%Y-%m-%d %H:%M:%S')} sweep: pid {os.getpid()}: "
            f"python -m acder_lite {shlex.join(argv)}",
            flush=True,
        )
        decided = None if state == "interrupted" else decided_dtype(cell, args)
        if decided:  # config.json says "asked for": the measurement is here
            print(
                f"# sweep: --update-dtype {decided[0]}, decided once for "
                f"{cell.env}'s new cells: {decided[1]}",
                flush=True,
            )
        try:
            rc = run_main(base_parser, argv)
        except KeyboardInterrupt:  # cancelled before train installed its own handler
            rc = EXIT_INTERRUPTED
        sys.stdout.flush()
        sys.stderr.flush()
    attempts = sum(
        line.startswith("# ") and " sweep: pid " in line
        for line in open(log_path, errors="replace")
    )
    if rc == 0 and (cell.out / "done.json").exists():
        status = "done"
    elif rc == EXIT_INTERRUPTED:
        status = "interrupted"
    else:
        status = f"FAILED rc={rc}"
    return dict(
        status=status, pid=os.getpid(), attempts=attempts, log_tail=_last_line(log_path)
    )


@contextlib.contextmanager
def _redirected(log):
    """File descriptors 1 and 2 (so C code and tqdm too) into `log` for the block."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    os.dup2(log.fileno(), 1)
    os.dup2(log.fileno(), 2)
    try:
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])


def _last_line(path: Path) -> str:
    """The last non-empty line of a log (progress-bar redraws split on
    carriage returns)."""
    try:
        with open(path, "rb") as f:
            f.seek(max(0, os.path.getsize(path) - 4096))
            lines = f.read().decode(errors="replace").replace("\r", "\n").splitlines()
    except OSError:
        return "no log"
    lines = [line.strip() for line in lines if line.strip()]
    return lines[-1][:200] if lines else "empty log"


# ----- the driver


def _say(msg: str) -> None:
    print(f"sweep: {msg}", flush=True)


def read_checked(args) -> list[Cell]:
    """The cells of --plan, checked with the sweep's options (`check_cells`); a
    PlanError if not, so a plan read again mid-sweep with a group that --train-args
    does not fit leaves the queue as it was."""
    cells = read_plan(args.plan)
    problem = check_cells(cells, args)
    if problem:
        raise PlanError(problem)
    return cells


def run(args) -> int:
    """Plan the grid and run it on Ray; 0 if every cell finished, 1 if one failed, 2 on
    bad input, 130 on Ctrl-C (every running cell keeps its last checkpoint)."""

    def bad(msg):
        print(f"error: sweep: {msg}", file=sys.stderr)
        return 2

    problem = check_args(args)
    if problem:
        return bad(problem)
    try:
        cells = (
            read_plan(args.plan)
            if args.plan is not None
            else plan(args.envs, args.methods, args.seeds, args.results or "results")
        )
        problem = check_cells(cells, args)
    except PlanError as e:
        return bad(e)
    if problem:
        return bad(problem)
    problem = check_folders(cells) or check_writable(cells)
    if problem:
        return bad(problem)
    # before the dry run too: it said nothing of an --address the real run refuses
    if args.address:
        problem = cluster.check_address(args.address)
        if problem:
            return bad(problem)
    note_config_differences(cells, args)
    if args.dry_run:
        for c in cells:
            print(
                f"{c.action:<6} {c.name:<40} {c.out}"
                + (f"  ({c.note})" if c.note else "")
            )
        counts = {
            a: sum(c.action == a for c in cells)
            for a in ("run", "resume", "copy", "skip")
        }
        _say(
            f"dry run: {counts['run']} to run, {counts['resume']} to resume, "
            f"{counts['copy']} to copy, {counts['skip']} to skip; "
            f"jobs={args.jobs} threads={args.threads}"
        )
        est = grid_time.estimate(cells, passed_options(args))
        _say(grid_time.sentence(est, args.jobs))
        return 0
    for c in cells:
        if c.action == "skip":
            _say(f"skip   {c.name} ({c.note})")
    todo = [c for c in cells if c.action not in ("skip", "copy")]
    if not todo:
        copied = _copy_all(cells, args)
        made = "".join(
            f"{copied[k]} {word}, "
            for k, word in (("done", "copied"), ("failed", "failed"))
            if copied[k]
        )
        skipped = len(cells) - copied["done"] - copied["failed"]
        _say(f"nothing to run: {made}{skipped} skipped")
        return 1 if copied["failed"] else 0
    # one precision per task, timed before Ray and the cells take the cores
    for line in decide_update_dtypes(todo, args):
        _say(line)
    import ray

    # Ray before the copies: a cluster that refuses this sweep leaves nothing written
    try:
        cluster.connect(args.address, args.jobs * args.threads, say=_say)
    except cluster.Refused as e:
        return bad(str(e))
    except Exception as e:  # e.g. the local Ray did not start (cluster.START_ATTEMPTS)
        what = f"joining {args.address!r}" if args.address else "starting the local Ray"
        first = cluster.first_line(e)[:200]
        print(f"error: sweep: {what} failed: {first}", file=sys.stderr)
        return 1
    from acder_lite.signals import interrupt_on_signals

    interrupt_on_signals()  # `kill PID` of a background sweep cancels its cells cleanly
    replan = (lambda: read_checked(args)) if args.plan is not None else None
    try:
        copied = _copy_all(cells, args)
        skipped = len(cells) - len(todo) - copied["done"] - copied["failed"]
        return _drive(todo, args, skipped, replan, copied)
    finally:
        ray.shutdown()


def _copy_all(cells: list[Cell], args) -> dict:
    """Copy every 'copy' cell (no Ray needed: a copy takes seconds); the counts."""
    copied = dict(done=0, failed=0)
    for c in cells:
        if c.action == "copy":
            _copy(c, args, copied)
    return copied


def _copy(cell: Cell, args, counts: dict) -> None:
    """Copy one 'copy' cell (`copy_cell`), count it and say so."""
    status = copy_cell(cell, args)
    counts["done" if status == "copied" else "failed"] += 1
    _say(f"finish {cell.name}: {status} (same_as {cell.source})")


def _drive(
    todo: list[Cell], args, skipped: int, replan=None, copied: dict | None = None
) -> int:
    import ray
    from tqdm import tqdm

    # max_calls=1: a fresh worker process per cell (a run's replay buffer is gigabytes)
    task = ray.remote(max_calls=1)(train_cell).options(
        num_cpus=args.threads, max_retries=MAX_RETRIES
    )
    # a local Ray gets `jobs` cells at a time (CellQueue says why); a cluster all
    queue = CellQueue(todo, None if args.address else args.jobs, replan)
    refs: dict = {}
    counts = dict(done=0, failed=0, interrupted=0)
    for key, n in (copied or {}).items():  # the copies made before Ray started
        counts[key] += n
    bar = tqdm(
        total=len(todo),
        unit="cell",
        dynamic_ncols=True,
        file=sys.stderr,
        disable=not sys.stderr.isatty(),
    )

    def start() -> None:
        while cells := queue.take(len(refs)):
            for line in decide_update_dtypes(cells, args):  # a task a replan added
                _say(line)
            for c in cells:
                if c.action == "copy":  # a same_as run that finished meanwhile
                    _copy(c, args, counts)
                    bar.update(1)
                else:
                    refs[task.remote(c, args)] = c

    start()
    _say(
        f"{count(len(todo), 'cell')} "
        f"({sum(c.action == 'resume' for c in todo)} to resume), "
        f"threads={args.threads} each"
        + ("" if args.address else f", local Ray of {args.jobs * args.threads} CPUs")
    )
    t0 = time.monotonic()
    stopped: list[Cell] = []  # the cells interrupted, to say which can resume
    try:
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1, timeout=1.0)
            for ref in ready:
                cell = refs.pop(ref)
                if _finish(cell, ref, counts, bar, t0) == "interrupted":
                    stopped.append(cell)
                change = queue.reread()
                if change:
                    _say(change)
                    bar.total = bar.n + len(refs) + len(queue.waiting)
                start()
    except KeyboardInterrupt:
        _say(
            f"interrupt: cancelling {count(len(refs), 'cell')}; "
            "each keeps its last checkpoint"
        )
        for ref in refs:  # the cells running now: those handed to Ray, not yet ended
            ray.cancel(ref)
        for ref, cell in list(refs.items()):
            if _finish(cell, ref, counts, bar, t0) == "interrupted":
                stopped.append(cell)
        bar.close()
        _say(interrupted_line(counts, stopped, len(queue.waiting)))
        return EXIT_INTERRUPTED
    bar.close()
    _say(
        f"all done: {counts['done']} finished, {counts['failed']} failed, "
        + (
            f"{counts['interrupted']} interrupted (re-run the same command to resume), "
            if counts["interrupted"]
            else ""
        )
        + f"{skipped} skipped"
    )
    if queue.problem:  # the plan was still wrong when the last cell ended
        print(
            f"error: sweep: {queue.problem}; the cells planned before it was edited "
            "have run; fix the plan, then run the same command for the rest",
            file=sys.stderr,
        )
        return 1 if counts["failed"] or counts["interrupted"] else 2
    return 1 if counts["failed"] or counts["interrupted"] else 0


def interrupted_line(counts: dict, stopped: list[Cell], waiting: int) -> str:
    """The last line after Ctrl-C: the cells finished, those stopped (`stopped`: at
    their last checkpoint, or before their first, which start over), failed, and
    not started (`waiting`).

    Trap: it counted only the finished and the not started ones ("0 finished, 0 not
    started" after stopping the one cell that ran)."""
    resumable = sum(cell_state(c.out) == "interrupted" for c in stopped)
    fresh = len(stopped) - resumable
    parts = [
        f"{counts['done']} finished",
        f"{resumable} stopped at "
        + ("its last checkpoint" if resumable == 1 else "their last checkpoints"),
    ]
    if fresh:
        parts.append(
            f"{fresh} stopped before "
            + ("its first checkpoint" if fresh == 1 else "their first checkpoints")
            + " (to start over)"
        )
    if counts["failed"]:
        parts.append(f"{counts['failed']} failed")
    parts.append(f"{waiting} not started")
    return f"interrupted: {', '.join(parts)}; re-run the same command to continue"


def _finish(cell: Cell, ref, counts: dict, bar, t0: float) -> str:
    """Report one cell that ended (its task's result, or why there is none); returns
    how it is counted: 'done', 'interrupted' or 'failed'."""
    import ray

    try:
        r = ray.get(ref)
    except (ray.exceptions.TaskCancelledError, KeyboardInterrupt):
        r = dict(status="interrupted", attempts=0, log_tail="")
    except ray.exceptions.RayError as e:
        r = dict(
            status=f"FAILED: {type(e).__name__}",
            attempts=0,
            log_tail=_last_line(cell.out / "train.log"),
        )
    status = r["status"]
    key = (
        "done"
        if status in ("done",) or status.startswith("skipped")
        else ("interrupted" if status == "interrupted" else "failed")
    )
    counts[key] += 1
    bar.update(1)
    more = f" (attempts {r['attempts']})" if r.get("attempts", 0) > 1 else ""
    tail = (
        f": {r['log_tail']} (see {cell.out / 'train.log'})" if key == "failed" else ""
    )
    _say(f"finish {cell.name}: {status}{tail} after {time.monotonic() - t0:.0f}s{more}")
    return key
