"""`diagnose`: S-ICM's error profile and the start pool's geometry,
read from a checkpoint."""

import json
import os

import numpy as np
import pytest

import torch

from acder_lite.cli import diagnose as D
from acder_lite.envs import fetch as E
from acder_lite.train.trainer import Trainer

from conftest import rewards_of, tiny_config
from test_cli import one_line_error


@pytest.mark.parametrize("env_id,n", [("FetchReach-v4", 10), ("FetchPush-v4", 25)])
def test_obs_names_label_the_right_entries(env_id, n):
    env = E.make_env(env_id, seed=3)
    names = E.obs_names(env)
    assert len(names) == n
    obs = env._get_obs()["observation"]
    grip = env._utils.get_site_xpos(env.model, env.data, "robot0:grip")
    np.testing.assert_allclose(
        obs[names.index("grip_pos.x") : names.index("grip_pos.z") + 1], grip
    )
    if env.has_object:
        obj = env._utils.get_site_xpos(env.model, env.data, "object0")
        np.testing.assert_allclose(
            obs[names.index("object_pos.x") : names.index("object_pos.z") + 1], obj
        )


def _push_trainer(**kw):
    return Trainer(tiny_config(env="FetchPush-v4", method="acder", **kw))


def test_pool_profile_measures_the_stored_states():
    tr = _push_trainer()
    env = tr.envs[0]
    rng = np.random.default_rng(0)
    dists = []
    for k in range(6):  # move the gripper around; store each state as a candidate
        for _ in range(4):
            E.step(env, rng.uniform(-1, 1, 4))
        obs = env._get_obs()["observation"]
        dists.append(
            np.linalg.norm(obs[6:9])
        )  # object_rel_pos, computed by the env itself
        tr.selector.pool.append(
            dict(state=E.get_state(env), goal=np.zeros(3), r_int=0.8 if k % 2 else 0.1)
        )
    far = float(np.median(dists))
    p = D.pool_profile(tr, far=far)
    assert p["size"] == 6
    assert p["distance_to"] == "object"
    assert p["share_at_clip"] == pytest.approx(0.5)
    tr.cfg.eta = 0.7  # float32 rounds it down: S-ICM stores float(float32(0.7)) < 0.7
    for c in tr.selector.pool:
        c["r_int"] = float(np.float32(min(c["r_int"], 0.7)))
    assert D.pool_profile(tr, far=far)["share_at_clip"] == pytest.approx(0.5)
    assert p["distance_median"] == pytest.approx(np.median(dists), abs=1e-9)
    assert p["distance_max"] == pytest.approx(max(dists), abs=1e-9)
    assert p["share_far"] == pytest.approx(np.mean(np.array(dists) > far))


def test_curiosity_profile_does_not_train(tmp_path):
    tr = _push_trainer(cycles=2, epochs=1)
    tr.train(progress=False)
    before = [p.detach().clone() for p in tr.curiosity.parameters()]
    c = D.curiosity_profile(tr, batches=3)
    assert c["rows"] == 3 * tr.cfg.batch_size * tr.cfg.workers
    assert 0.0 <= c["share_at_clip"] <= 1.0
    assert c["top_entries"][0][1] >= c["top_entries"][-1][1]
    assert all(name in D.state_names(tr) for name, _ in c["top_entries"])
    for a, b in zip(before, tr.curiosity.parameters()):
        assert bool((a == b).all())


def test_state_names_follow_sicm_angles():
    """With sicm_angles="sincos" the names are those of what S-ICM sees: the block's
    three angles as sines and cosines after the other 22 entries, then the goal."""
    tr = _push_trainer(cycles=2, epochs=1, sicm_angles="sincos")
    tr.train(progress=False)
    names = D.state_names(tr)
    assert len(names) == tr.curiosity.net[0].in_features - tr.dims["u"] == 31
    assert names[22:28] == [
        f"{f} object_rot.{c}" for f in ("sin", "cos") for c in "xyz"
    ] and names[28:] == ["goal.x", "goal.y", "goal.z"]
    c = D.curiosity_profile(tr, batches=2)
    assert all(name in names for name, _ in c["top_entries"])


