"""Table I's statistic (acder_lite.stats.report) on synthetic curves with
hand-computed answers."""

import math

import numpy as np
import pytest

from acder_lite.stats import report as R

from conftest import push_cell


def rows(values, first_epoch=1, per_epoch=400):
    """progress.csv rows of one evaluation per epoch."""
    return [
        dict(
            epoch=float(first_epoch + i),
            episodes=float((first_epoch + i) * per_epoch),
            test_success=float(v),
        )
        for i, v in enumerate(values)
    ]


def run(seed, values, ended, budget=10, per_epoch=400, name="her", env="FetchPush-v4"):
    """A run dict as runs.read_run makes it (only the keys report uses)."""
    return dict(
        env=env,
        name=name,
        method=name,
        seed=seed,
        rows=rows(values, per_epoch=per_epoch),
        ended=ended,
        budget_epochs=float(budget),
        episodes_per_epoch=float(per_epoch),
        update_dtype="float32",
    )


# Seed A held 95% at 5 evaluations (epochs 2-6) and stopped; it carries
# (4 x 0.95 + 1.0) / 5 = 0.96.
A = [0.5, 0.95, 0.95, 0.95, 0.95, 1.0]
# Seed B ran its 10-epoch budget.
B = [0.0, 0.1, 0.3, 0.5, 0.7, 0.8, 0.9, 0.98, 1.0, 1.0]


def test_first_crossing_interpolates():
    assert R.first_crossing([1, 2, 3], [0.5, 0.9, 1.0], 0.95) == pytest.approx(2.5)
    assert R.first_crossing([1, 2, 3], [0.5, 0.9, 1.0], 0.9) == pytest.approx(2.0)
    # at the first evaluation: no interpolation from before it
    # (there is no epoch-0 evaluation)
    assert R.first_crossing([1, 2], [0.97, 0.5], 0.95) == 1.0
    # a mean of ones that prints as 0.9999999999 reaches 1.0
    assert R.first_crossing([1, 2], [0.5, 0.9999999999], 1.0) == pytest.approx(2.0)
    # after a gap (NaN) the crossing is read at the point,
    # not interpolated across the gap
    assert R.first_crossing([1, 2, 3], [0.5, np.nan, 1.0], 0.95) == 3.0
    assert R.first_crossing([1, 2, 3], [0.5, 0.6, 0.94], 0.95) is None
    assert R.first_crossing([], [], 0.5) is None


def test_carry_forward():
    x, y, carried = R.carry_forward(np.arange(1.0, 7.0), A, budget=10)
    np.testing.assert_allclose(x, np.arange(1.0, 11.0))
    np.testing.assert_allclose(y[6:], [0.96] * 4)
    assert carried.tolist() == [False] * 6 + [True] * 4
    # protocol v1's spacing of 0.1 epoch: the carried points stay on that lattice,
    # then the budget
    x, _, carried = R.carry_forward([0.1, 0.2, 0.3], [1.0, 1.0, 1.0], budget=0.65)
    np.testing.assert_allclose(x, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.65])
    # a curve that reached its budget is left alone
    x, _, carried = R.carry_forward([1.0, 2.0], [0.1, 0.2], budget=2)
    assert len(x) == 2 and not carried.any()


