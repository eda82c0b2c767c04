"""Faults lose nothing and need no hand repair: no space left, a run folder made
read-only or removed mid-run, SIGKILL in the middle of a write, a plan file broken
while a sweep runs. Each is one line on stderr (what happened, what to do), exit 2
where a command stops, the previous files whole (compared byte for byte), no
temporary file left once the same command has run again, and that command (or
`train --resume`) then ends the run with the numbers of an uninterrupted run
(progress.csv without wall_s, and the policy's tensors).

A full disk is a real one where this machine lets the tests mount a small tmpfs, and
otherwise (and for the moments a real one cannot hit exactly) a write that fails
inside the real `io._atomic` (`fail_writes`); the kills are real SIGKILLs, sent by the
process itself in the middle of the write they name (`KILLER`)."""

from __future__ import annotations

import contextlib
import errno
import fnmatch
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import pytest
import torch

from acder_lite import io as aio
from acder_lite.cli.main import main
from acder_lite.io import WriteError, load_torch
from acder_lite.runs import packed
from acder_lite.train.trainer import Trainer

from conftest import ROOT, rows_of, tiny_config
from fault_files import Passthrough

TRAIN = [
    *"train --env FetchReach-v4 --method acder --epochs 2".split(),
    *"--workers 1 --cycles 2 --updates-per-cycle 2 --batch-size 16".split(),
    *"--test-episodes 1 --hidden 16 --sicm-hidden 16 --buffer-size 2000".split(),
    *"--threads 1 --quiet".split(),
]
"""A tiny ACDER run on FetchReach, two epochs of two cycles (a few seconds)."""


# ----- helpers


def one_line(capsys) -> str:
    """The one line the command printed on stderr (no traceback)."""
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def temps(folder) -> list[str]:
    """The temporary files `io._atomic` writes (`.NAME.<...>.tmp`) under `folder`."""
    return sorted(str(p.relative_to(folder)) for p in Path(folder).rglob(".*.tmp"))


def files(folder) -> dict:
    """Every file under `folder` and its bytes."""
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(Path(folder).rglob("*"))
        if p.is_file()
    }


def actor(run) -> dict:
    return load_torch(str(Path(run) / "policy.pt"))["policy"]["actor"]


def assert_same_run(run, reference) -> None:
    """`run` ended with the numbers of the uninterrupted `reference`: progress.csv
    (but wall_s), every tensor of the policy, done.json there, no temporary file."""
    assert rows_of(run / "progress.csv") == rows_of(reference / "progress.csv")
    a, b = actor(run), actor(reference)
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    assert (run / "done.json").exists() and not temps(run)


def assert_not_ahead(run) -> None:
    """progress.csv holds no row past the checkpoint on disk (none without one)."""
    if not (run / "progress.csv").exists():
        return
    assert (run / "checkpoint.pt").exists()
    saved = load_torch(str(run / "checkpoint.pt"))["progress"]["rows"]
    assert len(rows_of(run / "progress.csv")) <= len(saved)


class Full(Passthrough):
    """A file that takes `room` more bytes, then raises OSError(`err`): a disk that
    fills (ENOSPC) or a folder gone read-only (EROFS) in the middle of a write."""

    def __init__(self, f, room: int, err: int):
        super().__init__(f)
        self.room, self.err = room, err

    def write(self, b):
        b = memoryview(b).cast("B")
        if len(b) > self.room:
            self.f.write(b[: self.room])
            self.room = 0
            raise OSError(self.err, os.strerror(self.err))
        self.room -= len(b)
        return self.f.write(b)


def fail_writes(monkeypatch, name, nth=1, err=errno.ENOSPC, room=100, before=None):
    """The `nth` write of a file whose name matches `name` fails with OSError(`err`)
    after `room` bytes, inside the real `io._atomic` (its temporary file and its
    cleanup); `before(path)` runs first. Returns a dict whose "previous" is the bytes
    the file held then (None: it was not there)."""
    real, seen = aio._atomic, dict(n=0, previous=None, path=None)

    def atomic(path, write, make_folder=True):
        if fnmatch.fnmatch(os.path.basename(path), name):
            seen["n"] += 1
            if seen["n"] == nth:
                if before is not None:
                    before(path)
                p = Path(path)
                seen["path"] = p
                seen["previous"] = p.read_bytes() if p.is_file() else None
                return real(path, lambda f: write(Full(f, room, err)), make_folder)
        return real(path, write, make_folder)

    monkeypatch.setattr(aio, "_atomic", atomic)
    return seen


