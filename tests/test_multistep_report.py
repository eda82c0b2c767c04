"""Chapter 9's reading of the multi-step Push runs (acder_lite.book.multistep_report):
the plan, each method's progress, the chance level, and the 400-epoch run's state and
rule, on small synthetic run folders. The chapter writes the sentences; these test
the numbers it quotes."""

import csv
import json
import math

import numpy as np
import pytest

from acder_lite.book import multistep_report as MR
from acder_lite.book.multistep_report import (
    acder_parts,
    block_means,
    chance_reading,
    evaluation_counts,
    long_run,
    method_progress,
    read_runs,
    replayed_starts,
    rule_reading,
    run_state,
    same_first_rows,
    task_plan,
    versus_chance,
)

ENV = "FetchPushMultiStep-v0"


def seed(best, success=None, seed=0, tests=3200, test_successes=21):
    return dict(
        seed=seed,
        epoch=40.0,
        episodes=16_000.0,
        success=best if success is None else success,
        best=best,
        planned=40,
        ended="budget",
        share=0.1,
        tests=tests,
        test_successes=test_successes,
    )


def test_versus_chance_by_the_wilson_interval():
    # 21 of 3,200: 95% Wilson interval about [0.0043, 0.0100]
    assert versus_chance(21, 3200, 0.0066) == "at"
    assert versus_chance(21, 3200, 0.0040) == "above"
    assert versus_chance(21, 3200, 0.0110) == "below"
    assert versus_chance(0, 40, 0.0) == "at"  # the interval starts at 0


def test_chance_reading_pools_seeds_and_leaves_out_methods_without_runs():
    her, acder = seed(0.0375), seed(0.0375, test_successes=19)
    got = chance_reading({"her": [her], "acder": [acder], "x": []}, 66, 10_000)
    assert list(got) == ["her", "acder"]
    assert (got["her"]["k"], got["her"]["n"]) == (21, 3200)
    assert got["her"]["rate"] == pytest.approx(21 / 3200)
    assert got["her"]["low"] == pytest.approx(0.0043, abs=1e-4)
    assert got["her"]["high"] == pytest.approx(0.0100, abs=1e-4)
    assert got["her"]["verdict"] == got["acder"]["verdict"] == "at"
    assert got["her"]["chance"] == 66 / 10_000
    two = [acder, dict(acder, seed=1, test_successes=200)]  # 219 of 6,400: above
    got = chance_reading({"acder": two}, 66, 10_000)["acder"]
    assert (got["k"], got["n"], got["verdict"]) == (219, 6400, "above")


def test_evaluation_counts_turn_test_success_into_episodes():
    run = dict(
        config=dict(test_episodes=20, workers=4),
        rows=[
            dict(test_success=0.0125),
            dict(test_success=0.0),
            dict(test_success=0.0375),
        ],
    )
    assert evaluation_counts(run) == (4, 240)


def test_acder_parts_average_from_the_second_epoch():
    cols = dict(pool_size=50, alpha=0.68, novel_start_share=0.6, train_success=0.01)
    cols.update(r_int_mean=0.003, lambda_mean=1.2)
    rows = [dict(cols, epoch=1.0, pool_size=0, novel_start_share=0.0)]
    rows += [dict(cols, epoch=2.0), dict(cols, epoch=3.0, novel_start_share=0.7)]
    parts = acder_parts(rows)
    assert parts["first"] == 2.0 and parts["last"] == 3.0
    assert parts["pool_size"] == 50
    assert parts["novel_start_share"] == pytest.approx(0.65)
    assert acder_parts([rows[0]]) == {}


PLAN = """
[[group]]
envs = ["FetchPushMultiStep-v0"]
methods = ["her", "acder"]
seeds = [0]
config = { epochs = 40 }
root = "../short"

[[group]]
envs = ["FetchPushMultiStep-v0"]
methods = ["acder"]
seeds = [0]
config = { epochs = 400 }

[[group]]
envs = ["FetchPushMultiStep-v0"]
methods = ["acder"]
seeds = [1]
hold = "after the first"

[[group]]
envs = ["FetchPush-v4"]
methods = ["her"]
seeds = [2]
"""


