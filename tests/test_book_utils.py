"""The chapters' sentences about committed runs (acder_lite.book_utils)."""

from acder_lite.book_utils import best_sentence, progress_sentence


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
    )


def test_best_sentence_says_whether_any_run_reached_the_threshold():
    runs = {"DDPG+HER": [seed(0.0375, 0.0)], "DDPG+ACDER": [seed(0.01), seed(0.04, 1)]}
    assert best_sentence(runs, 0.95, 0.004) == (
        "No run reached the 95% threshold at any evaluation: the best test success was "
        "0.04 for DDPG+HER, 0.04 for DDPG+ACDER, against 0.00 for a random arm."
    )
    runs["DDPG+ACDER"].append(seed(0.96, 0.9, 2))
    assert best_sentence(runs, 0.95, 0.004).startswith(
        "Runs of DDPG+ACDER reached the 95% threshold: the best test success was "
        "0.04 for DDPG+HER, 0.96 for DDPG+ACDER"
    )
    assert best_sentence({"DDPG+HER": []}, 0.95, 0.0) == ""


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
