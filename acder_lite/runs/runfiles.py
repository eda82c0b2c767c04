"""A run folder's files:
progress.csv, config.json, checkpoint.pt with policy.pt, done.json (and, for a run
carried over from another machine, checkpoint.packed/: `packed`).

Every file is written atomically (`io`), so an interrupt leaves the previous version
whole, and a write that fails (a full disk, a read-only folder) raises `io.WriteError`
with the same guarantee. Only config.json, the run's first file, makes the folder: one
removed while its run trains is an error at the next write, not made again empty.
"""

from __future__ import annotations

import json
import os
import platform
import shutil

import numpy as np
import torch

from acder_lite.runs import packed
from acder_lite.io import arrays_as_tensors, save_torch, write_csv, write_json


def versions() -> dict:
    import gymnasium
    import mujoco

    return dict(
        python=platform.python_version(),
        numpy=np.__version__,
        torch=torch.__version__,
        mujoco=mujoco.__version__,
        gymnasium=gymnasium.__version__,
        gymnasium_robotics=_version("gymnasium-robotics"),
        acder_lite=_version("acder-lite"),
        git=git_commit(),
        cpu=cpu(),
    )


def cpu() -> str:
    """The CPU's model and the instruction set torch's kernels dispatch to (AVX2,
    AVX512, ...): float32 results are the same only where both are (a run resumed on
    another machine records it under config.json's `resumes`)."""
    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{model}; torch kernels: {torch.backends.cpu.get_cpu_capability()}"


def git_commit() -> str:
    """The source's commit (with '+dirty' for uncommitted changes),
    or '' outside a checkout."""
    import subprocess

    here = os.path.dirname(os.path.abspath(__file__))
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=here,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no", "--", "."],
            cwd=here,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return head + ("+dirty" if dirty and head else "")


def _version(dist: str) -> str:
    from importlib import metadata

    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "source"


class RunFiles:
    """The files of one run folder (`out_dir`),
    written by the trainer at the points it chooses."""

    def __init__(self, out_dir: str):
        self.out_dir = out_dir
        self.checkpoint_cycle: int | None = None
        """The cycle of the checkpoint on disk this run wrote (`save`) or went on from
        (`Trainer.load_state_dict`); None before the first. The trainer writes
        progress.csv only once there is one."""

    def path(self, name: str) -> str:
        return os.path.join(self.out_dir, name)

    def write_progress(self, rows: list[dict], columns: list[str]) -> None:
        """progress.csv: one row per evaluation."""
        write_csv(self.path("progress.csv"), rows, columns, make_folder=False)

    def write_config(
        self, config: dict, seed: int, command: str, at_cycle: int
    ) -> None:
        """config.json: the config, the command, versions. A resumed run (at_cycle > 0)
        keeps the first command and appends its own under "resumes"."""
        path = self.path("config.json")
        here = dict(
            command=command,
            at_cycle=at_cycle,
            versions=versions(),
            threads=torch.get_num_threads(),
        )
        if at_cycle and os.path.exists(path):
            with open(path) as f:
                d = json.load(f)
            d["config"] = config
            d.setdefault("resumes", []).append(here)
        else:
            d = dict(
                config=config,
                command=command,
                seed=seed,
                versions=here["versions"],
                threads=here["threads"],
            )
        write_json(path, d)

    def save(self, state: dict, policy_state: dict) -> None:
        """checkpoint.pt (everything, to resume) and policy.pt
        (the actor and its normalisers)."""
        save_torch(
            self.path("checkpoint.pt"), arrays_as_tensors(state), make_folder=False
        )
        self.checkpoint_cycle = int(state.get("progress", {}).get("cycle", 0))
        save_torch(self.path("policy.pt"), dict(policy=policy_state), make_folder=False)

    def write_done(self, info: dict) -> None:
        """done.json: the run ended (how, when, with what test success). A packed
        checkpoint (`packed`) it was carried over with has served: removed."""
        write_json(self.path("done.json"), info, make_folder=False)
        shutil.rmtree(self.path(packed.FOLDER), ignore_errors=True)
