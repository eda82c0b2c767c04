"""The book's figures (`book.plots`): chapter 7's diagnostics one panel each, the
learning curves' legend keyed, and where each seed's curve ends (so where the mean curve
ends); chapter 4's S-ICM errors against the clip eta; chapters 5, 6, 7 and 9's own
figures; the introduction's Table I bars."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib import colors as mcolors  # noqa: E402

from acder_lite.book import plots  # noqa: E402


def push_run(seed, values, ended, budget=50.0):
    rows = [
        dict(epoch=float(e), episodes=400.0 * e, test_success=v)
        for e, v in enumerate(values, 1)
    ]
    return dict(env="FetchPush-v4", name="acder", seed=seed, rows=rows, ended=ended,
                budget_epochs=budget, episodes_per_epoch=400.0)  # fmt: skip


def test_a_method_without_a_colour_gets_one_no_other_method_of_the_figure_has():
    """`plots.colors_for`: known methods keep `COLORS`; a new one takes a free colour,
    not matplotlib's next, which was another method's."""
    names = ["her", "acder", "mine", "yours"]
    c = plots.colors_for(names)
    assert c["her"] == plots.COLORS["her"] and c["acder"] == plots.COLORS["acder"]
    assert len(set(c.values())) == 4
    many = list(plots.COLORS) + [f"new{i}" for i in range(10)]
    c = plots.colors_for(many)
    assert all(c[n] == plots.COLORS[n] for n in plots.COLORS)
    new = [c[f"new{i}"] for i in range(10)]
    assert len(set(new)) == 10 and not set(new) & set(plots.COLORS.values())
    fig, ax = plt.subplots()
    runs = [dict(push_run(0, [0.5, 1.0], "budget"), name=n) for n in ("her", "mine")]
    plots.plot_mean_curves(ax, runs, "FetchPush-v4", ["her", "mine"])
    drawn = {mcolors.to_hex(ln.get_color()) for ln in ax.get_lines()[:4]}
    assert mcolors.to_hex(plots.COLORS["her"]) in drawn
    assert mcolors.to_hex(plots.colors_for(["her", "mine"])["mine"]) in drawn
    plt.close(fig)


def test_diagnostics_one_panel_each_r_int_on_a_log_axis_with_eta():
    rows = [
        dict(episodes=4.0, r_int_mean=0.03, lambda_mean=1.13, alpha=0.78,
             novel_start_share=0.0),
        dict(episodes=8.0, r_int_mean=2e-4, lambda_mean=1.14, alpha=0.3,
             novel_start_share=0.5),
    ]  # fmt: skip
    fig = plots.plot_diagnostics(rows, eta=0.05)
    axes = fig.axes
    assert len(axes) == 4
    assert [a.get_ylabel() for a in axes] == list(plots.DIAGNOSTICS.values())
    r_int = axes[0]
    assert r_int.get_yscale() == "log"
    np.testing.assert_allclose(r_int.get_lines()[0].get_ydata(), [0.03, 2e-4])
    eta = [ln for ln in r_int.get_lines() if ln.get_linestyle() == "--"]
    assert len(eta) == 1 and eta[0].get_ydata()[0] == 0.05
    assert all(a.get_yscale() == "linear" for a in axes[1:])
    assert axes[1].get_ylim()[0] < 1.0 < 1.5 < axes[1].get_ylim()[1]  # Eq. 6's range
    assert [a.get_xlabel() for a in axes[2:]] == ["training episodes"] * 2
    np.testing.assert_allclose(axes[3].get_lines()[0].get_ydata(), [0.0, 0.5])
    plt.close(fig)


def test_diagnostics_of_a_run_without_them_say_so():
    fig = plots.plot_diagnostics([dict(episodes=4.0, test_success=0.5)], eta=0.05)
    assert all(not a.get_lines() for a in fig.axes)
    assert [t.get_text() for t in fig.axes[0].texts] == ["no r_int_mean"]
    plt.close(fig)


def test_learning_curves_legend_keys_the_threshold_dotted_and_dot():
    runs = [push_run(0, [0.5, 0.9, 1.0], "budget", budget=3.0)]
    fig, ax = plt.subplots()
    plots.plot_learning_curves(ax, runs, "FetchPush-v4", ["acder"], threshold=0.95)
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts == [
        "DDPG+ACDER (1 seed)",
        "95%, the threshold",
        "a stopped seed carried forward",
        "the mean's first crossing of 95%",
    ]
    plt.close(fig)


def test_seed_ends_a_cut_seed_ends_the_mean_curve_a_stopped_one_is_carried():
    """Seed 0 stopped by the stop rule at epoch 2 (carried forward to the budget),
    seed 1 cut at epoch 3: the mean curve ends at epoch 3, the end of the cut seed."""
    from acder_lite.stats import report

    runs = [
        push_run(0, [0.9, 1.0], "stop rule"),
        push_run(1, [0.5, 0.8, 0.9], "cut"),
        push_run(2, [0.2], None),
    ]
    ends = plots.seed_ends(runs[:2], "FetchPush-v4", "acder")
    assert [e["text"] for e in ends] == [
        "seed 0: stop rule at epoch 2",
        "seed 1: cut at epoch 3",
    ]
    assert [e["carried"] for e in ends] == [True, False]
    m = report.learning_curves(runs[:2])[("FetchPush-v4", "acder")]
    last = m.x[~np.isnan(m.mean)][-1]
    assert last == min(e["epoch"] for e in ends if not e["carried"]) == 3.0
    (training,) = plots.seed_ends(runs[2:], "FetchPush-v4", "acder")
    assert training["text"] == "seed 2: still training at epoch 1"
    assert plots.seed_ends(runs, "FetchPush-v4", "her") == []


@pytest.mark.parametrize("threshold", [0.95, 1.0])
def test_key_entries_name_the_threshold(threshold):
    texts = [t for _, t in plots.key_entries(threshold)]
    assert texts[0] == f"{threshold:.0%}, the threshold"


def test_task_panels_name_the_methods_not_run_yet_inside_the_panel():
    """A panel whose title promises methods without runs says which, in its legend; one
    without any runs says only "not run yet"."""
    runs = [push_run(0, [0.5, 0.9, 1.0], "budget", budget=3.0)]
    fig, status = plots.task_panels(
        runs, ("acder", "acder-no-curiosity"), tasks=("FetchPush-v4", "FetchReach-v4")
    )
    push, reach = fig.axes[:2]
    legend = [t.get_text() for t in push.get_legend().get_texts()]
    assert "not run yet: ACDER w/o curiosity" in legend
    assert [t.get_text() for t in reach.texts] == ["not run yet"]
    assert status["FetchPush-v4"]["acder-no-curiosity"] == "not run yet"
    plt.close(fig)


def test_figures_fit_the_column_their_legend_under_the_axes():
    """The package's figures are drawn at the book's column width, with text of at least
    `FONT` points; a learning curve's legend lies under the x label, covering no data,
    in one column when a label is too long for two."""
    runs = [push_run(0, [0.5, 0.9, 1.0], "budget", budget=3.0)]
    fig, _ = plots.task_panels(
        runs, ("acder", "acder-no-curiosity"), tasks=("FetchPush-v4",)
    )
    assert fig.get_figwidth() == plots.WIDTH and fig.dpi == plots.DPI
    fig.canvas.draw()
    ax = fig.axes[0]
    legend = ax.get_legend()
    box = legend.get_window_extent()
    assert box.y1 < ax.xaxis.label.get_window_extent().y0  # under the x label
    assert box.x0 >= 0 and box.x1 <= fig.bbox.x1  # within the figure's width
    assert min(t.get_fontsize() for t in legend.get_texts()) >= plots.FONT
    assert legend._ncols == 2
    plt.close(fig)
    fig = plots.plot_diagnostics([dict(episodes=4.0, r_int_mean=0.03)], eta=0.05)
    assert fig.get_figwidth() == plots.WIDTH and fig.dpi == plots.DPI
    plt.close(fig)
    fig, ax = plt.subplots()
    ax.plot([0, 1], label="a label much too long for half of the figure's width")
    assert plots.legend_below(ax)._ncols == 1
    plt.close(fig)


def test_chance_panel_zooms_to_low_curves_and_draws_the_chance_line():
    """Chapter 9's panel: a dotted line at chance, the y axis zoomed to the data (and a
    note saying so) only while the curves stay far below the threshold."""
    env = "FetchPushMultiStep-v0"

    def run(name, values):
        return dict(push_run(0, values, "budget", budget=3.0), env=env, name=name)

    runs = [run("her", [0.0, 0.02, 0.01]), run("acder", [0.0, 0.0, 0.005])]
    runs.append(run("her-icm", [0.6, 0.6, 0.6]))  # not drawn: not zoomed to
    fig = plots.chance_panel(runs, ("her", "acder"), env, 0.0066, "why", "a title")
    ax = fig.axes[0]
    assert ax.get_ylim() == pytest.approx((0.0, 1.8 * 0.02))
    dotted = [ln for ln in ax.get_lines() if ln.get_linestyle() == ":"]
    assert [tuple(ln.get_ydata()) for ln in dotted] == [(0.0066, 0.0066)]
    assert [t.get_text() for t in ax.texts] == [
        "dotted: chance, 0.66% (why)\ny axis zoomed: the 95% threshold is far above"
    ]
    plt.close(fig)
    fig = plots.chance_panel(runs, ("her", "her-icm"), env, 0.0066, "why")
    ax = fig.axes[0]
    assert ax.get_ylim() == pytest.approx((-0.05, 1.05))  # 1.08 would hide no threshold
    assert [t.get_text() for t in ax.texts] == ["dotted: chance, 0.66% (why)"]
    plt.close(fig)


def test_clip_histogram_shares_of_each_set_the_clipped_errors_in_the_last_bin():
    """Chapter 4's histogram of r^i = clip(error, 0, eta): each set's bars are shares
    (they sum to 1 however large the set), and every error at or above eta lands in
    the last bin, whose share the title states."""
    fam = np.array([[0.01, 0.02], [1.0, 2.0]])  # half of them at or above the clip
    new = np.full(8, 0.01)
    fig, ax = plt.subplots()
    plots.clip_histogram(ax, fam, new, 0.8, "raw")
    first, second = ax.containers  # one BarContainer per set
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["familiar", "new exploration"]
    heights = [np.array([p.get_height() for p in c]) for c in (first, second)]
    assert [h.sum() for h in heights] == pytest.approx([1.0, 1.0])
    assert heights[0][-1] == pytest.approx(0.5) and heights[1][-1] == 0
    assert first[-1].get_x() + first[-1].get_width() == pytest.approx(0.8)
    assert first[0].get_x() == pytest.approx(0.01)  # the smallest error, < eta / 10
    assert ax.get_xscale() == "log"
    assert ax.get_title() == "share at the clip (the last bin): familiar 0.50, new 0.00"
    assert "0.80" in ax.get_xlabel() and "'raw'" in ax.get_xlabel()
    plt.close(fig)


def test_clip_share_curves_a_style_per_input_and_the_paper_etas_dotted():
    etas = np.geomspace(1e-3, 1.0, 5)
    shares = {
        "normalised": {"familiar": np.linspace(1, 0, 5), "new": np.linspace(1, 0.5, 5)},
        "raw": {"familiar": np.zeros(5), "new": np.full(5, 0.1)},
    }
    fig, ax = plt.subplots()
    plots.clip_share_curves(ax, etas, shares, marks=(0.05, 0.8))
    curves = [ln for ln in ax.get_lines() if ln.get_linestyle() != ":"]
    assert [ln.get_label() for ln in curves] == [
        "normalised: familiar",
        "normalised: new",
        "raw: familiar",
        "raw: new",
    ]
    assert [ln.get_linestyle() for ln in curves] == ["-", "-", "--", "--"]
    np.testing.assert_allclose(curves[1].get_ydata(), shares["normalised"]["new"])
    np.testing.assert_allclose(curves[1].get_xdata(), etas)
    dotted = [ln.get_xdata()[0] for ln in ax.get_lines() if ln.get_linestyle() == ":"]
    assert dotted == [0.05, 0.8]
    assert ax.get_xscale() == "log" and ax.get_legend() is not None
    plt.close(fig)


def test_factor_arrows_titles_the_factor_and_the_failed_steps_reward():
    fig, ax = plt.subplots()
    plots.factor_arrows(
        ax, np.array([0.1, 0, 0]), np.array([0, 1.0, 0, 0]), 1.25, -1.25
    )
    assert ax.get_title() == r"$\lambda_r$ = 1.250; a failed step earns -1.250"
    assert ax.get_xlim() == (-1, 1) and ax.get_ylim() == (-1, 1)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["to goal", "action (xy)"]
    plt.close(fig)


def test_alpha_point_marks_eq_9_at_the_success_rate():
    from acder_lite.algo.start_states import novel_start_ratio

    fig, ax = plt.subplots()
    plots.alpha_point(ax, 0.7, 0.5)
    curve, dot = ax.get_lines()
    assert np.allclose(curve.get_ydata()[[0, -1]], [0.7 - 0.5 / (10 * np.e), 0.2])
    assert dot.get_ydata()[0] == novel_start_ratio(0.5, 0.7)
    assert ax.get_title() == rf"$\alpha$ = {novel_start_ratio(0.5, 0.7):.3f}"
    plt.close(fig)


def test_curiosity_losses_a_log_curve_per_input_the_legend_titled_by_the_setting():
    rows = {
        "normalised": [
            dict(cycle=1, curiosity_loss=0.5),
            dict(cycle=2, curiosity_loss=0.2),
        ],
        "raw": [dict(cycle=1, curiosity_loss=1e-3), dict(cycle=2, curiosity_loss=4e-4)],
    }
    fig, ax = plt.subplots()
    plots.curiosity_losses(ax, rows)
    lines = ax.get_lines()
    assert [ln.get_label() for ln in lines] == ["normalised", "raw"]
    np.testing.assert_allclose(lines[1].get_xdata(), [1, 2])
    np.testing.assert_allclose(lines[1].get_ydata(), [1e-3, 4e-4])
    assert ax.get_yscale() == "log" and "Eq. 8" in ax.get_ylabel()
    assert ax.get_legend().get_title().get_text() == "sicm_input"
    plt.close(fig)


def test_error_boxes_a_panel_per_input_its_eta_dashed_the_sets_named_below():
    sets = {
        "normalised": {"familiar": np.array([[0.1, 0.2], [0.3, 0.4]]),
                       "new": np.array([1.0, 2.0, 3.0])},
        "raw": {"familiar": np.array([1e-3, 2e-3]), "new": np.array([0.1, 0.2])},
    }  # fmt: skip
    fig, axes = plt.subplots(2, 1, sharex=True)
    plots.error_boxes(axes, sets, {"normalised": 0.8, "raw": 0.05})
    for ax, eta in zip(axes, (0.8, 0.05)):
        dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        assert [tuple(ln.get_ydata()) for ln in dashed] == [(eta, eta)]
        assert ax.get_yscale() == "log"
    flat = [tuple(ln.get_ydata()) for ln in axes[0].get_lines()]
    assert (0.25, 0.25) in flat and (2.0, 2.0) in flat  # each set's median, raveled
    assert axes[1].get_title(loc="left") == "sicm_input = 'raw'"
    assert [t.get_text() for t in axes[1].get_xticklabels()] == ["familiar", "new"]
    assert axes[0].get_legend() is not None and axes[1].get_legend() is None
    plt.close(fig)


def test_rollout_errors_the_reward_clipped_at_each_eta_and_the_sweep_marked():
    err = {"normalised": np.array([0.1, 2.0, 0.5]), "raw": np.array([1e-3, 1e-2, 0.2])}
    fig, axes = plt.subplots(2, 1, sharex=True)
    plots.rollout_errors(axes, err, {"normalised": 0.8, "raw": 0.05}, explore=2)
    reward = r"$r^i$ (Eq. 4, clipped)"
    norm = {ln.get_label(): ln for ln in axes[0].get_lines()}
    raw = {ln.get_label(): ln for ln in axes[1].get_lines()}
    np.testing.assert_allclose(norm["error"].get_xdata(), [1, 2, 3])
    np.testing.assert_allclose(norm[reward].get_ydata(), [0.1, 0.8, 0.5])
    np.testing.assert_allclose(raw[reward].get_ydata(), [1e-3, 1e-2, 0.05])
    assert list(raw[r"$\eta$"].get_ydata()) == [0.05, 0.05]
    assert list(raw["sweep starts"].get_xdata()) == [2.5, 2.5]
    assert axes[1].get_xlabel() == "step" and axes[1].get_legend() is not None
    plt.close(fig)


def test_alpha_curves_one_curve_an_alpha0_of_the_presets(monkeypatch):
    from acder_lite.config import TASK_PRESETS
    from acder_lite.algo.start_states import novel_start_ratio

    fig, ax = plt.subplots()
    plots.alpha_curves(ax)
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert labels == [
        r"$\alpha_0$ = 0.8 (Reach, Push, Pick&Place)",
        r"$\alpha_0$ = 0.7 (Multi-step Push)",
    ]
    y = ax.get_lines()[1].get_ydata()
    assert y[0] == novel_start_ratio(0.0, 0.7) and y[-1] == novel_start_ratio(1.0, 0.7)
    plt.close(fig)
    # the labels follow the presets, not the paper's numbers written down
    push = dict(TASK_PRESETS["FetchPush-v4"], alpha0=0.6)
    monkeypatch.setitem(TASK_PRESETS, "FetchPush-v4", push)
    fig, ax = plt.subplots()
    plots.alpha_curves(ax, ("FetchReach-v4", "FetchPush-v4"))
    assert [ln.get_label() for ln in ax.get_lines()] == [
        r"$\alpha_0$ = 0.8 (Reach)",
        r"$\alpha_0$ = 0.6 (Push)",
    ]
    plt.close(fig)


def test_factor_curve_the_line_over_the_dots_and_the_corners_dashed():
    """Chapter 5's Eq. 6 on hand-made actions: the rotated action's line, the random
    actions' dots behind it, and under them their histogram with a dashed line at
    each corner's factor, labelled once."""
    from acder_lite.book import factor_report as F

    goal = np.array([0.1, 0.0, 0.0])
    line = F.rotated_actions(goal, azimuth=[-90, 0, 90])
    rand = F.random_actions(goal, 50, np.random.default_rng(0))
    corners = F.corner_factors(goal)
    fig, axes = plt.subplots(2, 1)
    plots.factor_curve(axes, line, rand, corners)
    curve, dots = axes[0].get_lines()
    np.testing.assert_allclose(curve.get_xdata(), [90, 0, 90])
    np.testing.assert_allclose(curve.get_ydata(), [1.25, 1.0, 1.25])
    assert dots.get_linestyle() == "None" and len(dots.get_xdata()) == 50
    assert dots.get_zorder() < curve.get_zorder()  # the dots behind the line
    assert [t.get_text() for t in axes[0].get_legend().get_texts()] == [
        "rotated action",
        "random actions",
    ]
    assert len(axes[1].patches) == 40  # the histogram's bars
    assert sum(p.get_height() for p in axes[1].patches) == 50
    dashed = [ln for ln in axes[1].get_lines() if ln.get_linestyle() == "--"]
    np.testing.assert_allclose([ln.get_xdata()[0] for ln in dashed], corners)
    legend = [t.get_text() for t in axes[1].get_legend().get_texts()]
    assert legend == ["cube-corner directions"]
    assert axes[1].get_xlabel() == r"$\lambda_r$ of uniformly random actions"
    plt.close(fig)


