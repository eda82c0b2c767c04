"""What a policy sees: the full Fetch observation, or the paper's simplified state.

Paper, section V-E ("Deployment on a Physical Robot"): for the UR5 the policies are
retrained "with simplified state inputs ... the positions of gripper and objects, the
relative positions of objects to gripper and finger states". `Config.obs = "simplified"`
keeps exactly those entries and drops every velocity and rotation: the camera that
stands in for the simulator on the robot measures positions, not a block's Euler angles
or spin.

The kept entries are chosen by *name* (`envs.obs_names`), never by number, so a change
of gymnasium-robotics' layout fails loudly (`simplified_indices`) instead of feeding the
policy the wrong numbers. The indices this gives (gymnasium-robotics 1.4.2;
`acder_lite.envs.multistep` for the two-block task):

    task                    full  kept  indices kept (names)
    FetchReach-v4             10     5  0-2 grip_pos, 3-4 finger_r/l
    FetchPush-v4              25    11  0-2 grip_pos, 3-5 object_pos,
    FetchPickAndPlace-v4      25    11    6-8 object_rel_pos, 9-10 finger_r/l
                                          (the same on FetchSlide-v4)
    FetchPushMultiStep-v0     40    17  0-2 grip_pos, 3-8 object{0,1}_pos,
                                          9-14 object{0,1}_rel_pos, 15-16 finger_r/l

Dropped: object rotations (Euler angles), object linear and angular velocities, the
gripper's linear velocity and the fingers' velocities (Reach: 5 of 10; one block: 14 of
25; two blocks: 23 of 40). "Finger states" are the two finger joints' positions
(`gripper_state`, the last two robot qpos), not their velocities. In every task the kept
entries happen to be a prefix of the full vector (gymnasium-robotics puts positions
first); nothing relies on that except one thing, which is checked: o[:3] is still the
gripper position, the agent position s^a_t of the goal-oriented factor (Eq. 5-6,
`Trainer.rewards`); `simplified_indices` raises if it were not.

How it is applied (`select`, called by `envs.make_env`): the env's `_get_obs` is
replaced, on that env instance only, by one returning the kept entries of the
observation; achieved and desired goals are untouched. Every path that reads an
observation goes through `_get_obs` (gymnasium-robotics' reset and step, `envs.step`,
`envs.restart_from`), so the trainer, HER (it relabels goals, not observations), S-ICM
(its input size is the observation's), the start states (a stored MuJoCo state is the
whole physics, whatever the policy sees) and `rollout.run_episodes` work unchanged. With
`obs = "full"` the env is returned as it was made: the full-state runs compute what they
always did, bit for bit.
"""

from __future__ import annotations

import re

import numpy as np

from acder_lite.config import OBS_SETS, ConfigError

KEPT = re.compile(r"^(grip_pos|object\d*_pos|object\d*_rel_pos)\.[xyz]$|^finger_[lr]$")
"""Names the simplified state keeps: gripper position, object positions,
object-minus-gripper positions, finger positions (paper, section V-E)."""
DROPPED = re.compile(
    r"^(object\d*_(rot|velp|velr)|grip_velp)\.[xyz]$"
    r"|^finger_vel_[lr]$"
)
"""Names it drops: rotations and velocities. A name matching neither pattern is a layout
this module does not know, and `simplified_indices` refuses to guess."""

ROTATION = re.compile(r"^object\d*_rot\.[xyz]$")
"""Names of the blocks' Euler angles (`object_rot`), which `sincos_angles` encodes."""

AGENT_POS = ["grip_pos.x", "grip_pos.y", "grip_pos.z"]
"""The first three kept names: the trainer's agent position o[:3] must stay the
gripper's."""


def check_obs(obs: str) -> str:
    """`obs` if it is an observation set, else ConfigError naming the field and what is
    allowed."""
    if obs not in OBS_SETS:
        allowed = " or ".join(repr(x) for x in OBS_SETS)
        raise ConfigError(f"obs={obs!r} is not allowed: {allowed}")
    return obs


def simplified_indices(names: list[str]) -> np.ndarray:
    """Indices (int64, increasing) of the entries the simplified state keeps, from the
    full observation's names (`envs.obs_names(env, full=True)`).

    RuntimeError for a name it does not know (neither kept nor dropped), or when the
    kept entries do not start with the gripper position (the agent position o[:3],
    departure 10).
    """
    unknown = [n for n in names if not (KEPT.match(n) or DROPPED.match(n))]
    if unknown:
        raise RuntimeError(
            f"simplified_indices: unknown observation entries "
            f"{unknown[:4]}; the simplified state cannot tell whether "
            "to keep them"
        )
    idx = np.array([i for i, n in enumerate(names) if KEPT.match(n)], dtype=np.int64)
    if [names[i] for i in idx[:3]] != AGENT_POS:
        raise RuntimeError(
            "simplified_indices: the kept entries do not start with "
            "grip_pos.x/y/z, the agent position o[:3] the goal-oriented "
            "factor reads"
        )
    return idx


def indices(env_or_names, obs: str) -> np.ndarray:
    """The indices into the *full* observation that observation set `obs` keeps (all of
    them for "full"). Takes an env (whichever set it gives) or the full names."""
    check_obs(obs)
    if isinstance(env_or_names, list):
        names = env_or_names
    else:
        names = full_obs_names(env_or_names)
    if obs == "full":
        return np.arange(len(names), dtype=np.int64)
    return simplified_indices(names)


