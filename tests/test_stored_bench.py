"""A live bench against one stored by `robust --json` (acder_lite.deploy.stored_bench),
on hand-made benches: a flipped trial is found, a shorter bench is compared on its
first trials but for its noise rows, other settings are refused, and the book's
table.
The command's own stored bench against run_bench: test_robust.py."""

from acder_lite.deploy.stored_bench import compare_stored


def _hand_bench(trials: int, rows: dict, **settings) -> dict:
    """A bench result as run_bench or `robust --json` gives it, made by hand: rows
    {(knob, level): per-trial outcomes}."""
    base = dict(env="FetchPush-v4", obs="simplified", seed=12345, tolerance=0.05)
    return dict(
        base,
        horizon=50,
        trials=trials,
        **settings,
        rows=[
            dict(knob=k, level=v, successes=sum(t), trials=trials, trial_success=t)
            for (k, v), t in rows.items()
        ],
    )


STORED = {
    ("obs_noise", 0.0): [1, 1, 0, 1],
    ("obs_noise", 0.01): [1, 0, 0, 1],
    ("mass", 2.0): [1, 0, 1, 1],
}


def test_compare_stored_finds_a_differing_trial():
    stored = _hand_bench(4, STORED)
    same = compare_stored(_hand_bench(4, dict(STORED)), stored)
    assert same["equal"] and same["whole"] and len(same["matched"]) == 3
    assert same["sentence"] == (
        "the live bench equals the stored one trial for trial on all 3 rows, all 4 "
        "trials of each"
    )
    # one trial flipped, the count unchanged too: found by trial, not by count
    flipped = {**STORED, ("mass", 2.0): [0, 1, 1, 1]}
    c = compare_stored(_hand_bench(4, flipped), stored)
    assert not c["equal"] and len(c["matched"]) == 2
    assert c["differing"] == [
        dict(knob="mass", level=2.0, live=3, stored=3, trials=[0, 1])
    ]
    assert c["sentence"].startswith(
        "the live bench differs from the stored one on 1 of 3 rows, all 4 trials of "
        "each: `mass` = 2 x (3/4 here, 3/4 stored)"
    )
    # the counts alone (a file without trial_success) at the same N
    counted = _hand_bench(4, {**STORED, ("mass", 2.0): [0, 0, 1, 1]})
    for r in counted["rows"]:
        del r["trial_success"]
    (d,) = compare_stored(counted, stored)["differing"]
    assert (d["live"], d["stored"], d["trials"]) == (2, 3, None)


def test_compare_stored_with_fewer_trials_skips_the_noise_rows():
    stored = _hand_bench(4, STORED)
    # the first 2 trials: obs_noise 0.01 differs, but its draws are not the stored
    # ones at 2 trials; mass 2 differs in trial 2, which is not compared
    live = _hand_bench(
        2,
        {("obs_noise", 0.0): [1, 1], ("obs_noise", 0.01): [0, 0], ("mass", 2): [1, 0]},
    )
    c = compare_stored(live, stored)
    assert c["equal"] and not c["whole"] and c["trials"] == 2
    assert c["matched"] == [("obs_noise", 0.0), ("mass", 2.0)]
    assert [s[:2] for s in c["skipped"]] == [("obs_noise", 0.01)]
    assert c["sentence"] == (
        "the live bench equals the stored one trial for trial on 2 rows, the first 2 "
        "trials of each (2 run here, 4 stored); 1 row cannot be compared at 2 trials, "
        "`obs_noise` = 0.01 m (their noise draws depend on the trial count)"
    )
    live["rows"][0]["trial_success"] = [1, 0]  # a noise-free row is compared
    c = compare_stored(live, stored)
    assert not c["equal"] and c["differing"][0]["trials"] == [1]


