"""Table I's statistic: where the mean test-success curve over seeds first
crosses the threshold.

Pure functions on arrays and on the rows of progress.csv; reading run folders is `runs`,
printing is `table`. The statistic (departure 29):

1. each seed's curve is its test success at its evaluations (protocol v2: once per
   epoch), on an axis of epochs; a seed that ended by the stop rule carries the mean of
   its last `CARRY_EVALUATIONS` evaluations forward to the budget (`carry_forward`);
2. the mean curve over seeds is taken where every seed has a value, linearly
   interpolated between evaluations, and read at its first crossing of the threshold
   (`first_crossing`);
3. the crossing is reported in Table I's unit, 400 episodes an epoch on every task
   (`PAPER_EPISODES_PER_EPOCH`), and in our own episodes (on FetchReach our epochs hold
   80);
4. a 95% bootstrap interval over seeds resamples the seeds with replacement and reads
   each resample's mean curve the same way (`bootstrap_crossings`, `interval`);
5. beside it, each seed's own first crossing, summarised by median, range and mean
   (`seed_summary`).

Traps:
- A crossing is never interpolated from a point before the first evaluation: there is no
  evaluation at epoch 0, and a curve already at the threshold at its first evaluation
  crosses there (a Push curve at 0.97 after epoch 1 crosses at 1.0 epoch, not 0.98).
- Success rates are means of 0/1 outcomes: 1.0 may arrive as 0.9999999999, so a value
  counts as reaching the threshold within `SUCCESS_TOL`.
- Where a seed is missing (still training, or cut short before its budget under protocol
  v1) the mean curve is undefined, not the mean of the others: a curve with fewer seeds
  can jump.
- A resample whose mean curve never crosses has no number. It is ranked after every
  crossing, so the interval's upper end is "beyond the budget" (`math.inf`) once more
  than 2.5% of the resamples never cross; `share_crossing` says how many did.
- With 3 seeds there are only 10 distinct resamples: the interval is coarse, and the
  percentile bootstrap covers less than 95% for few seeds (`bootstrap_coverage` measures
  it on a synthetic case: about 74% at 3 seeds, 85% at 5, 94% at 20).
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field, fields

import numpy as np

from acder_lite.config import OBJECT_ENVS, TASK_PRESETS
from acder_lite.io import json_ready

TASKS = ("FetchReach-v4", "FetchPush-v4", "FetchPickAndPlace-v4")
"""The paper's three tasks, in the column order of Table I."""

FIG4_METHODS = ("her", "her-icm", "her-per", "her-ebp", "acder")
"""The five methods of Table I and Fig. 4."""

ABLATIONS = ("acder-no-curiosity", "acder-no-goal-factor", "acder-no-start-states")
"""The three ablations of Fig. 5."""

GRID_METHODS = FIG4_METHODS + ABLATIONS
"""Every method of the reproduction grid (results/plan.toml);
her-ebp only on tasks with an object."""

PAPER_TABLE_I: dict[str, dict[str, int | None]] = {
    "her": {
        "FetchReach-v4": 2240,
        "FetchPush-v4": 11600,
        "FetchPickAndPlace-v4": 33600,
    },
    "her-icm": {
        "FetchReach-v4": 2400,
        "FetchPush-v4": 9800,
        "FetchPickAndPlace-v4": 29800,
    },
    "her-per": {
        "FetchReach-v4": 1440,
        "FetchPush-v4": 7800,
        "FetchPickAndPlace-v4": 17400,
    },
    "her-ebp": {
        "FetchReach-v4": None,
        "FetchPush-v4": 7200,
        "FetchPickAndPlace-v4": 17200,
    },
    "acder": {"FetchReach-v4": 400, "FetchPush-v4": 2200, "FetchPickAndPlace-v4": 5200},
}
"""Table I: episodes until the threshold, per method (our names) and task;
None is the paper's '–'."""

PAPER_EPISODES_PER_EPOCH = 400
"""Table I's unit: 4 workers x 100 episodes an epoch, on every task (section V-B)."""


def paper_epochs(env: str, per_epoch: float = PAPER_EPISODES_PER_EPOCH) -> dict:
    """Table I's numbers on `env` in epochs of `per_epoch` episodes, by method (those
    with a number). Trap: on Reach (threshold 100%) a mean curve reaches the threshold
    only at an evaluation, so our reading gives whole epochs there, and some of these
    are not."""
    return {m: v[env] / per_epoch for m, v in PAPER_TABLE_I.items() if v.get(env)}