def test_task_plan_lists_the_tasks_cells_with_their_folders_and_states(tmp_path):
    results = tmp_path / "results"
    results.mkdir()
    (results / "plan.toml").write_text(PLAN)
    done = tmp_path / "short" / ENV / "her" / "seed0"
    done.mkdir(parents=True)
    (done / "done.json").write_text("{}")
    cells, lines = task_plan(results / "plan.toml", root=tmp_path)
    assert [(c.method, c.seed, c.epochs) for c in cells] == [
        ("her", 0, 40),
        ("acder", 0, 40),
        ("acder", 0, 400),
        ("acder", 1, 400),
    ]
    assert lines == [
        f"DDPG+HER    seed 0:  40 epochs ( 10% of the paper's)  "
        f"short/{ENV}/her/seed0: finished",
        f"DDPG+ACDER  seed 0:  40 epochs ( 10% of the paper's)  "
        f"short/{ENV}/acder/seed0: planned",
        f"DDPG+ACDER  seed 0: 400 epochs (100% of the paper's)  "
        f"results/{ENV}/acder/seed0: planned",
        f"DDPG+ACDER  seed 1: 400 epochs (100% of the paper's)  "
        f"results/{ENV}/acder/seed1: planned; on hold: after the first",
    ]
    one = PLAN.replace("epochs = 40 }", "epochs = 1 }")  # "1 epoch", not "1 epochs"
    (results / "plan.toml").write_text(one)
    assert task_plan(results / "plan.toml")[1][0].startswith(
        "DDPG+HER    seed 0:    1 epoch (  0% of the paper's)"
    )
    cells, lines = task_plan(tmp_path / "missing.toml")
    assert cells == [] and len(lines) == 1 and lines[0].startswith("no plan: ")
    assert "missing.toml" in lines[0]


