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


PUSH_BEHIND = 0.065
"""Scripted pusher: the gripper centre's distance behind the block centre while pushing
(half a block and the fingers)."""
PUSH_LIFT = 0.07
"""Scripted pusher: height above the blocks while moving round one."""
PUSH_DONE = 0.02
"""Scripted pusher: a block within this distance (metres, in xy) of its target is left
alone; the pusher takes the first block farther than this."""


def scripted_push(o: np.ndarray, g: np.ndarray, height_offset: float) -> np.ndarray:
    """One action of a scripted pusher (nothing learnt), for one observation vector `o`
    (40) and goal `g` (6), re-planned every step: take the first block more than
    `PUSH_DONE` from its target, get behind it on the line target -> block (flying
    above the blocks whenever it moves to a new spot), lower to the block's height
    (`height_offset`, the env's), push; then the other block. It shows the task can be
    solved in 100 steps (tests/test_multistep.py, chapter 9)."""
    # the full observation only, not a selection
    if o.shape != (40,) or g.shape != (6,):
        raise ValueError(f"scripted_push: o (40,) and g (6,), got {o.shape}, {g.shape}")
    grip = o[:3]
    ag, g = o[3:9].reshape(2, 3), g.reshape(2, 3)  # object{0,1}_pos (OBS_LAYOUT)
    todo = [i for i in range(2) if np.linalg.norm(ag[i, :2] - g[i, :2]) > PUSH_DONE]
    a = np.zeros(4)
    if not todo:
        return a
    b, t = ag[todo[0], :2], g[todo[0], :2]
    u = (t - b) / max(np.linalg.norm(t - b), 1e-9)
    rel = grip[:2] - b
    along = rel @ u
    perp = np.linalg.norm(rel - along * u)
    h, behind = height_offset, b - PUSH_BEHIND * u
    low = h - 0.005
    if along < -0.035 and perp < 0.012 and grip[2] < low + 0.02:  # in place: push
        off_line = behind - grip[:2]  # ... and stay on the line
        a[:2] = (t - (PUSH_BEHIND - 0.02) * u - grip[:2]) * 10
        a[:2] += off_line - (off_line @ u) * u
        a[2] = (low - grip[2]) * 10
    elif np.linalg.norm(grip[:2] - behind) < 0.01:  # above the spot: lower
        a[:2], a[2] = (behind - grip[:2]) * 10, (low - grip[2]) * 10
    elif grip[2] < h + PUSH_LIFT - 0.02:  # lift (first clear of the blocks)
        near = np.linalg.norm(ag[:, :2] - grip[:2], axis=1).min() < 0.07
        a[:2], a[2] = (0.0 if near else (behind - grip[:2]) * 10), 1.0
    else:  # fly to the spot
        a[:2], a[2] = (behind - grip[:2]) * 10, (h + PUSH_LIFT - grip[2]) * 10
    return np.clip(a, -1, 1)


def scripted_pusher(height_offset: float):
    """`scripted_push` as a policy of batched (o, g), as `rollout.run_episodes` and
    `viz.record_rollout` call one: (W, 40), (W, 6) -> (W, 4)."""
    return lambda o, g: np.stack(
        [scripted_push(oi, gi, height_offset) for oi, gi in zip(o, g)]
    )


def pusher_successes(seeds, horizon: int = MAX_EPISODE_STEPS) -> np.ndarray:
    """Whether the scripted pusher (`scripted_pusher`) has both blocks on their targets
    at the last step, one bool per seed: the first `rollout.run_episodes` episode of an
    env made with that seed. Chapter 9's evidence that the task is solvable."""
    from .envs import make_env
    from .rollout import run_episodes

    envs = [make_env(ENV_ID, seed=s) for s in seeds]
    ep = run_episodes(envs, scripted_pusher(envs[0].height_offset), horizon)
    for e in envs:
        e.close()
    return ep["success"]


def random_counts(episodes: int, seed: int = 0, workers: int = 4) -> dict:
    """A uniformly random arm's episodes (rounded down to a multiple of `workers`),
    stepped as training steps them: dict(episodes, success = the share with both blocks
    on their targets at the last step, one = the share with at least one there, and
    n_success, n_one: the same as counts of episodes)."""
    from .envs import make_env
    from .rollout import run_episodes

    rng = np.random.default_rng(seed)
    envs = [make_env(ENV_ID, seed=100 + i) for i in range(workers)]
    threshold = envs[0].distance_threshold
    succ, one = [], []
    act = lambda o, g: rng.uniform(-1.0, 1.0, (len(o), 4))  # noqa: E731
    for _ in range(episodes // workers):
        ep = run_episodes(envs, act, MAX_EPISODE_STEPS)
        succ.append(ep["success"])
        last = block_distances(ep["ag"][:, -1], ep["g"][:, -1])
        one.append((last < threshold).any(axis=1))
    for e in envs:
        e.close()
    succ, one = np.concatenate(succ), np.concatenate(one)
    return dict(
        episodes=succ.size,
        success=succ.mean(),
        one=one.mean(),
        n_success=int(succ.sum()),
        n_one=int(one.sum()),
    )


def start_on_targets(seeds, resets: int) -> dict:
    """Which episodes start already solved: for an env made with each seed of `seeds`
    (`envs.make_env`, whose seeding reset is not counted), `resets` further resets, no
    step. dict(both: both blocks within distance_threshold of their targets at reset,
    the env's own success rule `envs.successes`; one: at least one block so), bool
    arrays (resets, len(seeds)) in reset order.

    A policy that never moves a block succeeds on the `both` episodes and on no other:
    the chance level of test success (chapter 9)."""
    from .envs import make_env, successes

    envs = [make_env(ENV_ID, seed=s) for s in seeds]
    both = np.zeros((resets, len(envs)), bool)
    one = np.zeros_like(both)
    for t in range(resets):
        for i, env in enumerate(envs):
            obs, _ = env.reset()
            ag, g = obs["achieved_goal"], obs["desired_goal"]
            both[t, i] = successes(env, ag, g)
            one[t, i] = (block_distances(ag, g) < env.distance_threshold).any()
    for env in envs:
        env.close()
    return dict(both=both, one=one)


def solved_test_starts(config: dict, evaluations: int) -> np.ndarray:
    """For a run of this task with `config` (config.json's "config": seed, workers,
    test_episodes), how many of each evaluation's test episodes start with both blocks
    on their targets, for its first `evaluations` evaluations (`Trainer.evaluate`
    resets each test env `test_episodes` times per evaluation, and nothing else draws
    from their random streams). Shape (evaluations,)."""
    from .envs import run_env_seeds

    seeds = run_env_seeds(config["seed"], config["workers"], test=True)
    both = start_on_targets(seeds, evaluations * config["test_episodes"])["both"]
    return both.reshape(evaluations, -1).sum(axis=1)


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
