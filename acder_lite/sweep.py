"""Run a grid of (env, method, seed) training runs as parallel, resumable subprocesses.

`python -m acder_lite sweep --envs FetchReach-v4 FetchPush-v4 --methods her acder --seeds 0 1 2`
starts one `python -m acder_lite train ... --out RESULTS/<env>/<method>/seed<k>` per cell, at
most `--jobs` at a time, each logging to `DIR/train.log`. `sweep --plan results/plan.toml` runs
the cells a plan file declares instead (`read_plan`): the same command every session. Re-running the same command is safe:
a cell with `done.json` is skipped, one with `checkpoint.pt` (and no `done.json`) is resumed with
`--resume DIR`, an empty or missing one starts fresh; anything else (a live run, a progress.csv
without checkpoint) is left alone. Ctrl-C (SIGINT, or SIGTERM) forwards SIGINT to the
running children, waits until they have exited (leaving their checkpoints) and returns 130.
"""
from __future__ import annotations

import argparse
import itertools
import os
import shlex
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from .config import ENV_IDS, METHODS, OBJECT_ENVS, Config, ConfigError

EXIT_INTERRUPTED = 130
"""Return code after Ctrl-C (128 + SIGINT), as a shell reports it."""

POLL_S = 0.2
"""How often the scheduler checks its children."""


@dataclass
class Cell:
    """One (env, method, seed) of the grid and what the sweep will do with it."""

    env: str
    method: str
    seed: int
    out: Path
    action: str
    """'run' (fresh), 'resume' (checkpoint.pt, no done.json) or 'skip' (see `plan`)."""
    note: str = ""
    """Why a cell is skipped, or what was found in its directory."""
    options: dict = field(default_factory=dict)
    """Config fields this cell sets (a plan group's `config`), passed to train as --field value."""
    hold: str = ""
    """A plan group on hold: why (the cell is skipped with this note)."""

    @property
    def name(self) -> str:
        return "/".join(self.out.parts[-3:])


def run_dir(results: str | Path, env: str, method: str, seed: int) -> Path:
    """`results/<env>/<method>/seed<k>`, the layout DESIGN.md fixes."""
    return Path(results) / env / method / f"seed{seed}"


def live_runs() -> dict[str, int]:
    """Run folders (real paths) that a live `acder_lite train` process writes to, from /proc.

    Finds runs started by hand as well as by another sweep; empty where /proc is missing.
    """
    found = {}
    try:
        pids = [int(p) for p in os.listdir("/proc") if p.isdigit()]
    except OSError:
        return found
    for pid in pids:
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                argv = f.read().decode(errors="replace").split("\0")
            if not any("acder_lite" in a for a in argv) or "train" not in argv:
                continue
            cwd = os.readlink(f"/proc/{pid}/cwd")
        except OSError:
            continue
        for i, a in enumerate(argv):
            for flag in ("--out", "--resume"):
                if a == flag and i + 1 < len(argv):
                    found[os.path.realpath(os.path.join(cwd, argv[i + 1]))] = pid
                elif a.startswith(flag + "="):
                    found[os.path.realpath(os.path.join(cwd, a.split("=", 1)[1]))] = pid
    return found


def cell_state(out: Path, live: dict[str, int] | None = None) -> str:
    """What a run folder holds: 'done' (done.json), 'running' (a live train process writes to it,
    see `live_runs`), 'interrupted' (checkpoint.pt), 'orphan' (progress.csv, no checkpoint) or 'new'."""
    if (out / "done.json").exists():
        return "done"
    if live and os.path.realpath(out) in live:
        return "running"
    if (out / "checkpoint.pt").exists():
        return "interrupted"
    if (out / "progress.csv").exists():
        return "orphan"
    return "new"


