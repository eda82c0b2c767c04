"""A cell of the grid that is a run already finished elsewhere: checked, then copied.

The same config, the same code and the same CPU give the same numbers (the project's
seeding rule), so training a cell whose config equals a finished run's, field for field,
would spend hours to write that run's files again. A plan group with `same_as = "DIR"`
(`plan.read_plan`) says its cells are the runs `DIR/seed<k>`; the sweep compares each
cell's resolved `Config` with the one the run recorded (`check`) and, when they agree,
copies the run's files into the cell's folder (`copy_run`), with a `same_as` record in
config.json naming where they came from. A config that differs is an error in the plan,
not a silent retraining.

Trap: equal configs are the claim only while the code between the two runs computes
the same floats; that is the grid's own rule (no change that moves a float while its
runs are in flight; experiments/bit-identity checks the changes).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from acder_lite.config import Config, ConfigError
from acder_lite.io import atomic_write, write_json

NEUTRAL_FIELDS = ("threads", "split_update", "step_threads")
"""Config fields that change how fast a run goes, not its numbers, so they are left out
of the comparison: the torch threads, the two losses at once and the parallel stepping
each give the one-thread run's numbers bit for bit (tests/test_rollout.py,
tests/test_losses.py)."""

FILES = ("progress.csv", "policy.pt", "config.json", "done.json")
"""What a finished run's folder holds and the grid commits; done.json is written last,
so a copy cut short is never taken for a complete run."""


def resolved(config: dict) -> dict:
    """A config.json "config" (or a cell's fields) as today's resolved Config dict."""
    return Config.from_dict(config).resolve().to_dict()


def check(config: dict, source: Path) -> tuple[str, str]:
    """Whether the run in `source` is the run `config` (a resolved Config dict) would
    train: ("copy", ""), ("wait", why) while it has not finished, or ("differs", why)
    with the first field that differs (one line)."""
    source = Path(source)
    if not (source / "done.json").exists():
        return "wait", f"its same_as run {str(source)!r} has not finished"
    missing = [name for name in FILES if not (source / name).exists()]
    if missing:
        return "differs", f"same_as run {str(source)!r} has no {missing[0]}"
    try:
        theirs = read_resolved(source)
    except (OSError, ValueError, KeyError, TypeError, ConfigError) as e:
        return "differs", f"same_as run {str(source)!r}: config.json unreadable ({e})"
    diffs = differences(config, theirs)
    if diffs:
        name, other, ours = diffs[0]
        return "differs", (
            f"same_as run {str(source)!r} differs in {name}: {other!r} there, "
            f"{ours!r} here; allowed: a run with this cell's config"
        )
    return "copy", ""


def read_resolved(run: Path) -> dict:
    """The resolved config (`resolved`) of a run folder's config.json; OSError,
    ValueError, KeyError, TypeError or ConfigError where it cannot be read."""
    with open(Path(run) / "config.json") as f:
        return resolved(json.load(f)["config"])


def differences(ours: dict, theirs: dict, ignore=NEUTRAL_FIELDS) -> list[tuple]:
    """(field, theirs, ours) for each field two resolved configs differ in, by name,
    but for `ignore`; a field one of them lacks is `'<absent>'` there."""
    return [
        (name, theirs.get(name, "<absent>"), ours.get(name, "<absent>"))
        for name in sorted(set(ours) | set(theirs))
        if name not in ignore
        and ours.get(name, "<absent>") != theirs.get(name, "<absent>")
    ]


def copy_run(source: Path, out: Path, record: dict) -> None:
    """Copy the run's `FILES` from `source` into `out`, each written atomically and
    done.json last; config.json gains `same_as` = `record` (where from, and what was
    compared)."""
    source, out = Path(source), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for name in FILES:
        if name == "config.json":
            with open(source / name) as f:
                d = json.load(f)
            d["same_as"] = record
            write_json(str(out / name), d)
        else:
            with open(source / name, "rb") as src:
                atomic_write(str(out / name), lambda f: shutil.copyfileobj(src, f))
