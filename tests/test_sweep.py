"""The sweep: planning (run / resume / skip), argument errors, and one tiny real interrupted sweep."""
import argparse
import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from acder_lite import sweep as S

ROOT = Path(__file__).resolve().parent.parent


def parse(argv):
    p = argparse.ArgumentParser()
    S.add_arguments(p)
    return p.parse_args(argv)


def touch(d: Path, *names):
    d.mkdir(parents=True, exist_ok=True)
    for n in names:
        (d / n).write_text("x")


@pytest.fixture
def grid(tmp_path):
    """seed0 complete, seed1 interrupted (checkpoint, no done.json), seed2 new, seed3 a progress.csv
    without checkpoint (committed results, or stopped before the first epoch), seed4 only a log."""
    base = tmp_path / "FetchReach-v4" / "her"
    touch(base / "seed0", "progress.csv", "config.json", "checkpoint.pt", "done.json")
    touch(base / "seed1", "progress.csv", "config.json", "checkpoint.pt")
    touch(base / "seed3", "progress.csv", "config.json")
    touch(base / "seed4", "train.log")
    return tmp_path


def test_plan(grid):
    cells = S.plan(["FetchReach-v4"], ["her"], [0, 1, 2, 3, 4], grid)
    assert [(c.seed, c.action) for c in cells] == [(0, "skip"), (1, "resume"), (2, "run"), (3, "skip"), (4, "run")]
    assert cells[1].out == grid / "FetchReach-v4" / "her" / "seed1"
    assert "nothing to resume" in cells[3].note


def test_plan_leaves_a_live_run_alone(grid, monkeypatch):
    """A train process started by hand (not by this sweep) on a folder: skipped, found via /proc."""
    if not os.path.isdir("/proc/self"):
        pytest.skip("no /proc")
    monkeypatch.chdir(grid)
    rel = os.path.join("FetchReach-v4", "her", "seed1")
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)",
                              "-m", "acder_lite", "train", "--resume", rel], cwd=grid)
    try:
        t0 = time.monotonic()
        while not open(f"/proc/{child.pid}/cmdline", "rb").read() and time.monotonic() - t0 < 5:
            time.sleep(0.01)  # just after exec the kernel may show an empty command line
        assert S.live_runs()[os.path.realpath(rel)] == child.pid
        cells = S.plan(["FetchReach-v4"], ["her"], [1, 2], ".")
        assert [c.action for c in cells] == ["skip", "run"]
        assert f"pid {child.pid}" in cells[0].note
    finally:
        child.kill()
        child.wait()


def test_plan_ebp_needs_an_object(tmp_path):
    cells = S.plan(["FetchReach-v4", "FetchPush-v4"], ["her-ebp"], [0], tmp_path)
    assert [(c.env, c.action) for c in cells] == [("FetchReach-v4", "skip"), ("FetchPush-v4", "run")]
    assert "object" in cells[0].note


def test_dry_run(grid, capsys):
    args = parse(["--envs", "FetchReach-v4", "--methods", "her", "her-ebp", "--seeds", "0", "1", "2",
                  "--results", str(grid), "--jobs", "2", "--dry-run"])
    assert S.run(args) == 0
    out = capsys.readouterr().out.splitlines()
    actions = [line.split()[:2] for line in out[:-1]]
    assert actions == [["skip", "FetchReach-v4/her/seed0"], ["resume", "FetchReach-v4/her/seed1"],
                       ["run", "FetchReach-v4/her/seed2"]] + [["skip", f"FetchReach-v4/her-ebp/seed{k}"]
                                                             for k in range(3)]
    assert "1 to run, 1 to resume, 4 to skip" in out[-1]
    assert not (grid / "FetchReach-v4" / "her" / "seed2").exists()  # a dry run creates nothing


