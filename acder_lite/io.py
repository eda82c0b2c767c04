"""Files that are never half-written (write to a temporary name in the same folder, then
rename), and torch files read without running anything from them (`load_torch`,
`SAFE_GLOBALS`)."""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import pickle
import re
import socket
import tempfile
import warnings
import zipfile

import numpy as np
import torch

from acder_lite.signals import deferred


def atomic_write(path: str, write, make_folder: bool = True) -> None:
    """Call `write(f)` on a binary file that becomes `path` only once written whole: a
    temporary file in the same folder, flushed and fsynced, then renamed over `path`
    (atomic on POSIX), so a reader sees the old file or the new one, never half of one.
    For writers outside this module (the robustness bench's tables, the exported
    policy). WriteError if the file cannot be written (`_atomic`)."""
    _atomic(path, write, make_folder)


class WriteError(OSError):
    """A file `atomic_write` could not write: no space left, a read-only folder, a
    folder removed meanwhile. Its previous version (or its absence) is as it was, and
    no temporary file is left; `filename` is the file meant, `strerror` why.

    Trap: torch.save on a full disk raised RuntimeError ("unexpected pos ..."), the
    OSError only its context: the command ended in a 40-line traceback."""

    def __str__(self) -> str:
        return (
            f"{self.filename!r} could not be written ({self.strerror}); "
            "its previous version is kept whole, and no partial file"
        )