def test_factor_minibatch_draws_the_relabelled_rows_only():
    lam = np.array([1.0, 1.5, 1.1, 1.4])
    r_her = np.array([-1.0, -1.0, 0.0, -1.0])
    r = lam * r_her
    h = np.array([True, False, True, True])  # row 1 was not relabelled
    fig, axes = plt.subplots(2, 1)
    plots.factor_minibatch(axes, lam, r_her, r, h)
    assert sum(p.get_height() for p in axes[0].patches) == 3  # the relabelled rows
    last = axes[0].patches[-1]  # the bins end at 1.4: row 1's 1.5 is left out
    assert last.get_x() + last.get_width() == pytest.approx(1.4)
    (random,) = axes[0].get_lines()
    assert list(random.get_xdata()) == [1.25, 1.25] and random.get_linestyle() == "--"
    her, factor = axes[1].containers  # one set of bars per reward
    assert len(her) == len(factor) == 32  # bins of 0.05 from -1.55 to 0.05
    assert sum(p.get_height() for p in her) == sum(p.get_height() for p in factor) == 3
    # with the factor -1.0, 0 and -1.4 (not row 1's -1.5) on the chapter's bins
    bins = np.linspace(-1.55, 0.05, 33)
    heights = [p.get_height() for p in factor]
    np.testing.assert_array_equal(heights, np.histogram([-1.0, 0.0, -1.4], bins)[0])
    labels = [t.get_text() for t in axes[1].get_legend().get_texts()]
    assert labels == [r"$r$ (HER)", r"$\lambda_r\, r$"]
    plt.close(fig)


