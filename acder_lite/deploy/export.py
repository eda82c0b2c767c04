"""A trained policy as one TorchScript file that runs without acder_lite

`python -m acder_lite export results/FetchPush-v4/acder/seed0/policy.pt --out push.ts`
writes the actor with everything between the sensors and the network baked in, in the
order `rollout.Policy` applies it (so the actions are the same numbers):

1. the observation set (`acder_lite.envs.observations`): a policy trained on the
simplified
   state takes either the full Fetch vector (its own entries are picked, `index`) or
   only its own entries, in the order of `obs_names`: what a robot with a camera can
   give it;
2. observation and goal clipped to +-clip_obs (200);
3. each normalised with the training statistics, (x - mean) / std, clipped to
   +-norm_clip (5);
4. the actor, max_u * tanh(MLP(.)), and the action clipped to the action space [-1, 1].

The robot side:

    import torch
    policy = torch.jit.load("push.ts")
    u = policy(torch.as_tensor(obs), torch.as_tensor(goal))  # (..., 4): dx dy dz grip
    policy.obs_names, policy.goal_names  # what each input number is

Inputs may be one observation or a batch (leading axes), of any float dtype; the action
is float32. A wrong input width raises a ValueError naming the widths it accepts. The
file also holds `acder_lite.json` (env, method, observation set, names, units, clips,
the frame, the source file, how far its run had trained, the versions):
`torch.jit.load(path, _extra_files={"acder_lite.json": ""})` fills it in.

**Units and frame** (`units`, `world`; `policy.obs_units`, `policy.goal_units`): every
position is in metres in the simulator's world frame (z up), where the normalisers were
fitted, so a robot expresses its camera's and its arm's positions in that frame;
`world` gives the gripper's start position and the height of a block resting on the
table to calibrate against. Finger entries are each finger's slide joint (0 closed,
0.05 m open). Fetch's "velocities" (full state only) are displacements in one control
step (velocity x `world["control_dt_s"]`, 0.04 s). The action: dx dy dz move the
end-effector's target by 0.05 m per unit in that step (world frame); the gripper
command (> 0 opens) is ignored on Reach and both Push tasks, whose gripper is blocked.

TorchScript is deprecated in torch 2.13 (a DeprecationWarning on script, save and load,
silenced here) in favour of `torch.export`; it is still what `torch.jit.load` reads with
nothing else installed, which is the point of this file. Loading it runs no Python code
of ours.

**ONNX** (`--onnx FILE`): `torch.onnx.export` in torch 2.13 needs the `onnx` and
`onnxscript` packages (and `onnxruntime` to run the file). requirements.txt pins them
beside the stack without changing it (onnx 1.23.2, onnxscript 0.7.2, onnx-ir 1.1.0,
ml-dtypes 0.7.0, onnxruntime 1.31.1, flatbuffers 25.12.19; protobuf stays at its pinned
7.36.2), and the export works offline with them: tests/test_export.py checks the file's
actions against the policy's. An install without them (the package alone, `pip install
-e .`) gets one line from `--onnx` saying what to install. The ONNX graph takes the
policy's own observation entries only (one static input width), float32, with a dynamic
batch axis; the model's `metadata_props` hold the same `acder_lite.json` (onnxruntime:
`session.get_modelmeta().custom_metadata_map`), its `accepts` saying so.
"""

import argparse
import contextlib
import json
import os
import re
import warnings
from pathlib import Path
from typing import List

import torch
from torch import nn

from acder_lite.envs import fetch as E
from acder_lite.config import ConfigError
from acder_lite.io import atomic_write
from acder_lite.envs.fetch import policy_env
from acder_lite.envs.observations import indices, policy_obs
from acder_lite.train.rollout import Policy
from acder_lite.words import count, plural

# No `from __future__ import annotations` in this module: TorchScript reads
# DeployedPolicy's class annotations (List[str]) as types, and cannot resolve them from
# strings.

META_FILE = "acder_lite.json"
"""The name of the metadata entry inside the TorchScript archive."""

ONNX_PACKAGES = "onnx==1.23.2 onnxscript==0.7.2 onnxruntime==1.31.1"

