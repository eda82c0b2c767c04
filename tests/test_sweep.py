"""The sweep: planning (run / resume / skip), argument errors,
and one tiny real interrupted sweep."""

import argparse
import csv
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from acder_lite.cli import sweep as S
from acder_lite.precision import usable_cpus
from acder_lite.runs.plan import PlanError, option_values, plan, read_plan
from conftest import stop_tree

ROOT = Path(__file__).resolve().parent.parent


REACH_HER_0 = "--envs FetchReach-v4 --methods her --seeds 0 --results".split()
"""A one-cell grid's options, up to the results folder."""


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
    """seed0 complete, seed1 interrupted (checkpoint, no done.json), seed2 new, seed3 a
    progress.csv without checkpoint (committed results, or stopped before the first
    epoch), seed4 only a log."""
    base = tmp_path / "FetchReach-v4" / "her"
    touch(base / "seed0", "progress.csv", "config.json", "checkpoint.pt", "done.json")
    touch(base / "seed1", "progress.csv", "config.json", "checkpoint.pt")
    touch(base / "seed3", "progress.csv", "config.json")
    touch(base / "seed4", "train.log")
    return tmp_path


def test_plan(grid):
    cells = plan(["FetchReach-v4"], ["her"], [0, 1, 2, 3, 4], grid)
    assert [(c.seed, c.action) for c in cells] == [
        (0, "skip"),
        (1, "resume"),
        (2, "run"),
        (3, "skip"),
        (4, "run"),
    ]
    assert cells[1].out == grid / "FetchReach-v4" / "her" / "seed1"
    assert "nothing to resume" in cells[3].note


def test_plan_refuses_a_cell_config_refuses(tmp_path):
    """Config's own check decides (one place): EBP on a task without an object is an
    error, not a skipped cell (it was, with exit 0)."""
    with pytest.raises(PlanError, match="needs a task with an object") as e:
        plan(["FetchReach-v4", "FetchPush-v4"], ["her-ebp"], [0], tmp_path)
    assert "(FetchReach-v4, her-ebp, seed 0)" in str(e.value)
    assert [c.action for c in plan(["FetchPush-v4"], ["her-ebp"], [0], tmp_path)] == [
        "run"
    ]


