"""How long the cells a sweep has left will take, read off the runs it has finished.

`sweep --dry-run` ends with this estimate. Per cell to run or resume: the epochs it has
left (its budget, less the epochs its progress.csv already holds), times the seconds an
epoch that the finished runs of its task and method took (the median over them of wall_s
/ epochs at their last row: one cell of a sweep, one thread, beside the other cells; of
its task's runs where the method has none). Two totals:

- **budget**: every cell runs its whole budget, an upper bound;
- **as finished**: every cell stops at the epoch where the finished runs of its task and
  method stopped (their median; the budget where none has finished yet), the stop rule
  being what ends most runs early.

A task with no finished run has no timing: its cells are counted apart, not guessed.

The runs moved between machines (sessions get different CPUs, 2.4x apart), and
config.json records the CPU of each stretch of a run (its first process, then each of
its `resumes`). So each stretch's seconds an epoch are scaled to the CPU the estimate
runs on (`cpu_factors`): a least-squares fit of log(seconds an epoch) = CPU + (task,
method) over every stretch of every run, finished or not, weighted by its epochs. A CPU
the fit cannot tie to this one (no task and method run on both, directly or through a
third CPU) keeps its own seconds, and the estimate says so. The totals are cell-hours on
this CPU: hours of one cell on one thread, beside the sweep's other cells (core-hours at
`--threads 1`); one cell alone on the machine runs faster.
"""

from __future__ import annotations

import math
import statistics
from collections import defaultdict

from acder_lite.config import Config
from acder_lite.runs.read import RunError, read_config, read_progress, read_run
from acder_lite.words import count

UNKNOWN_CPU = "an unrecorded CPU"
"""The CPU of a run whose config.json predates the record (`runfiles.cpu`)."""


def stretches(folder) -> list[tuple[str, float, float]]:
    """(cpu, epochs, seconds) of each stretch of a run trained by one process: the
    first, then one per resume (config.json's `resumes`, from `at_cycle`), read off
    progress.csv's cumulative wall_s. Empty if the folder cannot be read."""
    try:
        whole = read_config(folder)
        rows = read_progress(folder / "progress.csv")
    except (OSError, RunError):
        return []
    cycles = whole["config"]["cycles"]
    starts = [(0.0, (whole.get("versions") or {}).get("cpu", UNKNOWN_CPU))]
    for r in whole.get("resumes") or []:
        if isinstance(r, dict) and _positive(r.get("at_cycle")):
            cpu = (r.get("versions") or {}).get("cpu", UNKNOWN_CPU)
            starts.append((float(r["at_cycle"]) / cycles, cpu))
    walls = {0.0: 0.0}
    for row in rows:
        if _positive(row.get("epoch"), row.get("wall_s")):
            walls[float(row["epoch"])] = float(row["wall_s"])
    out = []
    ends = [e for e, _ in starts[1:]] + [max(walls)]
    for (e0, cpu), e1 in zip(starts, ends):
        if e1 > e0 and e0 in walls and e1 in walls and walls[e1] > walls[e0]:
            out.append((cpu, e1 - e0, walls[e1] - walls[e0]))
    return out


def cpu_factors(samples, here: str, rounds: int = 200) -> dict[str, float]:
    """Seconds an epoch on each CPU over those on `here`, from `samples` of (cpu, key,
    epochs, seconds), key = (task, method): log(seconds / epochs) = a[cpu] + b[key],
    least squares weighted by epochs (alternating updates), a[here] = 0. Only CPUs
    tied to `here` by a chain of shared keys are in the result (`here` itself as 1.0
    when it has samples); {} when it has none."""
    samples = [(c, k, n, t) for c, k, n, t in samples if n > 0 and t > 0]
    linked, frontier = {here}, {here}
    while frontier:  # the CPUs connected to `here` through shared keys
        keys = {k for c, k, _, _ in samples if c in frontier}
        frontier = {c for c, k, _, _ in samples if k in keys} - linked
        linked |= frontier
    samples = [s for s in samples if s[0] in linked]
    if not samples:
        return {}
    a = {c: 0.0 for c, _, _, _ in samples}
    b = {k: 0.0 for _, k, _, _ in samples}
    for _ in range(rounds):
        for side, other, pick in ((b, a, 1), (a, b, 0)):
            num, den = defaultdict(float), defaultdict(float)
            for s in samples:
                c, k, n, t = s
                num[s[pick]] += n * (math.log(t / n) - other[s[1 - pick]])
                den[s[pick]] += n
            for x in side:
                side[x] = num[x] / den[x]
    return {c: math.exp(v - a[here]) for c, v in a.items()}


def finished_timings(
    folders, factors: dict | None = None, parts: dict | None = None
) -> tuple[dict, dict]:
    """From finished run folders: (seconds an epoch, epochs at the end), each a median
    keyed by (task, method); the seconds also by task alone, for a method with no
    finished run. Each stretch of a run (`parts[folder]`, else read by `stretches`) is
    divided by its CPU's factor (`cpu_factors`; 1 for a CPU without one). Folders that
    cannot be read are passed over."""
    factors, parts = factors or {}, parts or {}
    per_epoch, ended = defaultdict(list), defaultdict(list)
    for d in folders:
        try:
            run = read_run(d)
        except RunError:
            continue
        last = run["rows"][-1] if run["rows"] else {}
        epoch, wall = last.get("epoch"), last.get("wall_s")
        # a copy (`same_as`) would count its source twice
        if not run["done"] or run["same_as"] or not _positive(epoch, wall):
            continue
        mine = parts[d] if d in parts else stretches(d)
        secs = (
            sum(t / factors.get(c, 1.0) for c, _, t in mine)
            / sum(n for _, n, _ in mine)
            if mine
            else float(wall) / float(epoch)
        )
        per_epoch[run["env"], run["method"]].append(secs)
        per_epoch[run["env"]].append(secs)
        ended[run["env"], run["method"]].append(float(epoch))
    med = lambda d: {k: statistics.median(v) for k, v in d.items()}
    return med(per_epoch), med(ended)


