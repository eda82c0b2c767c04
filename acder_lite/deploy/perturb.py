"""What a robot's world can get wrong, and how the simulator is changed to match

The perturbations of the robustness bench (`robust`), each one thing a real arm brings
that the simulator does not. `KNOBS` lists them; `parse_perturb` reads `--perturb
NAME=L1,L2,...` (default: every knob that applies to the task, at `Knob.levels`).
`Perturbed` wraps a policy's `act(o, g)` for the knobs on what it is shown and what it
does; `scaled_model` changes the MuJoCo model for the others (friction, mass).

- `obs_noise` (m): the camera's error on each block's position. Every step each block
  gets a fresh draw n_t ~ N(0, s^2 I_3), independent across steps, blocks and trials,
  and every entry the robot would compute from that measurement carries it:
  object_pos + n_t and object_rel_pos + n_t (the gripper's position comes from the
  arm's joint encoders and stays exact), and, for a full-state policy,
  object_velp + (n_t - n_{t-1}): Fetch's object_velp is the block's displacement in one
  step relative to the gripper's, which a robot gets as the difference of two camera
  frames (n_{-1} is drawn like the others). Rotations and angular velocities stay exact:
  a colour-blob camera gives none, so a full-state policy is flattered here (and could
  not run on the paper's robot at all). Reach has no block: the knob does not apply.
- `goal_noise` (m): the camera's error on the target(s) (the paper's goals also come
  from colour recognition): every step the goal the policy sees is the true one +
  N(0, s^2 I); success is judged on the true goal.
- `action_delay` (steps): the action computed from the observation of step t is applied
  at step t + d; the first d steps apply the zero action (Fetch's action is a
  displacement, so the arm holds still and the fingers keep their position).
- `action_scale` (factor): the arm moves `scale` x the commanded end-effector
  displacement (the first three action components; the gripper command is not scaled);
  then the env's clip to [-1, 1] applies, so above 1 it saturates at the controller's
  5 cm a step.
- `friction` (factor): the sliding friction of the table top and of every block x scale.
  Trap: MuJoCo gives a contact the larger of its two geoms' coefficients, so scaling the
  table alone would not lower the block-table friction; with both scaled it is exactly
  scale x 1.0. The finger-block contact (fingers at 1.0) is unchanged below 1 and scaled
  above. On Reach (no block) it scales the table alone, which nothing touches unless the
  gripper is pushed into it.
- `mass` (factor): every block's mass and inertia x scale (the same shape in a denser
  material); `mj_setConst` then recomputes what MuJoCo derives from them. Reach: does
  not apply.

Every model field a knob changes, and every one `mj_setConst` derives, is restored bit
for bit after its level (`scaled_model`): the env then steps as a freshly made one.
"""

from __future__ import annotations

import contextlib
import math
import re
from collections import deque
from dataclasses import dataclass

import mujoco
import numpy as np

from acder_lite.envs import fetch as E
from acder_lite.config import OBJECT_ENVS, ConfigError
from acder_lite.envs.observations import indices


@dataclass(frozen=True)
class Knob:
    """One perturbation: its unit, its nominal (unperturbed) level, its default levels,
    what a level may be, and whether it needs a task with a block."""

    name: str
    unit: str
    nominal: float
    levels: tuple
    allowed: str
    integer: bool = False
    positive: bool = False
    needs_object: bool = False
    doc: str = ""
    without_block: str = ""
    """What the knob does on a task without a block (Reach), where that is less than
    `doc` says ("" if the same, or if it `needs_object`)."""
    drawn: bool = False
    """Its level scales the bench's noise draws, which are made for all the trials at
    once ((W, K, 3) a step): above 0, trial i's outcome depends on the trial count."""
    most: float = math.inf
    """The largest level: a metre of camera error (past the size of the table) or a
    factor of 100, far past any real arm. Trap: 1e308 was taken, and MuJoCo's
    simulation went unstable ("Nan, Inf or huge value in QACC") under a table that
    still read like a result."""

    def check(self, value: float, horizon: int) -> None:
        """ConfigError (one line: knob, level, what is allowed) unless `value` is a
        level."""
        ok = math.isfinite(value) and (value > 0 if self.positive else value >= 0)
        if self.integer:
            ok = ok and float(value).is_integer() and value < horizon
        if not ok:
            allowed = self.allowed
            if self.integer:
                allowed += f" below the horizon {horizon}"
            raise ConfigError(
                f"perturb {self.name}={value:g} is not allowed: {allowed}"
            )
        if value > self.most:
            raise ConfigError(
                f"perturb {self.name}={value:g} is not allowed: {self.allowed}, at "
                f"most {self.most:g}"
            )


