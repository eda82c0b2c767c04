"""Table I from synthetic runs with known crossing points (no training)."""
import argparse
import csv
import json

import numpy as np
import pytest

from acder_lite import table as T


def make_run(root, env, method, seed, points, *, epochs=5, cycles=50, workers=4, config=True, done=False):
    """Write results/<env>/<method>/seed<k>/{progress.csv,config.json}; points = [(episodes, success)]."""
    d = root / env / method / f"seed{seed}"
    d.mkdir(parents=True)
    with open(d / "progress.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["epoch", "cycle", "episodes", "env_steps", "test_success", "wall_s"])
        for ep, s in points:
            cyc = ep / (2 * workers)
            w.writerow([cyc / cycles, int(cyc), ep, ep * 50, s, ep * 0.1])
    if config:
        cfg = dict(env=env, method=method, seed=seed, epochs=epochs, cycles=cycles,
                   episodes_per_cycle=2, workers=workers)
        (d / "config.json").write_text(json.dumps(dict(config=cfg, command="x", versions={})))
    if done:
        (d / "done.json").write_text("{}")
    return d


@pytest.fixture
def results(tmp_path):
    R = "FetchReach-v4"
    # her on Reach: seed 0 evaluated every 200 episodes, seed 1 every 40 (unequal grids), seed 2 never.
    make_run(tmp_path, R, "her", 0, [(200, 0.1), (400, 0.5), (600, 1.0), (800, 0.9), (1000, 1.0)])
    make_run(tmp_path, R, "her", 1, [(40 * i, min(1.0, 0.04 * i)) for i in range(1, 51)])  # 1.0 at i=25
    make_run(tmp_path, R, "her", 2, [(200 * i, 0.975) for i in range(1, 11)])
    make_run(tmp_path, R, "acder", 0, [(200, 0.9999999999), (400, 1.0)])  # float noise counts as 1.0
    make_run(tmp_path, R, "acder", 1, [(200, 0.5), (400, 1.0)])
    make_run(tmp_path, "FetchPush-v4", "her", 0, [(1000, 0.2), (2000, 0.5)])
    make_run(tmp_path, "FetchPush-v4", "acder", 0, [(500, 0.9), (1000, 0.96)], config=False)
    make_run(tmp_path, "FetchSlide-v4", "her", 0, [(400, 0.3)])  # no paper threshold
    return tmp_path


def test_episodes_to_threshold():
    rows = [dict(episodes=40.0, test_success=0.5), dict(episodes=80.0, test_success=0.95),
            dict(episodes=120.0, test_success=1.0)]
    assert T.episodes_to_threshold(rows, 0.95) == 80.0
    assert T.episodes_to_threshold(rows, 1.0) == 120.0
    assert T.episodes_to_threshold(rows[:2], 1.0) is None
    assert T.episodes_to_threshold([], 0.5) is None


def test_load_runs(results):
    runs = T.load_runs(results)
    assert len(runs) == 8
    by = {(r["env"], r["method"], r["seed"]): r for r in runs}
    assert by[("FetchReach-v4", "her", 1)]["budget"] == 5 * 50 * 2 * 4
    assert len(by[("FetchReach-v4", "her", 1)]["rows"]) == 50
    # without config.json: names from the path, budget from the last evaluation
    r = by[("FetchPush-v4", "acder", 0)]
    assert r["budget"] == 1000 and r["done"] is False


def test_planned_epochs():
    cfg = dict(epochs=18)
    train = "python -m acder_lite train --env FetchPush-v4 --method her --seed 1 --out R"
    ended = dict(command="python -m acder_lite train --resume R --epochs 18 --threads 1 --quiet")
    # ended at epoch 18 by a resume: the plan is the first command's --epochs
    assert T.planned_epochs(dict(config=cfg, command=train + " --epochs 50", resumes=[ended])) == 50
    assert T.planned_epochs(dict(config=cfg, command=train + " --epochs=40")) == 40
    # no --epochs anywhere: the config's value; no --epochs first but a resume changed it: the default
    assert T.planned_epochs(dict(config=cfg, command=train, resumes=[dict(command="x --threads 2")])) == 18
    assert T.planned_epochs(dict(config=cfg, command=train, resumes=[ended])) == 50
    # `--epochs-x` is another option, and a quoted argument is one token
    assert T.planned_epochs(dict(config=cfg, command=train + " --epochs-x 7 --out 'a --epochs 9'")) == 18


def test_load_runs_planned_epochs(results):
    d = results / "FetchReach-v4" / "her" / "seed0"
    whole = json.loads((d / "config.json").read_text())
    whole.update(command="train --epochs 25", resumes=[dict(command="train --resume R --epochs 3")])
    (d / "config.json").write_text(json.dumps(whole))
    by = {(r["env"], r["method"], r["seed"]): r for r in T.load_runs(results)}
    assert by[("FetchReach-v4", "her", 0)]["planned_epochs"] == 25
    assert by[("FetchReach-v4", "her", 1)]["planned_epochs"] == 5  # command "x": the config's epochs
    assert by[("FetchPush-v4", "acder", 0)]["planned_epochs"] is None  # no config.json


def test_summarize(results):
    s = {(r["method"], r["env"]): r for r in T.summarize(T.load_runs(results))}
    assert ("her", "FetchSlide-v4") not in s
    her = s[("her", "FetchReach-v4")]
    assert (her["n"], her["k"], her["threshold"]) == (3, 2, 1.0)
    assert her["episodes"] == [600.0, 1000.0, None]
    assert her["mean"] == pytest.approx(800.0)
    assert her["std"] == pytest.approx(np.std([600, 1000], ddof=1))
    assert her["budget"] == 2000 and her["paper"] == 2240
    acder = s[("acder", "FetchReach-v4")]
    assert acder["episodes"] == [200.0, 400.0] and acder["mean"] == 300.0 and acder["paper"] == 400
    push = s[("her", "FetchPush-v4")]
    assert push["k"] == 0 and push["mean"] is None and push["std"] is None and push["paper"] == 11600
    one = s[("acder", "FetchPush-v4")]
    assert (one["k"], one["mean"], one["std"]) == (1, 1000.0, 0.0)
    # rows in Table I's order
    assert [(r["method"], r["env"]) for r in T.summarize(T.load_runs(results))] == [
        ("her", "FetchReach-v4"), ("her", "FetchPush-v4"), ("acder", "FetchReach-v4"), ("acder", "FetchPush-v4")]


def test_paper_table():
    assert T.PAPER_TABLE_I["acder"] == {"FetchReach-v4": 400, "FetchPush-v4": 2200, "FetchPickAndPlace-v4": 5200}
    assert T.PAPER_TABLE_I["her-ebp"]["FetchReach-v4"] is None
    assert T.PAPER_THRESHOLDS == {"FetchReach-v4": 1.0, "FetchPush-v4": 0.95, "FetchPickAndPlace-v4": 0.95}


def test_to_markdown(results):
    md = T.to_markdown(T.summarize(T.load_runs(results)))
    assert "| DDPG+HER (`her`) | 800 ± 283 (2/3) · paper 2,240 | not reached in 2,000 (0/1) · paper 11,600 |" in md
    assert "| DDPG+ACDER (`acder`) | 300 ± 141 (2/2) · paper 400 | 1,000 (1/1) · paper 2,200 |" in md
    assert "| ours | ≥ 2.7 | > 2.0 |" in md          # HER missed on a seed / on every seed
    assert "| paper | 5.6 | 5.3 |" in md
    assert "Reach (100%)" in md and "Push (95%)" in md


def test_bfloat16_cells_say_so(tmp_path):
    # Table I is float32 unless a cell says otherwise: here 1 of 2 HER seeds and the ACDER seed
    P = "FetchPush-v4"
    for method, seed, dtype in [("her", 0, "bfloat16"), ("her", 1, None), ("acder", 0, "bfloat16")]:
        d = make_run(tmp_path, P, method, seed, [(400, 0.5), (800, 1.0)], epochs=2, done=True)
        if dtype:
            whole = json.loads((d / "config.json").read_text())
            whole["config"]["update_dtype"] = dtype
            (d / "config.json").write_text(json.dumps(whole))
    runs = T.load_runs(tmp_path)
    assert sorted(r["update_dtype"] for r in runs) == ["bfloat16", "bfloat16", "float32"]
    md = T.to_markdown(T.summarize(runs))
    assert "| DDPG+HER (`her`) | 800 ± 0 (2/2) · bfloat16 update in 1 of 2 seeds · paper 11,600 |" in md
    assert "| DDPG+ACDER (`acder`) | 800 (1/1) · bfloat16 update · paper 2,200 |" in md
    md = T.mean_curve_markdown(T.mean_curve_crossings(runs))
    assert "| DDPG+HER (`her`) | 800 (2 seeds, 1 in bfloat16) · paper 11,600 |" in md
    assert "| DDPG+ACDER (`acder`) | 800 (1 seed, bfloat16 update) · paper 2,200 |" in md
    # a mean curve that never gets there still says how it was computed
    never = [dict(r, rows=r["rows"][:1]) for r in runs if r["method"] == "acder"]
    md = T.mean_curve_markdown(T.mean_curve_crossings(never))
    assert "| DDPG+ACDER (`acder`) | never (bfloat16 update) · paper 2,200 |" in md


def test_mean_curve_of_runs_ended_after_their_crossing(tmp_path):
    # Each seed reached 95% once and was ended 3 epochs later (gap rule) at 0.9: the mean curve
    # (0.5 + 1.0) / 2, (1.0 + 0.85) / 2, then (0.9 + 0.9) / 2 never reaches 0.95 with both
    # seeds present, but that is the ending's doing, not "never" over a full budget.
    P = "FetchPush-v4"
    for seed, points in [(0, [(400, 0.5), (800, 1.0), (1200, 0.9)]), (1, [(400, 1.0), (800, 0.85), (1200, 0.9)])]:
        d = make_run(tmp_path, P, "her", seed, points, epochs=50)
        (d / "done.json").write_text(json.dumps(dict(epochs=3.0, stopped_early=True,
                                                     stop_reason="gap after first success")))
    make_run(tmp_path, P, "acder", 0, [(400, 0.5), (2000, 0.6)], epochs=5, done=True)  # full budget, never
    rows = {r["method"]: r for r in T.mean_curve_crossings(T.load_runs(tmp_path))}
    assert rows["her"]["episodes"] is None and rows["her"]["ended_short"] == 2
    assert rows["acder"]["ended_short"] == 0
    md = T.mean_curve_markdown(list(rows.values()))
    assert ("| DDPG+HER (`her`) | not before the runs ended (2 of 2 ended soon after their own first "
            "crossing) · paper 11,600 |") in md
    assert "| DDPG+ACDER (`acder`) | never · paper 2,200 |" in md


def test_learning_curves(tmp_path):
    make_run(tmp_path, "FetchReach-v4", "her", 0, [(0, 0.0), (100, 0.5), (200, 1.0)], epochs=1, cycles=25, workers=4)
    make_run(tmp_path, "FetchReach-v4", "her", 1, [(0, 0.0), (50, 0.2), (100, 0.3), (150, 0.4)],
             epochs=1, cycles=25, workers=4)
    # stopped early (done.json before the budget of 200): holds its last value up to the budget
    make_run(tmp_path, "FetchReach-v4", "acder", 0, [(0, 0.0), (100, 1.0)], epochs=1, cycles=25, workers=4,
             done=True)
    curves = T.learning_curves(T.load_runs(tmp_path))
    x, mean, std, n = curves[("FetchReach-v4", "her")]
    np.testing.assert_allclose(x, [0, 50, 100, 150, 200])
    np.testing.assert_allclose(n, [2, 2, 2, 2, 1])
    np.testing.assert_allclose(mean, [0.0, (0.25 + 0.2) / 2, 0.4, (0.75 + 0.4) / 2, 1.0])
    assert std[0] == 0 and std[2] == pytest.approx(0.1)
    x, mean, _, n = curves[("FetchReach-v4", "acder")]
    np.testing.assert_allclose(x, [0, 100, 200])
    np.testing.assert_allclose(mean, [0.0, 1.0, 1.0])


def _args(results, fmt="markdown"):
    return argparse.Namespace(results=str(results), format=fmt)


def test_cli(results, tmp_path, capsys):
    assert T.run(_args(results)) == 0
    assert "DDPG+ACDER" in capsys.readouterr().out
    assert T.run(_args(results, "json")) == 0
    assert json.loads(capsys.readouterr().out)[0]["method"] == "her"
    (tmp_path / "empty").mkdir()
    for bad in (tmp_path / "empty", tmp_path / "missing"):
        assert T.run(_args(bad)) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(bad) in err


def test_seed_crossings(results):
    runs = T.load_runs(results)
    md = T.seed_crossings(runs, "FetchReach-v4", ["her", "acder"], levels=(0.5, 1.0))
    lines = md.strip().splitlines()
    assert lines[0] == "| method | seed | 50% | 100% | evaluated to |"
    # her seeds in order, then acder; seed 1 reaches 0.5 at i=13 (0.52), 1.0 at i=25
    assert lines[2] == "| DDPG+HER | 0 | 400 | 600 | 1,000 (training) |"  # below its budget, no done.json
    assert lines[3] == "| DDPG+HER | 1 | 520 | 1,000 | 2,000 |"
    # seed 2 was evaluated up to its budget (5 epochs = 2,000 episodes) without reaching 1.0
    assert lines[4] == "| DDPG+HER | 2 | 200 | never | 2,000 |"
    assert lines[5].startswith("| DDPG+ACDER | 0 | 200 | 200 |")
    assert len(lines) == 2 + 5


def test_seed_crossings_running(tmp_path):
    make_run(tmp_path, "FetchPush-v4", "acder", 3, [(400, 0.6), (800, 0.7)], epochs=50)
    md = T.seed_crossings(T.load_runs(tmp_path), "FetchPush-v4", ["acder"])
    assert md.strip().splitlines()[-1] == "| DDPG+ACDER | 3 | 400 | not yet | not yet | 800 (training) |"


def test_mean_curve_crossings(tmp_path):
    P = "FetchPush-v4"
    # her: seed 0 at 0.9 then 1.0, seed 1 at 1.0 then 0.9 -> mean 0.95 at 80 and 120 (0.95), first at 80
    make_run(tmp_path, P, "her", 0, [(40, 0.0), (80, 0.9), (120, 1.0)], epochs=50)
    make_run(tmp_path, P, "her", 1, [(40, 0.5), (80, 1.0), (120, 0.9)], epochs=50)
    # acder: seed 0 ended (done.json) at 40 with 1.0, budget 1 epoch = 400 < seed 1's evaluations:
    # it holds 1.0 to the group's largest budget, so the mean is (1.0 + 0.9) / 2 = 0.95 at 800
    make_run(tmp_path, P, "acder", 0, [(40, 1.0)], epochs=1, done=True)
    make_run(tmp_path, P, "acder", 1, [(400, 0.5), (800, 0.9)], epochs=50)
    # her-per: one seed still training, below the threshold
    make_run(tmp_path, P, "her-per", 0, [(40, 0.3)], epochs=50)
    rows = T.mean_curve_crossings(T.load_runs(tmp_path))
    by = {r["method"]: r for r in rows}
    assert [r["method"] for r in rows] == ["her", "her-per", "acder"]
    assert by["her"]["episodes"] == 80 and by["her"]["n"] == 2 and by["her"]["paper"] == 11600
    assert by["acder"]["episodes"] == 800
    assert by["her-per"]["episodes"] is None and by["her-per"]["running"] == 1
    md = T.mean_curve_markdown(rows).splitlines()
    assert "| DDPG+HER (`her`) | 80 (2 seeds) · paper 11,600 |" in md
    assert "| DDPG+HER+PER (`her-per`) | not yet · paper 7,800 |" in md
    assert md[-1] == "| ours | 0.1 |"  # 80 / 800
    # a listed method without runs: "not run", or "–" where the paper has no number either (EBP, Reach)
    reach = dict(method="her", env="FetchReach-v4", threshold=1.0, n=1, episodes=40.0, running=0, paper=2240)
    md = T.mean_curve_markdown(rows + [reach], methods=["her", "her-ebp"]).splitlines()
    assert "| DDPG+HER+EBP (`her-ebp`) | – | not run · paper 7,200 |" in md


def test_how_ended(tmp_path):
    P = "FetchPush-v4"
    runs = {}
    for name, points, done in [
            ("early", [(400, 0.96)], dict(epochs=1.0, stopped_early=True)),
            ("budget", [(400, 0.5), (2000, 0.6)], dict(epochs=5.0, stopped_early=False)),
            ("hover", [(400, 0.96), (800, 0.9)], dict(epochs=2.0, stopped_early=False)),
            ("cut", [(400, 0.5), (800, 0.9)], dict(epochs=2.0, stopped_early=False)),
            ("training", [(400, 0.5)], None)]:
        d = make_run(tmp_path, P, name, 0, points, epochs=int(done["epochs"]) if done else 5)
        whole = json.loads((d / "config.json").read_text())
        whole["command"] = "python -m acder_lite train --epochs 5"  # planned 5; resumes may lower the config's
        (d / "config.json").write_text(json.dumps(whole))
        if done:
            (d / "done.json").write_text(json.dumps(dict(done, episodes=points[-1][0], wall_s=1.0)))
    for r in T.load_runs(tmp_path):
        runs[r["method"]] = T.how_ended(r)
    assert runs == {"early": "early stop", "budget": "full budget", "hover": "hovering",
                    "cut": "cut short", "training": None}
