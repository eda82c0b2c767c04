"""The chapters' sentences about committed runs (acder_lite.book_utils)."""

import pytest

from acder_lite.book_utils import (
    acder_parts,
    acder_parts_sentence,
    best_sentence,
    budgets,
    chance_sentence,
    evaluation_counts,
    progress_sentence,
    solved_starts_sentence,
    vector_text,
    versus_chance,
)


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


def test_budgets_of_a_chapter_that_trains_nothing_print_no_precision(capsys):
    assert budgets(False, trains=False, resets=(10, 2)) == {"resets": 10}
    assert capsys.readouterr().out.splitlines() == ["ACDER_FAST=0: resets=10"]


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


def test_percent_drops_trailing_zeros():
    from acder_lite.book_utils import percent

    assert [percent(x) for x in (0.1, 0.025, 0.003, 1.0, 0.12345)] == [
        "10%",
        "2.5%",
        "0.3%",
        "100%",
        "12.3%",
    ]


def test_percent_range_gives_both_ends_the_same_decimals():
    from acder_lite.book_utils import percent_range

    assert percent_range(0.0043, 0.01) == "0.43% to 1.00%"
    assert percent_range(0.12, 0.3449) == "12% to 34%"
    assert percent_range(0.0, 0.0093) == "0.00% to 0.93%"
    assert percent_range(0.00038, 0.0093) == "0.038% to 0.930%"


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


def test_vector_text_prints_no_negative_zero():
    assert vector_text([1.3634, -0.0001, -0.1384]) == "[ 1.363  0.000 -0.138]"
    assert vector_text([[-0.0, 0.26]], digits=1) == "[ 0.0  0.3]"
