"""Files that are never half-written: write to a temporary name in the same folder, then rename."""
from __future__ import annotations

import csv
import io
import json
import os
import tempfile

import torch


def _atomic(path: str, write) -> None:
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=folder)
    try:
        os.chmod(tmp, 0o644)
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def write_json(path: str, obj) -> None:
    _atomic(path, lambda f: f.write((json.dumps(obj, indent=2, sort_keys=False) + "\n").encode()))


def write_csv(path: str, rows: list[dict], columns: list[str]) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: _fmt(row.get(k, "")) for k in columns})
    _atomic(path, lambda f: f.write(buf.getvalue().encode()))


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    return v


def save_torch(path: str, obj) -> None:
    _atomic(path, lambda f: torch.save(obj, f))


class CheckpointError(ValueError):
    """A checkpoint that cannot be read: truncated, not ours, or for another task."""


def load_torch(path: str) -> dict:
    if not os.path.isfile(path):
        raise CheckpointError(f"checkpoint {path!r} does not exist")
    try:
        obj = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # truncated zip, random bytes, ...
        raise CheckpointError(f"checkpoint {path!r} is truncated or not a checkpoint "
                              f"({type(e).__name__}); allowed: a checkpoint.pt or policy.pt written by train") from None
    if not isinstance(obj, dict) or "policy" not in obj:
        raise CheckpointError(f"checkpoint {path!r} is not an acder_lite checkpoint "
                              "(allowed: a checkpoint.pt or policy.pt written by train)")
    return obj
