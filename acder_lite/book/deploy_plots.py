"""Chapter 10's figures: the robustness benches of its policies

`level_panels` draws a policy's success rate against each perturbation's level, a
panel per knob (`perturb.KNOBS`), a line per policy: its task's colour, solid for the
full state and dashed for the simplified state, so the two policies of a task sit side
by side. `state_bars` draws each task's two policies as bars: their success with nothing
perturbed beside the paper's UR5 count, with 95% Wilson intervals. Both take the
benches as `robust.bench_policies` returns them, {(task, column label): `run_bench`
result}, and return a Figure drawn as `plots` draws the book's figures (`plots.WIDTH`
wide at `plots.DPI`).

What the tests read: in `level_panels`, each axes' first lines are its policies' (in
the benches' order, those that ran the knob), x the levels in the panel's unit (camera
errors in cm), y the success rates; the dotted vertical line of the nominal level comes
after them. In `state_bars`, the bars are in `ax.patches`, a task at a time, in the
order full state, simplified state, the paper's; each bar's interval is in `ax.lines`,
in the same order.

Trap: a rate of 1.0 is common; lines that all sit at the top overlap, and the figure's
legend (under the panels) says which is which.
"""

from __future__ import annotations

from acder_lite.book import plots
from acder_lite.book.deploy_report import nominal_successes
from acder_lite.deploy.perturb import KNOBS
from acder_lite.runs.table import TASK_LABELS
from acder_lite.stats.trial_stats import wilson_interval

TASK_COLORS = {
    "FetchReach-v4": "C0",
    "FetchPush-v4": "C1",
    "FetchPickAndPlace-v4": "C2",
}
"""A colour per task, the same in both figures."""
STATE_STYLES = {
    "full state": dict(ls="-", marker="o"),
    "simplified state": dict(ls="--", marker="s"),
}
"""How a column's line is drawn in `level_panels`."""
PANEL_TITLES = {
    "obs_noise": "camera error on the blocks",
    "goal_noise": "camera error on the targets",
    "action_delay": "action delay",
    "action_scale": "action scale",
    "friction": "friction",
    "mass": "block mass",
}
"""Each knob's panel title."""
SCALE = {"m": (100.0, "cm, per axis")}
"""How a knob's unit is shown on its x axis: (factor, label) (metres in cm)."""


def _color(env: str) -> str:
    return TASK_COLORS.get(env) or plots.colors_for([env], {})[env]


def _x_axis(ax, knob: str) -> float:
    """Label `ax`'s x axis in the knob's unit; the factor its levels are drawn at."""
    k = KNOBS[knob]
    factor, unit = SCALE.get(k.unit, (1.0, k.unit))
    if k.unit == "x":  # factors: 0.5 and 2 equally far from 1
        ax.set_xscale("log", base=2)
        unit = "x the simulator's"
    ax.set_xlabel(unit, fontsize=plots.FONT)
    return factor