def test_mean_curve_crossing_with_carry_forward():
    # mean at epoch 7: (0.96 + 0.9) / 2 = 0.93, at 8: (0.96 + 0.98) / 2 = 0.97
    # -> crossing at 7 + (0.95 - 0.93) / (0.97 - 0.93) = 7.5 epochs = 3,000 episodes
    # in Table I's unit
    c = R.cell_stat(
        "FetchPush-v4", "her", [run(0, A, "stop rule"), run(1, B, "budget")], n_boot=200
    )
    assert c.crossing == pytest.approx(7.5)
    assert c.paper_units(c.crossing) == pytest.approx(3000)
    assert (c.n, c.done, c.stopped, c.why, c.paper) == (2, 2, 1, "", 11600)
    # each seed's own crossing: A at epoch 2, B between 0.9 (7) and 0.98 (8):
    # 7 + 0.05 / 0.08
    assert c.seed_crossings == pytest.approx([2.0, 7.625])
    assert (c.seed_median, c.seed_low, c.seed_high, c.k) == pytest.approx(
        (4.8125, 2.0, 7.625, 2)
    )
    assert c.seed_mean == pytest.approx((2.0 + 7.625) / 2)
    m = R.mean_curve(
        [
            R.seed_curve(run(0, A, "stop rule")["rows"], "stop rule", 10),
            R.seed_curve(run(1, B, "budget")["rows"], "budget", 10),
        ]
    )
    assert (
        m.carried.tolist() == [False] * 6 + [True] * 4
    )  # Fig. 4 draws epochs 6-10 dotted
    np.testing.assert_allclose(m.mean[6:8], [0.93, 0.97])


def test_without_carry_forward_the_mean_curve_ends_with_the_seed():
    # the same seed A, but ended for another reason (protocol v1's gap rule): it has no
    # value after epoch 6, where the mean is still 0.875,
    # so the mean curve does not cross
    c = R.cell_stat(
        "FetchPush-v4", "her", [run(0, A, "cut"), run(1, B, "budget")], n_boot=200
    )
    assert c.crossing is None and c.why == "not before a seed's curve was cut"
    assert c.evaluated_epochs == 6.0
    c = R.cell_stat(
        "FetchPush-v4", "her", [run(0, A, None), run(1, B, "budget")], n_boot=200
    )
    assert c.crossing is None and c.why == "not yet" and c.unfinished == 1


def test_reach_reports_both_units():
    # FetchReach epochs of 10 cycles hold 80 episodes; Table I counts 400 an epoch
    c = R.cell_stat(
        "FetchReach-v4",
        "her",
        [run(0, [0.5, 1.0], "budget", budget=2, per_epoch=80, env="FetchReach-v4")],
        n_boot=50,
    )
    assert c.crossing == pytest.approx(2.0)
    assert (c.paper_units(c.crossing), c.our_episodes(c.crossing)) == (800, 160)
    assert c.threshold == 1.0


def test_a_curve_that_never_crosses():
    never = [0.05 * i for i in range(10)]  # 0.0 .. 0.45 over the whole budget
    c = R.cell_stat(
        "FetchPush-v4",
        "acder",
        [run(0, never, "budget"), run(1, B, "budget")],
        n_boot=300,
    )
    assert c.crossing is None and c.why == "not within budget"
    assert c.seed_crossings[0] is None and math.isinf(c.seed_high) and c.k == 1
    # resamples of seed 1 alone cross (1/4 of them), the others do not:
    # the interval ends beyond the budget
    assert 0.15 < c.share_crossing < 0.35 and math.isinf(c.high)
    d = c.to_dict()
    assert d["high"] is None and d["crossing_episodes_paper_units"] is None
    empty = R.cell_stat(
        "FetchPush-v4", "acder", [], planned=dict(seeds=5, hold="readings")
    )
    assert (empty.why, empty.planned, empty.hold, empty.n) == (
        "not run yet",
        5,
        "readings",
        0,
    )


def test_ratio_from_the_mean_curves():
    her = R.cell_stat(
        "FetchPush-v4", "her", [run(0, A, "stop rule"), run(1, B, "budget")], n_boot=300
    )  # 7.5
    acder = R.cell_stat(
        "FetchPush-v4",
        "acder",
        [run(0, [0.2, 0.6, 1.0], "budget", budget=3, name="acder")],
        n_boot=300,
    )  # 2 + 0.35 / 0.4 = 2.875
    r = R.ratio_stat(her, acder)
    assert r.ours == pytest.approx(7.5 / 2.875) and r.paper == pytest.approx(
        11600 / 2200
    )
    assert r.low <= r.ours <= r.high and r.share == 1.0
    never = R.cell_stat(
        "FetchPush-v4", "her", [run(0, [0.1] * 10, "budget")], n_boot=100
    )
    r = R.ratio_stat(never, acder)
    assert (
        r.ours is None
        and r.bound == pytest.approx(10 / 2.875)
        and r.why == "HER not within budget"
    )
    assert R.ratio_stat(None, acder).why == "HER not run yet"
    # HER's seeds train while ACDER has none: the reason names ACDER
    unrun = R.cell_stat("FetchPush-v4", "acder", [], planned=dict(seeds=3, hold=""))
    assert R.ratio_stat(her, unrun).why == "ACDER not run yet"


