"""The sentences the book says about the experiments beside the grid
(acder_lite.book.experiment_findings: the constant-bonus control, the (sin, cos) run,
the readings), on synthetic cells: two equal seeds a cell make each 95% interval its
crossing."""

import math

import pytest

from acder_lite.book import experiment_findings as EF
from acder_lite.stats import report as RE

from conftest import curve_cell, push_cell

P = "FetchPush-v4"


def test_choice_sentence_says_what_the_rule_made_of_the_runs():
    a, b = (
        push_cell("sicm-normalised", 12.5, 9.0, 13.0),
        push_cell("sicm-raw", 15.0, 10.0, 17.0),
    )
    text = EF.choice_sentence(a, b, "sicm-raw", "the paper's eta values")
    assert (
        "5,000 inside 4,000 – 6,800" in text and "6,000 outside 3,600 – 5,200" in text
    )
    assert text.endswith(
        "falls back on the paper's eta values: ACDER, S-ICM on raw (o, g)."
    )
    text = EF.choice_sentence(
        a, push_cell("sicm-raw", 20.0, 14.0, 22.0), "sicm-raw", "x"
    )
    assert text.endswith("and ACDER, S-ICM on normalised (o, g) crosses first.")
    late = push_cell("sicm-raw", 15.0, 10.0, math.inf)
    assert "outside 4,000 or later" not in EF.choice_sentence(a, late, "sicm-raw", "x")
    assert "5,000 inside 4,000 or later" in EF.choice_sentence(a, late, "sicm-raw", "x")
    assert "cannot be applied yet" in EF.choice_sentence(
        a, push_cell("sicm-raw", None, None, None), "sicm-raw", "x"
    )


def test_readings_decisions_chain_the_two_rules():
    """(a) and (b) not separated (equal crossings never are): the paper's eta decides
    (b); then (b) against (c)."""
    norm = curve_cell("sicm-normalised", [0.4, 1.0, 1.0, 1.0])
    raw = curve_cell("sicm-raw", [0.4, 1.0, 1.0, 1.0])
    goal = curve_cell("sicm-raw-episode-goal", [0.0, 0.0, 0.5, 1.0])
    d = EF.readings_decisions(norm, raw, goal)
    assert d["choice"] == EF.choice_sentence(
        norm, raw, "sicm-raw", "the paper's eta values"
    )
    assert d["goal_choice"] == EF.choice_sentence(
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
    d = EF.readings_decisions(norm, raw, goal)
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
    text = EF.choice_sentence(raw, goal, "sicm-raw", "the default (a fresh goal)")
    assert "cannot cross before 9,200 episodes" in text
    assert "every seed is at 85% or more" in text and "crossed at 5,920" in text
    assert text.endswith("and the rule keeps ACDER, S-ICM on raw (o, g).")
    # the fallback is the challenger's: no early answer (the rule would need the runs)
    assert "cannot be applied yet" in EF.choice_sentence(goal, raw, "sicm-raw", "x")


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
    text = EF.bonus_sentence(runs, ["FetchReach-v4", P], last=2)
    assert text == (
        "On Push (clip η = 0.8): DDPG+HER+ICM 0.7 (87% of η), "
        "DDPG+ACDER 0.15 (19% of η)."
    )
    # a seed not ended yet (ended None): the value is said to be so far
    runs[0]["ended"], runs[1]["ended"] = None, "budget"
    text = EF.bonus_sentence(runs, [P], last=2)
    assert "DDPG+HER+ICM 0.7 (87% of η) so far (1 of its 2 seeds unfinished)," in text
    runs[0]["ended"] = "stop rule"
    assert "so far" not in EF.bonus_sentence(runs, [P], last=2)
    assert EF.bonus_sentence([], [P]) == "No curiosity method has an evaluation yet."
    # every evaluation (last=None): seeds (0.1 + 0.6 + 0.8) / 3 = 0.5 and 0.7 / 3 * 2
    want = (0.5 + 1.4 / 3) / 2
    assert RE.column_tail(runs, P, "her-icm", "r_int_mean", None) == pytest.approx(want)


def test_control_sentence_by_hand():
    """HER crosses at 2.9 epochs, ICM at 1.9 (as above); a constant bonus at 0.9 by
    epoch 2 crosses at 2 + 0.05 / 0.1 = 2.5: 0.4 of ICM's 1.0 epoch saved, 160 of 400
    episodes, 40%. Two equal seeds: every interval is its point."""
    her, icm = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0]),
    )
    bonus = curve_cell("her-bonus", [0.0, 0.9, 1.0, 1.0])
    s = EF.control_sentence(her, icm, bonus)
    assert (
        "DDPG+HER+ICM 760 < DDPG+HER with a constant bonus 1,000 < DDPG+HER 1,160" in s
    )
    assert (
        "Of DDPG+HER+ICM's 400 episodes saved over DDPG+HER, the constant alone " in s
    )
    assert "saves 160: 40%." in s
    assert "outside DDPG+HER's 95% interval and outside DDPG+HER+ICM's." in s
    same = curve_cell("her-bonus", [0.5, 1.0, 1.0, 1.0])
    s = EF.control_sentence(her, icm, same)
    assert "saves 400: 100%." in s and "inside DDPG+HER+ICM's." in s
    s = EF.control_sentence(her, icm, RE.cell_stat(P, "her-bonus", []))
    assert "not run yet: DDPG+HER with a constant bonus" in s
    assert "can be compared once each mean curve has crossed" in s
    s = EF.control_sentence(
        icm, her, bonus
    )  # "ICM" slower than "HER": nothing to explain
    assert "no gain of curiosity for the constant to explain" in s


