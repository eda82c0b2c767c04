"""Euler angles that wrap around: a jump of the observation that curiosity pays for.

Fetch's observation gives each block's orientation as three Euler angles
(`object_rot`, from `mat2euler`), each within [-pi, pi]. When the block turns through
+-pi the angle jumps by about 2 pi in one step although the block barely moved. A
forward model cannot predict that jump, so Eq. 4 pays its clip eta there: the largest
intrinsic reward there is, and the row the start-state selection (the largest r^i
among successful rows) is drawn to.

`angle_wraps` finds those steps in a rollout (`diagnose --episodes` reports their
share for a trained policy); `summarize` reads the JSON files that
`experiments/angle-wraps/run.sh` writes, one per finished run, and `table_rows` puts
them in the book ("Results in detail", whose sentences are written by hand).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from acder_lite.config import METHODS
from acder_lite.runs.table import task_label

WRAP_ERROR = 0.5 * (2 * np.pi) ** 2
"""Eq. 4's error before the clip, 1/2 ||.||^2, on raw inputs (`sicm_input="raw"`), of a
prediction that gets everything right but one Euler angle's wrap: about 19.7, far above
either eta (0.05, 0.8)."""


def angle_wraps(rot: np.ndarray) -> np.ndarray:
    """Steps at which one of an object's Euler angles wraps around: `rot` the
    observation's object_rot (..., T+1, 3), in radians within [-pi, pi]. Returns a bool
    array (..., T), True where an angle changed by more than pi in one step.

    Trap: the jump is the representation's, not the block's (at a pitch of +-pi/2 the
    other two angles can jump too, through gimbal lock). No step of a pushed block
    turns it by pi in 0.04 s, so every such step is a wrap, not motion."""
    return (np.abs(np.diff(np.asarray(rot, np.float64), axis=-2)) > np.pi).any(-1)


GIMBAL_COS = 0.2
"""`near_gimbal_lock`'s bound on |cos(pitch)|: a pitch within 11.5° of ±90°."""


def near_gimbal_lock(rot: np.ndarray, cos_below: float = GIMBAL_COS) -> np.ndarray:
    """Steps at which an object's pitch (the second Euler angle) is near +-pi/2 before
    or after the step: `rot` as in `angle_wraps`, returns (..., T) bools, True where
    |cos(pitch)| < `cos_below` at either end.

    A cube pitched by 90 degrees lies on a side face, an ordinary pose for a pushed
    block that tipped over, but there `mat2euler`'s other two angles are degenerate
    (gimbal lock): any wobble swings them by up to pi, and unlike a wrap, their
    (sin, cos) swings too (`Config.sicm_angles="sincos"` does not smooth it)."""
    locked = np.abs(np.cos(np.asarray(rot, np.float64)[..., 1])) < cos_below
    return locked[..., :-1] | locked[..., 1:]


def curiosity_in_reward(method: str) -> bool:
    """Whether `method` adds a curiosity bonus (S-ICM's or ICM's) to its reward."""
    return bool(METHODS[method]["curiosity_reward"])


def summarize(*folders: str | Path) -> list[dict]:
    """One row per (env, run name) from the `diagnose --json` files under `folders`
    (`<...>/<env>/<name>/seed<k>.json`): the seeds read, the mean share of test steps
    and of test episodes with a wrap, the range of the step share over seeds, the mean
    test success, and whether the method's reward has a curiosity bonus. Files without
    a motion block (no object) are left out. Sorted by env, then step share."""
    groups: dict[tuple[str, str], list[dict]] = {}
    paths = sorted(p for f in folders for p in Path(f).rglob("seed*.json"))
    for path in paths:
        d = json.loads(path.read_text())
        m = d.get("motion") or {}
        if "wrap_step_share" not in m:
            continue
        d["motion"] = m
        groups.setdefault((d["env"], path.parent.name), []).append(d)
    rows = []
    for (env, name), ds in groups.items():
        steps = np.array([d["motion"]["wrap_step_share"] for d in ds])
        rows.append(
            dict(
                env=env,
                name=name,
                method=ds[0]["method"],
                seeds=len(ds),
                step_share=float(steps.mean()),
                step_share_min=float(steps.min()),
                step_share_max=float(steps.max()),
                episode_share=float(
                    np.mean([d["motion"]["wrap_episode_share"] for d in ds])
                ),
                success=float(np.mean([d["motion"]["success"] for d in ds])),
                curiosity_reward=curiosity_in_reward(ds[0]["method"]),
            )
        )
    return sorted(rows, key=lambda r: (r["env"], r["step_share"]))


def table_rows(rows: list[dict]) -> tuple[list[str], list[list[str]]]:
    """Header and rows for `table.to_html`."""
    header = [
        "Task",
        "Run",
        "Curiosity in the reward",
        "Seeds",
        "Steps with a wrap: mean (range)",
        "Episodes with one",
        "Test success",
    ]
    body = [
        [
            task_label(r["env"]),
            f"`{r['name']}`",
            "yes" if r["curiosity_reward"] else "no",
            str(r["seeds"]),
            f"{r['step_share']:.2%} ({r['step_share_min']:.2%} – "
            f"{r['step_share_max']:.2%})",
            f"{r['episode_share']:.0%}",
            f"{r['success']:.2f}",
        ]
        for r in rows
    ]
    return header, body


def buffer_readings(folder: str | Path) -> list[dict]:
    """The `diagnose --json` files of runs' replay buffers under `folder`
    (`experiments/angle-wraps/buffer.sh`), those with an S-ICM wrap reading, in order
    of their path."""
    out = []
    for path in sorted(Path(folder).rglob("*.json")):
        d = json.loads(path.read_text())
        if "wraps" in (d.get("curiosity") or {}):
            out.append(d)
    return out