def assert_previous(seen) -> None:
    """The file whose write failed (or was killed) is as it was, or still absent."""
    p = seen["path"]
    if seen["previous"] is None:
        assert not p.exists(), p
    else:
        assert p.read_bytes() == seen["previous"], p


KILLER = r"""
import fnmatch, os, signal, sys
from acder_lite import io as aio
from fault_files import Passthrough
from acder_lite.cli.main import main

name, nth, record, argv = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
real, seen = aio._atomic, [0]


class Killed(Passthrough):  # the first bytes reach the temporary file, then SIGKILL
    def write(self, b):
        n = self.f.write(b)
        self.f.flush()
        os.kill(os.getpid(), signal.SIGKILL)
        return n


def atomic(path, write, *a, **kw):
    if fnmatch.fnmatch(os.path.basename(path), name):
        seen[0] += 1
        if seen[0] == nth:
            with open(record, "w") as r:  # which file, and its bytes before
                r.write(path)
            if os.path.isfile(path):
                with open(path, "rb") as f, open(record + ".bytes", "wb") as r:
                    r.write(f.read())
            return real(path, lambda f: write(Killed(f)), *a, **kw)
    return real(path, write, *a, **kw)


aio._atomic = atomic
if name == "<stdout>":  # a command that writes only to stdout: killed mid-line
    out = sys.stdout
    class Half:
        def write(self, s):
            out.write(s[: len(s) // 2])
            out.flush()
            os.kill(os.getpid(), signal.SIGKILL)
        def __getattr__(self, k):
            return getattr(out, k)
    sys.stdout = Half()
sys.exit(main(argv))
"""


def killed(tmp_path, name: str, nth: int, argv: list[str]) -> dict:
    """Run `python -m acder_lite ARGV` in a process that SIGKILLs itself in the middle
    of its `nth` write of a file matching `name` ("<stdout>": of its output); the file
    and the bytes it held then (`assert_previous`)."""
    record = tmp_path / "killed-at"
    p = subprocess.run(
        [sys.executable, "-c", KILLER, name, str(nth), str(record), *argv],
        cwd=ROOT,
        env=dict(
            os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.path.join(ROOT, "tests")])
        ),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == -signal.SIGKILL, p.stdout + p.stderr
    if name == "<stdout>":
        return dict(stdout=p.stdout)
    path = Path(record.read_text())
    previous = Path(str(record) + ".bytes")
    return dict(
        path=path, previous=previous.read_bytes() if previous.exists() else None
    )


# ----- a real tmpfs, where this machine lets us mount one


def _mountable() -> bool:
    if os.geteuid() != 0 or not shutil.which("mount"):
        return False
    with tempfile.TemporaryDirectory() as d:
        try:
            p = subprocess.run(
                ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", d],
                capture_output=True,
                timeout=10,
            )
        except (OSError, subprocess.SubprocessError):
            return False
        if p.returncode != 0:
            return False
        subprocess.run(["umount", d], capture_output=True, timeout=30)
    return True


MOUNTABLE = _mountable()
real_disk = pytest.mark.skipif(
    not MOUNTABLE, reason="this machine lets no test mount a tmpfs"
)


@contextlib.contextmanager
def tmpfs(where: Path, size: int):
    """A tmpfs of `size` bytes mounted at `where` for the block."""
    where.mkdir()
    subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
        check=True,
        capture_output=True,
    )
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], capture_output=True)


def remount(where: Path, options: str) -> None:
    subprocess.run(
        ["mount", "-o", f"remount,{options}", str(where)],
        check=True,
        capture_output=True,
    )


