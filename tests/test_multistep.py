"""FetchPushMultiStep-v0 (acder_lite.envs.multistep): two blocks, two targets,
success only with both.

Spaces (gymnasium's checker), the 2-block reward and success, batched rewards, seeding,
the reset rules, exact state restore, bad ids, and a scripted pusher showing the task is
solvable in 100 steps.
"""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import acder_lite  # noqa: F401  (registers FetchPushMultiStep-v0)
from acder_lite.envs import fetch as E
from acder_lite.envs import multistep as M
from acder_lite.book import pusher as P
from acder_lite.config import (
    ENV_IDS,
    METHODS,
    OBJECT_ENVS,
    TASK_PRESETS,
    Config,
    ConfigError,
)

ID = "FetchPushMultiStep-v0"


@pytest.fixture(scope="module")
def env():
    return E.make_env(ID, seed=0)


def place(env, xy0, xy1):
    """Put the blocks at xy0, xy1 (resting height,
    at rest) and recompute the kinematics."""
    for name, xy in (("object0:joint", xy0), ("object1:joint", xy1)):
        q = env._utils.get_joint_qpos(env.model, env.data, name)
        q[:2] = xy
        env._utils.set_joint_qpos(env.model, env.data, name, q)
    env.data.qvel[:] = 0
    E.set_state(env, E.get_state(env))  # mj_forward
    return env._get_obs()


def test_gymnasium_env_checker_passes():
    e = gym.make(ID)
    assert e.spec.max_episode_steps == M.MAX_EPISODE_STEPS == 100
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # the checker's render check opens a window
        # (render_modes includes "human"): skipped
        check_env(e.unwrapped, skip_render_check=True)
    # only the warnings FetchPush-v4 gets too (its Box spaces are unbounded)
    assert all("infinity" in str(w.message) for w in caught), [
        str(w.message) for w in caught
    ]
    e.close()


def test_spaces_and_shapes(env):
    sp = env.observation_space
    assert (
        sp["observation"].shape == (40,)
        and sp["achieved_goal"].shape == (6,)
        and sp["desired_goal"].shape == (6,)
    )
    assert (
        env.action_space.shape == (4,)
        and env.block_gripper
        and env.has_object
        and env.n_objects == 2
    )
    obs = env._get_obs()
    assert (
        obs["observation"].shape == (40,)
        and obs["achieved_goal"].shape == (6,)
        and obs["desired_goal"].shape == (6,)
    )
    assert sum(n for _, n in M.OBS_LAYOUT) == 40
    names = E.obs_names(env)
    assert len(names) == 40 and names[:3] == ["grip_pos.x", "grip_pos.y", "grip_pos.z"]
    assert names[3:9] == [f"object{i}_pos.{c}" for i in range(2) for c in "xyz"]
    assert E.goal_names(env) == [f"goal{i}.{c}" for i in range(2) for c in "xyz"]
    o = obs["observation"]
    grip = o[:3]
    for i, site in enumerate(M.OBJECTS):
        pos = env._utils.get_site_xpos(env.model, env.data, site)
        np.testing.assert_array_equal(o[3 + 3 * i : 6 + 3 * i], pos)  # object_pos
        np.testing.assert_allclose(
            o[9 + 3 * i : 12 + 3 * i], pos - grip
        )  # object_rel_pos
        np.testing.assert_array_equal(obs["achieved_goal"][3 * i : 3 * i + 3], pos)
    assert E.horizon(ID) == 100


def test_model_is_derived_from_the_installed_push_xml(env):
    text = M.derived_xml()
    assert 'name="object1:joint"' in text and 'name="target1"' in text
    assert env.fullpath == M.model_path() and not env.fullpath.startswith(M.ASSETS)
    m = env.model
    import mujoco

    for name in ("object0:joint", "object1:joint"):
        j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
        assert j >= 0 and m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
    for name in M.TARGETS + M.OBJECTS:
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name) >= 0
    env.reset(seed=2)
    env._render_callback()  # what render() draws: each target site on its block's goal
    for i, name in enumerate(M.TARGETS):
        sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
        np.testing.assert_allclose(
            env.data.site_xpos[sid], env.goal[3 * i : 3 * i + 3], atol=1e-12
        )
    # the robot and block 0 start exactly as on FetchPush-v4
    push = E.make_env("FetchPush-v4", seed=0)
    np.testing.assert_array_equal(env.initial_gripper_xpos, push.initial_gripper_xpos)
    assert env.height_offset == push.height_offset
    assert m.nq == push.model.nq + 7
    push.close()