def _positive(*values) -> bool:
    try:
        return all(float(v) > 0 for v in values)
    except (TypeError, ValueError):
        return False


def epochs_done(folder) -> float:
    """The epochs a run folder's progress.csv holds (0 for none)."""
    try:
        rows = read_progress(folder / "progress.csv")
    except (OSError, RunError):
        return 0.0
    epoch = rows[-1].get("epoch") if rows else None
    return float(epoch) if _positive(epoch) else 0.0


def estimate(cells, options: dict | None = None, here: str | None = None) -> dict:
    """The estimate for a sweep's cells (`plan.Cell`s with their actions set): hours
    to budget and as finished on CPU `here` (default: this machine's,
    `runfiles.cpu`), the cells counted, the cells of untimed tasks and those on hold,
    and the CPU factors used (`factors`; `unscaled`: CPUs of finished runs the fit
    could not tie to `here`). `options`: the sweep's own Config fields (`--epochs`,
    ...), over each cell's."""
    if here is None:
        from acder_lite.runs.runfiles import cpu

        here = cpu()
    done = [
        c.out for c in cells if c.action == "skip" and (c.out / "done.json").exists()
    ]
    parts = {c.out: stretches(c.out) for c in cells}  # each run folder read once
    samples = [
        (cpu_, (c.env, c.method), n, t) for c in cells for cpu_, n, t in parts[c.out]
    ]
    factors = cpu_factors(samples, here)
    per_epoch, ended = finished_timings(done, factors, parts)
    seen = {cpu_ for d in done for cpu_, _, _ in parts[d]}
    out = dict(cells=0, budget_h=0.0, finished_h=0.0, untimed=defaultdict(int))
    out.update(here=here, factors=factors, unscaled=sorted(seen - set(factors)))
    out["held"] = sum(c.action == "skip" and bool(c.hold) for c in cells)
    for c in cells:
        if c.action not in ("run", "resume"):
            continue
        if c.env not in per_epoch:
            out["untimed"][c.env] += 1
            continue
        budget = (
            Config(**{**c.options, **(options or {}), "env": c.env, "method": c.method})
            .resolve()
            .epochs
        )
        have = epochs_done(c.out)
        stop = min(ended.get((c.env, c.method), budget), budget)
        secs = per_epoch.get((c.env, c.method), per_epoch[c.env])
        out["cells"] += 1
        out["budget_h"] += max(budget - have, 0) * secs / 3600
        out["finished_h"] += max(stop - have, 0) * secs / 3600
    out["untimed"] = dict(out["untimed"])
    return out


def short(cpu: str) -> str:
    """`runfiles.cpu`'s label in a few words: 'AMD EPYC [AVX512]'."""
    model, _, kernels = cpu.partition("; torch kernels: ")
    model = model.replace("(R)", "").replace(" Processor", "").strip()
    return f"{model} [{kernels}]" if kernels else model


def sentence(est: dict, jobs: int) -> str:
    """The estimate as the line `sweep --dry-run` ends with. Cells of a task with no
    finished run are counted apart (the hours leave them out); with none timed, the line
    says so instead of '0 cells, 0.0 cell-hours'.

    Trap: a dry run of one cell not yet timed said "1 to run", then "time left: 0
    cells": the count was of timed cells only."""
    cells = lambda n: count(n, "cell")
    untimed = sum(est["untimed"].values())
    per_task = ", ".join(
        f"{env} ({cells(n)})" for env, n in sorted(est["untimed"].items())
    )
    held = f"; on hold, not counted: {cells(est['held'])}" if est["held"] else ""
    if not est["cells"]:  # no hours to give: say what there is instead of 0.0
        if not untimed:
            return f"time left: no cell to run or resume{held}"
        one = untimed == 1
        tasks = per_task if len(est["untimed"]) > 1 else next(iter(est["untimed"]))
        return (
            f"time left: {cells(untimed)} to run, none timed yet (no finished run of "
            f"{'its' if one else 'their'} task to time {'it' if one else 'them'} by: "
            f"{tasks}){held}"
        )
    # the cells not timed are no part of the hours: "6 cells timed (of 15 to run)"
    timed = f" timed (of {est['cells'] + untimed} to run)" if untimed else ""
    text = (
        f"time left: {cells(est['cells'])}{timed}, {est['finished_h']:.1f} cell-hours "
        f"as the finished runs of their task and method ended ({est['budget_h']:.1f} "
        f"if each runs its budget); {jobs} at a time, {est['finished_h'] / jobs:.1f}-"
        f"{est['budget_h'] / jobs:.1f} hours"
    )
    if untimed:
        text += f"; not timed (no finished run of the task): {per_task}"
    text += held
    others = {c: f for c, f in est.get("factors", {}).items() if c != est.get("here")}
    if others:
        text += (
            f"; scaled to this CPU, {short(est['here'])} (an epoch took "
            + ", ".join(
                f"{f:.2f}x as long on {short(c)}" for c, f in sorted(others.items())
            )
            + ")"
        )
    elif est.get("factors"):
        text += f"; on this CPU, {short(est['here'])}, where all the runs trained"
    if est.get("unscaled"):
        text += "; not scaled to this CPU (no task and method in common): " + ", ".join(
            short(c) for c in est["unscaled"]
        )
    return text