def test_curiosity_profile_finds_the_euler_wraps():
    """Every stored step made to turn the block's yaw through +-pi: every row is a wrap,
    and so is every candidate of successful episodes; with the angles still, none is."""
    tr = _push_trainer(cycles=2, epochs=1)
    tr.train(progress=False)
    (rot,) = D.object_fields(tr.envs[0], "rot")
    z, buf = rot.start + 2, tr.buffer
    buf.o[: buf.n, 0::2, z], buf.o[: buf.n, 1::2, z] = 3.0, -3.0
    buf.success[: buf.n] = True
    w = D.curiosity_profile(tr, batches=3)["wraps"]
    assert w["share_of_rows"] == 1.0 and w["candidates"] == 3
    assert w["share_of_candidates"] == 1.0
    assert w["share_at_clip"] == 1.0  # an error of about 2 pi^2 at raw inputs
    buf.o[: buf.n, :, rot] = 0.0
    c = D.curiosity_profile(tr, batches=3)
    w, k = c["wraps"], c["gimbal"]
    assert w["share_of_rows"] == 0.0 and w["share_of_candidates"] == 0.0
    assert k["share_of_rows"] == 0.0 and c["sicm_angles"] == "euler"
    buf.o[: buf.n, 1::2, rot.start + 1] = np.pi / 2  # on a side face every other step
    k = D.curiosity_profile(tr, batches=3)["gimbal"]
    assert k["share_of_rows"] == 1.0 and k["share_of_candidates"] == 1.0
    buf.o[: buf.n, :, rot] = 0.0
    text = D.to_text(
        dict(
            run="r",
            method="acder",
            env="FetchPush-v4",
            curiosity=D.curiosity_profile(tr, 2),
        )
    )
    assert "Euler-angle wraps: 0.0000 of all rows" in text
    assert "near gimbal lock (|cos pitch| < 0.2): 0.0000 of all rows" in text
    buf.success[: buf.n] = False  # no candidate, and no "nan" in the text
    c = D.curiosity_profile(tr, 2)
    assert c["wraps"]["candidates"] == 0
    text = D.to_text(dict(run="r", method="acder", env="FetchPush-v4", curiosity=c))
    assert "no start-state candidate in the drawn minibatches" in text
    assert "nan" not in text.split("wraps:")[1]


def test_diagnose_cli(tmp_path, cli):
    run = tmp_path / "acder"
    Trainer(
        tiny_config(env="FetchPush-v4", method="acder", epochs=1, cycles=2), str(run)
    ).train(progress=False)
    ckpt = run / "checkpoint.pt"
    mtime = os.path.getmtime(ckpt)
    outs = []
    for k in range(2):
        r = cli(
            "diagnose",
            str(run),
            "--batches",
            "2",
            "--json",
            str(tmp_path / f"d{k}.json"),
        )
        assert r.returncode == 0, r.stderr
        assert "curiosity:" in r.stdout and "pool:" in r.stdout
        outs.append(json.loads((tmp_path / f"d{k}.json").read_text()))
    assert outs[0] == outs[1]  # same checkpoint, same numbers
    assert os.path.getmtime(ckpt) == mtime  # the run folder is only read


def test_diagnose_reads_a_packed_run_as_its_checkpoint(tmp_path):
    """A run carried over in git has checkpoint.packed/ and no checkpoint.pt: diagnose
    rebuilds the buffer and gives the numbers of the checkpoint it was packed from."""
    from acder_lite.runs import packed
    from acder_lite.io import load_torch

    run = tmp_path / "acder"
    Trainer(
        tiny_config(env="FetchPush-v4", method="acder", epochs=1, cycles=2), str(run)
    ).train(progress=False)
    before = D.diagnose(str(run), batches=2)
    packed.pack(load_torch(str(run / "checkpoint.pt")), run / packed.FOLDER)
    (run / "checkpoint.pt").unlink()
    after = D.diagnose(str(run), batches=2)
    same = json.dumps(after, sort_keys=True) == json.dumps(before, sort_keys=True)
    assert same  # as text: a share of no rows is nan, and nan != nan