def test_reward_and_success_on_hand_placed_blocks(env):
    env.reset(seed=1)
    g = env.goal.reshape(2, 3)
    far0, far1 = g[0, :2] + [0.0, 0.12], g[1, :2] + [0.12, 0.0]
    cases = [
        ((g[0, :2], g[1, :2]), 0.0, True),  # both on target
        ((g[0, :2] + 0.03, g[1, :2]), 0.0, True),  # 4.2 cm off: still within 5 cm
        ((g[0, :2], far1), -1.0, False),  # one block on target is not enough
        ((far0, g[1, :2]), -1.0, False),
        ((far0, far1), -1.0, False),
        ((g[1, :2], g[0, :2]), -1.0, False),
    ]  # each on the other's target
    for (xy0, xy1), reward, success in cases:
        obs = place(env, xy0, xy1)
        ag = obs["achieved_goal"]
        assert env.compute_reward(ag, env.goal, {}) == reward
        assert bool(env._is_success(ag, env.goal)) is success
    # env.step's info and reward agree (both blocks on target;
    # a zero action keeps them there)
    place(env, g[0, :2], g[1, :2])
    _, r, term, trunc, info = env.step(np.zeros(4))
    assert r == 0.0 and info["is_success"] == 1.0 and not term and not trunc


def test_compute_reward_is_vectorised(env):
    rng = np.random.default_rng(0)
    ag = rng.uniform(1.0, 1.5, (300, 6))
    g = ag + rng.normal(0, 0.04, (300, 6))
    batch = env.compute_reward(ag, g, None)
    assert batch.shape == (300,) and batch.dtype == np.float32
    rows = np.array([env.compute_reward(a, b, None) for a, b in zip(ag, g)])
    np.testing.assert_array_equal(batch, rows)
    assert 0 < (batch == 0).sum() < 300  # both outcomes occur
    d = np.linalg.norm((ag - g).reshape(300, 2, 3), axis=-1)
    np.testing.assert_array_equal(batch, np.where((d <= 0.05).all(1), 0.0, -1.0))
    np.testing.assert_array_equal(env._is_success(ag, g), (d < 0.05).all(1))
    # HER hands float32 goals with extra leading axes
    r2 = env.compute_reward(
        ag.reshape(3, 100, 6).astype(np.float32),
        g.reshape(3, 100, 6).astype(np.float32),
        None,
    )
    assert r2.shape == (3, 100)
    with pytest.raises(ValueError):
        env.compute_reward(ag[:, :3], g[:, :3], None)


def test_seeded_resets_are_deterministic():
    a, b = gym.make(ID).unwrapped, gym.make(ID).unwrapped
    for seed in (0, 5):
        oa, ob = a.reset(seed=seed)[0], b.reset(seed=seed)[0]
        for k in oa:
            np.testing.assert_array_equal(oa[k], ob[k])
    assert not np.array_equal(
        a.reset(seed=1)[0]["desired_goal"], a.reset(seed=2)[0]["desired_goal"]
    )
    c, d = E.make_env(ID, seed=7), E.make_env(ID, seed=7)
    np.testing.assert_array_equal(
        c._get_obs()["observation"], d._get_obs()["observation"]
    )
    np.testing.assert_array_equal(c.goal, d.goal)