def rotation_indices(names: list[str]) -> np.ndarray:
    """Indices (int64, increasing) of the blocks' Euler angles among `names` (the
    observation's, `envs.obs_names`): Push 11-13, the multi-step Push 17-22, none on
    Reach or in the simplified state."""
    return np.array([i for i, n in enumerate(names) if ROTATION.match(n)], np.int64)


def sincos_angles(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """`x` (..., D) with the angles at `idx` each replaced by (sin, cos): the other
    entries in their order, then the sines, then the cosines, shape (..., D + len(idx)).
    What S-ICM sees with `Config.sicm_angles="sincos"`.

    Trap: an Euler angle jumps by about 2 pi when the block turns through +-pi
    (`wraps.angle_wraps`), and a forward model's error on that jump, 1/2 (2 pi)^2, is
    far above Eq. 4's clip. Its sine and cosine move by as little as the block does."""
    x = np.asarray(x)
    a = x[..., idx]
    keep = np.delete(x, idx, axis=-1)
    return np.concatenate([keep, np.sin(a), np.cos(a)], axis=-1).astype(x.dtype)


def sincos_names(names: list[str], idx: np.ndarray) -> list[str]:
    """Names of `sincos_angles`'s entries, in its order: `names` (the input's) without
    the angles at `idx`, then "sin NAME" for each angle, then "cos NAME"."""
    gone = set(np.asarray(idx).tolist())
    angles = [names[i] for i in idx]
    kept = [n for i, n in enumerate(names) if i not in gone]
    return kept + [f"sin {n}" for n in angles] + [f"cos {n}" for n in angles]


def obs_names(env, full: bool = False) -> list[str]:
    """A name for each entry of the Fetch observation vector,
    in the order `_get_obs` builds it.

    Reach has no object: its 10 entries are the gripper's position, finger state and
    velocities. Push, Pick&Place and Slide add the object's position, its position
    relative to the gripper, its rotation (Euler angles) and its linear and angular
    velocities (25 entries). With several objects (FetchPushMultiStep-v0:
    `env.n_objects` = 2, 40 entries) each object field holds every object in turn, named
    object0_pos, object1_pos, ... (`acder_lite.envs.multistep.OBS_LAYOUT`).

    An env made with obs="simplified" gives the names of the entries it keeps, in its
    order (`acder_lite.envs.observations`); `full=True` gives the full vector's names
    whatever the env gives.
    """
    xyz = lambda name: [f"{name}.{c}" for c in "xyz"]
    n_objects = getattr(env, "n_objects", 1) if env.has_object else 0
    prefixes = (
        ["object"] if n_objects == 1 else [f"object{i}" for i in range(n_objects)]
    )
    each = lambda field: [n for p in prefixes for n in xyz(f"{p}_{field}")]
    # the fingers in the model's joint order, right then left: `_get_obs` takes the
    # last two of robot_get_obs's joints, r_ then l_gripper_finger_joint
    names = xyz("grip_pos") + each("pos") + each("rel_pos") + ["finger_r", "finger_l"]
    names += each("rot") + each("velp") + each("velr")
    names += xyz("grip_velp") + ["finger_vel_r", "finger_vel_l"]
    n = getattr(env, "full_get_obs", env._get_obs)()["observation"].size
    if (
        len(names) != n
    ):  # a changed gymnasium-robotics layout must not be mislabelled silently
        raise RuntimeError(
            f"obs_names: {len(names)} names for an observation of {n} entries"
        )
    kept = getattr(env, "obs_index", None)
    return names if full or kept is None else [names[i] for i in kept]


def full_obs_names(env) -> list[str]:
    """The names of the env's full observation, whichever set the env itself gives."""
    return obs_names(env, full=True)


def select(env, obs: str):
    """Make `env` (a freshly made, unwrapped Fetch env) give observation set `obs`;
    returns it.

    "full": `env` unchanged. "simplified": `env._get_obs` (an instance attribute from
    now on) returns the full dict with "observation" cut to `simplified_indices`, and
    `observation_space["observation"]` has the new size. The env records `obs_set`,
    `obs_index` (into the full vector) and `full_get_obs` (the original method, which
    `envs.obs_names` reads the full size from).
    """
    check_obs(obs)
    if obs == "full":
        return env
    if getattr(env, "obs_index", None) is not None:
        raise RuntimeError("select: this env already gives a selected observation")
    idx = simplified_indices(obs_names(env))
    full_get_obs = env._get_obs

    def _get_obs():
        d = full_get_obs()
        d["observation"] = d["observation"][idx]  # a copy: the full array is not kept
        return d

    env.full_get_obs, env.obs_index, env.obs_set = full_get_obs, idx, obs
    env._get_obs = _get_obs
    space = getattr(env, "observation_space", None)
    if space is not None and "observation" in getattr(space, "spaces", {}):
        from gymnasium import spaces

        old = space.spaces["observation"]
        space.spaces["observation"] = spaces.Box(
            -np.inf, np.inf, shape=(idx.size,), dtype=old.dtype
        )
    return env


def policy_obs(policy: dict) -> str:
    """The observation set a policy dict (`Policy.state_dict`, policy.pt) was trained
    on; "full" for a policy written before the set was recorded, which is what those
    runs used."""
    return policy.get("obs", "full")


def on_full(act, index: np.ndarray):
    """`act(o, g)` of a policy that sees the entries `index` of the observation, as a
    function of the full observation: for rollouts that record (or perturb) the full
    vector, as the robustness bench and `diagnose` do."""
    index = np.asarray(index)

    def full_act(o, g):
        return act(o[..., index], g)

    return full_act
