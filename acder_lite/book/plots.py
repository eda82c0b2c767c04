"""The book's figures: mean curves over seeds (Fig. 4 and 5) as Table I reads them, and
the chapters' own figures.

Every curve is `report.mean_curve` of the runs of one (task, folder name), on an axis of
epochs with Table I's unit (400 episodes an epoch) on the top axis: the mean where every
seed has a value, one standard deviation as the band, dotted where a seed stopped by the
stop rule is carried forward, and a dot where the mean first reaches the threshold.
Missing runs come back in the returned status ("not run yet"), never as an error.
`seed_ends` says where each seed's curve ends; `plot_diagnostics` draws ACDER's
diagnostics of one run; `chance_panel` draws a task's curves beside the test success
no learning is needed for (chapter 9's chance level). `clip_histogram` and
`clip_share_curves` draw chapter 4's S-ICM errors against the clip eta (`novelty`), as
`curiosity_losses`, `error_boxes` and `rollout_errors` draw its losses, error spreads
and one rollout's errors; `factor_arrows`, `factor_curve`, `factor_minibatch` and
`factor_against_block` (chapter 5) and `alpha_point` (chapter 6) draw the goal-oriented
factor and the start-state share alpha; `sicm_error_histograms` (chapter 6) the S-ICM
errors of successful rows before the clip; `start_share_curves` and `pool_map` (chapter
6) a short run's start-state share and its pool seen from above; `live_success` and
`episode_distances` (chapter 7) the live runs and one recorded episode; `block_panels`
(chapter 9) the multi-step run's both-block and per-block shares; `r_int_over_training`
(chapter 4) the bonus over whole runs; `table_bars` draws Table I as bars, ours beside
the paper's (the introduction's figure).

The figures are drawn for the book's text column: `WIDTH` inches wide at `DPI`, text at
least `FONT` points, and a legend of learning curves under its axes (`legend_below`),
where it covers no curve. A caller that makes its own axes for these functions should
make its figure alike: `plt.subplots(figsize=(plots.WIDTH, height), dpi=plots.DPI)`.

Trap: on FetchReach our epochs hold 80 episodes, so the top axis (Table I's unit) is not
our episode count there; the x axis is epochs on every task, as in the paper's figures.
"""

from __future__ import annotations

import numpy as np

from acder_lite.stats import report
from acder_lite.config import OBJECT_ENVS, TASK_PRESETS
from acder_lite.runs.table import METHOD_LABELS, TASK_LABELS
from acder_lite.words import count

COLORS = {
    "her": "C0",
    "her-icm": "C1",
    "her-per": "C2",
    "her-ebp": "C3",
    "acder": "C4",
    "acder-no-curiosity": "C5",
    "acder-no-goal-factor": "C6",
    "acder-no-start-states": "C7",
    "acder-baselines-clip": "C8",
    "sicm-normalised": "C4",
    "sicm-raw": "C9",
    "sicm-raw-episode-goal": "C1",
    "her-bonus": "C8",
    "acder-sincos": "C9",
}
"""One colour per method or experiment, the same in every figure."""


def colors_for(names, colors: dict | None = None) -> dict[str, str]:
    """A colour for each of `names` in one figure: its own in `colors` (`COLORS`), and
    for a name without one the first of matplotlib's "C0"-"C9", then of tab20's ten
    light shades, that no other name of the figure has (the free ones again in turn
    once all are taken). Trap: left to matplotlib, a new method took the axes' next
    colour, which could be another method's."""
    import matplotlib
    from matplotlib import colors as mcolors

    colors = COLORS if colors is None else colors
    names = list(dict.fromkeys(names))
    out = {n: colors[n] for n in names if n in colors}
    light = [mcolors.to_hex(c) for c in matplotlib.colormaps["tab20"].colors[1::2]]
    free = [c for c in [f"C{i}" for i in range(10)] + light if c not in out.values()]
    for i, n in enumerate(n for n in names if n not in out):
        out[n] = free[i % len(free)] if free else f"C{i % 10}"
    return out


WIDTH = 7.0
"""Width of the package's figures (inches): the book's text column, about 690 CSS px, so
the page does not shrink them and their text shows at the size it is set in."""
DPI = 150
"""Dots per inch of the package's figures: a `WIDTH` figure is about 1050 px, sharp
where the page shows it at the column's width (or on a high-density screen)."""
FONT = 9
"""Font size (points) of legends and secondary labels, the smallest text of a figure."""
LEGEND_DROP = 38
"""Points from an axes' bottom edge to the top of `legend_below`'s legend: room for the
tick labels and the x label."""


def legend_below(ax, ncol: int | None = None):
    """The legend of `ax` under its x label, outside the axes, so it covers no data (a
    learning curve can pass through any corner): in two columns unless a label is too
    long for half the figure's width (`ncol` to choose). Returns the legend."""
    from matplotlib.transforms import offset_copy

    if ncol is None:
        longest = max(len(t) for t in ax.get_legend_handles_labels()[1])
        ncol = 2 if longest <= 32 else 1
    below = offset_copy(ax.transAxes, fig=ax.figure, y=-LEGEND_DROP, units="points")
    return ax.legend(
        loc="upper center",
        bbox_to_anchor=(0.5, 0),
        bbox_transform=below,
        ncol=ncol,
        fontsize=FONT,
        frameon=False,
    )


def draw_mean(ax, m: report.MeanCurve, threshold: float | None, color=None, label=None):
    """One mean curve of test success: solid where evaluated, dotted where carried
    forward, band of one std (within [0, 1]), a dot at its first crossing of
    `threshold`. Returns the crossing (epochs) or None."""
    ok = ~np.isnan(m.mean)
    if not ok.any():
        return None
    x, y, s, carried = m.x[ok], m.mean[ok], m.std[ok], m.carried[ok]
    j = int(np.argmax(carried)) if carried.any() else len(x)
    (line,) = ax.plot(x[:j], y[:j], color=color, label=label)
    if carried.any():
        ax.plot(x[max(j - 1, 0) :], y[max(j - 1, 0) :], ls=":", color=line.get_color())
    if m.n > 1:
        # a success rate lies in [0, 1]; mean +- std of rates can pass either end
        lo, hi = np.clip(y - s, 0.0, 1.0), np.clip(y + s, 0.0, 1.0)
        ax.fill_between(x, lo, hi, color=line.get_color(), alpha=0.15, lw=0)
    hit = (
        report.first_crossing(m.x, m.mean, threshold) if threshold is not None else None
    )
    if hit is not None:
        ax.plot([hit], [threshold], "o", ms=5, color=line.get_color())
    return hit


