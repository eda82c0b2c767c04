"""The simplified observation (paper, section V-E): names and indices per task, the env
paths that read an observation, the config field, and a short simplified-state training
end to end."""

import json

import numpy as np
import pytest

from acder_lite.envs import fetch as E
from acder_lite.config import Config, ConfigError
from acder_lite.envs.observations import (
    indices,
    on_full,
    policy_obs,
    rotation_indices,
    simplified_indices,
    sincos_angles,
    sincos_names,
)
from conftest import tiny_config


def xyz(name):
    return [f"{name}.{c}" for c in "xyz"]


FINGERS = ["finger_r", "finger_l"]
ONE_BLOCK = xyz("grip_pos") + xyz("object_pos") + xyz("object_rel_pos") + FINGERS
KEPT = {
    "FetchReach-v4": xyz("grip_pos") + FINGERS,
    "FetchPush-v4": ONE_BLOCK,
    "FetchPickAndPlace-v4": ONE_BLOCK,
    "FetchPushMultiStep-v0": xyz("grip_pos")
    + xyz("object0_pos")
    + xyz("object1_pos")
    + xyz("object0_rel_pos")
    + xyz("object1_rel_pos")
    + FINGERS,
}
FULL_SIZE = {
    "FetchReach-v4": 10,
    "FetchPush-v4": 25,
    "FetchPickAndPlace-v4": 25,
    "FetchPushMultiStep-v0": 40,
}
INDICES = {
    "FetchReach-v4": list(range(5)),
    "FetchPush-v4": list(range(11)),
    "FetchPickAndPlace-v4": list(range(11)),
    "FetchPushMultiStep-v0": list(range(17)),
}
"""The table of `acder_lite.envs.observations`' docstring."""


@pytest.mark.parametrize("env_id", list(KEPT))
def test_names_and_indices_per_task(env_id):
    full = E.make_env(env_id, seed=3)
    simple = E.make_env(env_id, seed=3, obs="simplified")
    names = E.obs_names(full)
    assert len(names) == FULL_SIZE[env_id]
    idx = indices(full, "simplified")
    assert idx.tolist() == INDICES[env_id]
    assert [names[i] for i in idx] == KEPT[env_id] == E.obs_names(simple)
    assert E.obs_names(simple, full=True) == names
    assert indices(simple, "full").tolist() == list(range(len(names)))
    dropped = [n for i, n in enumerate(names) if i not in set(idx.tolist())]
    assert all(("vel" in n or "rot" in n) for n in dropped)  # velocities, rotations
    assert not any(("vel" in n or "rot" in n) for n in KEPT[env_id])
    # the same numbers, at reset, after steps, and as the declared space says
    for _ in range(3):
        a, b = full._get_obs(), simple._get_obs()
        assert np.array_equal(b["observation"], a["observation"][idx])
        assert np.array_equal(b["desired_goal"], a["desired_goal"])
        assert np.array_equal(b["achieved_goal"], a["achieved_goal"])
        u = np.array([0.5, -0.3, 0.2, 0.1])
        oa, _ = E.step(full, u)
        ob, _ = E.step(simple, u)
        assert np.array_equal(ob["observation"], oa["observation"][idx])
    assert simple.observation_space["observation"].shape == (len(idx),)
    ra, _ = full.reset()
    rb, _ = simple.reset()
    assert np.array_equal(rb["observation"], ra["observation"][idx])
    grip = simple._get_obs()["observation"][:3]  # the agent position o[:3] (Eq. 6)
    assert np.array_equal(grip, full._get_obs()["observation"][:3])


def test_start_states_restore_the_simplified_observation():
    """A stored state is the whole physics: restored into a simplified env it gives the
    kept entries of what the full env gives from the same state."""
    full = E.make_env("FetchPush-v4", seed=1)
    simple = E.make_env("FetchPush-v4", seed=2, obs="simplified")
    for _ in range(5):
        E.step(full, np.array([0.3, 0.2, -0.1, 0.0]))
    state, goal = E.get_state(full), full.goal.copy()
    a = E.restart_from(full, state, goal)
    b = E.restart_from(simple, state, goal)
    assert np.array_equal(b["observation"], a["observation"][simple.obs_index])
    assert np.array_equal(b["desired_goal"], a["desired_goal"])


