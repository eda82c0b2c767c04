"""Run a grid of (env, method, seed) training runs as parallel, resumable subprocesses.

`python -m acder_lite sweep --envs FetchReach-v4 FetchPush-v4 --methods her acder --seeds 0 1 2`
starts one `python -m acder_lite train ... --out RESULTS/<env>/<method>/seed<k>` per cell, at
most `--jobs` at a time, each logging to `DIR/train.log`. Re-running the same command is safe:
a cell with `done.json` is skipped, one with `checkpoint.pt` (and no `done.json`) is resumed with
`--resume DIR`, an empty or missing one starts fresh; anything else (a live run, a progress.csv
without checkpoint) is left alone. Ctrl-C (SIGINT, or SIGTERM) forwards SIGINT to the
running children, waits until they have exited (leaving their checkpoints) and returns 130.
"""
from __future__ import annotations

import argparse
import os
import shlex
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from .config import ENV_IDS, METHODS, OBJECT_ENVS

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

    @property
    def name(self) -> str:
        return f"{self.env}/{self.method}/seed{self.seed}"


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


def plan(envs, methods, seeds, results) -> list[Cell]:
    """The grid in env-major order, each cell with its action. Assumes names were validated.

    Never touches a folder that is complete, written by a live process, or holds a progress.csv
    it cannot resume (no checkpoint.pt: committed results, or a run stopped before its first epoch).
    """
    cells = []
    live = live_runs()
    for env in envs:
        for method in methods:
            for seed in seeds:
                out = run_dir(results, env, method, seed)
                if METHODS[method]["priority"] == "ebp" and env not in OBJECT_ENVS:
                    cells.append(Cell(env, method, seed, out, "skip",
                                      f"{method} needs a task with an object"))
                    continue
                state = cell_state(out, live)
                if state == "done":
                    cells.append(Cell(env, method, seed, out, "skip", "already complete"))
                elif state == "running":
                    cells.append(Cell(env, method, seed, out, "skip",
                                      f"a live train process writes to it, pid {live[os.path.realpath(out)]}"))
                elif state == "interrupted":
                    cells.append(Cell(env, method, seed, out, "resume", "checkpoint.pt found"))
                elif state == "orphan":
                    cells.append(Cell(env, method, seed, out, "skip", "progress.csv without checkpoint.pt "
                                      "or done.json: nothing to resume; remove the folder to start over"))
                else:
                    cells.append(Cell(env, method, seed, out, "run"))
    return cells


def train_command(cell: Cell, args) -> list[str]:
    """The `python -m acder_lite train` command line of one cell.

    A resumed cell gets `--resume DIR` and the same options as a fresh one: train accepts a
    changed epochs/threads/stop option and refuses (exit 2, in train.log) any other change.
    """
    cmd = [sys.executable, "-m", "acder_lite", "train", "--env", cell.env, "--method", cell.method,
           "--seed", str(cell.seed)]
    cmd += ["--resume", str(cell.out)] if cell.action == "resume" else ["--out", str(cell.out)]
    for flag, value in (("--epochs", args.epochs), ("--workers", args.workers),
                        ("--eval-every-cycles", args.eval_every_cycles),
                        ("--stop-after-success", args.stop_after_success),
                        ("--stop-patience", args.stop_patience), ("--stop-gap-episodes", args.stop_gap_episodes),
                        ("--threads", args.threads)):
        if value is not None:
            cmd += [flag, str(value)]
    return cmd + shlex.split(args.train_args or "")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of `python -m acder_lite sweep`."""
    parser.add_argument("--envs", nargs="+", required=True, metavar="ENV",
                        help="tasks, e.g. FetchReach-v4 FetchPush-v4")
    parser.add_argument("--methods", nargs="+", required=True, metavar="METHOD",
                        help="rows of the method table, e.g. her acder")
    parser.add_argument("--seeds", nargs="+", type=int, required=True, metavar="N")
    parser.add_argument("--results", default="results", help="root of <env>/<method>/seed<k> (default: results)")
    parser.add_argument("--jobs", type=int, default=None,
                        help="runs at once (default: os.cpu_count())")
    parser.add_argument("--threads", type=int, default=None,
                        help="torch threads per run (default: max(1, cores // jobs))")
    parser.add_argument("--epochs", type=int, default=None, help="passed to train")
    parser.add_argument("--workers", type=int, default=None, help="passed to train")
    parser.add_argument("--eval-every-cycles", type=int, default=None, help="passed to train")
    parser.add_argument("--stop-after-success", type=float, default=None, help="passed to train")
    parser.add_argument("--stop-patience", type=int, default=None, help="passed to train")
    parser.add_argument("--stop-gap-episodes", type=int, default=None, help="passed to train")
    parser.add_argument("--train-args", default="", metavar="'ARGS'",
                        help="more options for train, one quoted string: --train-args='--cycles 2'")
    parser.add_argument("--dry-run", action="store_true",
                        help="print what each cell would do (run / resume / skip) and exit")


def check_args(args) -> str | None:
    """The first problem with the options, as one line, or None. Fills the defaults of jobs/threads."""
    for env in args.envs:
        if env not in ENV_IDS:
            return f"unknown env {env!r}; allowed: {', '.join(ENV_IDS)}"
    for method in args.methods:
        if method not in METHODS:
            return f"unknown method {method!r}; allowed: {', '.join(METHODS)}"
    if any(s < 0 for s in args.seeds):
        return "seeds must be integers >= 0"
    if len(set(args.seeds)) != len(args.seeds):
        return "seeds must be distinct"
    cores = os.cpu_count() or 1
    if args.jobs is None:
        args.jobs = cores
    if args.jobs < 1:
        return f"--jobs={args.jobs} is not allowed: an integer >= 1"
    if args.threads is None:
        args.threads = max(1, cores // args.jobs)
    if args.threads < 1:
        return f"--threads={args.threads} is not allowed: an integer >= 1"
    for name in ("epochs", "workers", "stop_patience"):
        value = getattr(args, name)
        if value is not None and value < 1:
            return f"--{name.replace('_', '-')}={value} is not allowed: an integer >= 1"
    for name in ("eval_every_cycles", "stop_gap_episodes"):
        value = getattr(args, name)
        if value is not None and value < 0:
            return f"--{name.replace('_', '-')}={value} is not allowed: an integer >= 0"
    if args.stop_after_success is not None and not 0 <= args.stop_after_success <= 1:
        return f"--stop-after-success={args.stop_after_success} is not allowed: a number in [0, 1]"
    try:
        shlex.split(args.train_args or "")
    except ValueError as e:
        return f"--train-args cannot be parsed: {e}"
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
    return plan([cell.env], [cell.method], [cell.seed], cell.out.parent.parent.parent)[0]


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
                    # a child interrupted from outside (its own Ctrl-C, or results/scripts/
                    # end_at_epoch.sh) kept its checkpoint: not a failure, but not finished either
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
