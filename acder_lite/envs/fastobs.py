"""The Fetch env's per-step Python without name lookups (issue 17): the same numbers.

gymnasium-robotics' `_get_obs` looks every joint and site up by name on every call
(`mujoco_utils.robot_get_obs` alone reads all 15 robot joints' qpos and qvel by name, to
keep the last two), and `_set_action` / `_step_callback` split and loop in numpy: about
half of `step` is Python. `install(env)` (called by `envs.make_env`) resolves the ids
and addresses once and puts three methods on that env instance, `_get_obs`,
`_set_action` and `_step_callback`, so every caller (gymnasium's reset and step,
`envs.step`, `envs.restart_from`, `observations.select`) gets them. The env's own
methods stay reachable as class methods, `type(env)._get_obs(env)`; `env.fast_methods`
names the installed ones.

**The same float64 numbers, bit for bit.** Each installed method does the arithmetic
gymnasium-robotics does, in the same order, on the same dtypes; only *where the numbers
are found* is cached. Elementwise IEEE operations (+, -, x dt, the float32 `x 0.05` of a
float32 action, upcasts) give the same bits however they are grouped, so they are free
to move; everything that is not elementwise is called exactly as gymnasium-robotics
calls it: the site velocity is `(jac @ qvel) * dt` with a fresh (3, nv) Jacobian from
`mj_jacSite` (the same BLAS call, so the same summation order; an object's jacp and
jacr come from one call where gymnasium-robotics makes two, which MuJoCo fills with the
same numbers), the rotation is
`rotations.mat2euler` of that one site's (3, 3) matrix, `dt` is `n_substeps *
model.opt.timestep` computed on each call. The ctrl of a position actuator is still
`qpos + action` (with a blocked gripper the action is 0.0, and -0.0 + 0.0 is +0.0, not a
copy). `tests/test_fast_env.py` compares every array against the class methods with
`np.array_equal`; tiny seeded training runs of every method, made before and after,
matched bit for bit (progress.csv and policy.pt).

**The trap it avoids.** `data.site_xpos[i]` is a *view* into MuJoCo's memory: the
gripper position gymnasium-robotics returns is a copy (`concatenate`, `.copy()`), and
so is every array here (the observation is a fresh `concatenate`, the achieved goal a
copy, the desired goal `goal.copy()`). Returning a view would silently rewrite stored
observations and goals on the next step.

Only the classes whose methods are replicated here get the fast methods (the four
gymnasium-robotics Fetch tasks and `multistep.MujocoFetchPushMultiStepEnv`), each method
checked on its own; any other class, or a model that does not fit the assumptions (all
robot joints 1-D, one mocap body), keeps its own methods.
"""

from __future__ import annotations

import mujoco
import numpy as np

_ROT_CTRL = [1.0, 0.0, 1.0, 0.0]
"""The fixed end-effector rotation (a quaternion delta) of gymnasium-robotics'
`_set_action`."""
_FINGERS = ("robot0:l_gripper_finger_joint", "robot0:r_gripper_finger_joint")


def _fetch_classes():
    from gymnasium_robotics.envs.fetch.fetch_env import MujocoFetchEnv

    from acder_lite.envs.multistep import OBJECTS, MujocoFetchPushMultiStepEnv as Multi

    return MujocoFetchEnv, Multi, OBJECTS


def _objects(env) -> list[str] | None:
    """The object sites the observation reads, in order, or None if this class's
    observation is not one replicated here."""
    Fetch, Multi, objects = _fetch_classes()
    cls = type(env)
    if cls._get_obs is Multi._get_obs and (
        cls.generate_mujoco_observations is Multi.generate_mujoco_observations
    ):
        return list(objects)
    if cls._get_obs is Fetch._get_obs and (
        cls.generate_mujoco_observations is Fetch.generate_mujoco_observations
    ):
        return ["object0"] if env.has_object else []
    return None