def style_axes(
    ax,
    threshold: float | None = None,
    title: str | None = None,
    xmax: float | None = None,
) -> None:
    """Axes of a success-rate plot: epochs below, Table I's episodes on top,
    the threshold dashed, the legend (if any) under the axes."""
    if threshold is not None:
        ax.axhline(threshold, color="gray", ls="--", lw=0.8)
    ax.set_xlabel("epochs")
    ax.set_ylabel("test success (mean over seeds)")
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlim(0, xmax)
    ax.grid(alpha=0.3)
    top = ax.secondary_xaxis(
        "top",
        functions=(
            lambda e: e * report.PAPER_EPISODES_PER_EPOCH,
            lambda n: n / report.PAPER_EPISODES_PER_EPOCH,
        ),
    )
    top.set_xlabel("episodes in Table I's unit (400 an epoch)", fontsize=FONT)
    if title:
        ax.set_title(title, fontsize=10, loc="left")
    if ax.get_legend_handles_labels()[0]:
        legend_below(ax)


def plot_mean_curves(
    ax,
    runs: list[dict],
    env: str,
    names,
    labels: dict | None = None,
    colors: dict | None = None,
    threshold: float | None = None,
) -> dict[str, str]:
    """The mean curve of every folder name in `names` on `env`
    (runs of `runs.load_runs`).

    The legend counts each cell's seeds and, while some have not ended, how many.
    Returns name -> status: "not run yet", or seeds, how far the mean reaches, its
    crossing."""
    labels, colors = labels or METHOD_LABELS, colors_for(names, colors)
    threshold = report.threshold(env) if threshold is None else threshold
    status = {}
    for name in names:
        rs = [r for r in runs if r["env"] == env and r["name"] == name]
        if not rs:
            status[name] = "not run yet"
            continue
        m = report.learning_curves(rs)[(env, name)]
        done = sum(r["ended"] is not None for r in rs)
        # a cell still training says so in the legend: its curve will move
        left = f", {len(rs) - done} unfinished" if done < len(rs) else ""
        label = f"{labels.get(name, name)} ({count(len(rs), 'seed')}{left})"
        hit = draw_mean(ax, m, threshold, colors.get(name), label)
        ok = ~np.isnan(m.mean)
        reach = (
            f"mean curve to epoch {m.x[ok][-1]:g}"
            if ok.any()
            else "no evaluation of every seed yet"
        )
        cross = "" if hit is None else f", first at {threshold:.0%} at epoch {hit:.2f}"
        status[name] = f"{count(len(rs), 'seed')}, {done} done, {reach}{cross}"
    return status


def plot_learning_curves(
    ax,
    runs: list[dict],
    env: str,
    methods,
    labels: dict | None = None,
    colors: dict | None = None,
    threshold: float | None = None,
) -> dict[str, str]:
    """`plot_mean_curves` with the axes styled and the legend keyed: what the dashed
    line, a dotted segment and a dot mean (chapter 7 and "Results in detail" draw their
    Push runs with it)."""
    threshold = report.threshold(env) if threshold is None else threshold
    status = plot_mean_curves(ax, runs, env, methods, labels, colors, threshold)
    for style, text in key_entries(threshold):
        ax.plot([], [], color="gray", label=text, **style)
    style_axes(ax, threshold)
    return status


def key_entries(threshold: float) -> list[tuple[dict, str]]:
    """The legend's key to `draw_mean`'s encodings, as (line style, text) pairs."""
    return [
        (dict(ls="--", lw=0.8), f"{threshold:.0%}, the threshold"),
        (dict(ls=":"), "a stopped seed carried forward"),
        (
            dict(ls="", marker="o", ms=5),
            f"the mean's first crossing of {threshold:.0%}",
        ),
    ]


def seed_ends(runs: list[dict], env: str, name: str) -> list[dict]:
    """How each seed of one (task, folder name) ended, in seed order: seed, `ended`
    (`runs.how_it_ended`: None while training), `epoch` of its last evaluation,
    `carried` (the mean curve carries it forward to the budget: stopped by the stop
    rule) and `text`, e.g. 'seed 2: cut at epoch 18'.

    A mean curve (`report.mean_curve`) is drawn where every seed has a value, so it ends
    at the earliest `epoch` among the seeds not carried."""
    out = []
    for r in sorted(
        (r for r in runs if r["env"] == env and r["name"] == name and r["rows"]),
        key=lambda r: r["seed"],
    ):
        c = report.seed_curve(r["rows"], None, None, r.get("episodes_per_epoch"))
        last = float(c.x[-1]) if len(c.x) else float("nan")
        how = r["ended"] or "still training"
        out.append(
            dict(
                seed=r["seed"],
                ended=r["ended"],
                epoch=last,
                carried=r["ended"] == "stop rule",
                text=f"seed {r['seed']}: {how} at epoch {last:g}",
            )
        )
    return out


DIAGNOSTICS = {
    "r_int_mean": "mean $r^i$ (Eq. 4)",
    "lambda_mean": "mean $\\lambda_r$ (Eq. 6)",
    "alpha": "$\\alpha$ (Eq. 9)",
    "novel_start_share": "share of novel starts",
}
"""ACDER's progress.csv diagnostics that `plot_diagnostics` draws, with their y labels.
At each evaluation: r^i and lambda_r are means over the updates since the previous one,
the share of novel starts is over its training episodes, alpha is its value then."""