def test_bootstrap_is_deterministic_and_per_cell():
    curves = [
        R.seed_curve(rows(v), "budget", 10)
        for v in (B, [min(1, 0.15 * i) for i in range(10)])
    ]
    a = R.bootstrap_crossings(curves, 0.95, 500, seed=R.cell_seed("FetchPush-v4/her"))
    b = R.bootstrap_crossings(curves, 0.95, 500, seed=R.cell_seed("FetchPush-v4/her"))
    c = R.bootstrap_crossings(curves, 0.95, 500, seed=R.cell_seed("FetchPush-v4/acder"))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    # every resample lies between the two seeds' own crossings
    lo, hi = sorted(R.first_crossing(s.x, s.y, 0.95) for s in curves)
    assert lo - 1e-9 <= a.min() and a.max() <= hi + 1e-9


def test_interval_ranks_never_last():
    boot = np.array([1.0] * 90 + [np.inf] * 10)
    assert R.interval(boot) == (1.0, math.inf)
    boot = np.array([1.0] * 98 + [np.inf] * 2)
    assert R.interval(boot) == (1.0, 1.0)


def test_seed_summary():
    s = R.seed_summary([3.0, None, 1.0])
    assert (s["median"], s["low"], s["k"], s["n"]) == (3.0, 1.0, 2, 3) and math.isinf(
        s["high"]
    )
    assert math.isinf(R.seed_summary([None, None, 1.0])["median"])


def test_bootstrap_interval_coverage():
    # seeds' curves min(1, a t), a ~ U(0.04, 0.06): the true mean curve reaches 0.5 at
    # epoch 10
    # with 20 seeds the percentile interval covers about 93% (binomial s.e. over 300
    # reps: 1.5%):
    # far below 0.88 it would be too narrow, near 1 too wide to mean anything
    assert 0.88 <= R.bootstrap_coverage(20, 300) <= 0.985
    # with 3 seeds, as in part of our grid, it covers clearly less than 95%
    # (measured: about 75%);
    # the book says so beside the table
    assert 0.6 <= R.bootstrap_coverage(3, 300) <= 0.88


def test_learning_curves_and_grid():
    curves = R.learning_curves([run(0, A, "stop rule"), run(1, B, "budget")])
    m = curves[("FetchPush-v4", "her")]
    assert m.n == 2 and len(m.x) == 10 and m.carried[-1]
    cells = R.grid_cells()
    assert ("FetchReach-v4", "her-ebp") not in cells and (
        "FetchPush-v4",
        "her-ebp",
    ) in cells
    assert len(cells) == 3 * 8 - 1
    assert (
        R.threshold("FetchReach-v4") == 1.0
        and R.threshold("FetchPickAndPlace-v4") == 0.95
    )


def test_the_readings_rule_hand_worked():
    """Epochs: (a) crosses at 12.7 in [9.0, 12.9]; (b) at 14.8 in [9.7, 16.8]. (b) lies
    outside (a)'s interval, (a) inside (b)'s: not separated, the fallback wins."""
    a, b = push_cell("a", 12.7, 9.0, 12.9), push_cell("b", 14.8, 9.7, 16.8)
    assert R.separated(a, b) is False and R.choose(a, b, "b") == ("b", False)
    c = push_cell("c", 20.0, 18.0, math.inf)  # beyond the budget counts as an upper end
    assert R.separated(a, c) is True and R.separated(c, a) is True
    assert R.choose(c, a, "c") == ("a", True)  # separated: the earlier crossing
    assert R.separated(a, push_cell("d", None, None, None)) is None
    assert R.choose(a, push_cell("d", 14.0, None, None), "a") == (None, None)
    tie = push_cell("e", 12.7, 12.7, 12.7)  # equal crossings: never separated
    assert R.separated(push_cell("f", 12.7, 20.0, 30.0), tie) is False
    assert R.separated(a, push_cell("g", 14.0, math.inf, math.inf)) is None