def test_reset_constraints_hold_over_many_seeds(env):
    grip = env.initial_gripper_xpos[:2]
    blocks, targets = [], []
    for seed in range(300):
        obs, _ = env.reset(seed=seed)
        ag, g = obs["achieved_goal"].reshape(2, 3), obs["desired_goal"].reshape(2, 3)
        blocks.append(ag)
        targets.append(g)
    b, t = np.array(blocks), np.array(targets)
    off_b, off_t = b[..., :2] - grip, t[..., :2] - grip
    assert np.abs(off_b).max() <= 0.15 and np.abs(off_t).max() <= 0.15
    assert np.linalg.norm(off_b, axis=-1).min() >= 0.1  # away from the gripper
    assert (
        np.linalg.norm(b[:, 0, :2] - b[:, 1, :2], axis=-1).min() >= 0.1
    )  # and from each other
    assert np.linalg.norm(t[:, 0, :2] - t[:, 1, :2], axis=-1).min() >= 0.1
    np.testing.assert_allclose(
        b[..., 2], env.height_offset, atol=1e-9
    )  # resting on the table
    np.testing.assert_array_equal(t[..., 2], env.height_offset)  # targets on the table
    assert (
        np.abs(off_b).max() > 0.13 and np.abs(off_t).max() > 0.13
    )  # the full range is used


def test_restored_state_replays_20_steps_exactly():
    rng = np.random.default_rng(0)
    a = E.make_env(ID, seed=3)
    for _ in range(7):
        E.step(a, rng.uniform(-1, 1, 4))
    saved = E.get_state(a)
    assert saved.size == E.state_size(a)
    actions = rng.uniform(-1, 1, (20, 4))
    ref = [E.step(a, u) for u in actions]

    b = E.make_env(ID, seed=99)  # a fresh env with another episode under way
    b.goal = a.goal.copy()
    E.set_state(b, saved)
    for u, (want, ok) in zip(actions, ref):
        got, ok2 = E.step(b, u)
        for k in ("observation", "achieved_goal"):
            np.testing.assert_array_equal(got[k], want[k])
        assert ok == ok2
    # restart_from (start states): the stored observation comes back,
    # with a fresh or the stored goal
    c = E.make_env(ID, seed=5)
    got = E.restart_from(c, saved)
    E.set_state(a, saved)
    want = a._get_obs()
    np.testing.assert_array_equal(got["observation"], want["observation"])
    got = E.restart_from(c, saved, a.goal)
    np.testing.assert_array_equal(got["desired_goal"], a.goal)


def test_a_scripted_pusher_solves_seeded_episodes_within_100_steps():
    T = E.horizon(ID)
    wins = []
    for seed in range(6):
        env = E.make_env(ID, seed=seed)
        obs, ok, h = env._get_obs(), False, env.height_offset
        assert not env._is_success(obs["achieved_goal"], env.goal)
        for _ in range(T):
            obs, ok = E.step(env, P.scripted_push(obs["observation"], env.goal, h))
        wins.append(ok)  # success at the last step, as training counts it
        env.close()
    # measured: 5 of these 6 (and 16 of seeds 0-19)
    assert sum(wins) >= 4, wins


def test_the_batched_pusher_is_the_pusher_row_by_row():
    envs = [E.make_env(ID, seed=k) for k in range(3)]
    o = np.stack([e._get_obs()["observation"] for e in envs])
    g = np.stack([e.goal for e in envs])
    h = envs[0].height_offset
    got = P.scripted_pusher(h)(o, g)
    want = np.stack([P.scripted_push(oi, gi, h) for oi, gi in zip(o, g)])
    assert got.shape == (3, 4) and np.array_equal(got, want) and np.abs(got).max() > 0


def test_config_knows_the_task():
    assert ID in ENV_IDS and ID in OBJECT_ENVS
    assert TASK_PRESETS[ID] == dict(
        eta=0.8, alpha0=0.7, epochs=400, cycles=50, success_threshold=0.95, gamma=0.99
    )
    cfg = Config(env=ID, method="her-ebp").resolve()
    assert (cfg.eta, cfg.alpha0, cfg.epochs, cfg.cycles) == (0.8, 0.7, 400, 50)


@pytest.mark.parametrize("bad", ["FetchPushMultiStep-v1", "FetchPushMultistep-v0"])
def test_bad_id_is_a_one_line_config_error(bad):
    with pytest.raises(ConfigError) as e:
        E.make_env(bad)
    msg = str(e.value)
    assert (
        "\n" not in msg
        and f"env={bad!r}" in msg
        and ID in msg
        and "FetchPush-v4" in msg
    )
    with pytest.raises(ConfigError, match=f"env={bad!r}.*{ID}"):
        Config(env=bad).resolve()