def plot_diagnostics(
    rows: list[dict], eta: float, x: str = "episodes", title: str | None = None
):
    """One panel per ACDER diagnostic of `DIAGNOSTICS` against `x`, from progress rows
    (`Trainer.train`'s or progress.csv's): r^i on a log axis with its clip `eta`
    dashed, lambda_r on its range [1, 1.5] (Eq. 6), alpha and the share of novel
    starts on [0, 1]. A column the rows lack leaves its panel saying so. Returns the
    figure (with `title` above the panels)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(WIDTH, 4.8), dpi=DPI, sharex=True)
    for ax, (key, ylabel) in zip(axes.flat, DIAGNOSTICS.items()):
        pts = [(r[x], r[key]) for r in rows if isinstance(r.get(key), (int, float))]
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if not pts:
            ax.text(0.5, 0.5, f"no {key}", ha="center", va="center",
                    transform=ax.transAxes, color="gray")  # fmt: skip
            continue
        ax.plot(*zip(*pts), "o-", ms=3)
        if key == "r_int_mean":
            ax.axhline(eta, color="gray", ls="--", lw=0.8, label=f"$\\eta$ = {eta:g}")
            ax.set_yscale("log")
            ax.legend(fontsize=FONT)
        elif key == "lambda_mean":
            ax.set_ylim(0.975, 1.525)
        else:
            ax.set_ylim(-0.05, 1.05)
    for ax in axes[-1]:
        ax.set_xlabel("training episodes" if x == "episodes" else x)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def view_limit(runs: list[dict], env: str, names) -> float | None:
    """Right end of a panel: a quarter past the last evaluation of any seed, at most the
    budget (carried tails run on to the budget, which would squeeze a fast task's curves
    to the left)."""
    last = [
        r["rows"][-1]["epoch"]
        for r in runs
        if r["env"] == env
        and r["name"] in names
        and r["rows"]
        and isinstance(r["rows"][-1].get("epoch"), float)
    ]
    budget = max(
        (r["budget_epochs"] for r in runs if r["env"] == env and r["name"] in names),
        default=TASK_PRESETS[env]["epochs"],
    )  # no runs: the task's budget
    return min(1.25 * max(last), budget) if last else budget


def task_panels(
    runs: list[dict],
    names,
    tasks=report.TASKS,
    title: str = "",
    labels: dict | None = None,
):
    """One full-width panel per task, the mean curves of `names` on it (her-ebp left out
    where there is no object); a panel where some of them have no runs names those in
    its legend ("not run yet: ..."), which `legend_below` puts under the panel. Returns
    (figure, {task: {name: status}})."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        len(tasks), 1, figsize=(WIDTH, 3.9 * len(tasks)), dpi=DPI, squeeze=False
    )
    statuses = {}
    for ax, env in zip(axes[:, 0], tasks):
        here = [n for n in names if not (n == "her-ebp" and env not in OBJECT_ENVS)]
        statuses[env] = plot_mean_curves(ax, runs, env, here, labels)
        unrun = [n for n, s in statuses[env].items() if s == "not run yet"]
        if len(unrun) == len(here):
            ax.text(
                0.5,
                0.5,
                "not run yet",
                ha="center",
                va="center",
                transform=ax.transAxes,
                color="gray",
            )
        elif unrun:  # the title promises them: the legend says which are missing
            names_text = ", ".join((labels or METHOD_LABELS).get(n, n) for n in unrun)
            ax.plot([], [], ls="none", label=f"not run yet: {names_text}")
        style_axes(
            ax,
            report.threshold(env),
            f"{TASK_LABELS.get(env, env)}{': ' + title if title else ''}",
            xmax=view_limit(runs, env, here),
        )
    fig.tight_layout()
    return fig, statuses


def chance_panel(
    runs: list[dict],
    names,
    env: str,
    chance: float,
    why: str,
    title: str = "",
    labels: dict | None = None,
):
    """`task_panels`' panel of `env` with a chance level: `chance`, the test success no
    learning is needed for (`why` says where it comes from), as a dotted line with a
    note. Where the curves stay low the y axis is zoomed to them (to 1.8 times the
    highest test success of `names`' runs, or of `chance`) and the note says the
    threshold lies above; otherwise it keeps [0, 1]. Returns the figure."""
    fig, _ = task_panels(runs, list(names), tasks=(env,), title=title, labels=labels)
    ax = fig.axes[0]
    rates = [
        x["test_success"]
        for r in runs
        if r["env"] == env and r["name"] in names
        for x in r["rows"]
    ]
    top, threshold = 1.8 * max(rates + [chance]), report.threshold(env)
    note = f"dotted: chance, {chance:.2%} ({why})"
    if 0 < top < threshold:  # the threshold is off the zoomed axis: say where it is
        ax.set_ylim(0, top)
        note += f"\ny axis zoomed: the {threshold:.0%} threshold is far above"
    ax.axhline(chance, color="black", ls=":", lw=1)
    ax.text(0.01, 0.96, note, transform=ax.transAxes, va="top", fontsize=FONT)
    return fig


def plot_seed_column(
    ax,
    runs: list[dict],
    env: str,
    names,
    column: str,
    ylabel: str,
    labels: dict | None = None,
) -> int:
    """One thin line per seed of a progress.csv column against epochs (e.g. r_int_mean),
    the legend under the axes. Returns how many seeds had the column."""
    labels, colors = labels or METHOD_LABELS, colors_for(names)
    drawn = 0
    for name in names:
        for i, r in enumerate(
            rr for rr in runs if rr["env"] == env and rr["name"] == name
        ):
            pts = [
                (row["epoch"], row[column])
                for row in r["rows"]
                if isinstance(row.get(column), float)
                and isinstance(row.get("epoch"), float)
            ]
            if pts:
                x, y = zip(*pts)
                ax.plot(
                    x,
                    y,
                    lw=0.9,
                    color=colors[name],
                    label=labels.get(name, name) if i == 0 else None,
                )
                drawn += 1
    ax.set_xlabel("epochs")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        legend_below(ax)
    return drawn


