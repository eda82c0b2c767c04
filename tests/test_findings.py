"""The sentences the book says about Table I and Fig. 4 (acder_lite.book.findings), on
synthetic cells: two equal seeds a cell make each 95% interval its crossing."""

import numpy as np
import pytest

from acder_lite.book import findings as F
from acder_lite.stats import report as RE
from acder_lite.words import sentence

from conftest import curve_cell, her_acder_cells

P = "FetchPush-v4"


def test_sentences_for_the_book():
    her, acder = her_acder_cells()  # 2.9 and 1.9 epochs
    (r,) = RE.ratios([her, acder], tasks=(P,))
    assert r.ours == pytest.approx(2.9 / 1.9)
    v = F.verdict([r])
    assert (
        "above our 95% interval on Push (5.3 against our 1.5)" in v
        and "does not reproduce" in v
    )
    assert "cannot say yet" in F.verdict(RE.ratios([her], tasks=(P,)))
    # cells with planned seeds still to come: the verdict is provisional
    her.planned, acder.planned = 5, 5
    partial = F.verdict([r], [her, acder])
    counts = f"HER {her.done} of 5 seeds, ACDER {acder.done} of 5"
    assert partial.startswith(f"So far (Push: {counts}): the paper's")
    assert partial.endswith("Those cells are still training, so this can change.")
    her.planned, acder.planned = her.done, acder.done
    assert F.verdict([r], [her, acder]) == v
    assert sentence(["on Push a", "b"]) == "On Push a; b."


def test_grid_state_counts_the_three_tasks_cells_only():
    from acder_lite.stats.report import CellStat, grid_cells

    grid = grid_cells()
    cells = [
        CellStat(env=e, name=n, method=n, threshold=0.95, planned=3) for e, n in grid
    ]
    cells[0].done, cells[0].n = 2, 3
    cells[0].unfinished = 1
    cells[1].done, cells[1].n = 3, 3
    # outside Table I and Fig. 5: not counted
    cells.append(
        CellStat(env="FetchPushMultiStep-v0", name="her", method="her", threshold=0.95)
    )
    cells[-1].done, cells[-1].planned = 1, 1
    planned = 3 * len(grid)
    assert F.grid_state(cells) == (
        f"2 of the {len(grid)} cells of Table I and Fig. 5 (the three tasks) have at "
        f"least one finished seed; 5 of the {planned} planned seeds have finished, "
        "1 more is training or interrupted. Still to come: on Reach, DDPG+HER (1 seed "
        "unfinished), and DDPG+HER+PER, DDPG+ACDER, ACDER w/o curiosity, ACDER w/o "
        "goal factor and ACDER w/o start states (not started); on Push, DDPG+HER, "
        "DDPG+HER+ICM, DDPG+HER+PER, DDPG+HER+EBP, DDPG+ACDER, ACDER w/o curiosity, "
        "ACDER w/o goal factor and ACDER w/o start states (not started); on "
        "Pick&Place, DDPG+HER, DDPG+HER+ICM, DDPG+HER+PER, DDPG+HER+EBP, DDPG+ACDER, "
        "ACDER w/o curiosity, ACDER w/o goal factor and ACDER w/o start states (not "
        "started)."
    )
    for c in cells:  # every planned seed in and ended: nothing to come
        c.n = c.done = c.planned or c.done
        c.unfinished = 0
    assert "Still to come" not in F.grid_state(cells)
    assert F.grid_caveat(cells).startswith(
        "Every planned seed of the grid has finished"
    )
    cells[2].n, cells[2].done = 1, 1  # 1 of 3 in, 2 not started
    assert "Still to come: on Reach, DDPG+HER+PER (2 not started)." in F.grid_state(
        cells
    )
    assert F.grid_caveat(cells).startswith("A cell still to come says so in Table I")
    cells[2].n, cells[2].done, cells[2].unfinished = 3, 2, 1  # all in, one training
    assert F.grid_caveat(cells).startswith("A cell still to come")