def test_factor_against_block_stacks_the_moved_rows_on_a_log_axis():
    f = dict(
        angle=np.array([1.0, 2.0, 100.0, 170.0]),
        moved=np.array([False, False, True, False]),
        lam_goal=np.array([1.0, 1.1, 1.4, 1.2]),
        lam_obj=np.array([1.0, 1.1, 1.2, 1.2]),
    )
    fig, axes = plt.subplots(2, 1)
    plots.factor_against_block(axes, f)
    assert axes[0].get_yscale() == "log" and axes[1].get_yscale() == "linear"
    still, moved = axes[0].containers
    assert len(still) == len(moved) == 36  # bins of 5 degrees from 0 to 180
    assert [p.get_height() for p in still][:1] == [2] and still[34].get_height() == 1
    # stacked: the moved row's bar (100 deg, bin 20) sits on the still rows' count
    assert moved[20].get_height() == 1 and moved[0].get_height() == 0
    assert moved[34].get_y() == still[34].get_height()
    labels = [t.get_text() for t in axes[0].get_legend().get_texts()]
    assert labels == ["block still at the goal's step", "block moved"]
    dots, diagonal = axes[1].get_lines()
    np.testing.assert_allclose(dots.get_xdata(), f["lam_obj"])
    np.testing.assert_allclose(dots.get_ydata(), f["lam_goal"])
    assert list(diagonal.get_xdata()) == list(diagonal.get_ydata()) == [1, 1.5]
    assert axes[1].get_ylabel() == r"$\lambda_r$ (Eq. 6, used)"
    plt.close(fig)