def write_run(folder, successes, done=None, epochs=400, **columns):
    """A run folder as `train` writes it: config.json, a progress.csv of one row per
    epoch with `successes` as test success and each of `columns` (a list of values per
    row), and, with `done` (a stop_reason), done.json."""
    folder.mkdir(parents=True, exist_ok=True)
    cfg = dict(env=ENV, method="acder", seed=0, epochs=epochs, cycles=50,
               episodes_per_cycle=2, workers=4, test_episodes=20)  # fmt: skip
    command = f"python -m acder_lite train --epochs {epochs}"
    (folder / "config.json").write_text(json.dumps(dict(config=cfg, command=command)))
    names = ["epoch", "episodes", "test_success", "wall_s", *columns]
    with open(folder / "progress.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for i, s in enumerate(successes):
            extra = [columns[c][i] for c in columns]
            w.writerow([i + 1, 400 * (i + 1), s, 10.0 * (i + 1), *extra])
    if done:
        info = dict(epochs=float(len(successes)), stop_reason=done)
        (folder / "done.json").write_text(json.dumps(info))
    return folder


def test_run_state_follows_what_the_folder_holds(tmp_path):
    run = tmp_path / ENV / "acder" / "seed0"
    assert run_state(run) == "planned"
    run.mkdir(parents=True)
    assert run_state(run) == "started"
    (run / "config.json").write_text("{}")
    assert run_state(run) == "started"  # config.json, no evaluation yet
    write_run(run, [0.0, 0.0125])
    assert run_state(run) == "in flight"
    (run / "done.json").write_text("{}")
    assert run_state(run) == "finished"
    assert MR.RUN_STATES == ("planned", "started", "in flight", "finished")


BLOCKS = dict(
    block0_on_target=[0.05, 0.10, 0.20],
    block1_on_target=[0.0, 0.05, 0.10],
    block0_moved=[0.1, 0.3, 0.5],
    block1_moved=[0.0, 0.2, 0.4],
    pool_block_on_target=["nan", 0.2, 0.4],
)


def test_long_run_in_flight_reads_its_rows_and_per_block_columns(tmp_path):
    """The 400-epoch run between sessions: progress.csv with per-block columns (the
    pool's share NaN at the first evaluation, the pool still empty), no done.json."""
    folder = write_run(tmp_path / "acder" / "seed0", [0.0, 0.0125, 0.0], **BLOCKS)
    got = long_run(folder)
    assert got["state"] == "in flight" and got["epoch"] == 3.0
    assert got["planned"] == 400 and got["run"]["ended"] is None
    assert got["versions"] == {}  # write_run records none
    rows = got["run"]["rows"]
    assert math.isnan(rows[0]["pool_block_on_target"])
    means = block_means(rows)
    assert means["block0_on_target"] == pytest.approx(0.35 / 3)
    assert means["pool_block_on_target"] == pytest.approx(0.3)  # the NaN left out
    assert (means["first"], means["last"]) == (1.0, 3.0)
    last = block_means(rows, last=2)
    assert last["block1_moved"] == pytest.approx(0.3) and last["first"] == 2.0
    assert math.isnan(block_means(rows[:1])["pool_block_on_target"])


def test_long_run_without_an_evaluation_has_no_run(tmp_path):
    assert long_run(tmp_path / "nowhere") == dict(
        state="planned", run=None, epoch=0.0, planned=None, versions={}
    )
    started = tmp_path / "started"
    started.mkdir()
    assert long_run(started)["state"] == "started"
    assert long_run(started)["run"] is None


def test_long_run_finished_by_its_budget(tmp_path):
    folder = write_run(tmp_path / "r", [0.0, 0.0, 0.0], done="budget", epochs=3)
    got = long_run(folder)
    assert got["state"] == "finished" and got["run"]["ended"] == "budget"


def test_block_means_of_runs_without_per_block_columns_is_empty(tmp_path):
    """The 40-epoch runs were trained before the per-block columns existed."""
    folder = write_run(tmp_path / "r", [0.0, 0.0125])
    assert block_means(long_run(folder)["run"]["rows"]) == {}
    assert block_means([]) == {}


def rows_of(successes):
    return [dict(epoch=float(e), test_success=s) for e, s in enumerate(successes, 1)]


def test_rule_reading_needs_five_consecutive_evaluations_at_the_level():
    at_chance = rule_reading(rows_of([0.0125, 0.0, 0.0375, 0.0]))
    assert at_chance == dict(
        met=False, met_at=None, longest=0, streak=0, best=0.0375, evaluations=4
    )
    four = rule_reading(rows_of([0.1, 0.2, 0.1, 0.15, 0.05, 0.1, 0.1]))
    assert (four["met"], four["longest"], four["streak"]) == (False, 4, 2)
    held = rule_reading(rows_of([0.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.3, 0.0]))
    assert (held["met"], held["met_at"], held["longest"]) == (True, 6.0, 6)
    assert held["streak"] == 0  # it fell back since: the rule was met all the same
    assert rule_reading([])["best"] == 0.0 and not rule_reading([])["met"]
    assert rule_reading(rows_of([0.099] * 9))["longest"] == 0  # below 0.10


def test_rule_reading_in_a_synthetic_finished_run(tmp_path):
    folder = write_run(tmp_path / "r", [0.0] + [0.125] * 5, done="budget", epochs=6)
    got = rule_reading(long_run(folder)["run"]["rows"])
    assert got["met"] and got["met_at"] == 6.0


def test_same_first_rows_compares_the_rows_and_columns_both_have(tmp_path):
    short = write_run(tmp_path / "short", [0.0125, 0.0], epochs=40)
    long = write_run(tmp_path / "long", [0.0125, 0.0, 0.0], **BLOCKS)
    a, b = (long_run(x)["run"]["rows"] for x in (short, long))
    assert same_first_rows(a, b) == []  # per-block columns: only the long run's
    b[1] = dict(b[1], test_success=0.0125, wall_s=99.0)  # wall_s is the timing
    assert same_first_rows(a, b) == [(2.0, "test_success", 0.0, 0.0125)]
    nan = [dict(epoch=1.0, x=float("nan"))]
    assert same_first_rows(nan, nan) == []


def test_replayed_starts_counts_evaluation_by_evaluation():
    run = dict(
        seed=0,
        config=dict(seed=0, test_episodes=20, workers=1),
        rows=[dict(test_success=x) for x in (0.05, 0.0, 0.1)],
    )
    from acder_lite.book.pusher import solved_test_starts

    solved = [int(x) for x in solved_test_starts(run["config"], 3)]
    got = replayed_starts(run)
    assert got["per_evaluation"] == list(zip(solved, [1, 0, 2]))
    assert (got["solved"], got["successes"], got["tests"]) == (sum(solved), 3, 60)
    assert got["equal"] == sum(s == w for s, w in zip(solved, [1, 0, 2]))
    assert got["evaluations"] == 3
    assert got["more"] + got["fewer"] + got["equal"] == 3
    assert got["more"] == sum(w > s for s, w in zip(solved, [1, 0, 2]))


def test_rule_chance_is_the_binomial_tail_at_the_level():
    one, five = MR.rule_chance(0.5, 10, level=0.9, evaluations=2)
    assert one == pytest.approx(11 / 1024)  # 9 or 10 heads of 10
    assert five == pytest.approx((11 / 1024) ** 2)
    one, _ = MR.rule_chance(0.0066, 80)  # 8 of 80: 0.10 exactly, ceil not off by one
    assert one == pytest.approx(6.84e-8, rel=1e-2)
    assert MR.rule_chance(0.0, 80) == (0.0, 0.0) and MR.rule_chance(1.0, 80)[0] == 1.0


def test_start_on_targets_counts_each_block():
    from acder_lite.book.pusher import start_on_targets

    got = start_on_targets([0], 300)
    assert got["each"].shape == (300, 1, 2)
    np.testing.assert_array_equal(got["one"], got["each"].any(axis=-1))
    np.testing.assert_array_equal(got["both"], got["each"].all(axis=-1))


def test_read_runs_names_what_it_skips_relative_to_the_root(tmp_path):
    broken = tmp_path / ENV / "her" / "seed0"
    broken.mkdir(parents=True)
    (broken / "config.json").write_text("not json")
    said = []
    assert read_runs(tmp_path / ENV, tmp_path, warn=said.append) == []
    assert len(said) == 1 and said[0].startswith(f"skipped {ENV}/her/seed0: ")
    assert read_runs(tmp_path / "nowhere", tmp_path, warn=said.append) == []
    assert len(said) == 1


def a_run(name, successes, seed=0, ended="budget", **columns):
    rows = [
        dict(epoch=float(e), episodes=400.0 * e, test_success=s, **columns)
        for e, s in enumerate(successes, 1)
    ]
    config = dict(seed=seed, workers=1, test_episodes=2)
    return dict(env=ENV, name=name, seed=seed, rows=rows, ended=ended,
                planned_epochs=40, config=config)  # fmt: skip


def test_method_progress_keeps_the_chapters_methods_in_order():
    runs = [a_run("her", [0.0, 0.5]), a_run("her-icm", [1.0])]
    progress = method_progress(runs)
    assert list(progress) == ["her", "acder"] and progress["acder"] == []
    (her,) = progress["her"]
    assert (her["tests"], her["test_successes"], her["best"]) == (4, 1, 0.5)
    assert her["share"] == pytest.approx(800 / 160_000)


def test_versus_chance_at_the_edges_of_the_interval_is_at():
    """Above or below only when the whole interval lies beyond the chance level: an
    interval that ends exactly at it is 'at'."""
    from acder_lite.stats.trial_stats import wilson_interval

    lo, hi = wilson_interval(21, 3200)
    assert versus_chance(21, 3200, lo) == "at"
    assert versus_chance(21, 3200, hi) == "at"


def test_evaluation_counts_round_a_test_success_to_its_count():
    """0.29 of 100 test episodes (25 a worker, 4 workers) is 29 successes, though
    0.29 * 100 is 28.999999999999996 in floats: rounded, not truncated."""
    run = dict(
        config=dict(test_episodes=25, workers=4),
        rows=[dict(test_success=0.29), dict(test_success=0.57)],
    )
    assert 0.29 * 100 < 29 and 0.57 * 100 < 57
    assert evaluation_counts(run) == (29 + 57, 200)


def test_no_success_is_at_a_chance_of_zero_and_every_success_at_one():
    """The Wilson interval's exact ends: 0 of 11 is at a chance level of 0 (in floats
    its lower end was 2.8e-17, "above"), 6 of 6 at a chance level of 1."""
    assert MR.versus_chance(0, 11, 0.0) == "at"
    assert MR.versus_chance(6, 6, 1.0) == "at"
