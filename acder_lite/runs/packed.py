"""Checkpoints that outlive the machine: a run's training state small enough to commit.

checkpoint.pt holds the replay buffer whole, and 95% of it is what MuJoCo can compute
again: every step's observation, achieved goal and full physics state. A packed
checkpoint (the folder `checkpoint.packed/` in the run folder) keeps, of each stored
episode, only its first physics state, its actions, its goal and its success; unpacking
re-simulates the rest. An observation is a function of the physics state
(`envs.step` refreshes the kinematics after every step) and a restored state replays
bit for bit, so the rebuilt buffer is the one that was packed. That is checked, not
assumed: packing records a SHA-256 digest of the whole buffer, and unpacking refuses a
rebuild whose digest differs (another MuJoCo build, another CPU) with one line.

A packed episode is some forty times smaller than a stored one (the sizes measured on
the grid's runs are in results/README.md). The episodes go to chunk files that never
change once written (`episodes-<first>-<end>.npz`), so packing the same run again in a
later session adds one chunk for the new episodes and rewrites only `state.pt.gz` (the
networks, optimisers, normalisers, random states: everything of checkpoint.pt but the
buffer's arrays). A repository that commits the packed folder of a run in flight thus
grows by that run's new episodes, not by its whole buffer, each session.

Trap: a buffer that wraps (FIFO: the 400-epoch Multi-step Push does at epoch 100)
overwrites its oldest slots, so its slots no longer hold the episodes in order. A chunk
is therefore a span of *slots*, kept while the buffer's slots there hold what it holds
(checked array by array), and new chunks are cut at multiples of `SLOT_BLOCK` slots: a
pack of a wrapped buffer writes only the blocks overwritten since the last pack (at most
two blocks more than the new episodes), not the whole buffer again (which for that run
was about 65 MB at each session's pack). A chunk written while the buffer is wrapped is
named by the episodes ever stored (`-w<total>`), so it never takes the name of a chunk
the current state.pt.gz still lists.

`python -m acder_lite pack DIR` packs every run under DIR that has a checkpoint.pt and
has not finished, and removes the packed folder of runs that have; `train --resume`
(and so `sweep`) unpacks a run folder whose packed checkpoint is the only one, or later
than its checkpoint.pt (never the other way round: an older checkpoint.pt neither
resumes nor is packed over a later pack).
"""

from __future__ import annotations

import gzip
import hashlib
import os
import re
import shutil
import sys
import tempfile
import zlib
from pathlib import Path

import numpy as np
import torch

from acder_lite.envs import fetch as E
from acder_lite.algo.buffer import KEYS
from acder_lite.io import (
    CheckpointError,
    arrays_as_tensors,
    atomic_write,
    checkpoint_config,
    load_torch,
)

FOLDER = "checkpoint.packed"
STATE = "state.pt.gz"
FORMAT = 1
"""The layout's version, recorded in state.pt.gz; unpack refuses others."""
SLOT_BLOCK = 2000
"""New chunks are cut at multiples of this many buffer slots (episodes): small enough
that a wrapped buffer's pack rewrites little beside the overwritten slots (2,000
Multi-step Push episodes pack to about 3 MB), large enough to keep a run's chunk files
few (20 for a full 40,000-episode buffer)."""
CHUNK = re.compile(r"episodes-(\d{8})-(\d{8})(?:-w(\d{8}))?\.npz")


def digest(buffer: dict) -> str:
    """SHA-256 over the filled part of every buffer array (the keys of
    `EpisodeBuffer.state_dict`), with their shapes and dtypes: equal digests, equal
    buffers bit for bit."""
    h = hashlib.sha256()
    for key in (*KEYS, "success"):
        a = np.ascontiguousarray(buffer[key])
        h.update(f"{key}:{a.dtype.str}:{a.shape};".encode())
        h.update(memoryview(a).cast("B"))
    return h.hexdigest()