def test_earliest_crossing_by_hand():
    """Three seeds planned, threshold 0.95: the mean can reach it only where every seed
    is at 1 - 3 x 0.05 = 0.85 or above."""
    done = R.seed_curve(rows(B), "budget", 10)  # B reaches 0.85 at epoch 6.5
    training = R.seed_curve(rows([0.1, 0.4, 0.7]), None, 10)  # below 0.85 up to 3
    assert R.earliest_crossing([done], 3, 0.95) == pytest.approx(6.5)
    assert R.earliest_crossing([training], 3, 0.95) == 3.0  # may reach it right after
    assert R.earliest_crossing([done, training], 3, 0.95) == pytest.approx(6.5)
    slow = R.seed_curve(rows([0.1] * 9 + [0.84]), None, 10)
    assert R.earliest_crossing([done, slow], 3, 0.95) == 10.0
    ended_low = R.seed_curve(rows([0.1, 0.84]), "budget", 2)
    assert R.earliest_crossing([done, ended_low], 3, 0.95) == math.inf
    # one seed planned: its own crossing; no evaluation yet: 0
    assert R.earliest_crossing([done], 1, 0.95) == pytest.approx(
        R.first_crossing(done.x, done.y, 0.95)
    )
    assert R.earliest_crossing([], 3, 0.95) == 0.0


def test_earliest_crossing_never_passes_the_crossing():
    """With every planned seed in, the bound lies at or before the mean curve's own
    crossing (the cell statistic records both)."""
    c = R.cell_stat(
        "FetchPush-v4", "her", [run(0, A, "stop rule"), run(1, B, "budget")]
    )
    assert c.crossing is not None and c.earliest <= c.crossing


def test_a_challenger_that_cannot_cross_first():
    raw = push_cell("sicm-raw", 14.8, 9.7, 16.75)
    raw.done, raw.planned = 3, 3
    goal = push_cell("sicm-raw-episode-goal", None, None, None)
    goal.earliest, goal.planned, goal.n, goal.done = 23.0, 3, 3, 1
    assert R.cannot_cross_first(goal, raw)
    # the rule's answer before the challenger's last seeds: the incumbent, by the bound
    assert R.choose(raw, goal, "sicm-raw") == ("sicm-raw", None)
    goal.earliest = 14.0  # its unfinished seeds could still make it cross first
    assert not R.cannot_cross_first(goal, raw)
    goal.earliest = 23.0
    raw.done, raw.unfinished = 2, 1  # the incumbent's crossing may still move
    assert not R.cannot_cross_first(goal, raw)


def test_the_rule_waits_for_every_planned_seed():
    """A cell with fewer seeds ended than planned (the committed seed of a cell still
    training) has a crossing and an interval, but not the rule's."""
    raw = push_cell("sicm-raw", 14.8, 9.7, 16.75)
    one = push_cell("sicm-raw-episode-goal", 20.8, 20.8, 20.8)
    assert R.separated(raw, one) is True  # as if complete
    one.planned, one.done, one.n = 3, 1, 1
    assert not R.complete(one)
    assert R.separated(raw, one) is None and R.choose(raw, one, "sicm-raw") == (
        None,
        None,
    )
    one.done = 3
    assert R.complete(one) and R.separated(raw, one) is True