CARRY_EVALUATIONS = 5
"""A seed stopped by the stop rule carries the mean of this many last
evaluations forward."""

TAIL_EVALUATIONS = 5
"""How many of a seed's last evaluations `column_tail` averages by default: where a
diagnostic (the mean r_i, the critic's Q) ends, not where it started."""

SUCCESS_TOL = 1e-9
"""Slack when comparing a success rate with a threshold
(a mean of ones may be 0.9999999999)."""

CUT_WHY = "not before a seed's curve was cut"
"""`CellStat.why` of a cell whose mean curve ends, uncrossed, where a seed's curve was
cut before its budget (protocol v1)."""

BOOTSTRAP_RESAMPLES = 2000
"""Resamples of the seeds per interval."""

LEVEL = 0.95
"""Coverage the bootstrap interval aims at."""


def grid_cells(tasks=TASKS, methods=GRID_METHODS) -> list[tuple[str, str]]:
    """(env, method) of every cell of the grid, in table order;
    her-ebp only where there is an object."""
    return [
        (e, m)
        for e in tasks
        for m in methods
        if not (m == "her-ebp" and e not in OBJECT_ENVS)
    ]


def threshold(env: str) -> float:
    """The test success Table I counts to on `env` (one source:
    `config.TASK_PRESETS`)."""
    return float(TASK_PRESETS[env]["success_threshold"])


def paper_ratio(env: str) -> float | None:
    """Table I's HER / ACDER episodes on `env`."""
    h, a = PAPER_TABLE_I["her"].get(env), PAPER_TABLE_I["acder"].get(env)
    return h / a if h and a else None


def episodes_to_threshold(rows: list[dict], threshold: float) -> float | None:
    """The first `episodes` value (in row order) at which `test_success` >=
    threshold; None if never.

    One seed's first evaluation at or above the threshold, without interpolation. The
    trainer's protocol-v1 gap rule (`Config.stop_gap_episodes`) counts from it; Table
    I's statistic is `first_crossing` of the mean curve instead.
    """
    for row in rows:
        s = row.get("test_success")
        if (
            isinstance(s, (int, float))
            and not math.isnan(s)
            and s >= threshold - SUCCESS_TOL
        ):
            return float(row["episodes"])
    return None


def first_crossing(x, y, threshold: float) -> float | None:
    """The first x at which the piecewise-linear curve through (x,
    y) reaches `threshold`.

    NaN values of y are gaps: a crossing right after a gap is read at the point itself,
    as is one at the first point (no interpolation from before the first evaluation).
    None if the curve never gets there.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    hit = crossings(x, y[None, :], threshold)[0]
    return None if math.isinf(hit) else float(hit)


def crossings(x: np.ndarray, Y: np.ndarray, threshold: float) -> np.ndarray:
    """`first_crossing` of every row of Y (curves on the common axis x);
    inf where none crosses."""
    Y = np.asarray(Y, dtype=float)
    if Y.shape[-1] == 0:
        return np.full(Y.shape[:-1], np.inf)
    hit = Y >= threshold - SUCCESS_TOL  # NaN compares False
    j = np.argmax(hit, axis=-1)
    any_hit = hit.any(axis=-1)
    prev = np.maximum(j - 1, 0)
    y0 = np.take_along_axis(Y, prev[..., None], -1)[..., 0]
    y1 = np.take_along_axis(Y, j[..., None], -1)[..., 0]
    at_point = (j == 0) | np.isnan(y0)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.clip((threshold - y0) / (y1 - y0), 0.0, 1.0)
    frac = np.where(at_point | ~np.isfinite(frac), 1.0, frac)
    out = x[prev] + frac * (x[j] - x[prev])
    return np.where(any_hit, out, np.inf)


def carry_forward(x, y, budget: float, n: int | None = None):
    """A curve stopped before `budget`, extended at its evaluation spacing with the mean
    of its last `n` values (default `CARRY_EVALUATIONS`, read at call time). Returns
    (x, y, carried), carried True on the added points.

    Trap: `n` must not exceed the stop rule's patience (`Config.stop_patience`, 5). A
    stopped seed held the threshold at its last `patience` evaluations only, so a mean
    over more of them takes in evaluations from before it got there and can carry a
    level below the threshold: with n = 10 Push's HER and ACDER cells would never
    cross."""
    n = CARRY_EVALUATIONS if n is None else n
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    carried = np.zeros(len(x), dtype=bool)
    if not len(x) or budget is None or x[-1] >= budget - 1e-9:
        return x, y, carried
    step = x[-1] - x[-2] if len(x) > 1 else x[-1]
    k = int(math.floor((budget - x[-1]) / step + 1e-6)) if step > 0 else 0
    extra = np.round(x[-1] + step * np.arange(1, k + 1), 9)
    if not len(extra) or extra[-1] < budget - 1e-9:
        extra = np.append(extra, budget)
    value = float(np.nanmean(y[-n:]))
    return (
        np.concatenate([x, extra]),
        np.concatenate([y, np.full(len(extra), value)]),
        np.concatenate([carried, np.ones(len(extra), dtype=bool)]),
    )


@dataclass
class SeedCurve:
    """One seed's test success against epochs, as the mean curve uses it."""

    x: np.ndarray
    """Epochs at the evaluations (and at the carried points)."""
    y: np.ndarray
    carried: np.ndarray
    """True where the value is carried forward, not evaluated."""
    ended: str | None
    """How the run ended: None (no done.json: training or interrupted), 'stop rule',
    'budget' or 'cut' (ended before its budget otherwise: protocol v1's gap rule, or a
    resume with fewer epochs)."""


