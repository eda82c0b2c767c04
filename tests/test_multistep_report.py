"""Chapter 9's reading of the multi-step Push runs (acder_lite.book.multistep_report):
the
plan, each method's progress, the chance level and the sentences the chapter glues."""

import dataclasses

import pytest

from acder_lite.book import multistep_report as MR
from acder_lite.book.multistep_report import (
    acder_note,
    acder_parts,
    acder_parts_sentence,
    best_sentence,
    chance_sentence,
    evaluation_counts,
    method_progress,
    plan_words,
    progress_sentence,
    read_runs,
    runs_words,
    solved_starts_sentence,
    starts_note,
    task_plan,
    versus_chance,
)

ENV = "FetchPushMultiStep-v0"


def seed(best, success=None, seed=0):
    return dict(
        seed=seed,
        epoch=40.0,
        episodes=16_000.0,
        success=best if success is None else success,
        best=best,
        planned=40,
        ended="budget",
        share=0.1,
        tests=3200,
        test_successes=21,
    )


def test_best_sentence_says_whether_any_run_reached_the_threshold():
    runs = {"DDPG+HER": [seed(0.0375, 0.0)], "DDPG+ACDER": [seed(0.01), seed(0.04, 1)]}
    assert best_sentence(runs, 0.95) == (
        "No run reached the 95% threshold at any evaluation."
    )
    runs["DDPG+ACDER"].append(seed(0.96, 0.9, 2))
    assert best_sentence(runs, 0.95) == "Runs of DDPG+ACDER reached the 95% threshold."
    runs["DDPG+HER"].append(seed(0.95, 0.9, 1))
    runs["DDPG+X"] = [seed(1.0)]
    assert best_sentence(runs, 0.95) == (
        "Runs of DDPG+HER, DDPG+ACDER and DDPG+X reached the 95% threshold."
    )
    assert best_sentence({"DDPG+HER": []}, 0.95) == ""


def test_versus_chance_by_the_wilson_interval():
    # 21 of 3,200: 95% Wilson interval about [0.0043, 0.0100]
    assert versus_chance(21, 3200, 0.0066) == "at"
    assert versus_chance(21, 3200, 0.0040) == "above"
    assert versus_chance(21, 3200, 0.0110) == "below"
    assert versus_chance(0, 40, 0.0) == "at"  # the interval starts at 0


def test_chance_sentence_pools_seeds_and_follows_the_numbers():
    her = seed(0.0375)
    acder = dict(seed(0.0375), test_successes=19)
    s = chance_sentence({"DDPG+HER": [her], "DDPG+ACDER": [acder]}, 66, 10_000)
    assert s == (
        "Over all their evaluations DDPG+HER succeeded in 21 of 3,200 test episodes "
        "(0.66%; 95% interval 0.43% to 1.00%) and DDPG+ACDER succeeded in 19 of 3,200 "
        "test episodes (0.59%; 95% interval 0.38% to 0.93%). Both blocks already "
        "start on their targets in 0.66% of the env's resets (66 of 10,000, no step "
        "taken): taking a rate as above or below that chance level only when its 95% "
        "Wilson interval lies wholly above or below it, DDPG+HER and DDPG+ACDER are at "
        "chance, as many successes as episodes that start solved would give."
    )
    two = [acder, dict(acder, seed=1, test_successes=200)]  # 219 of 6,400: above
    s = chance_sentence({"DDPG+HER": [her], "DDPG+ACDER": two}, 66, 10_000)
    assert "DDPG+ACDER succeeded in 219 of 6,400" in s
    assert s.endswith(
        "DDPG+ACDER is above chance; DDPG+HER is at chance, as many "
        "successes as episodes that start solved would give."
    )
    assert chance_sentence({"DDPG+HER": []}, 66, 10_000) == ""


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
    assert parts["pool_size"] == 50 and parts["novel_start_share"] == pytest.approx(
        0.65
    )
    s = acder_parts_sentence(parts, "at")
    assert s.startswith("Averaged over epochs 2 to 3: its start pool held 50")
    assert acder_parts_sentence(parts, "at", seed=1).startswith(
        "Seed 1, averaged over epochs 2 to 3: its start pool"
    )
    assert "65% of its training episodes restarted" in s
    assert s.endswith("stayed at chance: nothing it learnt shows at test.")
    assert "above chance" in acder_parts_sentence(parts, "above")
    assert acder_parts([rows[0]]) == {} and acder_parts_sentence({}, "at") == ""