def plot_statistic(ax, curves: list[report.SeedCurve], threshold: float):
    """How Table I is read, on given seed curves: each seed thin (carried part dotted),
    the mean curve thick, its first crossing marked. Returns the crossing (epochs) or
    None."""
    for i, c in enumerate(curves):
        ev = ~c.carried
        ax.plot(
            c.x[ev],
            c.y[ev],
            lw=0.8,
            color="gray",
            marker=".",
            label="seeds" if i == 0 else None,
        )
        if c.carried.any():
            k = int(np.argmax(c.carried))
            ax.plot(c.x[k - 1 :], c.y[k - 1 :], lw=0.8, ls=":", color="gray")
    hit = draw_mean(ax, report.mean_curve(curves), threshold, "C4", "mean curve")
    if hit is not None:
        ax.axvline(hit, color="C4", lw=0.6)
    style_axes(ax, threshold)
    return hit


def plot_block_paths(ax, ep: dict, env) -> None:
    """An episode of a block task seen from above: the gripper's path, each block's path
    in the colour the env's XML gives it, each target (its first goal) with its
    `distance_threshold` circle in the target's colour. `ep` is one env's arrays of
    `rollout.run_episodes` (o, ag, g); `env` the (unwrapped) env it ran in."""
    import matplotlib.pyplot as plt

    from acder_lite.book import viz

    model, k_blocks = env.model, ep["ag"].shape[-1] // 3
    ax.plot(ep["o"][:, 0], ep["o"][:, 1], ".-", color="0.6", ms=3, label="gripper")
    for k in range(k_blocks):
        block = viz.geom_rgba(model, model.geom(f"object{k}").id)[:3]
        target = model.site_rgba[model.site(f"target{k}").id][:3]
        xy = ep["g"][0, 3 * k : 3 * k + 2]
        ax.plot(
            *ep["ag"][:, 3 * k : 3 * k + 2].T,
            "s-",
            ms=3,
            color=block,
            label=f"block {k}",
        )
        ax.plot(*xy, "*", ms=15, color=target, label=f"target {k}")
        ax.add_patch(
            plt.Circle(xy, env.distance_threshold, color=target, fill=False, ls="--")
        )
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.legend(fontsize=FONT, loc="best")


def clip_histogram(ax, familiar: np.ndarray, new: np.ndarray, eta: float, inp: str):
    """Chapter 4's S-ICM errors of familiar and of new transitions as the reward Eq. 4
    makes of them, clip(error, 0, `eta`), on log-spaced bins from a tenth of eta (or
    the smallest error, if lower, but not below 1e-6) up to eta: each bar a share of
    its set, so that sets of any size compare, the last bin holding every error at the
    clip; the title gives the two shares at or above eta, the x label the S-ICM input
    `inp`."""
    fam, new = np.ravel(familiar), np.ravel(new)
    lo = min(max(min(fam.min(), new.min()), 1e-6), eta / 10)
    bins = np.geomspace(lo, eta, 30)  # log-spaced: the errors span decades
    for e, label in [(fam, "familiar"), (new, "new exploration")]:
        w = np.full(e.size, 1 / e.size)  # shares, so the two sets compare
        ax.hist(np.clip(e, lo, eta), bins=bins, weights=w, alpha=0.6, label=label)
    ax.set_xscale("log")
    clip = rf"$r^i = \operatorname{{clip}}(\mathrm{{error}}, 0, {eta:.2f})$"
    ax.set_xlabel(f"{clip}, input {inp!r} (log scale)")
    ax.set_ylabel("share of transitions")
    at = f"familiar {np.mean(fam >= eta):.2f}, new {np.mean(new >= eta):.2f}"
    ax.set_title(f"share at the clip (the last bin): {at}", fontsize=10)
    ax.legend()


def clip_share_curves(ax, etas, shares: dict[str, dict], marks=(0.05, 0.8)):
    """The share of S-ICM errors at or above the clip against the clip eta (a log
    axis), a curve per input and set of `shares` (`novelty.shares_at` over `etas`),
    one line style per input; `marks` (the paper's two eta values) dotted. The legend
    goes under the axes (`legend_below`)."""
    styles = ["-", "--", "-."]  # a line style per input; ":" marks the paper's etas
    for i, (inp, sets) in enumerate(shares.items()):
        for name, y in sets.items():
            ax.semilogx(etas, y, styles[i % len(styles)], label=f"{inp}: {name}")
    for x in marks:
        ax.axvline(x, color="gray", ls=":")
    ax.set_xlabel(r"the clip $\eta$")
    ax.set_ylabel("share at the clip")
    legend_below(ax)


def curiosity_losses(ax, rows: dict[str, list[dict]]):
    """S-ICM's training loss (Eq. 8) against the cycle, on a log axis, a curve per
    S-ICM input of `rows` (per input, the rows `Trainer.train` returned, each with its
    `cycle` and `curiosity_loss`); the legend, titled by the setting, right of the
    axes."""
    for inp, r in rows.items():
        cycles = [x["cycle"] for x in r]
        ax.semilogy(cycles, [x["curiosity_loss"] for x in r], "o-", label=inp)
    ax.set_xlabel("cycle")
    ax.set_ylabel("S-ICM loss $L_F$ (Eq. 8)")
    ax.legend(title="sicm_input", fontsize=FONT, title_fontsize=FONT,
              loc="upper left", bbox_to_anchor=(1.01, 1))  # fmt: skip