KNOBS: dict[str, Knob] = {
    k.name: k
    for k in (
        Knob(
            "obs_noise",
            "m",
            0.0,
            (0.0, 0.005, 0.01, 0.02),
            "a number >= 0 (metres, the std of the camera's error "
            "on a block's position)",
            needs_object=True,
            drawn=True,
            doc="Gaussian error on each block's measured position and on what derives "
            "from it",
            most=1.0,
        ),
        Knob(
            "goal_noise",
            "m",
            0.0,
            (0.0, 0.005, 0.01, 0.02),
            "a number >= 0 (metres, the std of the camera's error on a target)",
            drawn=True,
            doc="Gaussian error on the target the policy is shown",
            most=1.0,
        ),
        Knob(
            "action_delay",
            "steps",
            0,
            (0, 1, 2),
            "an integer >= 0",
            integer=True,
            doc="the action of step t is applied at step t + d "
            "(the zero action before)",
        ),
        Knob(
            "action_scale",
            "x",
            1.0,
            (0.8, 1.0, 1.2),
            "a number > 0 (1: the commanded motion)",
            positive=True,
            doc="the end effector moves scale x the commanded displacement",
            most=100.0,
        ),
        Knob(
            "friction",
            "x",
            1.0,
            (0.5, 1.0, 2.0),
            "a number > 0 (1: the model's friction)",
            positive=True,
            doc="sliding friction of the table and the blocks x scale (on Reach, "
            "which has no block, the table alone: nothing there touches it unless the "
            "gripper is pushed into it)",
            without_block="scales the table alone",
            most=100.0,
        ),
        Knob(
            "mass",
            "x",
            1.0,
            (0.5, 1.0, 2.0),
            "a number > 0 (1: the model's mass)",
            positive=True,
            needs_object=True,
            doc="mass and inertia of every block x scale",
            most=100.0,
        ),
    )
}
"""The perturbations, in the order the table shows them."""


def nominal() -> dict[str, float]:
    """Every knob at its nominal level: the unperturbed setting."""
    return {k.name: k.nominal for k in KNOBS.values()}


def applicable(env_id: str) -> list[str]:
    """The knobs that mean something on `env_id` (Reach has no block: no obs_noise, no
    mass)."""
    has_object = env_id in OBJECT_ENVS
    return [k.name for k in KNOBS.values() if has_object or not k.needs_object]


def parse_perturb(
    specs: list[str] | None, env_id: str, horizon: int
) -> dict[str, list[float]]:
    """`--perturb` values (`NAME` or `NAME=L1,L2,...`) as {knob: levels}; None or []:
    every knob that applies to `env_id`, at its default levels. ConfigError (one line)
    on an unknown name, a level that is not a number or not allowed, or a knob the task
    has nothing for."""
    if not specs:
        return {name: list(KNOBS[name].levels) for name in applicable(env_id)}
    out: dict[str, list[float]] = {}
    for spec in specs:
        name, eq, levels = spec.partition("=")
        name = name.strip()
        if name not in KNOBS:
            raise ConfigError(
                f"perturb {name!r} is not a perturbation; allowed: {', '.join(KNOBS)}"
            )
        knob = KNOBS[name]
        if name in out:  # the later one would silently win
            raise ConfigError(
                f"perturb {name!r} is given twice; allowed: each knob once, with all "
                f"its levels (--perturb {name}=L1,L2,...)"
            )
        if name not in applicable(env_id):
            raise ConfigError(
                f"perturb {name!r} needs a block; {env_id} has none "
                f"(allowed there: {', '.join(applicable(env_id))})"
            )
        values = []
        for text in levels.split(",") if eq else []:
            try:
                values.append(float(text))
            except ValueError:
                raise ConfigError(
                    f"perturb {name}: {text.strip()!r} is not a number; "
                    f"allowed: {knob.allowed}"
                ) from None
        values = values or list(knob.levels)
        for v in values:
            knob.check(v, horizon)
        out[name] = [int(v) if knob.integer else v for v in dict.fromkeys(values)]
    return out


def unit_of(level: float, unit: str) -> str:
    """A knob's unit as a level reads it: "step" for 1 step, else `unit`."""
    return "step" if unit == "steps" and level == 1 else unit


def quantity(level: float, unit: str) -> str:
    """A level with its unit for prose and tables: "0.02 m", "1 step", "2 steps"."""
    return f"{level:g} {unit_of(level, unit)}"


# ----- the observation layout the noise follows