WORLD_M = "m, world frame"
STEP = "per control step (x control_dt_s)"
UNITS = (
    (r"grip_pos\.[xyz]", WORLD_M + ", the gripper (arm's encoders)"),
    (r"object\d*_pos\.[xyz]", WORLD_M + ", the block (camera)"),
    (r"object\d*_rel_pos\.[xyz]", "m, the block's position minus the gripper's"),
    (r"finger_[lr]", "m, the finger's slide joint (0 closed, 0.05 open)"),
    (r"object\d*_rot\.[xyz]", "rad, the block's Euler angles (world frame)"),
    (r"object\d*_velp\.[xyz]", f"m {STEP}, the block's motion minus the gripper's"),
    (r"object\d*_velr\.[xyz]", f"rad {STEP}, the block's rotation"),
    (r"grip_velp\.[xyz]", f"m {STEP}, the gripper's motion"),
    (r"finger_vel_[lr]", f"m {STEP}, the finger's motion"),
    (r"goal\d*\.[xyz]", WORLD_M + ", a block's target (Reach: the gripper's)"),
)
"""The unit (and meaning) of each observation and goal entry, by name (`envs.obs_names`,
`envs.goal_names`); positions in metres in the world frame, Fetch's velocities as
displacements in one control step (gymnasium-robotics multiplies them by dt)."""


def unit_of(name: str) -> str:
    """The unit of entry `name` (`UNITS`); RuntimeError for a name it does not know,
    rather than a file that documents it wrongly."""
    for pattern, unit in UNITS:
        if re.fullmatch(pattern, name):
            return unit
    raise RuntimeError(f"export: no unit known for observation entry {name!r}")


def action_units(block_gripper: bool) -> list:
    """The unit of each action entry (dx, dy, dz, gripper): what Fetch's controller does
    with it in one control step."""
    move = "x 0.05 m: the end effector's target moves this much this step, world frame"
    grip = "each finger's target moves by this (m); > 0 opens, < 0 closes"
    if block_gripper:
        grip = "ignored: the gripper is blocked on this task"
    return [move, move, move, grip]


class DeployedPolicy(nn.Module):
    """The policy as a self-contained module: forward(observation, goal) -> action.

    Everything it needs is a buffer or a constant of its own (no acder_lite object
    survives scripting): the actor's layers, the float32 mean and 1/std of each
    normaliser (computed as `Normalizer._sync` computes them, so the numbers are the
    in-package policy's bit for bit), the indices of the policy's entries in the full
    observation, and the clips."""

    obs_names: List[str]
    full_obs_names: List[str]
    goal_names: List[str]
    obs_units: List[str]
    full_obs_units: List[str]
    goal_units: List[str]

    def __init__(
        self,
        policy: Policy,
        full_obs_names: list,
        index,
        goal_names: list,
        env: str,
        method: str,
        obs: str,
        world: str = "{}",
    ):
        super().__init__()
        self.net = nn.Sequential(*policy.actor.net)
        self.max_u = float(policy.actor.max_u)
        self.clip_obs = float(policy.clip_obs)
        self.norm_clip = float(policy.o_norm.clip)

        def f32(a):
            return torch.as_tensor(a, dtype=torch.float32).clone()

        self.register_buffer("o_mean", f32(policy.o_norm.mean))
        self.register_buffer("o_inv_std", f32(1.0 / policy.o_norm.std))
        self.register_buffer("g_mean", f32(policy.g_norm.mean))
        self.register_buffer("g_inv_std", f32(1.0 / policy.g_norm.std))
        self.register_buffer("index", torch.as_tensor(index, dtype=torch.long).clone())
        self.n_full, self.n_obs = len(full_obs_names), int(len(index))
        self.n_goal = len(goal_names)
        self.full_obs_names = list(full_obs_names)
        self.obs_names = [full_obs_names[int(i)] for i in index]
        self.goal_names = list(goal_names)
        self.full_obs_units = [unit_of(n) for n in full_obs_names]
        self.obs_units = [unit_of(n) for n in self.obs_names]
        self.goal_units = [unit_of(n) for n in goal_names]
        self.env, self.method, self.obs = env, method, obs
        self.world = world  # JSON (`world_of`): the frame's landmarks, the step's dt
        for p in self.parameters():
            p.requires_grad_(False)

    def forward(self, observation: torch.Tensor, goal: torch.Tensor) -> torch.Tensor:
        o = observation.to(torch.float32)
        if o.size(-1) == self.n_full and self.n_full != self.n_obs:
            o = o.index_select(-1, self.index)
        if o.size(-1) != self.n_obs:
            raise ValueError(
                "observation has "
                + str(o.size(-1))
                + " numbers; "
                + "allowed: "
                + str(self.n_obs)
                + " (obs_names) or "
                + str(self.n_full)
                + " (full_obs_names)"
            )
        g = goal.to(torch.float32)
        if g.size(-1) != self.n_goal:
            raise ValueError(
                "goal has "
                + str(g.size(-1))
                + " numbers; allowed: "
                + str(self.n_goal)
                + " (goal_names)"
            )
        c, nc = self.clip_obs, self.norm_clip
        o = ((o.clamp(-c, c) - self.o_mean) * self.o_inv_std).clamp(-nc, nc)
        g = ((g.clamp(-c, c) - self.g_mean) * self.g_inv_std).clamp(-nc, nc)
        u = self.max_u * self.net(torch.cat([o, g], dim=-1))
        return u.clamp(-1.0, 1.0)


