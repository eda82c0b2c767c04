"""Reading run folders (acder_lite.runs.read) and printing Table I
(acder_lite.runs.table),
on synthetic runs."""

import argparse
import csv
import json
import math
import subprocess

import pytest

from acder_lite.cli import main as cli
from acder_lite.stats import report as RE
from acder_lite.runs import read as RU, table as T
from acder_lite.config import TASK_PRESETS

from conftest import curve_cell, push_cell, run_cli


def make_run(
    root,
    env,
    name,
    seed,
    success,
    *,
    epochs=10,
    cycles=50,
    workers=4,
    method=None,
    config=True,
    done=None,
    command="python -m acder_lite train",
    name_dir=True,
):
    """Write <root>/<env>/<name>/seed<k>/ with one evaluation per epoch;
    success = [per epoch].

    done: None (still training) or a stop_reason ("success held", "budget", ...)."""
    d = root / env / name / f"seed{seed}" if name_dir else root
    d.mkdir(parents=True, exist_ok=True)
    per_epoch = cycles * 2 * workers
    with open(d / "progress.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["epoch", "cycle", "episodes", "env_steps", "test_success", "wall_s"]
        )
        for i, s in enumerate(success, 1):
            w.writerow([i, i * cycles, i * per_epoch, i * per_epoch * 50, s, i * 10.0])
    if config:
        cfg = dict(
            env=env,
            method=method or name,
            seed=seed,
            epochs=epochs,
            cycles=cycles,
            episodes_per_cycle=2,
            workers=workers,
        )
        (d / "config.json").write_text(
            json.dumps(dict(config=cfg, command=command, versions={}))
        )
    if done:
        (d / "done.json").write_text(
            json.dumps(
                dict(
                    epochs=float(len(success)),
                    episodes=len(success) * per_epoch,
                    stop_reason=done,
                    stopped_early=len(success) < epochs,
                    wall_s=1.0,
                )
            )
        )
    return d


P, R = "FetchPush-v4", "FetchReach-v4"


@pytest.fixture
def results(tmp_path):
    make_run(
        tmp_path,
        P,
        "her",
        0,
        [0.2, 0.6, 0.9, 1.0, 0.95, 0.95, 0.95, 0.95],
        done="success held",
    )
    make_run(
        tmp_path,
        P,
        "her",
        1,
        [0.0, 0.1, 0.5, 0.7, 0.8, 0.9, 0.98, 1.0, 1.0, 1.0],
        done="budget",
    )
    make_run(
        tmp_path,
        P,
        "acder",
        0,
        [0.5, 0.96, 0.96, 0.96, 0.96, 0.96],
        done="success held",
    )
    # Reach: epochs of 10 cycles hold 80 episodes
    make_run(tmp_path, R, "her", 0, [0.5, 1.0, 1.0], epochs=3, cycles=10, done="budget")
    return tmp_path


def test_episodes_to_threshold():
    rows = [
        dict(episodes=40.0, test_success=0.5),
        dict(episodes=80.0, test_success=0.95),
        dict(episodes=120.0, test_success=1.0),
    ]
    assert RE.episodes_to_threshold(rows, 0.95) == 80.0
    assert RE.episodes_to_threshold(rows, 1.0) == 120.0
    assert RE.episodes_to_threshold(rows[:2], 1.0) is None
    assert RE.episodes_to_threshold([], 0.5) is None


def test_paper_table_and_thresholds():
    assert RE.PAPER_TABLE_I["acder"] == {
        "FetchReach-v4": 400,
        "FetchPush-v4": 2200,
        "FetchPickAndPlace-v4": 5200,
    }
    assert RE.PAPER_TABLE_I["her-ebp"]["FetchReach-v4"] is None
    # one source of truth for the thresholds: the task presets
    assert {e: RE.threshold(e) for e in RE.TASKS} == {
        e: TASK_PRESETS[e]["success_threshold"] for e in RE.TASKS
    }
    assert T.METHOD_LABELS["her"] == "DDPG+HER" and T.TASK_LABELS[P] == "Push"


def test_load_runs(results):
    runs = RU.load_runs(results)
    by = {(r["env"], r["name"], r["seed"]): r for r in runs}
    assert len(runs) == 4
    her = by[(P, "her", 1)]
    assert (her["budget_epochs"], her["episodes_per_epoch"], her["budget"]) == (
        10.0,
        400.0,
        4000.0,
    )
    assert her["ended"] == "budget" and her["done"] and len(her["rows"]) == 10
    assert by[(P, "her", 0)]["ended"] == "stop rule"
    assert by[(R, "her", 0)]["episodes_per_epoch"] == 80.0


