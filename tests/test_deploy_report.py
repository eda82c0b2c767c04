"""Chapter 10's reading of the runs it benches (acder_lite.book.deploy_report), on
hand-made runs: which finished run each column takes and what kind of run it is, where
a run crossed its threshold and how it ended, the benches' counts, and the `robust`
command rerun in a fresh process."""

import pytest

from acder_lite.book.deploy_report import (
    STAND_IN,
    counts,
    full_state_source,
    nominal_successes,
    perturbed_rate,
    policies,
    training_summary,
)


def test_full_state_source_tells_the_grid_from_the_stand_in():
    P = "FetchPush-v4"
    assert full_state_source(f"results/{P}/acder/seed0") == "grid"
    assert full_state_source(f"{STAND_IN}{P}/acder/seed0") == "stand-in"
    assert full_state_source(None) is None


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


def test_training_summary_says_where_a_run_crossed_and_how_it_ended():
    stopped = _run([0.5, 0.9, 1.0, 1.0, 1.0, 1.0, 1.0], "stop rule", "success held")
    assert training_summary(stopped) == dict(
        threshold=0.95,
        patience=5,
        crossed=pytest.approx(1000.0),  # 0.9 at 800, 1.0 at 1,200: read halfway
        ended="early stop",
        epochs=7.0,
        episodes=2800,
        last=1.0,
    )
    budget = training_summary(_run([0.2, 0.97, 0.9, 0.89], "budget", "budget"))
    # 400 + 400 * (0.95 - 0.2) / (0.97 - 0.2) = 789.6
    assert budget["crossed"] == pytest.approx(789.61, abs=0.01)
    assert budget["ended"] == "full budget" and budget["last"] == 0.89
    assert (budget["epochs"], budget["episodes"]) == (4.0, 1600)
    running = training_summary(_run([0.1, 0.3], None, None))
    assert running["crossed"] is None and running["ended"] is None


def test_training_summary_reads_the_threshold_and_patience_of_the_runs_stop_rule():
    """done.json's stop rule (0.90, 3 evaluations) comes before the run's config.json
    (0.95, 5): the crossing of 0.90 between 0.8 at 800 episodes and 1.0 at 1,200 is
    read halfway, 800 + 400 * (0.9 - 0.8) / (1.0 - 0.8) = 1,000."""
    run = _run([0.5, 0.8, 1.0, 1.0, 1.0], "stop rule", "success held")
    run["done_info"]["stop_rule"] = dict(success_threshold=0.9, patience=3)
    got = training_summary(run)
    assert (got["threshold"], got["patience"]) == (0.9, 3)
    assert got["crossed"] == pytest.approx(1000.0)


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
    assert full_state_source(got[P]["full state"]) == "stand-in"


def _bench(rows):
    return dict(
        trials=20,
        rows=[
            dict(knob=k, level=lvl, successes=s, trials=20, nominal=nom)
            for k, lvl, s, nom in rows
        ],
    )


def test_counts_nominal_and_perturbed_readings_of_a_bench():
    b = _bench(
        [
            ("action_delay", 2, 6, False),  # the nominal row need not come first
            ("action_delay", 0, 19, True),
            ("mass", 2.0, 18, False),
            ("mass", 1.0, 19, True),
        ]
    )
    flat = counts({("FetchPush-v4", "full state"): b})
    assert flat[("FetchPush-v4", "full state", "action_delay", 2)] == 6
    assert flat[("FetchPush-v4", "full state", "action_delay", 2.0)] == 6
    assert flat[("FetchPush-v4", "full state", "mass", 1.0)] == 19
    assert nominal_successes(b) == 19
    assert perturbed_rate(b) == pytest.approx((6 / 20 + 18 / 20) / 2)
    with pytest.raises(ValueError):
        nominal_successes(_bench([("mass", 2.0, 18, False)]))
    with pytest.raises(ValueError):
        perturbed_rate(_bench([("mass", 1.0, 18, True)]))


def test_the_scene_takes_the_simplified_policy_else_the_full_one():
    from acder_lite.book.deploy_report import scene_label

    both = {"full state": "results/x", "simplified state": "experiments/deploy/x"}
    assert scene_label(both) == "simplified state"
    assert scene_label(dict(both, **{"simplified state": None})) == "full state"
    assert scene_label({"full state": None, "simplified state": None}) is None


def test_policy_clips_as_the_policy_records_them_else_the_training_defaults():
    from acder_lite.config import Config
    from acder_lite.book.deploy_report import policy_clips

    assert policy_clips(dict(clip_obs=5.0, norm=dict(clip=3.0))) == (5.0, 3.0)
    assert policy_clips(None) == (Config().clip_obs, Config().norm_clip)


def test_rerun_bench_gives_the_benches_outcomes_from_a_fresh_process(tmp_path):
    """The command in its own process, on a policy that holds the gripper still, gives
    the trials `run_bench` gives here; a command that fails raises its output."""
    from acder_lite.algo.core import Actor
    from acder_lite.algo.normalizer import Normalizer
    from acder_lite.book.deploy_report import rerun_bench
    from acder_lite.deploy.robust import policy_act, run_bench
    from acder_lite.io import load_policy, save_torch
    from acder_lite.train.rollout import Policy

    pol = Policy(Actor(13, 4, 6, 2), Normalizer(10), Normalizer(3), 200.0)
    for p in pol.actor.parameters():
        p.data.zero_()  # the zero action: the gripper stays where it starts
    (tmp_path / "run").mkdir()
    file = tmp_path / "run" / "policy.pt"
    save_torch(str(file), {"policy": dict(pol.state_dict("FetchReach-v4", "her"))})
    got = rerun_bench(tmp_path, "run", ["action_delay=0,1"], trials=3, seed=7)
    act, obs = policy_act(*load_policy(str(file)))
    here = run_bench(act, "FetchReach-v4", obs, {"action_delay": [0, 1]}, 3, seed=7)
    assert [r["trial_success"] for r in got["rows"]] == [
        r["trial_success"] for r in here["rows"]
    ]
    assert got["seed"] == 7 and got["trials"] == 3
    with pytest.raises(RuntimeError, match="robust"):
        rerun_bench(tmp_path, "no-such-run", ["mass"], trials=1, seed=0)
