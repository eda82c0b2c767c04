"""The time a sweep has left (`acder_lite.runs.grid_time`), on run folders with known
seconds an epoch and known stopping epochs."""

import csv
import json

import pytest

from acder_lite.runs import grid_time as G
from acder_lite.runs.plan import plan, run_dir
from acder_lite.cli.main import main
from acder_lite.config import Config

P, PP = "FetchPush-v4", "FetchPickAndPlace-v4"


def write_run(root, env, method, seed, epochs, wall, done=True, checkpoint=False):
    d = run_dir(root, env, method, seed)
    d.mkdir(parents=True)
    cfg = Config(env=env, method=method, seed=seed).resolve().to_dict()
    (d / "config.json").write_text(json.dumps(dict(config=cfg, command="")))
    with open(d / "progress.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["epoch", "cycle", "episodes", "env_steps", "test_success", "wall_s"]
        )
        for e in range(1, epochs + 1):
            w.writerow([e, e * 50, e * 400, e * 20000, 0.5, wall * e / epochs])
    if done:
        (d / "done.json").write_text(json.dumps(dict(epochs=epochs)))
    if checkpoint:
        (d / "checkpoint.pt").write_bytes(b"")  # only its presence is read here


@pytest.fixture
def grid(tmp_path):
    root = tmp_path / "results"
    write_run(root, P, "her", 0, 10, 1000)  # 100 s an epoch, ended at 10
    write_run(root, P, "her", 1, 20, 3000)  # 150 s an epoch, ended at 20
    write_run(root, P, "acder", 0, 30, 6000)  # 200 s an epoch, ended at 30
    write_run(root, P, "acder", 1, 10, 2000, done=False, checkpoint=True)
    return root


def test_the_estimate_adds_each_cells_epochs_left_at_its_timing(grid):
    cells = plan([P, PP], ["her", "acder", "her-icm"], [0, 1, 2], grid)
    est = G.estimate(cells)
    # her seed 2: 50 epochs at 125 s (budget), 15 (as finished); acder seed 1 from
    # epoch 10 and seed 2: at 200 s, to 50 or to 30; her-icm (no finished run of its
    # own): the task's 150 s, to its budget either way
    budget = 50 * 125 + 40 * 200 + 50 * 200 + 3 * 50 * 150
    finished = 15 * 125 + 20 * 200 + 30 * 200 + 3 * 50 * 150
    assert est["cells"] == 6
    assert est["budget_h"] == pytest.approx(budget / 3600)
    assert est["finished_h"] == pytest.approx(finished / 3600)
    assert est["untimed"] == {PP: 9}
    line = G.sentence(est, 2)
    assert "6 cells timed (of 15 to run)" in line
    assert f"{finished / 3600:.1f} cell-hours" in line
    assert f"{PP} (9 cells)" in line