def test_the_band_is_one_std_either_side_of_the_mean_of_two_seeds():
    """Seeds at 0.5, 0.9 and 0.9, 1.0: mean 0.7, 0.95 and std 0.2, 0.05, so the band
    runs from 0.5 to 0.9 at epoch 1 and from 0.9 to 1.0 at epoch 2 (two seeds are
    enough for a band)."""
    runs = [
        push_run(0, [0.5, 0.9], "budget", 2.0),
        push_run(1, [0.9, 1.0], "budget", 2.0),
    ]
    fig, ax = plt.subplots()
    plots.plot_mean_curves(ax, runs, "FetchPush-v4", ["acder"])
    (band,) = ax.collections
    xy = np.concatenate([p.vertices for p in band.get_paths()])
    edges = [(xy[xy[:, 0] == e, 1].min(), xy[xy[:, 0] == e, 1].max()) for e in (1, 2)]
    np.testing.assert_allclose(edges, [(0.5, 0.9), (0.9, 1.0)])
    plt.close(fig)


def test_the_carried_part_is_dotted_on_from_the_last_evaluation():
    """Seed 0 stopped by the stop rule after epoch 2, seed 1 evaluated to epoch 4: the
    mean (0.7, 0.9 at epochs 1, 2) is solid to epoch 2 and dotted from that point on,
    with no gap; it crosses 0.8 halfway between epochs 1 and 2, where the dot sits on
    the threshold."""
    runs = [
        push_run(0, [0.9, 1.0], "stop rule", budget=4.0),
        push_run(1, [0.5, 0.8, 0.9, 1.0], "budget", budget=4.0),
    ]
    from acder_lite.stats import report

    m = report.learning_curves(runs)
    fig, ax = plt.subplots()
    hit = plots.draw_mean(ax, m[("FetchPush-v4", "acder")], 0.8, "C4", "acder")
    solid, dotted, dot = ax.get_lines()
    np.testing.assert_allclose(solid.get_xydata(), [[1.0, 0.7], [2.0, 0.9]])
    assert dotted.get_linestyle() == ":"
    np.testing.assert_allclose(dotted.get_xdata(), [2.0, 3.0, 4.0])
    np.testing.assert_allclose(dotted.get_xydata()[0], [2.0, 0.9])
    assert hit == pytest.approx(1.5)
    np.testing.assert_allclose(dot.get_xydata(), [[1.5, 0.8]])
    plt.close(fig)