def test_diagnose_errors(tmp_path, cli):
    her = tmp_path / "her"
    Trainer(tiny_config(method="her", epochs=1, cycles=1), str(her)).train(
        progress=False
    )
    for args, needle in [
        ((str(her),), "neither S-ICM nor a start-state pool"),
        ((str(tmp_path / "nothing"),), "run folder"),
        ((str(tmp_path / "nothing"), "--episodes", "1"), "does not exist; allowed"),
        ((str(her), "--batches", "0"), "batches=0"),
        ((str(her / "policy.pt"),), "is a file; allowed: a folder written by train"),
        # an output that cannot be written is refused before the work (which would
        # otherwise end in the S-ICM error above)
        ((str(her), "--json", "/proc/x.json"), "json='/proc/x.json' cannot be written"),
    ]:
        r = cli("diagnose", *args)
        assert r.returncode == 2, (args, r.stderr)
        assert "Traceback" not in r.stderr and needle in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1


def test_object_motion_of_a_still_policy_is_zero():
    still = lambda o, g: np.zeros((o.shape[0], 4), np.float32)
    m = D.object_motion(still, "FetchPush-v4", episodes=4, workers=2)
    assert m["episodes"] == 4
    assert (
        m["speed_mean"] < 1e-3 and m["spin_mean"] < 1e-2
    )  # the object only settles on the table
    assert m["moved_share"] == 0.0 and np.isnan(m["path_over_distance"])
    assert m["wrap_step_share"] == 0.0 and m["wrap_episode_share"] == 0.0
    # the text says what was measured, and no "nan"
    text = D.to_text(dict(run="r", method="her", env="FetchPush-v4", motion=m))
    assert "moved in 0.00 of the episodes" in text and "nan" not in text
    assert "wraps at 0.0000 of the steps" in text


def test_text_of_a_minibatch_without_successful_rows():
    c = dict(
        rows=2048,
        eta=0.8,
        error_quantiles={"0.5": 0.1, "0.9": 0.5, "0.99": 0.8},
        share_at_clip=0.01,
        successful_rows=0,
        share_at_clip_successful=float("nan"),
        share_of_error_in_top=0.5,
        top_entries=[("grip_pos_x", 0.2)],
    )
    text = D.to_text(dict(run="r", method="acder", env="FetchPush-v4", curiosity=c))
    assert "no row of a successful episode drawn" in text and "nan" not in text
    # and its --json file is strict JSON: null where the share has no rows
    from acder_lite.io import json_ready

    strict = json.loads(json.dumps(json_ready(dict(curiosity=c)), allow_nan=False))
    assert strict["curiosity"]["share_at_clip_successful"] is None
    c.update(successful_rows=512, share_at_clip_successful=0.25)
    text = D.to_text(dict(run="r", method="acder", env="FetchPush-v4", curiosity=c))
    assert "0.25 of the 512 rows of successful episodes" in text
    assert "curiosity: 2,048 rows;" in text
    c.update(rows=1, successful_rows=1, share_at_clip_successful=1.0)
    text = D.to_text(dict(run="r", method="acder", env="FetchPush-v4", curiosity=c))
    assert "curiosity: 1 row;" in text and "of the 1 row of successful" in text


def test_text_counts_are_singular_at_one():
    p = dict(
        size=1,
        share_at_clip=1.0,
        distance_to="object",
        distance_median=0.1,
        distance_max=0.1,
        share_far=0.0,
        far=0.2,
        gripper_z_min=0.4,
        gripper_z_median=0.4,
    )
    text = D.to_text(
        dict(run="r", method="acder", env="FetchPush-v4", episodes=1, test_success=0.0)
        | dict(pool=p)
    )
    assert ", 1 episode, test success" in text and "pool: 1 candidate, " in text
    w = dict(
        share_of_rows=0.0, share_at_clip=0.0, candidates=1, share_of_candidates=0.0
    )
    c = dict(
        rows=2,
        eta=0.8,
        error_quantiles={"0.5": 0.1, "0.9": 0.5, "0.99": 0.8},
        share_at_clip=0.0,
        successful_rows=2,
        share_at_clip_successful=0.0,
        share_of_error_in_top=0.5,
        top_entries=[("grip_pos_x", 0.2)],
        wraps=w,
    )
    text = D.to_text(dict(run="r", method="acder", env="FetchPush-v4", curiosity=c))
    assert "of the 1 start-state candidate the minibatches give" in text