def _fast_get_obs(env, objects: list[str]):
    m = env.model
    site = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, n)
    grip, objs = site("robot0:grip"), [site(n) for n in objects]
    robot = [n for n in env._model_names.joint_names if n.startswith("robot")]
    jids = [env._model_names.joint_name2id[n] for n in robot]
    one_d = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
    if min([grip, *objs]) < 0 or len(jids) < 2:
        return None
    if any(int(m.jnt_type[j]) not in one_d for j in jids):
        return None  # robot_get_obs's squeeze would not give one entry per joint
    # robot_qpos[-2:] / robot_qvel[-2:]: the last two robot joints (the fingers)
    qadr = np.array([m.jnt_qposadr[j] for j in jids[-2:]])
    vadr = np.array([m.jnt_dofadr[j] for j in jids[-2:]])
    from gymnasium_robotics.utils.rotations import mat2euler

    multi = len(objects) > 1

    def _get_obs():
        m, d = env.model, env.data
        nv, qvel = m.nv, d.qvel
        dt = env.n_substeps * m.opt.timestep
        jac = np.zeros((3, nv))
        mujoco.mj_jacSite(m, d, jac, None, grip)
        grip_velp = (jac @ qvel) * dt
        grip_pos = d.site_xpos[grip]  # a view: only read, never returned
        parts = [grip_pos]
        if objs:
            pos, rel, rot, velp, velr = [], [], [], [], []
            for s in objs:
                p = d.site_xpos[s]
                jacp, jacr = np.zeros((3, nv)), np.zeros((3, nv))
                mujoco.mj_jacSite(m, d, jacp, jacr, s)
                pos.append(p)
                rel.append(p - grip_pos)
                rot.append(mat2euler(d.site_xmat[s].reshape(3, 3)))
                velp.append((jacp @ qvel) * dt - grip_velp)
                velr.append((jacr @ qvel) * dt)
            parts += pos
            parts += rel
            parts.append(d.qpos[qadr])
            parts += rot
            parts += velp
            parts += velr
            # a fresh array: (3,) for one object (np.squeeze), (3k,) for k objects
            achieved = np.concatenate(pos) if multi else pos[0].copy()
        else:
            parts.append(d.qpos[qadr])
            achieved = grip_pos.copy()
        parts += [grip_velp, qvel[vadr] * dt]
        return {
            "observation": np.concatenate(parts),
            "achieved_goal": achieved,
            "desired_goal": env.goal.copy(),
        }

    return _get_obs


def _fast_set_action(env):
    m = env.model
    if m.nmocap != 1 or 0 < m.nu < 2:
        return None  # gymnasium-robotics' reshape / ctrl loop would not fit either
    # ctrl_set_action: actuators 0 and 1 (the fingers), a position actuator relative
    # to its joint's qpos
    ctrl = []
    if m.nu:
        for i in range(2):
            rel = m.actuator_biastype[i] != 0
            ctrl.append((i, int(m.jnt_qposadr[m.actuator_trnid[i, 0]]) if rel else -1))
    # reset_mocap2body_xpos: every weld, in the model's order
    welds = []
    for eq_type, a, b in zip(m.eq_type, m.eq_obj1id, m.eq_obj2id):
        if eq_type != mujoco.mjtEq.mjEQ_WELD:
            continue
        mocap, body = m.body_mocapid[a], b
        if mocap == -1:
            mocap, body = m.body_mocapid[b], a
        if mocap == -1:
            return None
        welds.append((int(mocap), int(body)))

    def _set_action(action):
        assert action.shape == (4,)
        action = action.copy()
        pos_ctrl, g = action[:3], action[3]
        pos_ctrl *= 0.05  # in the action's dtype, as gymnasium-robotics does
        gripper = np.array([g, g])
        if env.block_gripper:
            gripper = np.zeros_like(gripper)
        u = np.concatenate([pos_ctrl, _ROT_CTRL, gripper])
        d = env.data
        for i, adr in ctrl:
            d.ctrl[i] = u[7 + i] if adr < 0 else d.qpos[adr] + u[7 + i]
        for mocap, body in welds:
            d.mocap_pos[mocap][:] = d.xpos[body]
            d.mocap_quat[mocap][:] = d.xquat[body]
        d.mocap_pos[:] = d.mocap_pos + u[:3]
        d.mocap_quat[:] = d.mocap_quat + u[3:7]

    return _set_action


def _fast_step_callback(env):
    m = env.model
    jids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in _FINGERS]
    if min(jids) < 0:
        return None
    left, right = (int(m.jnt_qposadr[j]) for j in jids)

    def _step_callback():
        if env.block_gripper:
            d = env.data
            d.qpos[left] = 0.0
            d.qpos[right] = 0.0
            mujoco.mj_forward(env.model, d)

    return _step_callback


def install(env):
    """Put the fast `_get_obs`, `_set_action` and `_step_callback` on `env` (a freshly
    made, unwrapped Fetch env), each only where its class's method is gymnasium-
    robotics' (or multistep's) own; returns `env`. `env.fast_methods`: the names
    installed. Call it before `observations.select`, which wraps `_get_obs`."""
    if getattr(env, "obs_index", None) is not None or "_get_obs" in vars(env):
        raise RuntimeError(
            "fastobs.install: the env's _get_obs is already replaced (an observation "
            "set?); install first, then observations.select"
        )
    Fetch, _, _ = _fetch_classes()
    cls = type(env)
    objects = _objects(env)
    built = {
        "_get_obs": None if objects is None else _fast_get_obs(env, objects),
        "_set_action": (
            _fast_set_action(env) if cls._set_action is Fetch._set_action else None
        ),
        "_step_callback": (
            _fast_step_callback(env)
            if cls._step_callback is Fetch._step_callback
            else None
        ),
    }
    for name, fast in built.items():
        if fast is not None:
            setattr(env, name, fast)
    env.fast_methods = tuple(name for name, fast in built.items() if fast is not None)
    return env
