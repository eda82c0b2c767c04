"""`diagnose`: S-ICM's error profile and the start pool's geometry, read from a checkpoint."""
import json
import os

import numpy as np
import pytest

from acder_lite import diagnose as D
from acder_lite import envs as E
from acder_lite.trainer import Trainer

from conftest import tiny_config


@pytest.mark.parametrize("env_id,n", [("FetchReach-v4", 10), ("FetchPush-v4", 25)])
def test_obs_names_label_the_right_entries(env_id, n):
    env = E.make_env(env_id, seed=3)
    names = E.obs_names(env)
    assert len(names) == n
    obs = env._get_obs()["observation"]
    grip = env._utils.get_site_xpos(env.model, env.data, "robot0:grip")
    np.testing.assert_allclose(obs[names.index("grip_pos.x"):names.index("grip_pos.z") + 1], grip)
    if env.has_object:
        obj = env._utils.get_site_xpos(env.model, env.data, "object0")
        np.testing.assert_allclose(obs[names.index("object_pos.x"):names.index("object_pos.z") + 1], obj)


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
        dists.append(np.linalg.norm(obs[6:9]))  # object_rel_pos, computed by the env itself
        tr.selector.pool.append(dict(state=E.get_state(env), goal=np.zeros(3), r_int=0.8 if k % 2 else 0.1))
    far = float(np.median(dists))
    p = D.pool_profile(tr, far=far)
    assert p["size"] == 6
    assert p["distance_to"] == "object"
    assert p["share_at_clip"] == pytest.approx(0.5)
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


def test_diagnose_cli(tmp_path, cli):
    run = tmp_path / "acder"
    Trainer(tiny_config(env="FetchPush-v4", method="acder", epochs=1, cycles=2), str(run)).train(progress=False)
    ckpt = run / "checkpoint.pt"
    mtime = os.path.getmtime(ckpt)
    outs = []
    for k in range(2):
        r = cli("diagnose", str(run), "--batches", "2", "--json", str(tmp_path / f"d{k}.json"))
        assert r.returncode == 0, r.stderr
        assert "curiosity:" in r.stdout and "pool:" in r.stdout
        outs.append(json.loads((tmp_path / f"d{k}.json").read_text()))
    assert outs[0] == outs[1]  # same checkpoint, same numbers
    assert os.path.getmtime(ckpt) == mtime  # the run folder is only read


def test_diagnose_errors(tmp_path, cli):
    her = tmp_path / "her"
    Trainer(tiny_config(method="her", epochs=1, cycles=1), str(her)).train(progress=False)
    for args, needle in [((str(her),), "neither S-ICM nor a start-state pool"),
                         ((str(tmp_path / "nothing"),), "does not exist"),
                         ((str(her), "--batches", "0"), "batches=0")]:
        r = cli("diagnose", *args)
        assert r.returncode == 2, (args, r.stderr)
        assert "Traceback" not in r.stderr and needle in r.stderr
        assert len(r.stderr.strip().splitlines()) == 1


def test_object_motion_of_a_still_policy_is_zero():
    still = lambda o, g: np.zeros((o.shape[0], 4), np.float32)
    m = D.object_motion(still, "FetchPush-v4", episodes=4, workers=2)
    assert m["episodes"] == 4
    assert m["speed_mean"] < 1e-3 and m["spin_mean"] < 1e-2  # the object only settles on the table
    assert m["moved_share"] == 0.0 and np.isnan(m["path_over_distance"])


def test_object_motion_of_a_pushing_policy():
    """A policy that drives the gripper into the object moves it."""
    def push(o, g):  # drive the gripper at the object's centre: it pushes the object away
        rel = o[:, 6:9]  # object_rel_pos
        return np.concatenate([np.clip(10 * rel, -1, 1), np.zeros((o.shape[0], 1), np.float32)], 1)
    m = D.object_motion(push, "FetchPush-v4", episodes=4, workers=2)
    assert m["speed_mean"] > 0.005 and m["moved_share"] > 0
    assert m["path_over_distance"] >= 1.0  # a path is never shorter than its displacement


def test_diagnose_motion_needs_only_the_policy(tmp_path, cli):
    run = tmp_path / "her"
    Trainer(tiny_config(env="FetchPush-v4", method="her", epochs=1, cycles=1), str(run)).train(progress=False)
    os.remove(run / "checkpoint.pt")
    r = cli("diagnose", str(run), "--episodes", "2", "--json", str(tmp_path / "m.json"))
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "m.json").read_text())["motion"]
    assert m["episodes"] == 4 and 0.0 <= m["success"] <= 1.0  # rounded up to the 4 test envs
    reach = tmp_path / "reach"
    Trainer(tiny_config(method="her", epochs=1, cycles=1), str(reach)).train(progress=False)
    r = cli("diagnose", str(reach), "--episodes", "2")
    assert r.returncode == 2 and "has no object" in r.stderr and "Traceback" not in r.stderr


def test_diagnose_refuses_a_checkpoint_of_another_state_layout(tmp_path, cli):
    import torch
    run = tmp_path / "acder"
    Trainer(tiny_config(env="FetchPush-v4", method="acder", epochs=1, cycles=1), str(run)).train(progress=False)
    ck = torch.load(run / "checkpoint.pt", weights_only=False)
    ck["buffer"]["state"] = np.zeros(ck["buffer"]["state"].shape[:2] + (292,))
    torch.save(ck, run / "checkpoint.pt")
    r = cli("diagnose", str(run))
    assert r.returncode == 2 and "(51, 292)" in r.stderr and "Traceback" not in r.stderr
