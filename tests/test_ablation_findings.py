"""The sentences the book says about Fig. 5's ablations
(acder_lite.book.ablation_findings),
on synthetic cells: two equal seeds a cell make each 95% interval its crossing."""

from acder_lite.book import ablation_findings as AF
from acder_lite.stats import report as RE
from acder_lite.runs import table as T

from conftest import curve_cell, her_acder_cells

P = "FetchPush-v4"


def test_ablation_sentence_for_the_book():
    her, acder = her_acder_cells()  # 2.9 and 1.9 epochs
    # 3.9: slower than HER too
    slow = curve_cell("acder-no-curiosity", [0.0, 0.0, 0.5, 1.0])
    fast = curve_cell("acder-no-start-states", [1.0] * 4)  # 1.0: faster than full ACDER
    cells = [her, acder, slow, fast, RE.cell_stat(P, "acder-no-goal-factor", [])]
    s = AF.ablation_sentence(cells, P)
    assert (
        "ACDER w/o start states 400 < DDPG+ACDER 760 < DDPG+HER 1,160 < ACDER w/o "
        "curiosity 1,560" in s
    )
    assert "not run yet: ACDER w/o goal factor" in s
    assert "Crosses later than full ACDER (mean curves): ACDER w/o curiosity" in s
    assert "; no later: ACDER w/o start states" in s
    # two equal seeds: every interval is its point, so the rule separates each pair
    assert (
        "Separated from full ACDER by the rule below, later, as in the paper: ACDER "
        "w/o curiosity; earlier, unlike the paper: ACDER w/o start states." in s
    )
    assert "Crosses before DDPG+HER (mean curves): ACDER w/o start states." in s


def test_ablation_sentence_reads_cells_that_never_cross():
    """A complete cell without a crossing is later than every crossing: slower than a
    full ACDER that crosses; where ACDER does not cross either, the two are alike; one
    still training is left out."""
    her, acder = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("acder", [0.5, 1.0, 1.0, 1.0]),
    )
    never = curve_cell("acder-no-goal-factor", [0.0, 0.2, 0.5, 0.6])
    s = AF.ablation_sentence([her, acder, never], P)
    assert "Crosses later than full ACDER (mean curves): ACDER w/o goal factor." in s
    assert "Crosses before DDPG+HER (mean curves): none." in s
    acder_never = curve_cell("acder", [0.0, 0.1, 0.2, 0.3])
    fast = curve_cell("acder-no-curiosity", [1.0] * 4)
    s = AF.ablation_sentence([her, acder_never, never, fast], P)
    assert "No ablation crosses later than full ACDER (mean curves)" in s
    assert "; no later: ACDER w/o curiosity" in s
    assert "like full ACDER, not within the budget: ACDER w/o goal factor" in s
    never.planned = 3  # a seed still to come: not compared
    s = AF.ablation_sentence([her, acder, never], P)
    assert s.startswith("On Push the ablations cannot be compared yet")


def test_ablation_sentence_names_fewer_seeds_at_a_100_percent_threshold():
    """On Reach (100%) an ablation of 2 seeds against ACDER's 3 is named; on Push (95%)
    the sentence does not add it."""
    R = "FetchReach-v4"
    values = [0.5, 1.0, 1.0, 1.0]
    for env, named in ((R, True), (P, False)):
        acder = curve_cell("acder", values, env=env, seeds=3)
        abl = curve_cell("acder-no-curiosity", values, env=env, seeds=2)
        s = AF.ablation_sentence([acder, abl], env)
        assert (
            "ACDER w/o curiosity (2 seeds) against full ACDER's 3;" in s
        ) == named, s
        assert s.endswith(".") and not s.endswith("..")