def test_bad_id_on_the_command_line(cli, tmp_path):
    p = cli(
        "train",
        "--env",
        "FetchPushMultiStep-v1",
        "--out",
        str(tmp_path / "run"),
        timeout=120,
    )
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and "FetchPushMultiStep-v1" in lines[0] and ID in lines[0], (
        p.stderr
    )
    assert not (tmp_path / "run").exists()


# ----- what the methods make of two objects (rewards.goal_factor_target,
# priority.trajectory_energy)


def test_goal_factor_targets_the_block_farthest_from_its_own():
    from acder_lite.algo.rewards import goal_factor_target

    g3 = np.array([[0.1, 0.2, 0.3]])
    assert (
        goal_factor_target(g3, np.zeros((1, 3))) is g3
    )  # one object: the goal itself, untouched
    goal = np.array([[1.0, 0, 0, 0, 2.0, 0], [1.0, 0, 0, 0, 2.0, 0]])
    achieved = np.array(
        [
            [1.0, 0, 0, 0, 0, 0],  # block 0 on target, block 1 2 m away
            [0.0, 0, 0, 0, 1.9, 0],
        ]
    )  # block 0 1 m away, block 1 0.1 m
    np.testing.assert_array_equal(
        goal_factor_target(goal, achieved), [[0, 2.0, 0], [1.0, 0, 0]]
    )


def test_energy_counts_both_blocks():
    from acder_lite.algo.priority import trajectory_energy

    T = 10
    still = np.zeros((1, T + 1, 3))
    moving = np.zeros((1, T + 1, 3))
    moving[0, :, 0] = np.linspace(0, 0.05, T + 1)
    one = trajectory_energy(moving, 0.04)
    assert one[0] > 0
    np.testing.assert_allclose(
        trajectory_energy(np.concatenate([still, moving], 2), 0.04), one
    )
    np.testing.assert_allclose(
        trajectory_energy(np.concatenate([moving, moving], 2), 0.04),
        trajectory_energy(moving * np.sqrt(2), 0.04),
    )  # kinetic adds up


@pytest.mark.parametrize("method", sorted(METHODS))
def test_every_method_runs_on_the_multistep_push(method):
    from acder_lite.train.trainer import Trainer
    from conftest import tiny_config

    tr = Trainer(
        tiny_config(
            env="FetchPushMultiStep-v0", method=method, workers=2, epochs=1, cycles=2
        )
    )
    rows = tr.train(progress=False)
    assert len(rows) == 1 and tr.buffer.o.shape[1:] == (101, 40)


def test_the_pusher_refuses_a_selected_observation():
    with pytest.raises(ValueError, match=r"o \(40,\)"):
        P.scripted_push(np.zeros(17), np.zeros(6), 0.42)


def test_the_books_pusher_and_random_counts():
    """Chapter 9's numbers: the scripted pusher's successes per seed, and a random arm's
    shares, deterministic for a seed."""
    wins = P.pusher_successes(range(3))
    assert wins.dtype == bool and wins.shape == (3,) and wins.sum() >= 2
    a, b = P.random_counts(4, seed=0), P.random_counts(4, seed=0)
    assert a == b and a["episodes"] == 4 and 0 <= a["success"] <= a["one"] <= 1
    assert a["n_success"] == round(4 * a["success"]) and a["n_one"] == round(
        4 * a["one"]
    )


def test_start_on_targets_is_the_envs_success_rule_at_reset():
    """Chapter 9's chance level: episodes that start solved, seeded; `both` is the env's
    own `_is_success` right after reset, `one` at least one block within the
    threshold."""
    got = P.start_on_targets([0, 1], 300)
    assert got["both"].shape == got["one"].shape == (300, 2)
    again = P.start_on_targets([0, 1], 300)
    assert (got["both"] == again["both"]).all() and (got["one"] == again["one"]).all()
    assert not (got["both"] & ~got["one"]).any()
    assert 0 < got["one"].mean() < 0.5 and got["both"].mean() < 0.05
    env = E.make_env(ID, seed=1)  # replayed by hand: env 1's resets
    for t in range(300):
        obs, _ = env.reset()
        ok = env._is_success(obs["achieved_goal"], obs["desired_goal"])
        d = M.block_distances(obs["achieved_goal"], obs["desired_goal"])
        assert got["both"][t, 1] == bool(ok)
        assert got["one"][t, 1] == bool((d < env.distance_threshold).any())


