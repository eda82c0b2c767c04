"""FetchPushMultiStep-v0: two blocks on the table, each with its own target (issue 14,
"our reading").

The paper's fourth task, "Multi-Step FetchPush", was never released and
gymnasium-robotics has no such task. Our reading, after the multi-object Fetch tasks of
the same years (Lanier et al.'s gym-fetch-stack, Li et al.'s fetch-block-construction):
FetchPush with a second block and a second target; success (and reward 0) only when
*both* blocks are within 5 cm of their own targets.

Everything not named here is FetchPush-v4's: the robot, the table, the blocked gripper
and 4-D action, 20 substeps of 2 ms, the sampling ranges (obj_range = target_range =
0.15 m).

**The model.** `derived_xml()` reads the installed gymnasium-robotics `fetch/push.xml`
(so the installed version is the source) and changes it in four places: the compiler's
`meshdir` and `texturedir` and the two `<include>`s (shared.xml, robot.xml) become
absolute paths into the installed assets folder, so the derived file loads from
anywhere; a second block `object1` (its own free joint `object1:joint`, geom and site, a
copy of `object0` but blue) follows `object0`; and a second target site `target1` (blue)
follows `target0`. The file is written once per content to
`<tempdir>/acder_lite-<uid>/FetchPushMultiStep-<hash>.xml` (written atomically;
site-packages is never written), and that path is the env's `model_path`.

**Observation** (40 numbers): FetchPush's fields in FetchPush's order
(gymnasium-robotics' `_get_obs`), each object field holding both blocks, object0's three
numbers then object1's:

    0-2   grip_pos                   3-8   object{0,1}_pos
    9-14  object{0,1}_rel_pos        15-16 gripper_state (fingers)
    17-22 object{0,1}_rot (Euler)    23-28 object{0,1}_velp (- grip_velp, x dt)
    29-34 object{0,1}_velr (x dt)    35-37 grip_velp (x dt)
    38-39 gripper_vel (x dt)

so o[:3] is the gripper and o[3:6] block 0, as on FetchPush (`OBS_LAYOUT`).
achieved_goal and desired_goal are 6-D: block 0's xyz then block 1's.

**Reset.** Block 0 as FetchPush places its block (uniform offset in [-0.15, 0.15]^2 from
the gripper's start xy, redrawn until at least 0.1 m from it); block 1 the same, redrawn
until it is also at least 0.1 m from block 0. Targets: on the table (z = the blocks'
resting height), each a uniform offset in [-0.15, 0.15]^2 from the gripper's start xy,
target 1 redrawn until at least 0.1 m from target 0. Horizon: 100 steps
(`max_episode_steps`, 50 per block as in those projects).
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import io
import os
import tempfile
import warnings
import xml.etree.ElementTree as ET

import numpy as np

with (
    contextlib.redirect_stdout(io.StringIO()),
    contextlib.redirect_stderr(io.StringIO()),
    warnings.catch_warnings(),
):
    warnings.simplefilter(
        "ignore"
    )  # gymnasium_robotics prints a notice about Adroit envs on import
    import gymnasium_robotics.envs.fetch as _fetch
    from gymnasium.utils.ezpickle import EzPickle
    from gymnasium_robotics.envs.fetch import MujocoFetchEnv
    from gymnasium_robotics.utils import rotations

ENV_ID = "FetchPushMultiStep-v0"
MAX_EPISODE_STEPS = 100
OBJECTS = ("object0", "object1")
"""Block names: body, geom and site are named so;
each block's free joint is `<name>:joint`."""
TARGETS = ("target0", "target1")
"""Target sites (bodies of the floor), one per block, in the same order."""
MIN_SPACING = 0.1
"""Metres (xy): each block at least this far from the gripper's start and from the other
block, and the two targets at least this far apart."""
OBJECT1_RGBA = "0.15 0.25 0.75 1"
TARGET1_RGBA = "0 0 1 1"

