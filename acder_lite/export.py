"""A trained policy as one TorchScript file that runs without acder_lite

`python -m acder_lite export results/FetchPush-v4/acder/seed0/policy.pt --out push.ts`
writes the actor with everything between the sensors and the network baked in, in the
order `rollout.Policy` applies it (so the actions are the same numbers):

1. the observation set (`acder_lite.observations`): a policy trained on the simplified
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
file also holds `acder_lite.json` (env, method, observation set, names, clips, the
source file, the versions): `torch.jit.load(path, _extra_files={"acder_lite.json": ""})`
fills it in.

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
batch axis.
"""

import argparse
import contextlib
import json
import os
import warnings
from typing import List

import torch
from torch import nn

from . import envs as E
from .config import ConfigError
from .io import atomic_write
from .observations import indices, policy_env, policy_obs
from .rollout import Policy

# No `from __future__ import annotations` in this module: TorchScript reads
# DeployedPolicy's class annotations (List[str]) as types, and cannot resolve them from
# strings.

META_FILE = "acder_lite.json"
"""The name of the metadata entry inside the TorchScript archive."""

ONNX_PACKAGES = "onnx==1.23.2 onnxscript==0.7.2 onnxruntime==1.31.1"


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

    def __init__(
        self,
        policy: Policy,
        full_obs_names: list,
        index,
        goal_names: list,
        env: str,
        method: str,
        obs: str,
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
        self.env, self.method, self.obs = env, method, obs
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


def build(pol: dict, path: str = "policy") -> DeployedPolicy:
    """The DeployedPolicy of a policy dict, its sizes checked against its task's env
    (`observations.policy_env`: CheckpointError, one line)."""
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
        )
    finally:
        env.close()
    return module.eval()


def script(module: DeployedPolicy) -> torch.jit.ScriptModule:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # torch 2.13: module doc
        return torch.jit.script(module)


def metadata(module: DeployedPolicy, source: str) -> dict:
    from .runfiles import versions

    return dict(
        env=module.env,
        method=module.method,
        obs=module.obs,
        source=source,
        obs_names=module.obs_names,
        full_obs_names=module.full_obs_names,
        goal_names=module.goal_names,
        action=["dx", "dy", "dz", "gripper"],
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
    meta = metadata(module, source)
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
    imported = the acder_lite modules the robot side imported, meta)."""
    import numpy as np

    meta = export_torchscript(pol, out, source=source)
    rng = np.random.default_rng(seed)
    o = rng.normal(size=(n, len(meta["full_obs_names"]))).astype(np.float32)
    g = rng.normal(size=(n, len(meta["goal_names"]))).astype(np.float32)
    robot = run_standalone(out, o, g)
    u = Policy.from_state_dict(pol)(
        o[:, indices(meta["full_obs_names"], meta["obs"])], g
    )
    return dict(
        gap=float(np.abs(robot["u"] - u).max()), imported=robot["imported"], meta=meta
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
    float32; output `action`), atomically. ConfigError without onnx/onnxscript."""
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
        with open(path, "rb") as f:
            data = f.read()
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
        "--out", required=True, metavar="FILE", help="the TorchScript file to write"
    )
    p.add_argument(
        "--onnx",
        metavar="FILE",
        help=f"also write an ONNX file (needs {ONNX_PACKAGES})",
    )


def run(args) -> int:
    from .robust import load_policy

    from .io import check_output, write_error

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
        "goal entries)"
    )
    if args.onnx:
        try:
            export_onnx(pol, args.onnx, path)
        except OSError as e:
            raise write_error("onnx", args.onnx, e) from None
        line += f"; ONNX: {args.onnx}"
    print(line)
    return 0