def test_runs_are_grouped_by_folder_not_method(tmp_path):
    # a protocol-v1 run of the old method acder-baselines-clip:
    # config upgraded, folder kept
    d = make_run(
        tmp_path, P, "acder-baselines-clip", 0, [0.5, 1.0], epochs=2, done="budget"
    )
    (run,) = RU.load_runs(tmp_path)
    assert (run["name"], run["method"], run["config"]["target_clip"]) == (
        "acder-baselines-clip",
        "acder",
        "baselines",
    )
    cells = RE.summarize([run])
    assert [(c.name, c.method) for c in cells] == [("acder-baselines-clip", "acder")]
    assert "ACDER with Baselines' clip (protocol v1)" in T.markdown(cells)
    # a run folder given directly is read as one run
    assert len(RU.load_runs(d)) == 1


def test_planned_epochs():
    cfg = dict(epochs=18)
    train = (
        "python -m acder_lite train --env FetchPush-v4 --method her --seed 1 --out R"
    )
    ended = dict(
        command="python -m acder_lite train --resume R --epochs 18 --threads 1 --quiet"
    )
    # ended at epoch 18 by a resume: the plan is the first command's --epochs
    assert (
        RU.planned_epochs(
            dict(config=cfg, command=train + " --epochs 50", resumes=[ended])
        )
        == 50
    )
    assert RU.planned_epochs(dict(config=cfg, command=train + " --epochs=40")) == 40
    # "²".isdigit() but int("²") fails: an unreadable --epochs, not a crash
    assert RU.planned_epochs(dict(config=cfg, command=train + " --epochs ²")) == 18
    assert (
        RU.planned_epochs(
            dict(config=cfg, command=train, resumes=[dict(command="x --threads 2")])
        )
        == 18
    )
    assert (
        RU.planned_epochs(
            dict(config=cfg, command=train + " --epochs-x 7 --out 'a --epochs 9'")
        )
        == 18
    )
    # started on the task's preset (no --epochs), ended at 18 by a resume: the preset
    push = dict(env="FetchPush-v4", epochs=18)
    assert RU.planned_epochs(dict(config=push, command=train, resumes=[ended])) == 50


def test_how_ended(tmp_path):
    make_run(
        tmp_path, P, "a", 0, [0.96] * 5, method="her", epochs=10, done="success held"
    )
    make_run(tmp_path, P, "b", 0, [0.5] * 10, method="her", epochs=10, done="budget")
    make_run(
        tmp_path,
        P,
        "c",
        0,
        [0.96, 0.9, 0.9],
        method="her",
        epochs=10,
        done="gap after first success",
    )
    # ended by `train --resume DIR --epochs 3` before reaching the threshold
    make_run(
        tmp_path,
        P,
        "d",
        0,
        [0.5, 0.6, 0.7],
        method="her",
        epochs=3,
        done="budget",
        command="train --epochs 10",
    )
    make_run(tmp_path, P, "e", 0, [0.5], method="her", epochs=10)
    got = {r["name"]: (r["ended"], RU.how_ended(r)) for r in RU.load_runs(tmp_path)}
    assert got == {
        "a": ("stop rule", "early stop"),
        "b": ("budget", "full budget"),
        "c": ("cut", "hovering"),
        "d": ("cut", "cut short"),
        "e": (None, None),
    }


def test_malformed_run_folders_are_skipped(results, capsys):
    bad = {
        "notjson": lambda d: (d / "config.json").write_text("{not json"),
        "noconfig": lambda d: (d / "config.json").unlink(),
        "badvalue": lambda d: (d / "progress.csv").write_text(
            "epoch,episodes,test_success\n1,400,abc\n"
        ),
        "nocolumn": lambda d: (d / "progress.csv").write_text(
            "epoch,episodes\n1,400\n"
        ),
        "noprogress": lambda d: (d / "progress.csv").unlink(),
        "badfield": lambda d: (d / "config.json").write_text(
            json.dumps(dict(config=dict(env=P, method="her", bogus=1)))
        ),
    }
    for name, spoil in bad.items():
        spoil(make_run(results, P, name, 0, [0.5, 0.6], method="her"))
    runs = RU.load_runs(results)
    assert len(runs) == 4  # the good ones are all read
    err = capsys.readouterr().err.splitlines()
    assert len(err) == len(bad)  # one line per bad folder, each naming it and why
    for name, why in [
        ("notjson", "not valid JSON"),
        ("noconfig", "no config.json"),
        ("badvalue", "test_success 'abc' is not a number"),
        ("nocolumn", "no 'test_success' column"),
        ("noprogress", "no progress.csv"),
        ("badfield", "unknown config field 'bogus'"),
    ]:
        (line,) = [x for x in err if f"/{name}/seed0" in x]
        assert line.startswith("skipped ") and why in line


def edit_config(d, change):
    """Rewrite run folder `d`'s config.json after `change(whole)` edits it in place."""
    whole = json.loads((d / "config.json").read_text())
    change(whole)
    (d / "config.json").write_text(json.dumps(whole))