ASSETS = os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(_fetch.__file__))),
    "assets",
    "fetch",
)
"""The installed gymnasium-robotics assets folder of the Fetch tasks (push.xml,
shared.xml, robot.xml)."""


OBS_LAYOUT = (
    ("grip_pos", 3),
    ("object_pos", 6),
    ("object_rel_pos", 6),
    ("gripper_state", 2),
    ("object_rot", 6),
    ("object_velp", 6),
    ("object_velr", 6),
    ("grip_velp", 3),
    ("gripper_vel", 2),
)
"""The observation's fields in order with their sizes (40 in all); an object field holds
block 0's three numbers, then block 1's."""


def derived_xml(assets: str = ASSETS) -> str:
    """The MJCF text of the task: the installed `push.xml` with absolute asset paths, a
    second block `object1` after `object0` and a second target site `target1` after
    `target0`."""
    root = ET.parse(os.path.join(assets, "push.xml")).getroot()
    compiler = root.find("compiler")
    for attr in ("meshdir", "texturedir"):
        compiler.set(attr, os.path.normpath(os.path.join(assets, compiler.get(attr))))
    for inc in root.iter("include"):
        inc.set("file", os.path.join(assets, inc.get("file")))
    world = root.find("worldbody")

    floor = next(
        b for b in world.findall("body") if b.find("site[@name='target0']") is not None
    )
    target0 = floor.find("site[@name='target0']")
    target1 = copy.deepcopy(target0)
    target1.set("name", "target1")
    target1.set("rgba", TARGET1_RGBA)
    floor.insert(list(floor).index(target0) + 1, target1)

    object0 = world.find("body[@name='object0']")
    object1 = copy.deepcopy(object0)
    object1.set("name", "object1")
    object1.find("joint").set("name", "object1:joint")
    object1.find("geom").set("name", "object1")
    object1.find("geom").set(
        "rgba", OBJECT1_RGBA
    )  # a geom's rgba takes precedence over its material
    object1.find("site").set("name", "object1")
    object1.find("site").set("rgba", TARGET1_RGBA)
    world.insert(list(world).index(object0) + 1, object1)
    return ET.tostring(root, encoding="unicode")


def model_path(assets: str = ASSETS) -> str:
    """Write `derived_xml()` to the temp dir (once per content) and return the
    file's path."""
    text = derived_xml(assets)
    folder = os.path.join(
        tempfile.gettempdir(),
        f"acder_lite-{os.getuid() if hasattr(os, 'getuid') else 'user'}",
    )
    os.makedirs(folder, mode=0o700, exist_ok=True)
    path = os.path.join(
        folder,
        f"FetchPushMultiStep-{hashlib.sha256(text.encode()).hexdigest()[:16]}.xml",
    )
    if not os.path.exists(path):
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".xml.tmp")
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(
            tmp, path
        )  # atomic: a concurrent reader sees no file or the whole file
    return path


def block_distances(achieved_goal, desired_goal) -> np.ndarray:
    """Distance of each block to its own target, shape (..., 2),
    from 6-D goals (..., 6)."""
    a, d = np.asarray(achieved_goal), np.asarray(desired_goal)
    if a.shape != d.shape or a.shape[-1] != 3 * len(OBJECTS):
        raise ValueError(
            f"goals must both be (..., {3 * len(OBJECTS)}), got {a.shape} and {d.shape}"
        )
    diff = (a - d).reshape(a.shape[:-1] + (len(OBJECTS), 3))
    return np.linalg.norm(diff, axis=-1)


MOVED = 0.01
"""Metres: a block counts as moved in an episode (`block_shares`) when its position at
the last step is more than this from its position at step 0. Why 1 cm: a block the arm
never touches stays where it was to float32 rounding (under 1e-7 m), so any threshold
well above that separates touched from untouched; a graze moves a block millimetres,
a push centimetres (of the blocks a uniformly random arm touches, about one in ten
moves less than 1 cm and most move several cm; the scripted pusher of
`acder_lite.book.pusher` moves each block 15 to 30 cm, its distance to its target). No
clean gap separates the two, so 1 cm, a fifth of the 5 cm target radius, is the line:
a block that moved less was grazed, not pushed anywhere."""

