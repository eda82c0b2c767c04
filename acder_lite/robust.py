"""A policy's success under what a real arm brings, a bench for the robot

`python -m acder_lite robust results/FetchPush-v4/acder/seed0` evaluates the run's
policy over N trials (default 20, the paper's count) at a tolerance (default 0.05 m),
once per level of each perturbation below with the others at their nominal level, and
prints the success counts out of N. Paper, section V-E: the policies, retrained on the
simplified state (`train --obs simplified`), succeed in 19 / 16 / 17 of 20 trials on a
UR5 (Reach / Push / Pick&Place) "with 5 cm tolerance error".

**Success** of a trial: at its last step every block (Reach: the gripper) is within
`tolerance` of its own target (Euclidean distance < tolerance: the env's own rule at
0.05 m), measured on the true positions, whatever the policy was shown.

**The knobs** (`perturb.KNOBS`; that module says what each does to the simulator):
camera error on the blocks and on the targets, action delay, action scale, friction,
mass.

**Determinism.** Trial i runs in its own env, seeded `seed + i`; before every level each
env's physics state and random generator are put back to what they were after seeding,
so every level sees the same initial positions and goals; the noise comes from one
generator seeded `[NOISE_STREAM, seed]` afresh at every level, so all noise levels scale
the same standard-normal draws. Levels differ only by their perturbation, and the same
command gives the same table. Trial i's env does not depend on the trial count, so a
bench of fewer trials replays a longer one's first trials, except at a noise level above
0: the noise is drawn for all trials at once, laid out by their count (`Knob.drawn`).
`compare_stored` checks a bench against one stored with `--json`.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os

import numpy as np

from . import envs as E
from .config import ENV_IDS, OBJECT_ENVS, OBS_SETS, Config, ConfigError
from .io import (
    CheckpointError,
    check_output,
    load_torch,
    write_csv,
    write_error,
    write_json,
)
from .observations import policy_env, policy_obs
from .perturb import (
    KNOBS,
    Knob,
    Layout,
    Perturbed,
    nominal,
    parse_perturb,
    quantity,
    scaled_model,
    unit_of,
)
from .rollout import Policy, run_episodes
from .table import task_label
from .words import and_join, count, plural

NOISE_STREAM = 0xACDE
"""First word of the noise generator's seed, [NOISE_STREAM, seed]: trial 0's env is
seeded `seed`, and a generator seeded `seed` alone would draw the very numbers that
place its block."""

PAPER_UR5 = {"FetchReach-v4": 19, "FetchPush-v4": 16, "FetchPickAndPlace-v4": 17}
"""Section V-E: successes of the simplified-state ACDER policies in 20 trials on a real
UR5 at 5 cm tolerance ("19 out of 20 trials in reach task, 16 out of 20 trials in push
task, while 17 out of 20 in pick&place task")."""
PAPER_TRIALS = 20
MAX_TRIALS = 1000
"""The most trials a bench takes: it keeps one env per trial for its whole run (about
10 MB each, measured on Pick&Place), so 1000 trials hold about 10 GB."""

CSV_COLUMNS = [
    "knob",
    "level",
    "unit",
    "nominal",
    "successes",
    "trials",
    "rate",
    "tolerance",
]


# ----- the bench


def check_trials(trials) -> None:
    """ConfigError (one line) unless `trials` is an integer in [1, MAX_TRIALS]."""
    if isinstance(trials, bool) or not isinstance(trials, int):
        raise ConfigError(f"trials={trials!r} is not allowed: an integer")
    if not 1 <= trials <= MAX_TRIALS:
        raise ConfigError(
            f"trials={trials} is not allowed: an integer in [1, {MAX_TRIALS}] "
            "(one env of about 10 MB each, all kept at once)"
        )


def success(ag: np.ndarray, g: np.ndarray, tolerance: float) -> np.ndarray:
    """(W,) bool: every block (3 numbers of the goal each) within `tolerance` of its
    target."""
    d = np.linalg.norm((ag - g).reshape(ag.shape[0], -1, 3), axis=-1)
    return np.all(d < tolerance, axis=-1)


class Bench:
    """The trials' envs, made once (with the full observation: the policy's entries are
    picked at every step), and one rollout per setting of the knobs."""

    def __init__(
        self, env_id: str, obs: str = "full", trials: int = PAPER_TRIALS, seed: int = 0
    ):
        self.env_id, self.obs, self.trials, self.seed = env_id, obs, trials, seed
        self.envs = [E.make_env(env_id, seed=seed + i) for i in range(trials)]
        self.start = [(E.get_state(e), E.env_rng_state(e)) for e in self.envs]
        self.layout = Layout.of(self.envs[0], obs)
        self.T = E.horizon(env_id)

    def rollout(self, act, setting: dict, log: list | None = None) -> dict:
        """One episode per trial under `setting` (every knob; `nominal()` for none): the
        arrays of `run_episodes` (true observations and goals, the applied actions)."""
        for env, (state, rng) in zip(self.envs, self.start):
            E.set_state(env, state)  # the warm start too: no level sees the last one
            E.set_env_rng_state(env, rng)
        rng = np.random.default_rng([NOISE_STREAM, self.seed])
        with contextlib.ExitStack() as stack:
            for env in self.envs:
                scaled = scaled_model(env, setting["friction"], setting["mass"])
                stack.enter_context(scaled)
            act = Perturbed(act, self.layout, setting, rng, log)
            return run_episodes(self.envs, act, self.T)

    def close(self) -> None:
        for env in self.envs:
            env.close()


def run_bench(
    act,
    env_id: str,
    obs: str = "full",
    knobs: dict | None = None,
    trials: int = PAPER_TRIALS,
    tolerance: float = 0.05,
    seed: int = 0,
) -> dict:
    """Success of `act(o, g)` (a policy on observation set `obs`) over `trials` trials
    at each level of each knob, one knob at a time, the others nominal; `knobs` is
    {knob: levels} as `parse_perturb` gives it (None: its default).

    Returns the settings and `rows`: one per (knob, level) with successes, trials, rate
    and the per-trial successes (0/1). A setting met twice (the nominal level of every
    knob) is rolled out once: it is the same trials either way."""
    if not (
        isinstance(tolerance, (int, float))
        and math.isfinite(tolerance)
        and tolerance > 0
    ):
        raise ConfigError(
            f"tolerance={tolerance!r} is not allowed: a number > 0 (metres)"
        )
    check_trials(trials)
    bench = Bench(env_id, obs, trials, seed)
    knobs = parse_perturb(None, env_id, bench.T) if knobs is None else knobs
    done: dict[tuple, np.ndarray] = {}
    rows = []
    try:
        for name, levels in knobs.items():
            for level in levels:
                setting = dict(nominal(), **{name: level})
                key = tuple(sorted(setting.items()))
                if key not in done:
                    ep = bench.rollout(act, setting)
                    done[key] = success(ep["ag"][:, -1], ep["g"][:, -1], tolerance)
                ok = done[key]
                rows.append(
                    dict(
                        knob=name,
                        level=level,
                        unit=KNOBS[name].unit,
                        nominal=bool(level == KNOBS[name].nominal),
                        successes=int(ok.sum()),
                        trials=trials,
                        rate=float(ok.mean()),
                        tolerance=tolerance,
                        trial_success=ok.astype(int).tolist(),
                    )
                )
    finally:
        bench.close()
    knob_docs = {
        n: dict(
            unit=KNOBS[n].unit,
            nominal=KNOBS[n].nominal,
            levels=list(v),
            doc=KNOBS[n].doc,
        )
        for n, v in knobs.items()
    }
    return dict(
        env=env_id,
        obs=obs,
        trials=trials,
        tolerance=tolerance,
        seed=seed,
        horizon=bench.T,
        env_seeds=[seed, seed + trials - 1],
        knobs=knob_docs,
        rows=rows,
    )


# ----- its readings


def to_text(result: dict) -> str:
    """The table: one line per (knob, level), success count out of N."""
    method = f", {result['method']}" if result.get("method") else ""
    head = (
        f"robust: {result['env']}{method} (obs {result['obs']}), "
        f"{count(result['trials'], 'trial')} at {result['tolerance']:g} m, seed "
        f"{result['seed']}; one knob at a time, the others nominal"
    )
    who = "every block" if result["env"] in OBJECT_ENVS else "the gripper"
    what = (
        f"success: at the last step ({result['horizon']}) {who} within "
        f"{result['tolerance']:g} m of its target, on the true positions"
    )
    lines = [head, what, f"{'knob':<14}{'level':>7} {'unit':<6}{'success':>8}"]
    last = None
    for r in result["rows"]:
        name, last = (r["knob"] if r["knob"] != last else ""), r["knob"]
        mark = "  (nominal)" if r["nominal"] else ""
        score = f"{r['successes']:>5}/{r['trials']}"
        unit = unit_of(r["level"], r["unit"])
        lines.append(f"{name:<14}{r['level']:>7g} {unit:<6}{score}{mark}")
    return "\n".join(lines)


def wilson_interval(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson's score interval for a success rate of k in n trials (z = 1.96: 95%);
    unlike the normal approximation it stays inside [0, 1] at k = 0 or k = n."""
    p = k / n
    mid = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return mid - half, mid + half


def told_apart(a: tuple[int, int], b: tuple[int, int], z: float = 1.96) -> bool:
    """Whether two counts (successes, trials) are told apart: their Wilson intervals
    (`wilson_interval`, z = 1.96: 95%) do not overlap."""
    (lo_a, hi_a), (lo_b, hi_b) = wilson_interval(*a, z), wilson_interval(*b, z)
    return hi_a < lo_b or hi_b < lo_a


def separating_gap(n: int, z: float = 1.96) -> dict | None:
    """How many trials apart two counts out of `n` must be to be told apart
    (`told_apart`): for each count k the least d with k and k + d apart; `least` and
    `most` of these over k, each with a pair (k, k + d) that needs it (`least`'s the
    lowest such k, `most`'s the one nearest the middle of the range). None when no two
    counts of n are apart (n <= 3 at 95%)."""
    need = {}
    for k in range(n + 1):
        d = next(
            (d for d in range(1, n - k + 1) if told_apart((k, n), (k + d, n), z)), None
        )
        if d is not None:
            need[k] = d
    if not need:
        return None
    least, most = min(need.values()), max(need.values())
    at_most = [k for k, d in need.items() if d == most]
    k_most = min(at_most, key=lambda k: abs(2 * k + most - n))  # nearest the centre
    k_least = min(k for k, d in need.items() if d == least)
    return dict(
        least=least,
        most=most,
        least_pair=(k_least, k_least + least),
        most_pair=(k_most, k_most + most),
    )


def separated_rows(bench: dict[tuple[str, str], dict], z: float = 1.96) -> list[dict]:
    """The rows (task, knob, level) where two columns of a task are told apart
    (`told_apart`): `bench` maps (task, column label) to a `run_bench` result, as
    chapter 10's BENCH. Every pair of a task's columns (in the order met) is compared
    on the (knob, level) rows both ran; the nominal rows of a task are the same trials
    under every knob, so only the first is kept.

    One dict per separated row, in the tasks' and the table's order: env, knob, level,
    unit, nominal, and counts: [(label, successes, trials), (label, ...)]."""
    tasks: dict[str, list[str]] = {}
    for env, label in bench:
        tasks.setdefault(env, []).append(label)
    out = []
    for env, labels in tasks.items():
        for i, a in enumerate(labels):
            for b in labels[i + 1 :]:
                rows_b = {(r["knob"], r["level"]): r for r in bench[env, b]["rows"]}
                seen_nominal = False
                for ra in bench[env, a]["rows"]:
                    rb = rows_b.get((ra["knob"], ra["level"]))
                    if rb is None or (ra["nominal"] and seen_nominal):
                        continue
                    seen_nominal = seen_nominal or ra["nominal"]
                    ka, kb = (
                        (ra["successes"], ra["trials"]),
                        (rb["successes"], rb["trials"]),
                    )
                    if told_apart(ka, kb, z):
                        out.append(
                            dict(
                                env=env,
                                knob=ra["knob"],
                                level=ra["level"],
                                unit=ra["unit"],
                                nominal=ra["nominal"],
                                counts=[(a, *ka), (b, *kb)],
                            )
                        )
    return out


def separation_sentence(n: int, rows: list[dict]) -> str:
    """Chapter 10's reading of its bench's resolution: how many trials apart two counts
    out of `n` must be to be told apart (`separating_gap`), and which rows of
    `separated_rows` are ("none" when none is)."""
    gap = separating_gap(n)
    if gap is None:
        head = (
            f"At {count(n, 'trial')} a level no two counts are told apart (their 95% "
            "Wilson intervals always overlap)"
        )
    else:
        (a, b), (c, d) = gap["least_pair"], gap["most_pair"]
        head = (
            f"At {count(n, 'trial')} a level, two counts are told apart (their 95% "
            f"Wilson intervals do not overlap) only when they are at least "
            f"{gap['least']} trials apart near an end of the range ({a} against {b} of "
            f"{n})"
        )
        if gap["most"] > gap["least"]:
            head += f" and {gap['most']} in its middle ({c} against {d})"
    if not rows:
        return head + "; no row of the bench separates a task's two columns."
    parts = []
    for r in rows:
        where = (
            "unperturbed"
            if r["nominal"]
            else f"`{r['knob']}` = {quantity(r['level'], r['unit'])}"
        )
        counts = ", ".join(f"{lab} {k}/{m}" for lab, k, m in r["counts"])
        parts.append(f"{task_label(r['env'])} {where} ({counts})")
    which = "the one row" if len(rows) == 1 else f"the {len(rows)} rows"
    verb = "is" if len(rows) == 1 else "are"
    return (
        head
        + f"; {which} of the bench that separates its columns {verb} "
        + (and_join(parts) + ".")
    )


def weakest(result: dict) -> dict:
    """The row of `result` (a `run_bench` result) with the fewest successes; the first
    such row, in the table's order, on a tie."""
    return min(result["rows"], key=lambda r: r["successes"])


def reading(label: str, result: dict | None) -> str:
    """One clause reading a bench: the policy `label`'s nominal count and its weakest
    level ("not trained yet" for None); every level tied for weakest is named, in the
    table's order."""
    name = label.replace(" ", "-")
    if result is None:
        return f"the {name} policy is not trained yet"
    nom = next(r for r in result["rows"] if r["nominal"])  # not always the first row
    low = weakest(result)
    head = (
        f"the {name} policy succeeds in {nom['successes']} of "
        f"{count(nom['trials'], 'trial')} unperturbed"
    )
    if low["successes"] == nom["successes"]:
        return head + " and as often at every perturbed level"
    ties = [r for r in result["rows"] if r["successes"] == low["successes"]]
    levels = [f"`{r['knob']}` = {quantity(r['level'], r['unit'])}" for r in ties]
    return head + f" and in {low['successes']} at its weakest, " + and_join(levels)


STAND_IN = "experiments/protocol-v1/"
"""Where chapter 10's full-state column finds a policy while the grid's own run
(results/<task>/acder/seed0) has not finished: the protocol-v1 run of the same method
and seed."""


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
    from .report import first_crossing, threshold
    from .runs import how_ended

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
        one = _trained(next(iter(runs.values())))
        return f"The {task} policies trained as long, {one} each."
    each = ", ".join(
        f"the {label.replace(' ', '-')} one {_trained(r)}" for label, r in runs.items()
    )
    return (
        f"The {task} policies did not train as long: {each}, so a difference between "
        "their columns is one of training as well as of state."
    )


def side_by_side(results: dict[str, dict]) -> str:
    """A Markdown table of several benches: a row per (knob, level) in the order the
    benches met them, a column per bench (`results`: {column label: `run_bench`
    result}) holding its successes out of its trials, "–" where the knob does not apply
    to that bench's task or was not run."""
    counts = {
        label: {
            (r["knob"], r["level"]): f"{r['successes']}/{r['trials']}"
            for r in res["rows"]
        }
        for label, res in results.items()
    }
    rows = list(dict.fromkeys(k for c in counts.values() for k in c))
    lines = [
        "| knob | level | " + " | ".join(results) + " |",
        "|---|---:|" + "---:|" * len(results),
    ]
    for knob, level in rows:
        cells = [c.get((knob, level), "–") for c in counts.values()]
        mark = " (nominal)" if level == KNOBS[knob].nominal else ""
        lines.append(
            f"| `{knob}` | {quantity(level, KNOBS[knob].unit)}{mark} | "
            + " | ".join(cells)
            + " |"
        )
    return "\n".join(lines)


SETTINGS = ("env", "obs", "seed", "tolerance", "horizon")
"""What two benches must share for their rows to be compared."""


def compare_stored(live: dict | None, stored: dict | None) -> dict:
    """Check a bench run here (`live`, a `run_bench` result) against one stored by
    `robust --json` (`stored`, the file's dict): the same policy, seed and simulator
    should give the same outcomes, trial for trial.

    Trial i starts from the env seeded `seed + i` whatever the trial count, so the first
    n = min(N_live, N_stored) trials of each row are compared, by their `trial_success`
    (by the counts if a side lacks it, and then only at equal N). At unequal N a row at
    a noise level above 0 is skipped: its draws are laid out by the trial count. Rows
    are matched by (knob, level).

    Returns dict(equal: no compared row differs and both sides have the same rows, one
    at least compared; whole: equal, nothing skipped and the same N; trials: n;
    live_trials, stored_trials: each side's N (when both are there);
    matched, only_live, only_stored: lists of (knob, level); skipped: (knob, level,
    why); differing: dicts of knob, level, live and stored successes in the n trials,
    trials: those that differ (from 0; None when only counts were compared);
    sentence: one line saying it)."""
    out = dict(equal=False, whole=False, trials=0, matched=[], differing=[])
    out.update(skipped=[], only_live=[], only_stored=[])
    if live is None or stored is None:
        what = "no bench run here" if live is None else "no stored bench"
        return dict(out, sentence=f"{what} to compare")
    other = [k for k in SETTINGS if live.get(k) != stored.get(k)]
    if other:
        diff = "; ".join(
            f"{k} {live.get(k)} here, {stored.get(k)} stored" for k in other
        )
        return dict(out, sentence=f"the benches cannot be compared ({diff})")
    n = out["trials"] = min(live["trials"], stored["trials"])
    out.update(live_trials=live["trials"], stored_trials=stored["trials"])
    same_n = live["trials"] == stored["trials"]
    rows = [
        {(r["knob"], float(r["level"])): r for r in b["rows"]} for b in (live, stored)
    ]
    out["only_stored"] = [k for k in rows[1] if k not in rows[0]]
    for key, a in rows[0].items():
        b = rows[1].get(key)
        per_trial = b is not None and "trial_success" in a and "trial_success" in b
        if b is None:
            out["only_live"].append(key)
        elif not (same_n or per_trial):
            out["skipped"].append((*key, "a side keeps no per-trial outcomes"))
        elif not same_n and KNOBS[key[0]].drawn and key[1] != 0:
            out["skipped"].append((*key, "their noise draws depend on the trial count"))
        elif per_trial:
            x, y = a["trial_success"][:n], b["trial_success"][:n]
            bad = [i for i in range(n) if x[i] != y[i]]
            _tally(out, key, bad, sum(x), sum(y))
        else:  # the counts of the same N trials
            k, m = a["successes"], b["successes"]
            _tally(out, key, [] if k == m else None, k, m)
    one_sided = out["only_live"] or out["only_stored"]
    out["equal"] = bool(out["matched"]) and not (out["differing"] or one_sided)
    out["whole"] = out["equal"] and same_n and not out["skipped"]
    sentence = _comparison_sentence(out, live["trials"], stored["trials"])
    return dict(out, sentence=sentence)


def _tally(out: dict, key: tuple, bad: list | None, live: int, stored: int) -> None:
    if bad == []:
        out["matched"].append(key)
    else:
        row = dict(knob=key[0], level=key[1], live=live, stored=stored, trials=bad)
        out["differing"].append(row)


def _comparison_sentence(c: dict, n_live: int, n_stored: int) -> str:
    """`compare_stored`'s one line."""
    n, compared = c["trials"], len(c["matched"]) + len(c["differing"])
    each = f"all {n} trials of each"
    if n_live != n_stored:
        each = f"the first {n} trials of each ({n_live} run here, {n_stored} stored)"
    if c["differing"]:
        parts = _differing_parts(c)
        text = (
            f"the live bench differs from the stored one on {len(parts)} of "
            f"{count(compared, 'row')}, {each}: " + "; ".join(parts)
        )
    elif compared:
        every = "" if c["skipped"] else "all "
        text = (
            f"the live bench equals the stored one trial for trial on {every}"
            f"{count(compared, 'row')}, {each}"
        )
    else:
        text = "no row of the live bench can be compared with the stored one"
    return text + _uncompared(c)


def _differing_parts(c: dict) -> list[str]:
    """Each differing row as "`mass` = 2 x (17/20 here, 18/20 stored)"."""
    n = c["trials"]
    return [
        f"`{d['knob']}` = {quantity(d['level'], KNOBS[d['knob']].unit)} "
        f"({d['live']}/{n} here, {d['stored']}/{n} stored)"
        for d in c["differing"]
    ]


def _uncompared(c: dict) -> str:
    """The rows left out of a comparison, as clauses after "; " ("" if none)."""
    text = ""
    if c["skipped"]:
        text += (
            f"; {count(len(c['skipped']), 'row')} cannot be compared at "
            f"{c['trials']} trials, {_levels(c['skipped'])} ({c['skipped'][0][2]})"
        )
    for side, where in (("only_live", "here"), ("only_stored", "stored")):
        if c[side]:
            text += f"; only {where}: {_levels(c[side])}"
    return text


STORED_HEADER = ("Task", "Rows compared", "Trials a row", "The live bench")
"""`stored_rows`' columns."""


def stored_rows(checks: dict[str, dict]) -> list[tuple]:
    """The book's table of `compare_stored` results, a row a task (`checks`: env id ->
    its result): how many rows were compared, on how many trials each, and whether
    the live bench gave the stored outcomes (what was left out after a semicolon)."""
    rows = []
    for env, c in checks.items():
        compared = len(c["matched"]) + len(c["differing"])
        if not compared:  # why nothing was compared
            rows.append((task_label(env), "–", "–", c["sentence"]))
            continue
        n, n_live, n_stored = c["trials"], c["live_trials"], c["stored_trials"]
        trials = str(n)
        if n_live != n_stored:
            trials = f"the first {n} ({n_live} here, {n_stored} stored)"
        outcome = "the same outcomes, trial for trial"
        if c["differing"]:
            outcome = f"differs on {len(c['differing'])}: " + "; ".join(
                _differing_parts(c)
            )
        rows.append((task_label(env), compared, trials, outcome + _uncompared(c)))
    return rows


def _levels(keys: list[tuple]) -> str:
    """(knob, level, ...) rows as "`obs_noise` = 0.005, 0.01 m and `mass` = 2 x"."""
    by_knob: dict[str, list] = {}
    for k, v, *_ in keys:
        by_knob.setdefault(k, []).append(v)
    return and_join(
        [
            f"`{k}` = {', '.join(f'{v:g}' for v in vs)} "
            f"{unit_of(vs[-1], KNOBS[k].unit)}"
            for k, vs in by_knob.items()
        ]
    )


# ----- the command


def load_policy(path: str) -> tuple[dict, str]:
    """The policy dict of a run folder (its policy.pt, else checkpoint.pt) or of a .pt
    file, read without running anything from it (`io.load_torch`), and that file."""
    if os.path.isdir(path):
        for name in ("policy.pt", "checkpoint.pt"):
            if os.path.isfile(os.path.join(path, name)):
                path = os.path.join(path, name)
                break
        else:
            raise CheckpointError(
                f"run folder {path!r} holds neither policy.pt nor "
                "checkpoint.pt; allowed: a run folder written by "
                "train, or its policy.pt"
            )
    pol = load_torch(path)["policy"]
    if pol["env"] not in ENV_IDS:
        raise CheckpointError(
            f"checkpoint {path!r} names env {pol['env']!r}; allowed: "
            f"one of {', '.join(ENV_IDS)}"
        )
    return pol, path


def policy_act(pol: dict, path: str, env_id: str | None = None, obs: str | None = None):
    """The in-package policy of `pol` and its observation set, checked against the task
    and the set asked for (None: the policy's own) and against the sizes its env gives:
    one-line ConfigError or CheckpointError otherwise."""
    trained_obs = policy_obs(pol)
    if env_id is not None and env_id != pol["env"]:
        raise ConfigError(
            f"env={env_id!r} is not the policy's task: {path} was "
            f"trained on {pol['env']}; allowed: --env {pol['env']} (or "
            "leave it out)"
        )
    if obs is not None and obs != trained_obs:
        raise ConfigError(
            f"obs={obs!r} is not the policy's observation set: {path} "
            f"was trained on obs={trained_obs!r}; allowed: --obs "
            f"{trained_obs} (or leave it out)"
        )
    policy_env(pol, path).close()
    return Policy.from_state_dict(pol), trained_obs


def perturbed_policy(path: str, env, setting: dict, seed: int) -> Perturbed:
    """The policy of run folder or file `path`, acting on `env` (its task) under
    `setting` (knob -> level; knobs left out are nominal), its noise drawn as a bench
    of that `seed` draws its own ([NOISE_STREAM, seed]): the book's scenes. The model
    knobs (friction, mass) are the caller's (`scaled_model`)."""
    act, obs = policy_act(*load_policy(path), env_id=env.spec.id)
    return Perturbed(
        act,
        Layout.of(env, obs),
        dict(nominal(), **setting),
        np.random.default_rng([NOISE_STREAM, seed]),
    )


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "policy",
        metavar="RUN_OR_POLICY",
        help="a run folder (its policy.pt, else checkpoint.pt) or a .pt file",
    )
    p.add_argument(
        "--trials",
        type=int,
        default=PAPER_TRIALS,
        help=f"trials per level, at most {MAX_TRIALS} "
        f"(default: {PAPER_TRIALS}, the paper's)",
    )
    p.add_argument(
        "--tolerance",
        type=float,
        default=0.05,
        help="metres; success: every block (Reach: the gripper) this close "
        "to its target at the last step (default: 0.05, the paper's "
        "5 cm)",
    )
    levels = lambda k: ",".join(f"{v:g}" for v in k.levels)

    def where(k: Knob) -> str:
        if k.needs_object:
            return "; needs a block: not on Reach"
        return f"; on Reach it {k.without_block}" if k.without_block else ""

    knobs = "; ".join(
        f"{k.name} ({k.unit}, default {levels(k)}{where(k)})" for k in KNOBS.values()
    )
    p.add_argument(
        "--perturb",
        action="append",
        metavar="NAME[=L1,L2,...]",
        help="a knob and its levels (repeatable; default: every knob that "
        f"applies to the policy's task, at its default levels): {knobs}",
    )
    p.add_argument(
        "--seed",
        type=int,
        default=12345,
        help="trial i's env is seeded seed + i (default: 12345, eval's default; "
        "eval plays its episodes in turn in one env, so not these trials)",
    )
    p.add_argument(
        "--env", default=None, help="must be the policy's task (default: the policy's)"
    )
    p.add_argument(
        "--obs",
        default=None,
        help="must be the policy's observation set: "
        + " or ".join(OBS_SETS)
        + " (default: the policy's)",
    )
    p.add_argument("--threads", type=int, default=1, help="torch threads (default: 1)")
    p.add_argument(
        "--json",
        metavar="FILE",
        help="write the settings and every row to FILE (replaced if it exists)",
    )
    p.add_argument(
        "--csv",
        metavar="FILE",
        help="write the table to FILE (replaced if it exists; columns "
        + ", ".join(CSV_COLUMNS)
        + ")",
    )


def run(args) -> int:
    import torch

    from .runfiles import versions

    check_trials(args.trials)
    if not (math.isfinite(args.tolerance) and args.tolerance > 0):
        raise ConfigError(
            f"tolerance={args.tolerance:g} is not allowed: a number > 0 (metres)"
        )
    if not 1 <= args.threads < 2**31:  # torch.set_num_threads takes a C int
        raise ConfigError(
            f"threads={args.threads} is not allowed: an integer >= 1 below 2**31"
        )
    if args.obs is not None and args.obs not in OBS_SETS:
        allowed = " or ".join(repr(x) for x in OBS_SETS)
        raise ConfigError(f"obs={args.obs!r} is not allowed: {allowed}")
    if args.seed < 0:
        raise ConfigError(f"seed={args.seed} is not allowed: an integer >= 0")
    if (
        args.json
        and args.csv
        and os.path.abspath(args.json) == os.path.abspath(args.csv)
    ):
        raise ConfigError(
            f"csv={args.csv!r} is the --json file too; allowed: another file"
        )
    pol, path = load_policy(args.policy)
    for name in ("json", "csv"):  # before the trials, not after them
        if getattr(args, name) is not None:
            check_output(getattr(args, name), name, (path,))
    # the task and the observation set asked for first, then the knobs on that task
    policy, obs = policy_act(pol, path, args.env, args.obs)
    knobs = parse_perturb(args.perturb, pol["env"], E.horizon(pol["env"]))
    torch.set_num_threads(args.threads)  # this process's own: the command runs alone
    result = run_bench(
        policy, pol["env"], obs, knobs, args.trials, args.tolerance, args.seed
    )
    result = dict(policy=path, method=pol["method"], **result, versions=versions())
    print(to_text(result))
    for name, write in (
        ("json", lambda: write_json(args.json, result)),
        ("csv", lambda: write_csv(args.csv, result["rows"], CSV_COLUMNS)),
    ):
        if getattr(args, name):
            try:
                write()
            except OSError as e:
                raise write_error(name, getattr(args, name), e) from None
    return 0