def test_paper_epochs_and_reachs_whole_epochs():
    """Table I's Reach numbers in epochs of 400 (two are not whole, which a mean
    curve at a 100% threshold cannot give) and of Reach's own 80 (all whole)."""
    from acder_lite.stats.report import paper_epochs

    assert paper_epochs("FetchReach-v4") == pytest.approx(
        {"her": 5.6, "her-icm": 6.0, "her-per": 3.6, "acder": 1.0}
    )
    assert paper_epochs("FetchReach-v4", 80) == {
        "her": 28.0,
        "her-icm": 30.0,
        "her-per": 18.0,
        "acder": 5.0,
    }
    assert set(paper_epochs("FetchPush-v4")) == {
        "her",
        "her-icm",
        "her-per",
        "her-ebp",
        "acder",
    }


def test_seed_summary_mean_is_inf_when_a_seed_never_crossed():
    s = R.seed_summary([5.0, 6.0, 6.0, 5.0, 6.0])
    assert (s["median"], s["mean"]) == (6.0, pytest.approx(5.6))  # Reach's HER: 2,240
    s = R.seed_summary([5.0, None, 6.0])
    assert s["mean"] == math.inf and s["median"] == 6.0 and s["k"] == 2
    assert R.seed_summary([])["mean"] is None


def test_made_up_seed_carries_a_stopped_seed_to_the_budget_only():
    stopped = R.made_up_seed([0.1, 0.96, 1.0], "stop rule", budget=6)
    assert list(stopped.x) == [1, 2, 3, 4, 5, 6]
    assert list(stopped.carried) == [False] * 3 + [True] * 3
    full = R.made_up_seed([0.1, 0.96, 1.0], "budget", budget=6)
    assert list(full.x) == [1, 2, 3] and list(full.y) == [0.1, 0.96, 1.0]


def test_ratio_boot_ranks_each_pair_by_hand():
    """HER / ACDER per resample pair: 2 / 1 = 2; ACDER never crossing: 0 (ranked
    first); HER never crossing: inf (ranked last); neither: NaN (left out)."""
    h = np.array([2.0, 3.0, math.inf, math.inf])
    a = np.array([1.0, math.inf, 1.0, math.inf])
    np.testing.assert_array_equal(R.ratio_boot(h, a), [2.0, 0.0, math.inf, math.nan])


def test_a_cells_budget_is_its_longest_seeds():
    """Seed A (budget 8) stopped at epoch 6, seed B ran a budget of 10: the cell's
    budget is 10, and A is carried to it, so the mean curve reaches epoch 10."""
    c = R.cell_stat(
        "FetchPush-v4",
        "her",
        [run(0, A, "stop rule", budget=8), run(1, B, "budget", budget=10)],
        n_boot=50,
    )
    assert (c.budget_epochs, c.evaluated_epochs) == (10.0, 10.0)


def test_earliest_crossing_counts_the_planned_seeds():
    """Two seeds still training at 0.5, 0.8, 0.85 (epochs 1-3). Of 2 seeds the mean
    reaches 95% only with each at 1 - 2 x 0.05 = 0.9, not reached yet: not before
    epoch 3. Of the 5 planned, each must be at 1 - 5 x 0.05 = 0.75, which the seeds
    reach at 1 + 0.25 / 0.3 = 1.833 epochs."""
    runs = [run(s, [0.5, 0.8, 0.85], None) for s in (0, 1)]
    assert R.cell_stat("FetchPush-v4", "her", runs, n_boot=20).earliest == 3.0
    planned = R.cell_stat(
        "FetchPush-v4", "her", runs, planned=dict(seeds=5, hold=""), n_boot=20
    )
    assert planned.earliest == pytest.approx(1 + 0.25 / 0.3)


def test_a_crossing_at_the_end_of_the_others_interval_is_inside_it():
    """(b) crosses at 2.5, the upper end of (a)'s interval [1.5, 2.5]: inside it, so
    the two are not separated, though (a) lies outside (b)'s [2.5, 3.0]."""
    a, b = push_cell("a", 2.0, 1.5, 2.5), push_cell("b", 2.5, 2.5, 3.0)
    assert R.separated(a, b) is False and R.choose(a, b, "b") == ("b", False)