def world_of(env) -> dict:
    """What a robot calibrates its frame and clock against, read from the task's env:
    the control step (s), the gripper's start position (m, world frame), the height of
    the centre of a block resting on the table (tasks with a block) and whether the
    gripper command is ignored."""
    world = dict(
        frame="MuJoCo world frame of the Fetch scene, metres, z up",
        control_dt_s=float(env.n_substeps * env.model.opt.timestep),
        initial_gripper_pos=[float(x) for x in env.initial_gripper_xpos[:3]],
        gripper_blocked=bool(env.block_gripper),
    )
    if env.has_object:
        world["block_rest_z"] = float(env.height_offset)
    return world


def build(pol: dict, path: str = "policy") -> DeployedPolicy:
    """The DeployedPolicy of a policy dict, its sizes checked against its task's env
    (`envs.policy_env`: CheckpointError, one line)."""
    obs = policy_obs(pol)
    env = policy_env(pol, path)
    try:
        full = E.obs_names(env, full=True)
        module = DeployedPolicy(
            Policy.from_state_dict(pol),
            full,
            indices(full, obs),
            E.goal_names(env),
            pol["env"],
            pol["method"],
            obs,
            json.dumps(world_of(env)),
        )
    finally:
        env.close()
    return module.eval()


def script(module: DeployedPolicy) -> torch.jit.ScriptModule:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # torch 2.13: module doc
        return torch.jit.script(module)


def trained_of(pol: dict, source: str = "") -> dict | None:
    """How far the policy's run had trained when the file was written: epochs,
    training episodes and the last evaluation's test success, with where that was
    read (`from`). A policy dict written since the trainer records it carries it
    (`trained`); an older one is read from the `done.json` beside `source` or in it (a
    run folder; a finished run's policy.pt and checkpoint.pt are its last epoch's); else
    None (unknown: an older file of a run still training, or one moved out of its run
    folder)."""
    from acder_lite.runs.read import RunError, read_json

    if isinstance(pol.get("trained"), dict):
        return dict(pol["trained"], **{"from": "the policy file"})
    if not source:
        return None
    folder = source if os.path.isdir(source) else os.path.dirname(source)
    try:
        d = read_json(Path(folder) / "done.json", "done.json")
        return {
            "epochs": float(d["epochs"]),
            "episodes": int(d["episodes"]),
            "test_success": float(d["final_test_success"]),
            "from": "done.json beside the policy file (the run had ended)",
        }
    except (RunError, ValueError, KeyError, TypeError):
        return None  # no done.json, or one of another shape: unknown, not guessed


def trained_text(trained: dict | None) -> str:
    """`trained_of`'s answer as words for the export's line."""
    if trained is None:
        return "how far its run had trained is not recorded"
    ts = trained.get("test_success")
    ep, n = trained["epochs"], trained["episodes"]
    return f"trained {ep:g} {plural(ep, 'epoch')}, {count(n, 'episode')}" + (
        "" if ts is None else f", test success {ts:.2f} at its last evaluation"
    )