def test_the_trainers_test_envs_are_replayed():
    """`envs.run_env_seeds` is the trainer's rule: its test envs reset to the same goals
    as envs made with those seeds; `solved_test_starts` counts per evaluation."""
    from acder_lite.train.trainer import Trainer
    from conftest import tiny_config

    cfg = tiny_config(env=ID, method="her", seed=3, workers=2)
    tr = Trainer(cfg)
    seeds = E.run_env_seeds(3, 2, test=True)
    assert seeds == [3500, 3501] and E.run_env_seeds(3, 2) == [3000, 3001]
    for env, s in zip(tr.test_envs, seeds):
        mine = E.make_env(ID, seed=s)
        np.testing.assert_array_equal(env.goal, mine.goal)
        np.testing.assert_array_equal(
            env.reset()[0]["desired_goal"], mine.reset()[0]["desired_goal"]
        )
    per = P.solved_test_starts(dict(seed=3, workers=2, test_episodes=5), 4)
    both = P.start_on_targets(seeds, 20)["both"]
    assert per.shape == (4,)
    np.testing.assert_array_equal(per, both.reshape(4, 10).sum(axis=1))


def test_the_pusher_leaves_a_block_within_push_done():
    """A block within `PUSH_DONE` of its target is left alone: with both so, the
    pusher does nothing."""
    env = E.make_env(ID, seed=0)
    o, g = env._get_obs()["observation"].copy(), env.goal.copy()
    o[3:9] = g + np.r_[0.9, 0, 0, 0, 0.9, 0] * P.PUSH_DONE
    np.testing.assert_array_equal(P.scripted_push(o, g, env.height_offset), 0.0)
    o[3:9] = g + np.r_[1.1, 0, 0, 0, 0, 0] * P.PUSH_DONE
    assert np.abs(P.scripted_push(o, g, env.height_offset)).sum() > 0


def test_block_distances_by_hand():
    """Each block to its own target: block 1 at (0, 0, 0) against (3, 4, 0) is 5 away,
    block 2 on its target is 0; batches keep their leading axes; other widths raise."""
    ag = np.array([0.0, 0, 0, 1, 1, 1])
    g = np.array([3.0, 4, 0, 1, 1, 1])
    np.testing.assert_allclose(M.block_distances(ag, g), [5.0, 0.0])
    batch = M.block_distances(np.stack([ag, g]), np.stack([g, g]))
    np.testing.assert_allclose(batch, [[5.0, 0.0], [0.0, 0.0]])
    with pytest.raises(ValueError, match=r"\(\.\.\., 6\)"):
        M.block_distances(ag[:3], g[:3])
    with pytest.raises(ValueError):
        M.block_distances(ag, np.stack([g, g]))


def test_block_shares_by_hand():
    """Four hand-made episodes (T = 2, targets at the origin so distances are exact):
    0 puts block 0 on its target (1 cm off) after pushing it 10 cm, block 1 stays
    20 cm off and still; 1 starts and ends with both on target, nothing moves; 2 grazes
    block 0 (5 mm) and pushes block 1 by 2 cm, neither on target; 3 ends block 0
    exactly at the threshold and moves block 1 (30 cm off) exactly `MOVED` (both
    strict: neither counts). Block 0 on target in 2 of 4, block 1 in 1; each moved
    in 1."""
    z = np.zeros(3)
    x = lambda d: np.array([d, 0.0, 0.0])  # noqa: E731
    starts_ends = [
        ((x(0.11), x(0.20)), (x(0.01), x(0.20))),
        ((z, x(0.02)), (z, x(0.02))),
        ((x(0.30), x(0.30)), (x(0.305), x(0.32))),
        ((x(0.05), x(0.3)), (x(0.05), x(0.3) + [0, M.MOVED, 0])),
    ]
    ag = np.array(
        [
            [np.r_[s0, s1], np.r_[s0, s1], np.r_[e0, e1]]
            for (s0, s1), (e0, e1) in starts_ends
        ]
    )
    g = np.zeros((4, 2, 6))
    want = dict(
        block0_on_target=0.5,
        block1_on_target=0.25,
        block0_moved=0.25,
        block1_moved=0.25,
    )
    assert M.block_shares(ag, g, 0.05) == want
    assert list(M.block_shares(ag, g[:, -1], 0.05)) == list(M.BLOCK_COLUMNS)
    assert M.block_shares(ag, g[:, -1], 0.05) == want  # (n, 6) goals too
    # a larger threshold puts episode 2's block 0 (30.5 cm) still off, episode 3's on
    assert M.block_shares(ag, g, 0.06)["block0_on_target"] == 0.75
    empty = M.block_shares(np.zeros((0, 3, 6)), np.zeros((0, 2, 6)), 0.05)
    assert all(np.isnan(v) for v in empty.values())
    with pytest.raises(ValueError, match="block_shares"):
        M.block_shares(ag[:, -1], g, 0.05)
    with pytest.raises(ValueError, match="block_shares"):
        M.block_shares(ag, g[:3], 0.05)


