"""The Fetch tasks: construction, seeding, and saving/restoring the full MuJoCo state.

We step the unwrapped MuJoCo env and count the task's horizon ourselves (`horizon`: 50
steps, 100 on FetchPushMultiStep-v0; as Baselines' rollout worker does), which skips
gymnasium's checker wrappers on the hot path.
"""

from __future__ import annotations

import contextlib
import io
import warnings

import mujoco
import numpy as np

from acder_lite.config import ENV_IDS, ConfigError
from acder_lite.envs.observations import obs_names  # noqa: F401  (envs.obs_names, as before)

_S = mujoco.mjtState
STATE_SPEC = int(
    _S.mjSTATE_FULLPHYSICS
    | _S.mjSTATE_WARMSTART
    | _S.mjSTATE_CTRL
    | _S.mjSTATE_EQ_ACTIVE
    | _S.mjSTATE_MOCAP_POS
    | _S.mjSTATE_MOCAP_QUAT
)
"""What a stored state holds: mjSTATE_FULLPHYSICS (time, qpos, qvel, act, history,
plugin state) plus the solver warm start, ctrl, the mocap pose and active equality
constraints. FULLPHYSICS alone is not enough (departure 17 lists the same parts):
without the warm start the solver starts from another guess and a restored rollout
drifts, by 1e-15 to 1e-11 within 20-40 steps depending on the task and MuJoCo's version
(the book's engineering appendix measures it); with it they match bit for bit.
The mocap pose and ctrl cost 7 numbers and keep restores exact for models that do not
re-anchor the mocap every step. The rest of mjSTATE_INTEGRATION (applied forces, 219 of
its 292 numbers on FetchPush) is always zero in these tasks and is left out: 73 numbers
a step on FetchPush (`mujoco.mj_stateSize(model, STATE_SPEC)`)."""