def metadata(
    module: DeployedPolicy, source: str, onnx: bool = False, trained: dict | None = None
) -> dict:
    """The file's `acder_lite.json`: what each input and output number is, in which
    unit and frame (`UNITS`, `world_of`), where the file came from and how far its run
    had trained (`trained_of`; None where unknown)."""
    from acder_lite.runs.runfiles import versions

    world = json.loads(module.world)
    if onnx:
        accepts = "observation: obs_names only (float32, batch first)"
    else:
        accepts = "observation: obs_names or full_obs_names (leading batch axes)"
    return dict(
        env=module.env,
        method=module.method,
        obs=module.obs,
        source=source,
        trained=trained,
        accepts=accepts,
        obs_names=module.obs_names,
        obs_units=module.obs_units,
        full_obs_names=module.full_obs_names,
        full_obs_units=module.full_obs_units,
        goal_names=module.goal_names,
        goal_units=module.goal_units,
        action=["dx", "dy", "dz", "gripper"],
        action_units=action_units(world.get("gripper_blocked", False)),
        world=world,
        clip_obs=module.clip_obs,
        norm_clip=module.norm_clip,
        action_clip=[-1.0, 1.0],
        versions=versions(),
    )


def export_torchscript(pol: dict, out: str, source: str = "") -> dict:
    """Write the TorchScript file `out` (atomically) for policy dict `pol`; returns the
    metadata it holds."""
    module = build(pol, source or "policy")
    scripted = script(module)
    meta = metadata(module, source, trained=trained_of(pol, source))
    extra = {META_FILE: json.dumps(meta, indent=2)}

    def write(f):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            torch.jit.save(scripted, f, _extra_files=extra)

    atomic_write(out, write)
    return meta


ROBOT_SIDE = r"""
import json, sys
import torch
extra = {"acder_lite.json": ""}
m = torch.jit.load(sys.argv[1], _extra_files=extra)
x = torch.load(sys.argv[2])
with torch.no_grad():
    u = m(x["o"], x["g"])
ours = sorted(k for k in sys.modules if k.split(".")[0] == "acder_lite")
torch.save({"u": u, "meta": json.loads(extra["acder_lite.json"]), "imported": ours},
           sys.argv[3])
"""
"""What a robot-side program does with an exported file: torch only."""


