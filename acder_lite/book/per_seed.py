"""One seed's reading, for "Results in detail": each seed's first crossing of a
success threshold in the protocol-v1 runs (`seed_crossings`). The page writes its
sentences about them by hand and glues the numbers in."""

from __future__ import annotations


def seed_crossings(
    runs: list[dict], env: str, name: str, threshold: float
) -> list[dict]:
    """Each seed's first evaluation at or above `threshold`
    (`report.episodes_to_threshold`, no interpolation), for runs of `runs.load_runs`; []
    when (env, name) has no run with rows.

    One dict per seed, in seed order: seed, `hit` (training episodes at the first
    crossing, None if never), `best` test success and `episodes` at the last
    evaluation. A single seed's crossing is what "Results in detail" tabulates;
    Table I's statistic is the crossing of the mean curve instead."""
    from acder_lite.stats.report import episodes_to_threshold

    mine = [r for r in runs if r["env"] == env and r["name"] == name and r["rows"]]
    out = []
    for r in sorted(mine, key=lambda r: r["seed"]):
        rows = r["rows"]
        hit = episodes_to_threshold(rows, threshold)
        best = max(x["test_success"] for x in rows)
        last = rows[-1]["episodes"]
        out.append(dict(seed=r["seed"], hit=hit, best=best, episodes=last))
    return out
