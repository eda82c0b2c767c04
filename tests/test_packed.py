"""Packed checkpoints (`acder_lite.runs.packed`): a run carried to another machine as
its first states and actions resumes to the numbers of an uninterrupted run; a packed
buffer that does not re-simulate to its digest is refused; packing again adds only
the new episodes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from acder_lite.runs import packed
from acder_lite.cli.main import main
from acder_lite.io import CheckpointError, load_torch
from acder_lite.runs.plan import cell_state
from acder_lite.train.trainer import Trainer

from conftest import rows_of, tiny_config


def carried(part):
    """`part`'s checkpoint packed, then checkpoint.pt removed: the run folder as a
    fresh clone of the repository holds it."""
    packed.pack(load_torch(str(part / "checkpoint.pt")), part / packed.FOLDER)
    (part / "checkpoint.pt").unlink()


@pytest.mark.parametrize(
    "env, method, kw",
    [
        ("FetchPush-v4", "acder", {}),
        ("FetchPush-v4", "her-per", {}),
        ("FetchPickAndPlace-v4", "her", {}),
        ("FetchPush-v4", "acder", {"obs": "simplified"}),
        ("FetchPushMultiStep-v0", "acder", {}),
    ],
)
def test_a_packed_run_resumes_to_the_uninterrupted_numbers(tmp_path, env, method, kw):
    kw = dict(env=env, method=method, eval_every_cycles=2, epochs=4, **kw)
    full = tmp_path / "full"
    Trainer(tiny_config(**kw), str(full)).train(False)
    part = tmp_path / "part"
    Trainer(tiny_config(**kw), str(part)).train(False, max_cycles=2 * 3)
    carried(part)
    assert cell_state(part) == "interrupted"
    assert main(["train", "--resume", str(part), "--quiet"]) == 0
    assert rows_of(part / "progress.csv") == rows_of(full / "progress.csv")
    # the run has ended: its packed folder has served
    assert (part / "done.json").exists() and not (part / packed.FOLDER).exists()
    # the machine it resumed on is on record (float32 kernels differ between CPUs)
    resumed = json.loads((part / "config.json").read_text())["resumes"][-1]
    assert "torch kernels: " in resumed["versions"]["cpu"]


def test_packing_again_adds_only_the_new_episodes(tmp_path):
    kw = dict(env="FetchPush-v4", method="acder", epochs=3)
    part = tmp_path / "part"
    Trainer(tiny_config(**kw), str(part)).train(False, max_cycles=3)
    first = packed.pack(load_torch(str(part / "checkpoint.pt")), part / packed.FOLDER)
    chunk0 = sorted((part / packed.FOLDER).glob("episodes-*.npz"))
    assert first == dict(episodes=3 * 2, new=3 * 2, bytes=first["bytes"])
    (part / "checkpoint.pt").unlink()
    # resumed from the packed folder for one more epoch, then packed again
    tr = Trainer(tiny_config(**kw), str(part))
    tr.load_state_dict(packed.unpack(part))
    tr.train(False, max_cycles=6)
    ckpt = load_torch(str(part / "checkpoint.pt"))
    before = chunk0[0].read_bytes()
    again = packed.pack(ckpt, part / packed.FOLDER)
    assert (again["episodes"], again["new"]) == (12, 6)
    names = sorted(p.name for p in (part / packed.FOLDER).glob("episodes-*.npz"))
    assert names == ["episodes-00000000-00000006.npz", "episodes-00000006-00000012.npz"]
    assert chunk0[0].read_bytes() == before  # the committed chunk is untouched
    back = packed.unpack(part)
    for k in ("o", "ag", "g", "u", "state", "success"):
        assert back["buffer"][k].tobytes() == ckpt["buffer"][k].tobytes(), k


def test_a_wrapped_buffer_packs_and_rebuilds(tmp_path):
    """Past its capacity the buffer overwrites its oldest slots, so a chunk of an
    earlier pack may no longer hold what its slots hold: a new pack replaces it, under
    a name no earlier pack used."""
    run = tmp_path / "run"
    cfg = tiny_config(env="FetchReach-v4", epochs=4, buffer_size=1000)  # 20 episodes
    Trainer(cfg, str(run)).train(False)
    ck = load_torch(str(run / "checkpoint.pt"))
    assert ck["buffer"]["total"] == 24 and ck["buffer"]["n"] == 20
    stale = run / packed.FOLDER / "episodes-00000000-00000002.npz"
    stale.parent.mkdir()
    old = {k: v.copy() for k, v in packed.episodes_of(ck["buffer"], 0, 2).items()}
    old["u"][0, 0, 0] += 0.5  # what slot 0 held before it was overwritten
    np.savez_compressed(stale, **old)
    packed.pack(ck, run / packed.FOLDER)
    # named by the episodes ever stored: never the name of a chunk a pack still lists
    assert [p.name for p in (run / packed.FOLDER).glob("*.npz")] == [
        "episodes-00000000-00000020-w00000024.npz"
    ]
    back = packed.unpack(run)["buffer"]
    assert (back["next"], back["total"]) == (
        ck["buffer"]["next"],
        ck["buffer"]["total"],
    )
    assert back["o"].tobytes() == ck["buffer"]["o"].tobytes()


def test_a_wrapped_buffer_packs_only_the_slots_it_overwrote(tmp_path):
    """Once the buffer wraps, a pack keeps every chunk whose slots still hold what it
    holds and writes the overwritten slots in blocks: the 400-epoch Multi-step Push's
    session-end packs grow by the new episodes, not by a whole buffer each."""
    kw = dict(env="FetchReach-v4", epochs=5, buffer_size=1000)  # 20 episodes
    part = tmp_path / "part"
    Trainer(tiny_config(**kw), str(part)).train(False, max_cycles=6)
    ck = load_torch(str(part / "checkpoint.pt"))
    assert (ck["buffer"]["n"], ck["buffer"]["total"]) == (12, 12)
    first = packed.pack(ck, part / packed.FOLDER, block=4)
    assert first["new"] == 12
    names = sorted(p.name for p in (part / packed.FOLDER).glob("*.npz"))
    assert names == [
        "episodes-00000000-00000004.npz",
        "episodes-00000004-00000008.npz",
        "episodes-00000008-00000012.npz",
    ]
    kept = {n: (part / packed.FOLDER / n).read_bytes() for n in names[1:]}
    (part / "checkpoint.pt").unlink()
    tr = Trainer(tiny_config(**kw), str(part))
    tr.load_state_dict(packed.unpack(part))
    # to 24 episodes, still in flight (a finished run drops its packed folder): slots
    # 0-3 overwritten, 12-19 filled
    tr.train(False, max_cycles=12)
    ck = load_torch(str(part / "checkpoint.pt"))
    assert (ck["buffer"]["n"], ck["buffer"]["total"], ck["buffer"]["next"]) == (
        20,
        24,
        4,
    )
    again = packed.pack(ck, part / packed.FOLDER, block=4)
    assert again["new"] == 12  # slots 0-3 and 12-19; 4-11 kept
    names = sorted(p.name for p in (part / packed.FOLDER).glob("*.npz"))
    assert names == [
        "episodes-00000000-00000004-w00000024.npz",
        "episodes-00000004-00000008.npz",
        "episodes-00000008-00000012.npz",
        "episodes-00000012-00000016-w00000024.npz",
        "episodes-00000016-00000020-w00000024.npz",
    ]
    assert all((part / packed.FOLDER / n).read_bytes() == b for n, b in kept.items())
    back = packed.unpack(part)["buffer"]
    for k in ("o", "ag", "g", "u", "state", "success"):
        assert back[k].tobytes() == ck["buffer"][k].tobytes(), k
    # packing the same checkpoint again writes nothing
    assert packed.pack(ck, part / packed.FOLDER, block=4)["new"] == 0


def test_chunks_that_do_not_follow_each_other_are_refused(tmp_path, monkeypatch):
    """A state that lists its chunks out of slot order (or with a gap) would rebuild
    a buffer of shuffled slots: refused in one line before any re-simulation."""
    run = tmp_path / "run"
    Trainer(tiny_config(epochs=2), str(run)).train(False, max_cycles=3)
    packed.pack(load_torch(str(run / "checkpoint.pt")), run / packed.FOLDER, block=4)
    state = packed.read_state(run)
    assert len(state["buffer"]["chunks"]) == 2  # 6 episodes in blocks of 4
    state["buffer"]["chunks"] = state["buffer"]["chunks"][::-1]
    monkeypatch.setattr(packed, "read_state", lambda run_dir: state)
    with pytest.raises(CheckpointError, match="do not follow each other"):
        packed.read(run)


def test_a_buffer_that_does_not_replay_is_refused(tmp_path, capsys):
    run = tmp_path / "run"
    Trainer(tiny_config(env="FetchPush-v4", epochs=2), str(run)).train(
        False, max_cycles=3
    )
    carried(run)
    chunk = next((run / packed.FOLDER).glob("episodes-*.npz"))
    part = dict(np.load(chunk))
    part["u"][1, 7, 0] = np.nextafter(part["u"][1, 7, 0], np.float32(2))  # one ulp
    np.savez_compressed(chunk, **part)
    with pytest.raises(CheckpointError, match="differs from the one that was packed"):
        packed.unpack(run)
    capsys.readouterr()
    assert main(["train", "--resume", str(run), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    # the line that announces the minutes of re-simulation, then the error: the
    # digest can be compared only once the buffer is rebuilt
    assert len(err) == 2 and "differs" in err[-1] and "Traceback" not in err[-1]
    chunk.unlink()
    with pytest.raises(CheckpointError, match="is missing"):
        packed.unpack(run)


def test_pack_command_packs_runs_in_flight_and_drops_finished_ones(tmp_path, capsys):
    root = tmp_path / "results"
    going, ended = root / "a" / "seed0", root / "b" / "seed0"
    Trainer(tiny_config(epochs=2), str(going)).train(False, max_cycles=3)
    Trainer(tiny_config(epochs=1), str(ended)).train(False)
    (ended / packed.FOLDER).mkdir()  # left over from the session it was carried in
    assert main(["pack", str(root)]) == 0
    out = capsys.readouterr().out
    assert "packed   " in out and "at epoch 1: 6 episodes (6 new)" in out
    assert f"removed  {ended}/{packed.FOLDER}" in out
    assert packed.has_packed(going) and not (ended / packed.FOLDER).exists()
    assert main(["pack", str(tmp_path / "nowhere")]) == 2
    assert "is not a folder" in capsys.readouterr().err


def test_the_later_of_checkpoint_and_pack_wins(tmp_path, capsys):
    """A checkpoint.pt older than the packed folder beside it (left on a machine that
    another one has since overtaken) is neither packed over the later pack nor
    resumed from."""
    kw = dict(env="FetchPush-v4", method="her", epochs=3)
    full = tmp_path / "full"
    Trainer(tiny_config(**kw), str(full)).train(False)
    part = tmp_path / "part"
    Trainer(tiny_config(**kw), str(part)).train(False, max_cycles=3)
    early = (part / "checkpoint.pt").read_bytes()
    Trainer(tiny_config(**kw), str(part)).train(False, max_cycles=6)  # from scratch
    assert main(["pack", str(part)]) == 0
    (part / "checkpoint.pt").write_bytes(early)  # cycle 3, the pack is at cycle 6
    assert main(["pack", str(part)]) == 0
    assert "kept" in capsys.readouterr().out.splitlines()[-1]
    assert packed.cycle_of(packed.read_state(part)) == 6
    assert main(["train", "--resume", str(part), "--quiet"]) == 0
    assert "rebuilding" in capsys.readouterr().err
    assert rows_of(part / "progress.csv") == rows_of(full / "progress.csv")


def test_a_damaged_chunk_is_one_line(tmp_path, capsys):
    run = tmp_path / "run"
    Trainer(tiny_config(epochs=2), str(run)).train(False, max_cycles=3)
    carried(run)
    chunk = next((run / packed.FOLDER).glob("episodes-*.npz"))
    chunk.write_bytes(chunk.read_bytes()[:100])
    assert main(["train", "--resume", str(run), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot be read" in err[0], err


def _folder_bytes(run) -> dict:
    return {
        str(p.relative_to(run)): p.read_bytes() for p in run.rglob("*") if p.is_file()
    }


def test_a_broken_pack_is_one_line_and_keeps_the_run_folder(tmp_path, capsys):
    """Found by fuzzing: a packed folder with a file truncated or missing printed two
    lines, "resume: rebuilding ..." and then the error. Its files are read whole
    before the line that announces the re-simulation (`packed.read`), and the options
    are checked against its state before the minutes of it; beside a checkpoint.pt,
    the "passed over" note comes with the warnings, once the options have passed; and
    diagnose reads the files whole too. One line each, exit 2, and not a byte of the
    run folder changed."""
    run = tmp_path / "run"
    Trainer(tiny_config(epochs=2), str(run)).train(False, max_cycles=3)
    early = (run / "checkpoint.pt").read_bytes()
    carried(run)
    folder = run / packed.FOLDER
    chunk = next(folder.glob("episodes-*.npz"))
    whole = _folder_bytes(run)

    def chunk_cut():
        chunk.write_bytes(whole[f"{packed.FOLDER}/{chunk.name}"][:100])

    def state_cut():
        state = folder / packed.STATE
        state.write_bytes(whole[f"{packed.FOLDER}/{packed.STATE}"][:300])

    for damage, needle in (
        (chunk_cut, f"chunk {chunk.name} cannot be read (BadZipFile); allowed:"),
        (chunk.unlink, f"chunk {chunk.name} is missing; allowed: a folder `pack`"),
        (state_cut, "state.pt.gz' is truncated or not gzip (EOFError); allowed:"),
        (lambda: None, "hidden=64 differs from the checkpoint's 32"),  # not rebuilt
    ):
        damage()
        before = _folder_bytes(run)
        argv = ["train", "--resume", str(run), "--quiet"]
        assert main(argv + (["--hidden", "64"] if "hidden" in needle else [])) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and needle in err[0], err
        assert _folder_bytes(run) == before
        for name, data in whole.items():  # back as `pack` wrote it
            (run / name).write_bytes(data)
    # diagnose, which rebuilds a packed run's buffer too
    chunk_cut()
    assert main(["diagnose", str(run)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot be read (BadZipFile)" in err[0], err
    # a damaged pack beside a checkpoint.pt, and an option the run cannot change
    state_cut()
    (run / "checkpoint.pt").write_bytes(early)
    assert main(["train", "--resume", str(run), "--quiet", "--hidden", "64"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "hidden=64 differs" in err[0], err


def test_damaged_or_foreign_packs_are_one_line(tmp_path, capsys):
    """A state.pt.gz that is not gzip, or chunks of another state layout: one line,
    no traceback; beside a readable checkpoint.pt the damaged pack is passed over."""
    run = tmp_path / "run"
    Trainer(tiny_config(epochs=2), str(run)).train(False, max_cycles=3)
    early = (run / "checkpoint.pt").read_bytes()
    carried(run)
    chunk = next((run / packed.FOLDER).glob("episodes-*.npz"))
    part = dict(np.load(chunk))
    part["state0"] = part["state0"][:, :-1]  # as if envs.STATE_SPEC had changed
    np.savez_compressed(chunk, **part)
    with pytest.raises(CheckpointError, match="holds state0 of shape"):
        packed.unpack(run)
    state = run / packed.FOLDER / packed.STATE
    state.write_bytes(b"\x1f\x8b\x08\x00" + bytes(range(200)))  # a gzip header, noise
    capsys.readouterr()
    assert main(["train", "--resume", str(run), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "state.pt.gz" in err[0], err
    # beside a checkpoint.pt the damaged pack loses (said in one line), packed over
    (run / "checkpoint.pt").write_bytes(early)
    assert main(["pack", str(run)]) == 0
    out = capsys.readouterr().out
    assert "packed   " in out and "passed over" in out
    assert packed.cycle_of(packed.read_state(run)) == 3


def test_pack_goes_on_past_a_run_it_cannot_pack(tmp_path, capsys):
    root = tmp_path / "results"
    bad, good = root / "a" / "seed0", root / "b" / "seed0"
    for d in (bad, good):
        Trainer(tiny_config(epochs=2), str(d)).train(False, max_cycles=3)
    (bad / "checkpoint.pt").write_bytes(b"not a checkpoint")
    assert main(["pack", str(root)]) == 2
    out, err = capsys.readouterr()
    assert f"failed   {bad}" in err and f"packed   {good}" in out
    assert packed.has_packed(good) and not packed.has_packed(bad)


def test_pack_refuses_a_checkpoint_of_bad_config_progress_or_buffer(tmp_path, capsys):
    """A checkpoint.pt whose config, progress or buffer train never writes (cycles=0,
    no cycle, a buffer of other keys), or a run folder that takes no file: one line
    each, exit 2, no packed state written (a ZeroDivisionError, KeyError or
    PermissionError traceback before, after the pack was written)."""
    import shutil

    from acder_lite.io import arrays_as_tensors, save_torch

    run = tmp_path / "run"
    Trainer(tiny_config(epochs=2), str(run)).train(False, max_cycles=3)
    for name, change, needle in (
        ("cycles0", lambda c: c["config"].update(cycles=0), "cycles=0"),
        ("nocycle", lambda c: c["progress"].pop("cycle"), "progress.cycle"),
        ("buffer", lambda c: c.update(buffer={"a": 1}), "its buffer is not"),
    ):
        bad = tmp_path / name
        shutil.copytree(run, bad)
        d = load_torch(str(run / "checkpoint.pt"))
        change(d)
        save_torch(str(bad / "checkpoint.pt"), arrays_as_tensors(d))
        capsys.readouterr()
        assert main(["pack", str(bad)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and needle in err[0] and "allowed:" in err[0], err
        assert not packed.has_packed(bad)
        if name != "buffer":  # train --resume reads it the same way
            assert main(["train", "--resume", str(bad), "--quiet"]) == 2
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and needle in err[0], err

    def refused(*a, **k):
        raise PermissionError(1, "Operation not permitted")

    capsys.readouterr()
    orig = packed.pack
    try:
        packed.pack = refused  # a read-only run folder, as root sees one
        assert main(["pack", str(run)]) == 2
    finally:
        packed.pack = orig
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot be written" in err[0], err
    assert main(["pack", str(run)]) == 0


def test_a_changed_success_flag_is_refused(tmp_path):
    """The success flags come from the chunks, not from the re-simulation, so the
    digest covers them too: a chunk with one episode's flag flipped is refused."""
    run = tmp_path / "run"
    Trainer(tiny_config(epochs=2), str(run)).train(False, max_cycles=3)
    carried(run)
    chunk = next((run / packed.FOLDER).glob("episodes-*.npz"))
    part = dict(np.load(chunk))
    part["success"][0] = not part["success"][0]
    np.savez_compressed(chunk, **part)
    with pytest.raises(CheckpointError, match="differs from the one that was packed"):
        packed.unpack(run)