def test_order_sentence_writes_ties_as_equal():
    """Equal crossings are a tie ('='), not an order ('<')."""
    a = curve_cell("acder", [0.5, 1.0, 1.0, 1.0])
    b = curve_cell("acder-no-curiosity", [0.5, 1.0, 1.0, 1.0])
    her = curve_cell("her", [0.0, 0.5, 1.0, 1.0])
    s = F.order_sentence([her, a, b])
    assert s == "DDPG+ACDER 760 = ACDER w/o curiosity 760 < DDPG+HER 1,160", s


def test_seed_ratio_and_beside_paper_sentences():
    her, acder = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("acder", [0.5, 1.0, 1.0, 1.0]),
    )
    (r,) = RE.ratios([her, acder], tasks=(P,))
    assert F.seed_ratio_sentence([r]) == "on Push 1.5 and 1.5, against the paper's 5.3"
    assert F.beside_paper_sentence([her, acder], tasks=(P,)) == (
        "On Push, DDPG+HER 1,160 against the paper's 11,600 (above our 95% interval, "
        "1,160 – 1,160) and DDPG+ACDER 760 against its 2,200 (above our 95% interval, "
        "760 – 760)."
    )
    # a cell whose seeds all ended without a crossing is said beside the paper's too
    never = curve_cell("acder", [0.0] * 4)
    assert F.beside_paper_sentence([her, never], tasks=(P,)) == (
        "On Push, DDPG+HER 1,160 against the paper's 11,600 (above our 95% interval, "
        "1,160 – 1,160) and DDPG+ACDER not within budget (4 epochs of the paper's 50) "
        "against its 2,200 "
        "(below our 95% interval, beyond budget)."
    )
    # one still training (no ended seed) is not: its crossing may still come
    training = curve_cell("acder", [0.0] * 4, ended=None)
    assert F.beside_paper_sentence([her, training], tasks=(P,)) == (
        "No task has both HER's and ACDER's mean curves crossed or ended yet."
    )


def test_a_ratio_bounded_below_is_said_as_a_bound():
    """Push: HER's two seeds end at 0.9 (no crossing within its 4 epochs), ACDER's cross
    at 1.9 epochs: the ratio is more than 4 / 1.9 = 2.1, which the paper's 5.3 exceeds.
    Reach beside it, read: HER at epoch 2, ACDER at 1, ratio 2.0 under the paper's 5.6.
    The verdict names the task it reads (not "every task with a ratio", which would
    take in Push) and says the bound apart; every HER resample is uncrossed, so the
    ratio's interval is [∞ – ∞]."""
    R = "FetchReach-v4"
    her = curve_cell("her", [0.0, 0.5, 0.9, 0.9])
    acder = curve_cell("acder", [0.5, 1.0, 1.0, 1.0])
    reach = [
        curve_cell("her", [0.5, 1.0, 1.0, 1.0], env=R),
        curve_cell("acder", [1.0] * 4, env=R),
    ]
    rs = RE.ratios([her, acder] + reach, tasks=(R, P))
    assert rs[1].ours is None and rs[1].bound == pytest.approx(4 / 1.9)
    assert F.ratio_sentence(rs[1]) == (
        "on Push DDPG+HER's mean curve does not reach 95% within its budget, so our "
        "HER/ACDER ratio is only bounded: more than 2.1 [∞ – ∞]; the paper's is 5.3"
    )
    assert F.ratio_sentence(rs[0]).startswith("on Reach our HER/ACDER ratio is 2.0")
    bound = (
        "On Push DDPG+HER's mean curve does not reach 95% within its budget, so our "
        "HER/ACDER ratio is bounded below by 2.1; the paper's 5.3 lies above "
        "that bound, and the runs cannot say whether ACDER's advantage there is as "
        "large as the paper's."
    )
    assert F.verdict(rs) == (
        "The paper's HER/ACDER ratio lies above our 95% interval on Reach (5.6 against "
        "our 2.0). On Reach, ACDER's advantage over HER is smaller here than in the "
        "paper: its factor of five does not reproduce there. " + bound
    )
    # the bound alone: said without "cannot say yet"
    assert F.verdict(rs[1:]) == bound
    # a bound above the paper's ratio: ACDER's advantage is larger here
    high = RE.RatioStat(P, None, bound=6.0, paper=5.3, why="HER not within budget")
    assert F.verdict([high]).endswith(
        "bounded below by 6.0, which is above the paper's 5.3: there ACDER's "
        "advantage over "
        "HER is larger here than in the paper."
    )
    # HER's cell with planned seeds to come: the bounded task makes it provisional
    her.planned = 5
    assert F.verdict(rs[1:], [her, acder]).startswith(
        "So far (Push: HER 2 of 5 seeds, ACDER 2 of 2): on Push DDPG+HER's"
    )