def test_any_block_on_target_by_hand():
    g = np.zeros(6)
    ag = np.array([[0.01, 0, 0, 1, 0, 0], [1, 0, 0, 0, 0.04, 0], [1, 0, 0, 0.05, 0, 0]])
    np.testing.assert_array_equal(
        M.any_block_on_target(ag, np.broadcast_to(g, ag.shape), 0.05),
        [True, True, False],
    )


def test_moved_lies_between_a_graze_and_a_push():
    """`MOVED`'s reading: a block nobody touches moves far less (float32 rounding of a
    still arm's episode), the scripted pusher's blocks far more."""
    envs = [E.make_env(ID, seed=s) for s in (0, 1)]
    still = run_episodes_(envs, lambda o, g: np.zeros((len(o), 4)))
    assert (M.block_distances(still["ag"][:, -1], still["ag"][:, 0]) < 1e-5).all()
    pushed = run_episodes_(envs, P.scripted_pusher(envs[0].height_offset))
    assert (
        M.block_distances(pushed["ag"][:, -1], pushed["ag"][:, 0]) > 10 * M.MOVED
    ).all()


def run_episodes_(envs, act):
    from acder_lite.train.rollout import run_episodes

    return run_episodes(envs, act, M.MAX_EPISODE_STEPS)


def test_site_positions_of_stored_states_are_the_achieved_goals():
    """`envs.site_positions` reads the blocks from stored states without the env: the
    same float32 numbers as the achieved goals of the episode that stored them, and the
    env's own state is left as it was."""
    envs = [E.make_env(ID, seed=s) for s in (5, 6)]
    rng = np.random.default_rng(0)
    ep = run_episodes_(envs, lambda o, g: rng.uniform(-1, 1, (len(o), 4)))
    states = ep["state"].reshape(-1, ep["state"].shape[-1])
    before = [E.get_state(e).copy() for e in envs]
    pos = E.site_positions(envs[0], states, M.OBJECTS)
    assert pos.shape == (len(states), 2, 3) and pos.dtype == np.float64
    np.testing.assert_array_equal(
        pos.reshape(len(states), 6).astype(np.float32), ep["ag"].reshape(-1, 6)
    )
    for b, e in zip(before, envs):
        np.testing.assert_array_equal(E.get_state(e), b)
    with pytest.raises(ValueError, match="site_positions"):
        E.site_positions(envs[0], states[:1], ["no_such_site"])


def test_block_columns_only_on_the_multistep_task():
    """The per-block columns follow the method's own; FetchPush's columns are as they
    were, column for column; the pool's column only with a start-state pool."""
    from acder_lite.train.trainer import BASE_COLUMNS, Trainer
    from conftest import tiny_config

    acder_extra = [
        "r_int_mean",
        "curiosity_loss",
        "lambda_mean",
        "alpha",
        "novel_start_share",
        "pool_size",
    ]
    push = Trainer(tiny_config(env="FetchPush-v4", method="acder"))
    assert push.columns == BASE_COLUMNS + acder_extra
    assert Trainer(tiny_config(env="FetchPush-v4")).columns == BASE_COLUMNS
    multi = Trainer(tiny_config(env=ID, method="acder"))
    assert multi.columns == (
        BASE_COLUMNS + acder_extra + list(M.BLOCK_COLUMNS) + [M.POOL_COLUMN]
    )
    her = Trainer(tiny_config(env=ID, method="her"))
    assert her.columns == BASE_COLUMNS + list(M.BLOCK_COLUMNS)
    no_pool = Trainer(tiny_config(env=ID, method="acder-no-start-states"))
    assert M.POOL_COLUMN not in no_pool.columns