def test_object_motion_of_a_pushing_policy():
    """A policy that drives the gripper into the object moves it."""

    def push(
        o, g
    ):  # drive the gripper at the object's centre: it pushes the object away
        rel = o[:, 6:9]  # object_rel_pos
        return np.concatenate(
            [np.clip(10 * rel, -1, 1), np.zeros((o.shape[0], 1), np.float32)], 1
        )

    m = D.object_motion(push, "FetchPush-v4", episodes=4, workers=2)
    assert m["speed_mean"] > 0.005 and m["moved_share"] > 0
    assert (
        m["path_over_distance"] >= 1.0
    )  # a path is never shorter than its displacement


def test_diagnose_motion_needs_only_the_policy(tmp_path, cli):
    run = tmp_path / "her"
    Trainer(
        tiny_config(env="FetchPush-v4", method="her", epochs=1, cycles=1), str(run)
    ).train(progress=False)
    os.remove(run / "checkpoint.pt")
    r = cli("diagnose", str(run), "--episodes", "2", "--json", str(tmp_path / "m.json"))
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "m.json").read_text())["motion"]
    assert (
        m["episodes"] == 4 and 0.0 <= m["success"] <= 1.0
    )  # rounded up to the 4 test envs
    # a finished run keeps policy.pt alone: the minibatch diagnosis says what to do,
    # not that checkpoint.pt "does not exist" beside a policy.pt
    one_line_error(
        cli("diagnose", str(run)),
        "has policy.pt but no checkpoint.pt: a finished run keeps only its policy "
        "(no replay buffer)",
        "checkpoint.packed/",
        "--episodes N to diagnose the policy on N fresh episodes",
    )
    # --episodes 0 (or less) is refused, not read as "no --episodes"
    for n in ("0", "-3"):
        one_line_error(
            cli("diagnose", str(run), "--episodes", n),
            f"episodes={n} is not allowed: an integer >= 1",
            "omit --episodes for the minibatch diagnosis",
        )
    reach = tmp_path / "reach"
    Trainer(tiny_config(method="her", epochs=1, cycles=1), str(reach)).train(
        progress=False
    )
    r = cli("diagnose", str(reach), "--episodes", "2")
    assert (
        r.returncode == 2
        and "has no object" in r.stderr
        and "Traceback" not in r.stderr
    )


def test_diagnose_refuses_a_checkpoint_of_another_state_layout(tmp_path, cli):
    import torch

    run = tmp_path / "acder"
    Trainer(
        tiny_config(env="FetchPush-v4", method="acder", epochs=1, cycles=1), str(run)
    ).train(progress=False)
    from acder_lite.io import load_torch

    ck = load_torch(str(run / "checkpoint.pt"))
    ck["buffer"]["state"] = np.zeros(ck["buffer"]["state"].shape[:2] + (292,))
    torch.save(ck, run / "checkpoint.pt")
    r = cli("diagnose", str(run))
    assert r.returncode == 2 and "(51, 292)" in r.stderr and "Traceback" not in r.stderr


# ----- the multi-step push (FetchPushMultiStep-v0): two blocks, 6-D goals

MULTI = "FetchPushMultiStep-v0"


def _place(env, block: int, xy) -> None:
    """Put block `block` at table xy (its resting height kept) and recompute
    the kinematics."""
    import mujoco

    joint = f"object{block}:joint"
    q = env._utils.get_joint_qpos(env.model, env.data, joint).copy()
    q[:2] = xy
    env._utils.set_joint_qpos(env.model, env.data, joint, q)
    mujoco.mj_forward(env.model, env.data)