def test_unknown_names_and_a_moved_gripper_are_refused():
    with pytest.raises(RuntimeError, match="grip_temp"):
        simplified_indices(xyz("grip_pos") + FINGERS + ["grip_temp"])
    with pytest.raises(RuntimeError, match="grip_pos"):
        simplified_indices(xyz("object_pos") + xyz("grip_pos"))


def test_config_field_default_old_files_and_bad_values():
    assert Config().obs == "full"
    old = {k: v for k, v in Config().to_dict().items() if k != "obs"}  # an old file
    assert Config.from_dict(old).obs == "full"
    with pytest.raises(
        ConfigError, match=r"obs='camera' is not allowed: 'full' or 'simplified'"
    ):
        Config(obs="camera").validate()
    with pytest.raises(ConfigError, match="obs="):
        E.make_env("FetchReach-v4", obs="camera")
    assert policy_obs({"env": "FetchReach-v4"}) == "full"  # an old policy.pt


def test_on_full_shows_a_policy_its_own_entries():
    seen = []

    def act(o, g):
        seen.append(o)
        return np.zeros((len(o), 4))

    on_full(act, np.array([0, 2]))(np.arange(12.0).reshape(2, 6), np.zeros((2, 3)))
    assert seen[0].tolist() == [[0, 2], [6, 8]]


def test_simplified_trainer_on_the_two_block_push():
    """Every ACDER part on the 17-entry state: S-ICM's sizes, the goal factor on o[:3],
    the start states."""
    from acder_lite.train.trainer import Trainer

    tr = Trainer(
        tiny_config(
            env="FetchPushMultiStep-v0",
            method="acder",
            obs="simplified",
            epochs=1,
            cycles=2,
            updates_per_cycle=2,
        )
    )
    assert tr.dims["o"] == 17 and tr.o_norm.size == 17
    tr.train(progress=False)
    assert tr.buffer.arrays()["o"].shape[-1] == 17
    assert tr.policy_state()["obs"] == "simplified"
    assert np.isfinite(tr.rows[-1]["critic_loss"])


TINY = (
    "--workers 1 --cycles 2 --updates-per-cycle 2 --test-episodes 1 "
    "--batch-size 16 --hidden 16 --sicm-hidden 16 --buffer-size 5000 "
    "--stop-patience 0 --threads 1 --quiet"
).split()


