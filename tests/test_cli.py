"""Bad input: one line naming the problem and what is allowed, exit code 2,
no traceback."""

import argparse
import os
import signal
import subprocess
import sys
import time
import types

import pytest

from acder_lite.cli import train as cli_train

from conftest import ROOT, rows_of, run_cli

TINY = (
    "--workers 1 --cycles 2 --updates-per-cycle 2 --batch-size 16 "
    "--test-episodes 1 --hidden 16 --threads 1 --quiet"
).split()


def one_line_error(p, *needles):
    assert p.returncode == 2, p.stderr
    lines = [l for l in p.stderr.strip().splitlines() if l.strip()]
    assert len(lines) == 1, p.stderr
    assert "Traceback" not in p.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize(
    "args,needles",
    [
        (["--env", "CartPole-v1"], ["env", "FetchReach-v4"]),
        (["--method", "sac"], ["method", "acder"]),
        (["--workers", "two"], ["--workers", "invalid int"]),
        # worker 500 would reset to test env 0's goals (and 100000 took 17 GB)
        (["--workers", "501"], ["workers=501", "[1, 500]", "test env 0"]),
        (["--lr-actor", "-0.001"], ["lr_actor", "> 0"]),
        (["--batch-size", "0"], ["batch_size", ">= 1"]),
        (["--eta", "1.5"], ["eta", "(0, 1)"]),
        (["--alpha0", "-0.1"], ["alpha0", "[0, 1]"]),
        (["--restart-goal", "random"], ["restart_goal", "resample"]),
        (["--update-dtype", "float16"], ["update_dtype", "'bfloat16'"]),
        (["--stop-gap-episodes", "-1"], ["stop_gap_episodes", ">= 0"]),
        (["--target-clip", "nope"], ["target_clip", "'baselines'", "'wide'"]),
        (["--sicm-input", "x"], ["sicm_input", "'normalised'", "'raw'"]),
        (["--sicm-angles", "quat"], ["sicm_angles", "'euler'", "'sincos'"]),
        (["--method", "acder", "--sicm-angles", "sincos"], ["sicm_angles", "Euler"]),
        (["--init", "he"], ["init", "'xavier'", "'torch'"]),
        (["--buffer-scope", "global"], ["buffer_scope", "'worker'", "'shared'"]),
        (["--success-threshold", "1.5"], ["success_threshold", "(0, 1]"]),
        (["--success-threshold", "0"], ["success_threshold", "(0, 1]"]),
        (["--stop-patience", "-1"], ["stop_patience", ">= 0"]),
        (["--method", "acder-baselines-clip"], ["method", "acder"]),
        (["--method", "her-ebp"], ["her-ebp", "object", "FetchPush-v4"]),
        (["--no-such-option", "1"], ["train: unrecognized", "--no-such-option"]),
        # abbreviations: --epoch once silently meant --epochs
        (["--epoch", "2"], ["train: unrecognized", "did you mean --epochs?"]),
        (["--epcohs", "2"], ["train: unrecognized", "--epcohs", "mean --epochs?"]),
        (["--test-episodes", "0"], ["test_episodes=0", "an integer >= 1"]),
        (["--compile-update=yes"], ["--compile-update", "ignored explicit argument"]),
        (["--reward-bonus", "2"], ["reward_bonus=2.0", "[-1, 1]"]),
        (["--reward-bonus", "nan"], ["reward_bonus=nan", "[-1, 1]"]),
        (["--ebp-temperature", "0"], ["ebp_temperature=0.0", "finite number > 0"]),
        (["--ebp-temperature", "inf"], ["ebp_temperature=inf", "finite number > 0"]),
        # a traceback from gym or torch before, or a run that trained on NaNs
        (["--seed", "-1"], ["seed=-1", "[0, 2**64)"]),
        (["--seed", str(2**64)], ["seed=", "[0, 2**64)"]),
        (["--lr-critic", "inf"], ["lr_critic=inf", "finite number > 0"]),
        (["--norm-eps", "0"], ["norm_eps=0.0", "finite number > 0"]),
        (["--norm-clip", "inf"], ["norm_clip=inf", "finite number >= 0"]),
        (["--clip-obs", "inf"], ["clip_obs=inf", "finite number >= 0"]),
        (["--icm-beta", "2"], ["icm_beta=2.0", "[0, 1]"]),
        (["--alpha-base", "1"], ["alpha_base=1.0", "finite number > 1", "10e"]),
        (["--candidate-success", "all"], ["candidate_success", "'final'", "'any'"]),
        (["--intrinsic-timing", "now"], ["intrinsic_timing", "'before'", "'after'"]),
        # past int64: a traceback from torch or numpy
        (["--hidden", str(10**23)], ["hidden=", "below 2**63"]),
        (["--layers", str(10**23)], ["layers=", "below 2**63"]),
        # found by fuzzing: libgomp's "Out of memory allocating 231928235112 bytes",
        # exit 1, and an empty run folder left behind
        (["--threads", str(2**31 - 1)], ["threads=2147483647", "[1, 1024]"]),
    ],
)
def test_train_bad_input(cli, tmp_path, args, needles):
    out = tmp_path / "run"
    p = cli("train", "--env", "FetchReach-v4", *args, "--out", str(out))
    one_line_error(p, *needles)
    assert not out.exists()


def test_an_out_that_cannot_be_a_run_folder(cli, tmp_path):
    """A file where the run folder (or a folder above it) should be, or --out beside
    --resume: one line, and the file is untouched."""
    f = tmp_path / "notes.txt"
    f.write_text("keep me")
    for out, needles in (
        (f, ["--out", "is a file", "allowed: a folder"]),
        (f / "run", ["--out", "is a file", "allowed: a folder"]),
    ):
        p = cli("train", "--env", "FetchReach-v4", *TINY, "--out", str(out))
        one_line_error(p, *needles)
    p = cli("train", "--out", str(tmp_path / "a"), "--resume", str(tmp_path / "b"))
    one_line_error(p, "--out", "--resume", "exclude each other")
    # a folder there already that takes no file: a traceback after the first epoch
    p = cli("train", "--env", "FetchReach-v4", *TINY, "--out", "/proc")
    one_line_error(p, "--out '/proc'", "cannot be made or written", "allowed:")
    assert f.read_text() == "keep me" and os.listdir(tmp_path) == ["notes.txt"]
    one_line_error(cli("bench", "--cycles", "0"), "cycles=0", "in [1, 1000]")


def test_protocol_settings_reach_config_json(cli, tmp_path):
    """The new settings are options of `train`; the presets fill what is not given."""
    import json

    out = tmp_path / "run"
    p = cli(
        *"train --env FetchReach-v4 --method acder --epochs 1".split(),
        *TINY,
        *"--target-clip wide --sicm-input normalised --init torch".split(),
        *"--reward-bonus 0.25".split(),
        *("--out", str(out)),
    )
    assert p.returncode == 0, p.stderr
    cfg = json.loads((out / "config.json").read_text())["config"]
    assert (cfg["target_clip"], cfg["sicm_input"], cfg["init"]) == (
        "wide",
        "normalised",
        "torch",
    )
    assert (cfg["success_threshold"], cfg["stop_patience"], cfg["buffer_scope"]) == (
        1.0,
        5,
        "worker",
    )
    assert "target_clip" not in cfg["switches"] and cfg["reward_bonus"] == 0.25
    done = json.loads((out / "done.json").read_text())
    assert (
        done["stop_reason"] == "budget"
        and done["stop_rule"]["success_threshold"] == 1.0
    )