def test_view_limit_is_a_quarter_past_the_last_evaluation_at_most_the_budget():
    """Last evaluations at epochs 6 and 8 of a 50-epoch budget: 1.25 x 8 = 10; a run
    evaluated to epoch 48 is held to the budget, 50; no runs: the task's budget."""
    runs = [
        push_run(0, [0.1] * 6, None, budget=50.0),
        push_run(1, [0.1] * 8, None, budget=50.0),
    ]
    assert plots.view_limit(runs, "FetchPush-v4", ["acder"]) == pytest.approx(10.0)
    runs.append(push_run(2, [0.1] * 48, None, budget=50.0))
    assert plots.view_limit(runs, "FetchPush-v4", ["acder"]) == 50.0
    assert plots.view_limit([], "FetchPush-v4", ["acder"]) == 50.0


def test_seed_column_draws_a_line_a_seed_and_names_each_method_once():
    """Two seeds of one method: two lines of their own values, one legend entry."""
    runs = [push_run(0, [0.1, 0.2], None), push_run(1, [0.3, 0.4], None)]
    fig, ax = plt.subplots()
    drawn = plots.plot_seed_column(
        ax, runs, "FetchPush-v4", ["acder"], "test_success", "test success"
    )
    assert drawn == 2
    np.testing.assert_allclose(ax.lines[1].get_xydata(), [[1.0, 0.3], [2.0, 0.4]])
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["DDPG+ACDER"]
    plt.close(fig)