MISTYPED = {
    # name: (edit of the whole config.json, what the skip line must say)
    "command-int": (lambda w: w.update(command=5), "command is 5; allowed: a string"),
    # shlex.split(None) reads stdin: a null command must fail, not wait for input
    "command-null": (
        lambda w: w.update(command=None),
        "command is null; allowed: a string",
    ),
    "same_as-str": (
        lambda w: w.update(same_as="x"),
        'same_as is "x"; allowed: an object with "run"',
    ),
    "same_as-run": (
        lambda w: w.update(same_as=dict(run=5)),
        "same_as.run is 5; allowed: a non-empty string",
    ),
    "resumes-str": (
        lambda w: w.update(resumes="x"),
        'resumes is "x"; allowed: a list of objects',
    ),
    "resumes-item": (
        lambda w: w.update(resumes=[5]),
        "resumes[0] is 5; allowed: an object",
    ),
    "resumes-command": (
        lambda w: w.update(resumes=[dict(command=["--epochs", "3"])]),
        "resumes[0].command is a list; allowed: a string",
    ),
    "versions-str": (
        lambda w: w.update(versions="x"),
        'versions is "x"; allowed: an object',
    ),
    "config-list": (lambda w: w.update(config=[1]), 'has no "config" object'),
    # a protocol-v1 config (no target_clip) has it read out of switches
    "switches-str": (
        lambda w: w["config"].update(method="acder-baselines-clip", switches="x"),
        'config.switches is "x"; allowed: an object',
    ),
    "seed-str": (lambda w: w["config"].update(seed="1"), "seed='1' is not allowed"),
    "env-list": (lambda w: w["config"].update(env=[P]), "env=['FetchPush-v4'] is not"),
}

IMPOSSIBLE = {
    # name: (column, value in the second row, what the skip line must say)
    "success-7": ("test_success", "7", "test_success '7' is out of range"),
    "success-nan": ("test_success", "nan", "test_success 'nan' is out of range"),
    "success-inf": ("test_success", "inf", "test_success 'inf' is out of range"),
    "success-negative": ("test_success", "-0.1", "test_success '-0.1' is out of"),
    "episodes-inf": ("episodes", "inf", "episodes 'inf' is out of range"),
    "episodes-negative": ("episodes", "-400", "episodes '-400' is out of range"),
    "episodes-nan": ("episodes", "NaN", "episodes 'NaN' is out of range"),
    "epoch-inf": ("epoch", "Infinity", "epoch 'Infinity' is out of range"),
    # the crossings interpolate between rows: a count that goes back is not a curve
    "episodes-back": ("episodes", "0", "episodes '0' is not above line 2's"),
}


def spoil_progress(d, column, value):
    """Put `value` in `column` of the second evaluation (line 3) of `d`'s
    progress.csv."""
    with open(d / "progress.csv", newline="") as f:
        rows = list(csv.reader(f))
    rows[2][rows[0].index(column)] = value
    with open(d / "progress.csv", "w", newline="") as f:
        csv.writer(f).writerows(rows)


def test_mistyped_config_and_impossible_progress_are_skipped(results, capsys):
    # each was taken as data (a 7, inf or nan in progress.csv) or crashed table with
    # an AttributeError (a command of 5, a same_as of "x", ...) before
    for name, (change, _) in MISTYPED.items():
        edit_config(make_run(results, P, name, 0, [0.5, 0.6], method="her"), change)
    for name, (column, value, _) in IMPOSSIBLE.items():
        d = make_run(results, P, name, 0, [0.5, 0.6, 0.7], method="her")
        spoil_progress(d, column, value)
    assert cli.main(["table", "--results", str(results), "--resamples", "20"]) == 0
    cap = capsys.readouterr()
    assert "| Push | DDPG+HER (`her`) | 2 done |" in cap.out  # the good runs are read
    err = cap.err.splitlines()
    assert len(err) == len(MISTYPED) + len(IMPOSSIBLE)  # one line per bad folder
    whys = {n: ("config.json", w) for n, (_, w) in MISTYPED.items()}
    whys.update(
        {n: ("progress.csv line 3: ", w) for n, (_, _, w) in IMPOSSIBLE.items()}
    )
    for name, (where, why) in whys.items():
        (line,) = [x for x in err if f"/{name}/seed0: {where}" in x]
        assert line.startswith("table: skipped ") and why in line, line


def test_run_with_well_typed_optional_fields_is_read(tmp_path):
    # what train and sweep write around "config" still reads, values at their limits
    d = make_run(tmp_path, P, "her", 0, [0.0, 1.0], epochs=2, done="budget")
    edit_config(
        d,
        lambda w: w.update(
            resumes=[dict(command="train --resume R --epochs 2", versions={})],
            same_as=dict(run="../../../../elsewhere/FetchPush-v4/her/seed0"),
        ),
    )
    (run,) = RU.load_runs(tmp_path, warn=pytest.fail)
    assert [r["test_success"] for r in run["rows"]] == [0.0, 1.0]
    assert run["same_as"].endswith("elsewhere/FetchPush-v4/her/seed0")