@pytest.mark.parametrize(
    "argv, msg",
    [
        (
            "--envs FetchReach-v4 --methods her-ebp --seeds 0",
            "the pair (FetchReach-v4, her-ebp): method='her-ebp' needs a task with",
        ),
        (
            "--envs FetchReach-v4 FetchPush-v4 --methods her her-ebp --seeds 0",
            "the pair (FetchReach-v4, her-ebp)",
        ),
        (
            "--envs FetchReach-v4 --methods her --seeds 18446744073709551616",
            "seeds must be integers < 2**64",
        ),
    ],
)
def test_grid_of_a_cell_config_refuses(tmp_path, capsys, argv, msg):
    """A grid cell Config refuses is exit 2 in one line, before anything is planned
    (it was "nothing to run: 1 skipped", exit 0)."""
    args = parse([*argv.split(), "--results", str(tmp_path), "--dry-run"])
    assert S.run(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and msg in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_dry_run(grid, capsys):
    args = parse(
        [
            "--envs",
            "FetchReach-v4",
            "--methods",
            "her",
            "her-per",
            "--seeds",
            "0",
            "1",
            "2",
            "--results",
            str(grid),
            "--jobs",
            "2",
            "--dry-run",
        ]
    )
    assert S.run(args) == 0
    out = capsys.readouterr().out.splitlines()
    actions = [line.split()[:2] for line in out[:-2]]
    assert actions == [
        ["skip", "FetchReach-v4/her/seed0"],
        ["resume", "FetchReach-v4/her/seed1"],
        ["run", "FetchReach-v4/her/seed2"],
    ] + [["run", f"FetchReach-v4/her-per/seed{k}"] for k in range(3)]
    assert "4 to run, 1 to resume, 0 to copy, 1 to skip" in out[-2]
    assert out[-1].startswith("sweep: time left: ")  # acder_lite.runs.grid_time
    assert not (
        grid / "FetchReach-v4" / "her" / "seed2"
    ).exists()  # a dry run creates nothing


def test_default_jobs_fill_the_usable_cpus(grid, monkeypatch):
    # the affinity mask, not os.cpu_count(): a container limited to 6 of 64 CPUs runs
    # 3 two-thread cells at once, not 32
    monkeypatch.setattr(S, "usable_cpus", lambda: 6)
    args = parse([*REACH_HER_0, str(grid), "--threads", "2"])
    assert S.check_args(args) is None and args.jobs == 3
    monkeypatch.setattr(S, "usable_cpus", lambda: 1)
    args = parse([*REACH_HER_0, str(grid), "--threads", "2"])
    assert S.check_args(args) is None and args.jobs == 1


def test_train_argv(grid):
    args = parse(
        [*REACH_HER_0, str(grid), *"--epochs 3 --eval-every-cycles 5".split()]
        + ["--train-args=--cycles 2"]
    )
    assert S.check_args(args) is None
    assert args.threads == 1 and args.jobs == usable_cpus()
    fresh, resume = plan(["FetchReach-v4"], ["her"], [2, 1], grid)
    argv = S.train_argv(fresh, args, resume=False)
    assert (
        argv[:1] == ["train"]
        and argv[argv.index("--out") + 1] == str(fresh.out)
        and "--resume" not in argv
    )
    assert (
        argv[argv.index("--epochs") + 1] == "3"
        and argv[argv.index("--eval-every-cycles") + 1] == "5"
    )
    assert argv[argv.index("--threads") + 1] == "1" and "--workers" not in argv
    assert argv[-3:] == ["--cycles", "2", "--quiet"]
    argv = S.train_argv(resume, args, resume=True)
    assert argv[argv.index("--resume") + 1] == str(resume.out) and "--out" not in argv


def test_auto_precision_is_decided_once_per_task(tmp_path, monkeypatch):
    """`--update-dtype auto` in a sweep: the driver decides once per task, before the
    cells start (`decide_update_dtypes`), and every new cell of the task gets that
    precision; a resumed cell keeps its checkpoint's; a plan's float32, or one in
    --train-args, is not decided."""
    from acder_lite import precision

    decisions = []

    def choose(requested, device="cpu", **shape):
        if requested != "auto":
            return requested, "asked for"
        decisions.append(shape)
        return ("bfloat16", f"auto: decision {len(decisions)}")

    monkeypatch.setattr(precision, "choose_update_dtype", choose)
    results = tmp_path / "r"
    touch(results / "FetchPush-v4" / "her" / "seed1", "config.json", "checkpoint.pt")
    grid = ["--envs", "FetchReach-v4", "FetchPush-v4", "--methods", "her", "her-per"]
    grid += ["--seeds", "0", "1", "--results", str(results)]
    cells = plan(["FetchReach-v4", "FetchPush-v4"], ["her", "her-per"], [0, 1], results)
    assert sum(c.action == "resume" for c in cells) == 1
    args = parse(grid)
    assert S.check_args(args) is None
    decisions.clear()  # planning resolved the cells too
    lines = S.decide_update_dtypes(cells, args)
    assert len(decisions) == 2 and lines == [
        "update_dtype bfloat16 for FetchReach-v4's 4 new cells (auto: decision 1)",
        "update_dtype bfloat16 for FetchPush-v4's 3 new cells (auto: decision 2)",
    ]
    for c in cells:
        resume = c.action == "resume"
        argv = S.train_argv(c, args, resume=resume)
        if resume:  # its precision is its checkpoint's
            assert "--update-dtype" not in argv
        else:
            assert argv.count("--update-dtype") == 1
            assert argv[argv.index("--update-dtype") + 1] == "bfloat16"
    # a task decided stays decided (a cell started later, after a replan)
    assert S.decide_update_dtypes(cells, args) == [] and len(decisions) == 2
    # the precision set by --train-args, or by the plan: nothing decided
    args = parse([*grid, "--train-args=--update-dtype float32"])
    assert S.check_args(args) is None and S.decide_update_dtypes(cells, args) == []
    argv = S.train_argv(cells[0], args, resume=False)
    assert argv.count("--update-dtype") == 1 and "float32" in argv
    (tmp_path / "plan.toml").write_text(
        '[defaults]\nconfig = { update_dtype = "float32" }\n\n[[group]]\n'
        'envs = ["FetchReach-v4"]\nmethods = ["her"]\nseeds = [0, 1]\n'
    )
    args = parse(["--plan", str(tmp_path / "plan.toml")])
    cells = read_plan(tmp_path / "plan.toml")
    decisions.clear()  # reading the plan resolved its pairs
    assert S.check_args(args) is None and S.decide_update_dtypes(cells, args) == []
    argv = S.train_argv(cells[0], args, resume=False)
    assert argv[argv.index("--update-dtype") + 1] == "float32"
    assert argv.count("--update-dtype") == 1 and decisions == []


@pytest.mark.parametrize(
    "argv, msg",
    [
        (["--envs", "FetchFly-v4", "--methods", "her"], "unknown env 'FetchFly-v4'"),
        (["--envs", "FetchReach-v4", "--methods", "dqn"], "unknown method 'dqn'"),
        (["--envs", "FetchReach-v4", "--methods", "her", "--jobs", "0"], "--jobs=0"),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--threads", "0"],
            "--threads=0",
        ),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--epochs", "0"],
            "epochs=0 is not allowed",
        ),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--success-threshold", "2"],
            "success_threshold=2.0 is not allowed",
        ),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--stop-patience", "-1"],
            "stop_patience=-1 is not allowed",
        ),
        (
            [
                "--envs",
                "FetchReach-v4",
                "--methods",
                "her",
                "--stop-gap-episodes",
                "-1",
            ],
            "stop_gap_episodes=-1",
        ),
        (
            [
                "--envs",
                "FetchReach-v4",
                "--methods",
                "her",
                "--eval-every-cycles",
                "-1",
            ],
            "eval_every_cycles=-1",
        ),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--train-args=--cycles '2"],
            "--train-args",
        ),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--train-args=--out x"],
            "may not hold --out",
        ),
        # after the cell's own --out, --out=DIR sent every cell to DIR
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--train-args=--out=x"],
            "may not hold --out",
        ),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--train-args=--resume=x"],
            "may not hold --out or --resume",
        ),
        # checked as train reads them, before any cell starts and fails alike
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--train-args=--bogus 1"],
            "--train-args: unrecognized arguments: --bogus",
        ),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--train-args=--gamma 2"],
            "--train-args: gamma=2.0 is not allowed",
        ),
        (
            ["--envs", "FetchReach-v4", "--methods", "her", "--train-args=--seed 3"],
            "may not hold --seed",
        ),
    ],
)
def test_argument_errors(tmp_path, capsys, argv, msg):
    args = parse(argv + ["--seeds", "0", "--results", str(tmp_path), "--dry-run"])
    assert S.run(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and msg in err
    assert list(tmp_path.iterdir()) == []


def test_results_folder_that_is_a_file(tmp_path, capsys):
    (tmp_path / "results").write_text("not a folder")
    args = parse([*REACH_HER_0, str(tmp_path / "results")])
    assert S.run(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a file" in err
    assert (tmp_path / "results").read_text() == "not a folder"


def test_address_that_does_not_answer(tmp_path, capsys):
    """A cluster address where nothing listens: one line, exit 2, nothing written,
    no Ray started."""
    # a port on loopback held, bound but not listening, for the whole call: nothing
    # answers there, and no other process can take it meanwhile
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        args = parse(
            [
                *REACH_HER_0,
                str(tmp_path / "r"),
                "--address",
                f"127.0.0.1:{port}",
            ]
        )
        t0 = time.monotonic()
        assert S.run(args) == 2
    err = capsys.readouterr().err
    assert (
        err.count("\n") == 1 and "does not answer" in err and time.monotonic() - t0 < 10
    )
    assert list(tmp_path.iterdir()) == []
    assert (
        S.run(
            parse(
                [
                    *REACH_HER_0,
                    str(tmp_path / "r"),
                    "--address",
                    "nonsense",
                ]
            )
        )
        == 2
    )
    assert "'auto' or HOST:PORT" in capsys.readouterr().err
    # Ray Client: refused at once, naming what to do instead
    args = parse([*REACH_HER_0, str(tmp_path / "r"), "--address", "ray://h:10001"])
    assert S.run(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "from a node of the cluster" in err
    assert list(tmp_path.iterdir()) == []
    # the dry run too (it printed its plan, exit 0, for an address the run refuses)
    assert (
        S.run(
            parse(
                [
                    *REACH_HER_0,
                    str(tmp_path / "r"),
                    "--dry-run",
                    "--address",
                    "ray://h:10001",
                ]
            )
        )
        == 2
    )
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1
    assert "from a node of the cluster" in captured.err


def test_join_problem_says_what_to_set(monkeypatch):
    """Each way a join fails gets its own line, with what to do."""
    from acder_lite.cli.cluster import join_problem

    class AuthenticationError(Exception):  # Ray's, by name
        pass

    a = "10.0.0.1:6379"
    retries = "gcs_client.cc:210: ... Unauthenticated: RPC error: InvalidAuthToken: ..."
    monkeypatch.delenv("RAY_AUTH_MODE", raising=False)
    refused = join_problem(a, ConnectionError("Failed to connect"), retries)
    assert "set RAY_AUTH_MODE=token" in refused and a in refused
    for mode in ("token", "TOKEN"):  # Ray reads the mode case-blind, and so do we
        monkeypatch.setenv("RAY_AUTH_MODE", mode)
        said = join_problem(a, ConnectionError(""), retries)
        assert "refused this sweep's token" in said
    none = join_problem(a, AuthenticationError("no authentication token was found"), "")
    assert "RAY_AUTH_MODE=token but no token here" in none
    other = join_problem(a, ConnectionError("Could not find any running Ray\nmore"), "")
    assert other.endswith("no Ray cluster there (Could not find any running Ray)")
    assert "(ValueError)" in join_problem(a, ValueError(""), "")
    for line in (refused, none, other):
        assert "\n" not in line


class RayHead:
    """`ray start --head --block` on a free port with token authentication (a token of
    its own, in the environment), in a temp folder of its own; `stop` ends it and
    everything it started (never `ray stop`: that would end every Ray on the
    machine)."""

    def __init__(self, tmp: Path):
        import secrets
        import tempfile

        self.token = secrets.token_hex(32)
        # Ray's socket paths must stay short: not under pytest's deep tmp_path
        self.dir = Path(tempfile.mkdtemp(prefix="acder-ray-"))
        self.log = tmp / "head.log"
        for _ in range(3):  # a free port could be taken before Ray binds it
            with socket.socket() as s:
                s.bind(("127.0.0.1", 0))
                self.port = s.getsockname()[1]
            self.proc = subprocess.Popen(
                [
                    str(Path(sys.executable).parent / "ray"),
                    "start",
                    "--head",
                    "--block",
                    f"--port={self.port}",
                    "--num-cpus=2",
                    "--include-dashboard=false",
                    "--disable-usage-stats",
                    f"--temp-dir={self.dir}",
                ],
                env=self.env(),
                stdout=open(self.log, "wb"),
                stderr=subprocess.STDOUT,
            )
            t0 = time.monotonic()
            while self.proc.poll() is None and time.monotonic() - t0 < 90:
                if "Ray runtime started" in self.log.read_text(errors="replace"):
                    return
                time.sleep(0.5)
            self.stop()
        pytest.fail(f"ray start failed:\n{self.log.read_text()[-2000:]}")

    def env(self, token: bool = True) -> dict:
        env = {
            k: v
            for k, v in os.environ.items()
            if not k.startswith(("RAY_AUTH", "RAY_ADDRESS"))
        }
        env["PYTHONPATH"] = str(ROOT)
        if token:
            env.update(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=self.token)
        return env

    def stop(self) -> None:
        stop_tree(self.proc)
        shutil.rmtree(self.dir, ignore_errors=True)


@pytest.mark.xdist_group("ray")
def test_sweep_joins_a_running_cluster(tmp_path):
    """A cluster started with `ray start --head` (token authentication on): a sweep
    with `--address HOST:PORT` and no token is refused in one line saying what to set;
    with the token it trains its cell there and leaves the cluster running."""
    head = RayHead(tmp_path)
    try:
        cmd = [
            *_sweep_cmd(tmp_path / "results", [0], 1),
            "--address",
            f"127.0.0.1:{head.port}",
        ]
        refused = subprocess.run(
            cmd,
            cwd=tmp_path,
            env=head.env(token=False),
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert refused.returncode == 2, refused.stdout + refused.stderr
        # Ray's C++ client printed a retry a second: held, not shown
        assert refused.stderr.count("\n") == 1, refused.stderr
        assert "set RAY_AUTH_MODE=token" in refused.stderr
        assert not (tmp_path / "results").exists()

        joined = subprocess.run(
            cmd,
            cwd=tmp_path,
            env=head.env(),
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert joined.returncode == 0, joined.stdout + joined.stderr
        assert "finish FetchReach-v4/her/seed0: done" in joined.stdout
        assert "local Ray" not in joined.stdout  # it joined, it did not start one
        run = tmp_path / "results" / "FetchReach-v4" / "her" / "seed0"
        assert (run / "done.json").exists() and len(_rows(run)) == 1
        assert head.proc.poll() is None, "the sweep ended the cluster it joined"
        socket.create_connection(("127.0.0.1", head.port), timeout=5).close()
    finally:
        head.stop()


def test_plan_and_grid_options_exclude_each_other(tmp_path, capsys):
    assert (
        S.run(
            parse(
                [
                    "--plan",
                    str(tmp_path / "p.toml"),
                    "--envs",
                    "FetchReach-v4",
                    "--dry-run",
                ]
            )
        )
        == 2
    )
    assert "exclude each other" in capsys.readouterr().err
    # --results beside --plan was ignored (the cells went under the plan's folder)
    plan_and_results = ["--plan", str(tmp_path / "p.toml"), "--results", "elsewhere"]
    assert S.run(parse([*plan_and_results, "--dry-run"])) == 2
    said = capsys.readouterr().err.strip().splitlines()
    assert len(said) == 1 and "--plan FILE and --results exclude each other" in said[0]
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
methods = ["her", "her-per"]
seeds = [0]

[[group]]
envs = ["FetchReach-v4"]
methods = ["acder"]
seeds = [0]
hold = "waits for the readings"
"""


def test_read_plan(tmp_path):
    """Groups expand to cells; two queues alternate; names, roots, config,
    defaults and holds apply."""
    (tmp_path / "results").mkdir()
    path = tmp_path / "results" / "plan.toml"
    path.write_text(PLAN)
    touch(
        tmp_path / "results" / "FetchReach-v4" / "her" / "seed0",
        "progress.csv",
        "checkpoint.pt",
    )
    cells = read_plan(path)
    assert [(c.name, c.action) for c in cells] == [
        ("FetchPush-v4/sicm-raw/seed0", "run"),
        ("FetchReach-v4/her/seed0", "resume"),
        ("FetchPush-v4/sicm-raw/seed1", "run"),
        ("FetchReach-v4/her-per/seed0", "run"),
        ("FetchPush-v4/her/seed0", "run"),
        ("FetchPush-v4/her-per/seed0", "run"),
        ("FetchReach-v4/acder/seed0", "skip"),  # on hold
    ]
    assert cells[0].out == tmp_path / "exp" / "FetchPush-v4" / "sicm-raw" / "seed0"
    assert cells[0].options == {"update_dtype": "float32", "sicm_input": "raw"}
    assert cells[4].options == {"update_dtype": "float32"}
    assert cells[-1].note == "on hold: waits for the readings"
    cmd = S.train_argv(cells[0], parse(["--plan", str(path)]), resume=False)
    assert (
        cmd[cmd.index("--sicm-input") + 1] == "raw"
        and cmd[cmd.index("--method") + 1] == "acder"
    )
    assert cmd[cmd.index("--out") + 1] == str(cells[0].out)
    # every cell sets update_dtype (defaults); only the readings' group sets sicm_input
    assert option_values(path, "update_dtype") == ["float32"]
    assert option_values(path, "sicm_input") == ["raw"]
    assert option_values(path, "reward_bonus") == []


@pytest.mark.parametrize(
    "text, msg",
    [
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "foo = 1\n",
            "unknown key 'foo'",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\n",
            "seeds must be a non-empty list",
        ),
        (
            "[[group]]\nenvs = ['FetchFly-v4']\nmethods = ['her']\nseeds = [0]\n",
            "unknown env 'FetchFly-v4'",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her', 'acder']\n"
            "seeds = [0]\nname = 'x'\n",
            "name needs exactly one method",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "config = { sicm_input = 'pixels' }\n",
            "sicm_input='pixels'",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n" * 2,
            "planned twice",
        ),
        ("[[group]\n", "not valid TOML"),
        ("[defaults]\n", "no [[group]] tables"),
        # a top-level typo: its tables were dropped silently, exit 0
        ("x = 1\n", "unknown top-level key 'x'; allowed: [defaults] and [[group]]"),
        (
            "[default]\nconfig = { epochs = 3 }\n[[group]]\nenvs = ['FetchReach-v4']\n"
            "methods = ['her']\nseeds = [0]\n",
            "unknown top-level key 'default'",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "[[groups]]\nenvs = ['FetchPush-v4']\nmethods = ['her']\nseeds = [0]\n",
            "unknown top-level key 'groups'",
        ),
        # every (env, method) pair of a group, not its first only: the others were
        # skipped cells, exit 0
        (
            "[[group]]\nenvs = ['FetchPush-v4', 'FetchReach-v4']\n"
            "methods = ['her-ebp']\nseeds = [0]\n",
            "group 1: the pair (FetchReach-v4, her-ebp): method='her-ebp' needs",
        ),
        (
            "[[group]]\nenvs = ['FetchPush-v4', 'FetchReach-v4']\n"
            "methods = ['acder']\nseeds = [0]\nconfig = { sicm_angles = 'sincos' }\n",
            "group 1: config on the pair (FetchReach-v4, acder): sicm_angles='sincos'",
        ),
        # tracebacks before (TypeError, UnicodeDecodeError), or a cell that trained
        # another env, seed or folder than the plan's
        ("group = [1, 2]\n", "group 1 is 1, not a table"),
        (
            "[defaults]\nconfig = 5\n[[group]]\nenvs = ['FetchReach-v4']\n"
            "methods = ['her']\nseeds = [0]\n",
            "[defaults]: config is 5, not a table",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = [['her']]\nseeds = [0]\n",
            "unknown method ['her']",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "name = 5\n",
            "name is 5, not a string",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "root = 5\n",
            "root is 5, not a string",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "name = '../../elsewhere'\n",
            "is not one folder name",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [true]\n",
            "seeds must be integers >= 0",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "config = { env = 'FetchPush-v4' }\n",
            "config may not set 'env'",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "config = { gamma = 'x' }\n",
            "gamma='x' is not allowed: a number",
        ),
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            "config = { nope = 1 }\n",
            "config: unknown field 'nope'",
        ),
        # a dry run said "run" of a folder no OS can make
        (
            "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
            'name = "a\\u0000b"\n',
            "name 'a\\x00b' holds a NUL character",
        ),
    ],
)
def test_bad_plan(tmp_path, capsys, text, msg):
    path = tmp_path / "plan.toml"
    path.write_text(text)
    assert S.run(parse(["--plan", str(path), "--dry-run"])) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and msg in err and str(path) in err
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "plan.toml"
    ]  # nothing written


def test_table_plan_with_a_top_level_typo(tmp_path):
    """`table --plan` reads the plan as the sweep does: a [default] table (for
    [defaults]) is an error naming it, not seed counts without it."""
    from acder_lite.runs import table
    from acder_lite.config import ConfigError

    path = tmp_path / "plan.toml"
    path.write_text(
        "[default]\nconfig = { epochs = 3 }\n[[group]]\nenvs = ['FetchReach-v4']\n"
        "methods = ['her']\nseeds = [0]\n"
    )
    with pytest.raises(ConfigError, match="unknown top-level key 'default'"):
        table.read_planned(argparse.Namespace(plan=str(path)), tmp_path)


SINCOS = ["--train-args=--sicm-angles sincos", "--dry-run"]


def test_train_args_checked_on_the_grids_own_pairs(tmp_path, capsys):
    """--train-args are checked on the grid's (env, method) pairs, not on
    FetchReach-v4: S-ICM on (sin, cos) of the block's angles is a Push option."""
    push = ["--envs", "FetchPush-v4", "--methods", "acder", "--seeds", "0"]
    assert S.run(parse([*push, "--results", str(tmp_path / "r"), *SINCOS])) == 0
    assert "1 to run" in capsys.readouterr().out
    both = [*push[:2], "FetchReach-v4", *push[2:]]
    assert S.run(parse([*both, "--results", str(tmp_path / "r"), *SINCOS])) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--train-args: sicm_angles='sincos'" in err
    assert err.rstrip().endswith("on the pair (FetchReach-v4, acder)")
    # a plan: its cells' pairs and configs, also when read again mid-sweep
    path = tmp_path / "plan.toml"
    group = "[[group]]\nenvs = ['{}']\nmethods = ['acder']\nseeds = [0]\n"
    path.write_text(group.format("FetchPush-v4"))
    assert S.run(parse(["--plan", str(path), *SINCOS])) == 0
    capsys.readouterr()
    path.write_text(group.format("FetchPush-v4") + group.format("FetchReach-v4"))
    assert S.run(parse(["--plan", str(path), *SINCOS])) == 2
    assert "on the pair (FetchReach-v4, acder)" in capsys.readouterr().err
    args = parse(["--plan", str(path), *SINCOS])
    assert S.check_args(args) is None
    with pytest.raises(PlanError, match="sicm_angles"):
        S.read_checked(args)
    assert not (tmp_path / "r").exists() and not (tmp_path / "FetchPush-v4").exists()


@pytest.mark.parametrize(
    "argv, msg",
    [
        (
            ["--epochs", "3", "--train-args=--epochs 5"],
            "--train-args may not hold --epochs: it is sweep's own --epochs",
        ),
        (["--train-args=--epochs 5"], "may not hold --epochs"),
        (
            ["--threads", "1", "--train-args=--cycles 2 --threads 2"],
            "--train-args may not hold --threads: it is sweep's own --threads",
        ),
        (["--train-args=--stop-patience 0"], "may not hold --stop-patience"),
    ],
)
def test_train_args_may_not_repeat_sweeps_own_options(tmp_path, capsys, argv, msg):
    """train reads --train-args last, so a duplicate there won silently, and a
    --threads there was not what Ray reserved per cell: refused, naming both."""
    args = parse([*REACH_HER_0, str(tmp_path), *argv, "--dry-run"])
    assert S.run(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and msg in err
    assert list(tmp_path.iterdir()) == []


def test_a_plan_that_is_not_text(tmp_path, capsys):
    path = tmp_path / "plan.toml"
    path.write_bytes(b"\xff\xfe[[group]]\x00")
    assert S.run(parse(["--plan", str(path), "--dry-run"])) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not valid TOML: not UTF-8 text" in err
    assert "Traceback" not in err and str(path) in err


def test_the_committed_plan_reads():
    """results/plan.toml, the reproduction grid, is a valid plan:
    the issue's seed counts, float32."""
    cells = read_plan(ROOT / "results" / "plan.toml")
    count = lambda env, method: sum(
        c.env == env and c.out.parent.name == method and "results" in c.out.parts
        for c in cells
    )
    assert [
        count("FetchPush-v4", m)
        for m in ("her", "acder", "her-icm", "her-per", "her-ebp", "acder-no-curiosity")
    ] == [5, 5, 3, 3, 3, 3]
    assert [
        count("FetchReach-v4", m)
        for m in ("her", "her-icm", "her-per", "acder", "acder-no-goal-factor")
    ] == [5, 5, 5, 5, 3]
    assert [
        count("FetchPickAndPlace-v4", m)
        for m in ("her", "acder", "her-ebp", "acder-no-start-states")
    ] == [5, 5, 2, 2]
    assert all(c.options.get("update_dtype") == "float32" for c in cells)
    # Multi-step Push: the 40-epoch pair in experiments/, ACDER at 400 in results/
    multi = {
        (c.out.parent.name, c.epochs, c.out.parts[-4])
        for c in cells
        if c.env == "FetchPushMultiStep-v0"
    }
    assert multi == {
        ("her", 40, "multistep-40"),
        ("acder", 40, "multistep-40"),
        ("acder", 400, "results"),
    }


def test_one_cell_under_two_roots_is_two_folders(tmp_path):
    """The same env/method/seed planned under two roots is two run folders, allowed;
    the same folder twice is refused by its path."""
    group = "[[group]]\nenvs = ['FetchReach-v4']\nmethods = ['her']\nseeds = [0]\n"
    path = tmp_path / "results" / "plan.toml"
    path.parent.mkdir()
    path.write_text(group + "root = '../exp'\n" + group)
    assert [c.out for c in read_plan(path)] == [
        tmp_path / "exp" / "FetchReach-v4" / "her" / "seed0",
        tmp_path / "results" / "FetchReach-v4" / "her" / "seed0",
    ]
    path.write_text(group + "root = '../results'\n" + group)
    with pytest.raises(PlanError, match="'FetchReach-v4/her/seed0' is planned twice"):
        read_plan(path)


def test_negative_seed(tmp_path, capsys):
    assert (
        S.run(
            parse(
                [
                    "--envs",
                    "FetchReach-v4",
                    "--methods",
                    "her",
                    "--seeds",
                    "-1",
                    "--dry-run",
                ]
            )
        )
        == 2
    )
    assert "seeds" in capsys.readouterr().err


TINY_OWN = ["--workers", "1", "--stop-patience", "0"]
"""The part of `TINY` that sweep has options of its own for (not --train-args)."""
TINY_TRAIN = (
    "--cycles 2 --updates-per-cycle 2 --test-episodes 1 --batch-size 16 "
    "--hidden 16 --buffer-size 5000"
)
"""The rest of `TINY`: the sweep's --train-args."""
TINY = " ".join([*TINY_OWN, TINY_TRAIN])
"""A FetchReach run of a few seconds an epoch (for the real Ray sweeps below)."""


def _sweep_cmd(results, seeds, epochs):
    return [
        sys.executable,
        "-m",
        "acder_lite",
        "sweep",
        "--envs",
        "FetchReach-v4",
        "--methods",
        "her",
        "--seeds",
        *map(str, seeds),
        "--results",
        str(results),
        "--jobs",
        "2",
        "--epochs",
        str(epochs),
        *TINY_OWN,
        f"--train-args={TINY_TRAIN}",
    ]


def _env():
    return dict(os.environ, PYTHONPATH=str(ROOT))


def _rows(run: Path) -> list[dict]:
    with open(run / "progress.csv") as f:
        return [
            {k: v for k, v in r.items() if k != "wall_s"} for r in csv.DictReader(f)
        ]


def _start(cmd, cwd) -> subprocess.Popen:
    """A sweep in the background, its stdout and stderr together."""
    return subprocess.Popen(
        cmd,
        cwd=cwd,
        env=_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def _wait_for(pred, proc, timeout):
    t0 = time.monotonic()
    while not pred():
        assert proc.poll() is None, proc.stdout.read()
        assert time.monotonic() - t0 < timeout, "timed out"
        time.sleep(0.05)


def _epochs_done(run: Path) -> int:
    try:
        return len(_rows(run))
    except (OSError, KeyError):
        return 0


@pytest.mark.xdist_group(
    "ray"
)  # one local Ray at a time: a busy machine starts them slowly
def test_ray_grid_completes_then_skips(tmp_path):
    """Two cells on a local Ray: both done.json; the same command again skips both,
    starts no Ray."""
    results = tmp_path / "results"
    out = subprocess.run(
        _sweep_cmd(results, [0, 1], 2),
        cwd=tmp_path,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=400,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    for k in (0, 1):
        run = results / "FetchReach-v4" / "her" / f"seed{k}"
        assert (run / "done.json").exists() and len(_rows(run)) == 2
        assert f"finish FetchReach-v4/her/seed{k}: done" in out.stdout
        cmd = __import__("json").loads((run / "config.json").read_text())["command"]
        assert (
            cmd.startswith("python -m acder_lite train --env FetchReach-v4")
            and f"--out {run}" in cmd
        )
    again = subprocess.run(
        _sweep_cmd(results, [0, 1], 2),
        cwd=tmp_path,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert again.returncode == 0 and "nothing to run: 2 skipped" in again.stdout
    assert again.stdout.count("(already complete)") == 2


@pytest.mark.xdist_group(
    "ray"
)  # one local Ray at a time: a busy machine starts them slowly
def test_ray_retries_a_killed_worker_from_its_checkpoint(tmp_path):
    """Kill the worker training a cell (its pid is in train.log): Ray's retry resumes
    it, and the run ends with the same progress.csv as an uninterrupted run (but
    wall_s)."""
    results, epochs = tmp_path / "results", 6
    run = results / "FetchReach-v4" / "her" / "seed0"
    proc = _start(_sweep_cmd(results, [0], epochs), tmp_path)
    try:
        _wait_for(
            lambda: _epochs_done(run) >= 2 and (run / "checkpoint.pt").exists(),
            proc,
            300,
        )
        pid = int(
            (run / "train.log").read_text().split(" sweep: pid ", 1)[1].split(":", 1)[0]
        )
        os.kill(pid, signal.SIGKILL)
        out, _ = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, out
    assert "finish FetchReach-v4/her/seed0: done" in out and "(attempts 2)" in out
    starts = [
        line
        for line in (run / "train.log").read_text().splitlines()
        if " sweep: pid " in line
    ]
    assert len(starts) == 2 and "--out" in starts[0] and "--resume" in starts[1]

    ref = tmp_path / "ref"
    argv = "train --env FetchReach-v4 --method her --seed 0 --threads 1 --quiet".split()
    argv += ["--out", str(ref), "--epochs", str(epochs), *TINY.split()]
    assert (
        subprocess.run(
            [sys.executable, "-m", "acder_lite", *argv], env=_env(), timeout=300
        ).returncode
        == 0
    )
    assert _rows(run) == _rows(ref) and len(_rows(run)) == epochs


@pytest.mark.xdist_group(
    "ray"
)  # one local Ray at a time: a busy machine starts them slowly
def test_ray_ctrl_c_keeps_checkpoints_and_the_same_command_finishes(tmp_path):
    # Trap: a tiny epoch takes well under a second on an idle machine, and Ray's
    # cancel a few: with a short budget the cell finished before the interrupt reached
    # it (a fresh-clone CI run did so with 12 epochs), so the budget is long
    epochs = 80
    results = tmp_path / "results"
    run = results / "FetchReach-v4" / "her" / "seed0"
    cmd = _sweep_cmd(results, [0], epochs)
    proc = _start(cmd, tmp_path)
    try:
        _wait_for(lambda: (run / "checkpoint.pt").exists(), proc, 300)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, out
    assert (
        "interrupted: 0 finished, 1 stopped at its last checkpoint, 0 not started; "
        "re-run the same command to continue"
    ) in out
    assert (run / "checkpoint.pt").exists() and not (run / "done.json").exists()
    out = subprocess.run(
        cmd, cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=400
    )
    assert out.returncode == 0, out.stdout + out.stderr
    assert (
        "to resume" in out.stdout
        and "finish FetchReach-v4/her/seed0: done" in out.stdout
    )
    assert len(_rows(run)) == epochs


def _two_group_plan(path: Path, hold: str = "second") -> None:
    """Reach her seeds 0-1, then Reach her-per seed 0; `hold` names the group on hold
    ("first", "second", or "" for none). Tiny runs (for the real sweep below)."""
    config = (
        "workers = 1, cycles = 2, updates_per_cycle = 2, test_episodes = 1, "
        "batch_size = 16, hidden = 16, buffer_size = 5000, stop_patience = 0, "
        "epochs = 3"
    )
    group = '[[group]]\nenvs = ["FetchReach-v4"]\nmethods = ["{}"]\nseeds = {}\n{}\n'
    path.write_text(
        f"[defaults]\nconfig = {{ {config} }}\n\n"
        + group.format("her", "[0, 1]", 'hold = "waits"' if hold == "first" else "")
        + group.format("her-per", "[0]", 'hold = "waits"' if hold == "second" else "")
    )


def test_queue_hands_out_the_plan_order_a_few_at_a_time(tmp_path):
    cells = plan(["FetchReach-v4"], ["her"], [0, 1, 2], tmp_path)
    q = S.CellQueue(cells, 2)
    assert [c.seed for c in q.take(running=0)] == [0, 1]
    assert q.take(running=2) == []
    assert [c.seed for c in q.take(running=1)] == [2] and q.take(running=0) == []
    assert len(S.CellQueue(cells, None).take(running=5)) == 3  # a cluster: all at once
    assert q.reread() == ""  # no plan file: nothing to read again


def test_queue_reads_the_plan_again(tmp_path):
    """A hold deleted while the sweep runs puts its cells in their place in the plan;
    one added keeps its unstarted cells back; started cells are never handed out
    twice; a plan broken meanwhile leaves the queue as it was."""
    path = tmp_path / "plan.toml"
    _two_group_plan(path, hold="second")
    todo = [c for c in read_plan(path) if c.action != "skip"]
    q = S.CellQueue(todo, 1, lambda: read_plan(path))
    assert [c.name for c in q.take(running=0)] == ["FetchReach-v4/her/seed0"]
    assert q.reread() == ""
    _two_group_plan(path, hold="")
    assert q.reread() == (
        "plan read again: 1 cell now to run (FetchReach-v4/her-per/seed0)"
    )
    assert [c.name for c in q.waiting] == [
        "FetchReach-v4/her/seed1",
        "FetchReach-v4/her-per/seed0",
    ]
    _two_group_plan(path, hold="first")
    assert q.reread() == "plan read again: 1 cell no longer to run"
    assert [c.name for c in q.waiting] == ["FetchReach-v4/her-per/seed0"]
    path.write_text("[[group]\n")
    assert q.reread().startswith("plan not read again (plan ")
    assert [c.name for c in q.waiting] == ["FetchReach-v4/her-per/seed0"]
    touch(tmp_path / "FetchReach-v4" / "her-per" / "seed0", "done.json")
    _two_group_plan(path, hold="first")  # another sweep finished it meanwhile
    assert q.reread() == "plan read again: 1 cell no longer to run"
    assert q.waiting == []
    q = S.CellQueue([], 1, lambda: read_plan(path))  # her-per/seed0 is done
    _two_group_plan(path, hold="")
    assert q.reread() == (
        "plan read again: 2 cells now to run (FetchReach-v4/her/seed0, "
        "FetchReach-v4/her/seed1)"
    )


@pytest.mark.xdist_group(
    "ray"
)  # one local Ray at a time: a busy machine starts them slowly
def test_ray_sweep_starts_a_group_whose_hold_is_lifted_while_it_runs(tmp_path):
    """One cell at a time (--jobs 1); the second group is on hold when the sweep
    starts and its hold is deleted while the first cells train: the same sweep runs it
    too, after them, without a restart."""
    results = tmp_path / "results"
    results.mkdir()
    path = results / "plan.toml"
    _two_group_plan(path, hold="second")
    first = results / "FetchReach-v4" / "her" / "seed0"
    proc = _start(
        [sys.executable, "-m", "acder_lite", "sweep", "--plan", str(path)]
        + ["--jobs", "1"],
        tmp_path,
    )
    try:
        _wait_for(lambda: (first / "train.log").exists(), proc, 300)
        _two_group_plan(path, hold="")
        out, _ = proc.communicate(timeout=400)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, out
    assert "skip   FetchReach-v4/her-per/seed0 (on hold: waits)" in out
    assert "plan read again: 1 cell now to run (FetchReach-v4/her-per/seed0)" in out
    assert "sweep: 2 cells (0 to resume)" in out
    finished = [line.split(": ")[1] for line in out.splitlines() if "finish " in line]
    assert finished == [
        "finish FetchReach-v4/her/seed0",
        "finish FetchReach-v4/her/seed1",
        "finish FetchReach-v4/her-per/seed0",
    ]
    assert all(
        (results / "FetchReach-v4" / m / f"seed{k}" / "done.json").exists()
        for m, k in (("her", 0), ("her", 1), ("her-per", 0))
    )


def finished_run(d: Path, **fields) -> Path:
    """A finished run folder as train leaves it, its config resolved from `fields`."""
    from acder_lite.config import Config

    config = Config(**fields).resolve().to_dict()
    d.mkdir(parents=True, exist_ok=True)
    (d / "config.json").write_text(
        json.dumps(dict(config=config, command="python -m acder_lite ..."))
    )
    (d / "progress.csv").write_text("epoch,episodes,test_success\n1,400,0.5\n")
    (d / "policy.pt").write_bytes(b"\x00policy bytes\xff")
    (d / "done.json").write_text('{"epochs": 1}\n')
    return d


SAME_AS = """
[[group]]
envs = ["FetchPush-v4"]
methods = ["acder"]
seeds = [0, 1]
same_as = "../exp/FetchPush-v4/sicm-raw"
config = { update_dtype = "float32"%s }
"""


def reading_run(tmp_path) -> Path:
    """A finished ACDER run on Push, seed 0, in `exp/FetchPush-v4/sicm-raw/seed0`, and
    an empty `results/` beside it for the plan; returns the run's parent folder."""
    exp = tmp_path / "exp" / "FetchPush-v4" / "sicm-raw"
    finished_run(
        exp / "seed0",
        env="FetchPush-v4",
        method="acder",
        seed=0,
        update_dtype="float32",
    )
    (tmp_path / "results").mkdir()
    return exp


def test_same_as_copies_a_finished_run_with_the_cells_config(tmp_path, capsys):
    """A same_as cell whose run has finished with its config is copied, not trained
    (no Ray); one whose run has not finished waits; the same command again skips it."""
    exp = reading_run(tmp_path)
    touch(exp / "seed1", "config.json", "progress.csv", "checkpoint.pt")  # in flight
    plan_file = tmp_path / "results" / "plan.toml"
    plan_file.write_text(SAME_AS % "")
    cells = read_plan(plan_file)
    assert [(c.name, c.action) for c in cells] == [
        ("FetchPush-v4/acder/seed0", "copy"),
        ("FetchPush-v4/acder/seed1", "skip"),
    ]
    assert (
        cells[1].note.startswith("waits: its same_as run") and "seed1" in cells[1].note
    )
    assert S.run(parse(["--plan", str(plan_file)])) == 0
    out = capsys.readouterr().out
    assert "finish FetchPush-v4/acder/seed0: copied" in out
    assert "nothing to run: 1 copied, 1 skipped" in out
    run = tmp_path / "results" / "FetchPush-v4" / "acder" / "seed0"
    for name in ("progress.csv", "policy.pt", "done.json"):
        assert (run / name).read_bytes() == (exp / "seed0" / name).read_bytes()
    config = json.loads((run / "config.json").read_text())
    source = json.loads((exp / "seed0" / "config.json").read_text())
    assert (
        config["config"] == source["config"] and config["command"] == source["command"]
    )
    assert config["same_as"]["run"] == "../../../../exp/FetchPush-v4/sicm-raw/seed0"
    from acder_lite.book import findings
    from acder_lite.runs import read as runs

    copied = runs.read_run(run)
    assert copied["same_as"] == str(exp / "seed0") and copied["seed"] == 0
    assert findings.copied_runs([copied, runs.read_run(exp / "seed0")]) == {
        ("FetchPush-v4", "acder", str(exp)): [0]
    }
    assert findings.copied_runs([copied], root=tmp_path) == {
        ("FetchPush-v4", "acder", "exp/FetchPush-v4/sicm-raw"): [0]
    }
    assert "threads" in config["same_as"]["compared"]
    assert not list(run.glob(".*.tmp"))
    assert read_plan(plan_file)[0].note == "already complete"


@pytest.mark.parametrize(
    "extra, argv, msg",
    [
        (", eta = 0.5", [], "differs in eta: 0.8 there, 0.5 here"),
        ("", ["--epochs", "7"], "differs in epochs: 50 there, 7 here"),
        ("", ["--train-args=--cycles 2"], "cannot be checked against --train-args"),
    ],
)
def test_same_as_refuses_a_run_with_another_config(tmp_path, capsys, extra, argv, msg):
    """A same_as run whose config differs from the cell's, by the plan (exit 2, one
    line) or by the sweep's own options (the cell fails): nothing is copied."""
    reading_run(tmp_path)
    plan_file = tmp_path / "results" / "plan.toml"
    plan_file.write_text((SAME_AS % extra).replace("[0, 1]", "[0]"))
    rc = S.run(parse(["--plan", str(plan_file), *argv]))
    captured = capsys.readouterr()
    if extra:  # the plan itself is wrong
        assert rc == 2 and captured.err.count("\n") == 1 and msg in captured.err
        assert "group 1" in captured.err
    else:
        assert rc == 1 and msg in captured.out and "FAILED" in captured.out
    assert not (tmp_path / "results" / "FetchPush-v4").exists()


def test_same_as_threads_do_not_count(tmp_path):
    """Threads, the split update and parallel stepping leave the numbers as they are
    (tests/test_rollout.py): a run at --threads 2 is the cell's at --threads 1."""
    from acder_lite.runs import same_as
    from acder_lite.config import Config

    run = finished_run(
        tmp_path / "seed0",
        env="FetchReach-v4",
        method="her",
        seed=0,
        threads=2,
        step_threads=2,
    )
    cell = Config(env="FetchReach-v4", method="her", seed=0).resolve().to_dict()
    assert same_as.check(cell, run) == ("copy", "")
    other = Config(env="FetchReach-v4", method="her", seed=1).resolve().to_dict()
    assert same_as.check(other, run)[0] == "differs"
    (run / "policy.pt").unlink()
    assert same_as.check(cell, run) == (
        "differs",
        f"same_as run {str(run)!r} has no policy.pt",
    )


def test_same_as_needs_one_env_and_one_method(tmp_path, capsys):
    path = tmp_path / "plan.toml"
    path.write_text(
        "[[group]]\nenvs = ['FetchReach-v4', 'FetchPush-v4']\nmethods = ['her']\n"
        "seeds = [0]\nsame_as = 'x'\n"
    )
    assert S.run(parse(["--plan", str(path), "--dry-run"])) == 2
    err = capsys.readouterr().err
    assert "same_as needs exactly one env and one method, not 2 and 1" in err


def test_interrupted_line_counts_the_stopped_cells(tmp_path):
    """After Ctrl-C, the cells stopped are counted, at their last checkpoint or before
    their first (it said "0 finished, 0 not started" after stopping the one running)."""
    cells = plan(["FetchReach-v4"], ["her"], [0, 1, 2], tmp_path)
    for c in cells[:2]:
        touch(c.out, "progress.csv", "checkpoint.pt")
    counts = dict(done=1, failed=0, interrupted=3)
    assert S.interrupted_line(counts, cells[:1], 0) == (
        "interrupted: 1 finished, 1 stopped at its last checkpoint, 0 not started; "
        "re-run the same command to continue"
    )
    counts["failed"] = 1
    assert S.interrupted_line(counts, cells, 2) == (
        "interrupted: 1 finished, 2 stopped at their last checkpoints, 1 stopped "
        "before its first checkpoint (to start over), 1 failed, 2 not started; re-run "
        "the same command to continue"
    )


def test_a_finished_cell_with_other_settings_is_a_skip_that_says_so(tmp_path, capsys):
    """A finished cell trained with other settings than the sweep's stays a skip, its
    note naming the fields; the speed-only fields, and S-ICM's on a method without it
    (the committed HER runs on Push recorded sicm_input 'normalised', the default
    before the readings), are no difference."""
    results = tmp_path / "results"
    base = dict(env="FetchPush-v4", update_dtype="float32")
    finished_run(
        results / "FetchPush-v4/her/seed0", **base, method="her", seed=0, epochs=2
    )
    finished_run(
        results / "FetchPush-v4/her/seed1",
        **base,
        method="her",
        seed=1,
        threads=2,
        sicm_input="normalised",
    )
    finished_run(
        results / "FetchPush-v4/acder/seed0",
        **base,
        method="acder",
        seed=0,
        sicm_input="normalised",
    )
    finished_run(results / "FetchPush-v4/acder/seed1", **base, method="acder", seed=1)
    argv = [
        "--envs",
        "FetchPush-v4",
        "--methods",
        "her",
        "acder",
        "--seeds",
        "0",
        "1",
        "--results",
        str(results),
        "--train-args=--update-dtype float32",
    ]
    assert S.run(parse([*argv, "--dry-run"])) == 0
    notes = {
        line.split()[1]: "(" + line.split("  (", 1)[1]
        for line in capsys.readouterr().out.splitlines()
        if line.startswith("skip")
    }
    assert notes == {
        "FetchPush-v4/her/seed0": (
            "(already complete; its config differs: epochs 2 (this sweep: 50))"
        ),
        "FetchPush-v4/her/seed1": "(already complete)",
        "FetchPush-v4/acder/seed0": (
            "(already complete; its config differs: sicm_input 'normalised' "
            "(this sweep: 'raw'))"
        ),
        "FetchPush-v4/acder/seed1": "(already complete)",
    }
    assert S.run(parse(argv)) == 0  # the real run: the same skips, nothing trained
    out = capsys.readouterr().out
    assert (
        "skip   FetchPush-v4/her/seed0 (already complete; its config differs: "
        "epochs 2 (this sweep: 50))"
    ) in out
    assert "nothing to run: 4 skipped" in out
    assert S.run(parse([*argv, "--epochs", "2", "--dry-run"])) == 0
    out = capsys.readouterr().out
    assert "her/seed0" in out and "epochs 2 (this sweep: 2)" not in out
    assert "epochs 50 (this sweep: 2)" in out  # her/seed1's budget was 50


def test_a_groups_own_keys_win_over_the_defaults(tmp_path):
    """[defaults] fills in what a group leaves out: a group's own key wins (root, hold),
    and its `config` wins field by field over the defaults' (epochs), keeping the
    defaults' other fields (eta)."""
    path = tmp_path / "plan.toml"
    path.write_text(
        '[defaults]\nroot = "a"\nhold = "later"\nconfig = { epochs = 3, eta = 0.5 }\n'
        '[[group]]\nenvs = ["FetchPush-v4"]\nmethods = ["acder"]\nseeds = [0]\n'
        'root = "b"\nhold = ""\nconfig = { epochs = 7 }\n'
        '[[group]]\nenvs = ["FetchReach-v4"]\nmethods = ["her"]\nseeds = [0]\n'
    )
    first, second = read_plan(path)
    assert first.out == tmp_path / "b" / "FetchPush-v4" / "acder" / "seed0"
    assert first.options == {"epochs": 7, "eta": 0.5} and first.action == "run"
    assert second.out == tmp_path / "a" / "FetchReach-v4" / "her" / "seed0"
    assert second.options == {"epochs": 3, "eta": 0.5}
    assert (second.action, second.note) == ("skip", "on hold: later")


def test_differences_name_every_field_but_the_speed_only_ones():
    """`same_as.differences`: every field whose values differ, by name, a field one
    config lacks read as '<absent>' there, in either direction; the threads, the split
    update and the parallel stepping are speed only (NEUTRAL_FIELDS), the update's
    precision is not."""
    from acder_lite.runs import same_as
    from acder_lite.config import Config

    ours = Config(env="FetchPush-v4", method="her", seed=0).resolve().to_dict()
    theirs = dict(ours, threads=2, step_threads=2, split_update="x", seed=1)
    other = "bfloat16" if ours["update_dtype"] == "float32" else "float32"
    theirs.update(update_dtype=other, old_field=3)
    del theirs["reward_bonus"]
    assert same_as.differences(ours, theirs) == [
        ("old_field", 3, "<absent>"),
        ("reward_bonus", "<absent>", 0.0),
        ("seed", 1, 0),
        ("update_dtype", other, ours["update_dtype"]),
    ]
    assert same_as.differences(ours, dict(ours, threads=8)) == []


def test_train_args_checked_with_each_groups_config(tmp_path, capsys):
    """Two groups of one (env, method) pair with different configs: --train-args are
    checked with each group's config, not with the first one's only (sincos angles
    need sicm_input='raw', which the second group turns off)."""
    path = tmp_path / "plan.toml"
    group = "[[group]]\nenvs = ['FetchPush-v4']\nmethods = ['acder']\nseeds = [0]\n"
    second = "name = 'normalised'\nconfig = { sicm_input = 'normalised' }\n"
    path.write_text(group + group + second)
    assert S.run(parse(["--plan", str(path), *SINCOS])) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--train-args: sicm_angles='sincos'" in err
    assert err.rstrip().endswith("on the pair (FetchPush-v4, acder)")
    assert not (tmp_path / "FetchPush-v4").exists()