def test_ablation_sentence_reads_acder_on_the_ablations_seeds():
    """Reach (100%): ACDER's seeds 0 and 1 reach 1.0 at epoch 2, its seed 2 at epoch 4,
    so its mean curve over 3 seeds crosses at 4 epochs, on seeds 0 and 1 alone at 2:
    the like-for-like reading beside an ablation of those 2 seeds."""
    R = "FetchReach-v4"

    def runs(name, curves):
        return [
            dict(
                env=R,
                name=name,
                method=name,
                seed=k,
                rows=[
                    dict(epoch=float(i), episodes=400.0 * i, test_success=v)
                    for i, v in enumerate(ys, 1)
                ],
                ended="budget",
                budget_epochs=float(len(ys)),
                episodes_per_epoch=400.0,
                update_dtype="float32",
            )
            for k, ys in enumerate(curves)
        ]

    fast, slow = [0.5, 1.0, 1.0, 1.0], [0.0, 0.5, 0.5, 1.0]
    acder_runs = runs("acder", [fast, fast, slow])
    abl_runs = runs("acder-no-curiosity", [fast, fast])
    acder = RE.cell_stat(R, "acder", acder_runs, n_boot=50)
    abl = RE.cell_stat(R, "acder-no-curiosity", abl_runs, n_boot=50)
    assert acder.crossing == 4.0 and abl.crossing == 2.0
    same = RE.cell_on_seeds(acder_runs, R, "acder", [0, 1])
    assert same.n == 2 and same.crossing == 2.0
    assert RE.cell_on_seeds(acder_runs, R, "acder", [0, 3]) is None  # no seed 3
    s = AF.ablation_sentence([acder, abl], R, acder_runs + abl_runs)
    assert (
        "so does full ACDER's mean curve on their seeds (0, 1) alone: "
        f"{T.mean_text(same)}." in s
    ), s
    assert "on their seeds" not in AF.ablation_sentence([acder, abl], R)


def test_separated_sentence_names_the_ablations_the_rule_separates():
    """Push: ACDER's seeds cross at 1.9 epochs, an ablation's at 3.9 (both seeds alike,
    so each interval is its crossing): separated; another equal to ACDER: not. A task
    whose ablations are not all finished is left out."""
    acder = curve_cell("acder", [0.5, 1.0, 1.0, 1.0])
    slow = curve_cell("acder-no-curiosity", [0.0, 0.0, 0.5, 1.0])
    same = curve_cell("acder-no-goal-factor", [0.5, 1.0, 1.0, 1.0])
    also = curve_cell("acder-no-start-states", [0.5, 1.0, 1.0, 1.0])
    s = AF.separated_sentence([acder, slow, same, also], tasks=(P,))
    assert s == "On Push: ACDER w/o curiosity.", s
    # another task whose ablations are still training is named as left out
    pp = "FetchPickAndPlace-v4"
    later = [curve_cell(c.name, [0.5, 1.0], env=pp) for c in (acder, slow, same, also)]
    later[1].planned = 3  # a seed still to come
    s = AF.separated_sentence([acder, slow, same, also] + later, tasks=(P, pp))
    assert s == (
        "On Push: ACDER w/o curiosity. Pick&Place is left out until the seeds of its "
        "ablations and of full ACDER have all ended."
    ), s
    also.planned = 3  # a seed still to come
    s = AF.separated_sentence([acder, slow, same, also], tasks=(P,))
    assert s == "No task has all its ablations finished yet."


def test_separated_sentence_says_one_side_is_tested_at_100_percent():
    R = "FetchReach-v4"
    cells = [curve_cell("acder", [0.5, 1.0, 1.0, 1.0], env=R)] + [
        curve_cell(n, [1.0] * 4, env=R) for n in RE.ABLATIONS
    ]
    s = AF.separated_sentence(cells, tasks=(R,))
    assert s.endswith(
        "On Reach the threshold is 100%, where an interval cannot extend to later "
        "crossings: a later crossing always lies outside the earlier one's interval, "
        "so only one side of the rule is tested."
    )


def test_ablation_sentence_reads_a_tie_with_full_acder_as_no_later():
    """An ablation whose mean curve crosses where full ACDER's does (1.9 epochs, 760
    episodes) is not later: it is named under "no later", not left unsaid."""
    acder = curve_cell("acder", [0.5, 1.0, 1.0, 1.0])
    tie = curve_cell("acder-no-curiosity", [0.5, 1.0, 1.0, 1.0])
    s = AF.ablation_sentence([acder, tie], P)
    assert (
        "No ablation crosses later than full ACDER (mean curves); no later: ACDER w/o "
        "curiosity." in s
    ), s


def test_ablation_sentence_a_tie_with_her_does_not_cross_before_it():
    """An ablation crossing where DDPG+HER does (2.9 epochs) does not cross before it;
    one at 1.9 does."""
    her, acder = her_acder_cells()
    tie = curve_cell("acder-no-curiosity", [0.0, 0.5, 1.0, 1.0])
    fast = curve_cell("acder-no-start-states", [0.5, 1.0, 1.0, 1.0])
    s = AF.ablation_sentence([her, acder, tie, fast], P)
    assert "Crosses before DDPG+HER (mean curves): ACDER w/o start states." in s, s