def test_table_exits_2_when_every_run_is_mistyped(tmp_path):
    d = make_run(tmp_path, P, "her", 0, [0.5, 0.6])
    edit_config(d, lambda w: w.update(command=None))
    spoil_progress(make_run(tmp_path, P, "acder", 0, [0.5, 0.6]), "test_success", "7")
    # stdin closed: the old reader waited on it for a null command
    p = run_cli("table", "--results", str(tmp_path), stdin=subprocess.DEVNULL)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.count("\n") == 1 and "Traceback" not in p.stderr
    assert f"no readable run under {str(tmp_path)!r} (2 folders skipped" in p.stderr


def args(results, fmt="markdown", plan=None):
    return argparse.Namespace(
        results=str(results), format=fmt, plan=plan, resamples=200
    )


def test_table_prints_every_cell_of_the_grid(results, capsys):
    assert T.run(args(results)) == 0
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith("| ")]
    assert (
        len(rows) == 1 + 23 + 5
    )  # header, the grid's cells, the ratio table (header + 4 rows)
    # Push HER: seed 0 carries 0.95 after epoch 8; mean (0.95 + 0.98) / 2 first
    # >= 0.95 at epoch 7 (interpolated from (0.95 + 0.9) / 2 = 0.925 at epoch 6:
    # 6 + 0.025 / 0.04 = 6.625 -> 2,650 episodes)
    her = next(r for r in rows if r.startswith("| Push | DDPG+HER (`her`)"))
    assert "| 2 done | 2,650 |" in her and her.endswith("| 11,600 |")
    assert "| Reach | DDPG+HER (`her`) | 1 done | 800 (ours 160) |" in out
    assert "| Pick&Place | DDPG+ACDER (`acder`) | 0 done | not run yet |" in out
    assert "| Reach | DDPG+HER+EBP" not in out  # no object on Reach
    # HER / ACDER: 6.625 / (1 + 0.45 / 0.46) epochs
    ratio = 6.625 / (1 + 0.45 / 0.46)
    ours = "| ours: mean curve [95% interval] | ACDER not run yet |"  # Reach: HER only
    assert f"{ours} {ratio:.1f} [" in out
    assert "| paper | 5.6 | 5.3 | 6.5 |" in out


def test_table_counts_planned_seeds(results, capsys):
    (results / "plan.toml").write_text(
        '[[group]]\nenvs = ["FetchPush-v4"]\nmethods = ["her"]\n'
        "seeds = [0, 1, 2, 3, 4]\n"
        '[[group]]\nenvs = ["FetchPush-v4"]\nmethods = ["acder-no-curiosity"]\n'
        'seeds = [0, 1]\nhold = "readings"\n'
    )
    assert T.run(args(results)) == 0
    out = capsys.readouterr().out
    assert "| Push | DDPG+HER (`her`) | 2 done / 5 planned |" in out
    assert (
        "| Push | ACDER w/o curiosity (`acder-no-curiosity`) | 0 done / 2 planned (on "
        "hold) | not run yet |" in out
    )


def test_table_json(results, capsys):
    assert T.run(args(results, "json")) == 0
    d = json.loads(capsys.readouterr().out)
    her = next(c for c in d["cells"] if (c["env"], c["name"]) == (P, "her"))
    assert her["crossing"] == pytest.approx(6.625) and her[
        "crossing_episodes_paper_units"
    ] == pytest.approx(2650)
    assert [r["env"] for r in d["ratios"]] == list(RE.TASKS)