def test_simplified_training_end_to_end(cli, tmp_path, capsys):
    """train --obs simplified (acder: curiosity, goal factor, start states); then eval
    and the motion diagnosis read the policy's set from policy.pt; a resume keeps it."""
    run = tmp_path / "run"
    p = cli(
        *"train --env FetchPush-v4 --method acder --obs simplified --epochs 1".split(),
        *TINY,
        *("--out", str(run)),
    )
    assert p.returncode == 0, p.stderr
    config = json.loads((run / "config.json").read_text())["config"]
    assert config["obs"] == "simplified"
    from acder_lite.io import load_torch

    pol = load_torch(str(run / "policy.pt"))["policy"]
    assert pol["obs"] == "simplified" and pol["norm"]["o"] == 11
    from acder_lite.cli.main import main  # eval and the refused resume, in this process

    capsys.readouterr()
    assert (
        main(["eval", "--checkpoint", str(run / "policy.pt"), "--episodes", "1"]) == 0
    )
    assert "success_rate=" in capsys.readouterr().out
    from acder_lite.cli.diagnose import diagnose

    assert diagnose(str(run), episodes=1)["motion"]["episodes"] >= 1
    assert main(["train", "--resume", str(run), "--obs", "full", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "obs='full' differs from the checkpoint's 'simplified'" in err
    assert len(err.strip().splitlines()) == 1


def test_train_bad_obs_is_one_line(cli, tmp_path):
    p = cli(
        "train",
        "--env",
        "FetchReach-v4",
        "--obs",
        "camera",
        "--out",
        str(tmp_path / "r"),
    )
    assert p.returncode == 2 and "Traceback" not in p.stderr
    want = "error: obs='camera' is not allowed: 'full' or 'simplified'"
    assert p.stderr.strip() == want


@pytest.mark.parametrize(
    "env_id, want",
    [
        ("FetchReach-v4", []),
        ("FetchPush-v4", [11, 12, 13]),
        ("FetchPushMultiStep-v0", 6),
    ],
)
def test_rotation_indices_are_the_blocks_euler_angles(env_id, want):
    env = E.make_env(env_id, seed=0)
    names = E.obs_names(env)
    idx = rotation_indices(names)
    assert idx.dtype == np.int64
    if isinstance(want, int):
        assert idx.size == want
    else:
        assert idx.tolist() == want
    assert all(names[i].split(".")[0].endswith("_rot") for i in idx)
    assert sum("_rot." in n for n in names) == idx.size  # none missed
    env.close()
    simplified = E.make_env("FetchPush-v4", seed=0, obs="simplified")
    assert rotation_indices(E.obs_names(simplified)).size == 0
    simplified.close()


def test_sincos_angles_by_hand():
    """The other entries in order, then the sines, then the cosines (float32 kept)."""
    x = np.array([[1.0, np.pi, 2.0, -np.pi / 2]], np.float32)
    y = sincos_angles(x, np.array([1, 3]))
    assert y.dtype == np.float32 and y.shape == (1, 6)
    np.testing.assert_allclose(y, [[1, 2, 0, -1, -1, 0]], atol=1e-6)
    np.testing.assert_array_equal(sincos_angles(x, np.array([], np.int64)), x)


def test_sincos_names_are_in_sincos_angles_order():
    names = ["a", "r1", "b", "r2"]
    got = sincos_names(names, np.array([1, 3]))
    assert got == ["a", "b", "sin r1", "sin r2", "cos r1", "cos r2"]
    x = np.array([10.0, 0.0, 20.0, np.pi / 2])  # a, r1, b, r2
    y = dict(zip(got, sincos_angles(x, np.array([1, 3]))))
    assert (y["a"], y["b"], y["sin r2"], y["cos r1"]) == pytest.approx((10, 20, 1, 1))


def test_sincos_angles_do_not_jump_where_an_euler_angle_wraps():
    """A block turning through pi: 2 pi - 0.02 apart as Euler angles, 0.02 as
    (sin, cos); Eq. 4's error of a model that predicted no change falls from about
    19.6, far above eta = 0.8, to 2e-4."""
    before = np.array([0.5, np.pi - 0.01, 0.0])
    after = np.array([0.5, -np.pi + 0.01, 0.0])
    idx = np.array([1])
    euler = 0.5 * np.sum((after - before) ** 2)
    enc = 0.5 * np.sum((sincos_angles(after, idx) - sincos_angles(before, idx)) ** 2)
    assert euler > 19.5 and enc == pytest.approx(0.5 * 0.02**2, rel=1e-3)


def test_sicm_angles_bad_values_are_refused():
    ok = dict(env="FetchPush-v4", method="acder", sicm_angles="sincos")
    Config(**ok).validate()
    for bad, needle in (
        (dict(sicm_angles="quaternion"), "'euler' or 'sincos'"),
        (dict(sicm_input="normalised"), "sicm_input='raw'"),
        (dict(env="FetchReach-v4"), "no block's Euler angles"),
        (dict(obs="simplified"), "no block's Euler angles"),
    ):
        with pytest.raises(ConfigError, match="sicm_angles") as e:
            Config(**{**ok, **bad}).validate()
        assert needle in str(e.value)