def test_object_fields_name_each_block_of_the_multistep_push():
    env = E.make_env(MULTI, seed=2)
    obs = env._get_obs()["observation"]
    for k, s in enumerate(D.object_fields(env, "pos")):
        np.testing.assert_allclose(
            obs[s], env._utils.get_site_xpos(env.model, env.data, f"object{k}")
        )
    assert [(s.start, s.stop) for s in D.object_fields(env, "velr")] == [
        (29, 32),
        (32, 35),
    ]
    assert [
        (s.start, s.stop)
        for s in D.object_fields(E.make_env("FetchPush-v4", seed=0), "velr")
    ] == [(17, 20)]


def test_diagnose_names_all_46_entries_of_a_multistep_checkpoint(tmp_path):
    run = tmp_path / "acder"
    Trainer(tiny_config(env=MULTI, method="acder", epochs=1, cycles=1), str(run)).train(
        progress=False
    )
    d = D.diagnose(str(run), batches=1, top=46)
    assert d["env"] == MULTI
    names = [n for n, _ in d["curiosity"]["top_entries"]]
    env = E.make_env(MULTI, seed=0)
    expected = E.obs_names(env) + E.goal_names(env)
    assert len(names) == len(set(names)) == 46 and sorted(names) == sorted(expected)
    assert {"object0_velr.z", "object1_velr.z", "goal0.x", "goal1.z"} <= set(names)
    assert "pool" in d and "curiosity:" in D.to_text(d)


def test_pool_profile_reports_each_block_of_the_multistep_push():
    tr = Trainer(tiny_config(env=MULTI, method="acder"))
    env = tr.envs[0]
    goal = env.goal.copy()
    expected = []
    for k, on_target in enumerate([(True, False), (True, True), (False, False)]):
        env.reset(seed=k)
        for b, on in enumerate(on_target):  # a block on its target, or 10 cm beside it
            _place(
                env, b, goal[3 * b : 3 * b + 2] + (0 if on else np.array([0.1, 0.0]))
            )
        grip = env._utils.get_site_xpos(env.model, env.data, "robot0:grip")
        blocks = [
            env._utils.get_site_xpos(env.model, env.data, f"object{b}")
            for b in range(2)
        ]
        expected.append([np.linalg.norm(grip - p) for p in blocks])
        tr.selector.pool.append(
            dict(state=E.get_state(env), goal=goal, r_int=0.9 if k else 0.1)
        )
    p = D.pool_profile(tr, far=0.2)
    assert (
        p["size"] == 3 and p["distance_to"] == "nearest block" and len(p["blocks"]) == 2
    )
    expected = np.array(expected)
    assert p["distance_median"] == pytest.approx(np.median(expected.min(1)), abs=1e-9)
    for b in range(2):
        assert p["blocks"][b]["distance_median"] == pytest.approx(
            np.median(expected[:, b]), abs=1e-9
        )
        assert p["blocks"][b]["distance_max"] == pytest.approx(
            expected[:, b].max(), abs=1e-9
        )
    assert p["blocks"][0]["share_on_target"] == pytest.approx(2 / 3)
    assert p["blocks"][1]["share_on_target"] == pytest.approx(1 / 3)
    assert p["blocks"][1]["to_target_median"] == pytest.approx(0.1, abs=2e-3)
    text = D.to_text(dict(run="r", method="acder", env=MULTI, pool=p))
    assert "block 0:" in text and "block 1:" in text


