"""The sentences the book says about the cells (acder_lite.findings), on synthetic
cells: two equal seeds a cell make each 95% interval its crossing."""

import math

import numpy as np
import pytest

from acder_lite import findings as F, report as RE, table as T

from conftest import curve_cell, push_cell

P = "FetchPush-v4"


def test_sentences_for_the_book():
    her, acder = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("acder", [0.5, 1.0, 1.0, 1.0]),
    )  # 2.9 and 1.9 epochs (2 + 0.45 / 0.5, 1 + 0.45 / 0.5)
    # 3.9: slower than HER too
    slow = curve_cell("acder-no-curiosity", [0.0, 0.0, 0.5, 1.0])
    fast = curve_cell("acder-no-start-states", [1.0] * 4)  # 1.0: faster than full ACDER
    cells = [her, acder, slow, fast, RE.cell_stat(P, "acder-no-goal-factor", [])]
    s = F.ablation_sentence(cells, P)
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
    assert F.sentence(["on Push a", "b"]) == "On Push a; b."


def test_choice_sentence_says_what_the_rule_made_of_the_runs():
    a, b = (
        push_cell("sicm-normalised", 12.5, 9.0, 13.0),
        push_cell("sicm-raw", 15.0, 10.0, 17.0),
    )
    text = F.choice_sentence(a, b, "sicm-raw", "the paper's eta values")
    assert (
        "5,000 inside 4,000 – 6,800" in text and "6,000 outside 3,600 – 5,200" in text
    )
    assert text.endswith(
        "falls back on the paper's eta values: ACDER, S-ICM on raw (o, g)."
    )
    text = F.choice_sentence(
        a, push_cell("sicm-raw", 20.0, 14.0, 22.0), "sicm-raw", "x"
    )
    assert text.endswith("and ACDER, S-ICM on normalised (o, g) crosses first.")
    late = push_cell("sicm-raw", 15.0, 10.0, math.inf)
    assert "outside 4,000 or later" not in F.choice_sentence(a, late, "sicm-raw", "x")
    assert "5,000 inside 4,000 or later" in F.choice_sentence(a, late, "sicm-raw", "x")
    assert "cannot be applied yet" in F.choice_sentence(
        a, push_cell("sicm-raw", None, None, None), "sicm-raw", "x"
    )


def test_readings_decisions_chain_the_two_rules():
    """(a) and (b) not separated (equal crossings never are): the paper's eta decides
    (b); then (b) against (c)."""
    norm = curve_cell("sicm-normalised", [0.4, 1.0, 1.0, 1.0])
    raw = curve_cell("sicm-raw", [0.4, 1.0, 1.0, 1.0])
    goal = curve_cell("sicm-raw-episode-goal", [0.0, 0.0, 0.5, 1.0])
    d = F.readings_decisions(norm, raw, goal)
    assert d["choice"] == F.choice_sentence(
        norm, raw, "sicm-raw", "the paper's eta values"
    )
    assert d["goal_choice"] == F.choice_sentence(
        raw, goal, "sicm-raw", "the default, a fresh goal"
    )
    assert d["decided"] == (RE.choose(raw, goal, "sicm-raw")[0] is not None)


def test_readings_decisions_when_normalised_crosses_first():
    """(a) separated from (b) and earlier: (a) wins the first rule and meets (c) in the
    second, (a)'s name the fallback there. Crossings by hand: (a) 1 + 0.95 = 1.95
    epochs = 780 episodes, (b) 3 + 0.45 / 0.5 = 3.9 = 1,560, (c) 3.95 = 1,580."""
    norm = curve_cell("sicm-normalised", [0.0, 1.0, 1.0, 1.0])
    raw = curve_cell("sicm-raw", [0.0, 0.0, 0.5, 1.0])
    goal = curve_cell("sicm-raw-episode-goal", [0.0, 0.0, 0.0, 1.0])
    d = F.readings_decisions(norm, raw, goal)
    assert d["choice"].startswith(
        "The mean curves cross at 780 episodes (ACDER, S-ICM on normalised (o, g)) "
        "and 1,560 (ACDER, S-ICM on raw (o, g));"
    )
    assert d["choice"].endswith(
        "the runs separate them, and ACDER, S-ICM on normalised (o, g) crosses first."
    )
    assert d["goal_choice"].startswith(
        "The mean curves cross at 780 episodes (ACDER, S-ICM on normalised (o, g)) "
        "and 1,580 (ACDER, S-ICM on raw (o, g), restarts keep the episode's goal);"
    )
    assert d["goal_choice"].endswith(
        "and ACDER, S-ICM on normalised (o, g) crosses first."
    )
    assert d["decided"] is True


