"""What the runs show (acder_lite.book.findings), computed on synthetic cells: chapter 8
and "Results in detail" glue these values into hand-written sentences and assert each
claim. Two equal seeds a cell (`curve_cell`) make each 95% interval its crossing, so
every pair of cells with different crossings is separated."""

import math
from dataclasses import replace
from pathlib import Path

import pytest

from acder_lite.book import findings as F
from acder_lite.stats import report as RE

from conftest import curve_cell, her_acder_cells

P, R = "FetchPush-v4", "FetchReach-v4"


def _runs(name, values, env=P, seeds=2, ended="budget"):
    rows = [
        dict(epoch=float(i), episodes=400.0 * i, test_success=v)
        for i, v in enumerate(values, 1)
    ]
    return [
        dict(env=env, name=name, method=name, seed=s, rows=rows, ended=ended,
             budget_epochs=float(len(values)), episodes_per_epoch=400.0,
             update_dtype="float32")
        for s in range(seeds)
    ]  # fmt: skip


def test_finished_runs_leave_out_seeds_still_training():
    done = _runs("her", [0.5, 1.0])
    training = _runs("her", [0.5], ended=None)
    assert F.finished_runs(done + training) == done
    assert F.finished_runs(training) == []


def test_reached_places_a_cell_that_never_crossed_after_every_crossing():
    her, acder = her_acder_cells()  # 2.9 and 1.9 epochs
    assert F.reached(her) == pytest.approx(2.9) and F.reached(acder) == 1.9
    never = curve_cell("her", [0.0, 0.2, 0.5, 0.6])  # ended without a crossing
    assert never.why == "not within budget" and F.reached(never) == math.inf
    # one planned seed still to come: it may yet cross, so it is placed nowhere
    assert F.reached(replace(never, planned=3)) is None
    training = curve_cell("her", [0.0, 0.2], ended=None)
    assert F.reached(training) is None


def test_paper_place_compares_table_i_with_our_interval_in_its_unit():
    """ACDER on Push crosses at 1.9 epochs = 760 episodes; the paper's 2,200 lies
    above that (two equal seeds: the interval is the crossing itself)."""
    _, acder = her_acder_cells()
    assert acder.paper == 2200 and F.paper_place(acder) == "above"
    wide = replace(acder, low=5.0, high=6.0)  # 2,000 to 2,400 episodes
    assert F.paper_place(wide) == "inside"
    assert F.paper_place(replace(acder, low=5.5, high=8.0)) == "inside"  # an end
    assert F.paper_place(replace(acder, low=6.0, high=8.0)) == "below"
    assert F.paper_place(replace(acder, low=None, high=None)) is None
    assert F.paper_place(replace(acder, paper=None)) is None
    assert F.paper_place(replace(acder, low=2.0, high=math.inf)) == "inside"


def test_ratio_place_compares_the_papers_ratio_with_ours():
    her, acder = her_acder_cells()
    r = RE.ratio_stat(her, acder)
    assert r.ours == pytest.approx(2.9 / 1.9) and r.paper == pytest.approx(11600 / 2200)
    assert F.ratio_place(r) == "above"
    assert F.ratio_place(replace(r, low=1.0, high=r.paper)) == "inside"
    assert F.ratio_place(replace(r, low=6.0, high=9.0)) == "below"
    assert F.ratio_place(replace(r, low=float("nan"))) is None
    assert F.ratio_place(replace(r, paper=None)) is None


def test_crossed_before_lists_the_methods_ahead_of_acder_in_order():
    her, acder = her_acder_cells()  # 2.9, 1.9
    icm = curve_cell("her-icm", [1.0] * 4)  # 1.0
    per = curve_cell("her-per", [0.9, 1.0, 1.0, 1.0])  # 1 + 0.05 / 0.1 = 1.5
    never = curve_cell("her-ebp", [0.0, 0.1, 0.2, 0.3])
    cells = [her, icm, per, never, acder]
    assert F.crossed_before(cells, P) == ["her-icm", "her-per"]
    assert F.crossed_before(cells, P, "her") == ["her-icm", "her-per", "acder"]
    assert F.crossed_before(cells, P, "her-icm") == []
    assert F.crossed_before(cells, R) is None  # no cell on Reach
    # a baseline without a crossing and a seed still to come: it may yet cross first
    assert F.crossed_before([her, replace(never, planned=3), acder], P) is None
    # one with a crossing so far is placed by it
    assert F.crossed_before([her, replace(icm, planned=3), acder], P) == ["her-icm"]
    # a cell not among `among` is not compared
    assert F.crossed_before(cells, P, among=("her", "acder")) == []


def test_rule_against_reads_each_ablation_against_full_acder():
    her, acder = her_acder_cells()  # ACDER 1.9
    slow = curve_cell("acder-no-curiosity", [0.0, 0.0, 0.5, 1.0])  # 3.9
    same = curve_cell("acder-no-goal-factor", [0.5, 1.0, 1.0, 1.0])  # 1.9: a tie
    waiting = replace(curve_cell("acder-no-start-states", [1.0] * 4), planned=3)
    rule = F.rule_against([her, acder, slow, same, waiting], P)
    assert rule == {
        "acder-no-curiosity": True,
        "acder-no-goal-factor": False,  # equal crossings are never separated
        "acder-no-start-states": None,  # a seed to come: not yet
    }
    assert F.rule_against([her, acder, slow], P, reference="her") == {
        "acder-no-curiosity": True
    }