def test_object_motion_is_per_block_on_the_multistep_push():
    """A policy that pushes block 1 only: block 1 moves, block 0 stays where it is."""

    def push1(o, g):
        rel = o[:, 12:15]  # object1_rel_pos
        return np.concatenate(
            [np.clip(10 * rel, -1, 1), np.zeros((o.shape[0], 1), np.float32)], 1
        )

    m = D.object_motion(push1, MULTI, episodes=2, workers=2)
    assert m["episodes"] == 2 and len(m["blocks"]) == 2 and "speed_mean" not in m
    b0, b1 = m["blocks"]
    assert {"wrap_step_share", "wrap_episode_share"} <= set(b0) & set(b1)
    assert (
        b1["speed_mean"] > 0.005
        and b1["moved_share"] > 0
        and b1["path_over_distance"] >= 1.0
    )
    assert b0["speed_mean"] < b1["speed_mean"] / 10
    text = D.to_text(dict(run="r", method="her", env=MULTI, motion=m))
    assert text.count("block ") == 2


def test_object_motion_error_lists_every_object_task():
    from acder_lite.config import ConfigError, OBJECT_ENVS

    with pytest.raises(ConfigError) as e:
        D.object_motion(
            lambda o, g: np.zeros((len(o), 4)), "FetchReach-v4", episodes=1, workers=1
        )
    assert all(env in str(e.value) for env in OBJECT_ENVS)


def test_minibatch_errors_match_the_trainers_intrinsic_reward():
    import copy

    tr = _push_trainer(sicm_input="raw")
    tr.train_cycle()
    before = [p.detach().clone() for p in tr.curiosity.parameters()]
    rng_state = copy.deepcopy(tr.rng.bit_generator.state)
    out = D.minibatch_errors(tr, batches=3)
    assert all(
        torch.equal(a, b) for a, b in zip(before, tr.curiosity.parameters())
    )  # no training
    n = 3 * tr.cfg.batch_size * tr.cfg.workers
    assert (
        out["err"].shape == out["successful"].shape == (n,) and out["eta"] == tr.cfg.eta
    )
    assert out["successful"].dtype == bool and (out["err"] >= 0).all()
    # the first minibatch again, through the trainer's own reward step, with eta out of
    # the way (the tiny model's errors all exceed 0.8): its r_i (Eq. 4) is err row for
    # row, and the success column is the buffer's
    tr.rng.bit_generator.state = rng_state
    b = tr.sample_batch()
    B = len(b["ep"])
    np.testing.assert_array_equal(out["successful"][:B], tr.buffer.success[b["ep"]])
    seen = {}
    tr.cfg.eta = 1e9
    tr.selector.offer = lambda batch, r_int, *rest: seen.setdefault("r", r_int.copy())
    rewards_of(tr, b)
    np.testing.assert_allclose(out["err"][:B], seen["r"], rtol=1e-5)
    assert np.ptp(seen["r"]) > 0  # distinct rows, compared one by one


def test_errors_need_sicm():
    from acder_lite.config import ConfigError

    tr = Trainer(tiny_config(method="her"))
    with pytest.raises(ConfigError, match="no S-ICM"):
        D.minibatch_errors(tr)


def test_goal_factor_against_object_by_hand():
    # gripper at the origin, block 10 cm along +x; four relabelled goals
    grip = np.zeros((4, 3))
    obj = np.tile([0.1, 0.0, 0.0], (4, 1))
    goal = np.array(
        [
            [0.1, 0.0, 0.0],  # the block itself: it has not moved
            [0.105, 0.0, 0.0],  # 5 mm on: less than 1 cm, not moved
            [0.0, 0.2, 0.0],  # off to the side (+y): 90 degrees
            [-0.1, 0.0, 0.0],  # behind the gripper: 180 degrees
        ]
    )
    u = np.array([[1, 0, 0, 0.3], [0, 0, 1, 0], [0, 1, 0, 0], [1, 0, 0, 0]], float)
    f = D.goal_factor_against_object(grip, obj, goal, u)
    np.testing.assert_array_equal(f["moved"], [False, False, True, True])
    np.testing.assert_allclose(f["angle"], [0, 0, 90, 180], atol=1e-6)
    # Eq. 6: 1 + angle / 360 degrees; u[1] is up, perpendicular to both directions
    np.testing.assert_allclose(f["lam_goal"], [1, 1.25, 1, 1.5])
    np.testing.assert_allclose(f["lam_obj"], [1, 1.25, 1.25, 1])
    wider = D.goal_factor_against_object(grip, obj, goal, u, moved=0.3)
    assert not wider["moved"].any()  # 0.3 m: no goal lies that far from the block