def test_choice_sentence_once_the_challenger_cannot_cross_first():
    raw = push_cell("sicm-raw", 14.8, 9.7, 16.75)
    raw.done, raw.planned = 3, 3
    goal = push_cell("sicm-raw-episode-goal", None, None, None)
    goal.earliest, goal.planned, goal.n, goal.done = 23.0, 3, 3, 1
    text = F.choice_sentence(raw, goal, "sicm-raw", "the default (a fresh goal)")
    assert "cannot cross before 9,200 episodes" in text
    assert "every seed is at 85% or more" in text and "crossed at 5,920" in text
    assert text.endswith("and the rule keeps ACDER, S-ICM on raw (o, g).")
    # the fallback is the challenger's: no early answer (the rule would need the runs)
    assert "cannot be applied yet" in F.choice_sentence(goal, raw, "sicm-raw", "x")


def test_bonus_sentence_averages_each_seeds_last_evaluations():
    """Seed means over the last 2 rows, then over seeds: ICM (0.6 + 0.8) / 2 = 0.7 and
    (0.7 + 0.7) / 2 = 0.7 -> 0.70; ACDER 0.1 and 0.2 -> 0.15. A method without the
    column (her) is left out, and so is a task without curiosity runs."""

    def run(name, seed, values):
        rows = [dict(epoch=float(i), r_int_mean=v) for i, v in enumerate(values, 1)]
        return dict(env=P, name=name, seed=seed, rows=rows)

    runs = [
        run("her-icm", 0, [0.1, 0.6, 0.8]),
        run("her-icm", 1, [0.0, 0.7, 0.7]),
        run("acder", 0, [0.5, 0.1, 0.1]),
        run("acder", 1, [0.9, 0.2, 0.2]),
        dict(env=P, name="her", seed=0, rows=[dict(epoch=1.0)]),
    ]
    text = F.bonus_sentence(runs, ["FetchReach-v4", P], last=2)
    assert text == (
        "On Push (clip η = 0.8): DDPG+HER+ICM 0.7 (87% of η), "
        "DDPG+ACDER 0.15 (19% of η)."
    )
    # a seed not ended yet (ended None): the value is said to be so far
    runs[0]["ended"], runs[1]["ended"] = None, "budget"
    text = F.bonus_sentence(runs, [P], last=2)
    assert "DDPG+HER+ICM 0.7 (87% of η) so far (1 of its 2 seeds unfinished)," in text
    runs[0]["ended"] = "stop rule"
    assert "so far" not in F.bonus_sentence(runs, [P], last=2)
    assert F.bonus_sentence([], [P]) == "No curiosity method has an evaluation yet."
    # every evaluation (last=None): seeds (0.1 + 0.6 + 0.8) / 3 = 0.5 and 0.7 / 3 * 2
    want = (0.5 + 1.4 / 3) / 2
    assert RE.column_tail(runs, P, "her-icm", "r_int_mean", None) == pytest.approx(want)


def test_grid_state_counts_the_three_tasks_cells_only():
    from acder_lite.report import CellStat, grid_cells

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
    cells[2].n, cells[2].done = 1, 1  # 1 of 3 in, 2 not started
    assert "Still to come: on Reach, DDPG+HER+PER (2 not started)." in F.grid_state(
        cells
    )


def test_control_sentence_by_hand():
    """HER crosses at 2.9 epochs, ICM at 1.9 (as above); a constant bonus at 0.9 by
    epoch 2 crosses at 2 + 0.05 / 0.1 = 2.5: 0.4 of ICM's 1.0 epoch saved, 160 of 400
    episodes, 40%. Two equal seeds: every interval is its point."""
    her, icm = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0]),
    )
    bonus = curve_cell("her-bonus", [0.0, 0.9, 1.0, 1.0])
    s = F.control_sentence(her, icm, bonus)
    assert (
        "DDPG+HER+ICM 760 < DDPG+HER with a constant bonus 1,000 < DDPG+HER 1,160" in s
    )
    assert (
        "Of DDPG+HER+ICM's 400 episodes saved over DDPG+HER, the constant alone " in s
    )
    assert "saves 160: 40%." in s
    assert "outside DDPG+HER's 95% interval and outside DDPG+HER+ICM's." in s
    same = curve_cell("her-bonus", [0.5, 1.0, 1.0, 1.0])
    s = F.control_sentence(her, icm, same)
    assert "saves 400: 100%." in s and "inside DDPG+HER+ICM's." in s
    s = F.control_sentence(her, icm, RE.cell_stat(P, "her-bonus", []))
    assert "not run yet: DDPG+HER with a constant bonus" in s
    assert "can be compared once each mean curve has crossed" in s
    s = F.control_sentence(
        icm, her, bonus
    )  # "ICM" slower than "HER": nothing to explain
    assert "no gain of curiosity for the constant to explain" in s