def test_the_legend_counts_the_seeds_still_training():
    """Three seeds, one ended: '3 seeds, 2 unfinished'."""
    runs = [push_run(0, [0.5], "budget"), push_run(1, [0.5], None)]
    runs.append(push_run(2, [0.5], None))
    fig, ax = plt.subplots()
    plots.plot_mean_curves(ax, runs, "FetchPush-v4", ["acder"])
    assert ax.lines[0].get_label() == "DDPG+ACDER (3 seeds, 2 unfinished)"
    plt.close(fig)


def test_clip_histogram_title_counts_an_error_exactly_at_the_clip():
    """Errors 0.01, 0.8, 0.8, 2.0 against eta = 0.8: three of four are at or above the
    clip (the last bin holds them), so the title says 0.75."""
    fig, ax = plt.subplots()
    plots.clip_histogram(
        ax, np.array([0.01, 0.8, 0.8, 2.0]), np.full(2, 0.8), 0.8, "raw"
    )
    first, second = ax.containers
    assert first[-1].get_height() == pytest.approx(0.75)
    assert ax.get_title().endswith("familiar 0.75, new 1.00")
    plt.close(fig)


def test_factor_arrows_point_to_the_goal_in_any_direction():
    """The red arrow is the goal's xy direction at length 0.8 (the unit action's
    length), wherever the goal lies: (0, -0.3) gives (0, -0.8), (0.1, 0) (0.8, 0); a
    goal straight above has no xy direction, and no arrow."""
    from acder_lite.book.plots import factor_arrows

    cases = (((0.0, -0.3, 0.0), (0.0, -0.8)), ((0.1, 0.0, 0.0), (0.8, 0.0)))
    for goal, tip in cases + (((0.0, 0.0, 0.2), (0.0, 0.0)),):  # above: no arrow
        fig, ax = plt.subplots()
        factor_arrows(ax, np.array(goal), np.array([1.0, 0, 0]), 1.0, -1.0)
        red = ax.patches[0]
        assert red.get_label() == "to goal"
        np.testing.assert_allclose(red._dx, tip[0], atol=1e-12)
        np.testing.assert_allclose(red._dy, tip[1], atol=1e-12)
        plt.close(fig)


def fake_cell(env, name, crossing=None, low=None, high=None, why="", **kw):
    """A Table I cell as `report.cell_stat` leaves it (epochs), made by hand."""
    from acder_lite.stats.report import CellStat

    c = CellStat(env, name, name, 0.95, crossing=crossing, low=low, high=high, why=why)
    for k, v in dict(dict(budget_epochs=50.0, n=3, done=3), **kw).items():
        setattr(c, k, v)
    return c


