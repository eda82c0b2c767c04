import mujoco
import numpy as np
import pytest

from acder_lite.envs import fetch as E
from acder_lite.config import ConfigError


@pytest.mark.parametrize("env_id", ["FetchPush-v4", "FetchPickAndPlace-v4"])
def test_restored_state_reproduces_next_20_steps_exactly(env_id):
    rng = np.random.default_rng(0)
    a = E.make_env(env_id, seed=3)
    for _ in range(7):
        E.step(a, rng.uniform(-1, 1, 4))
    saved = E.get_state(a)
    actions = rng.uniform(-1, 1, (20, 4))
    ref = [E.step(a, u)[0] for u in actions]

    b = E.make_env(env_id, seed=99)  # a fresh env with another episode under way
    b.goal = a.goal.copy()
    E.set_state(b, saved)
    for u, want in zip(actions, ref):
        got = E.step(b, u)[0]
        for k in ("observation", "achieved_goal"):
            np.testing.assert_array_equal(got[k], want[k])


def test_replay_difference_tells_the_state_specs_and_steps_apart():
    """The appendix's measurement: our state and step replay bit for bit; FULLPHYSICS
    alone (no warm start) or gymnasium's own step (a substep behind) do not."""
    d, n = E.replay_difference(steps=30)
    assert d.shape == (30,) and n == E.state_size(E.make_env("FetchPickAndPlace-v4"))
    assert not d.any()
    full = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
    d_full, n_full = E.replay_difference(steps=30, spec=full)
    assert n_full < n and d_full.max() > 0
    assert E.replay_difference(steps=30, gymnasium_step=True)[0].max() > 0


def test_the_replayed_actions_grasp_and_lift_the_block():
    """The appendix replays a rollout with contacts: `scripted_grasp`'s fingers touch
    the block (from step 21 of 40 on) and lift it, after random steps (a random arm
    would not touch it)."""
    for seed in (0, 1):
        env = E.make_env("FetchPickAndPlace-v4", seed=seed)
        rng = np.random.default_rng(seed)
        for _ in range(10):
            obs = E.step(env, rng.uniform(-1, 1, 4))[0]["observation"]
        z0, block = obs[5], env.model.body("object0").id
        fingers = {
            env.model.body(n).id
            for n in ("robot0:r_gripper_finger_link", "robot0:l_gripper_finger_link")
        }
        touching = 0
        for t in range(40):
            obs = E.step(env, E.scripted_grasp(obs, t))[0]["observation"]
            bodies = {
                frozenset(env.model.geom_bodyid[[c.geom1, c.geom2]])
                for c in env.data.contact[: env.data.ncon]
            }
            touching += any(frozenset((block, f)) in bodies for f in fingers)
        assert touching >= 15 and obs[5] - z0 > 0.2, (seed, touching, obs[5] - z0)
    assert not E.replay_difference(steps=5, warmup=0)[0].any()  # no warm-up: reset


@pytest.mark.parametrize("env_id", ["FetchPush-v4", "FetchPickAndPlace-v4"])
def test_restart_reproduces_stored_observation(env_id):
    a = E.make_env(env_id, seed=4)
    rng = np.random.default_rng(1)
    for _ in range(12):
        obs = E.step(a, rng.uniform(-1, 1, 4))[0]
    saved, goal = E.get_state(a), a.goal.copy()
    b = E.make_env(env_id, seed=5)
    got = E.restart_from(b, saved)  # restart_goal="resample": the goal is fresh
    np.testing.assert_array_equal(got["observation"], obs["observation"])
    np.testing.assert_array_equal(got["achieved_goal"], obs["achieved_goal"])
    got = E.restart_from(b, saved, goal)  # restart_goal="episode": the stored goal
    np.testing.assert_array_equal(got["desired_goal"], goal)


def test_unknown_env_is_a_config_error():
    with pytest.raises(ConfigError, match="env='CartPole-v1'.*FetchReach-v4"):
        E.make_env("CartPole-v1")


def test_seeding_is_deterministic():
    a, b = E.make_env("FetchPush-v4", seed=7), E.make_env("FetchPush-v4", seed=7)
    np.testing.assert_array_equal(
        a._get_obs()["observation"], b._get_obs()["observation"]
    )
    np.testing.assert_array_equal(a.goal, b.goal)


def test_a_runs_training_and_test_envs_never_share_a_seed():
    """Up to `MAX_WORKERS` a run's W training and W test envs (and the next seed's
    run's) have seeds of their own; one worker more and two coincide."""
    from acder_lite.config import MAX_WORKERS

    def seeds(seed, w):
        return E.run_env_seeds(seed, w) + E.run_env_seeds(seed, w, test=True)

    both = seeds(3, MAX_WORKERS) + seeds(4, MAX_WORKERS)
    assert len(set(both)) == len(both) == 4 * MAX_WORKERS
    assert E.run_env_seeds(3, 2, test=True) == [3500, 3501]
    more = seeds(3, MAX_WORKERS + 1)
    assert len(set(more)) < len(more)