def error_boxes(axes, sets: dict[str, dict[str, np.ndarray]], etas: dict[str, float]):
    """Chapter 4's S-ICM errors (`novelty.error_sets`), an axes of the column `axes`
    per input, a box per set (no fliers: the errors span decades) on a log axis, the
    input's clip `etas[input]` dashed; the legend on the first axes, the sets' names
    under the last (the axes share x)."""
    for ax, (inp, s) in zip(axes, sets.items()):
        ax.boxplot([e.ravel() for e in s.values()], showfliers=False)
        ax.axhline(etas[inp], color="gray", ls="--", label=r"$\eta$")
        ax.set_yscale("log")
        ax.set_ylabel(r"$\frac{1}{2}\|F(s,a) - s'\|^2$")
        ax.set_title(f"sicm_input = {inp!r}", fontsize=10, loc="left")
    axes[0].legend(fontsize=FONT, loc="upper left", bbox_to_anchor=(1.01, 1))
    names = list(next(iter(sets.values())))
    axes[-1].set_xticks(range(1, len(names) + 1), names, fontsize=FONT)


def rollout_errors(
    axes, errors: dict[str, np.ndarray], etas: dict[str, float], explore
):
    """One rollout's S-ICM error and its reward r^i (Eq. 4, clipped to the input's
    `etas[input]`, dotted) against the step (from 1), on log axes, an axes of the
    column `axes` per input of `errors` (one error a step); a dashed line after its
    first `explore` steps marks where the sweep starts (chapter 4's rollout). The
    legend goes under the last axes (`legend_below`)."""
    for ax, (inp, e) in zip(axes, errors.items()):
        steps, eta = np.arange(1, len(e) + 1), etas[inp]
        ax.semilogy(steps, e, label="error")
        ax.semilogy(steps, np.minimum(e, eta), label=r"$r^i$ (Eq. 4, clipped)")
        ax.axhline(eta, color="gray", ls=":", label=r"$\eta$")
        ax.axvline(explore + 0.5, color="gray", ls="--", label="sweep starts")
        ax.set_title(f"sicm_input = {inp!r}", fontsize=10, loc="left")
    axes[-1].set_xlabel("step")
    legend_below(axes[-1], ncol=4)


def factor_arrows(ax, goal, action, lam: float, r_fail: float):
    """Chapter 5's widget: from the gripper at the origin, the direction to `goal`
    (red) and the action's xy part (blue) on a square of side 2, titled with the
    action's factor `lam` (Eq. 6) and the reward `r_fail` a failed step then earns."""
    d = np.linalg.norm(goal[:2])  # 0 for a goal straight above: no xy direction
    to_goal = 0.8 * goal[:2] / d if d > 0 else np.zeros(2)
    ax.arrow(0, 0, *to_goal, color="r", width=0.01, label="to goal")
    xy = action[0] * 0.8, action[1] * 0.8  # both at 0.8 for a unit action
    ax.arrow(0, 0, *xy, color="b", width=0.01, label="action (xy)")
    ax.set_xlim(-1, 1)
    ax.set_ylim(-1, 1)
    ax.set_aspect("equal")
    title = rf"$\lambda_r$ = {lam:.3f}; a failed step earns {r_fail:.3f}"
    ax.set_title(title, fontsize=10, pad=10)
    ax.legend(loc="lower left", fontsize=9)


def _alpha_against_success(ax, alpha0: float, ylabel: str, **line):
    """Eq. 9's alpha (`start_states.novel_start_ratio`) for `alpha0` against the test
    success rate on `ax`, with the axes the two alpha figures share."""
    from acder_lite.algo.start_states import novel_start_ratio

    s = np.linspace(0, 1, 101)
    ax.plot(s, [novel_start_ratio(x, alpha0) for x in s], **line)
    ax.set_xlabel("test success rate")
    ax.set_ylabel(ylabel)
    ax.set_ylim(-0.05, 1.05)


def alpha_point(ax, alpha0: float, success_rate: float):
    """Chapter 6's widget: Eq. 9's alpha (`start_states.novel_start_ratio`) against
    the test success rate for `alpha0`, a red dot at `success_rate`, whose alpha the
    title gives."""
    from acder_lite.algo.start_states import novel_start_ratio

    _alpha_against_success(ax, alpha0, r"$\alpha$ (share of novel starts)")
    alpha = novel_start_ratio(success_rate, alpha0)
    ax.plot([success_rate], [alpha], "ro")
    ax.set_title(rf"$\alpha$ = {alpha:.3f}")


PAPER_TASKS = report.TASKS + ("FetchPushMultiStep-v0",)
"""The paper's four tasks, in its order: Table I's three and the multi-step Push."""


def alpha_curves(ax, tasks=PAPER_TASKS):
    """Chapter 6's Eq. 9: alpha (`start_states.novel_start_ratio`) against the test
    success rate, a curve for each alpha0 the `tasks`' presets set (`TASK_PRESETS`),
    labelled with the tasks that use it, so the figure follows the presets."""
    by_alpha0: dict[float, list[str]] = {}
    for env in tasks:
        by_alpha0.setdefault(TASK_PRESETS[env]["alpha0"], []).append(TASK_LABELS[env])
    for a0, names in by_alpha0.items():
        label = rf"$\alpha_0$ = {a0:g} ({', '.join(names)})"
        _alpha_against_success(ax, a0, r"$\alpha$ (Eq. 9)", label=label)
    ax.legend()


def factor_curve(axes, line: dict, rand: dict, corners):
    """Chapter 5's Eq. 6 on hand-made actions (`factor_report`), a column of two
    `axes`: the factor against the angle to the goal, `line` (`rotated_actions`) as a
    black line and `rand` (`random_actions`) as dots behind it; under it the histogram
    of `rand`'s factors, the factors of the `corners` directions (`corner_factors`)
    dashed, their legend above the axes."""
    ax = axes[0]
    ax.plot(line["angle"], line["lam"], lw=1, color="k", label="rotated action")
    dots = dict(ms=3, alpha=0.4, zorder=0)  # behind the line
    ax.plot(rand["angle"], rand["lam"], ".", label="random actions", **dots)
    ax.set_xlabel("angle between action and direction to goal (deg)")
    ax.set_ylabel(r"$\lambda_r$ (Eq. 6)")
    ax.legend()
    ax = axes[1]
    ax.hist(rand["lam"], bins=40)
    for k, lam_c in enumerate(corners):
        label = "cube-corner directions" if k == 0 else None
        ax.axvline(lam_c, color="gray", ls="--", label=label)
    ax.set_xlabel(r"$\lambda_r$ of uniformly random actions")
    ax.set_ylabel("actions")
    ax.legend(fontsize=FONT, loc="lower right", bbox_to_anchor=(1, 1))  # above