def seed_curve(
    rows: list[dict],
    ended: str | None,
    budget_epochs: float | None,
    episodes_per_epoch: float | None = None,
) -> SeedCurve:
    """A seed's curve from its progress.csv rows (`epoch` and `test_success`; without an
    `epoch` column, `episodes / episodes_per_epoch`). Rows without a success value are
    dropped; a seed stopped by the stop rule is carried forward to `budget_epochs`."""
    pts = []
    for r in rows:
        s = r.get("test_success")
        if not isinstance(s, float) or math.isnan(s):
            continue
        ep = r.get("epoch")
        if not isinstance(ep, float):
            ep = r["episodes"] / episodes_per_epoch if episodes_per_epoch else None
        if ep is not None:
            pts.append((round(ep, 9), s))
    pts.sort(key=lambda p: p[0])
    x = np.array([p[0] for p in pts], dtype=float)
    y = np.array([p[1] for p in pts], dtype=float)
    carried = np.zeros(len(x), dtype=bool)
    if ended == "stop rule" and budget_epochs:
        x, y, carried = carry_forward(x, y, budget_epochs)
    return SeedCurve(x, y, carried, ended)


def made_up_seed(values: list[float], ended: str | None, budget: float = 12):
    """A made-up seed's curve (`seed_curve`) from its test success at epochs 1, 2, ...
    (400 episodes an epoch), as chapter 8 draws the reading of Table I; a seed
    `ended` by the "stop rule" is carried forward to `budget` epochs."""
    rows = [
        dict(epoch=float(e), episodes=400.0 * e, test_success=v)
        for e, v in enumerate(values, 1)
    ]
    return seed_curve(rows, ended, budget)