def test_sincos_sentence_applies_the_rule_only_to_complete_cells():
    """Two equal seeds make each interval its point: ACDER crossing at 2.9 epochs
    (1,160 episodes) and the (sin, cos) variant at 1.9 (760) are separated; equal
    curves are not; a cell with seeds still to come is not read."""
    acder = curve_cell("acder", [0.0, 0.5, 1.0, 1.0])
    sincos = curve_cell("acder-sincos", [0.5, 1.0, 1.0, 1.0])
    s = F.sincos_sentence(acder, sincos)
    assert s.startswith(
        "Ordered by the mean curve: ACDER, S-ICM on (sin, cos) of the angles 760 < "
        "DDPG+ACDER 1,160."
    )
    assert s.endswith(
        "The runs separate them: ACDER, S-ICM on (sin, cos) of the angles "
        "crosses first."
    )
    same = curve_cell("acder-sincos", [0.0, 0.5, 1.0, 1.0])
    assert "do not separate them" in F.sincos_sentence(acder, same)
    sincos.planned = 3  # 2 of 3 seeds in: not the rule's yet
    s = F.sincos_sentence(acder, sincos)
    assert "applied once both cells have all their planned seeds" in s
    assert "(2 of 3 seeds of ACDER, S-ICM on (sin, cos) of the angles finished)" in s
    s = F.sincos_sentence(acder, RE.cell_stat(P, "acder-sincos", []))
    assert "not run yet: ACDER, S-ICM on (sin, cos) of the angles" in s


def test_control_sentence_when_the_constant_never_crosses():
    """A complete control cell whose mean curve stays below 95% for its whole budget
    saves none of ICM's episodes; beyond both points, the pre-registered rule leaves it
    open; where HER's interval reaches past the budget, inside HER's and beyond ICM's,
    the gain is ICM's own."""
    import math

    her, icm = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0]),
    )
    never = curve_cell("her-bonus", [0.0, 0.2, 0.5, 0.6])
    assert never.why == "not within budget"
    s = F.control_sentence(her, icm, never)
    assert "saves none of the 400 episodes DDPG+HER+ICM saves over DDPG+HER." in s
    assert (
        "beyond DDPG+HER's 95% interval and beyond DDPG+HER+ICM's 95% interval. "
        "Every seed of the constant crosses later than every seed of DDPG+HER or not "
        "within its budget (the constant's seeds 2 not within budget; DDPG+HER's at "
        "1,160 and 1,160 episodes), so the constant slowed it; the rule, written "
        "before the runs, named no outcome for this case." in s
    )
    her.high = math.inf
    s = F.control_sentence(her, icm, never)
    assert "the shift does not explain ICM's gain, which is its own. Every seed" in s
    never.planned = 3  # a seed still to come: not read yet
    s = F.control_sentence(her, icm, never)
    assert s.endswith("can be compared once each mean curve has crossed.")


def test_sincos_sentence_when_the_variant_never_crosses():
    """Beyond the budget lies outside ACDER's point interval, and ACDER's crossing
    before any crossing of the variant's resamples: separated, ACDER first."""
    acder = curve_cell("acder", [0.0, 0.5, 1.0, 1.0])
    never = curve_cell("acder-sincos", [0.0, 0.2, 0.5, 0.6])
    s = F.sincos_sentence(acder, never)
    assert "does not reach 95% within its budget" in s
    assert s.endswith("the runs separate them: DDPG+ACDER crosses first.")
    acder.high = float("inf")  # ACDER's own interval reaches past the budget
    assert "the runs do not separate them" in F.sincos_sentence(acder, never)


def test_ablation_sentence_reads_cells_that_never_cross():
    """A complete cell without a crossing is later than every crossing: slower than a
    full ACDER that crosses; where ACDER does not cross either, the two are alike; one
    still training is left out."""
    her, acder = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("acder", [0.5, 1.0, 1.0, 1.0]),
    )
    never = curve_cell("acder-no-goal-factor", [0.0, 0.2, 0.5, 0.6])
    s = F.ablation_sentence([her, acder, never], P)
    assert "Crosses later than full ACDER (mean curves): ACDER w/o goal factor." in s
    assert "Crosses before DDPG+HER (mean curves): none." in s
    acder_never = curve_cell("acder", [0.0, 0.1, 0.2, 0.3])
    fast = curve_cell("acder-no-curiosity", [1.0] * 4)
    s = F.ablation_sentence([her, acder_never, never, fast], P)
    assert "No ablation crosses later than full ACDER (mean curves)" in s
    assert "; no later: ACDER w/o curiosity" in s
    assert "like full ACDER, not within the budget: ACDER w/o goal factor" in s
    never.planned = 3  # a seed still to come: not compared
    s = F.ablation_sentence([her, acder, never], P)
    assert s.startswith("On Push the ablations cannot be compared yet")


