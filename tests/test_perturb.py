"""The perturbations: each knob's levels and the errors a bad one gets, the action's
delay and scale, the model's friction and mass scaled and restored bit for bit. How the
camera knobs change what a policy is shown: test_robust.py, through the bench."""

import mujoco
import numpy as np
import pytest

from acder_lite.envs import fetch as E
from acder_lite.config import ConfigError
from acder_lite.deploy.perturb import (
    KNOBS,
    Layout,
    Perturbed,
    nominal,
    parse_perturb,
    scaled_model,
)


def test_parse_perturb_defaults_and_errors():
    assert list(parse_perturb(None, "FetchPush-v4", 50)) == list(KNOBS)
    reach = ["goal_noise", "action_delay", "action_scale", "friction"]
    assert list(parse_perturb(None, "FetchReach-v4", 50)) == reach
    got = parse_perturb(["action_delay=0,1,1"], "FetchPush-v4", 50)
    assert got == {"action_delay": [0, 1]}
    assert parse_perturb(["mass"], "FetchPush-v4", 50) == {"mass": [0.5, 1.0, 2.0]}
    for spec, needle in (
        ("wind=1", "allowed: obs_noise, goal_noise"),
        ("obs_noise=-0.01", "obs_noise=-0.01 is not allowed: a number >= 0"),
        ("obs_noise=x", "'x' is not a number"),
        ("obs_noise=", "'' is not a number"),
        ("action_delay=1.5", "an integer >= 0"),
        ("action_delay=50", "below the horizon 50"),
        ("friction=0", "a number > 0"),
        ("mass=nan", "a number > 0"),
        # found by fuzzing: 1e308 was taken, and MuJoCo went unstable under the table
        ("mass=1e308", r"mass=1e\+308 is not allowed: .*, at most 100$"),
        ("friction=101", "at most 100"),
        ("action_scale=1e308", "at most 100"),
        ("obs_noise=1.5", r"obs_noise=1.5 is not allowed: .*, at most 1$"),
        ("goal_noise=1e308", "at most 1"),
    ):
        with pytest.raises(ConfigError, match=needle):
            parse_perturb([spec], "FetchPush-v4", 50)
    assert parse_perturb(["mass=100", "obs_noise=1"], "FetchPush-v4", 50) == {
        "mass": [100.0],
        "obs_noise": [1.0],
    }  # the bounds themselves are levels
    with pytest.raises(ConfigError, match="needs a block; FetchReach-v4 has none"):
        parse_perturb(["mass=2"], "FetchReach-v4", 50)


def test_action_delay_and_scale():
    no_block = np.zeros((0, 3), np.int64)
    layout = Layout(no_block, no_block, no_block, keep=np.arange(3))
    calls = iter(range(1, 100))

    def act(o, g):
        return np.full((1, 4), next(calls) / 10, np.float32)

    p = Perturbed(
        act,
        layout,
        dict(nominal(), action_delay=2, action_scale=2.0),
        np.random.default_rng(0),
    )
    out = [p(np.zeros((1, 3)), np.zeros((1, 3)))[0] for _ in range(5)]
    assert [u.tolist() for u in out[:2]] == [[0, 0, 0, 0]] * 2  # held still
    assert np.allclose(out[2], [0.2, 0.2, 0.2, 0.1])  # step 1's; xyz x2, gripper not
    assert np.allclose(out[4], [0.6, 0.6, 0.6, 0.3])
    p = Perturbed(
        lambda o, g: np.full((1, 4), 0.9, np.float32),
        layout,
        dict(nominal(), action_scale=1.2),
        np.random.default_rng(0),
    )
    assert p(np.zeros((1, 3)), np.zeros((1, 3))).max() == 1.0  # the action space's clip


def test_model_fields_scale_and_come_back_bit_for_bit():
    env = E.make_env("FetchPush-v4", seed=0)
    fresh = E.make_env("FetchPush-v4", seed=0)
    m = env.model
    fields = (
        "geom_friction",
        "body_mass",
        "body_inertia",
        "dof_invweight0",
        "body_subtreemass",
    )
    before = {k: np.array(getattr(m, k)) for k in fields}
    meaninertia = m.stat.meaninertia
    body = lambda name: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
    block = body("object0")
    with scaled_model(env, friction=0.5, mass=2.0):
        assert m.body_mass[block] == 2 * before["body_mass"][block]
        changed = np.nonzero(m.geom_friction[:, 0] != before["geom_friction"][:, 0])[0]
        owners = sorted(m.geom_bodyid[changed].tolist())
        assert owners == sorted([block, body("table0")])
        assert not np.array_equal(m.dof_invweight0, before["dof_invweight0"])
    for k, v in before.items():
        assert np.array_equal(getattr(m, k), v), k
    assert m.stat.meaninertia == meaninertia
    u = np.array([0.4, 0.1, -0.2, 0.0])
    for _ in range(10):
        a, _ = E.step(env, u)
        b, _ = E.step(fresh, u)
    assert np.array_equal(a["observation"], b["observation"])  # as a freshly made env