BLOCK_COLUMNS = (
    "block0_on_target",
    "block1_on_target",
    "block0_moved",
    "block1_moved",
)
"""progress.csv's columns of this task at each evaluation (`block_shares`), so that a
test success still at 0 (both blocks) shows whether the agent put one block on its
target, moved the blocks, or did nothing."""
POOL_COLUMN = "pool_block_on_target"
"""progress.csv's column of this task for a method with a start-state pool: the share of
its stored candidates with at least one block on its target (`any_block_on_target`)."""


def any_block_on_target(achieved_goal, desired_goal, threshold: float) -> np.ndarray:
    """Whether at least one block is within `threshold` of its own target (`d <
    threshold`, the env's rule for one block), booleans of shape (...,) from 6-D goals
    (..., 6)."""
    return (block_distances(achieved_goal, desired_goal) < threshold).any(axis=-1)


def block_shares(ag, g, threshold: float, moved: float = MOVED) -> dict:
    """Per block, shares of n episodes (`BLOCK_COLUMNS`, floats; NaN for n = 0), from
    their achieved goals `ag` (n, T+1, 6) and goals `g` (n, T, 6) or (n, 6), as
    `train.rollout.run_episodes` returns them:

    - `block{i}_on_target`: block i within `threshold` of its own target at the last
      step (`d < threshold`, the env's rule for one block; an episode succeeds when
      both are);
    - `block{i}_moved`: block i's position at the last step more than `moved` (`MOVED`)
      from its position at step 0.

    Pure: reads the arrays only."""
    ag, g = np.asarray(ag), np.asarray(g)
    if ag.ndim != 3 or g.ndim not in (2, 3) or len(g) != len(ag):
        raise ValueError(
            f"block_shares: ag (n, T+1, 6) and g (n, T, 6) or (n, 6), "
            f"got {ag.shape} and {g.shape}"
        )
    n = len(ag)
    if n == 0:
        return {k: float("nan") for k in BLOCK_COLUMNS}
    last_g = g[:, -1] if g.ndim == 3 else g
    on = (block_distances(ag[:, -1], last_g) < threshold).mean(axis=0)
    mv = (block_distances(ag[:, -1], ag[:, 0]) > moved).mean(axis=0)
    out = {f"block{i}_on_target": float(on[i]) for i in range(len(OBJECTS))}
    out.update({f"block{i}_moved": float(mv[i]) for i in range(len(OBJECTS))})
    return {k: out[k] for k in BLOCK_COLUMNS}


