"""A live bench held against one that `robust --json` stored, trial for trial

`compare_stored` holds a `robust.run_bench` result run here against the dict of a JSON
file that `python -m acder_lite robust RUN --json FILE` wrote for the same policy
(chapter 10 reads each simplified-state run's `robust.json`). The same policy, seed and
simulator give the same outcomes, trial for trial, so a differing row is a break of
determinism, or another CPU kind: the actor's float32 matrix products go through MKL,
which picks its kernels by CPU, and an action a few 1e-6 off can flip a trial where the
gripper meets the block. Measured (chapter 10): forcing MKL's CPU-independent path
(`MKL_CBWR=COMPATIBLE`) moved the actions by up to 3e-6 and changed 5 of Push's 20
bench rows, 1 of Pick&Place's, none of Reach's (no contact to magnify
the difference); threads do not matter (2 threads give the same actions).
`check_stored` compares every task's simplified-state bench with the `robust.json` of
its run folder; chapter 10 says what the checks found in its own words.

Traps: trial i starts from the env seeded seed + i whatever the trial count, so a bench
of fewer trials is compared on the stored one's first trials; but a noise level above 0
draws for all the trials of a level at once, laid out by their count
(`perturb.Knob.drawn`), so such a row is compared only at equal trial counts. A side
without per-trial outcomes (`trial_success`) is compared by its success counts, and
only at equal trial counts. Rows are matched by (knob, level) with the level as a float
(an integer level in the file matches its float). Benches that differ in a `SETTINGS`
entry are not compared at all.
"""

from __future__ import annotations

import json
from pathlib import Path

from acder_lite.deploy.perturb import KNOBS, quantity, unit_of
from acder_lite.words import and_join, count


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


def check_stored(root, policies: dict, bench: dict, label="simplified state") -> dict:
    """`compare_stored` for every task of `policies` ({task: {column label: run folder
    relative to `root`, or None}}, as `deploy_report.policies` gives it): the bench of
    its `label` column run here (`bench`: {(task, label): `run_bench` result}, as
    `robust.bench_policies` returns it) against the `robust.json` stored in that
    column's run folder. A task without the folder, the file or the live bench gets
    `compare_stored`'s answer for a missing side. Returns {task: result}."""
    checks = {}
    for env, cols in policies.items():
        folder = cols.get(label)
        file = Path(root) / folder / "robust.json" if folder else None
        stored = json.loads(file.read_text()) if file and file.is_file() else None
        checks[env] = compare_stored(bench.get((env, label)), stored)
    return checks