def test_range_text():
    assert F.range_text([5, 3, 5, 3]) == "3 to 5"
    assert F.range_text([3, 3]) == "3" and F.range_text([]) == "none"


def test_cut_texts_counts_runs_and_the_cells_a_cut_leaves_unread():
    """Protocol v1: 2 of 5 runs cut; one cell uncrossed because of a cut, one not yet,
    one read."""
    make = lambda n, cut, why: RE.CellStat(
        "FetchPush-v4", "x", "her", 0.95, n=n, cut=cut, why=why
    )
    cells = [make(2, 2, RE.CUT_WHY), make(2, 0, "not yet"), make(1, 0, "")]
    assert F.cut_texts(cells) == ("2 of its 5 runs", "1 of its 3 cells")
    assert F.cut_texts([make(1, 0, "")]) == ("0 of its 1 run", "0 of its 1 cell")


def test_paper_epochs_texts_reach_by_hand():
    """Table I's Reach: HER 2,240 = 5.6 epochs of 400 and PER 1,440 = 3.6 are not whole;
    ICM 2,400 = 6 and ACDER 400 = 1 are. In epochs of 80 episodes: 28, 30, 18, 5, of
    which 28 and 30 lie past a budget of 25."""
    t = F.paper_epochs_texts("FetchReach-v4", 80, 25)
    assert t["fractional"] == (
        "DDPG+HER 2,240 (5.6 epochs) and DDPG+HER+PER 1,440 (3.6 epochs)"
    )
    assert t["in_ours"] == "28, 30, 18 and 5"
    assert t["over"] == "2"
    push = F.paper_epochs_texts("FetchPush-v4", 400, 50)  # 29, 24.5, 19.5, 18, 5.5
    assert push["fractional"].startswith("DDPG+HER+ICM 9,800 (24.5 epochs), ")
    assert push["over"] == "0"
    assert (
        F.paper_epochs_texts("FetchPush-v4", 200, 50)["in_ours"]
        == "58, 49, 39, 36 and 11"
    )


def test_order_sentence_names_the_seeds_still_unfinished():
    training = curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0], ended=None)
    done = curve_cell("acder", [0.0, 0.5, 1.0, 1.0])
    assert F.order_sentence([training, done]) == (
        "DDPG+HER+ICM 760 (2 of 2 seeds unfinished) < DDPG+ACDER 1,160"
    )


def _runs(name, values, env=P):
    rows = [
        dict(epoch=float(i), episodes=400.0 * i, test_success=v)
        for i, v in enumerate(values, 1)
    ]
    return [
        dict(env=env, name=name, method=name, seed=s, rows=rows, ended="budget",
             budget_epochs=float(len(values)), episodes_per_epoch=400.0)
        for s in range(2)
    ]  # fmt: skip


def test_unheld_sentence_names_crossings_that_do_not_hold():
    """Crossing at 1.9 epochs, then below 95% at 2 of the 4 later evaluations (half:
    named); a curve that stays up is not."""
    runs = _runs("her-icm", [0.5, 1.0, 0.5, 0.5, 1.0]) + _runs(
        "acder", [0.5, 1.0, 1.0, 0.9, 1.0]
    )
    cells = RE.summarize(runs, n_boot=50)
    assert F.unheld_sentence(cells, runs) == (
        "DDPG+HER+ICM's mean curve on Push reaches 95% at epoch 1.9 and is below it "
        "at 2 of its 4 later evaluations."
    )
    assert F.unheld_sentence(cells, runs, share=0.6) == ""