def on_grid(curves: list[SeedCurve]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The seeds on one axis, the union of their points: (x, Y, C), Y[i] seed i linearly
    interpolated inside its own range and NaN outside it, C[i] True where that value is
    carried."""
    curves = [c for c in curves if len(c.x)]
    if not curves:
        return np.zeros(0), np.zeros((0, 0)), np.zeros((0, 0), dtype=bool)
    x = np.unique(np.concatenate([c.x for c in curves]))
    Y = np.full((len(curves), len(x)), np.nan)
    C = np.zeros((len(curves), len(x)), dtype=bool)
    for i, c in enumerate(curves):
        inside = (x >= c.x[0]) & (x <= c.x[-1])
        Y[i, inside] = np.interp(x[inside], c.x, c.y)
        if c.carried.any():
            C[i, inside] = x[inside] > c.x[~c.carried][-1]
    return x, Y, C


def seed_level(n: int, threshold: float) -> float:
    """The level every one of n seeds (each at most 1) must be at for their mean to
    reach `threshold`: 1 - n (1 - threshold)."""
    return 1 - n * (1 - threshold)


def earliest_crossing(curves: list[SeedCurve], n: int, threshold: float) -> float:
    """The earliest epoch at which the mean curve of `n` seeds can still reach
    `threshold`, given `curves`, the seeds read so far (finished or not; n >=
    len(curves), the rest not started).

    A mean of n values of at most 1 reaches the threshold only where every seed is at
    the level 1 - n (1 - threshold) or above, so not before the latest of the seeds'
    first crossings of that level. A seed still training that has not reached it counts
    with its last evaluation (it may reach it right after); one that ended without
    reaching it leaves no crossing at all (inf). 0 while no seed has an evaluation.
    Trap: this bounds the mean curve only; a bootstrap resample that repeats the fast
    seeds can cross earlier."""
    level = seed_level(n, threshold)
    bound = 0.0
    for s in curves:
        if not len(s.x):
            continue
        hit = first_crossing(s.x, s.y, level)
        if hit is None:
            hit = math.inf if s.ended is not None else float(s.x[-1])
        bound = max(bound, hit)
    return bound


@dataclass
class MeanCurve:
    """The mean over seeds where every seed has a value (elsewhere NaN)."""

    x: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    """One standard deviation over the seeds (ddof=0), the band of Fig. 4."""
    carried: np.ndarray
    """True where at least one seed's value is carried forward (Fig.
    4 draws it dotted)."""
    n: int
    """Seeds in the mean."""


def mean_curve(curves: list[SeedCurve]) -> MeanCurve:
    """The mean curve of `curves` (see `on_grid`); NaN wherever a seed has no value."""
    x, Y, C = on_grid(curves)
    if not len(x):
        return MeanCurve(x, x.copy(), x.copy(), np.zeros(0, dtype=bool), 0)
    return MeanCurve(x, Y.mean(axis=0), Y.std(axis=0), C.any(axis=0), len(Y))


def cell_seed(key: str) -> int:
    """A bootstrap seed per cell, stable across runs of the program
    (Python's hash() is not).

    Trap: one seed for every cell would draw the same resample indices for HER and
    ACDER, and their bootstrap ratio would pair resample i of one with the same pattern
    of the other."""
    return zlib.crc32(key.encode())


def bootstrap_crossings(
    curves: list[SeedCurve],
    threshold: float,
    n_boot: int = BOOTSTRAP_RESAMPLES,
    seed: int = 0,
) -> np.ndarray:
    """The mean-curve crossing of `n_boot` resamples of the seeds (with replacement, as
    many as there are); inf where a resample's mean curve does not cross. Deterministic
    in `seed`."""
    x, Y, _ = on_grid(curves)
    if not len(Y):
        return np.full(n_boot, np.inf)
    idx = np.random.default_rng(seed).integers(0, len(Y), size=(n_boot, len(Y)))
    return crossings(x, Y[idx].mean(axis=1), threshold)


def interval(boot: np.ndarray, level: float = LEVEL) -> tuple[float, float]:
    """The percentile interval of bootstrap values (inf, "never crossed", ranks last;
    the upper end is inf once more than (1 - level) / 2 of the resamples never
    cross)."""
    boot = np.asarray(boot, dtype=float)
    boot = boot[~np.isnan(boot)]
    if not len(boot):
        return (math.nan, math.nan)
    a = (1 - level) / 2
    lo, hi = np.quantile(boot, [a, 1 - a], method="inverted_cdf")
    return float(lo), float(hi)


def bootstrap_coverage(
    n_seeds: int,
    reps: int = 300,
    n_boot: int = 600,
    seed: int = 12345,
    level: float = LEVEL,
) -> float:
    """Share of `reps` synthetic experiments of `n_seeds` seeds whose `interval` covers
    the true mean-curve crossing.

    Each seed's curve is min(1, a t) at epochs t = 1..25 with a ~ U(0.04, 0.06): the
    population's mean curve reaches 0.5 at t = 0.5 / E[a] = 10 epochs, and a sample's at
    0.5 / mean(a) (the curves are straight up to there, so interpolation is exact)."""
    rng = np.random.default_rng(seed)
    t = np.arange(1.0, 26.0)
    hits = 0
    for i in range(reps):
        curves = [
            SeedCurve(t, np.minimum(1.0, a * t), np.zeros(len(t), dtype=bool), "budget")
            for a in rng.uniform(0.04, 0.06, size=n_seeds)
        ]
        lo, hi = interval(bootstrap_crossings(curves, 0.5, n_boot, seed=i), level)
        hits += lo <= 10.0 <= hi
    return hits / reps


def seed_summary(values: list[float | None]) -> dict:
    """Median, mean and range of per-seed crossings, None (never crossed) ranked after
    every number.

    Returns median, mean, low, high (inf where the median, any seed or the slowest seed
    did not cross), k (seeds that crossed) and n. The mean is the reading that fits
    Table I's Reach column (departure 29)."""
    v = np.array([math.inf if x is None else x for x in values], dtype=float)
    if not len(v):
        return dict(median=None, mean=None, low=None, high=None, k=0, n=0)
    return dict(
        median=float(np.median(v)),
        mean=float(v.mean()),
        low=float(v.min()),
        high=float(v.max()),
        k=int(np.isfinite(v).sum()),
        n=len(v),
    )


def ratio_of(h: float | None, a: float | None) -> float | None:
    """h / a; None unless both are numbers."""
    return (
        h / a
        if h is not None
        and a is not None
        and math.isfinite(h)
        and math.isfinite(a)
        and a > 0
        else None
    )


def ratio_boot(h_boot: np.ndarray, a_boot: np.ndarray) -> np.ndarray:
    """HER / ACDER per pair of resamples: inf where only HER never crossed, 0 where only
    ACDER never crossed, NaN (left out of `interval`) where neither did."""
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.asarray(h_boot, dtype=float) / np.asarray(a_boot, dtype=float)
    r[np.isinf(h_boot) & np.isfinite(a_boot)] = np.inf
    r[np.isfinite(h_boot) & np.isinf(a_boot)] = 0.0
    r[np.isinf(h_boot) & np.isinf(a_boot)] = np.nan
    return r


@dataclass
class CellStat:
    """Both statistics of one (task, method) cell. Epoch values; `paper_units` and
    `our_episodes` convert them."""

    env: str
    name: str
    """The folder under `<env>/` (a method, or an experiment's name such as
    acder-baselines-clip)."""
    method: str | None
    """The runs' method (config.json), None without runs."""
    threshold: float
    n: int = 0
    """Seeds read."""
    seeds: list = field(default_factory=list)
    done: int = 0
    """Seeds with done.json."""
    unfinished: int = 0
    """Seeds without done.json (training, or interrupted)."""
    stopped: int = 0
    """Seeds ended by the stop rule (carried forward)."""
    cut: int = 0
    """Seeds ended before their budget otherwise (protocol v1)."""
    bf16: int = 0
    """Seeds whose gradient step ran in bfloat16."""
    planned: int | None = None
    """Seeds the plan file plans for this cell (None without a plan)."""
    hold: str = ""
    """Why the plan holds this cell back ('' if it does not)."""
    budget_epochs: float | None = None
    episodes_per_epoch: float | None = None
    """Our training episodes an epoch (all workers); None if the seeds disagree."""
    evaluated_epochs: float | None = None
    """How far the mean curve reaches (every seed has a value up to here)."""
    crossing: float | None = None
    """Epoch at which the mean curve first reaches the threshold."""
    earliest: float | None = None
    """The earliest epoch at which the mean curve of the planned seeds can still reach
    the threshold, given the seeds read so far (`earliest_crossing`; inf: never)."""
    why: str = ""
    """Why there is no crossing: 'not run yet', 'no evaluation yet', 'not yet', 'not
    within budget' or 'not before a seed's curve was cut'."""
    low: float | None = None
    high: float | None = None
    """The bootstrap interval (epochs; high is inf when it reaches past the budget)."""
    share_crossing: float | None = None
    """Share of the bootstrap resamples whose mean curve crosses."""
    seed_crossings: list = field(default_factory=list)
    """Each seed's own first crossing (epochs; None where it has not crossed)."""
    seed_ended: list = field(default_factory=list)
    """Per seed, whether it has ended (done.json): a seed that ended without a crossing
    never will."""
    seed_median: float | None = None
    seed_mean: float | None = None
    seed_low: float | None = None
    seed_high: float | None = None
    """Median, mean and range of the seed crossings (inf for a seed that has not
    crossed; the mean is inf if any has not)."""
    k: int = 0
    """Seeds that crossed."""
    paper: int | None = None
    """Table I's number (episodes), None where the paper has none."""
    boot: np.ndarray | None = field(default=None, repr=False)
    """The bootstrap crossings (for ratios); left out of `to_dict`."""

    def paper_units(self, epochs: float | None) -> float | None:
        """Epochs in Table I's unit (x 400 episodes)."""
        return None if epochs is None else epochs * PAPER_EPISODES_PER_EPOCH

    def our_episodes(self, epochs: float | None) -> float | None:
        """Epochs in our training episodes (None where unknown)."""
        return (
            None
            if epochs is None or self.episodes_per_epoch is None
            else epochs * self.episodes_per_epoch
        )

    def to_dict(self) -> dict:
        """The scalars as JSON-ready values (inf and NaN become None),
        with the two conversions."""
        d = {
            f.name: json_ready(getattr(self, f.name))
            for f in fields(self)
            if f.name != "boot"
        }
        d["crossing_episodes_paper_units"] = json_ready(self.paper_units(self.crossing))
        d["crossing_our_episodes"] = json_ready(self.our_episodes(self.crossing))
        return d


def one_or_none(values):
    """The single distinct value of `values`, else None."""
    s = {v for v in values if v is not None}
    return s.pop() if len(s) == 1 else None


def cell_stat(
    env: str,
    name: str,
    runs: list[dict],
    planned: dict | None = None,
    n_boot: int = BOOTSTRAP_RESAMPLES,
) -> CellStat:
    """Both statistics of one cell from its runs (dicts of `runs.read_run`: rows, ended,
    budget_epochs, episodes_per_epoch, seed, method, update_dtype).

    `planned` is this cell's entry of `runs.planned_cells` (seeds, hold), or None."""
    thr = threshold(env)
    c = CellStat(
        env,
        name,
        one_or_none(r["method"] for r in runs),
        thr,
        paper=PAPER_TABLE_I.get(name, {}).get(env),
    )
    if planned:
        c.planned, c.hold = planned.get("seeds"), planned.get("hold", "")
    if not runs:
        c.why = "not run yet"
        return c
    c.n, c.seeds = len(runs), [r["seed"] for r in runs]
    c.done = sum(r["ended"] is not None for r in runs)
    c.unfinished = c.n - c.done
    c.stopped = sum(r["ended"] == "stop rule" for r in runs)
    c.cut = sum(r["ended"] == "cut" for r in runs)
    c.bf16 = sum(r.get("update_dtype") == "bfloat16" for r in runs)
    c.episodes_per_epoch = one_or_none(r.get("episodes_per_epoch") for r in runs)
    budgets = [r["budget_epochs"] for r in runs if r.get("budget_epochs")]
    c.budget_epochs = max(budgets) if budgets else None
    curves = [
        seed_curve(r["rows"], r["ended"], c.budget_epochs, r.get("episodes_per_epoch"))
        for r in runs
    ]
    c.seed_crossings = [first_crossing(s.x, s.y, thr) for s in curves]
    c.seed_ended = [r["ended"] is not None for r in runs]
    c.earliest = earliest_crossing(curves, max(c.planned or 0, c.n), thr)
    summ = seed_summary(c.seed_crossings)
    c.seed_median, c.seed_mean, c.seed_low, c.seed_high, c.k = (
        summ["median"],
        summ["mean"],
        summ["low"],
        summ["high"],
        summ["k"],
    )
    if any(not len(s.x) for s in curves):
        c.why = "no evaluation yet"
        return c
    m = mean_curve(curves)
    c.evaluated_epochs = (
        float(m.x[~np.isnan(m.mean)][-1]) if (~np.isnan(m.mean)).any() else None
    )
    c.crossing = first_crossing(m.x, m.mean, thr)
    c.boot = bootstrap_crossings(curves, thr, n_boot, cell_seed(f"{env}/{name}"))
    c.low, c.high = interval(c.boot)
    c.share_crossing = float(np.isfinite(c.boot).mean())
    if c.crossing is None:
        reached_budget = (
            c.budget_epochs is not None
            and c.evaluated_epochs is not None
            and c.evaluated_epochs >= c.budget_epochs - 1e-9
        )
        c.why = (
            "not within budget"
            if reached_budget or not (c.unfinished or c.cut)
            else "not yet"
            if c.unfinished
            else CUT_WHY
        )
    return c


def cell_on_seeds(
    runs: list[dict], env: str, name: str, seeds, n_boot: int = BOOTSTRAP_RESAMPLES
) -> CellStat | None:
    """`cell_stat` of cell (env, name) on the given seeds alone: one cell read on
    another's seeds, so the two are compared like for like. None unless every one of
    those seeds has a run."""
    picked = [r for r in runs if (r["env"], r["name"]) == (env, name)]
    picked = sorted(
        (r for r in picked if r["seed"] in set(seeds)), key=lambda r: str(r["seed"])
    )
    if not picked or len(picked) != len(set(seeds)):
        return None
    return cell_stat(env, name, picked, n_boot=n_boot)


def summarize(
    runs: list[dict],
    planned: dict | None = None,
    cells=None,
    n_boot: int = BOOTSTRAP_RESAMPLES,
) -> list[CellStat]:
    """`cell_stat` of every (env, name): those of `cells` (e.g. `grid_cells()`) in their
    order, then the others found in `runs` or `planned` (a `runs.planned_cells` dict),
    by task."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in runs:
        groups.setdefault((r["env"], r["name"]), []).append(r)
    keys = list(cells or [])
    extra = sorted(
        (set(groups) | set(planned or {})) - set(keys),
        key=lambda k: (
            TASKS.index(k[0]) if k[0] in TASKS else len(TASKS),
            k[0],
            GRID_METHODS.index(k[1]) if k[1] in GRID_METHODS else len(GRID_METHODS),
            k[1],
        ),
    )
    return [
        cell_stat(
            e,
            n,
            sorted(groups.get((e, n), []), key=lambda r: str(r["seed"])),
            (planned or {}).get((e, n)),
            n_boot,
        )
        for e, n in keys + extra
    ]


@dataclass
class RatioStat:
    """HER / ACDER episodes on one task, from the mean-curve statistic of both cells."""

    env: str
    ours: float | None
    """The ratio of the two crossings (None unless both crossed)."""
    bound: float | None = None
    """A lower bound where HER did not cross within its budget but ACDER did:
    budget / ACDER."""
    low: float | None = None
    high: float | None = None
    """Bootstrap interval of the ratio (pairs of independent resamples of
    the two cells)."""
    share: float | None = None
    """Share of resample pairs in which both crossed."""
    paper: float | None = None
    why: str = ""
    """Why there is no ratio ('' if there is one)."""
    seed_ratio: float | None = None
    """The ratio of the two cells' per-seed median crossings (a second reading,
    for comparison)."""
    seed_mean_ratio: float | None = None
    """The ratio of their per-seed mean crossings (a third: the reading that fits
    Table I's Reach column, departure 29)."""

    def to_dict(self) -> dict:
        return {f.name: json_ready(getattr(self, f.name)) for f in fields(self)}


def ratio_stat(her: CellStat | None, acder: CellStat | None) -> RatioStat:
    """HER's crossing over ACDER's, both read off their mean curves (same unit, so the
    Reach episode count does not matter)."""
    env = (her or acder).env
    r = RatioStat(env, None, paper=paper_ratio(env))
    missing = [k for k, c in (("HER", her), ("ACDER", acder)) if c is None or not c.n]
    if missing:  # say which: "ACDER not run yet" while HER's seeds train
        r.why = f"{' and '.join(missing)} not run yet"
        return r
    r.ours = ratio_of(her.crossing, acder.crossing)
    r.seed_ratio = ratio_of(her.seed_median, acder.seed_median)
    r.seed_mean_ratio = ratio_of(her.seed_mean, acder.seed_mean)
    if r.ours is None:
        if acder.crossing is None:
            r.why = f"ACDER {acder.why}"
        elif her.why == "not within budget" and her.budget_epochs:
            r.bound, r.why = her.budget_epochs / acder.crossing, "HER not within budget"
        else:
            r.why = f"HER {her.why}"
    if her.boot is not None and acder.boot is not None:
        n = min(len(her.boot), len(acder.boot))
        h, a = her.boot[:n], acder.boot[:n]
        r.low, r.high = interval(ratio_boot(h, a))
        r.share = float((np.isfinite(h) & np.isfinite(a)).mean())
    return r


def ratios(cells: list[CellStat], tasks=TASKS) -> list[RatioStat]:
    """`ratio_stat` per task, from the her and acder cells of `cells`."""
    by = {(c.env, c.name): c for c in cells}
    return [
        ratio_stat(by.get((e, "her")), by.get((e, "acder")))
        for e in tasks
        if (e, "her") in by or (e, "acder") in by
    ]


def complete(c: CellStat) -> bool:
    """Every seed the plan plans for the cell has ended (without a plan: every seed
    read has)."""
    return c.unfinished == 0 and (c.planned is None or c.done >= c.planned)


def separated(a: CellStat, b: CellStat) -> bool | None:
    """The readings' rule (experiments/readings/README.md, fixed before their last
    seeds were in): two settings are separated when each one's mean-curve crossing lies
    outside the other's 95% bootstrap interval. None while either lacks a crossing or an
    interval (one whose lower end is beyond the budget is none), or has seeds still to
    come (`complete`: the crossing and interval of fewer seeds than planned, e.g. the
    committed ones of a cell still training, are not the rule's). Traps: one crossing
    outside the other's interval is not enough (with 3 seeds the intervals are wide and
    lopsided); equal crossings are never separated, whatever their intervals."""
    if any(v is None for v in (a.crossing, b.crossing, a.low, b.low, a.high, b.high)):
        return None
    if not (complete(a) and complete(b)):
        return None
    if not (math.isfinite(a.low) and math.isfinite(b.low)):
        return None
    if a.crossing == b.crossing:
        return False

    def outside(x: float, c: CellStat) -> bool:
        return not c.low <= x <= c.high

    return outside(a.crossing, b) and outside(b.crossing, a)


def cannot_cross_first(challenger: CellStat, incumbent: CellStat) -> bool:
    """True when `challenger`'s mean curve can no longer cross before `incumbent`'s,
    whatever its unfinished and unstarted seeds do: every seed of `incumbent` has ended
    and `challenger.earliest` is at or after its crossing.

    The readings' second rule gives the challenger the default only where the runs
    separate the two with the challenger crossing first; once this is True that cannot
    happen, and the rule's answer (the incumbent) is known before the challenger's last
    seeds are in."""
    return (
        incumbent.crossing is not None
        and complete(incumbent)
        and challenger.earliest is not None
        and challenger.earliest >= incumbent.crossing
    )


def choose(a: CellStat, b: CellStat, fallback: str) -> tuple[str | None, bool | None]:
    """(the setting the readings' rule picks, `separated(a, b)`): where the runs
    separate `a` and `b`, the one with the earlier crossing; where they do not,
    `fallback` (the name of the one the paper's text favours); None while undecided.
    Before `b`'s last seeds are in, `a` (when it is the fallback) is already the answer
    once `b` cannot cross first (`cannot_cross_first`): then (a.name, None)."""
    sep = separated(a, b)
    if sep is None:
        if fallback == a.name and cannot_cross_first(b, a):
            return a.name, None
        return None, None
    if not sep:
        return fallback, False
    return (a.name if a.crossing < b.crossing else b.name), True


def learning_curves(runs: list[dict]) -> dict[tuple[str, str], MeanCurve]:
    """The mean curve (epochs) of every (env, name) in `runs`, as Table I reads it."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in runs:
        groups.setdefault((r["env"], r["name"]), []).append(r)
    out = {}
    for key, rs in sorted(groups.items()):
        budget = max(
            (r["budget_epochs"] for r in rs if r.get("budget_epochs")), default=None
        )
        out[key] = mean_curve(
            [
                seed_curve(r["rows"], r["ended"], budget, r.get("episodes_per_epoch"))
                for r in rs
            ]
        )
    return out


def column_tail(
    runs: list[dict],
    env: str,
    name: str,
    column: str,
    last: int | None = TAIL_EVALUATIONS,
) -> float | None:
    """A progress.csv column averaged over each seed's `last` evaluations (all of them
    with None), then over the seeds of (env, name); None where no seed has the column
    (e.g. r_int_mean of a method without S-ICM)."""
    per_seed = []
    for r in runs:
        if r["env"] == env and r["name"] == name:
            vals = [
                row[column]
                for row in r["rows"]
                if isinstance(row.get(column), float) and not math.isnan(row[column])
            ]
            if vals:
                per_seed.append(float(np.mean(vals if last is None else vals[-last:])))
    return float(np.mean(per_seed)) if per_seed else None
