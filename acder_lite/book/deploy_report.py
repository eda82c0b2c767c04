"""Chapter 10's reading of the runs it benches: where each came from, how it trained,
what its bench counted

Chapter 10 benches two ACDER policies a task, seed 0: the full state's, the grid's run
(results/<task>/acder/seed0) or, until that has finished, the protocol-v1 run that
stands in for it (`STAND_IN`), and the simplified state's (experiments/deploy/).
`policies` finds each one's folder (`runs.finished_run`) and `full_state_source` says
which kind of folder the full state's is. From what `runs.read_run` read of a folder
(progress.csv, config.json, done.json) `training_summary` gives how the run trained, in
numbers. `counts` lays the benches of `robust.bench_policies` out flat for the
chapter's sentences; `nominal_successes` and `perturbed_rate` read one bench (its
unperturbed count, its mean over the perturbed levels); `rerun_bench` runs the `robust`
command again in a fresh process under other environment variables (the chapter's
check of why a stored bench can differ from a live one). `scene_label` picks the
policy of the chapter's scene and `policy_clips` reads the clips the export bakes in.
The chapter writes every sentence itself: this module returns numbers and labels only.

Traps: each run ended by its own stop rule or budget, so a task's two columns need not
have trained as long. A run's threshold and patience are read from the run (done.json's
stop rule, else its config.json) before today's defaults; where it first reached the
threshold is read between evaluations (`report.first_crossing`). A stand-in is told by
its folder's prefix: `STAND_IN` must be the path, relative to the repo, that the
chapter gives `finished_run`.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from acder_lite.config import Config


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


def full_state_source(folder: str | None) -> str | None:
    """Which run a full-state folder of `policies` is: "grid" (the grid's own run),
    "stand-in" (under `STAND_IN`), or None (no finished run)."""
    if folder is None:
        return None
    return "stand-in" if folder.startswith(STAND_IN) else "grid"


def training_summary(run: dict) -> dict:
    """How a run of chapter 10 trained (`run`: `runs.read_run` of its folder, with at
    least one row), in numbers: `threshold` and `patience`, its stop rule's (done.json,
    else config.json, else today's defaults); `crossed`, the training episodes where its
    test-success curve, read between evaluations (`report.first_crossing`), first
    reaches the threshold (None: never); `ended`, how it ended (`runs.how_ended`: "early
    stop", "full budget", "hovering", "cut short", None while training); `epochs` and
    `episodes`, how far it trained; `last`, its last test success."""
    from acder_lite.runs.read import how_ended
    from acder_lite.stats.report import first_crossing, threshold

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
    last = run["rows"][-1]
    return dict(
        threshold=thr,
        patience=int(patience),
        crossed=first_crossing(x, y, thr),
        ended=how_ended(run),
        epochs=float(last["epoch"]),
        episodes=int(last["episodes"]),
        last=float(last["test_success"]),
    )


def counts(bench: dict[tuple[str, str], dict]) -> dict[tuple, int]:
    """The benches of `robust.bench_policies` ({(task, column label): `run_bench`
    result}) flat: {(task, label, knob, level): successes}, the level a float (an
    integer level, 2 steps of delay, is found as 2 or 2.0)."""
    return {
        (env, label, r["knob"], float(r["level"])): int(r["successes"])
        for (env, label), res in bench.items()
        for r in res["rows"]
    }


def nominal_successes(result: dict) -> int:
    """A `run_bench` result's successes at every knob's nominal level (its first
    nominal row: they are all the same trials); ValueError if it ran none."""
    for r in result["rows"]:
        if r["nominal"]:
            return int(r["successes"])
    raise ValueError("the bench ran no nominal level")


def perturbed_rate(result: dict) -> float:
    """A `run_bench` result's success rate over its perturbed rows (every row but the
    nominal ones), each row weighing alike; ValueError if it ran none."""
    rates = [r["successes"] / r["trials"] for r in result["rows"] if not r["nominal"]]
    if not rates:
        raise ValueError("the bench ran no perturbed level")
    return sum(rates) / len(rates)


def rerun_bench(
    root,
    folder: str,
    knobs: list[str],
    trials: int,
    seed: int,
    environ: dict[str, str] | None = None,
) -> dict:
    """`python -m acder_lite robust` on the run `folder` (relative to `root`) in a
    fresh Python process, with `knobs` (each a `--perturb` argument: a knob name, at
    its default levels, or NAME=L1,L2) at `trials` trials and `seed`, under this
    process's environment updated by `environ` (e.g. {"MKL_CBWR": "COMPATIBLE"}): the
    dict its `--json` file holds. RuntimeError (with the command's last output) if it
    fails."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "robust.json"
        cmd = [sys.executable, "-m", "acder_lite", "robust", str(Path(root) / folder)]
        for k in knobs:
            cmd += ["--perturb", k]
        cmd += ["--trials", str(trials), "--seed", str(seed), "--json", str(out)]
        env = dict(os.environ, **(environ or {}))
        done = subprocess.run(cmd, env=env, cwd=root, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(
                f"{' '.join(cmd)}: {(done.stderr or done.stdout)[-800:]}"
            )
        return json.loads(out.read_text())


SCENE_ORDER = ("simplified state", "full state")
"""The columns chapter 10's scene takes its policy from, the first trained one: the
paper deployed simplified-state policies."""


def scene_label(columns: dict[str, str | None]) -> str | None:
    """The column label of the policy chapter 10's scene shows, from one task's
    `policies` entry ({column label: run folder or None}): the first of `SCENE_ORDER`
    with a trained run, or None (no scene)."""
    return next((k for k in SCENE_ORDER if columns.get(k)), None)


def policy_clips(pol: dict | None) -> tuple[float, float]:
    """The clips an export bakes in, (observation clip, normaliser clip), as a policy
    dict (`robust.load_policy`) records them; for None (no policy trained yet), the
    training defaults (`Config.clip_obs`, `Config.norm_clip`)."""
    if pol is None:
        return Config().clip_obs, Config().norm_clip
    return pol["clip_obs"], pol["norm"]["clip"]
