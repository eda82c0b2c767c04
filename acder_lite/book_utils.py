"""Small helpers for the book's notebooks: show a package function's source,
the budgets, glue and how numbers are written, and what chapter 1 counts of a random
policy's episodes (`random_episode_stats`)."""

from __future__ import annotations

import inspect


def show_source(obj, lines: tuple[int, int] | None = None):
    """Display the source of a package object (function, class,
    method) as highlighted code.

    The notebooks show the package's code this way instead of copying it, so the book
    and the package cannot drift apart.
    """
    from IPython.display import Markdown

    src = inspect.getsource(obj)
    if lines is not None:
        src = "\n".join(src.splitlines()[lines[0] : lines[1]])
    mod = inspect.getmodule(obj)
    where = f"{mod.__name__}.{getattr(obj, '__qualname__', '')}" if mod else ""
    return Markdown(f"`{where}`\n\n```python\n{src.rstrip()}\n```")


def budgets(fast: bool, trains: bool = True, **pairs) -> dict:
    """Pick each budget: `name=(full, fast)` -> value for this mode.

    Prints the table, and the precision `Config.update_dtype="auto"` picks on this CPU:
    the chapters train with the default, so a reader on another CPU sees why their
    numbers differ from the rendered book's in the later digits. A chapter that trains
    no network passes `trains=False` and gets the table only."""
    from .precision import choose_update_dtype

    chosen = {k: (v[1] if fast else v[0]) for k, v in pairs.items()}
    print(
        f"ACDER_FAST={int(fast)}: " + ", ".join(f"{k}={v}" for k, v in chosen.items())
    )
    if trains:
        dtype, why = choose_update_dtype("auto")
        print(f"network updates in {dtype} on this CPU ({why})")
    return chosen


def glue(name: str, value, display: bool = False):
    """`myst_nb.glue` for values quoted in prose, with display off.

    Numpy scalars become Python numbers first (numpy 2's repr, `np.float64(0.5)`, cannot
    be formatted by `{glue:text}` with a format spec). Strings become Markdown, to be
    pasted with `{glue:md}` (`{glue:text}` would show their quotes)."""
    import numpy as np
    from IPython.display import Markdown
    from myst_nb import glue as _glue

    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, str):
        value = Markdown(value)
    return _glue(name, value, display=display)


def percent(share: float, digits: int = 3) -> str:
    """A share as the book writes it: '10%', '2.5%', '0.3%' (`digits` significant
    digits at most, no trailing zeros)."""
    return f"{100 * share:.{digits}g}%"


def percent_range(low: float, high: float, digits: int = 2) -> str:
    """An interval of shares with one number of decimals for both ends, enough for
    `digits` significant digits of the smaller nonzero one: '0.43% to 1.00%', not
    '0.43% to 1%'."""
    import math

    ends = [100 * abs(x) for x in (low, high) if x]  # a 0 end takes the other's
    places = digits - 1 - math.floor(math.log10(min(ends))) if ends else 0
    places = max(0, places)
    return f"{100 * low:.{places}f}% to {100 * high:.{places}f}%"


def vector_text(x, digits: int = 3) -> str:
    """A vector as the chapters print it: `digits` decimals, a space where the sign
    of a positive number goes (the columns line up) and no negative zero, which numpy
    prints for a tiny negative rounded away: '[ 1.363  0.000 -0.138]'."""
    import numpy as np

    values = np.round(np.asarray(x, dtype=float).ravel(), digits) + 0.0  # -0. -> 0.
    return "[" + " ".join(f"{v: .{digits}f}" for v in values) + "]"


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
    from .report import episodes_to_threshold

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


EPISODE_STATS = {
    "success": "success at the last step",
    "start": "already solved at step 0",
    "earned": "success, not solved at step 0",
    "any_step": "within 5 cm at some step",
    "moved": "achieved goal moved > 1 cm",
}
"""What `episode_stats` counts per episode, in words (chapter 1's legend)."""


def episode_stats(ep: dict, env) -> dict:
    """Per episode of `rollout.run_episodes`' output `ep` on `env`'s task (arrays with a
    leading episode axis): the `EPISODE_STATS` as bools, and `dist`, the achieved goal's
    distance to the goal at steps 1..T. 'moved': the achieved goal ever more than 1 cm
    from where it started; 'start': the reset itself within the distance threshold."""
    import numpy as np

    start = env.compute_reward(ep["ag"][:, 0], ep["g"][:, 0], None) == 0
    dist = np.linalg.norm(ep["ag"][:, 1:] - ep["g"], axis=-1)
    moved = np.linalg.norm(ep["ag"] - ep["ag"][:, :1], axis=-1).max(axis=1) > 0.01
    succ = ep["success"].astype(bool)
    return dict(
        success=succ,
        start=start,
        earned=succ & ~start,
        any_step=(dist < env.distance_threshold).any(axis=1),
        moved=moved,
        dist=dist,
    )


def random_policy(rng, action_dim: int = 4):
    """A uniformly random policy for `rollout.run_episodes`: `act(o, g)` draws one
    action a row of `o` from `rng`, each entry uniform in [-1, 1]."""
    return lambda o, g: rng.uniform(-1.0, 1.0, (len(o), action_dim))


def random_episode_stats(
    env_id: str, episodes: int, rng, workers: int = 4, seed: int = 100
) -> dict:
    """`episode_stats` of a uniformly random policy (`random_policy(rng)`) on `env_id`
    over `episodes // workers` rounds of `rollout.run_episodes`, each stepping
    `workers` envs together (seeded `seed`, `seed + 1`, ...): one array a key, the
    rounds' episodes concatenated (`episodes // workers * workers` of them).

    Trap: the actions are drawn from the caller's `rng`, which this advances. Chapter 1
    measures its tasks in turn from one generator, so a task's draws follow the ones
    before it: measure them in the same order with the same generator for its
    numbers."""
    import numpy as np

    from . import envs as E
    from .rollout import run_episodes

    if not 1 <= workers <= episodes:
        raise ValueError(
            f"episodes={episodes}, workers={workers}: allowed 1 <= workers <= episodes"
        )
    envs = [E.make_env(env_id, seed=seed + i) for i in range(workers)]
    act, horizon = random_policy(rng), E.horizon(env_id)
    try:
        per = [
            episode_stats(run_episodes(envs, act, horizon), envs[0])
            for _ in range(episodes // workers)
        ]
    finally:
        for env in envs:
            env.close()
    return {key: np.concatenate([p[key] for p in per]) for key in per[0]}


def success_rank(push: float, reach: float) -> str:
    """How the random policy's success rates (shares) rank Push against Reach, as a
    sentence opening. Trap: compared as the book prints them (`percent`), so two rates
    that print alike are a tie even where the floats differ."""
    if percent(push) == percent(reach):
        return "The success rates do not even tell Push from Reach"
    if push > reach:
        return "The success rates even rank Push above Reach"
    return "The success rates rank Reach above Push"


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