def test_step_matches_the_env_step_up_to_the_kinematics_refresh():
    a, b = E.make_env("FetchPush-v4", seed=2), E.make_env("FetchPush-v4", seed=2)
    u = np.array([0.5, -0.2, 0.1, 0.0])
    mine, ok = E.step(a, u)
    theirs, _, _, _, info = b.step(u)
    np.testing.assert_allclose(mine["observation"], theirs["observation"], atol=2e-3)
    assert ok == info["is_success"]
    np.testing.assert_array_equal(a.data.qpos, b.data.qpos)  # same physics step


def test_get_and_set_state_with_another_spec():
    import mujoco

    full = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
    env = E.make_env("FetchPush-v4", seed=6)
    rng = np.random.default_rng(2)
    for _ in range(5):
        E.step(env, rng.uniform(-1, 1, 4))
    # the default spec is STATE_SPEC, as every existing call has it
    np.testing.assert_array_equal(E.get_state(env), E.get_state(env, spec=E.STATE_SPEC))
    state = E.get_state(env, spec=full)
    assert state.size == E.state_size(env, full) < E.state_size(env)
    want = {k: getattr(env.data, k).copy() for k in ("qpos", "qvel", "act")}
    want["time"], mocap = env.data.time, env.data.mocap_pos.copy()
    for _ in range(5):  # move on: qpos, qvel, time and the mocap target change
        E.step(env, rng.uniform(-1, 1, 4))
    assert not np.array_equal(env.data.qpos, want["qpos"])
    assert not np.array_equal(env.data.mocap_pos, mocap)
    E.set_state(env, state, spec=full)
    for k in ("qpos", "qvel", "act", "time"):
        np.testing.assert_array_equal(getattr(env.data, k), want[k])
    # FULLPHYSICS holds no mocap pose: it stays where the later steps left it
    assert not np.array_equal(env.data.mocap_pos, mocap)
    # a mocap-only state writes the mocap pose back and nothing else
    env.data.mocap_pos[:] = mocap
    only = E.get_state(env, spec=int(mujoco.mjtState.mjSTATE_MOCAP_POS))
    assert only.size == mocap.size
    env.data.mocap_pos[:] += 0.1
    qpos = env.data.qpos.copy()
    E.set_state(env, only, spec=int(mujoco.mjtState.mjSTATE_MOCAP_POS))
    np.testing.assert_array_equal(env.data.mocap_pos, mocap)
    np.testing.assert_array_equal(env.data.qpos, qpos)


def test_obs_names_label_each_finger_by_its_joint():
    """Moving one finger joint moves the entry named after it (the right finger was
    labelled left before): `obs_names` follows the model, not a guess."""
    env = E.make_env("FetchPush-v4", seed=0)
    names = E.obs_names(env)
    for side in "rl":
        before = env._get_obs()["observation"].copy()
        j = env.model.joint(f"robot0:{side}_gripper_finger_joint")
        env.data.qpos[j.qposadr[0]] += 0.01
        mujoco.mj_forward(env.model, env.data)
        moved = np.flatnonzero(env._get_obs()["observation"] != before)
        assert f"finger_{side}" in [names[i] for i in moved]
        assert f"finger_{'lr'[side == 'l']}" not in [names[i] for i in moved]


def test_a_task_added_to_the_tables_but_not_registered_is_one_line(
    tmp_path, capsys, monkeypatch
):
    """'Using acder_lite' (book/using.md), 'Extending it', adds a task to `ENV_IDS` and
    `TASK_PRESETS`; forgetting to register it with gymnasium gives one line naming the
    id (exit 2), not
    gymnasium's NameNotFound traceback, and writes no run file."""
    from acder_lite.cli import main as cli
    from acder_lite import config

    ids = (*config.ENV_IDS, "FetchFoo-v1")
    presets = {
        **config.TASK_PRESETS,
        "FetchFoo-v1": config.TASK_PRESETS["FetchPush-v4"],
    }
    for mod in (config, E, cli):
        monkeypatch.setattr(mod, "ENV_IDS", ids, raising=False)
    monkeypatch.setattr(config, "TASK_PRESETS", presets)
    with pytest.raises(ConfigError, match="env='FetchFoo-v1' is not registered"):
        E.horizon("FetchFoo-v1")
    out = tmp_path / "run"
    argv = ["train", "--env", "FetchFoo-v1", "--epochs", "1", "--out", str(out)]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "env='FetchFoo-v1' is not registered" in err[0], err
    assert not out.exists() or not any(out.iterdir())