def factor_minibatch(axes, lam, r_her, r, relabelled):
    """Chapter 5's minibatch through the goal factor, on its `relabelled` rows only, a
    column of two `axes`: the histogram of their factors `lam` (Eq. 6) with a random
    direction's 1.25 dashed (legend above the axes), and under it their rewards before
    (`r_her`) and after (`r`) the factor, on bins of width 0.05 from -1.55 to 0.05."""
    h = np.asarray(relabelled, bool)
    ax = axes[0]
    ax.hist(lam[h], bins=40, label="relabelled rows of the minibatch")
    ax.axvline(1.25, color="gray", ls="--", label="random direction")
    ax.set_xlabel(r"$\lambda_r$ (Eq. 6)")
    ax.legend(fontsize=FONT, loc="lower right", bbox_to_anchor=(1, 1))  # above
    bins = np.linspace(-1.55, 0.05, 33)
    ax = axes[1]
    ax.hist([r_her[h], r[h]], bins=bins, label=[r"$r$ (HER)", r"$\lambda_r\, r$"])
    ax.set_xlabel("reward of relabelled rows")
    ax.legend()


def factor_against_block(axes, f: dict):
    """Chapter 5's FetchPush rows, `f` as `diagnose.goal_factor_against_object` returns
    it, a column of two `axes`: the angle between gripper -> g^h and gripper -> block,
    a stacked histogram split by whether the block moved, on a log count axis (most rows
    sit in the first bin); under it the factor as used against the factor scored
    towards the block, a row a dot, the diagonal dashed."""
    moved, angle = f["moved"], f["angle"]
    ax = axes[0]
    labels = ["block still at the goal's step", "block moved"]
    split = [angle[~moved], angle[moved]]
    ax.hist(split, bins=36, range=(0, 180), stacked=True, label=labels)
    ax.set_xlabel(r"angle between gripper $\to g^h$ and gripper $\to$ block (deg)")
    ax.set_yscale("log")
    ax.set_ylabel("rows")
    ax.legend(fontsize=FONT)
    ax = axes[1]
    ax.plot(f["lam_obj"], f["lam_goal"], ".", ms=2, alpha=0.5)
    ax.plot([1, 1.5], [1, 1.5], color="gray", ls="--")
    ax.set_xlabel(r"$\lambda_r$ scored against the block (gripper $\to$ block)")
    ax.set_ylabel(r"$\lambda_r$ (Eq. 6, used)")


TABLE_BARS_METHODS = ("her", "her-icm", "acder")
"""The methods `table_bars` draws by default: the paper's pair and the baseline whose
curiosity ACDER's replaces."""


def bar_reading(c: report.CellStat) -> dict:
    """One cell of Table I as `table_bars` draws it, in Table I's unit (400 episodes an
    epoch): `value`, the mean curve's first crossing, or where the mean curve ended
    without crossing within the budget the budget itself with `bound` True (the
    crossing, if any, lies beyond it: a lower bound); `low` and `high`, the 95%
    bootstrap interval, None for an end beyond the budget; `paper`, Table I's number
    (None for its '–'); `why`, the cell's reason for having no value ('not yet', 'not
    run yet', ...), '' where it has one."""
    out = dict(value=None, bound=False, low=None, high=None, paper=c.paper, why="")

    def units(epochs):
        finite = epochs is not None and np.isfinite(epochs)
        return c.paper_units(epochs) if finite else None

    if c.crossing is not None:
        out["value"] = units(c.crossing)
    elif c.why == "not within budget" and c.budget_epochs:
        out["value"], out["bound"] = units(c.budget_epochs), True
    else:
        out["why"] = c.why or "no crossing"
        return out
    out["low"], out["high"] = units(c.low), units(c.high)
    return out