def test_compare_stored_refuses_other_settings_and_reports_missing_rows():
    stored = _hand_bench(4, STORED)
    c = compare_stored(_hand_bench(4, STORED, seed=0), stored)
    assert not c["equal"] and not c["matched"]
    assert c["sentence"] == "the benches cannot be compared (seed 0 here, 12345 stored)"
    fewer = {k: v for k, v in STORED.items() if k[0] != "mass"}
    more = {**STORED, ("action_delay", 1): [0, 0, 0, 0]}
    c = compare_stored(_hand_bench(4, fewer), _hand_bench(4, more))
    assert not c["equal"] and c["only_stored"] == [("mass", 2.0), ("action_delay", 1)]
    assert c["sentence"].endswith(
        "; only stored: `mass` = 2 x and `action_delay` = 1 step"
    )
    assert compare_stored(None, stored)["sentence"] == "no bench run here to compare"
    assert not compare_stored(stored, None)["equal"]


def test_check_stored_reads_each_simplified_runs_robust_json(tmp_path):
    """Each task's simplified-state bench against the robust.json of its run folder;
    a task without the folder or the file, or without a live bench, is said to be."""
    import json

    from acder_lite.deploy.stored_bench import check_stored

    R, P, PP = "FetchReach-v4", "FetchPush-v4", "FetchPickAndPlace-v4"
    (tmp_path / "push").mkdir()
    (tmp_path / "push" / "robust.json").write_text(
        json.dumps(_hand_bench(4, {k: list(v) for k, v in STORED.items()}))
    )
    (tmp_path / "reach").mkdir()  # a run folder without robust.json
    policies = {
        R: {"full state": "x", "simplified state": "reach"},
        P: {"full state": None, "simplified state": "push"},
        PP: {"full state": "x", "simplified state": None},
    }
    live = _hand_bench(2, {k: v[:2] for k, v in STORED.items()})
    bench = {(R, "simplified state"): live, (P, "simplified state"): live}
    bench[P, "full state"] = _hand_bench(4, {})  # not the column compared
    checks = check_stored(tmp_path, policies, bench)
    assert list(checks) == [R, P, PP]
    assert checks[R]["sentence"] == "no stored bench to compare"
    assert checks[PP]["sentence"] == "no bench run here to compare"  # no folder
    assert len(checks[P]["matched"]) == 2 and checks[P]["trials"] == 2
    assert checks[P]["skipped"][0][:2] == ("obs_noise", 0.01)


def test_compare_stored_with_every_row_skipped_is_not_equal():
    """A shorter bench whose only row has noise: nothing is compared, so the benches
    are not called equal."""
    stored = _hand_bench(4, {("obs_noise", 0.01): [1, 0, 0, 1]})
    live = _hand_bench(2, {("obs_noise", 0.01): [1, 0]})
    c = compare_stored(live, stored)
    assert c["matched"] == [] and c["differing"] == []
    assert not c["equal"] and not c["whole"]
    assert c["sentence"] == (
        "no row of the live bench can be compared with the stored one; 1 row cannot "
        "be compared at 2 trials, `obs_noise` = 0.01 m (their noise draws depend on "
        "the trial count)"
    )


def test_levels_of_one_knob_read_with_the_unit_of_the_last():
    """Two levels of one knob share its unit, as the last reads it: '1, 2 steps', not
    '1, 2 step'."""
    more = {**STORED, ("action_delay", 1): [0, 0, 0, 0], ("action_delay", 2): [0] * 4}
    c = compare_stored(_hand_bench(4, STORED), _hand_bench(4, more))
    assert c["only_stored"] == [("action_delay", 1.0), ("action_delay", 2.0)]
    assert c["sentence"].endswith("; only stored: `action_delay` = 1, 2 steps")


def test_compare_stored_by_counts_when_the_stored_side_keeps_no_trials():
    """A stored file without `trial_success` (the live bench has it): at the same N
    the rows are compared by their success counts."""
    stored = _hand_bench(4, STORED)
    for r in stored["rows"]:
        del r["trial_success"]
    c = compare_stored(_hand_bench(4, STORED), stored)
    assert c["equal"] and c["whole"] and len(c["matched"]) == 3
    flipped = _hand_bench(4, {**STORED, ("mass", 2.0): [0, 0, 1, 1]})
    (d,) = compare_stored(flipped, stored)["differing"]
    assert (d["live"], d["stored"], d["trials"]) == (2, 3, None)
