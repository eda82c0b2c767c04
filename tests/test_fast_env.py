"""acder_lite.envs.fastobs (issue 17): the env's fast `_get_obs`, `_set_action` and
`_step_callback` give gymnasium-robotics' numbers bit for bit, and fresh arrays.

Each case steps a fast env (`make_env`'s default) and a reference env of the same seed
made with `fast=False` (the classes' own methods) through the same random actions, a
reset and a `restart_from` of a stored state, and compares every array exactly
(`np.array_equal`, dtypes and shapes too): the observation dicts, the success flags and
the whole stored MuJoCo state (qpos, qvel, warm start, ctrl, mocap pose), and on the
fast env itself its `_get_obs` against the class's.
"""

import numpy as np
import pytest
from gymnasium_robotics.envs.fetch.reach import MujocoFetchReachEnv

from acder_lite.envs import fetch as E
from acder_lite.envs.fastobs import install

FAST = ("_get_obs", "_set_action", "_step_callback")
CASES = [
    ("FetchReach-v4", "full"),
    ("FetchPush-v4", "full"),
    ("FetchPickAndPlace-v4", "full"),
    ("FetchSlide-v4", "full"),
    ("FetchPushMultiStep-v0", "full"),
    ("FetchPush-v4", "simplified"),
]
DATA = ("qpos", "qvel", "xpos", "xquat", "site_xpos", "site_xmat", "mocap_pos", "ctrl")
"""MjData arrays a returned observation must not be a view of."""


def same(got: dict, want: dict) -> None:
    assert got.keys() == want.keys()
    for k in want:
        assert got[k].dtype == want[k].dtype and got[k].shape == want[k].shape, k
        assert np.array_equal(got[k], want[k]), k


def fresh(env, obs: dict) -> None:
    """No returned array shares memory with the env's MjData or its goal."""
    for k, v in obs.items():
        for name in DATA:
            assert not np.may_share_memory(v, getattr(env.data, name)), (k, name)
        assert not np.may_share_memory(v, env.goal), k


def class_obs(env) -> dict:
    """What the class's own `_get_obs` gives on this env (the observation set's
    entries of it, for a simplified env)."""
    d = type(env)._get_obs(env)
    if getattr(env, "obs_index", None) is not None:
        d["observation"] = d["observation"][env.obs_index]
    return d


@pytest.mark.parametrize("env_id,obs", CASES)
def test_fast_path_is_bit_identical_and_fresh(env_id, obs):
    fast = E.make_env(env_id, seed=11, obs=obs)
    ref = E.make_env(env_id, seed=11, obs=obs, fast=False)
    assert fast.fast_methods == FAST
    assert not hasattr(ref, "fast_methods") and "_set_action" not in vars(ref)
    same(fast._get_obs(), ref._get_obs())  # after make_env's seeded reset
    rng = np.random.default_rng(5)
    stored = None
    for t in range(60):
        if t == 25:
            got, want = fast.reset()[0], ref.reset()[0]
        elif t == 45:  # a restart from the state stored at step 10, its goal kept
            got = E.restart_from(fast, *stored)
            want = E.restart_from(ref, *stored)
        else:
            # float32 (what the trainer passes) and float64, some outside the box
            u = rng.uniform(-1.3, 1.3, 4).astype(np.float32 if t % 2 else np.float64)
            got, ok = E.step(fast, u)
            want, ok_ref = E.step(ref, u)
            assert ok == ok_ref
        same(got, want)
        same(got, class_obs(fast))  # the class's method, on the fast env itself
        if obs != "full":
            same(fast.full_get_obs(), type(fast)._get_obs(fast))
        assert np.array_equal(E.get_state(fast), E.get_state(ref))
        fresh(fast, got)
        if t == 10:
            stored = (E.get_state(fast), fast.goal.copy())
            kept = {k: v.copy() for k, v in got.items()}
            held = got
    same(held, kept)  # stored 50 steps ago: not rewritten by later steps


def test_a_class_with_its_own_methods_keeps_them():
    class Custom(MujocoFetchReachEnv):
        def _get_obs(self):
            return super()._get_obs()

        def _step_callback(self):
            super()._step_callback()

    env = install(Custom())
    assert env.fast_methods == ("_set_action",)
    assert "_get_obs" not in vars(env) and "_step_callback" not in vars(env)
    env.close()


def test_install_after_an_observation_set_is_refused():
    env = E.make_env("FetchPush-v4", seed=0, obs="simplified")
    with pytest.raises(RuntimeError, match="install first"):
        install(env)