def test_sincos_sentence_applies_the_rule_only_to_complete_cells():
    """Two equal seeds make each interval its point: ACDER crossing at 2.9 epochs
    (1,160 episodes) and the (sin, cos) variant at 1.9 (760) are separated; equal
    curves are not; a cell with seeds still to come is not read."""
    acder = curve_cell("acder", [0.0, 0.5, 1.0, 1.0])
    sincos = curve_cell("acder-sincos", [0.5, 1.0, 1.0, 1.0])
    s = EF.sincos_sentence(acder, sincos)
    assert s.startswith(
        "Ordered by the mean curve: ACDER, S-ICM on (sin, cos) of the angles 760 < "
        "DDPG+ACDER 1,160."
    )
    assert s.endswith(
        "The runs separate them: ACDER, S-ICM on (sin, cos) of the angles "
        "crosses first."
    )
    same = curve_cell("acder-sincos", [0.0, 0.5, 1.0, 1.0])
    assert "do not separate them" in EF.sincos_sentence(acder, same)
    sincos.planned = 3  # 2 of 3 seeds in: not the rule's yet
    s = EF.sincos_sentence(acder, sincos)
    assert "applied once both cells have all their planned seeds" in s
    assert "(2 of 3 seeds of ACDER, S-ICM on (sin, cos) of the angles finished)" in s
    s = EF.sincos_sentence(acder, RE.cell_stat(P, "acder-sincos", []))
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
    s = EF.control_sentence(her, icm, never)
    assert "saves none of the 400 episodes DDPG+HER+ICM saves over DDPG+HER." in s
    assert (
        "beyond DDPG+HER's 95% interval and beyond DDPG+HER+ICM's 95% interval. "
        "Every seed of the constant crosses later than every seed of DDPG+HER or not "
        "within its budget (the constant's seeds 2 not within budget; DDPG+HER's at "
        "1,160 and 1,160 episodes), so the constant slowed it; the rule, written "
        "before the runs, named no outcome for this case." in s
    )
    her.high = math.inf
    s = EF.control_sentence(her, icm, never)
    assert "the shift does not explain ICM's gain, which is its own. Every seed" in s
    never.planned = 3  # a seed still to come: not read yet
    s = EF.control_sentence(her, icm, never)
    assert s.endswith("can be compared once each mean curve has crossed.")


def test_sincos_sentence_when_the_variant_never_crosses():
    """Beyond the budget lies outside ACDER's point interval, and ACDER's crossing
    before any crossing of the variant's resamples: separated, ACDER first."""
    acder = curve_cell("acder", [0.0, 0.5, 1.0, 1.0])
    never = curve_cell("acder-sincos", [0.0, 0.2, 0.5, 0.6])
    s = EF.sincos_sentence(acder, never)
    assert "does not reach 95% within its budget" in s
    assert s.endswith("the runs separate them: DDPG+ACDER crosses first.")
    acder.high = float("inf")  # ACDER's own interval reaches past the budget
    assert "the runs do not separate them" in EF.sincos_sentence(acder, never)


def test_control_found_places_the_constant_seed_by_seed():
    her, icm = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0]),
    )
    between = curve_cell("her-bonus", [0.0, 0.9, 1.0, 1.0])
    assert EF.control_found(her, icm, between).startswith(
        "The constant's seeds lie between the fastest seed of DDPG+HER+ICM and the "
        "slowest of DDPG+HER (the constant's seeds at 1,000 and 1,000 episodes;"
    )
    fast = curve_cell("her-bonus", [1.0] * 4)
    assert EF.control_found(her, icm, fast).startswith(
        "Every seed of the constant crosses earlier than every seed of DDPG+HER+ICM"
    )
    training = curve_cell("her-bonus", [1.0] * 4, ended=None)
    assert EF.control_found(her, icm, training) == ""


def test_control_sentence_when_icm_ties_her():
    """DDPG+HER+ICM crossing where DDPG+HER does (2.9 epochs) gains nothing: no share
    of a zero gain is computed, whether the constant crosses (2.5 epochs) or not."""
    her, icm = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("her-icm", [0.0, 0.5, 1.0, 1.0]),
    )
    bonus = curve_cell("her-bonus", [0.0, 0.9, 1.0, 1.0])
    s = EF.control_sentence(her, icm, bonus)
    assert s.endswith("so there is no gain of curiosity for the constant to explain.")
    never = curve_cell("her-bonus", [0.0, 0.2, 0.5, 0.6])
    s = EF.control_sentence(her, icm, never)
    assert (
        "so the constant alone saves nothing (DDPG+HER+ICM is no faster than "
        "DDPG+HER)." in s
    ), s


@pytest.mark.parametrize("bonus", ["her-icm", "her"])
def test_control_found_reads_ties_at_either_end_as_between(bonus):
    """The constant's seeds equal to ICM's (1.9 epochs, the fastest) or to HER's (2.9,
    the slowest) lie between the two, at its ends: neither earlier than every seed of
    ICM nor later than every seed of HER."""
    her, icm = (
        curve_cell("her", [0.0, 0.5, 1.0, 1.0]),
        curve_cell("her-icm", [0.5, 1.0, 1.0, 1.0]),
    )
    values = {"her-icm": [0.5, 1.0, 1.0, 1.0], "her": [0.0, 0.5, 1.0, 1.0]}[bonus]
    same = curve_cell("her-bonus", values)
    assert EF.control_found(her, icm, same).startswith(
        "The constant's seeds lie between the fastest seed of DDPG+HER+ICM and the "
        "slowest of DDPG+HER"
    )