def test_first_sentence_says_whether_acder_comes_first():
    her = curve_cell("her", [0.0, 0.5, 1.0, 1.0])
    acder = curve_cell("acder", [0.5, 1.0, 1.0, 1.0])
    unrun = RE.cell_stat(P, "her-per", [])
    assert (
        F.first_sentence([her, acder], tasks=(P,)) == "On Push DDPG+ACDER comes first."
    )
    icm = curve_cell("her-icm", [1.0] * 4)
    assert F.first_sentence([her, acder, icm, unrun], tasks=(P,)) == (
        "On Push DDPG+ACDER does not come first: DDPG+HER+ICM crosses earlier "
        "(separated by the rule), with DDPG+HER+PER not run yet."
    )
    icm.planned = 3  # a seed still to come: the rule is not applied
    assert "(the rule cannot be applied yet)" in F.first_sentence(
        [her, acder, icm], tasks=(P,)
    )


def test_verdict_at_a_100_percent_threshold_says_the_interval_is_capped():
    """Reach: HER's mean curve at 100% at epoch 2, ACDER's seeds at epoch 1: no HER
    resample crosses after 2, so no resample ratio exceeds 2 / 1 = 2.0, below the
    paper's 5.6."""
    R = "FetchReach-v4"
    cells = [
        curve_cell("her", [0.5, 1.0, 1.0, 1.0], env=R),
        curve_cell("acder", [1.0] * 4, env=R),
    ]
    rs = RE.ratios(cells, tasks=(R,))
    v = F.verdict(rs, cells, {2: 0.5})
    assert (
        "On Reach the threshold is 100%: no resample's mean curve crosses later than "
        "the cell's own, so the interval cannot extend to later crossings, and it "
        "could not contain a ratio above about 2.0 (DDPG+HER's crossing over "
        "DDPG+ACDER's fastest seed), below the paper's 5.6. The per-seed ratios (2.0 "
        "of the medians, 2.0 of the means) carry the verdict there as much as the "
        "interval; with 2 seeds such an interval covers about 50% of the time "
        "(measured on synthetic seeds by report.bootstrap_coverage), not 95%." in v
    )
    assert float(np.nanmax(RE.ratio_boot(cells[0].boot, cells[1].boot))) <= 2.0
    push = [curve_cell("her", [0.0, 0.5, 1.0, 1.0]), curve_cell("acder", [1.0] * 4)]
    assert "threshold is 100%" not in F.verdict(RE.ratios(push, tasks=(P,)), push)


def test_bound_sentence_names_the_seeds_and_their_own_crossings():
    """HER's mean curve never reaches 95% (its two seeds differ), but each seed does on
    its own: the bound is said on these seeds, with the median of HER's crossings."""
    runs = _runs("her", [0.0, 0.5, 1.0, 0.5]) + _runs("acder", [0.5, 1.0, 1.0, 1.0])
    runs[1]["rows"] = [dict(r, test_success=0.5) for r in runs[1]["rows"]]
    runs[1]["rows"][-1]["test_success"] = 1.0
    cells = RE.summarize(runs, n_boot=50)
    (r,) = RE.ratios(cells, tasks=(P,))
    assert r.bound is not None
    v = F.verdict([r], cells)
    assert "bounded below by 2.1 on these seeds (2 of DDPG+HER, 2 of DDPG+ACDER" in v
    assert "each DDPG+HER seed crossed on its own, at a median of 1,360 episodes" in v


def test_after_colon_lowers_an_ordinary_first_word_only():
    """The book pastes some sentences after a colon of its own ('... as in the paper:
    on Reach ...'): an ordinary first word goes lower case, a name stays."""
    assert F.after_colon("On Reach DDPG+ACDER comes first.") == (
        "on Reach DDPG+ACDER comes first."
    )
    assert F.after_colon("The mean curves cross.") == "the mean curves cross."
    assert F.after_colon("A resample.") == "a resample."
    for kept in (
        "DDPG+HER first.",
        "ACDER, S-ICM on raw.",
        "Reach first.",
        "Push.",
        "",
    ):
        assert F.after_colon(kept) == kept
    her, acder = curve_cell("her", [0.0, 0.5, 1.0, 1.0]), curve_cell("acder", [1.0] * 4)
    said = F.after_colon(F.first_sentence([her, acder], tasks=(P,)))
    assert said.startswith("on Push DDPG+ACDER comes first")