def test_dry_run_ends_with_the_estimate(grid, capsys):
    argv = ["sweep", "--envs", P, "--methods", "her", "--seeds", "0", "1", "2"]
    assert main([*argv, "--results", str(grid), "--dry-run", "--jobs", "2"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("sweep: time left: 1 cell, 0.5 cell-hours")  # 15 x 125 s
    assert "2 at a time, 0.3-0.9 hours" in last and "not timed" not in last


def test_the_sweeps_budget_copies_holds_and_unreadable_rows(grid, capsys):
    """--epochs over the cells' budget; a copied run (`same_as`) is not timed twice; a
    held cell is named, not counted; a finished run without wall_s is passed over."""
    copy = run_dir(grid, P, "her", 3)
    copy.parent.mkdir(parents=True, exist_ok=True)
    write_run(grid, P, "her", 3, 40, 40 * 1000)  # 1000 s an epoch, if it were read
    whole = json.loads((copy / "config.json").read_text())
    whole["same_as"] = dict(run="../seed0")
    (copy / "config.json").write_text(json.dumps(whole))
    write_run(grid, P, "her", 4, 40, 0)  # wall_s 0: no timing
    cells = plan([P], ["her"], [0, 1, 2, 3, 4, 5], grid)
    cells[-1].action, cells[-1].hold = "skip", "waits"
    est = G.estimate(cells, {"epochs": 12})
    # her seed 2 alone: 12 epochs at 125 s, or 12 (its runs ended at 15 > 12)
    assert est["cells"] == 1 and est["held"] == 1
    assert est["budget_h"] == pytest.approx(12 * 125 / 3600) == est["finished_h"]
    assert "; on hold, not counted: 1 cell" in G.sentence(est, 1)


def on_cpus(root, env, method, seed, walls, cpus, resume_at=()):
    """A finished run whose epochs ended at the cumulative `walls`, trained first on
    cpus[0], then resumed on cpus[i] at epoch resume_at[i - 1] (as config.json says)."""
    write_run(root, env, method, seed, len(walls), 1.0)
    d = run_dir(root, env, method, seed)
    with open(d / "progress.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["epoch", "cycle", "episodes", "env_steps", "test_success", "wall_s"]
        )
        for e, wall in enumerate(walls, 1):
            w.writerow([e, e * 50, e * 400, e * 20000, 0.5, wall])
    whole = json.loads((d / "config.json").read_text())
    whole["versions"] = dict(cpu=cpus[0])
    whole["resumes"] = [
        dict(at_cycle=e * 50, versions=dict(cpu=c)) for e, c in zip(resume_at, cpus[1:])
    ]
    (d / "config.json").write_text(json.dumps(whole))
    return d


def test_epochs_from_other_cpus_are_scaled_to_this_one(tmp_path):
    """CPU B takes twice A's time an epoch: her 100 s on A and 200 s on B; acder 150 s
    for 4 epochs on A, then 300 s for 2 on B after a resume. C ran only her-icm, which
    nothing else ran: it cannot be tied to A or B and is left unscaled."""
    A, B, C = "Xeon; torch kernels: AVX512", "EPYC; torch kernels: AVX2", "C"
    root = tmp_path / "results"
    on_cpus(root, P, "her", 0, [100.0 * e for e in range(1, 5)], [A])
    on_cpus(root, P, "her", 1, [200.0 * e for e in range(1, 5)], [B])
    acder = on_cpus(root, P, "acder", 0, [150, 300, 450, 600, 900, 1200], [A, B], [4])
    on_cpus(root, P, "her-icm", 0, [50.0, 100.0], [C])
    assert G.stretches(acder) == [(A, 4.0, 600.0), (B, 2.0, 600.0)]
    samples = [(A, "her", 4, 400.0), (B, "her", 4, 800.0), (A, "a", 4, 600.0)]
    samples += [(B, "a", 2, 600.0), (C, "icm", 2, 100.0)]
    assert G.cpu_factors(samples, A) == pytest.approx({A: 1.0, B: 2.0})
    assert G.cpu_factors(samples, B) == pytest.approx({A: 0.5, B: 1.0})
    assert G.cpu_factors(samples, "a CPU with no runs") == {}

    cells = plan([P], ["her", "acder", "her-icm"], [0, 1], root)
    est = G.estimate(cells, here=B)
    # on B: acder 300 s an epoch (both stretches), her-icm 50 (C's, unscaled); each
    # seed 1 from epoch 0 to where its method's runs ended (her's seeds are both done)
    assert est["factors"] == pytest.approx({A: 0.5, B: 1.0}) and est["unscaled"] == [C]
    assert est["finished_h"] == pytest.approx((6 * 300 + 2 * 50) / 3600)
    est = G.estimate(plan([P], ["her"], [2], root) + cells, here=B)
    # her seed 2 on B: 200 s an epoch (seed 0's 100 on A doubled, seed 1's own 200)
    assert est["finished_h"] == pytest.approx((4 * 200 + 6 * 300 + 2 * 50) / 3600)
    line = G.sentence(est, 1)
    assert "scaled to this CPU, EPYC [AVX2] (an epoch took 0.50x as long on " in line
    assert "Xeon [AVX512])" in line and line.endswith(
        "(no task and method in common): C"
    )


def test_cells_not_timed_are_counted_not_zero(grid, tmp_path, capsys):
    """A dry run whose cells cannot be timed says how many there are (it said "1 to
    run", then "time left: 0 cells, 0.0 cell-hours"); beside timed ones, the timed
    count says it is part of the cells to run; with none to run, no hours at all."""
    empty = tmp_path / "empty"
    argv = ["sweep", "--envs", PP, "--methods", "her", "--seeds", "0"]
    assert main([*argv, "--results", str(empty), "--dry-run"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert "1 to run" in out[-2]
    assert out[-1] == (
        "sweep: time left: 1 cell to run, none timed yet (no finished run of its "
        f"task to time it by: {PP})"
    )
    cells = plan([PP, "FetchReach-v4"], ["her"], [0, 1], empty)
    cells[-1].action, cells[-1].hold = "skip", "waits"
    assert G.sentence(G.estimate(cells), 1) == (
        "time left: 3 cells to run, none timed yet (no finished run of their task to "
        f"time them by: {PP} (2 cells), FetchReach-v4 (1 cell)); on hold, not "
        "counted: 1 cell"
    )
    est = G.estimate(plan([P, PP], ["her"], [1, 2], grid))
    assert G.sentence(est, 1).startswith("time left: 1 cell timed (of 3 to run), ")
    assert G.sentence(G.estimate(plan([P], ["her"], [0, 1], grid)), 1) == (
        "time left: no cell to run or resume"
    )


def test_the_sweeps_options_win_over_a_cells_own(grid):
    """A cell whose plan group sets epochs = 30, swept with --epochs 12: timed to 12
    epochs, the budget its train command gets (the sweep's options over the cell's,
    `sweep.cell_options`), at her's median 125 s an epoch (seeds 0 and 1 finished)."""
    cells = plan([P], ["her"], [0, 1, 2], grid, options={"epochs": 30})
    assert G.estimate(cells)["budget_h"] == pytest.approx(30 * 125 / 3600)
    est = G.estimate(cells, {"epochs": 12})
    assert est["budget_h"] == pytest.approx(12 * 125 / 3600) == est["finished_h"]