def test_table_exits_2_when_nothing_is_readable(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    (tmp_path / "push.ts").write_bytes(b"a file, not a folder")
    broken = tmp_path / "broken"
    make_run(broken, P, "her", 0, [0.5])
    (broken / P / "her" / "seed0" / "config.json").write_text("[]")
    for root, why in [
        (tmp_path / "empty", "no readable run"),
        (tmp_path / "missing", "does not exist"),
        (tmp_path / "push.ts", "is a file; allowed: a folder of runs"),
        (broken, "config.json is not a JSON object"),
    ]:
        assert cli.main(["table", "--results", str(root)]) == 2
        cap = capsys.readouterr()
        assert (
            cap.out == ""
            and cap.err.count("\n") == 1
            and str(root) in cap.err
            and why in cap.err
        )


def test_html_table(results):
    cells = RE.summarize(RU.load_runs(results), n_boot=100)
    html = T.to_html(*T.table_rows(cells))
    assert (
        html.startswith("<table><thead><tr><th>Task</th>")
        and "<code>her</code>" in html
    )
    assert "|" not in html


def test_an_unfinished_mean_curve_says_how_early_it_can_still_cross():
    c = push_cell("sicm-raw-episode-goal", None, None, None)
    c.why, c.evaluated_epochs = "not yet", 4.0
    assert T.mean_text(c) == "not yet (evaluated to epoch 4)"
    c.earliest = 24.0  # a slow seed rules out a crossing before epoch 24
    assert T.mean_text(c) == "not yet (evaluated to epoch 4; not before 9,600)"
    c.earliest = math.inf
    assert (
        T.mean_text(c) == "not yet (evaluated to epoch 4; cannot cross within budget)"
    )
    c.earliest = 3.0  # nothing beyond what the curve itself shows
    assert T.mean_text(c) == "not yet (evaluated to epoch 4)"


def test_interval_bound_that_may_still_cross_says_not_yet():
    """An infinite bound is 'beyond budget' only for a cell whose seeds all had their
    budget; while a seed trains it is 'not yet', after a cut 'cut short'."""
    c = push_cell("her-per", None, 10.0, math.inf)
    c.boot, c.n, c.share_crossing = [10.0, math.inf], 3, 0.5
    assert T.interval_text(c) == "4,000 – beyond budget (50%)"
    c.unfinished = 1
    assert T.interval_text(c) == "4,000 – not yet (50%)"
    c.low = math.inf
    assert T.interval_text(c) == "not yet (50%)"  # once, not "not yet – not yet"
    c.unfinished, c.cut = 0, 1
    assert T.interval_text(c) == "cut short (50%)"
    c.high = 12.0
    assert T.interval_text(c) == "cut short – 4,800 (50%)"


def test_finished_run_skips_a_run_still_training(tmp_path):
    """policy.pt is rewritten at every epoch end: only a folder with done.json does."""
    from acder_lite.runs.read import finished_run

    for name, files in (("live", ["policy.pt"]), ("done", ["policy.pt", "done.json"])):
        (tmp_path / name).mkdir()
        for f in files:
            (tmp_path / name / f).write_text("x")
    assert finished_run(tmp_path, "missing", "live", "done") == "done"
    assert finished_run(tmp_path, "live") is None


def test_per_seed_column_gives_median_range_and_mean():
    her = curve_cell("her", [0.0, 0.5, 1.0, 1.0])  # two equal seeds, each at 2.9 epochs
    assert T.per_seed_text(her) == "1,160 (1,160 – 1,160), mean 1,160, 2/2"
    assert T.HEADER[5] == "Per seed: median (range), mean, crossed"


def test_ratio_rows_give_three_readings_beside_the_papers():
    """Two equal seeds a cell: the mean curve, the seeds' medians and their means all
    cross at 2.9 (HER) and 1.9 (ACDER) epochs."""
    her, acder = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("acder", [0.5, 1.0, 1.0, 1.0]),
    )
    (r,) = RE.ratios([her, acder], tasks=(P,))
    assert r.seed_mean_ratio == pytest.approx(2.9 / 1.9) == r.seed_ratio
    header, rows = T.ratio_rows([r])
    assert header == ("HER / ACDER episodes", "Push")
    assert [row[0] for row in rows] == [
        "ours: mean curve [95% interval]",
        "ours: per-seed medians",
        "ours: per-seed means",
        "paper",
    ]
    assert rows[2][1] == "1.5" and rows[3][1] == "5.3"


def test_ratio_interval_beyond_the_budget_prints_infinity_at_both_ends():
    """HER's two seeds at 0.1 for 4 epochs never cross; ACDER's cross at 1 + 0.45 / 0.5
    = 1.9 epochs. Every resample pair has HER never crossing, so the ratio's interval
    is [inf, inf], printed as such (not 'inf' on the left, '∞' on the right)."""
    her, acder = curve_cell("her", [0.1] * 4), curve_cell("acder", [0.5, 1.0, 1.0, 1.0])
    (r,) = RE.ratios([her, acder], tasks=(P,))
    assert (r.ours, r.bound, r.low, r.high) == (
        None,
        pytest.approx(4 / 1.9),
        math.inf,
        math.inf,
    )
    assert T.ratio_text(r) == "> 2.1 (HER not within budget) [∞ – ∞]"