def test_table_bars_ours_beside_the_papers_a_bound_open_with_an_arrow():
    """Table I as bars (`plots.table_bars`) from a small fake table: a crossing is a
    filled bar in Table I's unit (400 episodes an epoch) with its 95% interval, beside
    the paper's hatched; a mean curve that did not cross within its budget is an open
    bar to the budget with an arrow (a lower bound, its interval open above); a cell
    still training draws its reason, not a bar."""
    from matplotlib.text import Annotation

    P, PP = "FetchPush-v4", "FetchPickAndPlace-v4"
    inf = float("inf")
    cells = [
        fake_cell(P, "her", 27.0, 22.0, 28.0, paper=11600),
        fake_cell(P, "acder", 14.0, 10.0, 16.0, paper=2200),
        fake_cell(PP, "her", None, 61.0, inf, "not within budget", budget_epochs=100.0,
                  paper=33600),
        fake_cell(PP, "acder", None, why="not yet", paper=5200, unfinished=1),
    ]  # fmt: skip
    fig, bars = plots.table_bars(cells, methods=("her", "acder"), tasks=(P, PP))
    assert bars[P]["her"] == dict(
        value=10800.0, bound=False, low=8800.0, high=11200.0, paper=11600, why=""
    )
    assert bars[PP]["her"] == dict(
        value=40000.0, bound=True, low=24400.0, high=None, paper=33600, why=""
    )
    assert bars[PP]["acder"]["value"] is None and bars[PP]["acder"]["why"] == "not yet"
    push, pick = fig.axes[:2]
    assert [ax.get_title(loc="left") for ax in (push, pick)] == [
        "Push (95%)",
        "Pick&Place (95%)",
    ]

    def bars_of(ax):  # (height, filled, hatched) of each bar
        return sorted(
            (round(p.get_height()), p.get_facecolor()[3] > 0 and not p.get_hatch(),
             bool(p.get_hatch()))
            for p in ax.patches
        )  # fmt: skip

    assert bars_of(push) == [
        (2200, False, True), (5600, True, False), (10800, True, False),
        (11600, False, True),
    ]  # fmt: skip
    # the bound: an open bar (no fill) to the budget, an arrow on top; the paper's two
    assert bars_of(pick) == [(5200, False, True), (33600, False, True),
                             (40000, False, False)]  # fmt: skip
    arrows = [t for t in pick.texts if isinstance(t, Annotation)]
    assert len(arrows) == 1 and arrows[0].xy[1] > 40000
    assert not [t for t in push.texts if isinstance(t, Annotation)]
    assert "not yet" in [t.get_text() for t in pick.texts]
    # the intervals, one vertical segment each
    spans = sorted(
        tuple(np.round(ln.get_ydata()).tolist())
        for ax in (push, pick)
        for ln in ax.get_lines()
        if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == ln.get_xdata()[1]
    )
    assert spans == [(4000, 6400), (8800, 11200), (24400, 40000)]
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "the paper's" in legend and "95% bootstrap interval" in legend
    assert "Table I's unit" in push.get_ylabel() and pick.get_ylabel() == ""
    plt.close(fig)


def test_r_int_over_training_a_line_per_seed_skips_missing_values_marks_the_demo():
    """One line per run, by seed, of r_int_mean against episodes (a row without the
    column, e.g. a first evaluation before any update, is left out), the clip eta as
    a dashed line, and the chapter's own short run as a star."""
    runs = [
        {"seed": 1, "rows": [{"episodes": 400, "r_int_mean": 0.01}]},
        {
            "seed": 0,
            "rows": [
                {"episodes": 400, "r_int_mean": 0.012},
                {"episodes": 800, "r_int_mean": None},
                {"episodes": 1200, "r_int_mean": 0.15},
            ],
        },
    ]
    fig, ax = plt.subplots()
    plots.r_int_over_training(ax, runs, eta=0.8, demo=(64, 0.002))
    seed0, seed1, eta, demo = ax.lines
    assert seed0.get_label() == "seed 0" and list(seed0.get_xdata()) == [400, 1200]
    assert list(seed0.get_ydata()) == [0.012, 0.15]
    assert seed1.get_label() == "seed 1"
    assert list(eta.get_ydata()) == [0.8, 0.8] and eta.get_linestyle() == "--"
    assert list(demo.get_xdata()) == [64] and demo.get_marker() == "*"
    assert ax.get_yscale() == "log"
    plt.close(fig)


def multistep_rows(n, extra=True):
    rows = []
    for e in range(1, n + 1):
        r = dict(epoch=float(e), episodes=400.0 * e, test_success=0.01 * e)
        if extra:
            r.update(block0_on_target=0.1 * e, block1_on_target=0.05 * e,
                     block0_moved=0.2, block1_moved=0.3,
                     pool_block_on_target=float("nan") if e == 1 else 0.4)  # fmt: skip
        rows.append(r)
    return rows


def test_block_panels_two_panels_with_the_block_columns_one_without():
    """Chapter 9's figure: with progress.csv's per-block columns, a top panel (both
    blocks, each block on its target, the chance levels dotted, the rule dashed, the
    40-epoch run thin) and a bottom one (each block moved, the start pool's share with a
    block on its target); a run recorded before those columns existed gets the top only,
    and nothing is drawn for a column it lacks."""
    run = dict(rows=multistep_rows(3))
    short = dict(rows=multistep_rows(2, extra=False))
    fig = plots.block_panels(run, 0.02, each_chance=(0.1, 0.12), short=short,
                             level=0.1, title="in flight")  # fmt: skip
    top, bottom = fig.axes
    labels = [ln.get_label() for ln in top.get_lines()]
    assert labels[:3] == ["both blocks (test success)", "block 0 on its target",
                          "block 1 on its target"]  # fmt: skip
    dotted = [ln for ln in top.get_lines() if ln.get_linestyle() == ":"]
    assert sorted(ln.get_ydata()[0] for ln in dotted) == [0.02, 0.1, 0.12]
    assert "the 40-epoch run, both" in labels and "rule: 10%" in labels
    np.testing.assert_allclose(top.get_lines()[0].get_ydata(), [0.01, 0.02, 0.03])
    assert top.get_title(loc="left") == "in flight"
    low = {ln.get_label(): ln for ln in bottom.get_lines()}
    assert set(low) == {"block 0 moved (test)", "block 1 moved (test)",
                        "start pool: a block on its target"}  # fmt: skip
    assert np.isnan(low["start pool: a block on its target"].get_ydata()[0])
    plt.close(fig)
    fig = plots.block_panels(dict(rows=multistep_rows(3, extra=False)), 0.02)
    (only,) = fig.axes
    labels = [ln.get_label() for ln in only.get_lines()]
    assert not any("block 0" in s or "block 1" in s or "rule" in s for s in labels)
    assert only.get_xlim()[1] == 3
    plt.close(fig)


