"""Success counts over trials: how wide a count's interval is, when two are told apart

A bench row (`robust.run_bench`) or a method's test episodes (`multistep_report`) are k
successes in n trials. `wilson_interval` is the 95% interval of the rate k/n,
`told_apart` says whether two counts' intervals do not overlap, and `separating_gap`
how many trials apart two counts out of n must be for that. When the same trials are
run by two policies (same seeds, same perturbations), `sign_test` compares them pair by
pair instead. Pure arithmetic on (successes, trials): nothing is read or run. Which
rows of a bench separate its columns, and chapter 10's sentence saying so, read bench
results: `robust`.

Traps: Wilson's interval, not the normal approximation, which leaves [0, 1] and shrinks
to a point at k = 0 or k = n. Intervals that do not overlap are a strict test (two
counts can differ at the 5% level while their 95% intervals overlap): "not told apart"
is not "the same". The gap a pair needs depends on where in the range it sits: fewer
trials near an end than in the middle. Paired trials are not independent counts: the
trials both policies win or both lose say nothing about which is better, so the sign
test reads only the trials that split them.
"""

from __future__ import annotations

import math


def wilson_interval(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson's score interval for a success rate of k in n trials (z = 1.96: 95%);
    unlike the normal approximation it stays inside [0, 1] at k = 0 or k = n."""
    p = k / n
    mid = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    # trap: in floats mid -/+ half miss 0 at k = 0 and 1 at k = n by ~1e-17 either
    # way (0 of 11 would be "above" a chance of 0): those ends are exact
    lo = 0.0 if k == 0 else max(mid - half, 0.0)
    hi = 1.0 if k == n else min(mid + half, 1.0)
    return lo, hi


def told_apart(a: tuple[int, int], b: tuple[int, int], z: float = 1.96) -> bool:
    """Whether two counts (successes, trials) are told apart: their Wilson intervals
    (`wilson_interval`, z = 1.96: 95%) do not overlap."""
    (lo_a, hi_a), (lo_b, hi_b) = wilson_interval(*a, z), wilson_interval(*b, z)
    return hi_a < lo_b or hi_b < lo_a


def separating_gap(n: int, z: float = 1.96) -> dict | None:
    """How many trials apart two counts out of `n` must be to be told apart
    (`told_apart`): for each count k the least d with k and k + d apart; `least` and
    `most` of these over k, each with a pair (k, k + d) that needs it (`least`'s the
    lowest such k, `most`'s the one nearest the middle of the range). None when no two
    counts of n are apart (n <= 3 at 95%)."""
    need = {}
    for k in range(n + 1):
        d = next(
            (d for d in range(1, n - k + 1) if told_apart((k, n), (k + d, n), z)), None
        )
        if d is not None:
            need[k] = d
    if not need:
        return None
    least, most = min(need.values()), max(need.values())
    at_most = [k for k, d in need.items() if d == most]
    k_most = min(at_most, key=lambda k: abs(2 * k + most - n))  # nearest the centre
    k_least = min(k for k, d in need.items() if d == least)
    return dict(
        least=least,
        most=most,
        least_pair=(k_least, k_least + least),
        most_pair=(k_most, k_most + most),
    )


def sign_test(first, second) -> tuple[int, int, float]:
    """The two-sided sign test of two policies run on the same trials: `first` and
    `second` are each trial's success (bools, or 0/1), trial i the same for both.

    Returns (a, b, p): a trials won by `first` only, b by `second` only, and p the
    chance that a fair coin splits a + b tosses at least as unevenly,
    p = min(1, 2 * sum_{i <= min(a, b)} C(a + b, i) / 2^(a + b)) (exact binomial,
    1.0 when no trial splits them). Trials both win or both lose do not enter."""
    first, second = list(first), list(second)
    if len(first) != len(second):
        raise ValueError(
            f"sign_test: paired trials need equal lengths, got {len(first)} and "
            f"{len(second)}"
        )
    a = sum(bool(x) and not bool(y) for x, y in zip(first, second))
    b = sum(bool(y) and not bool(x) for x, y in zip(first, second))
    tail = sum(math.comb(a + b, i) for i in range(min(a, b) + 1))
    return a, b, min(1.0, 2 * tail / 2 ** (a + b))