def test_per_seed_column_says_not_crossed_for_a_seed_that_ended():
    """Seed 0 ended at its budget without crossing, seed 1 is still training: the
    slowest seed and the mean are 'not crossed' for good, and so is the median of two
    (np.median counts the upper middle value). With no seed crossed, the column says so
    once."""
    rows = [dict(epoch=float(i), episodes=400.0 * i, test_success=0.1) for i in (1, 2)]
    r = dict(
        env=P,
        name="her",
        method="her",
        rows=rows,
        budget_epochs=2.0,
        episodes_per_epoch=400.0,
        update_dtype="float32",
    )
    ended, training = dict(r, seed=0, ended="budget"), dict(r, seed=1, ended=None)
    c = RE.cell_stat(P, "her", [ended, training], n_boot=20)
    assert T.per_seed_text(c) == "not crossed, 0/2"  # of 2, one never: the median
    c = RE.cell_stat(P, "her", [dict(training, seed=0), training], n_boot=20)
    assert T.per_seed_text(c) == "not yet, 0/2"
    c = RE.cell_stat(P, "her", [ended, dict(ended, seed=1)], n_boot=20)
    assert T.per_seed_text(c) == "not crossed, 0/2"
    up = [dict(epoch=1.0, episodes=400.0, test_success=1.0)] * 2
    c = RE.cell_stat(P, "her", [ended, dict(training, rows=up)], n_boot=20)
    # the median of (400, never) is never, for good: the ended seed will not cross
    assert (
        T.per_seed_text(c) == "not crossed (400 – not crossed), mean not crossed, 1/2"
    )
    three = [dict(training, seed=2), dict(training, seed=3, rows=up)]
    c = RE.cell_stat(P, "her", [ended] + three, n_boot=20)  # never, (training), 400
    assert T.per_seed_text(c).startswith("not yet (400 – not crossed)")
    c = RE.cell_stat(P, "her", [ended, dict(ended, seed=1), three[1]], n_boot=20)
    assert T.per_seed_text(c).startswith("not crossed (400 – not crossed)")


def flat_run(root, folder, method, seed, success, env=P, **kw):
    """A run as `train --out ROOT/FOLDER` writes it: no <env>/<name>/seed<k> above."""
    return make_run(
        root / folder,
        env,
        folder,
        seed,
        success,
        method=method,
        name_dir=False,
        epochs=len(success),
        **kw,
    )


def test_flat_run_folders_are_a_cell_each(tmp_path, capsys):
    """`train --out runs/push-her` and `runs/push-acder`, as the README's examples: each
    run folder is its own cell, named after it, its seed from config.json; not one cell
    "runs" mixing methods with seed 0 twice."""
    runs = tmp_path / "runs"
    flat_run(runs, "push-her", "her", 0, [0.2, 0.96], done="budget")
    flat_run(runs, "push-acder", "acder", 0, [0.96, 0.96], done="budget")
    flat_run(runs, "push-acder-s3", "acder", 3, [0.5, 0.96], done="budget")
    got = RU.load_runs(runs, warn=pytest.fail)
    assert [(r["env"], r["name"], r["method"], r["seed"]) for r in got] == [
        (P, "push-acder", "acder", 0),
        (P, "push-acder-s3", "acder", 3),
        (P, "push-her", "her", 0),
    ]
    assert cli.main(["table", "--results", str(runs)]) == 0
    cap = capsys.readouterr()
    assert cap.err == "" and "(`runs`)" not in cap.out
    for name in ("push-her", "push-acder", "push-acder-s3"):
        assert f"(`{name}`) | 1 done |" in cap.out


def test_a_single_run_folder_is_named_after_itself(tmp_path, capsys):
    d = flat_run(tmp_path / "runs", "push-her", "her", 2, [0.5, 0.96], done="budget")
    (run,) = RU.load_runs(d, warn=pytest.fail)
    assert (run["name"], run["method"], run["seed"]) == ("push-her", "her", 2)
    assert cli.main(["table", "--results", str(d)]) == 0
    cap = capsys.readouterr()
    assert "| Push | push-her (`push-her`) | 1 done |" in cap.out and cap.err == ""
    # a seed folder of the grid is still a seed of its cell
    g = make_run(tmp_path / "grid", P, "her", 4, [0.5, 0.96], done="budget")
    (run,) = RU.load_runs(g, warn=pytest.fail)
    assert (run["env"], run["name"], run["seed"]) == (P, "her", 4)


def test_a_repeated_seed_or_mixed_methods_leave_those_runs_out(results, capsys):
    """Two trees of one layout under one folder: both seed 0 runs of (Push, her) are
    named on stderr and left out, the other runs read as before; a cell whose runs
    disagree on the method is left out whole."""
    again = make_run(results / "older", P, "her", 0, [0.1, 0.2], done="budget")
    make_run(results, R, "mine", 0, [0.5, 1.0], method="her", epochs=2, done="budget")
    make_run(results, R, "mine", 1, [0.5, 1.0], method="acder", epochs=2, done="budget")
    lines = []
    got = RU.load_runs(results, warn=lines.append)
    assert sorted((r["env"], r["name"], r["seed"]) for r in got) == [
        (P, "acder", 0),
        (P, "her", 1),
        (R, "her", 0),
    ]
    first = results / P / "her" / "seed0"
    assert sorted(lines) == sorted(
        [
            f"skipped {again}: seed 0 of cell {P}/her is in 2 run folders; "
            "allowed: one run per seed of a cell",
            f"skipped {first}: seed 0 of cell {P}/her is in 2 run folders; "
            "allowed: one run per seed of a cell",
        ]
        + [
            f"skipped {results / R / 'mine' / f'seed{k}'}: the runs of cell {R}/mine "
            "mix methods (acder, her); allowed: one method per cell (a folder of its "
            "own per method)"
            for k in (0, 1)
        ]
    )
    # the command prints each on one line and the table of the rest
    assert cli.main(["table", "--results", str(results)]) == 0
    cap = capsys.readouterr()
    err = cap.err.strip().splitlines()
    assert len(err) == 4 and all(x.startswith("table: skipped ") for x in err)
    assert "| Push | DDPG+HER (`her`) | 1 done |" in cap.out and "`mine`" not in cap.out