def plan_cell(cell: Cell, live: dict[str, int] | None = None) -> Cell:
    """`cell` with its action (and note) set from what its folder holds. Returns the cell.

    Never touches a folder that is complete, written by a live process, or holds a progress.csv
    it cannot resume (no checkpoint.pt: committed results, or a run stopped before its first epoch).
    """
    live = live_runs() if live is None else live
    if METHODS[cell.method]["priority"] == "ebp" and cell.env not in OBJECT_ENVS:
        cell.action, cell.note = "skip", f"{cell.method} needs a task with an object"
        return cell
    state = cell_state(cell.out, live)
    if state == "done":
        cell.action, cell.note = "skip", "already complete"
    elif state == "running":
        cell.action, cell.note = "skip", f"a live train process writes to it, pid {live[os.path.realpath(cell.out)]}"
    elif cell.hold:
        cell.action, cell.note = "skip", f"on hold: {cell.hold}"
    elif state == "interrupted":
        cell.action, cell.note = "resume", "checkpoint.pt found"
    elif state == "orphan":
        cell.action, cell.note = "skip", ("progress.csv without checkpoint.pt or done.json: nothing to "
                                          "resume; remove the folder to start over")
    else:
        cell.action, cell.note = "run", ""
    return cell


def plan(envs, methods, seeds, results) -> list[Cell]:
    """The grid in env-major order, each cell with its action (`plan_cell`). Assumes names were validated."""
    live = live_runs()
    return [plan_cell(Cell(env, method, seed, run_dir(results, env, method, seed), ""), live)
            for env in envs for method in methods for seed in seeds]


class PlanError(ValueError):
    """A bad plan file; the message is one line naming the file, the group and the field."""


_GROUP_KEYS = {"envs", "methods", "seeds", "root", "name", "config", "queue", "hold", "note"}