def _os_error(e: BaseException) -> OSError | None:
    """The OSError a failed write raised: `e` itself, or the one under the
    RuntimeError that torch's zip writer raises over it (its context or cause)."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, OSError):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def _atomic(path: str, write, make_folder: bool = True) -> None:
    """`atomic_write`. `make_folder=False`: a folder that is not there is an error, not
    made again (a run folder removed while its run trained, `runfiles.RunFiles`)."""
    folder = os.path.dirname(os.path.abspath(path))
    tmp = None
    try:
        if make_folder:
            os.makedirs(folder, exist_ok=True)
        remove_stale_temps(folder)
        fd, tmp = tempfile.mkstemp(
            prefix=f".{os.path.basename(path)}.{_TEMP_TAG}-{os.getpid()}.",
            suffix=".tmp",
            dir=folder,
        )
        with deferred():  # an interrupt inside torch.save is no KeyboardInterrupt
            os.chmod(tmp, 0o644)
            with os.fdopen(fd, "wb") as f:
                write(f)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
    except BaseException as e:
        if tmp is not None and os.path.exists(tmp):
            try:
                os.unlink(tmp)
            except OSError:  # e.g. the folder went read-only meanwhile
                pass
        # not an interrupt, nor a value the writer refused (TypeError, ...)
        err = _os_error(e) if isinstance(e, (OSError, RuntimeError)) else None
        if err is None or isinstance(err, WriteError):
            raise
        raise WriteError(err.errno, err.strerror or str(err), path) from None


_TEMP_TAG = hashlib.sha1(socket.gethostname().encode()).hexdigest()[:8]
"""This machine, in the names of the temporary files `_atomic` writes
(`.NAME.<machine>-<pid>.<random>.tmp`), so `remove_stale_temps` knows whose process
left one."""

_TEMP_NAME = re.compile(r"^\..+\.([0-9a-f]{8})-([0-9]+)\.[^.]+\.tmp$")


def remove_stale_temps(folder: str) -> list[str]:
    """Remove the temporary files in `folder` that a process of this machine killed
    while it wrote (SIGKILL, a power cut: `_atomic` could not remove its own), and
    return their names. A file of a process still running, of another machine (a
    shared folder), or of another name is left alone. Trap: a checkpoint's temporary
    file is as large as the checkpoint, and every kill left one more."""
    gone = []
    try:
        names = os.listdir(folder)
    except OSError:
        return gone
    for name in names:
        m = _TEMP_NAME.match(name)
        if not m or m.group(1) != _TEMP_TAG or _running(int(m.group(2))):
            continue
        try:
            os.unlink(os.path.join(folder, name))
            gone.append(name)
        except OSError:  # gone meanwhile, or a folder that takes no change
            pass
    return gone


def _running(pid: int) -> bool:
    """Whether process `pid` runs on this machine (ours or another user's)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True
    return True


RUN_FILES = ("checkpoint.pt", "policy.pt", "config.json", "progress.csv", "done.json")
"""The files train writes in a run folder (`runfiles.RunFiles`)."""


def check_output(
    path: str, option: str, inputs: tuple = (), overwrite: bool = True
) -> None:
    """Raise ConfigError (one line naming `option`) unless a command may write its
    output `path` (checked before any work): not empty, not a folder, not a link, a
    device or a pipe (the atomic rename would replace it by a plain file), no file
    where a folder above it should be, not one of the command's `inputs`, not a
    run's own file (`RUN_FILES`), (overwrite=False) not there yet, and a file can be
    made where it goes: a temporary file in its folder, or in the nearest folder
    above it that exists, made and removed at once (`write_error` if not). Trap:
    os.access says yes to root in a folder such as /proc, where no file can be made.
    The output itself is still written atomically, after the work."""
    from acder_lite.config import ConfigError

    def bad(what, allowed="another file"):
        raise ConfigError(f"{option}={path!r} {what}; allowed: {allowed}")

    if not path:
        bad("is empty", "a file path")
    if os.path.isdir(path):
        bad("is a folder", "a file path (in a folder)")
    if os.path.islink(path) or (os.path.exists(path) and not os.path.isfile(path)):
        # the atomic rename would put a plain file in place of a link, a device
        # (/dev/null) or a FIFO
        bad("is a link, a device or a pipe", "a regular file or a new path")
    up = file_in_the_way(path, itself=False)
    if up:
        bad(f"lies under {up!r}, a file", "a path in a folder")
    if any(os.path.abspath(path) == os.path.abspath(i) for i in inputs if i):
        bad("is the input file itself")
    if os.path.exists(path):
        if os.path.basename(path) in RUN_FILES:
            bad("would overwrite a run's file", "a file outside the run's files")
        if not overwrite:
            bad("already exists", "a file not yet there (nothing is overwritten)")
    try:
        probe_write(next(f for f in folders_above(path) if os.path.isdir(f)))
    except OSError as e:
        raise write_error(option, path, e) from None


def probe_write(folder: str) -> None:
    """Make and remove a file in `folder` (OSError if it takes none). Trap: a folder
    there already may take no file (/proc, read-only; os.access says yes to root),
    which train's first write found only after the work, a traceback."""
    fd, probe = tempfile.mkstemp(prefix=".probe.", suffix=".tmp", dir=folder)
    os.close(fd)
    os.unlink(probe)


def folders_above(path: str) -> list[str]:
    """The folders above `path`, nearest first, up to the root."""
    out, p = [], os.path.dirname(os.path.abspath(path))
    while p and p not in out:
        out.append(p)
        p = os.path.dirname(p)
    return out


def file_in_the_way(path, itself: bool = True) -> str | None:
    """The nearest path that exists at `path` (if `itself`) or above it, when it is not
    a folder (a file where a folder must be, or be made); None when it is one. Train's
    --out, sweep's run folders, a plan's same_as and every output file ask this."""
    for p in [str(path)] * itself + folders_above(str(path)):
        if os.path.exists(p):
            return None if os.path.isdir(p) else p
    return None


def write_error(option: str, path: str, e: OSError):
    """The one-line error of an output that could not be written
    (to raise from the OSError `e`)."""
    from acder_lite.config import ConfigError

    return ConfigError(
        f"{option}={path!r} cannot be written ({e.strerror or type(e).__name__}); "
        "allowed: a file in a folder you can write to"
    )


def json_ready(v):
    """`v` with inf and NaN (which JSON has not) as None, through lists and dicts."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, (list, tuple)):
        return [json_ready(x) for x in v]
    if isinstance(v, dict):
        return {k: json_ready(x) for k, x in v.items()}
    return v


def write_json(path: str, obj, make_folder: bool = True) -> None:
    _atomic(
        path,
        lambda f: f.write((json.dumps(obj, indent=2, sort_keys=False) + "\n").encode()),
        make_folder,
    )


def write_csv(
    path: str, rows: list[dict], columns: list[str], make_folder: bool = True
) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(
        buf, fieldnames=columns, extrasaction="ignore", lineterminator="\n"
    )
    w.writeheader()
    for row in rows:
        w.writerow({k: _fmt(row.get(k, "")) for k in columns})
    _atomic(path, lambda f: f.write(buf.getvalue().encode()), make_folder)


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    return v


def save_torch(path: str, obj, make_folder: bool = True) -> None:
    _atomic(path, lambda f: torch.save(obj, f), make_folder)


NUMPY_TAG = "__numpy__"
"""The key of the one-entry dict that stands for a numpy array in a checkpoint.pt
(`arrays_as_tensors`)."""


def arrays_as_tensors(obj):
    """`obj` with every numpy array in its dicts, lists and tuples replaced by
    {NUMPY_TAG: a tensor sharing the array's memory}; everything else (and every
    container holding no array) is the same object. `load_torch` turns them back into
    the same arrays, bit for bit (`tensors_as_arrays`).

    Why: torch.save writes a tensor's bytes to the archive as they are, but pickles a
    numpy array through pickle protocol 2, which copies it and spells its bytes as
    latin-1 text. A Push run's checkpoint at epoch 24 (354 MB of replay buffer) was a
    525 MB file that took 8-9 s to write (6 s of CPU) at every epoch end; as tensors,
    359 MB in 0.8-2 s (experiments/speed/checkpoint_ab.txt)."""
    if isinstance(obj, np.ndarray):
        try:
            return {NUMPY_TAG: torch.from_numpy(np.ascontiguousarray(obj))}
        except TypeError:  # a dtype torch has no tensor of: pickled as before
            return obj
    return _map_children(obj, arrays_as_tensors)


def tensors_as_arrays(obj):
    """Undo `arrays_as_tensors`: each {NUMPY_TAG: tensor} becomes the tensor's numpy
    array (the same memory, the same dtype and bits). A file written before (arrays
    pickled as arrays) passes unchanged."""
    if (
        isinstance(obj, dict)
        and len(obj) == 1
        and isinstance(obj.get(NUMPY_TAG), torch.Tensor)
    ):
        return obj[NUMPY_TAG].numpy()
    return _map_children(obj, tensors_as_arrays)


def _map_children(obj, f):
    """`obj` with `f` applied to the values of a dict (any dict type) or the items of a
    list or tuple; `obj` itself when nothing changed. Trap: rebuilding every dict would
    drop what a torch state_dict carries beside its items (its `_metadata`)."""
    if isinstance(obj, dict):
        new = {k: f(v) for k, v in obj.items()}
        if all(new[k] is v for k, v in obj.items()):
            return obj
        out = type(obj)(new) if type(obj) is not dict else new
        if hasattr(obj, "_metadata"):
            out._metadata = obj._metadata
        return out
    if isinstance(obj, (list, tuple)):
        new = [f(v) for v in obj]
        if all(a is b for a, b in zip(new, obj)):
            return obj
        return type(obj)(new)
    return obj


class CheckpointError(ValueError):
    """A checkpoint that cannot be read: truncated, not ours, or for another task."""


def _safe_globals() -> tuple:
    """What a file of ours may name besides tensors, numbers, strings, lists, dicts:
    see SAFE_GLOBALS."""
    from torch.torch_version import TorchVersion

    # numpy's array reconstructor, whatever module it lives in
    rebuild = np.zeros(0).__reduce__()[0]
    return (
        # numpy arrays (normaliser sums, replay buffer, start-state pool, priorities,
        # energies): ndarray.__reduce__ -> _reconstruct(ndarray, (0,), b'b')
        # + BUILD with the dtype and bytes
        (rebuild, "numpy._core.multiarray._reconstruct"),  # numpy >= 2 writes this name
        (
            rebuild,
            "numpy.core.multiarray._reconstruct",
        ),  # numpy 1.x wrote this one: the same function
        np.ndarray,
        np.dtype,  # dtype('f8', False, True) + BUILD, on the dtype's class below
        # the dtype classes our arrays have (float32 buffer rows,
        # float64 states and statistics, bool success)
        np.dtypes.Float32DType,
        np.dtypes.Float64DType,
        np.dtypes.BoolDType,
        # checkpoint.pt's versions.torch is torch.__version__, a str subclass
        TorchVersion,
    )


SAFE_GLOBALS = _safe_globals()
"""The only globals `load_torch` lets a file name (torch.load(weights_only=True) already
allows tensors, OrderedDict, and Python's
int/float/str/bytes/bool/None/list/tuple/dict/set). Everything else -- os.system,
builtins.eval, a class of the writer's -- is refused before it runs. The numpy bit
generators' states are plain dicts of str and int (PCG64's ints exceed 2^64; pickle's
LONG1 carries them), so they need nothing here."""

ALLOWED = "allowed: a checkpoint.pt or policy.pt written by train"
CHECKPOINT_KEYS = (
    "config",
    "policy",
    "agent",
    "o_norm",
    "g_norm",
    "buffer",
    "progress",
    "rng",
)
"""What a checkpoint.pt holds besides the policy (Trainer.state_dict);
a policy.pt holds only `policy`."""


def _first_line(e: BaseException) -> str:
    """The informative line of an exception, made one line and not too long."""
    text = str(e)
    if (
        "WeightsUnpickler error:" in text
    ):  # torch's explanation first, then what was refused
        text = text.split("WeightsUnpickler error:", 1)[1]
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    line = lines[0] if lines else type(e).__name__
    return line if len(line) <= 200 else line[:197] + "..."


def _refused(e: BaseException) -> str:
    """Why torch's safe unpickler refused the file, as the end of one sentence."""
    m = re.search(r"GLOBAL ([\w.]+)", str(e))
    if m:  # a __reduce__ of the writer's: os.system, builtins.exec, a class, ...
        return (
            f"it names the global {m.group(1)} (to call or "
            "build it), which a policy or checkpoint never does"
        )
    return f"its pickle is not one torch reads safely ({_first_line(e)})"


