"""Chapter 10's reading of the runs it benches (acder_lite.book.deploy_report), on
hand-made runs: which finished run each column takes, where the full-state policy came
from, where a run crossed its threshold and how it ended, and whether a task's columns
trained as long."""

from acder_lite.book.deploy_report import (
    STAND_IN,
    TRAINING_HEADER,
    full_state_sentence,
    lengths_sentence,
    policies,
    policy_lines,
    training_facts,
    training_rows,
)


def test_full_state_sentence_names_the_stand_ins():
    """Chapter 10's full-state column: the grid's run, the protocol-v1 stand-in while
    the grid's has not finished, or none."""
    R, P, PP = "FetchReach-v4", "FetchPush-v4", "FetchPickAndPlace-v4"
    grid = {e: f"results/{e}/acder/seed0" for e in (R, P, PP)}
    assert full_state_sentence(grid) == (
        "Every task's full-state policy is the grid's own run."
    )
    mixed = dict(grid, **{P: f"{STAND_IN}{P}/acder/seed0", PP: None})
    assert full_state_sentence(mixed) == (
        "On Reach the full-state policy is the grid's run; on Push the grid's run has "
        "not finished, and the protocol-v1 run of the same method and seed stands in "
        "for it (chapter 8 says what differs); on Pick&Place no full-state policy has "
        "finished."
    )


def _run(success, ended, stop_reason, epochs_per_row=1, per_epoch=400):
    """A hand-made `runs.read_run` result of FetchPush (threshold 0.95, patience 5)."""
    rows = [
        dict(
            epoch=(i + 1) * epochs_per_row, episodes=(i + 1) * per_epoch, test_success=s
        )
        for i, s in enumerate(success)
    ]
    done = (
        None
        if ended is None
        else dict(
            stop_reason=stop_reason,
            stop_rule=dict(success_threshold=0.95, patience=5),
        )
    )
    return dict(
        env="FetchPush-v4",
        rows=rows,
        config=dict(success_threshold=0.95, stop_patience=5),
        done_info=done,
        ended=ended,
    )


def test_training_facts_say_where_a_run_crossed_and_how_it_ended():
    stopped = _run([0.5, 0.9, 1.0, 1.0, 1.0, 1.0, 1.0], "stop rule", "success held")
    assert training_facts(stopped) == dict(
        crossed="first reached 0.95 at 1,000 episodes",
        ended="stopped once it had held 0.95 for 5 evaluations, after 7 epochs "
        "(2,800 episodes)",
    )  # 0.9 at 800, 1.0 at 1,200: 0.95 read halfway between
    budget = _run([0.2, 0.97, 0.9, 0.89], "budget", "budget")
    assert training_facts(budget) == dict(
        crossed="first reached 0.95 at 790 episodes",
        ended="never held 0.95 for 5 evaluations: it used its whole budget, 4 "
        "epochs (1,600 episodes), and ended at 0.89",
    )  # 400 + 400 * (0.95 - 0.2) / (0.97 - 0.2) = 789.6
    running = _run([0.1, 0.3], None, None)
    assert training_facts(running) == dict(
        crossed="never reached 0.95",
        ended="is still training (2 epochs (800 episodes) so far, at 0.30)",
    )
    both = {"full state": stopped, "simplified state": None}
    rows = training_rows({"FetchPush-v4": both, "FetchReach-v4": {"a": running}})
    assert len(TRAINING_HEADER) == 4 and rows == [
        ("Push", "full state", *training_facts(stopped).values()),
        ("", "simplified state", "–", "not trained yet"),
        ("Reach", "a", "never reached 0.95", training_facts(running)["ended"]),
    ]
    assert lengths_sentence("FetchPush-v4", both) == (
        "Not every Push column is trained: there are no lengths to compare."
    )
    assert lengths_sentence(
        "FetchPush-v4", {"full state": stopped, "simplified state": budget}
    ) == (
        "The Push policies did not train as long: the full-state one 7 epochs (2,800 "
        "episodes), the simplified-state one 4 epochs (1,600 episodes), so a "
        "difference between their columns is one of training as well as of state."
    )
    assert lengths_sentence("FetchPush-v4", {"a": budget, "b": budget}) == (
        "The Push policies trained as long, 4 epochs (1,600 episodes) each."
    )


