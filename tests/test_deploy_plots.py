"""Chapter 10's figures (acder_lite.book.deploy_plots) on hand-made benches: every line
and bar carries the counts it was given."""

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from acder_lite.book import deploy_plots as DP  # noqa: E402
from acder_lite.stats.trial_stats import wilson_interval  # noqa: E402

R, P = "FetchReach-v4", "FetchPush-v4"


def bench(env, counts, trials=20):
    """A hand-made `run_bench` result: `counts` {knob: {level: successes}}."""
    from acder_lite.deploy.perturb import KNOBS

    rows = [
        dict(knob=k, level=lvl, unit=KNOBS[k].unit, successes=s, trials=trials,
             nominal=lvl == KNOBS[k].nominal)
        for k, levels in counts.items()
        for lvl, s in levels.items()
    ]  # fmt: skip
    return dict(env=env, trials=trials, rows=rows)


BENCH = {
    (R, "full state"): bench(R, {"action_delay": {0: 20, 1: 20, 2: 18}}),
    (R, "simplified state"): bench(R, {"action_delay": {0: 20, 1: 19, 2: 15}}),
    (P, "full state"): bench(
        P, {"obs_noise": {0: 19, 0.01: 18, 0.02: 7}, "action_delay": {0: 19, 2: 6}}
    ),
    (P, "simplified state"): bench(
        P, {"obs_noise": {0: 20, 0.01: 19, 0.02: 17}, "action_delay": {0: 20, 2: 10}}
    ),
}


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def test_level_panels_a_panel_a_knob_a_line_a_policy():
    fig = DP.level_panels(BENCH)
    shown = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title(loc="left") for ax in shown] == [
        "camera error on the blocks",
        "action delay",
    ]  # in KNOBS' order, only the knobs some bench ran
    noise, delay = shown
    # camera error: Push's two policies only (Reach has no block), x in cm
    assert len(noise.lines) == 3  # two policies and the nominal level
    np.testing.assert_allclose(noise.lines[0].get_xdata(), [0, 1, 2])
    np.testing.assert_allclose(noise.lines[0].get_ydata(), [19 / 20, 18 / 20, 7 / 20])
    np.testing.assert_allclose(noise.lines[1].get_ydata(), [1.0, 19 / 20, 17 / 20])
    assert noise.lines[0].get_linestyle() == "-"  # full state solid
    assert noise.lines[1].get_linestyle() == "--"  # simplified dashed
    assert noise.lines[0].get_color() == noise.lines[1].get_color() == "C1"  # Push
    np.testing.assert_allclose(noise.lines[2].get_xdata(), [0, 0])  # nominal: no error
    # delay: every policy, in the benches' order
    assert len(delay.lines) == 5
    np.testing.assert_allclose(delay.lines[1].get_ydata(), [1.0, 19 / 20, 15 / 20])
    np.testing.assert_allclose(delay.lines[3].get_xdata(), [0, 2])
    np.testing.assert_allclose(delay.lines[3].get_ydata(), [1.0, 0.5])
    assert delay.lines[0].get_color() == "C0"  # Reach


def test_level_panels_factors_on_a_log_axis():
    b = {(P, "full state"): bench(P, {"mass": {0.5: 20, 1.0: 19, 2.0: 18}})}
    (ax,) = [a for a in DP.level_panels(b).axes if a.get_visible()]
    assert ax.get_xscale() == "log"
    np.testing.assert_allclose(ax.lines[0].get_xdata(), [0.5, 1, 2])
    np.testing.assert_allclose(ax.lines[0].get_ydata(), [1.0, 0.95, 0.9])


def test_state_bars_nominal_beside_the_paper_with_intervals():
    fig = DP.state_bars(BENCH, paper={R: 19, P: 16}, paper_trials=20)
    (ax,) = fig.axes  # one panel: no mean over the perturbed levels
    heights = [p.get_height() for p in ax.patches]
    # a task at a time: full state, simplified state, the paper's
    assert heights == pytest.approx([1.0, 1.0, 19 / 20, 19 / 20, 1.0, 16 / 20])
    assert ax.patches[2].get_hatch() == "////"
    # an interval a bar, Wilson's at 95%
    assert len(ax.lines) == 6
    np.testing.assert_allclose(ax.lines[3].get_ydata(), wilson_interval(19, 20))
    np.testing.assert_allclose(ax.lines[5].get_ydata(), wilson_interval(16, 20))


def test_state_bars_without_the_paper():
    fig = DP.state_bars({(P, "full state"): BENCH[P, "full state"]})
    (ax,) = fig.axes
    assert [p.get_height() for p in ax.patches] == pytest.approx([19 / 20])
    np.testing.assert_allclose(ax.lines[0].get_ydata(), wilson_interval(19, 20))
