"""The robustness bench: a perfect scripted policy scores N/N, the camera knobs perturb
only what they name, the same seed gives the same table (and the table the command
stored), bad input. The knobs themselves: test_perturb.py; the counts' statistics:
test_trial_stats.py; a bench against a stored one: test_stored_bench.py; chapter
10's reading of its runs: test_deploy_report.py."""

import csv
import json
import os

import numpy as np
import pytest

from acder_lite.envs import fetch as E
from acder_lite.config import ConfigError
from acder_lite.deploy.perturb import KNOBS, nominal, parse_perturb
from acder_lite.deploy.robust import (
    Bench,
    bench_policies,
    load_policy,
    perturbed_policy,
    policy_act,
    run_bench,
    separated_rows,
    side_by_side,
    weakest,
)
from acder_lite.deploy.stored_bench import compare_stored

from test_cli import one_line_error


def reach_controller(o, g):
    """A perfect Reach policy: step the gripper (o[:3]) toward the goal; FetchReach
    moves the mocap 0.05 m per unit action, so half the error a step converges well
    within 50 steps."""
    u = np.zeros((len(o), 4), np.float32)
    u[:, :3] = np.clip(0.5 * (g - o[:, :3]) / 0.05, -1, 1)
    return u


def zero_policy(o, g):
    return np.zeros((len(o), 4), np.float32)


def test_a_perfect_policy_scores_n_of_n_on_reach():
    r = run_bench(
        reach_controller,
        "FetchReach-v4",
        knobs={"goal_noise": [0.0]},
        trials=20,
        seed=7,
    )
    (row,) = r["rows"]
    assert (row["successes"], row["trials"]) == (20, 20) and row["nominal"]
    # and on the simplified state: the controller reads only o[:3]
    r = run_bench(
        reach_controller,
        "FetchReach-v4",
        obs="simplified",
        knobs={"goal_noise": [0.0]},
        trials=5,
        seed=7,
    )
    assert r["rows"][0]["successes"] == 5


def test_side_by_side_puts_benches_in_columns():
    reach = run_bench(
        reach_controller,
        "FetchReach-v4",
        knobs={"action_delay": [0, 1, 2]},
        trials=3,
        seed=7,
    )
    lazy = run_bench(
        zero_policy,
        "FetchReach-v4",
        knobs={"action_delay": [0], "goal_noise": [0.01]},
        trials=2,
        seed=7,
    )
    lines = side_by_side({"controller": reach, "zero": lazy}).splitlines()
    assert lines[0] == "| knob | level | controller | zero |"
    by_row = {
        tuple(c.strip() for c in ln.split("|")[1:3]): ln.split("|")[3:5]
        for ln in lines[2:]
    }
    assert [c.strip() for c in by_row[("`action_delay`", "0 steps (nominal)")]] == [
        f"{reach['rows'][0]['successes']}/3",
        f"{lazy['rows'][0]['successes']}/2",
    ]
    assert [c.strip() for c in by_row[("`goal_noise`", "0.01 m")]] == ["–", "0/2"]
    assert ("`action_delay`", "1 step") in by_row  # singular
    assert len(lines) == 2 + 4  # delay 0, 1, 2, goal noise 0.01
    low = weakest(reach)
    assert low["successes"] == min(r["successes"] for r in reach["rows"])


def _bench(*rows):
    """A hand-made `run_bench` result: rows (knob, level, successes) of 20 trials."""
    return dict(
        rows=[
            dict(
                knob=k,
                level=v,
                unit=KNOBS[k].unit,
                nominal=v == KNOBS[k].nominal,
                successes=s,
                trials=20,
            )
            for k, v, s in rows
        ]
    )


def test_separated_rows_lists_the_rows_whose_columns_are_told_apart():
    P, PP = "FetchPush-v4", "FetchPickAndPlace-v4"
    bench = {
        (P, "full state"): _bench(
            ("obs_noise", 0.0, 0), ("obs_noise", 0.02, 7), ("mass", 1.0, 0)
        ),
        (P, "simplified state"): _bench(
            ("obs_noise", 0.0, 20), ("obs_noise", 0.02, 17), ("mass", 1.0, 20)
        ),
        (PP, "full state"): _bench(("obs_noise", 0.02, 4), ("friction", 2.0, 20)),
        (PP, "simplified state"): _bench(("obs_noise", 0.02, 9)),
    }
    rows = separated_rows(bench)
    # the nominal row once (mass = 1 is the same trials), friction only in one column
    assert [(r["env"], r["knob"], r["level"]) for r in rows] == [
        (P, "obs_noise", 0.0),
        (P, "obs_noise", 0.02),
    ]
    assert rows[1]["counts"] == [("full state", 7, 20), ("simplified state", 17, 20)]