def test_policies_take_a_finished_run_and_the_stand_in_until_the_grids_finishes(
    tmp_path,
):
    """A folder counts once it holds done.json and policy.pt: the grid's run before
    its stand-in, the stand-in while the grid's is still training, else None."""
    R, P, PP = "FetchReach-v4", "FetchPush-v4", "FetchPickAndPlace-v4"

    def run(folder, finished=True):
        (tmp_path / folder).mkdir(parents=True)
        for name in ("policy.pt", "done.json") if finished else ("policy.pt",):
            (tmp_path / folder / name).write_text("{}")

    run(f"results/{R}/acder/seed0")
    run(f"{STAND_IN}{R}/acder/seed0")  # not taken: the grid's run has finished
    run(f"experiments/deploy/{R}/acder-simplified/seed0")
    run(f"results/{P}/acder/seed0", finished=False)  # still training
    run(f"{STAND_IN}{P}/acder/seed0")
    run(f"experiments/deploy/{PP}/acder-simplified/seed0", finished=False)
    got = policies(tmp_path, [R, P, PP])
    assert got == {
        R: {
            "full state": f"results/{R}/acder/seed0",
            "simplified state": f"experiments/deploy/{R}/acder-simplified/seed0",
        },
        P: {"full state": f"{STAND_IN}{P}/acder/seed0", "simplified state": None},
        PP: {"full state": None, "simplified state": None},
    }
    lines = policy_lines(got)
    assert len(lines) == 6
    assert lines[0] == f"{R:22s} {'full state':17s} results/{R}/acder/seed0"
    assert lines[3] == f"{P:22s} simplified state  not trained yet"


def test_the_scene_takes_the_simplified_policy_else_the_full_one_and_says_how_it_went():
    from acder_lite.book.deploy_report import scene_label, scene_sentence

    both = {"full state": "results/x", "simplified state": "experiments/deploy/x"}
    assert scene_label(both) == "simplified state"
    assert scene_label(dict(both, **{"simplified state": None})) == "full state"
    assert scene_label({"full state": None, "simplified state": None}) is None
    assert scene_sentence("FetchPush-v4", "simplified state", True) == (
        "The simplified-state policy succeeds in this episode."
    )
    assert scene_sentence("FetchPush-v4", "full state", False) == (
        "The full-state policy fails in this episode."
    )
    assert scene_sentence("FetchPush-v4", None, None) == (
        "No Push policy has finished training, so there is no scene."
    )


def test_policy_clips_as_the_policy_records_them_else_the_training_defaults():
    from acder_lite.config import Config
    from acder_lite.book.deploy_report import policy_clips

    assert policy_clips(dict(clip_obs=5.0, norm=dict(clip=3.0))) == (5.0, 3.0)
    assert policy_clips(None) == (Config().clip_obs, Config().norm_clip)


def test_full_state_sentence_without_a_stand_in_names_the_unfinished_tasks():
    """No stand-in, but a task with no finished full-state policy: the sentence must
    not say every task's policy is the grid's own run."""
    R, P = "FetchReach-v4", "FetchPush-v4"
    folders = {R: f"results/{R}/acder/seed0", P: None}
    assert full_state_sentence(folders) == (
        "On Reach the full-state policy is the grid's run; on Push no full-state "
        "policy has finished."
    )


def test_training_facts_read_the_threshold_and_patience_of_the_runs_stop_rule():
    """done.json's stop rule (0.90, 3 evaluations) comes before the run's config.json
    (0.95, 5): the crossing of 0.90 between 0.8 at 800 episodes and 1.0 at 1,200 is
    read halfway, 800 + 400 * (0.9 - 0.8) / (1.0 - 0.8) = 1,000."""
    run = _run([0.5, 0.8, 1.0, 1.0, 1.0], "stop rule", "success held")
    run["done_info"]["stop_rule"] = dict(success_threshold=0.9, patience=3)
    assert training_facts(run) == dict(
        crossed="first reached 0.90 at 1,000 episodes",
        ended="stopped once it had held 0.90 for 3 evaluations, after 5 epochs "
        "(2,000 episodes)",
    )


def test_a_run_of_one_epoch_reads_1_epoch():
    """'1 epoch (400 episodes)': the noun follows the epochs, not the episodes."""
    assert training_facts(_run([0.3], None, None))["ended"] == (
        "is still training (1 epoch (400 episodes) so far, at 0.30)"
    )


def test_lengths_sentence_compares_the_episodes_not_the_epochs():
    """Two runs of 4 epochs each, one of 400 episodes an epoch (1,600) and one of 200
    (800), did not train as long."""
    full = _run([0.2, 0.4, 0.6, 0.8], "budget", "budget")
    simplified = _run([0.2, 0.4, 0.6, 0.8], "budget", "budget", per_epoch=200)
    assert lengths_sentence(
        "FetchPush-v4", {"full state": full, "simplified state": simplified}
    ) == (
        "The Push policies did not train as long: the full-state one 4 epochs (1,600 "
        "episodes), the simplified-state one 4 epochs (800 episodes), so a "
        "difference between their columns is one of training as well as of state."
    )


def test_lengths_sentence_at_equal_episodes_in_epochs_of_another_size():
    """4 epochs of 400 episodes and 8 of 200: as long, and the sentence names the
    1,600 episodes only (not the first run's "4 epochs" for both)."""
    long = _run([0.2, 0.4, 0.6, 0.8], "budget", "budget")
    short = _run([0.1] * 8, "budget", "budget", per_epoch=200)
    assert lengths_sentence("FetchPush-v4", {"a": long, "b": short}) == (
        "The Push policies trained as long, 1,600 episodes each."
    )