def run_standalone(path: str, o, g, timeout: float = 120.0) -> dict:
    """Load the TorchScript file `path` in a fresh Python process (`ROBOT_SIDE`, run in
    another folder without PYTHONPATH) and act on observations `o` and goals `g` (numpy,
    batched). Returns dict(u: numpy actions, meta: the file's metadata, imported: the
    acder_lite modules that process imported, which should be none). Trap: the venv's
    editable install would still let the child import acder_lite; `imported` is what
    shows that it did not. RuntimeError with the child's stderr if it fails."""
    import subprocess
    import sys
    import tempfile

    import numpy as np

    with tempfile.TemporaryDirectory() as tmp:
        x = {"o": torch.from_numpy(np.asarray(o)), "g": torch.from_numpy(np.asarray(g))}
        torch.save(x, os.path.join(tmp, "in.pt"))
        with open(os.path.join(tmp, "robot.py"), "w") as f:
            f.write(ROBOT_SIDE)
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        p = subprocess.run(
            [sys.executable, "robot.py", os.path.abspath(path), "in.pt", "out.pt"],
            cwd=tmp,
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
        if p.returncode != 0:
            raise RuntimeError(f"the robot-side process failed: {p.stderr.strip()}")
        out = torch.load(os.path.join(tmp, "out.pt"))
    return dict(u=out["u"].numpy(), meta=out["meta"], imported=out["imported"])


def compare_with_package(pol: dict, out: str, source: str = "", n: int = 100, seed=0):
    """Export `pol` to `out` (`export_torchscript`), give the file in a fresh process
    (`run_standalone`) and the in-package policy the same `n` random full observations
    and goals, and compare: dict(gap = the largest absolute action difference,
    clipped = the fraction of the policy's normalised inputs at the normalisers' clip,
    imported = the acder_lite modules the robot side imported, meta).

    The policy's entries are drawn around its normalisers' statistics, mean + std z
    with z ~ N(0, 1) (a tenth of the rows z x 8, past the clip): a trained policy's
    positions sit near (1.3, 0.75, 0.42) m with a std of centimetres, so N(0, 1) numbers
    would put most normalised inputs at the clip and test little but the clip."""
    import numpy as np

    meta = export_torchscript(pol, out, source=source)
    policy = Policy.from_state_dict(pol)
    idx = indices(meta["full_obs_names"], meta["obs"])
    rng = np.random.default_rng(seed)

    def around(norm, size):
        z = rng.normal(size=(n, size))
        z[: max(1, n // 10)] *= 8.0
        return norm.mean + norm.std * z

    o = rng.normal(size=(n, len(meta["full_obs_names"])))
    o[:, idx] = around(policy.o_norm, idx.size)
    o = o.astype(np.float32)
    g = around(policy.g_norm, len(meta["goal_names"])).astype(np.float32)
    robot = run_standalone(out, o, g)
    u = policy(o[:, idx], g)
    z = np.concatenate(
        [policy.o_norm.normalize(o[:, idx]), policy.g_norm.normalize(g)], 1
    )
    return dict(
        gap=float(np.abs(robot["u"] - u).max()),
        clipped=float(np.mean(np.abs(z) >= policy.o_norm.clip)),
        imported=robot["imported"],
        meta=meta,
    )


def check_onnx() -> None:
    """ConfigError (one line) unless torch.onnx.export can run: onnx and onnxscript."""
    try:
        import onnx  # noqa: F401
        import onnxscript  # noqa: F401
    except ImportError:
        raise ConfigError(
            "onnx: --onnx needs packages that are not installed; "
            f"allowed: install {ONNX_PACKAGES}, or leave --onnx out"
        ) from None


def export_onnx(pol: dict, out: str, source: str = "") -> None:
    """Write an ONNX file (inputs `observation` (B, n_obs) and `goal` (B, n_goal),
    float32; output `action`; `metadata_props` {META_FILE: the metadata}), atomically.
    ConfigError without onnx/onnxscript."""
    check_onnx()
    import tempfile

    module = build(pol, source or "policy")
    example = (torch.zeros(2, module.n_obs), torch.zeros(2, module.n_goal))
    batch = torch.export.Dim("batch")
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "policy.onnx")
        with warnings.catch_warnings(), _quiet():
            warnings.simplefilter("ignore")
            torch.onnx.export(
                module,
                example,
                path,
                input_names=["observation", "goal"],
                output_names=["action"],
                dynamo=True,
                external_data=False,
                dynamic_shapes={"observation": {0: batch}, "goal": {0: batch}},
            )
        import onnx

        model = onnx.load(path)
        meta = json.dumps(
            metadata(module, source, onnx=True, trained=trained_of(pol, source)),
            indent=2,
        )
        onnx.helper.set_model_props(model, {META_FILE: meta})
        data = model.SerializeToString()
    atomic_write(out, lambda f: f.write(data))


@contextlib.contextmanager
def _quiet():
    """torch.onnx prints its progress to stdout and logs a warning per torchvision op it
    skips; the command prints one line of its own."""
    import io
    import logging

    log = logging.getLogger("torch.onnx")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            yield
    finally:
        log.setLevel(level)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "policy",
        metavar="POLICY",
        help="a policy.pt or checkpoint.pt (or a run folder)",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="FILE",
        help="the TorchScript file to write (never replaced); its acder_lite.json "
        "names every input entry with its unit and frame",
    )
    p.add_argument(
        "--onnx",
        metavar="FILE",
        help=f"also write an ONNX file (needs {ONNX_PACKAGES})",
    )


def run(args) -> int:
    from acder_lite.io import load_policy

    from acder_lite.io import check_output, write_error

    pol, path = load_policy(args.policy)
    for name in ("out", "onnx"):
        target = getattr(args, name)
        if target and os.path.abspath(target) == os.path.abspath(path):
            raise ConfigError(
                f"{name}={target!r} is the policy file itself; allowed: another file"
            )
    if args.onnx is not None and os.path.abspath(args.onnx) == os.path.abspath(
        args.out
    ):
        raise ConfigError(
            f"onnx={args.onnx!r} is the --out file too; allowed: another file"
        )
    for name in ("out", "onnx"):  # an export never replaces a file
        if getattr(args, name) is not None:
            check_output(getattr(args, name), name, (path,), overwrite=False)
    if args.onnx:
        check_onnx()  # before anything is written
    try:
        meta = export_torchscript(pol, args.out, path)
    except OSError as e:
        raise write_error("out", args.out, e) from None
    line = (
        f"export: {args.out} ({meta['env']}, {meta['method']}, obs {meta['obs']}: "
        f"{len(meta['obs_names'])} observation entries, {len(meta['goal_names'])} "
        "goal entries; " + trained_text(meta["trained"]) + ")"
    )
    if args.onnx:
        try:
            export_onnx(pol, args.onnx, path)
        except OSError as e:
            raise write_error("onnx", args.onnx, e) from None
        line += f"; ONNX: {args.onnx}"
    print(line)
    return 0