def test_existing_run_is_not_overwritten_and_checkpoint_errors(cli, tmp_path):
    out = tmp_path / "run"
    p = cli(
        "train", "--env", "FetchReach-v4", "--epochs", "1", *TINY, "--out", str(out)
    )
    assert p.returncode == 0, p.stderr
    before = {f: (out / f).read_bytes() for f in os.listdir(out)}
    p = cli(
        "train", "--env", "FetchReach-v4", "--epochs", "1", *TINY, "--out", str(out)
    )
    one_line_error(p, "already holds a run", "--resume")
    assert {f: (out / f).read_bytes() for f in os.listdir(out)} == before

    p = cli("eval", "--checkpoint", str(out / "checkpoint.pt"), "--episodes", "2")
    assert p.returncode == 0 and "success_rate=" in p.stdout
    p = cli("eval", "--checkpoint", str(out / "checkpoint.pt"), "--env", "FetchPush-v4")
    one_line_error(p, "FetchReach-v4", "--env FetchReach-v4")
    p = cli("train", "--resume", str(out), "--env", "FetchPush-v4")
    one_line_error(p, "env", "differs")

    trunc = tmp_path / "trunc.pt"
    data = (out / "checkpoint.pt").read_bytes()
    trunc.write_bytes(data[: len(data) // 2])
    p = cli("eval", "--checkpoint", str(trunc))
    one_line_error(p, "truncated")
    p = cli("eval", "--checkpoint", str(tmp_path / "missing.pt"))
    one_line_error(p, "does not exist", "allowed: a checkpoint.pt")
    p = cli("eval", "--checkpoint", str(out / "checkpoint.pt"), "--episodes", "0")
    one_line_error(p, "--episodes", "in [1, 10000]")
    # a huge count ran for ever
    p = cli("eval", "--checkpoint", str(out / "checkpoint.pt"), "--episodes", "10001")
    one_line_error(p, "--episodes 10001", "in [1, 10000]")
    p = cli("eval", "--checkpoint", str(out / "policy.pt"), "--seed", "-1")
    one_line_error(p, "--seed -1", ">= 0")
    one_line_error(cli("eval", "--checkpoint", str(out)), "is a folder", "policy.pt")
    assert {f: (out / f).read_bytes() for f in os.listdir(out)} == before
    _bad_input_on_a_finished_run(cli, tmp_path, out)


def _files(folder):
    return [f for f in os.listdir(folder) if (folder / f).is_file()]


def _bad_input_on_a_finished_run(cli, tmp_path, out):
    """The commands that read a run, given bad input next to a good run: one line each,
    and nothing already written changes."""
    import shutil

    keep = tmp_path / "existing.ts"
    keep.write_text("an earlier export")
    # a resumed run rewrites config.json at its start: one it cannot read is refused
    # before anything is trained or written
    for text in ('{"config": ', "[1, 2]", '{"resumes": 5}', None):
        broken = tmp_path / "broken"
        shutil.rmtree(broken, ignore_errors=True)
        shutil.copytree(out, broken)
        if text is None:  # a folder where the file should be
            (broken / "config.json").unlink()
            (broken / "config.json").mkdir()
        else:
            (broken / "config.json").write_text(text)
        files = {f: (broken / f).read_bytes() for f in _files(broken)}
        p = cli("train", "--resume", str(broken), "--epochs", "2", "--quiet")
        one_line_error(p, "config.json", "allowed:")
        assert {f: (broken / f).read_bytes() for f in _files(broken)} == files
    # a run file that is a folder: the rename onto it failed after the epoch, a
    # traceback; a checkpoint whose config or progress train never writes, too
    from acder_lite.io import arrays_as_tensors, load_torch, save_torch

    for name in ("done.json", "progress.csv", "policy.pt", "cycles", "cycle"):
        broken = tmp_path / "broken"
        shutil.rmtree(broken, ignore_errors=True)
        shutil.copytree(out, broken)
        if name == "cycles" or name == "cycle":
            d = load_torch(str(out / "checkpoint.pt"))
            part, value = ("config", 0) if name == "cycles" else ("progress", "x")
            d[part][name] = value
            save_torch(str(broken / "checkpoint.pt"), arrays_as_tensors(d))
            needles = [f"{name}=0" if name == "cycles" else "progress.cycle is 'x'"]
        else:
            (broken / name).unlink()
            (broken / name).mkdir()
            needles = [f"its {name} is not a file", "allowed:"]
        files = {f: (broken / f).read_bytes() for f in _files(broken)}
        p = cli("train", "--resume", str(broken), "--epochs", "2", "--quiet")
        one_line_error(p, *needles)
        assert {f: (broken / f).read_bytes() for f in _files(broken)} == files
    before = {f: (out / f).read_bytes() for f in os.listdir(out)}
    for args, needles in (
        (("export", str(out), "--out", str(keep)), ["out=", "already exists"]),
        (("export", str(out), "--out", str(tmp_path)), ["out=", "is a folder"]),
        (
            ("export", str(out), "--out", str(keep / "p.ts")),
            ["out=", "a file", "allowed: a path in a folder"],
        ),
        (
            ("export", str(out), "--out", str(tmp_path / "n.ts"), "--onnx")
            + (str(tmp_path / "n.ts"),),
            ["onnx=", "the --out file too"],
        ),
        (
            ("diagnose", str(out), "--json", str(out / "checkpoint.pt")),
            ["json=", "would overwrite a run's file"],
        ),
        (("diagnose", str(out), "--seed", "-1", "--episodes", "1"), ["seed=-1"]),
        (("robust", str(out), "--seed", "-1"), ["seed=-1", ">= 0"]),
        (
            ("robust", str(out), "--perturb", "action_delay=1")
            + ("--perturb", "action_delay=2"),
            ["action_delay", "given twice", "allowed:"],
        ),
        (
            ("robust", str(out), "--csv", str(out / "progress.csv")),
            ["csv=", "would overwrite a run's file"],
        ),
        (("robust", str(out), "--threads", str(2**31 - 1)), ["threads=", "1024]"]),
        (
            ("robust", str(out), "--perturb", "friction=1e308"),
            ["friction=1e+308", "most 100"],
        ),
        # numpy's "Maximum allowed dimension exceeded": the out-of-memory line, naming
        # the command's own size, not train's
        (
            ("table", "--results", str(out), "--resamples", str(10**23)),
            ["out of memory", "allowed:", "(--resamples)"],
        ),
    ):
        one_line_error(cli(*args), *needles)
    assert keep.read_text() == "an earlier export"
    assert not (tmp_path / "n.ts").exists()
    assert {f: (out / f).read_bytes() for f in os.listdir(out)} == before
    # table: an explicit --plan that cannot be read is an error, not a warning
    results = tmp_path / "results"
    shutil.copytree(out, results / "FetchReach-v4" / "her" / "seed0")
    (tmp_path / "bytes.toml").write_bytes(b"\xff\xfe\x00 not text")
    for plan, needles in (
        (tmp_path / "missing.toml", ["--plan", "does not exist", "allowed:"]),
        (tmp_path / "bytes.toml", ["--plan", "not valid TOML", "UTF-8"]),
    ):
        p = cli("table", "--results", str(results), "--plan", str(plan))
        one_line_error(p, *needles)


def test_a_buffer_too_large_for_memory_is_one_line_and_no_folder(cli, tmp_path):
    out = tmp_path / "huge"
    p = cli(
        *("train", "--env", "FetchReach-v4", "--buffer-size", str(10**14), *TINY),
        *("--out", str(out)),
    )
    one_line_error(p, "out of memory", "buffer_size")
    assert not out.exists()
    # a size torch cannot count: "Storage size calculation overflowed", a traceback
    p = cli(
        *("train", "--env", "FetchReach-v4", *TINY, "--hidden", str(2**62)),
        *("--out", str(out)),
    )
    one_line_error(p, "out of memory", "hidden")
    assert not out.exists()


def test_resume_into_a_folder_that_takes_no_file(tmp_path, capsys, monkeypatch):
    """A read-only run folder (root writes anywhere but there): one line before
    training, not a PermissionError at config.json's rewrite; an ended run still says
    so."""
    from acder_lite.cli import main as cli

    out = tmp_path / "run"
    argv = ["train", "--env", "FetchReach-v4", "--epochs", "1", *TINY]
    assert cli.main([*argv, "--out", str(out)]) == 0
    before = {f: (out / f).read_bytes() for f in os.listdir(out)}

    def refused(folder):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(cli_train, "probe_write", refused)
    capsys.readouterr()
    assert cli.main(["train", "--resume", str(out), "--epochs", "2", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot be written" in err[0] and "--resume" in err[0]
    assert cli.main(["train", "--resume", str(out)]) == 0  # ended: nothing to write
    assert {f: (out / f).read_bytes() for f in os.listdir(out)} == before


def test_out_of_memory_lines():
    """What MuJoCo, torch and numpy raise when a size is too large counts as out of
    memory (one line); anything else is not."""
    from acder_lite.cli.main import out_of_memory

    class FatalError(Exception):  # mujoco.FatalError's name
        pass

    for e in (
        ValueError("Error: engine error: Could not allocate memory"),
        FatalError("Could not allocate memory"),
        RuntimeError("Storage size calculation overflowed with sizes=[4, 13]"),
        ValueError("array is too big; `arr.size * arr.dtype.itemsize` is larger"),
        MemoryError(),
    ):
        assert out_of_memory(e), e
    for e in (ValueError("bad value"), RuntimeError("boom"), KeyError("memory")):
        assert not out_of_memory(e), e


def test_ctrl_c_in_the_first_epoch_leaves_a_run_to_start_again(cli, tmp_path):
    """Stopped before its first checkpoint, a run has nothing to resume: its files go,
    and the same command starts it again (a sweep sees a new cell, not a stuck one)."""
    out = tmp_path / "run"
    cmd = [*"train --env FetchReach-v4 --epochs 1".split(), *TINY, "--out", str(out)]
    long = [*cmd, "--cycles", "500", "--eval-every-cycles", "1"]  # the later --cycles
    # config.json: the run has started (progress.csv waits for the first checkpoint)
    code, err = _ctrl_c_once_written(long, out / "config.json", settle=1.0)
    assert code == 130 and "before the first checkpoint" in err, err
    assert not (out / "checkpoint.pt").exists() and os.listdir(out) == []
    one_line_error(cli("train", "--resume", str(out)), "no checkpoint.pt", "--out")
    assert cli(*cmd).returncode == 0 and (out / "done.json").exists()


def _interrupt_once_written(args, path, settle=0.0, stdout=subprocess.PIPE):
    """Start `python -m acder_lite ARGS`, send SIGINT once `path` exists (after
    `settle` seconds more), and return the process (its stderr a pipe)."""
    p = subprocess.Popen(
        [sys.executable, "-m", "acder_lite", *args],
        cwd=ROOT,
        env=dict(os.environ, PYTHONPATH=ROOT),
        stdout=stdout,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.time() + 120
    while not path.exists() and time.time() < deadline:
        time.sleep(0.1)
    time.sleep(settle)
    p.send_signal(signal.SIGINT)
    return p


def _ctrl_c_once_written(args, path, settle=0.0):
    """`_interrupt_once_written`, then the exit code and stderr."""
    p = _interrupt_once_written(args, path, settle)
    _, err = p.communicate(timeout=60)
    return p.returncode, err


def test_ctrl_c_leaves_a_checkpoint_to_resume(tmp_path):
    out = tmp_path / "run"
    env = dict(os.environ, PYTHONPATH=ROOT)
    args = [*"train --env FetchReach-v4 --epochs 50".split(), *TINY, "--out", str(out)]
    code, err = _ctrl_c_once_written(args, out / "checkpoint.pt", settle=0.5)
    assert code == 130, err
    assert "--resume" in err and "Traceback" not in err
    from acder_lite.io import load_torch

    done = load_torch(str(out / "checkpoint.pt"))["progress"]["cycle"]
    assert done >= 2 and not (out / "done.json").exists()
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "acder_lite",
            "train",
            "--resume",
            str(out),
            "--epochs",
            str(done // 2 + 1),
            "--quiet",
        ],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 0, p.stderr
    assert (out / "done.json").exists()
    # the same numbers as the run never interrupted: the same arguments and budget
    import torch

    ref = tmp_path / "ref"
    budget = ["--epochs", str(done // 2 + 1)]
    r = run_cli(*args[:-1], str(ref), *budget, timeout=120)
    assert r.returncode == 0, r.stderr
    assert rows_of(out / "progress.csv") == rows_of(ref / "progress.csv")
    a, b = (load_torch(str(d / "policy.pt"))["policy"]["actor"] for d in (out, ref))
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def test_a_second_ctrl_c_while_train_exits_is_no_traceback(tmp_path):
    """Found by fuzzing: a second Ctrl-C a moment after the first (train had written
    its checkpoint and said so) raised KeyboardInterrupt in torch's exit callback, an
    "Exception ignored in atexit callback" traceback. Once main has returned, SIGINT
    ends the process at once (`signals.end_on_signals`): the one line, no traceback,
    and the checkpoint whole."""
    out = tmp_path / "run"
    args = [*"train --env FetchReach-v4 --epochs 50".split(), *TINY, "--out", str(out)]
    p = _interrupt_once_written(
        args, out / "checkpoint.pt", settle=0.5, stdout=subprocess.DEVNULL
    )
    first = ""
    while not first.startswith("interrupted") and p.poll() is None:
        first = p.stderr.readline() or first  # "" at the end: the loop ends on poll
    if p.poll() is None:
        p.send_signal(signal.SIGINT)  # while it exits
    err = first + p.communicate(timeout=60)[1]
    assert p.returncode in (130, -signal.SIGINT), err
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert err.startswith("interrupted: the last checkpoint is in"), err
    from acder_lite.io import load_torch

    assert load_torch(str(out / "checkpoint.pt"))["progress"]["cycle"] >= 2


def test_bench_both_dtypes_ends_with_the_bench_line(cli):
    p = cli(
        "bench",
        "--env",
        "FetchReach-v4",
        "--workers",
        "1",
        "--cycles",
        "1",
        "--threads",
        "1",
        "--update-dtype",
        "both",
    )
    assert p.returncode == 0, p.stderr
    lines = p.stdout.strip().splitlines()
    assert lines[-1].startswith("bench: sim_ms_per_episode=")
    for key in ("train_ms_per_episode=", "ratio=", "update_gflops=", "matmul_gflops="):
        assert key in lines[-1]
    fields = dict(kv.split("=") for kv in lines[-1].split()[1:])
    limit, train = (
        float(fields["limit_ms_per_episode"]),
        float(fields["train_ms_per_episode"]),
    )
    assert (
        0 < float(fields["sim_ms_per_episode"]) < limit
    )  # the limit is simulation plus the updates
    assert float(fields["share_of_limit"]) == pytest.approx(limit / train, abs=0.01)
    assert float(fields["grid_cpu_ms_per_episode"]) > 0
    for head in ("update_ms float32=", "train_ms_per_episode float32="):
        (cmp,) = [l for l in lines if l.startswith(head)]
        speedup = float(cmp.split("speedup=")[1].split()[0])
        assert speedup > 0
    one_line_error(
        cli("bench", "--update-dtype", "float16"), "--update-dtype", "bfloat16"
    )


def test_help_lists_every_command_with_its_line(capsys):
    """`--help` names each command once with its `cli.COMMANDS` line, and every
    command's own `--help` opens with a description (a command without one fails)."""
    from acder_lite.cli import main as cli

    with pytest.raises(SystemExit) as e:
        cli.build_parser().parse_args(["--help"])
    assert e.value.code == 0
    out = " ".join(capsys.readouterr().out.split())  # argparse wraps the lines
    parser = cli.build_parser()
    (sub,) = [a for a in parser._actions if a.dest == "cmd"]
    assert set(sub.choices) == set(cli.COMMANDS)
    for name, line in cli.COMMANDS.items():
        assert f"{name} {line}" in out
        assert sub.choices[name].description, name


def documented_commands() -> list[tuple[str, list[str]]]:
    """Every `python -m acder_lite ...` command the READMEs, the book's pages and the
    chapters' text show, as (file, argv): each line of a shell block (continuation lines
    joined; comments, redirections and `[optional]` brackets dropped; `<task>` read as
    FetchPush-v4), and each inline one with an argument. Left out: a line that still
    holds a shell variable (`$S ...`), an inline one with `...` or `a|b` in it."""
    import json
    import re
    import shlex
    from pathlib import Path

    root = Path(ROOT)
    files = [root / "README.md", root / "results" / "README.md"]
    files += sorted((root / "experiments").glob("*/README.md"))
    files += sorted((root / "book").glob("*.md"))
    files += sorted((root / "notebooks").glob("*.ipynb"))
    out = []
    for f in files:
        text = f.read_text()
        if f.suffix == ".ipynb":
            cells = json.loads(text)["cells"]
            text = "\n".join(
                "".join(c["source"]) for c in cells if c["cell_type"] == "markdown"
            )
        where = str(f.relative_to(root))
        for block in re.findall(r"```(?:bash|sh)\n(.*?)```", text, flags=re.S):
            for line in block.replace("\\\n", " ").splitlines():
                if "-m acder_lite " not in line:
                    continue
                cmd = line.split("-m acder_lite ", 1)[1]
                cmd = re.split(r"\s(?:#|>|2>|&&|;)", " " + cmd)[0]
                cmd = cmd.replace("$OLDPWD/", "").replace("<task>", "FetchPush-v4")
                cmd = cmd.replace("[", "").replace("]", "").rstrip('"')
                if "$" not in cmd:
                    out.append((where, shlex.split(cmd)))
        inline = re.findall(
            r"`python -m acder_lite (\S[^`]*)`", text.replace("\n", " ")
        )
        out += [
            (where, cmd.split())
            for cmd in inline
            if " " in cmd.strip() and "..." not in cmd and "|" not in cmd
        ]
    return out


def test_every_documented_command_parses():
    """The commands the READMEs and the book tell a reader to type are ones the CLI
    takes: every option exists and has a value of its type, and a `train` line's
    settings pass Config's checks. Catches a flag renamed in the code but not in the
    prose."""
    from acder_lite.cli.main import UsageError, build_parser, given_options
    from acder_lite.config import Config

    cmds = documented_commands()
    assert len(cmds) >= 35, cmds  # the extraction found the blocks and inline ones
    used = {argv[0] for _, argv in cmds}
    assert used >= {"train", "eval", "bench", "sweep", "table", "diagnose", "robust"}
    assert used >= {"export", "pack"}
    for where, argv in cmds:
        try:
            args = build_parser().parse_args(argv)
        except (UsageError, SystemExit) as e:
            pytest.fail(f"{where}: python -m acder_lite {' '.join(argv)}: {e}")
        if args.cmd == "train" and not args.resume:
            Config(**given_options(args)).resolve()


def test_no_command_takes_an_abbreviated_option(cli):
    """Every parser refuses abbreviations (`--epoch 2` once meant --epochs); an unknown
    option names its command, with the close one if there is one."""
    import argparse

    from acder_lite.cli.main import build_parser

    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    assert not parser.allow_abbrev
    assert all(not s.allow_abbrev for s in sub.choices.values())
    line = one_line_error(cli("eval", "--checkpoint", "x.pt", "--episode", "3"))
    assert line.endswith(
        "python -m acder_lite eval: unrecognized arguments: --episode 3; "
        "did you mean --episodes?"
    ), line
    line = one_line_error(cli("table", "--zzzzzz"), "table: unrecognized", "--zzzzzz")
    assert "did you mean" not in line


def test_eval_help_gives_the_defaults(capsys):
    from acder_lite.cli.main import build_parser

    with pytest.raises(SystemExit):
        build_parser().parse_args(["eval", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "test episodes to run, at most 10000 (default: 10)" in out
    assert "(default: 12345)" in out


def test_resume_of_an_ended_run(cli, tmp_path):
    """--resume on a run that has ended: one line on stdout, exit 0, no file rewritten
    (no progress bar either); a budget below the epochs trained is refused (it once
    silently ended the run there); a file is not a run folder; a larger --epochs, or
    for a run stopped early another stop rule, trains on."""
    import json
    import shutil

    from acder_lite.io import load_torch, save_torch

    out = tmp_path / "run"
    p = cli(
        "train", "--env", "FetchReach-v4", "--epochs", "2", *TINY, "--out", str(out)
    )
    assert p.returncode == 0, p.stderr
    before = {f: (out / f).read_bytes() for f in _files(out)}
    p = cli("train", "--resume", str(out))  # no --quiet: no stray progress bar
    assert p.returncode == 0 and p.stderr == "", p.stderr
    assert p.stdout.strip().splitlines() == [
        f"train: {out} has already ended (budget, epoch 2); nothing to do; to train "
        f"it further: --resume {out} --epochs N with N > 2"
    ], p.stdout
    for epochs in ("1", "0"):
        p = cli("train", "--resume", str(out), "--epochs", epochs)
        one_line_error(p, f"--epochs {epochs}", "trained 2 epochs", "--epochs >= 2")
    p = cli("train", "--resume", str(out / "policy.pt"))
    one_line_error(p, "--resume", "is a file", "allowed: the run folder")
    one_line_error(cli("train", "--resume", str(tmp_path / "nope")), "does not exist")
    assert {f: (out / f).read_bytes() for f in _files(out)} == before
    # a run stopped at epoch 2 of 4 (no done.json): --epochs 1 would have ended it
    unfinished = tmp_path / "unfinished"
    shutil.copytree(out, unfinished)
    (unfinished / "done.json").unlink()
    files = {f: (unfinished / f).read_bytes() for f in _files(unfinished)}
    p = cli("train", "--resume", str(unfinished), "--epochs", "1", "--quiet")
    one_line_error(p, "has trained 2 epochs", "--epochs >= 2")
    assert {f: (unfinished / f).read_bytes() for f in _files(unfinished)} == files
    # a run that stopped early (success held at epoch 2 of 3)
    early = tmp_path / "early"
    shutil.copytree(out, early)
    ckpt = load_torch(str(early / "checkpoint.pt"))
    ckpt["config"]["epochs"] = 3
    ckpt["progress"].update(done=True, stop_reason="success held")
    save_torch(str(early / "checkpoint.pt"), ckpt)
    done = json.loads((early / "done.json").read_text())
    (early / "done.json").write_text(json.dumps(dict(done, stop_reason="success held")))
    files = {f: (early / f).read_bytes() for f in _files(early)}
    p = cli("train", "--resume", str(early), "--quiet")
    assert p.returncode == 0 and "has already ended (success held, epoch 2)" in p.stdout
    assert "--stop-patience 0" in p.stdout
    assert {f: (early / f).read_bytes() for f in _files(early)} == files
    p = cli("train", "--resume", str(early), "--stop-patience", "0", "--quiet")
    assert p.returncode == 0 and f"done: {early} epochs=3 " in p.stdout, p.stderr
    # a larger --epochs extends a run that ended on its budget
    p = cli("train", "--resume", str(out), "--epochs", "3", "--quiet")
    assert p.returncode == 0 and f"done: {out} epochs=3 " in p.stdout, p.stderr
    assert json.loads((out / "done.json").read_text())["epochs"] == 3


def test_threads_beyond_the_cpus_get_one_warning_line():
    from acder_lite.precision import threads_warning, usable_cpus

    assert usable_cpus() >= 1
    assert threads_warning(2, cpus=2) is None and threads_warning(1, cpus=2) is None
    line = threads_warning(64, cpus=2)
    assert "\n" not in line and "threads=64" in line and "--threads 2" in line


def test_train_help_lists_every_method_and_task_from_their_tables(capsys):
    # from config.METHODS and config.ENV_IDS, so an added method or task shows up in
    # --help without a docstring to edit
    from acder_lite.cli.main import build_parser
    from acder_lite.config import ENV_IDS, METHODS

    with pytest.raises(SystemExit):
        build_parser().parse_args(["train", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    method = text[text.index("--method METHOD") :].split("(default: her)")[0]
    assert "One of: " + ", ".join(METHODS) in method.replace("- ", "-")
    env = text[text.index("--env ENV") :].split("(default: FetchReach-v4)")[0]
    assert "One of: " + ", ".join(ENV_IDS) in env


def test_config_ranges_at_their_edges():
    """Config.validate at both edges of a range: workers in [1, MAX_WORKERS] (no env is
    no run), replay_k >= 0 (HER's future_p = 1 - 1/(1 + k) stays in [0, 1)), the
    exploration's noise and random-action probability in [0, 1]."""
    from acder_lite.config import MAX_WORKERS, Config, ConfigError

    for ok in (
        dict(workers=1),
        dict(workers=MAX_WORKERS),
        dict(replay_k=0),
        dict(noise_eps=0.0, random_eps=0.0),
        dict(noise_eps=1.0, random_eps=1.0),
    ):
        Config(**ok).validate()
    assert Config(replay_k=0).resolve().future_p == 0.0
    for bad, want in (
        (dict(workers=0), "workers=0 is not allowed: an integer >= 1"),
        (dict(workers=MAX_WORKERS + 1), f"workers={MAX_WORKERS + 1} is not allowed"),
        (dict(replay_k=-1), "replay_k=-1 is not allowed: an integer >= 0"),
        (dict(random_eps=1.5), "random_eps=1.5 is not allowed: a number in [0, 1]"),
        (dict(noise_eps=-0.1), "noise_eps=-0.1 is not allowed: a number in [0, 1]"),
    ):
        with pytest.raises(ConfigError) as e:
            Config(**bad).validate()
        assert str(e.value).startswith(want), e.value


def _fake_bench(monkeypatch, cycle_wall):
    """bench.run_bench on a fake Trainer and clock: a training cycle takes
    `cycle_wall[update_dtype]` s of wall time and 3 s of CPU, an evaluation 0.8 s of
    CPU, an update 4 ms, a simulated episode batch 0.5 s; 0.2 GFLOP an update on a
    100 GFLOP/s matmul."""
    from acder_lite.cli import bench
    from acder_lite.train import rollout, trainer

    clock = dict(wall=0.0, cpu=0.0)

    def spend(wall=0.0, cpu=0.0):
        clock["wall"] += wall
        clock["cpu"] += cpu

    class FakeTrainer:
        def __init__(self, cfg):
            cfg = cfg.resolve()
            self.cfg, self.device, self.T, self.dims = cfg, "cpu", 50, {"u": 4}
            self.envs, self.pool = [None] * cfg.workers, None

        def train_cycle(self):
            spend(wall=cycle_wall[self.cfg.update_dtype], cpu=3.0)

        def evaluate(self):
            spend(cpu=0.8)

        def update_step(self):
            spend(wall=0.004)

    monkeypatch.setattr(trainer, "Trainer", FakeTrainer)
    monkeypatch.setattr(rollout, "run_episodes", lambda *a, **k: spend(wall=0.5))
    fake_time = types.SimpleNamespace(
        perf_counter=lambda: clock["wall"], process_time=lambda: clock["cpu"]
    )
    monkeypatch.setattr(bench, "time", fake_time)
    monkeypatch.setattr(bench, "update_flops", lambda tr: 2e8)
    monkeypatch.setattr(bench, "matmul_gflops", lambda *a, **k: 100.0)
    # what auto would pick: an update timed at 5 ms in float32, 2 ms in bfloat16
    from acder_lite import precision

    monkeypatch.setattr(precision, "native_bf16", lambda: (True, "probe"))
    monkeypatch.setattr(precision, "time_update", lambda *shape: (5e-3, 2e-3))
    monkeypatch.setattr(precision, "_MEASURED", {})

    def run(update_dtype):
        args = argparse.Namespace(
            env="FetchReach-v4", method="her", workers=2, threads=1, cycles=2,
            update_dtype=update_dtype, device="cpu", compile_update=False,
        )  # fmt: skip
        return bench.run_bench(args)

    return run


def test_bench_line_derives_the_limit_share_and_grid_cost_from_its_timings(
    monkeypatch, capsys
):
    """run_bench's arithmetic on a fake clock. FetchReach-v4 (10 cycles an epoch), 2
    workers x 2 episodes = 4 episodes a cycle, 40 updates a cycle (10 an episode):
    simulation 0.5 s per 2 episodes = 250 ms; 2 timed cycles of 2 s = 500 ms an
    episode, of 3 s CPU = 750 ms, plus one 0.8 s evaluation shared by an epoch's
    10 x 4 episodes = 20 ms: grid 770 ms. An update takes 4 ms for 0.2 GFLOP (50
    GFLOP/s) on a 100 GFLOP/s matmul: 10 updates x 2 ms = 20 ms on top of simulation,
    limit 270 ms, 270 / 500 = 0.54 of training."""
    assert _fake_bench(monkeypatch, {"float32": 2.0})("float32") == 0
    first, auto, last = capsys.readouterr().out.strip().splitlines()
    assert first.endswith("update_ms=4.0 update_gflop=0.20 update_share_of_matmul=0.50")
    # the line before the last: what `--update-dtype auto` picks here, and why
    assert auto == (
        "auto picks update_dtype=bfloat16 here: probe; the update (512 rows, 3x256 "
        "hidden, 1 thread) measured float32 5.00 ms, bfloat16 2.00 ms: 2.50x, at least "
        "1.2x: bfloat16"
    )
    assert last.split() == [
        "bench:",
        "sim_ms_per_episode=250.0",
        "train_ms_per_episode=500.0",
        "ratio=2.00",
        "update_gflops=50.0",
        "matmul_gflops=100.0",
        "limit_ms_per_episode=270.0",
        "share_of_limit=0.54",
        "grid_cpu_ms_per_episode=770.0",
    ]


def test_bench_warns_when_its_matmul_reference_ran_slower_than_the_update(
    monkeypatch, capsys
):
    """On a busy machine the reference matmul can be timed slower than the update
    itself (a share of 5.49 was seen at --threads 2 beside the grid): the bench line
    stays as it is, and one warning line on stderr says its limit is not to be trusted.
    Below 1, no warning."""
    from acder_lite.cli import bench

    run = _fake_bench(monkeypatch, {"float32": 2.0})
    assert run("float32") == 0
    assert capsys.readouterr().err == ""
    monkeypatch.setattr(bench, "matmul_gflops", lambda *a, **k: 10.0)  # update: 50
    assert run("float32") == 0
    out, err = capsys.readouterr()
    assert out.strip().splitlines()[-1].startswith("bench: sim_ms_per_episode=")
    (line,) = err.strip().splitlines()
    assert "update_share_of_matmul=5.00 is above 1" in line and "idle" in line


def test_bench_both_dtypes_keeps_float32s_line(monkeypatch, capsys):
    """--update-dtype both: bfloat16's cycles take 1 s (250 ms an episode) against
    float32's 2 s (500 ms); the side line gives both, the bench line float32's."""
    assert _fake_bench(monkeypatch, {"float32": 2.0, "bfloat16": 1.0})("both") == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[2] == (
        "train_ms_per_episode float32=500.0 bfloat16=250.0 speedup=2.00 "
        "(the bench line below is float32's)"
    )
    assert "train_ms_per_episode=500.0" in lines[-1].split()


def test_eval_takes_seed_0(capsys):
    """--seed 0 is within 'an integer >= 0': eval goes on to the checkpoint (here one
    that is not there), so the error names the file, not the seed."""
    from acder_lite.cli.main import main

    assert main(["eval", "--checkpoint", "no-such.pt", "--seed", "0"]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and "--seed" not in err


def test_eval_and_bench_parse_to_their_documented_defaults():
    """The defaults eval's --help states (10 episodes, seed 12345) and bench's own
    (FetchPush-v4 with HER, 4 workers, 6 cycles, 2 threads, auto precision)."""
    from acder_lite.cli.main import build_parser

    e = build_parser().parse_args(["eval", "--checkpoint", "x.pt"])
    assert (e.episodes, e.seed, e.env) == (10, 12345, None)
    b = build_parser().parse_args(["bench"])
    assert (b.env, b.method, b.workers, b.cycles, b.threads) == (
        "FetchPush-v4", "her", 4, 6, 2,
    )  # fmt: skip
    assert (b.update_dtype, b.device, b.compile_update) == ("auto", "auto", False)


def test_out_of_memory_names_the_commands_own_sizes(monkeypatch, capsys):
    """eval out of memory: the size to make smaller is its --episodes; bench's is
    --workers (`cli._SIZES`), not train's buffer_size."""
    from acder_lite.cli import main as cli

    def oom(args):
        raise MemoryError()

    for command, argv, sizes in (
        ("cmd_eval", ["eval", "--checkpoint", "x.pt"], "(--episodes)"),
        ("cmd_bench", ["bench"], "(--workers)"),
    ):
        monkeypatch.setattr(cli_train, command, oom)
        assert cli.main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: out of memory") and err.strip().endswith(sizes)


def test_an_option_misspelt_twice_gets_one_hint(capsys):
    """`--epoch 2 --epoch 3`: both unknown, one option meant: '--epochs' once."""
    from acder_lite.cli.main import main

    assert main(["train", "--epoch", "2", "--epoch", "3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(
        "unrecognized arguments: --epoch 2 --epoch 3; did you mean --epochs?"
    )


def test_resume_of_a_runs_file_names_its_folder(tmp_path, capsys):
    """--resume RUN/policy.pt: refused, naming RUN, the folder to give instead."""
    from acder_lite.cli.main import main

    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "policy.pt").write_bytes(b"x")
    assert main(["train", "--resume", str(tmp_path / "run" / "policy.pt")]) == 2
    err = capsys.readouterr().err
    assert f"allowed: the run folder ({str(tmp_path / 'run')!r}, where" in err


def test_ctrl_c_in_a_command_exits_130(monkeypatch, capsys):
    """Ctrl-C in a command other than train (which says where its checkpoint is):
    'interrupted' and exit code 130, the shell's for SIGINT."""
    from acder_lite.cli import main as cli

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli_train, "cmd_eval", interrupted)
    assert cli.main(["eval", "--checkpoint", "x.pt"]) == 130
    assert capsys.readouterr().err == "interrupted\n"


def test_outputs_never_replace_a_link_a_device_or_a_trained_policy(cli, tmp_path):
    """Found by fuzzing: `--json /dev/full` replaced the device by a JSON file (the
    atomic rename puts a plain file in place of whatever is there), and `train --out`
    overwrote a folder holding a trained policy but no checkpoint. Each is one line now,
    and what was there is untouched."""
    from acder_lite.config import ConfigError
    from acder_lite.io import check_output

    target = tmp_path / "target.json"
    target.write_text("keep me")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    for path in (link, fifo, "/dev/null"):
        with pytest.raises(ConfigError, match="is a link, a device or a pipe"):
            check_output(str(path), "--json")
    assert link.is_symlink() and target.read_text() == "keep me"
    check_output(str(target), "--json")  # a regular file may be overwritten
    trained = tmp_path / "exported"
    trained.mkdir()
    (trained / "policy.pt").write_bytes(b"weights")
    p = cli("train", "--env", "FetchReach-v4", *TINY, "--out", str(trained))
    one_line_error(p, "holds policy.pt", "allowed: a new folder")
    assert os.listdir(trained) == ["policy.pt"]
    assert (trained / "policy.pt").read_bytes() == b"weights"


def test_a_file_this_user_cannot_read_is_one_line(monkeypatch, capsys):
    """A PermissionError anywhere below a command (an unreadable policy.pt, a run
    folder that cannot be entered) was a traceback and exit 1."""
    from acder_lite.cli import main as C

    def refuse(args):
        raise PermissionError(13, "Permission denied", "runs/r1/policy.pt")

    monkeypatch.setattr(cli_train, "cmd_eval", refuse)
    assert C.main(["eval", "--checkpoint", "runs/r1/policy.pt"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "permission denied 'runs/r1/policy.pt'" in line and "allowed:" in line


def _error_line(capsys) -> str:
    """The one line an in-process command wrote to stderr (no traceback)."""
    err = capsys.readouterr().err
    lines = [line for line in err.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


REACH_GRID = "sweep --envs FetchReach-v4 --methods her --seeds 0".split()
"""A one-cell sweep, before its --results and --dry-run (no Ray is started)."""


def test_threads_are_bounded_in_every_command(capsys, tmp_path):
    """Found by fuzzing: --threads 2147483647 (below the C int that torch takes)
    reached libgomp, whose thread table failed ("Out of memory allocating
    231928235112 bytes", exit 1). Config, bench, sweep and robust refuse more than
    MAX_THREADS = 1024 in one line; 1024 itself passes Config."""
    from acder_lite.cli.main import main
    from acder_lite.config import MAX_THREADS, Config, ConfigError

    Config(threads=MAX_THREADS).validate()
    with pytest.raises(
        ConfigError, match=r"threads=1025 is not allowed: .*\[1, 1024\]"
    ):
        Config(threads=MAX_THREADS + 1).validate()
    big = str(2**31 - 1)
    assert main(["bench", "--threads", big, "--cycles", "1"]) == 2
    assert "threads=2147483647 is not allowed" in _error_line(capsys)
    argv = [*REACH_GRID, "--results", str(tmp_path), "--dry-run"]
    assert main([*argv, "--threads", big]) == 2
    line = _error_line(capsys)
    assert "sweep: --threads=2147483647 is not allowed: an integer in [1, 1024]" in line
    assert os.listdir(tmp_path) == []


def test_a_sweep_refuses_a_name_given_twice(capsys, tmp_path):
    """Found by fuzzing: `--envs X X` (or a method given twice) planned the same cell
    twice, two tasks for one folder; refused like a repeated seed, naming the option
    and the value."""
    from acder_lite.cli.main import main

    for option, values, line in (
        ("--envs", ["FetchReach-v4"] * 2, "--envs gives 'FetchReach-v4' twice"),
        ("--methods", ["her", "her"], "--methods gives 'her' twice"),
        ("--seeds", ["0", "1", "0"], "--seeds gives 0 twice"),
    ):
        grid = {"--envs": ["FetchReach-v4"], "--methods": ["her"], "--seeds": ["0"]}
        grid[option] = values
        argv = ["sweep", *[a for k, v in grid.items() for a in (k, *v)]]
        assert main([*argv, "--results", str(tmp_path), "--dry-run"]) == 2
        assert line + "; allowed: each" in _error_line(capsys)


def test_counts_that_would_run_for_ever_are_refused(capsys, tmp_path):
    """Found by fuzzing: `bench --cycles 10**20`, `diagnose --batches 10**14` and
    `diagnose --episodes 10**14` ran for ever. Each has an upper bound (bench's
    MAX_CYCLES, diagnose's MAX_BATCHES and MAX_EPISODES), checked before anything is
    read; and diagnose's --batches with --episodes, where --batches was ignored
    without a word, is refused."""
    from acder_lite.cli.main import main

    for argv, needle in (
        (["bench", "--cycles", str(10**20)], "an integer in [1, 1000]"),
        (["diagnose", str(tmp_path), "--batches", str(10**14)], "in [1, 10000]"),
        (["diagnose", str(tmp_path), "--episodes", str(10**14)], "in [1, 10000]"),
        (
            ["diagnose", str(tmp_path), "--episodes", "4", "--batches", "3"],
            "--batches 3 and --episodes 4 exclude each other; allowed:",
        ),
    ):
        assert main(argv) == 2
        assert needle in _error_line(capsys), argv


def test_an_empty_path_or_name_is_one_line_before_anything_is_done(
    capsys, tmp_path, monkeypatch
):
    """Found by fuzzing: '' was read as "not given" (table's and sweep's --results
    fell back on results/, eval's --env on the checkpoint's, sweep's --address on a
    local Ray) or as "." (`pack ''` packed the current folder). Each is one line now,
    and nothing is read or written."""
    from acder_lite.cli.main import main

    monkeypatch.chdir(tmp_path)
    run = tmp_path / "run"
    run.mkdir()
    (run / "checkpoint.pt").write_bytes(b"not read")
    for argv, needle in (
        (["table", "--results", ""], "table: --results '' is empty; allowed:"),
        (["table", "--plan", ""], "table: --plan '' is empty; allowed:"),
        ([*REACH_GRID, "--results", "", "--dry-run"], "--results '' is empty"),
        (["sweep", "--plan", "", "--dry-run"], "sweep: --plan '' is empty"),
        ([*REACH_GRID, "--address", "", "--dry-run"], "--address '' is empty"),
        (["eval", "--checkpoint", "run/policy.pt", "--env", ""], "--env '' is empty"),
        (["pack", ""], "pack: '' is an empty path; allowed: a folder"),
        (["pack", "run", ""], "pack: '' is an empty path; allowed: a folder"),
        (["train", "--out", ""], "train: --out '' is empty; allowed: a run folder"),
        (["train", "--resume", ""], "train: --resume '' is empty"),
    ):
        assert main(argv) == 2
        assert needle in _error_line(capsys), argv
    assert sorted(os.listdir(tmp_path)) == ["run"]
    assert os.listdir(run) == ["checkpoint.pt"]


def _plan(tmp_path, text: str):
    """A one-cell plan file (FetchReach-v4, her, seed 0) with `text` added to its
    group."""
    path = tmp_path / "plan.toml"
    path.write_text(
        "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n" + text
    )
    return str(path)


def test_sweep_options_that_were_settled_silently(capsys, tmp_path):
    """Found by fuzzing: a second --train-args replaced the first; `sweep --epochs 5`
    (or --train-args '--cycles 2') replaced a plan's config value; and `--train-args
    '--bogus'` was argparse's "expected one argument", naming neither. Each is one line
    now; a sweep option equal to the plan's value is taken."""
    from acder_lite.cli.main import main

    plan = _plan(tmp_path, "config = { epochs = 3, cycles = 4 }\n")
    for argv, needle in (
        (
            ["--train-args", "--cycles 2", "--train-args", "--batch-size 16"],
            "argument --train-args: given twice ('--cycles 2', then '--batch-size 16')",
        ),
        (
            ["--epochs", "5"],
            "--epochs 5 differs from the plan's config epochs = 3 of "
            "FetchReach-v4/her/seed0; allowed: the plan's value, or no --epochs",
        ),
        (["--train-args", "--cycles 2"], "--cycles 2 in --train-args differs"),
        (["--train-args", "--bogus"], "--train-args: unrecognized arguments: --bogus"),
    ):
        assert main(["sweep", "--plan", plan, *argv, "--dry-run"]) == 2
        assert needle in _error_line(capsys), argv
    assert main(["sweep", "--plan", plan, "--epochs", "3", "--dry-run"]) == 0
    assert "1 to run" in capsys.readouterr().out
    assert sorted(os.listdir(tmp_path)) == ["plan.toml"]


def test_a_same_as_that_can_never_be_copied_is_refused(capsys, tmp_path):
    """Found by fuzzing: a plan group whose same_as is a file, or the folder its own
    runs go to, waited for ever ("its same_as run ... has not finished"); refused when
    the plan is read."""
    from acder_lite.cli.main import main
    from acder_lite.runs.plan import PlanError, read_plan

    (tmp_path / "notes.txt").write_text("keep me")
    for same_as, needle in (
        ("notes.txt", "same_as 'notes.txt' is a file; allowed: a folder of seed<k>"),
        ("notes.txt/x", "same_as 'notes.txt/x' is under"),
        ("FetchReach-v4/her", "is where the group's own runs go; allowed:"),
        ("./FetchReach-v4/../FetchReach-v4/her", "is where the group's own runs go"),
    ):
        plan = _plan(tmp_path, f"same_as = '{same_as}'\n")
        with pytest.raises(PlanError, match="group 1: same_as"):
            read_plan(plan)
        assert main(["sweep", "--plan", plan, "--dry-run"]) == 2
        assert needle in _error_line(capsys), same_as
    # another folder, not there yet: its runs may still come, so the cell waits
    cells = read_plan(_plan(tmp_path, "same_as = 'elsewhere'\n"))
    assert cells[0].action == "skip" and cells[0].note.startswith("waits: ")


def test_a_dry_run_says_when_its_results_cannot_be_written(capsys):
    """Found by fuzzing: `sweep --dry-run --results /proc/x` said "1 to run" (os.access
    says yes to root), and every cell would have failed in its task."""
    from acder_lite.cli.main import main

    assert main([*REACH_GRID, "--results", "/proc/acder-x", "--dry-run"]) == 2
    line = _error_line(capsys)
    assert "results folder '/proc' cannot be written" in line and "allowed:" in line


def test_a_run_inside_a_run_is_refused(capsys, tmp_path):
    """Found by fuzzing: `train --out RUN/sub`, RUN a run folder, trained a run inside
    a run, which table, pack and sweep then found as a run of its own under the first;
    a sweep's --results inside a run the same, cell by cell. Refused in one line naming
    the run folder above and the file that makes it one (`runs.run_folder_above`),
    before anything is made. Another tool's progress.csv, checkpoint.pt or config.json
    makes no run (a stray ~/checkpoint.pt must not refuse every run under $HOME)."""
    from acder_lite.cli.main import main
    from acder_lite.runs.read import run_folder_above

    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(
        '{"command": "python -m acder_lite train", "config": {}}'
    )
    argv = ["train", "--env", "FetchReach-v4", *TINY, "--out", str(run / "sub" / "x")]
    assert main(argv) == 2
    assert (
        f"train: --out '{run}/sub/x' is inside the run folder '{run}' (it holds "
        "config.json); allowed: a folder outside every run folder"
    ) in _error_line(capsys)
    assert main([*REACH_GRID, "--results", str(run), "--dry-run"]) == 2
    assert (
        f"results folder '{run}/FetchReach-v4/her/seed0' is inside the run folder "
        f"'{run}' (it holds config.json); allowed:"
    ) in _error_line(capsys)
    assert os.listdir(run) == ["config.json"]
    # relative paths are named relative
    cwd = os.getcwd()
    try:
        os.chdir(run)
        assert run_folder_above("sub") == (type(run)("."), "config.json")
    finally:
        os.chdir(cwd)
    # a packed run (its state) is one too; other tools' files are not
    (run / "config.json").write_text('{"tool": "not train"}')
    assert run_folder_above(run / "sub") is None
    for other in ("progress.csv", "checkpoint.pt", "done.json"):
        (run / other).write_bytes(b"")
    assert run_folder_above(run / "a" / "b") is None
    (run / "checkpoint.packed").mkdir()
    (run / "checkpoint.packed" / "state.pt.gz").write_bytes(b"")
    assert run_folder_above(run / "a" / "b") == (run, "checkpoint.packed/state.pt.gz")


def test_a_plan_may_not_set_threads(capsys, tmp_path):
    """Found by fuzzing: a plan group's `config = { threads = 2 }` was replaced by
    sweep's --threads (default 1) without a word: `_overrides_plan` compares only the
    options given, and --threads is always passed. --threads is also the CPUs Ray
    reserves for each cell, which a plan's value could not change, and threads change
    how fast a run goes, not its numbers: the plan refuses it, in a group or in
    [defaults], with or without sweep --threads."""
    from acder_lite.cli.main import main
    from acder_lite.runs.plan import PlanError, read_plan

    plan = _plan(tmp_path, "config = { threads = 2 }\n")
    with pytest.raises(PlanError, match="group 1: config may not set 'threads'"):
        read_plan(plan)
    for more in ([], ["--threads", "2"]):
        assert main(["sweep", "--plan", plan, *more, "--dry-run"]) == 2
        assert (
            "group 1: config may not set 'threads': sweep's --threads sets it for "
            "every cell (the CPUs Ray reserves for it); allowed: sweep --threads N, "
            "and no 'threads' in the plan"
        ) in _error_line(capsys)
    defaults = tmp_path / "defaults.toml"
    defaults.write_text("[defaults]\nconfig = { threads = 2 }\n")
    defaults.write_text(defaults.read_text() + open(_plan(tmp_path, "")).read())
    assert main(["sweep", "--plan", str(defaults), "--dry-run"]) == 2
    assert "[defaults]: config may not set 'threads'" in _error_line(capsys)
    assert sorted(os.listdir(tmp_path)) == ["defaults.toml", "plan.toml"]