def table_bars(cells: list, methods=TABLE_BARS_METHODS, tasks=report.TASKS):
    """Table I as bars, one panel per task (each on its own scale): for each of
    `methods`, our mean-curve crossing (`bar_reading` of its `report.CellStat` in
    `cells`) in the method's colour with its 95% bootstrap interval as an error bar,
    beside the paper's number hatched in the same colour. A cell whose mean curve did
    not cross within its budget is an open bar up to the budget with an arrow on top
    (the crossing lies beyond: a lower bound), an interval reaching beyond the budget an
    arrow above its lower end, a cell without a value its reason in grey. Returns
    (figure, {task: {method: bar_reading}})."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    by = {(c.env, c.name): c for c in cells}
    colors = colors_for(methods)
    fig, axes = plt.subplots(
        1, len(tasks), figsize=(WIDTH, 3.6), dpi=DPI, squeeze=False
    )
    readings: dict[str, dict[str, dict]] = {}
    for ax, env in zip(axes[0], tasks):
        here = [m for m in methods if not (m == "her-ebp" and env not in OBJECT_ENVS)]
        readings[env] = {m: bar_reading(by[env, m]) for m in here if (env, m) in by}
        drawn = [
            v
            for b in readings[env].values()
            for v in (b["value"], b["paper"], b["high"])
            if v is not None
        ]
        top = max(drawn, default=1.0)
        head = 0.12 * top  # an arrow's length above what it marks
        for i, m in enumerate(here):
            b, color = readings[env].get(m), colors[m]
            if b is None:
                continue
            if b["paper"] is not None:
                ax.bar(i + 0.2, b["paper"], 0.38, facecolor="white", edgecolor=color,
                       hatch="////", lw=1)  # fmt: skip
            if b["value"] is None:
                ax.text(i - 0.2, 0.02 * top, b["why"], rotation=90, ha="center",
                        va="bottom", fontsize=FONT, color="gray")  # fmt: skip
                continue
            if b["bound"]:
                ax.bar(
                    i - 0.2, b["value"], 0.38, facecolor="none", edgecolor=color, lw=1.5
                )
                _arrow_up(ax, i - 0.2, b["value"], head, color)
            else:
                ax.bar(i - 0.2, b["value"], 0.38, color=color)
            if b["low"] is not None:
                hi = b["value"] if b["high"] is None else b["high"]
                ax.plot([i - 0.2] * 2, [b["low"], hi], color="k", lw=1)
                ax.plot([i - 0.27, i - 0.13], [b["low"]] * 2, color="k", lw=1)
                if b["high"] is None and not b["bound"]:
                    _arrow_up(ax, i - 0.2, b["value"], head, "k")
                elif b["high"] is not None:
                    ax.plot([i - 0.27, i - 0.13], [b["high"]] * 2, color="k", lw=1)
        ax.set_xticks(range(len(here)))
        names = [METHOD_LABELS.get(m, m).replace("DDPG+", "") for m in here]
        ax.set_xticklabels([n.replace("+", "+\n") for n in names], fontsize=FONT)
        ax.set_ylim(0, top + 1.6 * head)
        ax.yaxis.set_major_formatter(lambda y, _: f"{y:,.0f}")
        ax.tick_params(axis="y", labelsize=FONT)
        ax.grid(axis="y", alpha=0.3)
        ax.set_title(
            f"{TASK_LABELS.get(env, env)} ({report.threshold(env):.0%})",
            fontsize=10,
            loc="left",
        )
    axes[0, 0].set_ylabel("episodes to the threshold\n(Table I's unit, 400 an epoch)")
    key = [
        Patch(color="0.45", label="ours: the mean curve's crossing"),
        Patch(facecolor="white", edgecolor="0.45", hatch="////", label="the paper's"),
        Patch(facecolor="none", edgecolor="0.45", lw=1.5,
              label="ours: not within the budget (more than the bar)"),
        Line2D([], [], color="k", lw=1, label="95% bootstrap interval"),
    ]  # fmt: skip
    fig.legend(handles=key, loc="lower center", ncol=2, fontsize=FONT, frameon=False)
    fig.tight_layout(rect=(0, 0.13, 1, 1))
    return fig, readings


def _arrow_up(ax, x: float, y: float, length: float, color) -> None:
    """An arrow from (x, y) up by `length`: what it marks goes on beyond."""
    ax.annotate("", xy=(x, y + length), xytext=(x, y),
                arrowprops=dict(arrowstyle="->", color=color, lw=1.2))  # fmt: skip


def block_panels(
    run: dict,
    chance: float,
    each_chance=(),
    short: dict | None = None,
    level: float | None = None,
    title: str = "",
):
    """Chapter 9's 400-epoch run of the multi-step Push, one run (`runs.read_run`), in
    two panels over epochs. Top: its test success (both blocks on their targets at the
    last step), each block's share on its target (`block{i}_on_target`, when
    progress.csv has them), the chance level `chance` of both blocks and, dotted in
    each block's colour, `each_chance` (each block's), the rule's `level` dashed, and
    the 40-epoch run `short`'s test success, thin, where given. Bottom, when
    progress.csv has them: each block's share of test episodes in which it moved
    (`block{i}_moved`) and the share of the start-state pool holding a block on its
    target (`pool_block_on_target`). `title` heads the figure (say there whether the
    run has finished). Returns it."""
    import matplotlib.pyplot as plt

    rows = run["rows"]
    has = set(rows[0]) if rows else set()
    lower = [c for c in ("block0_moved", "block1_moved") if c in has]
    lower += ["pool_block_on_target"] if "pool_block_on_target" in has else []
    n = 2 if lower else 1
    fig, axes = plt.subplots(n, 1, figsize=(WIDTH, 3.4 * n), dpi=DPI, squeeze=False)
    x = [r["epoch"] for r in rows]
    block = {0: "0.45", 1: "C0"}  # the scene's colours: block 0 grey, block 1 blue
    top = axes[0, 0]
    top.plot(x, [r["test_success"] for r in rows], color="k", lw=1.6,
             label="both blocks (test success)")  # fmt: skip
    for i in (0, 1):
        if f"block{i}_on_target" in has:
            ys = [r[f"block{i}_on_target"] for r in rows]
            top.plot(x, ys, color=block[i], lw=1, label=f"block {i} on its target")
    for i, c in enumerate(each_chance):
        top.axhline(c, color=block[i], ls=":", lw=1)
    top.axhline(chance, color="k", ls=":", lw=1, label=f"chance, both ({chance:.2%})")
    if short is not None:
        sx = [r["epoch"] for r in short["rows"]]
        top.plot(sx, [r["test_success"] for r in short["rows"]], color="C4", lw=0.8,
                 alpha=0.7, label="the 40-epoch run, both")  # fmt: skip
    if level is not None:
        top.axhline(level, color="gray", ls="--", lw=0.8, label=f"rule: {level:.0%}")
    top.set_ylabel("share of test episodes")
    top.set_title(title, fontsize=10, loc="left")
    if lower:
        ax = axes[1, 0]
        for i in (0, 1):
            if f"block{i}_moved" in has:
                ys = [r[f"block{i}_moved"] for r in rows]
                ax.plot(x, ys, color=block[i], lw=1, label=f"block {i} moved (test)")
        if "pool_block_on_target" in has:
            ys = [r["pool_block_on_target"] for r in rows]  # NaN: empty pool, no dot
            ax.plot(x, ys, color="C4", lw=1, ls="--",
                    label="start pool: a block on its target")  # fmt: skip
        ax.set_ylabel("share")
    for ax in axes[:, 0]:
        ax.set_xlabel("epochs")
        ax.set_xlim(0, max(x + [1]))
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=FONT)
        legend_below(ax)
    fig.tight_layout()
    return fig


def sicm_error_histograms(axes, errs: dict):
    """Chapter 6's S-ICM errors before the clip on the successful rows of fresh
    minibatches, an axes of the column `axes` per S-ICM input: `errs` maps the input to
    `diagnose.minibatch_errors`' dict (`err`, `successful`, `eta`). Log bins; the clip
    eta dashed, right of which Eq. 4 pays eta to every row alike."""
    for ax, (inp, d) in zip(axes, errs.items()):
        e = d["err"][d["successful"]]
        if e.size:
            bins = np.geomspace(max(e.min(), 1e-6), max(e.max(), d["eta"]) * 1.01, 50)
            ax.hist(e, bins=bins)
        label = rf"$\eta$ = {d['eta']}: Eq. 4 pays min(error, $\eta$)"
        ax.axvline(d["eta"], color="r", ls="--", label=label)
        ax.set_xscale("log")
        ax.set_ylabel("rows")
        ax.set_title(f"sicm_input = {inp!r}: successful rows", fontsize=10, loc="left")
        ax.legend(fontsize=FONT)
    axes[-1].set_xlabel(r"S-ICM error $\frac{1}{2}\|F(s,a) - s'\|^2$ before the clip")


START_SHARE_COLUMNS = [
    ("test_success", "o-", "test success"),
    ("alpha", "s-", r"$\alpha$ (Eq. 9)"),
    ("novel_start_share", "^-", "share of novel starts"),
]
"""What `start_share_curves` draws: (progress column, line style, label)."""


def start_share_curves(ax, rows: list[dict]):
    """Chapter 6's short ACDER run, from its progress rows (`Trainer.train`'s), against
    its training episodes, one evaluation a point: the test success, Eq. 9's alpha and
    the share of its training episodes that started from a stored candidate
    (`START_SHARE_COLUMNS`), the legend below the axes."""
    x = [r["episodes"] for r in rows]
    for key, style, label in START_SHARE_COLUMNS:
        ax.plot(x, [r[key] for r in rows], style, label=label)
    ax.set_xlabel("training episodes")
    ax.set_ylabel("rate, probability or share")
    legend_below(ax, ncol=3)


def pool_map(ax, gripper: np.ndarray, start) -> None:
    """Chapter 6's start-state pool seen from above: the gripper position (x, y) of
    each candidate of `gripper` (k, 3), coloured from the oldest (0) to the newest, with
    a colour bar, and the gripper's reset position `start` as a black cross."""
    k = len(gripper)
    sc = ax.scatter(gripper[:, 0], gripper[:, 1], c=np.arange(k), cmap="viridis")
    ax.figure.colorbar(sc, ax=ax, label="candidate, oldest (0) to newest")
    ax.plot(start[0], start[1], "k+", ms=15, label="reset position of the gripper")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.legend(fontsize=FONT)