def test_sicm_error_histograms_the_successful_rows_only_and_eta_dashed():
    """One panel per S-ICM input: the errors of the successful rows only, on log bins
    that reach past eta, eta as a red dashed line; an input without a successful row
    still gets its panel and its eta."""
    errs = {
        "state": dict(err=np.array([1e-3, 1e-2, 5.0, 7.0]),
                      successful=np.array([True, True, False, True]), eta=0.05),
        "sincos": dict(err=np.array([0.5]), successful=np.array([False]), eta=0.8),
    }  # fmt: skip
    fig, axes = plt.subplots(2, 1)
    plots.sicm_error_histograms(axes, errs)
    heights = [p.get_height() for p in axes[0].patches]
    assert sum(heights) == 3  # the unsuccessful 5.0 is left out
    assert axes[0].get_xscale() == "log" and not axes[1].patches
    for ax, eta in zip(axes, (0.05, 0.8)):
        (line,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        assert list(line.get_xdata()) == [eta, eta]
    assert "'sincos'" in axes[1].get_title(loc="left")
    assert "before the clip" in axes[1].get_xlabel()
    plt.close(fig)


def test_start_share_curves_a_line_per_column_against_episodes():
    rows = [
        dict(episodes=50.0, test_success=0.1, alpha=0.8, novel_start_share=0.0),
        dict(episodes=100.0, test_success=0.4, alpha=0.5, novel_start_share=0.3),
    ]
    fig, ax = plt.subplots()
    plots.start_share_curves(ax, rows)
    lines = ax.get_lines()
    assert [ln.get_label() for ln in lines] == [c[2] for c in plots.START_SHARE_COLUMNS]
    for ln, (key, _, _) in zip(lines, plots.START_SHARE_COLUMNS):
        assert list(ln.get_xdata()) == [50.0, 100.0]
        assert list(ln.get_ydata()) == [r[key] for r in rows]
    assert ax.get_xlabel() == "training episodes"
    plt.close(fig)


def test_pool_map_colours_candidates_oldest_to_newest_and_marks_the_reset():
    gripper = np.array([[1.0, 0.5, 0.4], [1.2, 0.7, 0.4], [1.3, 0.8, 0.5]])
    fig, ax = plt.subplots()
    plots.pool_map(ax, gripper, start=np.array([1.34, 0.75, 0.53]))
    (sc,) = ax.collections
    np.testing.assert_allclose(sc.get_offsets(), gripper[:, :2])
    assert list(sc.get_array()) == [0, 1, 2]
    (cross,) = ax.get_lines()
    assert cross.get_marker() == "+" and list(cross.get_xdata()) == [1.34]
    assert len(fig.axes) == 2  # the colour bar
    plt.close(fig)


def test_live_success_labels_methods_as_the_paper_names_them():
    live = {
        "her": [
            dict(episodes=10.0, test_success=0.0),
            dict(episodes=20.0, test_success=0.5),
        ],
        "mine": [dict(episodes=10.0, test_success=0.2)],
    }
    fig, ax = plt.subplots()
    plots.live_success(ax, live)
    her, mine = ax.get_lines()
    assert her.get_label() == plots.METHOD_LABELS["her"] != "her"
    assert mine.get_label() == "mine"
    assert list(her.get_ydata()) == [0.0, 0.5] and ax.get_ylim() == (-0.05, 1.05)
    plt.close(fig)


def test_episode_distances_in_cm_against_the_goal_of_each_state():
    """T = 2 steps give 3 states; the last state is measured against the last goal.
    The achieved goal starts 10 cm from the goal and ends on it; the gripper starts 3 cm
    from the block."""
    ag = np.array([[1.0, 0.0, 0.4], [1.05, 0.0, 0.4], [1.1, 0.0, 0.4]])
    o = np.zeros((3, 10))
    o[:, :3] = ag + np.array([0.0, 0.03, 0.0])
    g = np.array([[1.1, 0.0, 0.4], [1.1, 0.0, 0.4]])
    fig, axes = plt.subplots(2, 1)
    plots.episode_distances(axes, dict(o=o, ag=ag, g=g))
    d_goal, d_grip, five = axes[0].get_lines()
    np.testing.assert_allclose(d_goal.get_ydata(), [10.0, 5.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(d_grip.get_ydata(), [3.0, 3.0, 3.0], atol=1e-9)
    assert list(five.get_ydata()) == [5, 5]
    star = axes[1].get_lines()[-1]
    assert star.get_marker() == "*" and list(star.get_xdata()) == [1.1]
    plt.close(fig)