# ----- the runs to compare with


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny run, uninterrupted."""
    out = tmp_path_factory.mktemp("reference") / "run"
    assert main([*TRAIN, "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def first_epoch(tmp_path_factory):
    """The tiny run stopped at its first checkpoint (for its files' sizes)."""
    out = tmp_path_factory.mktemp("first") / "run"
    assert main([*TRAIN, "--epochs", "1", "--out", str(out)]) == 0
    return out


# ----- train: no space, read-only, removed


@pytest.mark.parametrize(
    "name, nth, err",
    [
        ("checkpoint.pt", 1, errno.ENOSPC),  # the issue's: the first checkpoint
        ("checkpoint.pt", 2, errno.ENOSPC),
        ("policy.pt", 1, errno.ENOSPC),
        ("progress.csv", 1, errno.ENOSPC),
        ("done.json", 1, errno.ENOSPC),
        ("config.json", 1, errno.ENOSPC),
        ("checkpoint.pt", 2, errno.EROFS),  # the folder made read-only mid-run
        ("progress.csv", 2, errno.EACCES),
    ],
)
def test_train_on_a_write_that_fails(
    tmp_path, capsys, monkeypatch, reference, name, nth, err
):
    out = tmp_path / "run"
    argv = [*TRAIN, "--out", str(out)]
    seen = fail_writes(monkeypatch, name, nth, err)
    assert main(argv) == 2
    line = one_line(capsys)
    assert line.startswith(
        f"error: train: {name} could not be written in {out} ({os.strerror(err)})"
    ), line
    fix = "there is space" if err == errno.ENOSPC else "the folder is writable"
    assert_previous(seen)
    assert not temps(out)
    assert_not_ahead(out)
    monkeypatch.undo()
    if (out / "checkpoint.pt").exists():
        assert line.endswith(
            f"once {fix}, continue with `python -m acder_lite train --resume {out}`"
        ), line
        again = ["train", "--resume", str(out), "--quiet"]
    else:  # nothing left that the same command would refuse
        assert line.endswith(f"once {fix}, start it again with the same command")
        assert os.listdir(out) == [], os.listdir(out)
        again = argv
    assert main(again) == 0
    assert_same_run(out, reference)


@real_disk
def test_train_on_a_real_full_disk(tmp_path, capsys, reference, first_epoch):
    """The issue's run on a tmpfs too small for its first checkpoint, then one that
    holds the first but not the second: torch.save's "unexpected pos" RuntimeError
    over the OSError is one line; the same command, and --resume, once there is
    room."""
    page = 4096
    size = {f: os.path.getsize(first_epoch / f) for f in os.listdir(first_epoch)}
    small = (size["config.json"] // page + 3) * page  # config.json, no checkpoint
    assert size["checkpoint.pt"] > small
    with tmpfs(tmp_path / "disk", small) as disk:
        out = disk / "run"
        argv = [*TRAIN, "--out", str(out)]
        assert main(argv) == 2
        line = one_line(capsys)
        assert line.startswith(
            f"error: train: checkpoint.pt could not be written in {out} (No space "
            "left on device), and the run has no checkpoint yet"
        ), line
        assert os.listdir(out) == []
        remount(disk, "size=16m")
        assert main(argv) == 0
        assert_same_run(out, reference)
    # room for the first epoch's files, not for the second checkpoint beside them
    room = sum((n // page + 1) * page for n in size.values()) + 2 * page
    assert os.path.getsize(reference / "checkpoint.pt") > 2 * page
    with tmpfs(tmp_path / "disk2", room) as disk:
        out = disk / "run"
        assert main([*TRAIN, "--out", str(out)]) == 2
        line = one_line(capsys)
        assert "the run is kept at its last checkpoint (epoch 1), whole" in line, line
        assert load_torch(str(out / "checkpoint.pt"))["progress"]["cycle"] == 2
        assert len(rows_of(out / "progress.csv")) == 1 and not temps(out)
        remount(disk, "size=16m")
        assert main(["train", "--resume", str(out), "--quiet"]) == 0
        assert_same_run(out, reference)


@real_disk
def test_train_in_a_folder_made_read_only_mid_run(
    tmp_path, capsys, monkeypatch, reference
):
    """The filesystem remounted read-only before the second checkpoint: one line,
    the first checkpoint whole; --resume says so again while it stays read-only, and
    ends the run once it is writable."""
    with tmpfs(tmp_path / "disk", 16 << 20) as disk:
        out = disk / "run"
        seen = fail_writes(
            monkeypatch,
            "checkpoint.pt",
            nth=2,
            room=1 << 40,  # no fault of ours: the filesystem's own
            before=lambda path: remount(disk, "ro"),
        )
        assert main([*TRAIN, "--out", str(out)]) == 2
        line = one_line(capsys)
        assert line.startswith(
            f"error: train: checkpoint.pt could not be written in {out} (Read-only "
            "file system); the run is kept at its last checkpoint (epoch 1), whole; "
            "once the folder is writable, continue with"
        ), line
        assert_previous(seen)
        assert_not_ahead(out)
        monkeypatch.undo()
        resume = ["train", "--resume", str(out), "--quiet"]
        assert main(resume) == 2
        assert "cannot be written (Read-only file system)" in one_line(capsys)
        remount(disk, "rw")
        assert main(resume) == 0
        assert_same_run(out, reference)


def test_train_in_a_folder_removed_mid_run(tmp_path, capsys, monkeypatch, reference):
    """The run folder removed before the second checkpoint: not made again empty (a
    folder with checkpoint files but no config.json), one line; the same command
    trains the run again from the start."""
    out = tmp_path / "run"
    argv = [*TRAIN, "--out", str(out)]

    def remove_folder(path):
        shutil.rmtree(os.path.dirname(path))

    fail_writes(monkeypatch, "checkpoint.pt", nth=2, room=1 << 40, before=remove_folder)
    assert main(argv) == 2
    line = one_line(capsys)
    assert line == (
        f"error: train: the run folder {str(out)!r} was removed while the run trained "
        "(checkpoint.pt could not be written); nothing of it is left to resume; "
        "start it again with the same command"
    )
    assert not out.exists()
    monkeypatch.undo()
    assert main(argv) == 0
    assert_same_run(out, reference)


# ----- train: SIGKILL in the end-of-epoch save


@pytest.mark.xdist_group("faults-kill")
@pytest.mark.parametrize(
    "name, nth", [("checkpoint.pt", 1), ("checkpoint.pt", 2), ("progress.csv", 2)]
)
def test_train_killed_in_its_save(tmp_path, capsys, reference, name, nth):
    """SIGKILL while an epoch's end writes `name`: the file as it was, progress.csv
    never past the checkpoint; killed before the first checkpoint, the folder holds
    config.json alone, which the same command takes (before: a progress.csv that
    --resume and --out both refused). The temporary file the kill left is gone once
    the command has run again."""
    out = tmp_path / "run"
    argv = [*TRAIN, "--out", str(out)]
    seen = killed(tmp_path, name, nth, argv)
    assert_previous(seen)
    assert_not_ahead(out)
    assert temps(out)  # killed mid-write: its temporary file is there
    capsys.readouterr()
    if (out / "checkpoint.pt").exists():
        assert main(["train", "--resume", str(out), "--quiet"]) == 0
    else:
        assert sorted(os.listdir(out)) == sorted(["config.json", *temps(out)])
        assert main(argv) == 0
    assert_same_run(out, reference)


# ----- pack


def _in_flight(tmp_path) -> tuple[Path, object]:
    """A tiny ACDER run paused at its first checkpoint (cycle 3 of 9), and its
    config (`_go_on` trains it on)."""
    cfg = tiny_config(method="acder", epochs=3)
    run = tmp_path / "run"
    Trainer(cfg, str(run)).train(False, max_cycles=3)
    return run, cfg


def _go_on(run: Path, cfg, cycles: int) -> None:
    """Train `run` on from its checkpoint.pt to `cycles` cycles in all (a pause)."""
    tr = Trainer(cfg, str(run))
    tr.load_state_dict(load_torch(str(run / "checkpoint.pt")))
    tr.train(False, max_cycles=cycles)


def assert_packs_the_checkpoint(run: Path) -> None:
    """run's packed folder is whole and is its checkpoint.pt: every file it names
    there and no other, the buffer re-simulated to the checkpoint's bit for bit (its
    digest), the rest of the state the same; no temporary file."""
    state = packed.read_state(run)
    names = {p.name for p in (run / packed.FOLDER).iterdir()}
    assert names == {packed.STATE, *state["buffer"]["chunks"]}, names
    ck, back = load_torch(str(run / "checkpoint.pt")), packed.unpack(run)
    for k, v in ck["buffer"].items():
        assert (
            (v == back["buffer"][k])
            if isinstance(v, int)
            else (v.tobytes() == back["buffer"][k].tobytes())
        ), k
    assert back["progress"] == ck["progress"] and not temps(run)


def test_pack_on_a_full_disk(tmp_path, capsys, monkeypatch):
    """No space for the first pack's state.pt.gz, then for a later pack's chunk: one
    line each, exit 2; the packed checkpoint as it was (none, then the earlier one,
    whole), no temporary file; pack again once there is room."""
    run, cfg = _in_flight(tmp_path)
    seen = fail_writes(monkeypatch, packed.STATE)
    assert main(["pack", str(run)]) == 2
    line = one_line(capsys)
    assert line.startswith(
        f"failed   {run}: {packed.FOLDER}/ cannot be written (No space left on "
        "device); its packed checkpoint is as it was (or none), checkpoint.pt "
        "untouched; allowed: a run folder you can write to, with space (then pack "
        "again)"
    ), line
    assert_previous(seen)
    assert not packed.has_packed(run) and not temps(run)
    monkeypatch.undo()
    assert main(["pack", str(run)]) == 0
    assert_packs_the_checkpoint(run)
    whole = files(run / packed.FOLDER)
    _go_on(run, cfg, 6)
    fail_writes(monkeypatch, "episodes-*.npz")
    assert main(["pack", str(run)]) == 2
    assert "(No space left on device)" in one_line(capsys)
    assert files(run / packed.FOLDER) == whole and not temps(run)
    monkeypatch.undo()
    assert main(["pack", str(run)]) == 0
    assert packed.cycle_of(packed.read_state(run)) == 6
    assert_packs_the_checkpoint(run)


@pytest.mark.xdist_group("faults-kill")
def test_pack_killed_mid_write(tmp_path, capsys):
    """SIGKILL in the first pack's chunk: no packed checkpoint (absent; resume says
    it passes the folder over); SIGKILL in a later pack's state.pt.gz: the earlier
    packed checkpoint whole. pack again: whole, no temporary file; and the run
    carried by it (checkpoint.pt gone) resumes to the numbers of an uninterrupted
    run."""
    run, cfg = _in_flight(tmp_path)
    seen = killed(tmp_path, "episodes-*.npz", 1, ["pack", str(run)])
    assert seen["previous"] is None and not packed.has_packed(run)
    assert temps(run)
    later, note = packed.later_than(run, load_torch(str(run / "checkpoint.pt")))
    assert not later and "holds no whole packed checkpoint" in note, note
    assert main(["pack", str(run)]) == 0
    assert_packs_the_checkpoint(run)
    _go_on(run, cfg, 6)
    seen = killed(tmp_path, packed.STATE, 1, ["pack", str(run)])
    assert_previous(seen)
    assert packed.cycle_of(packed.read(run)[0]) == 3  # the earlier pack, read whole
    assert temps(run)
    capsys.readouterr()
    assert main(["pack", str(run)]) == 0
    assert packed.cycle_of(packed.read_state(run)) == 6
    assert_packs_the_checkpoint(run)
    (run / "checkpoint.pt").unlink()  # carried to another machine by its pack
    assert main(["train", "--resume", str(run), "--quiet"]) == 0
    assert "rebuilding" in capsys.readouterr().err
    full = tmp_path / "full"
    Trainer(cfg, str(full)).train(False)
    assert_same_run(run, full)


# ----- export, table, the book's scenes


def test_export_on_a_full_disk(tmp_path, capsys, monkeypatch, reference):
    out = tmp_path / "policy.ts"
    argv = ["export", str(reference), "--out", str(out)]
    seen = fail_writes(monkeypatch, "policy.ts")
    assert main(argv) == 2
    line = one_line(capsys)
    assert line == (
        f"error: out={str(out)!r} cannot be written (No space left on device); "
        "allowed: a file in a folder you can write to"
    )
    assert_previous(seen)
    assert os.listdir(tmp_path) == []
    monkeypatch.undo()
    assert main(argv) == 0 and out.exists() and not temps(tmp_path)


@pytest.mark.xdist_group("faults-kill")
def test_export_killed_mid_write(tmp_path, capsys, reference):
    """SIGKILL in the middle of the export: no file (an export never replaces one),
    so the same command then writes it: the file an uninterrupted export writes."""
    out = tmp_path / "out" / "policy.ts"
    argv = ["export", str(reference), "--out", str(out)]
    seen = killed(tmp_path, "policy.ts", 1, argv)
    assert_previous(seen)
    assert temps(out.parent)
    assert main(argv) == 0 and not temps(out.parent)
    ref = tmp_path / "ref.ts"
    assert main(["export", str(reference), "--out", str(ref)]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # torch.jit.load's
        a, b = torch.jit.load(str(out)), torch.jit.load(str(ref))
    o, g = torch.zeros(3, 10), torch.zeros(3, 3)
    assert torch.equal(a(o, g), b(o, g))


@pytest.mark.xdist_group("faults-kill")
def test_table_killed_mid_write(tmp_path, capsys, reference):
    """table writes only to stdout: killed mid-line, not a byte under --results
    changes, and the same command prints the table an uninterrupted one does."""
    argv = ["table", "--results", str(reference.parent), "--resamples", "50"]
    before = files(reference.parent)
    seen = killed(tmp_path, "<stdout>", 1, argv)
    assert files(reference.parent) == before and not temps(reference.parent)
    capsys.readouterr()
    assert main(argv) == 0
    first = capsys.readouterr().out
    assert first.startswith(seen["stdout"]) and len(seen["stdout"]) < len(first)
    assert main(argv) == 0
    assert capsys.readouterr().out == first


class _Scene:
    """What `viz.save_scene_html` reads of a Meshcat visualizer."""

    def __init__(self, html: str):
        self.html = html

    def static_html(self) -> str:
        return self.html


def test_a_scene_on_a_full_disk(tmp_path, monkeypatch):
    """The book's scene page: the page there before stays whole, no temporary file,
    one line naming it; written once there is room."""
    from acder_lite.book import viz

    page = tmp_path / "scenes" / "03_reach_her.html"
    viz.save_scene_html(_Scene("<html>before</html>"), str(page))
    seen = fail_writes(monkeypatch, page.name, room=5)
    with pytest.raises(WriteError) as e:
        viz.save_scene_html(_Scene("<html>after</html>" * 100), str(page))
    assert str(e.value) == (
        f"{str(page)!r} could not be written (No space left on device); its "
        "previous version is kept whole, and no partial file"
    )
    assert_previous(seen)
    assert page.read_text() == "<html>before</html>" and not temps(page.parent)
    monkeypatch.undo()
    viz.save_scene_html(_Scene("<html>after</html>"), str(page))
    assert page.read_text() == "<html>after</html>"


def test_torch_saves_runtime_error_is_the_write_error(tmp_path, monkeypatch):
    """torch.save on a full disk raises RuntimeError ("unexpected pos"), the OSError
    only its context: `io.save_torch` raises the WriteError."""
    path = tmp_path / "x.pt"
    aio.save_torch(str(path), dict(a=torch.zeros(10)))
    before = path.read_bytes()
    fail_writes(monkeypatch, "x.pt", room=64)
    with pytest.raises(WriteError) as e:
        aio.save_torch(str(path), dict(a=torch.zeros(100_000)))
    assert e.value.errno == errno.ENOSPC and e.value.filename == str(path)
    assert isinstance(e.value, OSError)
    assert path.read_bytes() == before and not temps(tmp_path)


def test_stale_temporary_files_of_dead_processes_go(tmp_path):
    """A temporary file of a process of this machine that is no more (killed) goes at
    the next write into its folder; one of a running process, of another machine or
    of another name stays."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    tag = aio._TEMP_TAG
    names = {
        f".checkpoint.pt.{tag}-{dead.pid}.abc123.tmp": False,  # killed: goes
        f".progress.csv.{tag}-{os.getppid()}.xyz_9.tmp": True,  # running: stays
        f".checkpoint.pt.0123abcd-{dead.pid}.abc123.tmp": True,  # another machine
        ".checkpoint.pt.abc123.tmp": True,  # the old names: not ours to judge
        "notes.tmp": True,
    }
    for n in names:
        (tmp_path / n).write_text("x")
    aio.write_json(str(tmp_path / "a.json"), {})
    assert {n: (tmp_path / n).exists() for n in names} == names


# ----- a plan file broken while a sweep runs


def test_a_broken_plan_names_its_line(tmp_path):
    """The sweep reads the plan again whenever a cell ends: a plan edited into an
    invalid one leaves the queue as it was, and the line says which line is wrong."""
    from acder_lite.cli import sweep as S
    from acder_lite.runs.plan import read_plan

    path = tmp_path / "plan.toml"
    good = (
        "# the grid\n[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\n"
        "seeds = [0, 1]\n"
    )
    path.write_text(good)
    q = S.CellQueue(read_plan(path), 1, lambda: read_plan(path))
    assert [c.seed for c in q.take(running=0)] == [0]
    for text, line, what in (
        (good.replace("'her'", "'herr'"), 4, "group 1: unknown method 'herr'"),
        (good.replace("[0, 1]", "[0, -1]"), 5, "group 1: seeds must be integers"),
        (good + "[[group]]\nenvs = []\n", 7, "group 2: envs must be a non-empty"),
        (good.replace("seeds", "seed"), 5, "group 1: unknown key 'seed'"),
        # tomllib's own line: where the unclosed list is found
        (good.replace("methods = ['her']", "methods = ['her'"), 5, "not valid TOML"),
    ):
        path.write_text(text)
        said = q.reread()
        assert said.startswith("plan not read again (") and what in said, said
        assert f"line {line}" in said, said
        assert said.endswith(
            "the queue stays as it was (fix the plan: it is read "
            "again when a cell ends)"
        )
        assert [c.seed for c in q.waiting] == [1] and q.problem
    path.write_text(good)
    assert q.reread() == "" and q.problem == ""


@pytest.mark.xdist_group("ray")
def test_a_plan_broken_while_the_sweep_runs(tmp_path):
    """The plan edited into an invalid one while its first cell trains: the cells go
    on and finish (the queue as it was), the sweep names the wrong line when it reads
    the plan again, and ends with it (one line on stderr, exit 2); fixed, the same
    command runs what the fixed plan adds, and nothing was lost."""
    results = tmp_path / "results"
    results.mkdir()
    plan = results / "plan.toml"
    group = (
        "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['{}']\nseeds = [{}]\n"
        "config = {{ epochs = 1, cycles = 2, updates_per_cycle = 2, batch_size = 16, "
        "test_episodes = 1, hidden = 16, buffer_size = 2000 }}\n"
    )
    plan.write_text(group.format("her", "0, 1"))
    first = results / "FetchReach-v4" / "her" / "seed0"
    cmd = [sys.executable, "-m", "acder_lite", "sweep", "--plan", str(plan)]
    proc = subprocess.Popen(
        [*cmd, "--jobs", "1"],
        cwd=tmp_path,
        env=dict(os.environ, PYTHONPATH=ROOT),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.time() + 300
        while not (first / "train.log").exists() and proc.poll() is None:
            assert time.time() < deadline
            time.sleep(0.2)
        broken = group.format("her", "0, 1") + group.format("her-per", "0").replace(
            "'her-per'", "'her-perr'"
        )
        plan.write_text(broken)
        out, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 2, out + err
    lines = [ln for ln in err.splitlines() if ln.startswith("error")]
    assert len(lines) == 1 and "line 8, group 2: unknown method 'her-perr'" in lines[0]
    assert "fix the plan, then run the same command" in lines[0]
    assert "plan not read again" in out
    for k in (0, 1):
        run = results / "FetchReach-v4" / "her" / f"seed{k}"
        assert (run / "done.json").exists() and not temps(run)
    plan.write_text(broken.replace("'her-perr'", "'her-per'"))
    again = subprocess.run(
        [*cmd, "--jobs", "1"],
        cwd=tmp_path,
        env=dict(os.environ, PYTHONPATH=ROOT),
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert again.returncode == 0, again.stdout + again.stderr
    assert "finish FetchReach-v4/her-per/seed0: done" in again.stdout
    assert again.stdout.count("(already complete)") == 2