def load_torch(path: str) -> dict:
    """Read a policy.pt or checkpoint.pt written by train,
    without running anything from the file.

    torch.load(weights_only=True) with SAFE_GLOBALS: a pickle naming any other global
    (a crafted `__reduce__`) is refused before the call happens. Then the layout is
    checked: a dict with our `policy` (keys, types and the actor's shapes,
    `check_policy`) and, for a checkpoint, every part of `CHECKPOINT_KEYS`. Anything
    else raises CheckpointError: one line naming the file.
    """
    if os.path.isdir(path):
        raise CheckpointError(f"checkpoint {path!r} is a folder; {ALLOWED}")
    if not os.path.isfile(path):
        raise CheckpointError(f"checkpoint {path!r} does not exist; {ALLOWED}")
    with open(path, "rb") as f:
        head = f.read(4)
    if (
        head[:1] == b"\x80"
    ):  # pickle's PROTO opcode: a bare pickle (or torch's pre-1.6 format), never ours
        raise CheckpointError(
            f"checkpoint {path!r} is a bare pickle, not the zip archive torch.save "
            f"writes; it was not unpickled; {ALLOWED}"
        )
    if head != b"PK\x03\x04" or not zipfile.is_zipfile(path):
        raise CheckpointError(
            f"checkpoint {path!r} is truncated or not a checkpoint (not the zip "
            f"archive torch.save writes); {ALLOWED}"
        )
    if is_torchscript(path):
        raise CheckpointError(
            f"checkpoint {path!r} is a TorchScript file written by export; {ALLOWED}"
        )
    try:
        with (
            warnings.catch_warnings(),
            torch.serialization.safe_globals(list(SAFE_GLOBALS)),
        ):
            warnings.simplefilter(
                "ignore"
            )  # e.g. torch's note on an unusual pickle protocol: one line only
            obj = torch.load(path, map_location="cpu", weights_only=True)
        obj = tensors_as_arrays(obj)
    except pickle.UnpicklingError as e:
        raise CheckpointError(
            f"checkpoint {path!r} is not an acder_lite file: {_refused(e)}; nothing "
            f"from it was run; {ALLOWED}"
        ) from None
    except Exception as e:  # truncated zip, random bytes, ...
        raise CheckpointError(
            f"checkpoint {path!r} is truncated or not a checkpoint "
            f"({type(e).__name__}); {ALLOWED}"
        ) from None
    if not isinstance(obj, dict) or "policy" not in obj:
        what = (
            f"a dict with keys {_keys(obj)}"
            if isinstance(obj, dict)
            else f"a {type(obj).__name__}"
        )
        raise CheckpointError(
            f"checkpoint {path!r} is not an acder_lite checkpoint: it holds {what}, "
            f"not a dict with 'policy' ({ALLOWED})"
        )
    check_policy(obj["policy"], path)
    if any(k in obj for k in CHECKPOINT_KEYS if k != "policy"):
        missing = [k for k in CHECKPOINT_KEYS if not isinstance(obj.get(k), dict)]
        if missing:
            raise CheckpointError(
                f"checkpoint {path!r} is an incomplete checkpoint: no dict "
                f"{', '.join(missing)} ({ALLOWED})"
            )
    return obj