def level_panels(bench: dict[tuple[str, str], dict]):
    """Success rate against level, a panel per knob any bench ran (in `KNOBS`' order,
    two rows of panels), a line per (task, column) that ran it, the knob's nominal level
    dotted; the legend under the panels. Returns the Figure."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    ran = [
        k
        for k in KNOBS
        if any(r["knob"] == k for b in bench.values() for r in b["rows"])
    ]
    ncols = 3
    nrows = max(1, -(-len(ran) // ncols))
    fig, axes = plt.subplots(
        nrows, ncols, figsize=(plots.WIDTH, 2.3 * nrows + 0.9), dpi=plots.DPI,
        sharey=True, squeeze=False,
    )  # fmt: skip
    for ax, knob in zip(axes.flat, ran):
        factor = _x_axis(ax, knob)
        levels = set()
        for (env, label), res in bench.items():
            rows = [r for r in res["rows"] if r["knob"] == knob]
            if not rows:
                continue
            x = [factor * r["level"] for r in rows]
            y = [r["successes"] / r["trials"] for r in rows]
            levels.update(x)
            style = STATE_STYLES.get(label, dict(ls=":", marker="^"))
            ax.plot(x, y, color=_color(env), ms=4, lw=1.3, alpha=0.85, **style)
        ax.axvline(factor * KNOBS[knob].nominal, color="gray", ls=":", lw=1)
        ax.set_xticks(sorted(levels))
        ax.set_xticklabels([f"{v:g}" for v in sorted(levels)])
        ax.minorticks_off()
        ax.set_title(PANEL_TITLES.get(knob, knob), fontsize=10, loc="left")
        ax.set_ylim(-0.05, 1.05)
        ax.tick_params(labelsize=plots.FONT)
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(ran) :]:
        ax.set_visible(False)
    for row in axes:
        row[0].set_ylabel("success rate")
    envs = list(dict.fromkeys(env for env, _ in bench))
    labels = list(dict.fromkeys(label for _, label in bench))
    tasks = [
        Line2D([], [], color=_color(e), lw=3, label=TASK_LABELS.get(e, e)) for e in envs
    ]
    states = [
        Line2D([], [], color="0.3", label=lab, **STATE_STYLES.get(lab, {}))
        for lab in labels
    ]
    states.append(Line2D([], [], color="gray", ls=":", label="nominal level"))
    _legend_rows(fig, [tasks, states])
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    return fig


def _legend_rows(fig, rows: list[list]) -> None:
    """A legend under the figure with each list of `rows` on a line of its own (the
    legend fills its columns first: the rows are interleaved, blanks padding the short
    ones)."""
    from matplotlib.lines import Line2D

    ncol = max(len(r) for r in rows)
    blank = Line2D([], [], alpha=0, label=" ")
    padded = [r + [blank] * (ncol - len(r)) for r in rows]
    handles = [row[c] for c in range(ncol) for row in padded]
    fig.legend(
        handles=handles,
        loc="lower center",
        ncol=ncol,
        fontsize=plots.FONT,
        frameon=False,
    )


def state_bars(
    bench: dict[tuple[str, str], dict],
    paper: dict[str, int] | None = None,
    paper_trials: int = 20,
):
    """Bars of each policy's success rate with nothing perturbed, a group a task, and,
    hatched, the paper's UR5 count (`paper`: {task: successes} out of `paper_trials`),
    each with its 95% Wilson interval. The full state's bar solid in its task's colour,
    the simplified state's lighter. A mean over the perturbed levels is not drawn: its
    levels replay the same starts, so no binomial interval fits it. Returns the
    Figure."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    paper = paper or {}
    envs = list(dict.fromkeys(env for env, _ in bench))
    labels = [lab for lab in STATE_STYLES if any(lab == b for _, b in bench)]
    labels += [lab for lab in dict.fromkeys(b for _, b in bench) if lab not in labels]
    fig, ax = plt.subplots(figsize=(plots.WIDTH, 3.2), dpi=plots.DPI)
    n = len(labels) + 1  # bars a group, the paper's included
    width = 0.8 / n
    for i, env in enumerate(envs):
        color = _color(env)
        bars = []  # (x, rate, interval, style)
        for j, lab in enumerate(labels):
            res = bench.get((env, lab))
            if res is None:
                continue
            style = dict(color=color, alpha=1.0 if j == 0 else 0.45)
            k, t = nominal_successes(res), res["trials"]
            x = i + (j - (n - 1) / 2) * width
            bars.append((x, k / t, wilson_interval(k, t), style))
        if env in paper:
            k, x = paper[env], i + (n - 1) / 2 * width
            hatch = dict(facecolor="white", edgecolor=color, hatch="////", lw=1)
            bars.append((x, k / paper_trials, wilson_interval(k, paper_trials), hatch))
        for x, rate, ci, style in bars:
            ax.bar(x, rate, 0.9 * width, **style)
            ax.plot([x, x], ci, color="k", lw=1)
    ax.set_xticks(range(len(envs)))
    ax.set_xticklabels([TASK_LABELS.get(e, e) for e in envs], fontsize=plots.FONT)
    ax.set_ylim(0, 1.05)
    ax.set_title(
        "nothing perturbed (95% Wilson intervals)", fontsize=plots.FONT, loc="left"
    )
    ax.grid(axis="y", alpha=0.3)
    ax.tick_params(axis="y", labelsize=plots.FONT)
    ax.set_ylabel("success rate")
    key = [
        Patch(color="0.3", alpha=1.0 if j == 0 else 0.45, label=lab)
        for j, lab in enumerate(labels)
    ]
    if paper:
        key.append(
            Patch(
                facecolor="white",
                edgecolor="0.3",
                hatch="////",
                label="the paper's UR5",
            )
        )
    fig.legend(
        handles=key, loc="lower center", ncol=3, fontsize=plots.FONT, frameon=False
    )
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    return fig
