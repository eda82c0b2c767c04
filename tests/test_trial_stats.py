"""Success counts over trials (acder_lite.stats.trial_stats): Wilson's interval worked
by hand, and when two counts out of 20 are told apart. Which bench rows separate:
test_robust.py. The paired sign test worked by hand."""

import pytest

from acder_lite.stats.trial_stats import (
    separating_gap,
    sign_test,
    told_apart,
    wilson_interval,
)


def test_wilson_interval_hand_worked():
    # 16 of 20: p = 0.8, z = 1.96: centre (0.8 + 0.09604) / 1.19208 = 0.75166, half
    # 1.96 / 1.19208 * sqrt(0.008 + 0.0024010) = 0.16768
    lo, hi = wilson_interval(16, 20)
    assert lo == pytest.approx(0.58398, abs=1e-4) and hi == pytest.approx(
        0.91934, abs=1e-4
    )
    lo, hi = wilson_interval(20, 20)
    assert hi == 1.0 and 0.8 < lo < 0.85


def test_wilson_interval_ends_are_exact_at_no_and_every_success():
    """In floats mid - half at k = 0 comes out 2.8e-17 at n = 11 and -6.9e-18 at
    n = 40, and mid + half at k = n = 6 a hair below 1: then no success in 11 would be
    "above" a chance of 0 (multistep_report.versus_chance). The ends are exact."""
    for n in range(1, 1001):
        lo, hi = wilson_interval(0, n)
        assert lo == 0.0 and 0.0 < hi < 1.0, n
        lo, hi = wilson_interval(n, n)
        assert hi == 1.0 and 0.0 < lo < 1.0, n


def test_told_apart_and_the_gap_it_takes_at_20_trials():
    # chapter 10's bench: gaps of 4 or 5 trials overlap, 7 against 17 does not
    assert not told_apart((4, 20), (9, 20)) and not told_apart((15, 20), (20, 20))
    assert told_apart((7, 20), (17, 20)) and told_apart((17, 20), (7, 20))
    gap = separating_gap(20)
    assert (gap["least"], gap["most"]) == (7, 9)
    assert gap["least_pair"] == (0, 7) and gap["most_pair"] == (5, 14)
    # each the least gap at its k: one trial fewer overlaps
    assert told_apart((0, 20), (7, 20)) and not told_apart((0, 20), (6, 20))
    assert told_apart((5, 20), (14, 20)) and not told_apart((5, 20), (13, 20))
    assert all(  # and no k needs more than 9
        told_apart((k, 20), (k + 9, 20)) for k in range(12)
    )
    assert separating_gap(3) is None  # 0 of 3 and 3 of 3 overlap at 95%
    four = separating_gap(4)
    assert (four["least"], four["most"], four["least_pair"]) == (4, 4, (0, 4))


def test_sign_test_hand_worked():
    # first = 1 1 1 0 1 1, second = 0 1 0 0 0 1: first alone on trials 0, 2 and 4
    # (a = 3), second alone on none
    # (b = 0); the tail is C(3, 0) = 1, p = 2 * 1 / 2^3 = 0.25
    assert sign_test([1, 1, 1, 0, 1, 1], [0, 1, 0, 0, 0, 1]) == (3, 0, 0.25)
    # a = 5, b = 1: tail C(6, 0) + C(6, 1) = 7, p = 14 / 64 = 0.21875
    first = [True] * 5 + [False] + [True] * 4
    second = [False] * 5 + [True] + [True] * 4
    assert sign_test(first, second) == (5, 1, 0.21875)
    # symmetric: swapping the policies swaps a and b and keeps p
    assert sign_test(second, first) == (1, 5, 0.21875)
    # a = 8, b = 0: 2 / 256 = 0.0078125, the smallest p eight split trials can give
    assert sign_test([1] * 8, [0] * 8) == (8, 0, 0.0078125)


def test_sign_test_ties_and_no_split():
    # a = b = 2: tail 1 + 4 + 6 = 11, 2 * 11 / 16 > 1 -> capped at 1
    assert sign_test([1, 1, 0, 0], [0, 0, 1, 1]) == (2, 2, 1.0)
    # no trial splits them (all shared wins and losses): nothing to test, p = 1
    assert sign_test([1, 0, 1], [1, 0, 1]) == (0, 0, 1.0)


def test_sign_test_refuses_unpaired_lengths():
    with pytest.raises(ValueError, match="equal lengths, got 3 and 2"):
        sign_test([1, 0, 1], [1, 0])