class MujocoFetchPushMultiStepEnv(MujocoFetchEnv, EzPickle):
    """FetchPush with two blocks and two targets; see the module docstring."""

    n_objects = len(OBJECTS)

    def __init__(self, reward_type: str = "sparse", **kwargs):
        if reward_type not in ("sparse", "dense"):
            raise ValueError(
                f"reward_type={reward_type!r} is not allowed: 'sparse' or 'dense'"
            )
        initial_qpos = {
            "robot0:slide0": 0.405,
            "robot0:slide1": 0.48,
            "robot0:slide2": 0.0,
            "object0:joint": [1.25, 0.53, 0.4, 1.0, 0.0, 0.0, 0.0],  # FetchPush's
            "object1:joint": [
                1.25,
                0.97,
                0.4,
                1.0,
                0.0,
                0.0,
                0.0,
            ],  # its mirror in y about the gripper
        }
        MujocoFetchEnv.__init__(
            self,
            model_path=model_path(),
            has_object=True,
            block_gripper=True,
            n_substeps=20,
            gripper_extra_height=0.0,
            target_in_the_air=False,
            target_offset=0.0,
            obj_range=0.15,
            target_range=0.15,
            distance_threshold=0.05,
            initial_qpos=initial_qpos,
            reward_type=reward_type,
            **kwargs,
        )
        EzPickle.__init__(self, reward_type=reward_type, **kwargs)

    # --- GoalEnv: both blocks must be on their targets
    def compute_reward(self, achieved_goal, goal, info):
        """-1 unless both blocks are within distance_threshold of their targets, else 0
        (sparse); dense: minus the sum of the two distances. Vectorised over leading
        axes of (..., 6) goals."""
        d = block_distances(achieved_goal, goal)
        if self.reward_type == "sparse":
            return -np.any(d > self.distance_threshold, axis=-1).astype(np.float32)
        return -d.sum(axis=-1)

    def _is_success(self, achieved_goal, desired_goal):
        d = block_distances(achieved_goal, desired_goal)
        return np.all(d < self.distance_threshold, axis=-1).astype(np.float32)

    # --- observation: FetchPush's fields, each object field for both blocks
    def generate_mujoco_observations(self):
        u, m, d = self._utils, self.model, self.data
        grip_pos = u.get_site_xpos(m, d, "robot0:grip")
        dt = self.n_substeps * m.opt.timestep
        grip_velp = u.get_site_xvelp(m, d, "robot0:grip") * dt
        robot_qpos, robot_qvel = u.robot_get_obs(m, d, self._model_names.joint_names)
        pos = np.stack([u.get_site_xpos(m, d, name) for name in OBJECTS])
        rot = np.stack(
            [rotations.mat2euler(u.get_site_xmat(m, d, name)) for name in OBJECTS]
        )
        velp = (
            np.stack([u.get_site_xvelp(m, d, name) * dt for name in OBJECTS])
            - grip_velp
        )
        velr = np.stack([u.get_site_xvelr(m, d, name) * dt for name in OBJECTS])
        rel_pos = pos - grip_pos
        gripper_state = robot_qpos[-2:]
        gripper_vel = robot_qvel[-2:] * dt
        return (
            grip_pos,
            pos,
            rel_pos,
            gripper_state,
            rot,
            velp,
            velr,
            grip_velp,
            gripper_vel,
        )

    def _get_obs(self):
        obs = (
            super()._get_obs()
        )  # gymnasium-robotics' order; ravel() puts block 0 before block 1
        obs["achieved_goal"] = obs["achieved_goal"].reshape(-1)
        return obs

    # --- reset
    def _reset_sim(self):
        super()._reset_sim()  # FetchPush's reset: places block 0 (its rule, its draws)
        grip = self.initial_gripper_xpos[:2]
        xy0 = self._utils.get_joint_qpos(self.model, self.data, "object0:joint")[:2]
        xy1 = grip
        while (
            np.linalg.norm(xy1 - grip) < MIN_SPACING
            or np.linalg.norm(xy1 - xy0) < MIN_SPACING
        ):
            xy1 = grip + self.np_random.uniform(-self.obj_range, self.obj_range, size=2)
        qpos = self._utils.get_joint_qpos(self.model, self.data, "object1:joint")
        qpos[:2] = xy1
        self._utils.set_joint_qpos(self.model, self.data, "object1:joint", qpos)
        self._mujoco.mj_forward(self.model, self.data)
        return True

    def _sample_goal(self):
        grip = self.initial_gripper_xpos[:2]
        draw = lambda: (
            grip + self.np_random.uniform(-self.target_range, self.target_range, size=2)
        )
        t0 = draw()
        t1 = draw()
        while np.linalg.norm(t1 - t0) < MIN_SPACING:
            t1 = draw()
        h = self.height_offset
        return np.array([t0[0], t0[1], h, t1[0], t1[1], h])

    def _render_callback(self):
        # Each target site is a child of the floor body: its model pos is the goal minus
        # the body's offset (the site's world pos minus its model pos).
        offsets = self.data.site_xpos - self.model.site_pos
        for i, name in enumerate(TARGETS):
            sid = self._mujoco.mj_name2id(
                self.model, self._mujoco.mjtObj.mjOBJ_SITE, name
            )
            self.model.site_pos[sid] = self.goal[3 * i : 3 * i + 3] - offsets[sid]
        self._mujoco.mj_forward(self.model, self.data)
