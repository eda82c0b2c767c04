"""Small helpers for the book's notebooks: show a package function's source,
the budgets."""

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


def budgets(fast: bool, **pairs) -> dict:
    """Pick each budget: `name=(full, fast)` -> value for this mode.

    Prints the table, and the precision `Config.update_dtype="auto"` picks on this CPU:
    the chapters train with the default, so a reader on another CPU sees why their
    numbers differ from the rendered book's in the later digits."""
    from .precision import choose_update_dtype

    chosen = {k: (v[1] if fast else v[0]) for k, v in pairs.items()}
    print(
        f"ACDER_FAST={int(fast)}: " + ", ".join(f"{k}={v}" for k, v in chosen.items())
    )
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


def run_progress(
    runs: list[dict],
    env: str,
    name: str,
    paper_epochs: int,
    paper_episodes_per_epoch: int = 400,
) -> list[dict]:
    """How far each seed of (env, name) got, for runs of `runs.load_runs`;
    [] when there is none.

    One dict per seed with an evaluation: seed, epoch and episodes at its last
    evaluation, its test success there and its best, the epochs its command planned, how
    it ended (`runs.how_ended`: None while there is no done.json) and `share`, its
    training episodes over the paper's budget (`paper_epochs` epochs of
    `paper_episodes_per_epoch` episodes)."""
    from .runs import how_ended

    out = []
    for r in runs:
        if r["env"] != env or r["name"] != name or not r["rows"]:
            continue
        last = r["rows"][-1]
        epoch = last.get("epoch")
        out.append(
            dict(
                seed=r["seed"],
                epoch=epoch if isinstance(epoch, float) else None,
                episodes=last["episodes"],
                success=last["test_success"],
                best=max(x["test_success"] for x in r["rows"]),
                planned=r["planned_epochs"],
                ended=how_ended(r),
                share=last["episodes"] / (paper_epochs * paper_episodes_per_epoch),
            )
        )
    return out


def percent(share: float) -> str:
    """A share as the book writes it: '10%', '2.5%', '0.3%' (3 significant digits at
    most, no trailing zeros)."""
    return f"{100 * share:.3g}%"


def progress_sentence(
    label: str, seeds: list[dict], paper_epochs: int, started: bool = False
) -> str:
    """`run_progress` in words: "DDPG+HER: not run yet." (or, with `started`, a run
    folder exists but holds no evaluation yet) or, per seed, the epoch reached (of those
    planned), its share of the paper's budget and the test success at that last
    epoch."""
    if not seeds:
        return f"{label}: {'started, no evaluation yet' if started else 'not run yet'}."
    parts = []
    for s in seeds:
        epoch = (
            f"epoch {s['epoch']:g}"
            if s["epoch"] is not None
            else f"{s['episodes']:,.0f} episodes"
        )
        planned = f" of the {s['planned']} planned" if s["planned"] else ""
        state = {None: "still running (no done.json yet)"}.get(
            s["ended"], f"ended: {s['ended']}"
        )
        parts.append(
            f"seed {s['seed']} reached {epoch}{planned} ({percent(s['share'])} of the "
            f"paper's budget of {paper_epochs} epochs), test success "
            f"{s['success']:.2f} at its last epoch (best {s['best']:.2f}); {state}"
        )
    return f"{label}: " + "; ".join(parts) + "."


def best_sentence(
    progress: dict[str, list[dict]], threshold: float, random_success: float
) -> str:
    """What runs of `run_progress` (by label) show at their best, in one sentence: which
    reached `threshold` at an evaluation, and the best test success of each method's
    seeds beside a random arm's `random_success`; "" when there is no run."""
    best = {
        lab: max(s["best"] for s in seeds) for lab, seeds in progress.items() if seeds
    }
    if not best:
        return ""
    each = ", ".join(f"{v:.2f} for {lab}" for lab, v in best.items())
    hit = [lab for lab, v in best.items() if v >= threshold]
    head = (
        f"No run reached the {threshold:.0%} threshold at any evaluation"
        if not hit
        else f"Runs of {', '.join(hit)} reached the {threshold:.0%} threshold"
    )
    return (
        f"{head}: the best test success was {each}, against {random_success:.2f} "
        "for a random arm."
    )


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