def test_words_plural_and_count():
    from acder_lite.words import count, plural

    assert [plural(n, "epoch") for n in (0, 1, 2, 2.5)] == [
        "epochs", "epoch", "epochs", "epochs"
    ]  # fmt: skip
    assert count(2560, "row") == "2,560 rows" and count(1, "trial") == "1 trial"
    assert [count(n, "seed") for n in (0, 1, 3)] == ["0 seeds", "1 seed", "3 seeds"]


def test_book_table_has_four_columns_and_the_rest_in_its_detail(results):
    """The book's Table I fits its text column: task (once per task), method, ours
    (crossing, then the interval on a line of its own) and the paper's; the other
    columns of the full table are in the detail below it, so no fact is lost."""
    cells = RE.summarize(RU.load_runs(results), n_boot=100)
    header, rows = T.book_rows(cells)
    assert header == T.BOOK_HEADER and all(len(r) == 4 for r in rows)
    tasks = [r[0] for r in rows]
    assert tasks[0] and tasks.count("Push") == 1  # each task named once
    push = [c for c in cells if c.env == P]
    first = rows[tasks.index("Push")]
    assert first[1] == T.label(push[0].name) and first[3] == T.episodes(push[0].paper)
    lines = first[2].split("\n")
    assert lines[0] == T.mean_text(push[0])
    span = T.interval_span(push[0]).replace(" – ", "\u00a0–\u00a0")
    assert lines[1] in ("95%: " + span, "one seed: no interval")
    d_header, detail = T.detail_rows(cells)
    assert d_header[-1] == T.HEADER[5] and len(detail) == len(rows)
    full = T.table_rows(cells)[1]
    for d, f in zip(detail, full):  # seeds, share of resamples, per seed: as in full
        assert d[2] == f[2] and d[4] == f[5] and d[3] in f[4] + "–"
    html = T.book_html(cells, "Table I", "episodes")
    assert html.count("<table>") == 2 and "<details><summary>Table I, per seed" in html
    assert "<caption" in html and "<strong>Table I.</strong> Episodes" in html
    assert "<br>95%: " in html or "one seed: no interval" in html


def test_book_table_says_which_cells_still_train():
    c = push_cell("her-per", 10.0, 9.0, 12.0)
    c.boot, c.n, c.share_crossing, c.unfinished = [10.0], 3, 1.0, 2
    assert T.interval_span(c) == "3,600 – 4,800"
    assert T.ours_text(c) == (  # no line break inside the interval
        "4,000\n95%: 3,600\u00a0–\u00a04,800\n2 of 3 seeds still training"
    )


def test_html_caption_and_line_breaks():
    html = T.to_html(("a", "b"), [("x\ny", "`z`")], caption=("T", "what & why"))
    assert html.startswith('<table><caption style="caption-side: top')
    assert "<strong>T.</strong> What &amp; why</caption><thead>" in html
    assert "<td>x<br>y</td><td><code>z</code></td>" in html
    assert T.to_html(("a",), [("x",)]) == (
        "<table><thead><tr><th>a</th></tr></thead><tbody><tr><td>x</td></tr>"
        "</tbody></table>"
    )


def test_protocol_rows_follow_the_presets():
    # protocol v2: Baselines' Reach epochs of 10 cycles, 20 test episodes per worker,
    # the paper's budgets (25 / 50 / 100 epochs) and Table I's thresholds
    from acder_lite.runs.table import PROTOCOL_HEADER, protocol_rows

    header, rows = protocol_rows()
    assert header == PROTOCOL_HEADER and len(header) == len(rows[0])
    assert rows == [
        ("Reach", 25, 10, 80, "20 per worker", "100%"),
        ("Push", 50, 50, 400, "20 per worker", "95%"),
        ("Pick&Place", 100, 50, 400, "20 per worker", "95%"),
    ]
    assert protocol_rows(["FetchPush-v4"])[1] == rows[1:2]


def test_switch_rows_one_column_per_switch_bools_as_yes_no():
    from acder_lite.config import METHODS

    head, rows = T.switch_rows(["her", "acder"])
    assert head == ("method", *(f"`{k}`" for k in METHODS["acder"]))
    assert [r[0] for r in rows] == ["`her`", "`acder`"]
    her = dict(zip(METHODS["acder"], rows[0][1:]))
    for k, v in METHODS["her"].items():
        assert her[k] == (("yes" if v else "no") if isinstance(v, bool) else v)
    assert set(rows[1][1:]) - {"yes", "no"}  # a choice, 'sicm', kept as it is