def test_pool_positions_read_each_stored_state_and_count_the_distinct_ones():
    tr = _push_trainer()
    env = tr.envs[0]
    rng = np.random.default_rng(1)
    grips = []
    for k in range(4):
        for _ in range(3):
            E.step(env, rng.uniform(-1, 1, 4))
        grips.append(env._get_obs()["observation"][:3].copy())
        tr.selector.pool.append(
            dict(state=E.get_state(env), goal=np.full(3, k), r_int=0.1 * k)
        )
    tr.selector.pool.append(dict(tr.selector.pool[1]))  # offered again
    other = E.make_env("FetchPush-v4", seed=5)
    before = E.get_state(other)
    P = D.pool_positions(tr, other)
    np.testing.assert_array_equal(E.get_state(other), before)  # put back
    assert P["states"].shape == (5, E.state_size(env)) and P["distinct"] == 4
    np.testing.assert_allclose(P["gripper"], np.array(grips)[[0, 1, 2, 3, 1]])
    np.testing.assert_allclose(P["goals"][:, 0], [0, 1, 2, 3, 1])
    np.testing.assert_allclose(P["r_int"], [0, 0.1, 0.2, 0.3, 0.1])
    tr.selector.pool.clear()
    P = D.pool_positions(tr)
    assert P["states"].shape[0] == 0 and P["gripper"].shape == (0, 3)
    assert P["distinct"] == 0 and D.pool_profile(tr) == dict(
        size=0, far=0.2, eta=tr.cfg.eta
    )
    from acder_lite.config import ConfigError

    with pytest.raises(ConfigError, match="no start-state pool"):
        D.pool_positions(Trainer(tiny_config(env="FetchPush-v4", method="her")))


def test_curiosity_profile_shares_at_the_clip_among_successful_rows_only():
    """`share_at_clip_successful` counts the rows of successful episodes only: with
    every such row past the clip and every other row below it, it is 1.0, while the
    share of all rows is that of the successful rows."""
    tr = Trainer(tiny_config(env="FetchReach-v4", method="acder"))
    tr.train_cycle()
    buf = tr.buffer
    buf.success[: buf.n] = np.arange(buf.n) % 2 == 0  # every other episode succeeded
    b = tr.sample_batch()
    ok = buf.success[b["ep"]].astype(bool)
    assert 0 < ok.sum() < len(ok)  # both kinds of rows in the minibatch
    eta = tr.cfg.eta
    err = torch.tensor(np.where(ok, 2 * eta, 0.0), dtype=torch.float32)
    tr.sample_batch = lambda: b  # the same minibatch each time
    tr.curiosity.errors = lambda x, u, x2: (err, x2)  # S-ICM's error, made by hand
    c = D.curiosity_profile(tr, batches=2)
    assert c["rows"] == 2 * len(ok) and c["successful_rows"] == 2 * ok.sum()
    assert c["share_at_clip_successful"] == 1.0
    assert c["share_at_clip"] == pytest.approx(ok.mean())


def test_motion_stats_share_of_episodes_with_a_wrap_by_hand():
    """4 still episodes of 5 steps whose yaw jumps 3 -> -3 rad (a wrap): once in
    episode 0, twice in episode 1, never in 2 and 3. Wraps at 3 of the 20 steps
    (0.15), in 2 of the 4 episodes (0.5)."""
    ag, velr = np.zeros((4, 6, 3)), np.zeros((4, 5, 3))
    rot = np.zeros((4, 6, 3))
    rot[0, :, 2] = [3, 3, 3, -3, -3, -3]
    rot[1, :, 2] = [3, -3, 3, 3, 3, 3]
    m = D.motion_stats(ag, velr, 0.04, rot)
    assert m["wrap_step_share"] == pytest.approx(0.15)
    assert m["wrap_episode_share"] == 0.5