def test_a_pack_of_another_format_is_refused(tmp_path):
    """state.pt.gz records the layout's version (`packed.FORMAT`): a packed folder of
    another version is refused in one line naming both, not unpacked as if it were
    this one."""
    import gzip

    import torch

    from acder_lite.io import arrays_as_tensors

    run = tmp_path / "run"
    Trainer(tiny_config(epochs=2), str(run)).train(False, max_cycles=3)
    carried(run)
    state = packed.read_state(run)
    state["packed_format"] = packed.FORMAT + 1
    with gzip.open(run / packed.FOLDER / packed.STATE, "wb") as z:
        torch.save(arrays_as_tensors(state), z)
    want = f"has format {packed.FORMAT + 1}; allowed: {packed.FORMAT}"
    with pytest.raises(CheckpointError, match=want):
        packed.read_state(run)
    with pytest.raises(CheckpointError, match=want):
        packed.unpack(run)


def test_packing_again_replaces_a_chunk_that_holds_other_episodes(tmp_path):
    """A chunk whose name fits the buffer but whose episodes are not the buffer's (one
    action one ulp off: a stale or damaged chunk) is not kept by the next pack: it is
    written again, and the folder unpacks to the checkpoint's buffer."""
    run = tmp_path / "run"
    Trainer(tiny_config(epochs=2), str(run)).train(False, max_cycles=3)
    ckpt = load_torch(str(run / "checkpoint.pt"))
    packed.pack(ckpt, run / packed.FOLDER)
    chunk = next((run / packed.FOLDER).glob("episodes-*.npz"))
    part = dict(np.load(chunk))
    part["u"][1, 7, 0] = np.nextafter(part["u"][1, 7, 0], np.float32(2))
    np.savez_compressed(chunk, **part)
    again = packed.pack(ckpt, run / packed.FOLDER)
    assert (again["episodes"], again["new"]) == (6, 6)  # 3 cycles of 2 episodes
    back = packed.unpack(run)["buffer"]
    for k in ("o", "ag", "g", "u", "state", "success"):
        assert back[k].tobytes() == ckpt["buffer"][k].tobytes(), k