def episodes_of(buffer: dict, lo: int, hi: int) -> dict:
    """What a chunk keeps of stored episodes lo..hi-1: the first physics state, the
    actions, the goal (one per episode: `run_episodes` holds it for the whole episode)
    and the success flag."""
    g = buffer["g"][lo:hi]
    if not (g == g[:, :1]).all():
        raise ValueError("a stored episode changes its goal mid-episode: cannot pack")
    return dict(
        state0=np.ascontiguousarray(buffer["state"][lo:hi, 0]),
        u=np.ascontiguousarray(buffer["u"][lo:hi]),
        g=np.ascontiguousarray(g[:, 0]),
        success=np.ascontiguousarray(buffer["success"][lo:hi]),
    )


def replay(env, state0: np.ndarray, u: np.ndarray, g: np.ndarray) -> dict:
    """One stored episode re-simulated from its first state and its actions: o, ag and
    state for its T + 1 steps, as `rollout.run_episodes` recorded them, and whether
    its last step succeeded."""
    T = u.shape[0]
    E.set_state(env, state0)
    env.goal = np.array(g, dtype=np.float64)
    obs = E.observe(env)
    o = np.empty((T + 1, obs["observation"].size), np.float32)
    ag = np.empty((T + 1, obs["achieved_goal"].size), np.float32)
    state = np.empty((T + 1, state0.size), np.float64)
    o[0], ag[0], state[0] = obs["observation"], obs["achieved_goal"], state0
    ok = False
    for t in range(T):
        obs, ok = E.step(env, u[t])
        o[t + 1], ag[t + 1] = obs["observation"], obs["achieved_goal"]
        E.get_state(env, state[t + 1])
    return dict(o=o, ag=ag, state=state, success=ok)


def rebuild(env, meta: dict, chunks: list[dict]) -> dict:
    """The buffer's `state_dict` from its packed chunks, re-simulated in `env` (a Fetch
    env of the run's task and observation set), then checked against the digest taken
    when it was packed."""
    n, T = int(meta["n"]), int(meta["T"])
    obs = E.observe(env)
    want = dict(
        state0=(E.state_size(env),),
        u=(T, env.action_space.shape[0]),
        g=(obs["desired_goal"].size,),
        success=(),
    )
    for i, c in enumerate(chunks):
        for k, shape in want.items():
            if c[k].shape[1:] != shape:  # e.g. packed before envs.STATE_SPEC changed
                raise CheckpointError(
                    f"packed checkpoint: chunk {i} holds {k} of shape "
                    f"{c[k].shape[1:]} an episode, this version and task need {shape}; "
                    "allowed: a folder `pack` wrote for this task with this version"
                )
    parts = {k: np.concatenate([c[k] for c in chunks]) for k in want}
    if parts["u"].shape[0] != n:
        raise CheckpointError(
            f"packed checkpoint: its chunks hold {parts['u'].shape[0]} episodes, "
            f"its state names {n}; allowed: a folder `pack` wrote"
        )
    out = dict(
        o=np.empty((n, T + 1, obs["observation"].size), np.float32),
        ag=np.empty((n, T + 1, obs["achieved_goal"].size), np.float32),
        g=np.repeat(parts["g"][:, None, :], T, axis=1),
        u=parts["u"],
        state=np.empty((n, T + 1, want["state0"][0]), np.float64),
        success=parts["success"],
    )
    for e in range(n):
        ep = replay(env, parts["state0"][e], out["u"][e], parts["g"][e])
        out["o"][e], out["ag"][e], out["state"][e] = ep["o"], ep["ag"], ep["state"]
    if digest(out) != meta["digest"]:
        raise CheckpointError(
            "packed checkpoint: the re-simulated replay buffer differs from the one "
            "that was packed (another MuJoCo build or CPU?); nothing was resumed; "
            "allowed: unpack where the versions in its config.json hold"
        )
    out.update(n=n, next=int(meta["next"]), total=int(meta["total"]))
    return out


# ----- the folder


def _chunk_name(lo: int, hi: int, total: int | None = None) -> str:
    """`episodes-<first>-<end>.npz`, the buffer slots it holds; a wrapped buffer's
    (`total` episodes ever stored) adds `-w<total>`, so it never overwrites a chunk the
    current state.pt.gz names."""
    wrap = "" if total is None else f"-w{total:08d}"
    return f"episodes-{lo:08d}-{hi:08d}{wrap}.npz"


def _read_chunk(path: Path) -> dict:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in ("state0", "u", "g", "success")}