def test_train_command(grid):
    args = parse(["--envs", "FetchReach-v4", "--methods", "her", "--seeds", "0", "--results", str(grid),
                  "--jobs", "1", "--epochs", "3", "--eval-every-cycles", "5", "--train-args=--cycles 2 --quiet"])
    assert S.check_args(args) is None
    assert args.threads == max(1, (os.cpu_count() or 1) // 1)
    fresh, resume = S.plan(["FetchReach-v4"], ["her"], [2, 1], grid)
    assert (fresh.action, resume.action) == ("run", "resume")
    cmd = S.train_command(fresh, args)
    assert cmd[:4] == [sys.executable, "-m", "acder_lite", "train"]
    assert cmd[cmd.index("--out") + 1] == str(fresh.out) and "--resume" not in cmd
    assert cmd[cmd.index("--epochs") + 1] == "3" and cmd[cmd.index("--eval-every-cycles") + 1] == "5"
    assert cmd[-3:] == ["--cycles", "2", "--quiet"] and "--workers" not in cmd
    cmd = S.train_command(resume, args)
    assert cmd[cmd.index("--resume") + 1] == str(resume.out) and "--out" not in cmd


@pytest.mark.parametrize("argv, msg", [
    (["--envs", "FetchFly-v4", "--methods", "her"], "unknown env 'FetchFly-v4'"),
    (["--envs", "FetchReach-v4", "--methods", "dqn"], "unknown method 'dqn'"),
    (["--envs", "FetchReach-v4", "--methods", "her", "--jobs", "0"], "--jobs=0"),
    (["--envs", "FetchReach-v4", "--methods", "her", "--threads", "0"], "--threads=0"),
    (["--envs", "FetchReach-v4", "--methods", "her", "--epochs", "0"], "--epochs=0"),
    (["--envs", "FetchReach-v4", "--methods", "her", "--success-threshold", "2"], "--success-threshold=2"),
    (["--envs", "FetchReach-v4", "--methods", "her", "--stop-patience", "-1"], "--stop-patience=-1"),
    (["--envs", "FetchReach-v4", "--methods", "her", "--stop-gap-episodes", "-1"], "--stop-gap-episodes=-1"),
    (["--envs", "FetchReach-v4", "--methods", "her", "--eval-every-cycles", "-1"], "--eval-every-cycles=-1"),
    (["--envs", "FetchReach-v4", "--methods", "her", "--train-args=--cycles '2"], "--train-args"),
])
def test_argument_errors(tmp_path, capsys, argv, msg):
    args = parse(argv + ["--seeds", "0", "--results", str(tmp_path), "--dry-run"])
    assert S.run(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and msg in err
    assert list(tmp_path.iterdir()) == []


def test_plan_and_grid_options_exclude_each_other(tmp_path, capsys):
    assert S.run(parse(["--plan", str(tmp_path / "p.toml"), "--envs", "FetchReach-v4", "--dry-run"])) == 2
    assert "exclude each other" in capsys.readouterr().err
    assert S.run(parse(["--envs", "FetchReach-v4", "--dry-run"])) == 2
    assert "required (or --plan FILE)" in capsys.readouterr().err


PLAN = """
[defaults]
config = { update_dtype = "float32" }

[[group]]
queue = "readings"
root = "../exp"
envs = ["FetchPush-v4"]
methods = ["acder"]
name = "sicm-raw"
seeds = [0, 1]
config = { sicm_input = "raw" }

[[group]]
envs = ["FetchReach-v4", "FetchPush-v4"]
methods = ["her", "her-ebp"]
seeds = [0]

[[group]]
envs = ["FetchReach-v4"]
methods = ["acder"]
seeds = [0]
hold = "waits for the readings"
"""


def test_read_plan(tmp_path):
    """Groups expand to cells; two queues alternate; names, roots, config, defaults and holds apply."""
    (tmp_path / "results").mkdir()
    path = tmp_path / "results" / "plan.toml"
    path.write_text(PLAN)
    touch(tmp_path / "results" / "FetchReach-v4" / "her" / "seed0", "progress.csv", "checkpoint.pt")
    cells = S.read_plan(path)
    assert [(c.name, c.action) for c in cells] == [
        ("FetchPush-v4/sicm-raw/seed0", "run"),
        ("FetchReach-v4/her/seed0", "resume"),
        ("FetchPush-v4/sicm-raw/seed1", "run"),
        ("FetchReach-v4/her-ebp/seed0", "skip"),       # EBP needs an object
        ("FetchPush-v4/her/seed0", "run"),
        ("FetchPush-v4/her-ebp/seed0", "run"),
        ("FetchReach-v4/acder/seed0", "skip"),         # on hold
    ]
    assert cells[0].out == tmp_path / "exp" / "FetchPush-v4" / "sicm-raw" / "seed0"
    assert cells[0].options == {"update_dtype": "float32", "sicm_input": "raw"}
    assert cells[4].options == {"update_dtype": "float32"}
    assert cells[-1].note == "on hold: waits for the readings"
    cmd = S.train_command(cells[0], parse(["--plan", str(path)]))
    assert cmd[cmd.index("--sicm-input") + 1] == "raw" and cmd[cmd.index("--method") + 1] == "acder"
    assert cmd[cmd.index("--out") + 1] == str(cells[0].out)


@pytest.mark.parametrize("text, msg", [
    ("[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\nfoo = 1\n", "unknown key 'foo'"),
    ("[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\n", "seeds must be a non-empty list"),
    ("[[group]]\nenvs = ['FetchFly-v4']\nmethods = ['her']\nseeds = [0]\n", "unknown env 'FetchFly-v4'"),
    ("[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her', 'acder']\nseeds = [0]\nname = 'x'\n", "name needs exactly one method"),
    ("[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\nconfig = { sicm_input = 'pixels' }\n", "sicm_input='pixels'"),
    ("[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n" * 2, "planned twice"),
    ("[[group]\n", "not valid TOML"),
    ("x = 1\n", "no [[group]] tables"),
])
def test_bad_plan(tmp_path, capsys, text, msg):
    path = tmp_path / "plan.toml"
    path.write_text(text)
    assert S.run(parse(["--plan", str(path), "--dry-run"])) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and msg in err and str(path) in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.toml"]  # nothing written


def test_the_committed_plan_reads():
    """results/plan.toml, the reproduction grid, is a valid plan: the issue's seed counts, float32."""
    cells = S.read_plan(ROOT / "results" / "plan.toml")
    count = lambda env, method: sum(c.env == env and c.out.parent.name == method and "results" in c.out.parts
                                    for c in cells)
    assert [count("FetchPush-v4", m) for m in ("her", "acder", "her-icm", "her-per", "her-ebp",
                                                "acder-no-curiosity")] == [5, 5, 3, 3, 3, 3]
    assert [count("FetchReach-v4", m) for m in ("her", "her-icm", "her-per", "acder", "acder-no-goal-factor")] == [5, 5, 5, 5, 3]
    assert [count("FetchPickAndPlace-v4", m) for m in ("her", "acder", "her-ebp", "acder-no-start-states")] == [3, 3, 2, 2]
    assert all(c.options.get("update_dtype") == "float32" for c in cells)


def test_negative_seed(tmp_path, capsys):
    assert S.run(parse(["--envs", "FetchReach-v4", "--methods", "her", "--seeds", "-1", "--dry-run"])) == 2
    assert "seeds" in capsys.readouterr().err


def _wait_for(pred, proc, timeout):
    t0 = time.monotonic()
    while not pred():
        assert proc.poll() is None, proc.stdout.read()
        assert time.monotonic() - t0 < timeout, "timed out"
        time.sleep(0.05)


def test_real_sweep_interrupt_and_restart(tmp_path):
    """Two tiny runs, one at a time: Ctrl-C during the second, then the same command finishes it."""
    cli = pytest.importorskip("acder_lite.cli")
    if "train" not in cli.build_parser().format_help():
        pytest.skip("no train command yet")
    results = tmp_path / "results"
    cmd = [sys.executable, "-m", "acder_lite", "sweep", "--envs", "FetchReach-v4", "--methods", "her",
           "--seeds", "0", "1", "--results", str(results), "--jobs", "1", "--threads", "1",
           "--epochs", "20", "--workers", "1",
           "--train-args=--cycles 2 --updates-per-cycle 2 --test-episodes 1 --batch-size 16 --hidden 16 "
           "--buffer-size 5000 --stop-patience 0 --quiet"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    run0, run1 = results / "FetchReach-v4" / "her" / "seed0", results / "FetchReach-v4" / "her" / "seed1"

    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        _wait_for(lambda: (run1 / "checkpoint.pt").exists(), proc, 150)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, out
    assert "finish FetchReach-v4/her/seed0: done" in out
    assert "finish FetchReach-v4/her/seed1: interrupted" in out
    assert (run0 / "done.json").exists() and not (run1 / "done.json").exists()
    before = {p.name: p.stat().st_mtime_ns for p in run0.iterdir()}

    out = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=150).stdout
    assert "skip   FetchReach-v4/her/seed0 (already complete)" in out
    assert "start  FetchReach-v4/her/seed1 (resume)" in out
    assert "finish FetchReach-v4/her/seed1: done" in out
    assert {p.name: p.stat().st_mtime_ns for p in run0.iterdir()} == before  # the finished run is untouched
    starts = [line for line in (run1 / "train.log").read_text().splitlines() if line.startswith("# ")]
    assert len(starts) == 2 and "--out" in starts[0] and "--resume" in starts[1]
    with open(run1 / "progress.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 20 and float(rows[-1]["episodes"]) == 20 * 2 * 2  # one row per epoch


def test_a_child_interrupted_from_outside_is_not_a_failure(grid, monkeypatch, capsys):
    """A run stopped by SIGINT from elsewhere keeps its checkpoint: the summary says interrupted."""
    def fake_start(cell, args):
        cell.out.mkdir(parents=True, exist_ok=True)
        log = open(cell.out / "train.log", "a")
        proc = subprocess.Popen(["sh", "-c", "kill -INT $$"], stdout=log, stderr=subprocess.STDOUT)
        return proc, log, time.monotonic()
    monkeypatch.setattr(S, "_start", fake_start)
    monkeypatch.setattr(S, "POLL_S", 0.01)
    args = parse(["--envs", "FetchReach-v4", "--methods", "her", "--seeds", "2", "--results", str(grid),
                  "--jobs", "1"])
    assert S.run(args) == 1
    out = capsys.readouterr().out
    assert "finish FetchReach-v4/her/seed2: interrupted" in out
    assert "0 finished, 0 failed, 1 interrupted (re-run the same command to resume)" in out