def is_torchscript(path: str) -> bool:
    """Whether the zip at `path` is a TorchScript archive (torch.jit.save, as `export`
    writes it): its records, under one top folder, hold constants.pkl and a code/
    folder, which torch.save never writes (torch.load tells the two apart the same
    way)."""
    try:
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
    except (OSError, zipfile.BadZipFile, ValueError):
        return False  # torch.load's error says what is wrong with it
    parts = [n.split("/") for n in names]
    return any(p[1:] == ["constants.pkl"] for p in parts) and any(
        len(p) > 2 and p[1] == "code" for p in parts
    )


def _keys(d: dict, most: int = 6) -> str:
    ks = [repr(k) for k in list(d)[:most]]
    return "[" + ", ".join(ks) + (", ..." if len(d) > most else "") + "]"


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_real(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


POLICY_KEYS = (
    "env",
    "method",
    "actor",
    "o_norm",
    "g_norm",
    "clip_obs",
    "shape",
    "norm",
)
"""What `rollout.Policy.state_dict` writes (and `Policy.from_state_dict` reads). The
trainer adds `obs` (`Config.obs`, the observation set; a policy written before it has
none and saw "full") and `trained` (epochs, episodes and the last test success, which
`export` copies into its metadata)."""


def _nonfinite(a) -> str:
    """How many entries of a tensor or array are NaN or infinite, as words."""
    if isinstance(a, torch.Tensor):  # numpy has no bfloat16
        a = a.detach().float().numpy()
    bad = ~np.isfinite(np.asarray(a, dtype=np.float64))
    return f"{int(bad.sum())} of {bad.size} values NaN or infinite"


def check_policy(d, path: str | None = None) -> None:
    """Raise CheckpointError (one line, naming `path`) unless `d` is a policy as
    `Policy.state_dict` writes it: its keys, the types of its numbers, and every actor
    tensor of the shape its recorded `shape` implies ([in_dim] + [hidden] * layers +
    [act_dim] Linear layers, in_dim = norm.o + norm.g), normaliser statistics of the
    sizes in `norm`, and every weight and statistic finite (a diverged run's NaN weights
    are refused, not run). Nothing is built; a valid policy passes unchanged."""
    where = f"checkpoint {path!r}: its policy" if path is not None else "policy"

    def bad(what: str):
        raise CheckpointError(f"{where} {what} ({ALLOWED})")

    if not isinstance(d, dict):
        bad(f"is a {type(d).__name__}, not a dict")
    missing = [k for k in POLICY_KEYS if k not in d]
    if missing:
        bad(f"has no {', '.join(missing)}")
    for k in ("env", "method"):
        if not isinstance(d[k], str):
            bad(f"{k} is a {type(d[k]).__name__}, not a string")
    from acder_lite.config import OBS_SETS

    if d.get("obs", "full") not in OBS_SETS:
        bad(f"obs is {d['obs']!r}, not one of {', '.join(OBS_SETS)}")
    s, n = d["shape"], d["norm"]
    for name, part, ints, reals in (
        ("shape", s, ("in_dim", "act_dim", "hidden", "layers"), ("max_u",)),
        ("norm", n, ("o", "g"), ("eps", "clip")),
    ):
        if not isinstance(part, dict):
            bad(f"{name} is a {type(part).__name__}, not a dict")
        for k in ints:
            if not _is_int(part.get(k)) or part[k] < 1:
                bad(f"{name}.{k} is {part.get(k)!r}, not an integer >= 1")
        for k in reals:
            if not _is_real(part.get(k)):
                bad(f"{name}.{k} is {part.get(k)!r}, not a finite number")
    if not _is_real(d["clip_obs"]):
        bad(f"clip_obs is {d['clip_obs']!r}, not a finite number")
    if s["in_dim"] != n["o"] + n["g"]:
        bad(f"shape.in_dim {s['in_dim']} is not norm.o + norm.g = {n['o']} + {n['g']}")
    sizes = [s["in_dim"]] + [s["hidden"]] * s["layers"] + [s["act_dim"]]
    want = {}
    for i in range(len(sizes) - 1):
        want[f"net.{2 * i}.weight"] = (sizes[i + 1], sizes[i])
        want[f"net.{2 * i}.bias"] = (sizes[i + 1],)
    actor = d["actor"]
    if not isinstance(actor, dict):
        bad(f"actor is a {type(actor).__name__}, not a dict of tensors")
    if set(actor) != set(want):
        extra, lack = (
            sorted(map(str, set(actor) - set(want))),
            sorted(set(want) - set(actor)),
        )
        bad(
            "actor does not match its shape ("
            + "; ".join(
                ([f"missing {', '.join(lack[:4])}"] if lack else [])
                + ([f"unexpected {', '.join(extra[:4])}"] if extra else [])
            )
            + f"; shape: layers={s['layers']})"
        )
    for k, shp in want.items():
        t = actor[k]
        if not isinstance(t, torch.Tensor) or not t.is_floating_point():
            bad(f"actor {k} is a {type(t).__name__}, not a float tensor")
        if tuple(t.shape) != shp:
            bad(f"actor {k} has shape {tuple(t.shape)}, its shape record implies {shp}")
        # Trap: a diverged run saves NaN weights without complaint, and a NaN action
        # reaches MuJoCo (which warns and resets) or an exported robot controller.
        if not bool(torch.isfinite(t).all()):
            bad(f"actor {k} holds {_nonfinite(t)}: the run that wrote it diverged")
    for k, size in (("o_norm", n["o"]), ("g_norm", n["g"])):
        st = d[k]
        if not isinstance(st, dict):
            bad(f"{k} is a {type(st).__name__}, not a dict")
        for a in ("sum", "sumsq"):
            v = st.get(a)
            if not isinstance(v, np.ndarray) or v.dtype.kind not in "fiu":
                bad(f"{k}.{a} is a {type(v).__name__}, not a numeric array")
            if v.shape != (size,):
                bad(f"{k}.{a} has shape {v.shape}, norm records {(size,)}")
            if not np.isfinite(v).all():
                bad(f"{k}.{a} holds {_nonfinite(v)}: the run that wrote it diverged")
        if not _is_int(st.get("count")) or st["count"] < 0:
            bad(f"{k}.count is {st.get('count')!r}, not an integer >= 0")


def checkpoint_config(ckpt: dict, path: str):
    """The Config of a checkpoint (`load_torch`'s, with its training state) that
    `train --resume` or `pack` reads, its fields and its progress checked first
    (CheckpointError, one line naming `path`). Trap: both divide by its cycles and count
    its progress before anything validates them; cycles=0 or a cycle 'x' was a
    traceback there."""
    from acder_lite.config import Config, ConfigError

    def bad(what):
        raise CheckpointError(
            f"checkpoint {path!r}: its {what}; allowed: the checkpoint.pt train writes"
        )

    try:
        cfg = Config.from_dict(dict(ckpt["config"]))
        cfg.validate()
    except ConfigError as e:
        bad(f"config: {e}")
    except TypeError as e:  # a field of no such name, e.g. a number as a key
        bad(f"config does not fit ({e})")
    p = ckpt["progress"]
    for k in ("cycle", "episodes", "env_steps"):
        v = p.get(k)
        if not isinstance(v, int) or isinstance(v, bool) or v < 0:
            bad(f"progress.{k} is {v!r}, not an integer >= 0")
    for k in ("wall", "success_rate"):
        v = p.get(k)
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            bad(f"progress.{k} is {v!r}, not a number")
    if not isinstance(p.get("rows"), list) or not all(
        isinstance(r, dict) for r in p["rows"]
    ):
        bad("progress.rows is not a list of rows (dicts)")
    if not isinstance(p.get("done"), bool):
        bad(f"progress.done is {p.get('done')!r}, not True or False")
    return cfg


def check_policy_fits(d: dict, path: str, obs: int, goal: int, act: int) -> None:
    """Raise CheckpointError unless the (checked) policy `d` takes observations of size
    `obs`, goals of size `goal` and gives actions of size `act` -- the sizes of the env
    it is asked to run in."""
    n, s = d["norm"], d["shape"]
    if (n["o"], n["g"], s["act_dim"]) != (obs, goal, act):
        raise CheckpointError(
            f"checkpoint {path!r}: its policy takes observation/goal/action sizes "
            f"{n['o']}/{n['g']}/{s['act_dim']}, {d['env']} has {obs}/{goal}/{act} "
            f"({ALLOWED})"
        )


def load_policy(path: str) -> tuple[dict, str]:
    """The policy dict of a run folder (its policy.pt, else checkpoint.pt) or of a .pt
    file, read without running anything from it (`io.load_torch`), and that file."""
    if os.path.isdir(path):
        for name in ("policy.pt", "checkpoint.pt"):
            if os.path.isfile(os.path.join(path, name)):
                path = os.path.join(path, name)
                break
        else:
            raise CheckpointError(
                f"run folder {path!r} holds neither policy.pt nor "
                "checkpoint.pt; allowed: a run folder written by "
                "train, or its policy.pt"
            )
    from acder_lite.config import ENV_IDS

    pol = load_torch(path)["policy"]
    if pol["env"] not in ENV_IDS:
        raise CheckpointError(
            f"checkpoint {path!r} names env {pol['env']!r}; allowed: "
            f"one of {', '.join(ENV_IDS)}"
        )
    return pol, path