def test_below_after_crossing_counts_the_evaluations_under_the_threshold():
    """Crossing at 1.9 epochs, then below 95% at 2 of the 4 later evaluations; a curve
    that stays up has none below; a cell without a crossing has no answer."""
    runs = _runs("her-icm", [0.5, 1.0, 0.5, 0.5, 1.0]) + _runs(
        "acder", [0.5, 1.0, 1.0, 0.96, 1.0]
    )
    cells = {c.name: c for c in RE.summarize(runs, n_boot=50)}
    assert F.below_after_crossing(cells["her-icm"], runs) == (2, 4)
    assert F.below_after_crossing(cells["acder"], runs) == (0, 4)
    never = RE.summarize(_runs("her", [0.1, 0.2]), n_boot=20)[0]
    assert F.below_after_crossing(never, _runs("her", [0.1, 0.2])) is None


@pytest.mark.parametrize(
    "values, placed",
    [
        ([0.0, 0.0, 0.0, 0.5], "after slow"),  # never crosses: after HER's 2.9
        ([0.0, 0.0, 0.5, 1.0], "after slow"),  # 3.9
        ([1.0] * 4, "before fast"),  # 1.0, before ICM's 1.9
        ([0.0, 0.9, 1.0, 1.0], "between"),  # 2.5
        ([0.5, 1.0, 1.0, 1.0], "between"),  # ICM's own 1.9: the fast end
        ([0.0, 0.5, 1.0, 1.0], "between"),  # HER's own 2.9: the slow end
    ],
)
def test_seed_placement_places_the_constant_seed_by_seed(values, placed):
    her = curve_cell("her", [0.0, 0.5, 1.0, 1.0])  # 2.9
    icm = curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0])  # 1.9
    bonus = curve_cell("her-bonus", values)
    assert F.seed_placement(bonus, her, icm) == placed


def test_seed_placement_of_spread_seeds_and_of_seeds_still_to_come():
    her = curve_cell("her", [0.0, 0.5, 1.0, 1.0])
    icm = curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0])
    runs = _runs("her-bonus", [1.0] * 4, seeds=1) + [
        dict(r, seed=1) for r in _runs("her-bonus", [0.0, 0.0, 0.0, 1.0], seeds=1)
    ]
    spread = RE.cell_stat(P, "her-bonus", runs, n_boot=20)  # seeds at 1.0 and 3.95
    assert F.seed_placement(spread, her, icm) == "overlap"
    training = curve_cell("her-bonus", [1.0] * 4, ended=None)
    assert F.seed_placement(training, her, icm) is None
    planned = replace(curve_cell("her-bonus", [1.0] * 4), planned=3)
    assert F.seed_placement(planned, her, icm) is None
    assert F.seed_placement(her, replace(her, planned=5), icm) is None


def test_bonus_over_run_gives_each_seeds_low_start_and_its_end():
    rows = [
        dict(epoch=float(i), episodes=400.0 * i, test_success=0.0, r_int_mean=v)
        for i, v in enumerate([0.01, 0.002, 0.004, 0.1, 0.2, 0.3, 0.4], 1)
    ]
    run = dict(env=P, name="acder", seed=0, rows=rows)
    other = dict(run, seed=1, rows=[dict(r, r_int_mean=math.nan) for r in rows])
    no_column = dict(run, seed=2, rows=[{"epoch": 1.0}])
    got = F.bonus_over_run([run, other, no_column, dict(run, env=R)], P, "acder")
    assert got == [(0.002, pytest.approx((0.2 + 0.3 + 0.4 + 0.1 + 0.004) / 5))]
    assert F.bonus_over_run([run], P, "acder", first=1, last=2) == [
        (0.01, pytest.approx(0.35))
    ]
    assert F.bonus_over_run([run], P, "her") == []


def test_copied_runs_groups_the_seeds_by_their_source(tmp_path):
    source = tmp_path / "exp" / "FetchPush-v4" / "sicm-raw"
    runs = [
        dict(env=P, name="acder", seed=1, same_as=str(source / "seed1")),
        dict(env=P, name="acder", seed=0, same_as=str(source / "seed0")),
        dict(env=P, name="acder", seed=3, same_as=None),
        dict(env=P, name="her", seed=0),
    ]
    assert F.copied_runs(runs) == {(P, "acder", str(source)): [0, 1]}
    assert F.copied_runs(runs, root=tmp_path) == {
        (P, "acder", str(Path("exp/FetchPush-v4/sicm-raw"))): [0, 1]
    }
    assert F.copied_runs(runs, root=tmp_path / "elsewhere") == {
        (P, "acder", str(source)): [0, 1]
    }
    assert F.copied_runs(runs[2:]) == {}


def test_cell_on_seeds_reads_full_acder_like_for_like():
    """Reach (100%): ACDER's seeds 0 and 1 reach 1.0 at epoch 2, its seed 2 at epoch 4,
    so its mean curve over 3 seeds crosses at 4 epochs, on seeds 0 and 1 alone at 2:
    the reading beside an ablation of those 2 seeds (`report.cell_on_seeds`), which
    fewer seeds favour at a 100% threshold."""
    fast, slow = [0.5, 1.0, 1.0, 1.0], [0.0, 0.5, 0.5, 1.0]
    runs = [
        dict(r, seed=k)
        for k, ys in enumerate([fast, fast, slow])
        for r in _runs("acder", ys, env=R, seeds=1)
    ]
    assert RE.cell_stat(R, "acder", runs, n_boot=50).crossing == 4.0
    same = RE.cell_on_seeds(runs, R, "acder", [0, 1])
    assert same.n == 2 and same.crossing == 2.0
    assert RE.cell_on_seeds(runs, R, "acder", [0, 3]) is None  # no seed 3
