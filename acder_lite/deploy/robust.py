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
`stored_bench.compare_stored` checks a bench against one stored with `--json`.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os

import numpy as np

from acder_lite.envs import fetch as E
from acder_lite.config import (
    MAX_THREADS,
    OBJECT_ENVS,
    OBS_SETS,
    THREADS_ALLOWED,
    ConfigError,
)
from acder_lite.io import (
    load_policy,
    check_output,
    write_csv,
    write_error,
    write_json,
)
from acder_lite.envs.fetch import policy_env
from acder_lite.envs.observations import policy_obs
from acder_lite.deploy.perturb import (
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
from acder_lite.train.rollout import Policy, run_episodes
from acder_lite.stats.trial_stats import told_apart
from acder_lite.words import count

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
        self.start = [E.env_rng_state(e) for e in self.envs]
        self.layout = Layout.of(self.envs[0], obs)
        self.T = E.horizon(env_id)

    def rollout(self, act, setting: dict, log: list | None = None) -> dict:
        """One episode per trial under `setting` (every knob; `nominal()` for none): the
        arrays of `run_episodes` (true observations and goals, the applied actions)."""
        # the same trials at every level: each env's random stream back to its start;
        # run_episodes' reset (mj_resetData) clears the last level, warm start too
        for env, rng in zip(self.envs, self.start):
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


def weakest(result: dict) -> dict:
    """The row of `result` (a `run_bench` result) with the fewest successes; the first
    such row, in the table's order, on a tie."""
    return min(result["rows"], key=lambda r: r["successes"])


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


# ----- the command


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


def bench_policies(
    root,
    policies: dict[str, dict[str, str | None]],
    trials: int = PAPER_TRIALS,
    seed: int = 0,
    knobs: dict | None = None,
) -> tuple[dict[tuple[str, str], dict], list[str]]:
    """Every policy of `policies` ({task: {column label: run folder relative to `root`,
    or None}}, as `deploy_report.policies` gives it) through `run_bench` on its own
    observation set, the None ones skipped (not trained yet).

    Returns the benches, {(task, label): `run_bench` result} in the order met, and a
    line a bench: its nominal count and how far its run had trained
    (`export.trained_text`). The same `seed` for every policy: a task's columns then
    replay the same starts and noise, and differ only by the policy."""
    from pathlib import Path

    from acder_lite.deploy.export import trained_of, trained_text

    bench, lines = {}, []
    for env, cols in policies.items():
        for label, folder in cols.items():
            if folder is None:
                continue
            pol, path = load_policy(str(Path(root) / folder))
            act, obs = policy_act(pol, path, env_id=env)  # refuses another task's
            res = run_bench(act, env, obs, knobs=knobs, trials=trials, seed=seed)
            bench[env, label] = res
            nom = [r for r in res["rows"] if r["nominal"]]  # not always the first row
            score = (
                f"nominal {nom[0]['successes']}/{nom[0]['trials']}"
                if nom
                else "no nominal level run"
            )
            trained = trained_text(trained_of(pol, path))
            lines.append(f"{env} {label}: {score}; {trained}")
    return bench, lines


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
        f"{k.name} ({k.unit}, default {levels(k)}"
        + (f", at most {k.most:g}" if math.isfinite(k.most) else "")
        + f"{where(k)})"
        for k in KNOBS.values()
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
    p.add_argument(
        "--threads",
        type=int,
        default=1,
        help=f"torch threads, at most {MAX_THREADS} (default: 1)",
    )
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

    from acder_lite.runs.runfiles import versions

    check_trials(args.trials)
    if not (math.isfinite(args.tolerance) and args.tolerance > 0):
        raise ConfigError(
            f"tolerance={args.tolerance:g} is not allowed: a number > 0 (metres)"
        )
    if not 1 <= args.threads <= MAX_THREADS:  # past it libgomp's thread table failed
        raise ConfigError(f"threads={args.threads} is not allowed: {THREADS_ALLOWED}")
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