def test_progress_sentence_gives_each_seeds_last_epoch_and_best():
    s = progress_sentence("DDPG+HER", [seed(0.0375, 0.0)], 400)
    assert s == (
        "DDPG+HER: seed 0 reached epoch 40 of the 40 planned (10% of the paper's "
        "budget of 400 epochs), test success 0.00 at its last epoch (best 0.04); "
        "ended: budget."
    )
    assert progress_sentence("DDPG+HER", [], 400) == "DDPG+HER: not run yet."
    assert progress_sentence("DDPG+HER", [], 400, started=True) == (
        "DDPG+HER: started, no evaluation yet."
    )


def test_solved_starts_sentence_compares_evaluation_by_evaluation():
    run = dict(
        seed=0,
        config=dict(test_episodes=20, workers=4),
        rows=[dict(test_success=x) for x in (0.0125, 0.0, 0.025)],
    )
    assert solved_starts_sentence(run, "DDPG+HER", [1, 1, 2]) == (
        "DDPG+HER seed 0: 4 of its 240 test episodes started with both blocks on "
        "their targets, and it had 3 successes; the two counts are equal at 2 of its "
        "3 evaluations."
    )


PLAN = """
[[group]]
envs = ["FetchPushMultiStep-v0"]
methods = ["her", "acder"]
seeds = [0]
config = { epochs = 40 }

[[group]]
envs = ["FetchPushMultiStep-v0"]
methods = ["acder"]
seeds = [1]
hold = "after the grid"

[[group]]
envs = ["FetchPush-v4"]
methods = ["her"]
seeds = [2]
"""


def test_task_plan_lists_the_tasks_cells_with_their_share_of_the_paper(tmp_path):
    (tmp_path / "plan.toml").write_text(PLAN)
    cells, lines = task_plan(tmp_path / "plan.toml")
    assert [(c.method, c.seed) for c in cells] == [
        ("her", 0),
        ("acder", 0),
        ("acder", 1),
    ]
    assert lines == [
        "DDPG+HER    seed 0: 40 epochs (10% of the paper's)",
        "DDPG+ACDER  seed 0: 40 epochs (10% of the paper's)",
        "DDPG+ACDER  seed 1: 400 epochs (100% of the paper's); on hold: after the grid",
    ]
    one = PLAN.replace(
        "epochs = 40", "epochs = 1"
    )  # a try-out: "1 epoch", not "1 epochs"
    (tmp_path / "plan.toml").write_text(one)
    assert task_plan(tmp_path / "plan.toml")[1][0] == (
        "DDPG+HER    seed 0: 1 epoch (0% of the paper's)"
    )
    cells, lines = task_plan(tmp_path / "missing.toml")
    assert cells == [] and len(lines) == 1 and lines[0].startswith("no plan: ")
    assert "missing.toml" in lines[0]


def test_plan_words_follow_the_cells(tmp_path):
    (tmp_path / "plan.toml").write_text(PLAN)
    cells, _ = task_plan(tmp_path / "plan.toml")
    assert plan_words(cells) == dict(
        plan_epochs="400",
        plan_share="100%",
        plan_seeds="seeds 0 and 1",
        seeds_note="With 2 seeds a curve is a mean of few draws",
    )
    one = plan_words(cells[:2])
    assert (one["plan_epochs"], one["plan_share"]) == ("40", "10%")
    assert one["plan_seeds"] == "seed 0"
    assert one["seeds_note"] == "With one seed a curve is one draw"
    three = [dataclasses.replace(cells[0], seed=k) for k in (2, 0, 1)]
    assert plan_words(three)["plan_seeds"] == "seeds 0, 1 and 2"
    none = plan_words([])
    assert (none["plan_seeds"], none["plan_epochs"]) == ("no seed yet", "0")
    assert none["seeds_note"] == "With no seed planned there is no curve yet"


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


