"""Protocol v1, in one place: how a run recorded before protocol v2 (the grid's
protocol, book/departures.md, "The protocol") is read today, so that its config.json
still reproduces it (`experiments/protocol-v1/`).

What v1 did that v2 does not:
- fields that did not exist yet, and what the runs did instead (`LEGACY_VALUES`);
- a method that is now a method plus a setting (`LEGACY_METHODS`);
- a stop rule with a threshold of its own (`stop_after_success`, 0 for never), now
  `success_threshold` and `stop_patience` (`upgrade_legacy`).

Two v1 code paths stay where they act, named here so they can be found: the gap rule
(`Config.stop_gap_episodes`, `train.trainer.Trainer.past_gap`), and the words a v1 run
ended with ("hovering", "cut short": `runs.read.how_ended`).

The top layer: imports nothing of the package (`config` imports it)."""

from __future__ import annotations

LEGACY_VALUES = dict(
    init="torch",
    buffer_scope="shared",
    sicm_input="normalised",
    update_dtype="float32",
    split_update="off",
)
LEGACY_METHODS = {"acder-baselines-clip": ("acder", "baselines")}
"""Methods of protocol v1 that are now a method plus a setting:
name -> (method, target_clip)."""


def upgrade_legacy(d: dict) -> dict:
    """A protocol-v1 config dict in today's fields, meaning the same run (a copy)."""
    d = dict(d)
    if "target_clip" not in d:
        d["target_clip"] = (d.get("switches") or {}).get("target_clip", "wide")
    if d.get("method") in LEGACY_METHODS:
        d["method"], d["target_clip"] = LEGACY_METHODS[d["method"]]
    for name, value in LEGACY_VALUES.items():
        d.setdefault(name, value)
    if "stop_after_success" in d:  # v1: 0 meant "never stop early"
        thr = d.pop("stop_after_success")
        d.setdefault("success_threshold", thr if thr > 0 else None)
        if not thr > 0:
            d["stop_patience"] = 0
    if isinstance(d.get("switches"), dict):
        d["switches"] = {k: v for k, v in d["switches"].items() if k != "target_clip"}
    return d