def test_load_folder_and_planned_folder_read_what_is_there(results, tmp_path):
    lines = []
    assert RU.load_folder(tmp_path / "absent", warn=lines.append) == []
    assert len(RU.load_folder(results, warn=lines.append)) == 4 and not lines
    assert RU.planned_folder(results / "plan.toml", results) == {}
    (results / "plan.toml").write_text(
        '[[group]]\nenvs = ["FetchPush-v4"]\nmethods = ["her"]\nseeds = [0, 1, 2]\n'
    )
    planned = RU.planned_folder(results / "plan.toml", results)
    assert planned == RU.planned_cells(results / "plan.toml", results)
    assert planned[(P, "her")]["seeds"] == 3


def test_a_curve_evaluated_up_to_its_earliest_crossing_says_no_more():
    """A seed still training below the level counts with its last evaluation, so the
    earliest crossing is often where the mean curve ends (epoch 4): "not before 1,600"
    would only repeat "evaluated to epoch 4"."""
    c = push_cell("her-per", None, None, None)
    c.why, c.evaluated_epochs, c.earliest = "not yet", 4.0, 4.0
    assert T.mean_text(c) == "not yet (evaluated to epoch 4)"


def test_not_within_budget_names_the_papers_budget_only_when_ours_is_shorter():
    """Push's budget is 50 epochs in the paper: a run of 25 cannot say "never", one of
    50 can, and its text names no second budget."""
    c = push_cell("her", None, None, None)
    c.why, c.budget_epochs = "not within budget", 50.0
    assert T.mean_text(c) == "not within budget (50 epochs)"
    c.budget_epochs = 25.0
    assert T.mean_text(c) == "not within budget (25 epochs of the paper's 50)"
    c.budget_epochs = 1.0  # a one-epoch try-out run
    assert T.mean_text(c) == "not within budget (1 epoch of the paper's 50)"


def test_seeds_text_says_on_hold_only_while_planned_seeds_are_missing():
    c = push_cell("her-per", None, None, None)
    c.planned, c.hold, c.n, c.done = 3, "until the readings are in", 1, 1
    assert T.seeds_text(c) == "1 done / 3 planned (on hold)"
    c.n = c.done = 3  # every planned seed is in: the hold no longer says anything
    assert T.seeds_text(c) == "3 done / 3 planned"


def test_ratio_text_writes_its_interval_low_end_first():
    r = RE.RatioStat(P, 2.0, low=1.8, high=3.5, paper=5.3)
    assert T.ratio_text(r) == "2.0 [1.8 – 3.5]"
    r.high = math.inf  # HER never crossing in the upper 2.5% of resample pairs
    assert T.ratio_text(r) == "2.0 [1.8 – ∞]"


def test_progress_with_a_repeated_episode_count_is_refused(tmp_path):
    """Two evaluations at 400 episodes: no training between them, not a curve."""
    path = tmp_path / "progress.csv"
    path.write_text("epoch,episodes,test_success\n1,400,0.5\n2,400,0.6\n")
    with pytest.raises(RU.RunError, match="episodes '400' is not above line 2's"):
        RU.read_progress(path)


def test_a_hidden_run_folder_is_not_read(tmp_path):
    """A run folder whose own name starts with '.' (a copy put aside) is left out."""
    kept = make_run(tmp_path, P, "her", 0, [0.5, 0.6])
    make_run(tmp_path / P / "her" / ".seed1", P, "her", 1, [0.5], name_dir=False)
    assert RU.find_run_dirs(tmp_path) == [kept]
    assert [r["seed"] for r in RU.load_runs(tmp_path)] == [0]


def test_a_runs_budget_is_its_first_commands_epochs(tmp_path):
    """Started with --epochs 10, ended at epoch 3 by a resume (config.json: 3): its
    budget is 10 epochs of 400 episodes."""
    make_run(
        tmp_path, P, "her", 0, [0.5, 0.6, 0.7], epochs=3, done="budget",
        command="train --epochs 10",
    )  # fmt: skip
    (run,) = RU.load_runs(tmp_path)
    assert (run["planned_epochs"], run["budget_epochs"], run["budget"]) == (
        10,
        10.0,
        4000.0,
    )


def test_words_sentence_leaves_out_empty_clauses():
    """`sentence` joins only the clauses that say something: an empty one (a
    finding with nothing to report) leaves no '; ;' behind."""
    from acder_lite.words import sentence

    assert sentence(["on Push a", "", "b"]) == "On Push a; b."
    assert sentence(["", ""]) == ""


def test_words_sentence_ends_with_one_full_stop():
    """A last clause that already ends in a full stop gets no second one."""
    from acder_lite.words import sentence

    assert sentence(["a", "b ends here."]) == "A; b ends here."