def read_plan(path: str | Path) -> list[Cell]:
    """The cells of a plan file (TOML), in the order they are to start, each with its action.

    A plan is a list of `[[group]]` tables, each a grid: `envs`, `methods`, `seeds` (lists);
    `root` (folder of <env>/<name>/seed<k>, relative to the plan's own folder; default: that
    folder); `name` (the folder under <env>/, default the method; needs one method); `config`
    (Config fields the runs set, e.g. {sicm_input = "raw"}); `queue` (default "grid"); `hold`
    (a reason: the group is planned but not started). A `[defaults]` table gives every group its
    keys (a group's own win; `config` tables merge). Cells of different queues alternate, so
    two queues share the cores; within a queue they keep the file's order.
    """
    import tomllib
    path = Path(path)
    try:
        with open(path, "rb") as f:
            doc = tomllib.load(f)
    except OSError as e:
        raise PlanError(f"plan {str(path)!r} cannot be read: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise PlanError(f"plan {str(path)!r} is not valid TOML: {e}") from None
    groups = doc.get("group")
    if not isinstance(groups, list) or not groups:
        raise PlanError(f"plan {str(path)!r} has no [[group]] tables; allowed: one or more")
    defaults = doc.get("defaults", {})
    if not isinstance(defaults, dict) or set(defaults) - _GROUP_KEYS:
        raise PlanError(f"plan {str(path)!r}: [defaults] may hold only: {', '.join(sorted(_GROUP_KEYS))}")
    queues: dict[str, list[Cell]] = {}
    live = live_runs()
    for i, g in enumerate(groups, 1):
        where = f"plan {str(path)!r}, group {i}"
        g = {**defaults, **g, "config": {**defaults.get("config", {}), **g.get("config", {})}}
        unknown = sorted(set(g) - _GROUP_KEYS)
        if unknown:
            raise PlanError(f"{where}: unknown key {unknown[0]!r}; allowed: {', '.join(sorted(_GROUP_KEYS))}")
        for key in ("envs", "methods", "seeds"):
            if not isinstance(g.get(key), list) or not g[key]:
                raise PlanError(f"{where}: {key} must be a non-empty list")
        problem = _check_names(g["envs"], g["methods"], g["seeds"])
        if problem:
            raise PlanError(f"{where}: {problem}")
        if "name" in g and len(g["methods"]) != 1:
            raise PlanError(f"{where}: name needs exactly one method, not {len(g['methods'])}")
        options = g.get("config", {})
        try:
            Config.from_dict(dict(options, env=g["envs"][0], method=g["methods"][0])).resolve()
        except (ConfigError, TypeError) as e:
            raise PlanError(f"{where}: config: {e}") from None
        root = Path(os.path.normpath(path.parent / g.get("root", ".")))
        for env, method, seed in itertools.product(g["envs"], g["methods"], g["seeds"]):
            out = run_dir(root, env, g.get("name", method), seed)
            cell = Cell(env, method, seed, out, "", options=dict(options), hold=str(g.get("hold", "")))
            queues.setdefault(str(g.get("queue", "grid")), []).append(plan_cell(cell, live))
    names = [c.name for q in queues.values() for c in q]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup:
        raise PlanError(f"plan {str(path)!r}: the run folder {dup!r} is planned twice; allowed: once")
    return [c for batch in itertools.zip_longest(*queues.values()) for c in batch if c is not None]


def train_command(cell: Cell, args) -> list[str]:
    """The `python -m acder_lite train` command line of one cell.

    A resumed cell gets `--resume DIR` and the same options as a fresh one: train accepts a
    changed epochs/threads/stop option and refuses (exit 2, in train.log) any other change.
    """
    cmd = [sys.executable, "-m", "acder_lite", "train", "--env", cell.env, "--method", cell.method,
           "--seed", str(cell.seed)]
    cmd += ["--resume", str(cell.out)] if cell.action == "resume" else ["--out", str(cell.out)]
    for name, value in cell.options.items():
        cmd += ["--" + name.replace("_", "-"), str(value)]
    for flag, value in (("--epochs", args.epochs), ("--workers", args.workers),
                        ("--eval-every-cycles", args.eval_every_cycles),
                        ("--success-threshold", args.success_threshold),
                        ("--stop-patience", args.stop_patience), ("--stop-gap-episodes", args.stop_gap_episodes),
                        ("--threads", args.threads)):
        if value is not None:
            cmd += [flag, str(value)]
    return cmd + shlex.split(args.train_args or "")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `python -m acder_lite sweep`."""
    parser.add_argument("--plan", default=None, metavar="FILE",
                        help="a plan file (TOML, see `read_plan`), e.g. results/plan.toml, instead of "
                             "--envs/--methods/--seeds")
    parser.add_argument("--envs", nargs="+", default=None, metavar="ENV",
                        help="tasks, e.g. FetchReach-v4 FetchPush-v4")
    parser.add_argument("--methods", nargs="+", default=None, metavar="METHOD",
                        help="rows of the method table, e.g. her acder")
    parser.add_argument("--seeds", nargs="+", type=int, default=None, metavar="N")
    parser.add_argument("--results", default="results", help="root of <env>/<method>/seed<k> (default: results)")
    parser.add_argument("--jobs", type=int, default=None,
                        help="runs at once (default: os.cpu_count())")
    parser.add_argument("--threads", type=int, default=None,
                        help="torch threads per run (default: max(1, cores // jobs))")
    parser.add_argument("--epochs", type=int, default=None, help="passed to train")
    parser.add_argument("--workers", type=int, default=None, help="passed to train")
    parser.add_argument("--eval-every-cycles", type=int, default=None, help="passed to train")
    parser.add_argument("--success-threshold", type=float, default=None, help="passed to train")
    parser.add_argument("--stop-patience", type=int, default=None, help="passed to train")
    parser.add_argument("--stop-gap-episodes", type=int, default=None, help="passed to train")
    parser.add_argument("--train-args", default="", metavar="'ARGS'",
                        help="more options for train, one quoted string: --train-args='--cycles 2'")
    parser.add_argument("--dry-run", action="store_true",
                        help="print what each cell would do (run / resume / skip) and exit")


def check_args(args) -> str | None:
    """The first problem with the options, as one line, or None. Fills the defaults of jobs/threads."""
    grid = [args.envs, args.methods, args.seeds]
    if args.plan is not None:
        if any(x is not None for x in grid):
            return "--plan FILE and --envs/--methods/--seeds exclude each other; allowed: one of them"
    elif any(x is None for x in grid):
        return "--envs, --methods and --seeds are required (or --plan FILE)"
    else:
        problem = _check_names(*grid)
        if problem:
            return problem
    cores = os.cpu_count() or 1
    if args.jobs is None:
        args.jobs = cores
    if args.jobs < 1:
        return f"--jobs={args.jobs} is not allowed: an integer >= 1"
    if args.threads is None:
        args.threads = max(1, cores // args.jobs)
    if args.threads < 1:
        return f"--threads={args.threads} is not allowed: an integer >= 1"
    for name in ("epochs", "workers"):
        value = getattr(args, name)
        if value is not None and value < 1:
            return f"--{name.replace('_', '-')}={value} is not allowed: an integer >= 1"
    for name in ("eval_every_cycles", "stop_patience", "stop_gap_episodes"):
        value = getattr(args, name)
        if value is not None and value < 0:
            return f"--{name.replace('_', '-')}={value} is not allowed: an integer >= 0"
    if args.success_threshold is not None and not 0 < args.success_threshold <= 1:
        return f"--success-threshold={args.success_threshold} is not allowed: a number in (0, 1]"
    try:
        shlex.split(args.train_args or "")
    except ValueError as e:
        return f"--train-args cannot be parsed: {e}"
    return None


def _check_names(envs, methods, seeds) -> str | None:
    for env in envs:
        if env not in ENV_IDS:
            return f"unknown env {env!r}; allowed: {', '.join(ENV_IDS)}"
    for method in methods:
        if method not in METHODS:
            return f"unknown method {method!r}; allowed: {', '.join(METHODS)}"
    if any(not isinstance(s, int) or s < 0 for s in seeds):
        return "seeds must be integers >= 0"
    if len(set(seeds)) != len(seeds):
        return "seeds must be distinct"
    return None


def _say(msg: str) -> None:
    print(f"sweep: {msg}", flush=True)


def _child_env(threads: int) -> dict:
    """The environment of a child: the package importable from any cwd, BLAS threads capped."""
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parent.parent)
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        env[var] = str(threads)
    return env


def _replan(cell: Cell) -> Cell:
    """The cell planned again just before it starts (hours may have passed since the plan)."""
    return plan_cell(cell)


def _start(cell: Cell, args) -> tuple[subprocess.Popen, object, float]:
    cell.out.mkdir(parents=True, exist_ok=True)
    cmd = train_command(cell, args)
    log = open(cell.out / "train.log", "a")
    log.write(f"# {time.strftime('%Y-%m-%d %H:%M:%S')} sweep: {shlex.join(cmd)}\n")
    log.flush()
    # A new session: a terminal's Ctrl-C reaches only the sweep, which forwards it exactly once.
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            env=_child_env(args.threads), start_new_session=True)
    return proc, log, time.monotonic()


def _release(cell: Cell, log) -> None:
    """After a child exited: close its log."""
    log.close()


def _finish_status(cell: Cell, rc: int) -> str:
    if rc == 0 and (cell.out / "done.json").exists():
        return "done"
    if rc == 0:
        return "exited 0 without done.json"
    if rc in (-signal.SIGINT, EXIT_INTERRUPTED):
        return "interrupted"
    if rc == -signal.SIGKILL:
        return "killed"
    return f"FAILED rc={rc}: {_last_line(cell.out / 'train.log')} (see {cell.out / 'train.log'})"


def _last_line(path: Path) -> str:
    """The last non-empty line of a log (progress-bar redraws split on carriage returns)."""
    try:
        with open(path, "rb") as f:
            f.seek(max(0, os.path.getsize(path) - 4096))
            lines = f.read().decode(errors="replace").replace("\r", "\n").splitlines()
    except OSError:
        return "no log"
    lines = [line.strip() for line in lines if line.strip()]
    return lines[-1][:200] if lines else "empty log"


def _signal(proc: subprocess.Popen, sig: int) -> None:
    try:
        os.killpg(proc.pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt


def run(args) -> int:
    """Plan the grid and run it; 0 if every run finished, 1 if one failed or was interrupted from
    outside, 2 on bad input, 130 on Ctrl-C."""
    problem = check_args(args)
    if problem:
        print(f"error: sweep: {problem}", file=sys.stderr)
        return 2
    if args.plan is not None:
        try:
            cells = read_plan(args.plan)
        except PlanError as e:
            print(f"error: sweep: {e}", file=sys.stderr)
            return 2
    else:
        cells = plan(args.envs, args.methods, args.seeds, args.results)
    if args.dry_run:
        for c in cells:
            print(f"{c.action:<6} {c.name:<40} {c.out}" + (f"  ({c.note})" if c.note else ""))
        counts = {a: sum(c.action == a for c in cells) for a in ("run", "resume", "skip")}
        _say(f"dry run: {counts['run']} to run, {counts['resume']} to resume, {counts['skip']} to skip; "
             f"jobs={args.jobs} threads={args.threads}")
        return 0

    for c in cells:
        if c.action == "skip":
            _say(f"skip   {c.name} ({c.note})")
    todo = [c for c in cells if c.action != "skip"]
    _say(f"{len(todo)} runs ({sum(c.action == 'resume' for c in todo)} resumed), "
         f"jobs={args.jobs}, threads={args.threads}, results={args.results}")

    main = threading.current_thread() is threading.main_thread()
    if main:  # Ctrl-C and SIGTERM become KeyboardInterrupt, even if the parent ignored SIGINT
        old_int = signal.signal(signal.SIGINT, signal.default_int_handler)
        old_term = signal.signal(signal.SIGTERM, _raise_interrupt)
    running: dict[int, tuple[Cell, subprocess.Popen, object, float]] = {}
    failed = finished = interrupted = 0
    try:
        try:
            while todo or running:
                while todo and len(running) < args.jobs:
                    cell = _replan(todo.pop(0))
                    if cell.action == "skip":
                        _say(f"skip   {cell.name} ({cell.note})")
                        continue
                    proc, log, t0 = _start(cell, args)
                    running[proc.pid] = (cell, proc, log, t0)
                    _say(f"start  {cell.name} ({cell.action}) pid={proc.pid} -> {cell.out / 'train.log'}")
                for pid, (cell, proc, log, t0) in list(running.items()):
                    rc = proc.poll()
                    if rc is None:
                        continue
                    _release(cell, log)
                    del running[pid]
                    status = _finish_status(cell, rc)
                    # a child interrupted from outside (its own Ctrl-C, a kill -INT) kept its
                    # checkpoint: not a failure, but not finished either
                    finished += status == "done"
                    interrupted += status == "interrupted"
                    failed += status not in ("done", "interrupted")
                    _say(f"finish {cell.name}: {status} in {time.monotonic() - t0:.0f}s")
                if running:
                    time.sleep(POLL_S)
        except KeyboardInterrupt:
            stopped = len(running)
            finished += _interrupt(running)
            _say(f"interrupted: {finished} finished, {stopped} stopped, {len(todo)} not started; "
                 "re-run the same command to continue")
            return EXIT_INTERRUPTED
        except BaseException:
            _interrupt(running)  # never leave children behind
            raise
    finally:
        if main:
            signal.signal(signal.SIGINT, old_int)
            signal.signal(signal.SIGTERM, old_term)
    _say(f"all done: {finished} finished, {failed} failed, "
         + (f"{interrupted} interrupted (re-run the same command to resume), " if interrupted else "")
         + f"{sum(c.action == 'skip' for c in cells)} skipped")
    return 1 if failed or interrupted else 0


def _interrupt(running: dict) -> int:
    """Forward SIGINT to every child, wait for all; a second Ctrl-C kills them. Returns how many were done."""
    _say(f"interrupt: forwarding SIGINT to {len(running)} run(s), waiting for their checkpoints "
         "(Ctrl-C again to kill)")
    for cell, proc, log, t0 in running.values():
        _signal(proc, signal.SIGINT)
    killed = False
    done = 0
    while True:
        try:
            for pid, (cell, proc, log, t0) in list(running.items()):
                rc = proc.wait()
                _release(cell, log)
                del running[pid]
                status = _finish_status(cell, rc)
                done += status == "done"
                _say(f"finish {cell.name}: {status} in {time.monotonic() - t0:.0f}s")
            return done
        except KeyboardInterrupt:
            if not killed:
                _say("second interrupt: killing the remaining runs (their last checkpoint stays)")
                for cell, proc, log, t0 in running.values():
                    _signal(proc, signal.SIGKILL)
                killed = True