def test_determinism_for_a_seed_and_common_trials():
    knobs = {"goal_noise": [0.0, 0.02], "action_delay": [0, 2], "friction": [0.5]}
    kw = dict(knobs=knobs, trials=6, tolerance=0.02, seed=3)
    a = run_bench(reach_controller, "FetchReach-v4", **kw)
    b = run_bench(reach_controller, "FetchReach-v4", **kw)
    assert a["rows"] == b["rows"]
    assert [r["level"] for r in a["rows"]] == [0.0, 0.02, 0, 2, 0.5]
    # the nominal level of every knob is the same trials: the same outcome
    assert a["rows"][0]["trial_success"] == a["rows"][2]["trial_success"]
    assert a["rows"][1]["successes"] < 6  # 2 cm of goal noise at a 2 cm tolerance shows


def test_run_bench_refuses_a_bad_tolerance():
    with pytest.raises(ConfigError, match="tolerance=0 is not allowed"):
        run_bench(zero_policy, "FetchReach-v4", tolerance=0)


def _logged(bench, setting, act=zero_policy):
    log = []
    ep = bench.rollout(act, setting, log)
    shown_o = np.stack([o for o, _ in log], 1)  # (W, T, .): what the policy was shown
    shown_g = np.stack([g for _, g in log], 1)
    return ep, shown_o, shown_g


def test_obs_noise_changes_only_the_block_entries():
    bench = Bench("FetchPush-v4", trials=3, seed=0)
    names = E.obs_names(bench.envs[0])
    ep, o, g = _logged(bench, nominal())
    assert np.array_equal(o, ep["o"][:, :-1])  # level 0: exactly the observation
    assert np.array_equal(g, ep["g"])
    ep2, o2, g2 = _logged(bench, dict(nominal(), obs_noise=0.01))
    assert np.array_equal(ep2["o"], ep["o"])  # the same world (a zero policy); the view
    d = o2.astype(np.float64) - ep["o"][:, :-1]
    moved = {names[i] for i in np.nonzero(np.abs(d).max(axis=(0, 1)) > 0)[0]}
    fields = ("pos", "rel_pos", "velp")
    assert moved == {f"object_{f}.{c}" for f in fields for c in "xyz"}
    pos, rel, velp = (
        [names.index(f"object_{f}.{c}") for c in "xyz"]
        for f in ("pos", "rel_pos", "velp")
    )
    n = d[..., pos]
    assert np.allclose(d[..., rel], n, atol=1e-6)  # the same error; the gripper exact
    frames = n[:, 1:] - n[:, :-1]
    assert np.allclose(d[:, 1:][..., velp], frames, atol=1e-6)  # a frame difference
    assert 0.005 < n.std() < 0.015
    assert np.array_equal(g2, ep["g"])


def test_goal_noise_changes_only_the_goal_and_success_uses_the_true_goal():
    bench = Bench("FetchPush-v4", obs="simplified", trials=2, seed=0)
    ep, o, g = _logged(bench, dict(nominal(), goal_noise=0.01))
    assert o.shape[-1] == 11  # the simplified policy is shown its 11 entries
    assert np.array_equal(o, ep["o"][:, :-1, :11])
    assert not np.array_equal(g, ep["g"].astype(np.float32))
    assert np.ptp(ep["g"], axis=1).max() == 0  # the recorded (true) goal never moves


def test_simplified_obs_noise_touches_position_and_relative_position():
    bench = Bench("FetchPushMultiStep-v0", obs="simplified", trials=2, seed=0)
    ep, o, _ = _logged(bench, dict(nominal(), obs_noise=0.01))
    d = o.astype(np.float64) - ep["o"][:, :-1, bench.layout.keep]
    changed = np.nonzero(np.abs(d).max(axis=(0, 1)) > 0)[0].tolist()
    # object{0,1}_pos and object{0,1}_rel_pos; the gripper and the fingers stay exact
    assert changed == list(range(3, 15))