def _same(a: dict, b: dict) -> bool:
    return all(np.array_equal(a[k], b[k]) for k in a)


def pack(ckpt: dict, folder: str | Path, block: int = SLOT_BLOCK) -> dict:
    """Write checkpoint `ckpt` (a `Trainer.state_dict`, as `load_torch` reads it) as a
    packed folder. Chunks already there whose slots the buffer still holds unchanged
    are kept; the other slots are written in new chunks cut at multiples of `block`
    slots; any chunk not kept is removed once the new state names the new set. Returns
    what was written: episodes, new (slots written), bytes of the folder."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    buf = ckpt["buffer"]
    n, total = int(buf["n"]), int(buf["total"])
    wrapped = total != n  # slots no longer in episode order
    chunks = {lo: (hi, name) for lo, hi, name in _reusable_chunks(folder, buf)}
    written, at = 0, 0
    for lo in [*sorted(chunks), n]:  # the gaps between kept chunks, in blocks
        while at < lo:
            hi = min(lo, (at // block + 1) * block)
            name = _chunk_name(at, hi, total if wrapped else None)
            part = episodes_of(buf, at, hi)
            atomic_write(str(folder / name), lambda f: np.savez_compressed(f, **part))
            chunks[at] = (hi, name)
            written += hi - at
            at = hi
        at = chunks[lo][0] if lo < n else n
    names = [chunks[lo][1] for lo in sorted(chunks)]
    T = int(np.asarray(buf["u"]).shape[1])
    meta = dict(
        n=n,
        next=int(buf["next"]),
        total=int(buf["total"]),
        T=T,
        digest=digest(buf),
        chunks=names,
    )
    rest = {k: v for k, v in ckpt.items() if k != "buffer"}
    rest.update(buffer=meta, packed_format=FORMAT)

    def write(f):
        with gzip.GzipFile(fileobj=f, mode="wb", compresslevel=6, mtime=0) as z:
            torch.save(arrays_as_tensors(rest), z)

    atomic_write(str(folder / STATE), write)
    for p in folder.glob("episodes-*.npz"):  # after state.pt.gz names the new set
        if p.name not in names:
            p.unlink()
    size = sum(p.stat().st_size for p in folder.iterdir())
    return dict(episodes=n, new=written, bytes=size)


def _spans(names) -> list[tuple[int, int, str]]:
    """(first slot, end slot, name) of each chunk name `pack` writes, in their order;
    other names are left out."""
    found = [(m, name) for name in names if (m := CHUNK.fullmatch(name))]
    return [(int(m[1]), int(m[2]), name) for m, name in found]


def _reusable_chunks(folder: Path, buf: dict) -> list[tuple[int, int, str]]:
    """The chunks in `folder` whose slots the buffer still holds unchanged (checked
    array by array), none overlapping another; for two over the same slots the one
    starting first and then the longer is tried first."""
    n, keep, end = int(buf["n"]), [], 0
    spans = _spans(p.name for p in folder.glob("episodes-*.npz"))
    for lo, hi, name in sorted(spans, key=lambda x: (x[0], -x[1])):
        if lo < end or hi > n or hi <= lo:
            continue
        try:
            same = _same(_read_chunk(folder / name), episodes_of(buf, lo, hi))
        except Exception:  # damaged: its slots go to a new chunk
            same = False
        if same:
            keep.append((lo, hi, name))
            end = hi
    return keep


def has_packed(run_dir: str | Path) -> bool:
    return (Path(run_dir) / FOLDER / STATE).is_file()


def read_state(run_dir: str | Path) -> dict:
    """The packed folder's state.pt.gz: the checkpoint without the buffer's arrays,
    its `buffer` the list of chunks, counts and digest. CheckpointError (one line) for
    a missing, truncated or foreign file."""
    state_path = Path(run_dir) / FOLDER / STATE
    if not state_path.is_file():
        raise CheckpointError(
            f"{str(state_path.parent)!r} holds no packed checkpoint ({STATE})"
        )
    fd, tmp = tempfile.mkstemp(suffix=".pt")
    try:
        with os.fdopen(fd, "wb") as out, gzip.open(state_path, "rb") as z:
            shutil.copyfileobj(z, out)
        ckpt = load_torch(tmp)
    except (OSError, EOFError, zlib.error) as e:
        raise CheckpointError(
            f"packed checkpoint {str(state_path)!r} is truncated or not gzip "
            f"({type(e).__name__}); allowed: a folder `pack` wrote"
        ) from None
    except CheckpointError as e:  # it names the temporary file: name ours
        raise CheckpointError(
            str(e).replace(repr(tmp), repr(str(state_path)))
        ) from None
    finally:
        os.unlink(tmp)
    if ckpt.get("packed_format") != FORMAT:
        raise CheckpointError(
            f"packed checkpoint {str(state_path)!r} has format "
            f"{ckpt.get('packed_format')!r}; allowed: {FORMAT}"
        )
    return ckpt


def cycle_of(ckpt: dict) -> int:
    """The training cycle a checkpoint (full or packed) was written at."""
    return int(ckpt["progress"]["cycle"])


def later_than(run_dir: str | Path, ckpt: dict | None) -> tuple[bool, str]:
    """(whether `run_dir`'s packed checkpoint should be used rather than `ckpt`, its
    checkpoint.pt as loaded or None, and a note when a packed folder is passed over).
    The later of the two wins; a packed folder that cannot be read loses to a
    checkpoint.pt (and raises CheckpointError where there is none). A folder without
    its state.pt.gz (a first `pack` killed before it ended: it writes the state last)
    holds no packed checkpoint, and the note says so."""
    if not has_packed(run_dir):
        if ckpt is not None and (Path(run_dir) / FOLDER).is_dir():
            return False, (
                f"{FOLDER}/ passed over: it holds no whole packed checkpoint (no "
                f"{STATE}: a pack stopped before its end)"
            )
        return False, ""
    if ckpt is None:
        return True, ""
    try:
        return cycle_of(read_state(run_dir)) > cycle_of(ckpt), ""
    except CheckpointError as e:
        return False, f"{FOLDER}/ passed over: {e}"


def read(run_dir: str | Path) -> tuple[dict, list[dict]]:
    """The packed folder of `run_dir` read whole, nothing re-simulated yet: its state
    (`read_state`: the checkpoint without the buffer's arrays) and the chunks it
    names. CheckpointError (one line) for any file missing, truncated or foreign, so
    a damaged folder is refused before the minutes of `unpack`."""
    folder = Path(run_dir) / FOLDER
    state = read_state(run_dir)
    chunks = []
    for name in state["buffer"]["chunks"]:
        try:
            chunks.append(_read_chunk(folder / name))
        except FileNotFoundError:
            raise CheckpointError(
                f"packed checkpoint {str(folder)!r}: chunk {name} is missing; "
                "allowed: a folder `pack` wrote, with every chunk its state.pt.gz names"
            ) from None
        except Exception as e:  # a truncated or foreign .npz
            raise CheckpointError(
                f"packed checkpoint {str(folder)!r}: chunk {name} cannot be read "
                f"({type(e).__name__}); allowed: a folder `pack` wrote"
            ) from None
    if not chunks:
        raise CheckpointError(
            f"packed checkpoint {str(folder)!r} names no chunk; allowed: a folder "
            "`pack` wrote"
        )
    spans = _spans(state["buffer"]["chunks"])
    ends = [0] + [hi for _, hi, _ in spans]
    if len(spans) != len(chunks) or any(lo != e for (lo, _, _), e in zip(spans, ends)):
        raise CheckpointError(
            f"packed checkpoint {str(folder)!r}: its chunks do not follow each other "
            "slot by slot from 0; allowed: a folder `pack` wrote"
        )
    return state, chunks


def unpack(run_dir: str | Path, env=None, files=None) -> dict:
    """The full checkpoint (as `load_torch` gives checkpoint.pt) from the packed folder
    of `run_dir`: the buffer re-simulated and checked (`rebuild`). `env`: a Fetch env
    of the run's task and observation set (None: made here); `files`: what `read` gave
    for the folder, if it has been read already (None: read here)."""
    state, chunks = read(run_dir) if files is None else files
    ckpt = dict(state)  # `files` stays as it was
    meta = ckpt.pop("buffer")
    ckpt.pop("packed_format")
    if env is None:
        cfg = ckpt["config"]
        env = E.make_env(cfg["env"], seed=0, obs=cfg.get("obs", "full"))
    ckpt["buffer"] = rebuild(env, meta, chunks)
    return ckpt


# ----- python -m acder_lite pack


def run_folders(paths: list[str]) -> list[Path]:
    """The run folders in `paths` (each a run folder, or a folder searched for them):
    every folder that holds a checkpoint.pt or a packed checkpoint, sorted."""
    if "" in paths:  # Path("") is ".": this folder was packed
        raise CheckpointError("pack: '' is an empty path; allowed: a folder")
    found = set()
    for p in map(Path, paths):
        if not p.is_dir():
            raise CheckpointError(f"pack: {str(p)!r} is not a folder")
        for hit in [*p.rglob("checkpoint.pt"), *p.rglob(f"{FOLDER}/{STATE}")]:
            found.add(hit.parent.parent if hit.name == STATE else hit.parent)
    return sorted(found)


def pack_run(run_dir: Path) -> str:
    """Pack one run folder, or remove the packed folder of a run that has ended;
    returns the line to print."""
    folder = run_dir / FOLDER
    if (run_dir / "done.json").exists():
        if folder.exists():
            shutil.rmtree(folder)
            return f"removed  {run_dir}/{FOLDER} (the run has ended)"
        return f"skipped  {run_dir} (the run has ended)"
    if not (run_dir / "checkpoint.pt").exists():
        return f"kept     {run_dir}/{FOLDER} (no checkpoint.pt)"
    ckpt = load_torch(str(run_dir / "checkpoint.pt"))
    if "buffer" not in ckpt:
        raise CheckpointError(f"{str(run_dir)!r}: checkpoint.pt holds a policy only")
    path = str(run_dir / "checkpoint.pt")
    cycles = checkpoint_config(ckpt, path).cycles  # before anything is written
    later, note = later_than(run_dir, ckpt)
    if later:  # e.g. a checkpoint.pt left on this machine, a later pack from another
        return f"kept     {run_dir}/{FOLDER} (later than checkpoint.pt)"
    try:
        w = pack(ckpt, folder)
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as e:
        if isinstance(e, CheckpointError):
            raise
        # a buffer of other keys or shapes; the packed folder's state.pt.gz, written
        # last, still names the chunks it had (or there is none)
        raise CheckpointError(
            f"checkpoint {path!r}: its buffer is not one train writes "
            f"({type(e).__name__}: {e}); allowed: the checkpoint.pt train writes"
        ) from None
    epoch = ckpt["progress"]["cycle"] / cycles
    return (
        f"packed   {run_dir} at epoch {epoch:g}: {w['episodes']} episodes "
        f"({w['new']} new), {w['bytes'] / 1e6:.1f} MB" + (f"; {note}" if note else "")
    )


def add_arguments(p) -> None:
    p.add_argument(
        "paths",
        nargs="+",
        metavar="DIR",
        help="run folders, or folders to search for them (e.g. results experiments)",
    )


def run(args) -> int:
    """Pack every unfinished run under the paths (and drop finished runs' packed
    folders); exit 2 if a run could not be packed (one line each; the other runs are
    packed all the same). A path that is not a folder is a CheckpointError before any
    run is packed (`run_folders`; the CLI prints its one line and exits 2)."""
    folders = run_folders(args.paths)
    if not folders:
        print("pack: no run folder with a checkpoint under " + " ".join(args.paths))
    failed = 0
    for d in folders:  # one bad folder does not keep the others from being packed
        try:
            print(pack_run(d), flush=True)
        except CheckpointError as e:
            failed += 1
            print(f"failed   {d}: {e}", file=sys.stderr, flush=True)
        except OSError as e:  # a run folder that takes no file (read-only, full disk)
            failed += 1
            # io.WriteError: the file's previous version is whole, no partial file
            print(
                f"failed   {d}: {FOLDER}/ cannot be written ({e.strerror}); its "
                "packed checkpoint is as it was (or none), checkpoint.pt untouched; "
                "allowed: a run folder you can write to, with space (then pack again)",
                file=sys.stderr,
                flush=True,
            )
    return 2 if failed else 0