def test_verdict_counts_a_paper_ratio_at_the_intervals_end_as_inside():
    """The interval is closed: the paper's 5.3 at its upper end is inside it."""
    r = RE.RatioStat(P, 4.0, low=3.0, high=5.3, paper=5.3)
    assert F.verdict([r]) == (
        "The paper's HER/ACDER ratio lies inside our 95% interval on Push (5.3 "
        "against our 4.0). Our runs are consistent with the paper's factor on every "
        "task with a ratio."
    )


def test_a_bound_equal_to_the_papers_ratio_says_the_advantage_is_larger():
    """HER did not cross within its budget, so its crossing and the ratio lie above
    the bound: a bound of 5.3 against the paper's 5.3 already exceeds it."""
    r = RE.RatioStat(P, None, bound=5.3, paper=5.3, why="HER not within budget")
    assert F.verdict([r]).endswith(
        "bounded below by 5.3, which is above the paper's 5.3: there ACDER's "
        "advantage over HER is larger here than in the paper."
    )


def test_capped_sentence_divides_by_acders_fastest_seed():
    """Reach (100%): HER's two seeds at 100% from epoch 2 (crossing 2.0); ACDER's seed
    0 from epoch 1, seed 1 from epoch 2. The largest resample ratio is HER's 2.0 over
    ACDER's fastest seed's 1.0 = 2.0 (not over its slower seed's 2.0)."""
    R = "FetchReach-v4"
    runs = _runs("her", [0.5, 1.0, 1.0, 1.0], env=R)
    runs += _runs("acder", [1.0] * 4, env=R)
    runs[3]["rows"] = [dict(r, test_success=1.0) for r in runs[3]["rows"]]
    runs[3]["rows"][0]["test_success"] = 0.5
    cells = RE.summarize(runs, n_boot=50)
    v = F.verdict(RE.ratios(cells, tasks=(R,)), cells)
    assert "could not contain a ratio above about 2.0 (DDPG+HER's crossing" in v


def test_grid_state_counts_a_held_cell_only_while_seeds_are_missing():
    grid = RE.grid_cells()
    cells = [
        RE.CellStat(env=e, name=n, method=n, threshold=0.95, planned=3, n=3, done=3)
        for e, n in grid
    ]
    cells[0].hold = "the readings"  # every planned seed in: nothing held back
    assert "on hold" not in F.grid_state(cells)
    cells[0].n = cells[0].done = 1
    assert ", and 1 cell is on hold until the readings below are in." in (
        F.grid_state(cells)
    )


def test_first_sentence_names_a_method_crossing_with_acder():
    """DDPG+HER+ICM's mean curve crosses at ACDER's 1.9 epochs: ACDER is not first,
    and equal crossings are never separated."""
    her, acder = her_acder_cells()
    icm = curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0])
    assert F.first_sentence([her, acder, icm], tasks=(P,)) == (
        "On Push DDPG+ACDER does not come first: DDPG+HER+ICM crosses at the same "
        "point (not separated by the rule)."
    )


def test_still_training_without_a_plan_counts_the_seeds_read():
    """No plan file: HER has three seeds read, one still training. The verdict says
    "HER 2 of 3 seeds", not "2 of 2", which would call the cell complete."""
    runs = _runs("her", [0.0, 0.5, 1.0, 1.0]) + _runs("acder", [0.5, 1.0, 1.0, 1.0])
    runs.append({**runs[0], "seed": 2, "ended": None})
    cells = RE.summarize(runs, n_boot=50)
    text = F.verdict(RE.ratios(cells, tasks=(P,)), cells)
    assert text.startswith("So far (Push: HER 2 of 3 seeds, ACDER 2 of 2): ")