def test_a_tiny_run_writes_the_block_columns(tmp_path):
    """A seeded ACDER run on the task: progress.csv has the per-block shares in [0, 1]
    at every evaluation (the pool's share NaN while the pool is empty); then, with a
    hand-filled pool of the run's own stored states, half of them given goals on their
    achieved goals and half far off, the pool's share is 1/2."""
    import csv

    from acder_lite.train.trainer import Trainer
    from conftest import tiny_config

    cfg = tiny_config(
        env=ID, method="acder", seed=3, workers=2, epochs=2, cycles=1, test_episodes=2
    )
    tr = Trainer(cfg, out_dir=str(tmp_path / "run"))
    tr.train(progress=False)
    with open(tmp_path / "run" / "progress.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2
    for r in rows:
        for k in M.BLOCK_COLUMNS:
            assert 0.0 <= float(r[k]) <= 1.0, (k, r[k])
        pool = float(r[M.POOL_COLUMN])
        assert (np.isnan(pool) and int(r["pool_size"]) == 0) or 0.0 <= pool <= 1.0
    buf = tr.buffer
    tr.selector.pool.clear()
    for k, (e, t) in enumerate([(0, 10), (1, 50), (2, 99), (3, 0)]):
        ag = buf.ag[e, t + 1]
        goal = ag.copy() if k % 2 == 0 else ag + np.float32(1.0)
        tr.selector.pool.append(dict(state=buf.state[e, t + 1].copy(), goal=goal))
    assert tr.pool_block_on_target() == 0.5


def test_the_block_columns_move_no_float():
    """Recording the block columns draws no random number and changes no training
    float: the same seeded run with the recording switched off ends with the same
    networks, random streams and every other column."""
    import torch

    from acder_lite.train.trainer import Trainer
    from conftest import tiny_config

    cfg = tiny_config(env=ID, method="acder", seed=4, workers=2, epochs=2, cycles=1)
    # a pool from the start (the same in both runs), so its column is computed too
    envs = [E.make_env(ID, seed=9)]
    rng = np.random.default_rng(1)
    ep = run_episodes_(envs, lambda o, g: rng.uniform(-1, 1, (1, 4)))
    pool = [
        dict(state=ep["state"][0, t], goal=ep["g"][0, 0], r_int=0.1)
        for t in (0, 40, 100)
    ]
    runs = []
    for record in (True, False):
        tr = Trainer(cfg)
        tr.multistep = record
        tr.selector.pool.extend(pool)
        rows = tr.train(progress=False)
        runs.append((tr, rows))
    (a, ra), (b, rb) = runs
    assert set(ra[0]) - set(rb[0]) == set(M.BLOCK_COLUMNS) | {M.POOL_COLUMN}
    assert all(0 <= r[M.POOL_COLUMN] <= 1 for r in ra)
    for x, y in zip(ra, rb):
        assert {k: v for k, v in x.items() if k in y and k != "wall_s"} == {
            k: v for k, v in y.items() if k != "wall_s"
        }
    nets = ("actor", "critic", "actor_targ", "critic_targ")
    for n in nets:
        da, db = getattr(a.agent, n).state_dict(), getattr(b.agent, n).state_dict()
        assert all(torch.equal(da[k], db[k]) for k in da), n
    ca, cb = a.curiosity.state_dict(), b.curiosity.state_dict()
    assert all(torch.equal(ca[k], cb[k]) for k in ca if torch.is_tensor(ca[k])), (
        "curiosity"
    )
    assert a.rng.bit_generator.state == b.rng.bit_generator.state
    for e, f in zip(a.test_envs + a.envs, b.test_envs + b.envs):
        assert E.env_rng_state(e) == E.env_rng_state(f)