# ----- the command


@pytest.fixture(scope="module")
def reach_policy(tmp_path_factory):
    """A policy.pt of an untrained FetchReach actor (what a run writes, without the
    run)."""
    import torch

    from acder_lite.algo.core import Actor
    from acder_lite.io import save_torch
    from acder_lite.algo.normalizer import Normalizer
    from acder_lite.train.rollout import Policy

    torch.manual_seed(0)
    pol = Policy(Actor(13, 4, 16, 2), Normalizer(10), Normalizer(3), 200.0)
    path = tmp_path_factory.mktemp("policy") / "policy.pt"
    d = dict(pol.state_dict("FetchReach-v4", "her"), obs="full")
    save_torch(str(path), {"policy": d})
    return path


def test_cli_table_json_and_csv(cli, reach_policy, tmp_path):
    js, cs = tmp_path / "r.json", tmp_path / "r.csv"
    p = cli(
        "robust",
        str(reach_policy),
        "--trials",
        "2",
        "--perturb",
        "action_delay=0,1",
        "--perturb",
        "goal_noise=0.01",
        "--json",
        str(js),
        "--csv",
        str(cs),
    )
    assert p.returncode == 0, p.stderr
    assert "robust: FetchReach-v4, her (obs full), 2 trials at 0.05 m" in p.stdout
    # what a count counts
    success = "success: at the last step (50) the gripper within 0.05 m of its target"
    assert p.stdout.splitlines()[1].startswith(success)
    assert "action_delay" in p.stdout and "/2  (nominal)" in p.stdout
    d = json.loads(js.read_text())
    assert [(r["knob"], r["level"]) for r in d["rows"]] == [
        ("action_delay", 0),
        ("action_delay", 1),
        ("goal_noise", 0.01),
    ]
    assert d["seed"] == 12345 and d["trials"] == 2 and d["tolerance"] == 0.05
    rows = list(csv.DictReader(cs.open()))
    assert [r["knob"] for r in rows] == ["action_delay", "action_delay", "goal_noise"]
    assert rows[0]["trials"] == "2"


@pytest.mark.parametrize(
    "args,needles",
    [
        (
            ["--perturb", "wind=2"],
            ["perturb 'wind' is not a perturbation", "obs_noise", "mass"],
        ),
        (["--perturb", "goal_noise=-0.01"], ["goal_noise=-0.01", ">= 0"]),
        (["--tolerance", "0"], ["tolerance=0", "> 0"]),
        (["--tolerance", "-0.05"], ["tolerance=-0.05", "> 0"]),
        (
            ["--env", "FetchPush-v4"],
            ["env='FetchPush-v4'", "trained on FetchReach-v4", "--env FetchReach-v4"],
        ),
        (["--obs", "simplified"], ["obs='simplified'", "obs='full'", "--obs full"]),
        (["--trials", "0"], ["trials=0", "[1, 1000]"]),
        (["--trials", "100000"], ["trials=100000", "[1, 1000]", "10 MB"]),
    ],
)
def test_cli_bad_input_is_one_line(cli, reach_policy, args, needles):
    one_line_error(cli("robust", str(reach_policy), *args), *needles)


def test_cli_missing_policy(cli, tmp_path):
    one_line_error(cli("robust", str(tmp_path)), "neither policy.pt nor checkpoint.pt")


def test_perturbed_policy_is_the_policy_under_the_setting(reach_policy):
    """The book's scene helper: nominal is the policy itself, a knob changes what it is
    shown, the same seed draws the same noise, another task is one ConfigError."""
    env = E.make_env("FetchReach-v4", seed=1)
    d = env._get_obs()
    o, g = d["observation"][None], d["desired_goal"][None]
    act, _ = policy_act(*load_policy(str(reach_policy)))
    same = perturbed_policy(str(reach_policy), env, {}, seed=3)
    assert np.array_equal(same(o, g), act(o.astype(np.float32), g.astype(np.float32)))
    noisy = [perturbed_policy(str(reach_policy), env, dict(goal_noise=0.05), 3)]
    noisy.append(perturbed_policy(str(reach_policy), env, dict(goal_noise=0.05), 3))
    a, b = noisy[0](o, g), noisy[1](o, g)
    assert np.array_equal(a, b) and not np.array_equal(a, same(o, g))
    with pytest.raises(ConfigError, match="not the policy's task"):
        perturbed_policy(str(reach_policy), E.make_env("FetchPush-v4"), {}, 3)


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="needs /proc")
@pytest.mark.parametrize("option", ["--json", "--csv"])
def test_cli_unwritable_output_is_refused_before_the_trials(cli, reach_policy, option):
    """/proc exists and os.access says root may write there, but no file can be made:
    refused before any trial (the table is not printed), not after all of them."""
    p = cli("robust", str(reach_policy), "--trials", "1", option, "/proc/x.out")
    one_line_error(p, f"{option[2:]}='/proc/x.out' cannot be written", "allowed:")
    assert p.stdout == ""