@dataclass
class Layout:
    """Where the camera-measured entries sit in the *full* observation (found by name,
    `envs.obs_names`): (K, 3) index arrays, one row per block, for position, relative
    position and velocity; and the indices the policy sees (`observations.indices`)."""

    pos: np.ndarray
    rel: np.ndarray
    velp: np.ndarray
    keep: np.ndarray

    @classmethod
    def of(cls, env, obs: str) -> "Layout":
        names = E.obs_names(env, full=True)
        first = (re.match(r"^(object\d*)_pos\.x$", n) for n in names)
        blocks = [m.group(1) for m in first if m]

        def field(f):
            rows = [[names.index(f"{b}_{f}.{c}") for c in "xyz"] for b in blocks]
            return np.array(rows, dtype=np.int64).reshape(len(blocks), 3)

        return cls(field("pos"), field("rel_pos"), field("velp"), indices(names, obs))


class Perturbed:
    """`act(o, g)` under one setting of the knobs, as `rollout.run_episodes` calls it:
    with the true full observation and goal, once per step of one batch of episodes
    (make one per batch).

    Draws its noise every step whatever the levels (from `rng`), so settings share their
    draws. If `log` is a list, each step's (observation, goal) as the policy was shown
    them is appended to it."""

    def __init__(
        self,
        act,
        layout: Layout,
        setting: dict,
        rng: np.random.Generator,
        log: list | None = None,
    ):
        self.act, self.layout, self.s = act, layout, setting
        self.rng, self.log = rng, log
        self.prev = None
        self.queue: deque | None = None

    def __call__(self, o: np.ndarray, g: np.ndarray) -> np.ndarray:
        L, s = self.layout, self.s
        W, K = o.shape[0], L.pos.shape[0]
        if self.prev is None:
            self.prev = self.rng.standard_normal((W, K, 3))
        z, zg = self.rng.standard_normal((W, K, 3)), self.rng.standard_normal(g.shape)
        o, g = np.array(o, dtype=np.float64), np.array(g, dtype=np.float64)
        if s["obs_noise"] > 0 and K:
            n, n_prev = s["obs_noise"] * z, s["obs_noise"] * self.prev
            o[:, L.pos] += n
            o[:, L.rel] += n  # (pos + n) - grip: the gripper's is exact
            o[:, L.velp] += n - n_prev  # a difference of two camera frames
        self.prev = z
        if s["goal_noise"] > 0:
            g = g + s["goal_noise"] * zg
        o_in, g_in = o[:, L.keep].astype(np.float32), g.astype(np.float32)
        if self.log is not None:
            self.log.append((o_in, g_in))
        u = np.array(self.act(o_in, g_in), dtype=np.float32)
        u[:, :3] *= np.float32(s["action_scale"])
        u = np.clip(u, -1.0, 1.0)
        d = int(s["action_delay"])
        if d == 0:
            return u
        if self.queue is None:
            self.queue = deque([np.zeros_like(u)] * d)
        self.queue.append(u)
        return self.queue.popleft()


# ----- the model fields


def _model_arrays(model) -> dict:
    out = {}
    for name in dir(model):
        if name.startswith("_"):
            continue
        try:
            v = getattr(model, name)
        except Exception:  # a property that does not apply to this model
            continue
        if isinstance(v, np.ndarray):
            out[name] = v.copy()
    return out


def _body_ids(model, pattern: str) -> list[int]:
    names = (
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) or ""
        for i in range(model.nbody)
    )
    return [i for i, name in enumerate(names) if re.fullmatch(pattern, name)]


@contextlib.contextmanager
def scaled_model(env, friction: float = 1.0, mass: float = 1.0):
    """The env's MuJoCo model with the sliding friction of the table and the blocks x
    `friction`, and the blocks' mass and inertia x `mass` (bodies `table0`, `object0`,
    `object1`, ...); on exit every array of the model and its `stat` are as they were,
    bit for bit."""
    if friction == 1.0 and mass == 1.0:
        yield env
        return
    m = env.model
    saved = _model_arrays(m)
    stat = {
        k: getattr(m.stat, k) for k in ("meaninertia", "meanmass", "meansize", "extent")
    }
    stat["center"] = np.array(m.stat.center)
    try:
        blocks = _body_ids(m, r"object\d*")
        if friction != 1.0:
            geoms = np.isin(m.geom_bodyid, blocks + _body_ids(m, r"table0"))
            m.geom_friction[geoms, 0] *= friction
        if mass != 1.0:
            m.body_mass[blocks] *= mass
            m.body_inertia[blocks] *= mass
            # trap: mj_setConst uses the data it is given as scratch (sets its qpos)
            mujoco.mj_setConst(m, mujoco.MjData(m))
        yield env
    finally:
        for name, v in saved.items():
            getattr(m, name)[...] = v
        for k, v in stat.items():
            setattr(m.stat, k, v)
