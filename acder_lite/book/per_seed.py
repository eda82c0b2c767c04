"""One seed's reading, for chapter 7: each seed's first crossing of a success
threshold in the protocol-v1 runs (`seed_crossings`, in words `crossing_text`), and how
the chapter's live runs ended (`live_ended`)."""

from __future__ import annotations


def seed_crossings(
    runs: list[dict], env: str, name: str, threshold: float
) -> list[dict]:
    """Each seed's first evaluation at or above `threshold`
    (`report.episodes_to_threshold`, no interpolation), for runs of `runs.load_runs`; []
    when (env, name) has no run with rows.

    One dict per seed, in seed order: seed, `hit` (training episodes at the first
    crossing, None if never), `best` test success and `episodes` at the last
    evaluation. A single seed's crossing is what chapter 7 tabulates; Table I's
    statistic is the crossing of the mean curve instead."""
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


def crossing_text(s: dict) -> str:
    """One seed of `seed_crossings` in a few words: 'seed 0: 4,000', or 'seed 1: not
    reached (best 0.90 in 10,000)'."""
    if s["hit"] is not None:
        return f"seed {s['seed']}: {s['hit']:,.0f}"
    return (
        f"seed {s['seed']}: not reached (best {s['best']:.2f} in {s['episodes']:,.0f})"
    )


def live_ended(ends: dict, n_eval: int, patience: int) -> str:
    """How chapter 7's two live runs ended, in words: `ends` maps a method to (its
    training episodes, the trainer's `stop_reason` if it stopped before its budget,
    else None). Where the runs evaluated fewer than `patience` times (ACDER_FAST's
    budget) it adds that the stop rule could not fire."""
    stopped = [
        f"{m} stopped early, after {n} episodes ({why})"
        for m, (n, why) in ends.items()
        if why is not None
    ]
    most = max(n for n, _ in ends.values())
    text = "; ".join(stopped) or f"both ran the full {most} episodes"
    if n_eval < patience:
        text += f" (each run's {n_eval} evaluations: the stop rule needs {patience})"
    return text