def test_ablation_sentence_names_fewer_seeds_at_a_100_percent_threshold():
    """On Reach (100%) an ablation of 2 seeds against ACDER's 3 is named; on Push (95%)
    the sentence does not add it."""
    R = "FetchReach-v4"
    values = [0.5, 1.0, 1.0, 1.0]
    for env, named in ((R, True), (P, False)):
        acder = curve_cell("acder", values, env=env, seeds=3)
        abl = curve_cell("acder-no-curiosity", values, env=env, seeds=2)
        s = F.ablation_sentence([acder, abl], env)
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
    s = F.ablation_sentence([acder, abl], R, acder_runs + abl_runs)
    assert (
        "so does full ACDER's mean curve on their seeds (0, 1) alone: "
        f"{T.mean_text(same)}." in s
    ), s
    assert "on their seeds" not in F.ablation_sentence([acder, abl], R)


def test_order_sentence_writes_ties_as_equal():
    """Equal crossings are a tie ('='), not an order ('<')."""
    a = curve_cell("acder", [0.5, 1.0, 1.0, 1.0])
    b = curve_cell("acder-no-curiosity", [0.5, 1.0, 1.0, 1.0])
    her = curve_cell("her", [0.0, 0.5, 1.0, 1.0])
    s = F.order_sentence([her, a, b])
    assert s == "DDPG+ACDER 760 = ACDER w/o curiosity 760 < DDPG+HER 1,160", s


def test_separated_sentence_names_the_ablations_the_rule_separates():
    """Push: ACDER's seeds cross at 1.9 epochs, an ablation's at 3.9 (both seeds alike,
    so each interval is its crossing): separated; another equal to ACDER: not. A task
    whose ablations are not all finished is left out."""
    acder = curve_cell("acder", [0.5, 1.0, 1.0, 1.0])
    slow = curve_cell("acder-no-curiosity", [0.0, 0.0, 0.5, 1.0])
    same = curve_cell("acder-no-goal-factor", [0.5, 1.0, 1.0, 1.0])
    also = curve_cell("acder-no-start-states", [0.5, 1.0, 1.0, 1.0])
    s = F.separated_sentence([acder, slow, same, also], tasks=(P,))
    assert s == "On Push: ACDER w/o curiosity.", s
    # another task whose ablations are still training is named as left out
    pp = "FetchPickAndPlace-v4"
    later = [curve_cell(c.name, [0.5, 1.0], env=pp) for c in (acder, slow, same, also)]
    later[1].planned = 3  # a seed still to come
    s = F.separated_sentence([acder, slow, same, also] + later, tasks=(P, pp))
    assert s == (
        "On Push: ACDER w/o curiosity. Pick&Place is left out until the seeds of its "
        "ablations and of full ACDER have all ended."
    ), s
    also.planned = 3  # a seed still to come
    s = F.separated_sentence([acder, slow, same, also], tasks=(P,))
    assert s == "No task has all its ablations finished yet."


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
        "(above), not 95%." in v
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


def test_control_found_places_the_constant_seed_by_seed():
    her, icm = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0]),
    )
    between = curve_cell("her-bonus", [0.0, 0.9, 1.0, 1.0])
    assert F.control_found(her, icm, between).startswith(
        "The constant's seeds lie between the fastest seed of DDPG+HER+ICM and the "
        "slowest of DDPG+HER (the constant's seeds at 1,000 and 1,000 episodes;"
    )
    fast = curve_cell("her-bonus", [1.0] * 4)
    assert F.control_found(her, icm, fast).startswith(
        "Every seed of the constant crosses earlier than every seed of DDPG+HER+ICM"
    )
    training = curve_cell("her-bonus", [1.0] * 4, ended=None)
    assert F.control_found(her, icm, training) == ""


def test_separated_sentence_says_one_side_is_tested_at_100_percent():
    R = "FetchReach-v4"
    cells = [curve_cell("acder", [0.5, 1.0, 1.0, 1.0], env=R)] + [
        curve_cell(n, [1.0] * 4, env=R) for n in RE.ABLATIONS
    ]
    s = F.separated_sentence(cells, tasks=(R,))
    assert s.endswith(
        "On Reach the threshold is 100%, where an interval cannot extend to later "
        "crossings: a later crossing always lies outside the earlier one's interval, "
        "so only one side of the rule is tested."
    )


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