def live_success(ax, live: dict[str, list[dict]]) -> None:
    """Chapter 7's live runs: the test success of each method's progress rows (`live`
    maps a method to `Trainer.train`'s rows) against its training episodes, one
    evaluation a point, labelled as the paper names the methods (DDPG+HER, ...)."""
    for method, rows in live.items():
        x, y = [r["episodes"] for r in rows], [r["test_success"] for r in rows]
        ax.plot(x, y, "o-", label=METHOD_LABELS.get(method, method))
    ax.set_xlabel("training episodes")
    ax.set_ylabel("test success")
    ax.set_ylim(-0.05, 1.05)
    ax.legend(fontsize=FONT)


def episode_distances(axes, ep: dict) -> None:
    """One recorded episode (`viz.record_rollout`'s `episode`: o, ag, g), a column of
    two `axes` (chapter 7's trained policy). Top: the achieved goal's distance to the
    goal and the gripper's distance to the achieved goal against the step, in cm, the 5
    cm of success dashed. Below: the gripper's and the achieved goal's paths seen from
    above, the goal a red star."""
    g_all = np.concatenate([ep["g"], ep["g"][-1:]])  # a goal for each of T + 1 states
    ax = axes[0]
    d_goal = np.linalg.norm(ep["ag"] - g_all, axis=-1) * 100
    ax.plot(d_goal, label="achieved goal to goal")
    d_grip = np.linalg.norm(ep["o"][:, :3] - ep["ag"], axis=-1) * 100
    ax.plot(d_grip, label="gripper to achieved goal")
    ax.axhline(5, color="gray", ls="--")
    ax.set_xlabel("step")
    ax.set_ylabel("cm")
    ax.legend(fontsize=FONT)
    ax = axes[1]
    ax.plot(ep["o"][:, 0], ep["o"][:, 1], ".-", label="gripper")
    ax.plot(ep["ag"][:, 0], ep["ag"][:, 1], "s-", ms=3, label="achieved goal")
    ax.plot(*ep["g"][0, :2], "r*", ms=15, label="goal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    ax.legend(fontsize=FONT)


def r_int_over_training(ax, runs: list[dict], eta: float, demo=None):
    """Chapter 4's mean intrinsic reward over training: one line per run of `runs`
    (`runs.read.load_runs`' dicts, e.g. the Push ACDER seeds) of progress.csv's
    `r_int_mean` against its `episodes`, on a log axis, the clip `eta` dashed; `demo`,
    an (episodes, r_int_mean) pair, marks a short run (the chapter's own) with a star.
    The legend goes under the axes (`legend_below`)."""
    for r in sorted(runs, key=lambda r: str(r["seed"])):
        pts = [
            (row["episodes"], row["r_int_mean"])
            for row in r["rows"]
            if isinstance(row.get("r_int_mean"), float)
        ]
        if pts:
            ax.plot(*zip(*pts), lw=1, label=f"seed {r['seed']}")
    ax.axhline(eta, color="gray", ls="--", lw=0.8, label=rf"$\eta$ = {eta:g}")
    if demo is not None:
        ax.plot(*demo, "k*", ms=10, label="this chapter's run")
    ax.set_yscale("log")
    ax.set_xlabel("training episodes")
    ax.set_ylabel(r"mean $r^i$ of the minibatches")
    ax.grid(alpha=0.3)
    legend_below(ax, ncol=4)