def test_runs_words_say_each_methods_progress_then_the_outcome(tmp_path):
    (tmp_path / "acder").mkdir()  # started, no evaluation yet
    runs = [a_run("her", [0.0, 0.5]), a_run("her-icm", [1.0])]
    progress = method_progress(runs)
    assert list(progress) == ["her", "acder"] and progress["acder"] == []
    assert [s["tests"] for s in progress["her"]] == [4]
    words = runs_words(progress, tmp_path, 66, 10_000)
    her = progress_sentence("DDPG+HER", progress["her"], 400)
    assert her.startswith("DDPG+HER: seed 0 reached epoch 2 of the 40 planned (0.5%")
    outcome = words["runs_outcome"]
    assert outcome.startswith("No run reached the 95% threshold at any evaluation. ")
    assert "DDPG+HER succeeded in 1 of 4 test episodes" in outcome
    assert "DDPG+ACDER succeeded" not in outcome  # her-icm is no method of the chapter
    assert words["runs_note"] == (
        f"{her} DDPG+ACDER: started, no evaluation yet. {outcome}"
    )
    none = runs_words(method_progress([]), tmp_path / "nowhere", 66, 10_000)
    assert none == dict(
        runs_outcome=MR.NOTHING_YET,
        runs_note="DDPG+HER: not run yet. DDPG+ACDER: not run yet. "
        "There is nothing to plot yet.",
    )


def test_starts_note_replays_each_run_in_the_chapters_order():
    runs = [a_run("acder", [0.0, 0.5]), a_run("her-icm", [0.0, 0.0])]
    runs += [a_run("her", [0.0, 0.0]), a_run("her", [], seed=1)]  # seed 1: no rows
    note = starts_note(runs)
    heads = ("DDPG+HER seed 0: ", "DDPG+ACDER seed 0: ", "her-icm seed 0: ")
    at = [note.index(h) for h in heads]
    assert at == sorted(at) and "seed 1" not in note
    assert note.count("of its 4 test episodes started with both blocks") == 3
    assert "and it had 1 successes" in note  # DDPG+ACDER's 0.5 of 2 episodes
    assert starts_note([]) == "There is no run to replay yet."


def test_acder_note_reads_each_acder_run_against_chance():
    cols = dict(pool_size=50, alpha=0.68, novel_start_share=0.6, train_success=0.01)
    cols.update(r_int_mean=0.003, lambda_mean=1.2)
    late = a_run("acder", [0.0, 0.5, 0.0], seed=3, **cols)  # 1 of 6: above 0
    runs = [a_run("her", [0.0, 0.5, 0.0], **cols), late]
    note = acder_note(runs, chance=0.0)
    assert note == acder_parts_sentence(acder_parts(late["rows"]), "above", 3)
    assert note.startswith("Seed 3, averaged over epochs 2 to 3: ")
    assert acder_note(runs, chance=0.5).endswith("stayed at chance: nothing it "
                                                 "learnt shows at test.")  # fmt: skip
    early = a_run("acder", [0.0], **cols)  # epoch 1 only: no parts to average yet
    fallback = "There is no DDPG+ACDER run to read yet."
    assert acder_note([early], 0.0) == acder_note(runs[:1], 0.0) == fallback


def test_best_sentence_counts_a_best_exactly_at_the_threshold():
    """The threshold is reached at or above it (as the stop rule reads it): a best of
    exactly 0.95 reached 95%."""
    assert best_sentence({"DDPG+HER": [seed(0.95)]}, 0.95) == (
        "Runs of DDPG+HER reached the 95% threshold."
    )


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