def test_cli_output_in_a_new_folder_is_written(cli, reach_policy, tmp_path):
    """The check before the trials leaves nothing behind, and a folder still to be
    made is no obstacle (the atomic write makes it)."""
    out = tmp_path / "new" / "sub" / "r.json"
    p = cli(
        "robust",
        str(reach_policy),
        "--trials",
        "1",
        "--perturb",
        "goal_noise=0",
        "--json",
        str(out),
    )
    assert p.returncode == 0, p.stderr
    # one trial: "1 trial", not "1 trials"
    assert "(obs full), 1 trial at 0.05 m" in p.stdout
    assert json.loads(out.read_text())["trials"] == 1
    assert sorted(x.name for x in tmp_path.rglob("*")) == ["new", "r.json", "sub"]


def test_perturb_help_says_which_knobs_need_a_block(cli):
    text = " ".join(cli("robust", "--help").stdout.split())
    assert (
        "obs_noise (m, default 0,0.005,0.01,0.02, at most 1; needs a block: not on "
        "Reach)" in text
    )
    assert "mass (x, default 0.5,1,2, at most 100; needs a block: not on Reach)" in text
    assert (
        "friction (x, default 0.5,1,2, at most 100; on Reach it scales the table alone)"
        in text
    )
    assert "goal_noise (m, default 0,0.005,0.01,0.02, at most 1)" in text
    assert "action_delay (steps, default 0,1,2)" in text  # bounded by the horizon
    assert "on Reach, which has no block, the table alone" in KNOBS["friction"].doc
    # which knobs apply is unchanged (committed robust.json files depend on it)
    assert list(parse_perturb(None, "FetchReach-v4", 50)) == [
        "goal_noise",
        "action_delay",
        "action_scale",
        "friction",
    ]


# ----- a bench against a stored one


@pytest.fixture(scope="module")
def controller_policy(tmp_path_factory):
    """A policy.pt whose actor is `reach_controller`, saturated by its tanh: its
    ReLU layers carry g - o[:3] (the normalisers are the identity) and the last
    multiplies by 10."""
    import torch

    from acder_lite.algo.core import Actor
    from acder_lite.io import save_torch
    from acder_lite.algo.normalizer import Normalizer
    from acder_lite.train.rollout import Policy

    actor = Actor(13, 4, 6, 2)
    first, second, last = (m for m in actor.net if isinstance(m, torch.nn.Linear))
    with torch.no_grad():
        for p in actor.parameters():
            p.zero_()
        for i in range(3):
            for j, sign in ((i, 1.0), (i + 3, -1.0)):  # relu(d) and relu(-d)
                first.weight[j, i], first.weight[j, 10 + i] = -sign, sign
                second.weight[j, j] = 1.0
                last.weight[i, j] = 10.0 * sign
    pol = Policy(actor, Normalizer(10), Normalizer(3), 200.0)
    path = tmp_path_factory.mktemp("controller") / "policy.pt"
    save_torch(str(path), {"policy": dict(pol.state_dict("FetchReach-v4", "her"))})
    return path