def _import_robotics():
    import gymnasium as gym

    # gymnasium_robotics prints a notice about Adroit envs on import;
    # it concerns none of ours.
    with (
        contextlib.redirect_stdout(io.StringIO()),
        contextlib.redirect_stderr(io.StringIO()),
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")
        import gymnasium_robotics

        gym.register_envs(gymnasium_robotics)
    return gym


def _spec(env_id: str):
    """gymnasium's spec of `env_id`, or ConfigError saying it is not registered.

    Trap: an id added to `config.ENV_IDS` passes the config's check, but gymnasium
    only knows it once something registers it (as importing acder_lite registers
    FetchPushMultiStep-v0); without this, gymnasium's NameNotFound traceback is
    what a user sees."""
    gym = _import_robotics()
    try:
        return gym.spec(env_id)
    except gym.error.UnregisteredEnv as e:
        raise ConfigError(
            f"env={env_id!r} is not registered with gymnasium ({e}): register it "
            "with gymnasium.register before making it (the book's 'Using acder_lite', "
            "'Extending it')"
        ) from None


def run_env_seeds(seed: int, workers: int, test: bool = False) -> list[int]:
    """The seeds of a run's W training envs (`seed * 1000 + i`) or of its W test envs
    (`seed * 1000 + 500 + i`): `Trainer` makes its envs with these, and a run's test
    episodes are replayed from them (`book.pusher.solved_test_starts`). Trap: past 500
    workers a training env would share its seed with a test env, and past 1000 with
    the next seed's run."""
    return [seed * 1000 + (500 if test else 0) + i for i in range(workers)]


def make_env(
    env_id: str, seed: int | None = None, obs: str = "full", fast: bool = True
):
    """Build a goal-based Fetch env (the unwrapped MuJoCo env) and seed it.

    `obs` is the observation set it gives (`Config.obs`): "full" (the env as
    gymnasium-robotics makes it) or "simplified" (the paper's section V-E state,
    `acder_lite.envs.observations`). Raises ConfigError for an id that is not a known
    Fetch task or whose observation is not the goal-based dict (observation,
    achieved_goal, desired_goal), or for an unknown `obs`.

    `fast` (the default) puts `acder_lite.envs.fastobs`' methods on the env: `_get_obs`,
    `_set_action` and `_step_callback` without gymnasium-robotics' per-call name
    lookups, the same float64 numbers bit for bit; `fast=False` keeps the env's own
    (the reference `tests/test_fast_env.py` compares against).
    """
    if (
        obs != "full"
    ):  # checked before the (slow) make; "full" takes the path it always took
        from acder_lite.envs.observations import check_obs

        check_obs(obs)
    if env_id not in ENV_IDS:
        raise ConfigError(f"env={env_id!r} is not allowed: one of {', '.join(ENV_IDS)}")
    _spec(env_id)  # an unregistered id: one line, not gymnasium's traceback
    gym = _import_robotics()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make(env_id)
    space = env.observation_space
    keys = set(getattr(space, "spaces", {}) or {})
    if not {"observation", "achieved_goal", "desired_goal"} <= keys:
        raise ConfigError(
            f"env={env_id!r} has no goal-based dict observation "
            "(needs observation, achieved_goal, desired_goal)"
        )
    env = env.unwrapped
    if fast:  # before the first reset, so it too reads the fast _get_obs
        from acder_lite.envs.fastobs import install

        install(env)
    env.reset(seed=seed)
    if obs != "full":
        from acder_lite.envs.observations import select

        select(env, obs)
    return env


def horizon(env_id: str) -> int:
    """Steps per episode (the registered time limit: 50 for gymnasium-robotics' Fetch
    tasks, 100 for FetchPushMultiStep-v0, registered by importing acder_lite)."""
    return int(_spec(env_id).max_episode_steps)


def goal_names(env) -> list[str]:
    """A name for each entry of the goal: goal.x/y/z, or goal0.x ... goal1.z for the two
    blocks of FetchPushMultiStep-v0 (block 0's target, then block 1's)."""
    n = observe(env)["desired_goal"].size
    if n == 3:
        return [f"goal.{c}" for c in "xyz"]
    return [f"goal{i}.{c}" for i in range(n // 3) for c in "xyz"]


def state_size(env, spec: int = STATE_SPEC) -> int:
    """Numbers in a stored state of `spec` (`mj_stateSize`; default `STATE_SPEC`)."""
    return int(mujoco.mj_stateSize(env.model, spec))


def get_state(env, out: np.ndarray | None = None, spec: int = STATE_SPEC) -> np.ndarray:
    """The full physics state (float64), `mj_getState(..., STATE_SPEC)`.

    `spec` picks other MuJoCo state components (an `mjtState` bit mask, e.g.
    `mjSTATE_FULLPHYSICS`; the book's appendix compares them); training always uses
    the default. Set such a state back with the same `spec`."""
    if out is None:
        out = np.empty(state_size(env, spec), dtype=np.float64)
    mujoco.mj_getState(env.model, env.data, out, spec)
    return out


def set_state(env, state: np.ndarray, spec: int = STATE_SPEC) -> None:
    """Write a stored full physics state back and recompute derived quantities
    (`mj_forward`). `spec` is the one `get_state` stored it with (default
    `STATE_SPEC`)."""
    mujoco.mj_setState(env.model, env.data, np.asarray(state, dtype=np.float64), spec)
    mujoco.mj_forward(env.model, env.data)


def site_positions(
    env, states: np.ndarray, sites, spec: int = STATE_SPEC
) -> np.ndarray:
    """World positions of the named `sites` in stored states (k, state_size) of `env`'s
    model, float64 of shape (k, len(sites), 3), without the env: each state is written
    into a scratch `MjData` and only its kinematics computed (`mj_kinematics`), so no
    env's data, random stream or model changes. An object site's position is the
    achieved goal the env gives in that state (`observe` after `set_state`)."""
    m = env.model
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, s) for s in sites]
    if min(ids, default=0) < 0:
        raise ValueError(
            f"site_positions: {list(sites)} are not all sites of the model"
        )
    data = mujoco.MjData(m)
    states = np.asarray(states, dtype=np.float64)
    out = np.empty((len(states), len(ids), 3))
    for k, s in enumerate(states):
        mujoco.mj_setState(m, data, s, spec)
        mujoco.mj_kinematics(m, data)
        out[k] = data.site_xpos[ids]
    return out


def observe(env) -> dict:
    """The observation dict (observation, achieved_goal, desired_goal) of the env's
    current state, without stepping: gymnasium-robotics' `_get_obs`, the one private
    method of the env the rest of the package needs, named once here."""
    return env._get_obs()


def restart_from(env, state: np.ndarray, goal: np.ndarray | None = None) -> dict:
    """Start a new episode from a stored state (departures 16-18, Eq. 9).

    `env.reset()` first, so the episode counter and the goal are fresh
    (`restart_goal="resample"`); then the stored state is written. Pass `goal` to keep a
    stored goal (`"episode"`).
    """
    env.reset()
    set_state(env, state)
    if goal is not None:
        env.goal = np.array(goal, dtype=np.float64)
    return observe(env)


def step(env, action: np.ndarray) -> tuple[dict, bool]:
    """One env step; returns (observation dict, is_success).

    The env's own `step` with one change: `mj_forward` after the physics step. MuJoCo's
    `mj_step` leaves positions (xpos, site_xpos) computed for the state one substep
    *before* the new qpos, so the standard Fetch observation, and the next action's
    mocap target (which starts from the gripper's xpos), lag one substep (1/20 of a
    step) behind the state. A stored state cannot reproduce that lag, so restored
    rollouts would drift (measured: 8e-4 m in 20 steps on FetchPickAndPlace). With
    kinematics refreshed after every step, the observation is a function of the state
    and a restored state reproduces a rollout bit for bit. Reward and success are
    unchanged in definition (5 cm rule).
    """
    action = np.clip(action, env.action_space.low, env.action_space.high)
    env._set_action(action)
    env._mujoco_step(action)
    env._step_callback()
    mujoco.mj_forward(env.model, env.data)
    obs = env._get_obs()
    return obs, bool(env._is_success(obs["achieved_goal"], env.goal))


def successes(env, achieved_goal: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """The env's own success rule (the 5 cm rule; both blocks on the multi-step task)
    over any leading axes of goals, as booleans."""
    return np.asarray(env._is_success(achieved_goal, goal)) > 0


def scripted_grasp(obs: np.ndarray, t: int) -> np.ndarray:
    """A grasp-and-lift controller for a block task (Push, Pick&Place), step `t` of it:
    open fingers above the block (12 steps), down to it (8), close (5), then lift.
    Proportional on the block's position relative to the gripper (`obs[6:9]`), the
    displacement x 10 clipped to the action's [-1, 1]."""
    rel = obs[6:9]
    if t < 12:
        target, fingers = rel + np.array([0.0, 0.0, 0.06]), 1.0
    elif t < 20:
        target, fingers = rel, 1.0
    elif t < 25:
        target, fingers = rel, -1.0
    else:
        target, fingers = np.array([0.0, 0.0, 0.08]), -1.0
    return np.append(np.clip(target * 10, -1, 1), fingers)


def replay_difference(
    env_id: str = "FetchPickAndPlace-v4",
    spec: int = STATE_SPEC,
    gymnasium_step: bool = False,
    steps: int = 40,
    warmup: int = 10,
    seed: int = 0,
) -> tuple[np.ndarray, int]:
    """How exactly a stored state replays: `warmup` random steps, store the state
    (`get_state` with `spec`), take `steps` actions of `scripted_grasp` (with the
    defaults the fingers touch the block from step 21 on and lift it), restore the
    state in the same env and take the same actions again (replayed as recorded, not
    recomputed).

    Returns the largest |difference| of the observation at each replayed step (zeros:
    bit for bit) and the stored state's size. `gymnasium_step` steps with the env's
    own `env.step` instead of ours (`step`), whose kinematics lag a substep behind.
    The engineering appendix compares `STATE_SPEC` with `mjSTATE_FULLPHYSICS` and the
    two steps.
    """
    env = make_env(env_id, seed=seed)
    rng = np.random.default_rng(seed)

    def obs_after(a):
        return (env.step(a) if gymnasium_step else step(env, a))[0]["observation"]

    obs = env._get_obs()["observation"]
    for _ in range(warmup):
        obs = obs_after(rng.uniform(-1, 1, 4))
    state = get_state(env, spec=spec)
    actions, original = [], []
    for t in range(steps):
        actions.append(scripted_grasp(obs, t))
        obs = obs_after(actions[-1])
        original.append(obs)
    set_state(env, state, spec=spec)  # and mj_forward, as every restore
    restored = np.array([obs_after(a) for a in actions])
    return np.abs(restored - np.array(original)).max(axis=1), state.size


def env_rng_state(env) -> dict:
    return env.np_random.bit_generator.state


def set_env_rng_state(env, state: dict) -> None:
    env.np_random.bit_generator.state = state


def policy_env(policy: dict, path: str, seed: int | None = None):
    """The env a policy dict runs in: its task, made with the observation set it was
    trained on, its sizes checked against the policy's (`io.check_policy_fits`:
    CheckpointError, one line, naming `path`). The caller closes it."""
    from acder_lite.envs.observations import policy_obs
    from acder_lite.io import check_policy_fits

    env = make_env(policy["env"], seed=seed, obs=policy_obs(policy))
    first = observe(env)
    try:
        check_policy_fits(
            policy,
            path,
            first["observation"].size,
            first["desired_goal"].size,
            env.action_space.shape[0],
        )
    except Exception:
        env.close()
        raise
    return env