def test_the_bench_equals_the_one_the_command_stored(cli, controller_policy, tmp_path):
    """The command's path (its own process, policy file, --json) and run_bench here
    give the same outcomes, trial for trial; with fewer trials, their first ones."""
    js = tmp_path / "robust.json"
    knobs = {"goal_noise": [0.0, 0.01], "action_scale": [0.1, 1.0]}
    flags = [f"--perturb={k}={','.join(map(str, v))}" for k, v in knobs.items()]
    args = ["--trials", "6", "--tolerance", "0.02", "--json", str(js)]
    p = cli("robust", str(controller_policy), *flags, *args)
    assert p.returncode == 0, p.stderr
    stored = json.loads(js.read_text())
    scale = stored["rows"][2]["trial_success"]
    assert 0 < sum(scale[:3]) < 3  # trials that tell a bench apart, even the first 3
    act, obs = policy_act(*load_policy(str(controller_policy)))
    kw = dict(knobs=knobs, tolerance=0.02, seed=12345)
    same = compare_stored(run_bench(act, "FetchReach-v4", obs, trials=6, **kw), stored)
    assert same["whole"] and len(same["matched"]) == 4, same["sentence"]
    fewer = run_bench(act, "FetchReach-v4", obs, trials=3, **kw)
    c = compare_stored(fewer, stored)
    assert c["equal"] and c["trials"] == 3 and len(c["matched"]) == 3, c["sentence"]
    assert [s[:2] for s in c["skipped"]] == [("goal_noise", 0.01)]
    other = run_bench(act, "FetchReach-v4", obs, trials=6, **dict(kw, seed=1))
    assert not compare_stored(other, dict(stored, seed=1))["equal"]


def test_bench_policies_benches_every_trained_column(controller_policy):
    """Chapter 10's benches: `run_bench` of each policy found, on its own observation
    set and the seed given, with a line of its nominal count; a column without a
    folder is skipped, and a folder holding another task's policy is refused."""
    root, folder = controller_policy.parent.parent, controller_policy.parent.name
    knobs = {"goal_noise": [0.2, 0.0]}  # the target shown 20 cm off, then nominal
    cols = {"full state": folder, "simplified state": None}
    kw = dict(trials=3, seed=5, knobs=knobs)
    bench, lines = bench_policies(root, {"FetchReach-v4": cols}, **kw)
    assert list(bench) == [("FetchReach-v4", "full state")]
    act, obs = policy_act(*load_policy(str(controller_policy)))
    alone = run_bench(act, "FetchReach-v4", obs, **kw)
    assert bench["FetchReach-v4", "full state"]["rows"] == alone["rows"]
    shaken, nominal_row = alone["rows"]
    assert nominal_row["nominal"] and nominal_row["successes"] == 3
    assert shaken["successes"] < 3
    assert lines == [
        "FetchReach-v4 full state: nominal 3/3; how far its run had trained is not "
        "recorded"
    ]  # the nominal row found by its flag: here the second
    with pytest.raises(ConfigError, match="is not the policy's task"):
        bench_policies(root, {"FetchPush-v4": cols}, **kw)


def test_success_needs_every_block_within_the_tolerance():
    """Two blocks (6-D goals) at 5 cm: 3 cm and 4 cm off succeed; one block on its
    target and the other 6 cm off does not; one block (3-D goals): strictly within."""
    from acder_lite.deploy.robust import success

    g = np.zeros((3, 6))
    ag = np.array(
        [
            [0.03, 0, 0, 0, 0.04, 0],
            [0, 0, 0, 0.06, 0, 0],
            [0.06, 0, 0, 0, 0, 0],
        ]
    )
    assert success(ag, g, 0.05).tolist() == [True, False, False]
    one = np.array([[0.0, 0.03, 0.0399], [0.0, 0.03, 0.0401]])  # 4.99 and 5.01 cm
    assert success(one, np.zeros((2, 3)), 0.05).tolist() == [True, False]


def test_a_level_does_not_see_the_level_rolled_out_before_it():
    """Push, where contacts make the solver's warm start matter: the nominal trials
    rolled out after a friction level are the nominal trials rolled out first, bit for
    bit (run_episodes' reset clears the last level's state, warm start included)."""

    def push(o, g):  # toward the block, then through it toward the goal
        u = np.zeros((len(o), 4), np.float32)
        u[:, :3] = np.clip(10 * (o[:, 3:6] - o[:, :3]) + 5 * (g - o[:, 3:6]), -1, 1)
        return u

    bench = Bench("FetchPush-v4", trials=2, seed=1)
    try:
        first = bench.rollout(push, nominal())
        bench.rollout(push, {**nominal(), "friction": 0.3})
        again = bench.rollout(push, nominal())
    finally:
        bench.close()
    assert first.keys() == again.keys()
    for k in first:
        assert np.array_equal(first[k], again[k]), k
