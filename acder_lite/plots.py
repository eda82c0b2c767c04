"""Learning curves from committed runs: results/<env>/<method>/seed<k>/progress.csv.

Used by the book (chapters 7 and 8). Missing runs are reported, never an error: the full runs
are long and the book may be built while some are still going.
"""
from __future__ import annotations

import csv
import glob
import os

import numpy as np


def load_progress(path: str) -> dict[str, np.ndarray] | None:
    """Columns of a progress.csv as float arrays; None if the file is missing or has no rows."""
    if not os.path.exists(path):
        return None
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return None
    out = {}
    for k in rows[0]:
        try:
            out[k] = np.array([float(r[k]) if r[k] not in ("", None) else np.nan for r in rows])
        except ValueError:
            continue
    return out


def find_runs(results: str, env: str, method: str) -> dict[int, dict[str, np.ndarray]]:
    """seed -> columns, for every results/<env>/<method>/seed<k>/progress.csv with rows."""
    runs = {}
    for d in sorted(glob.glob(os.path.join(results, env, method, "seed*"))):
        try:
            seed = int(os.path.basename(d)[4:])
        except ValueError:
            continue
        p = load_progress(os.path.join(d, "progress.csv"))
        if p is not None:
            runs[seed] = p
    return runs


def mean_curve(runs: dict, x: str = "episodes", y: str = "test_success", n: int = 100):
    """Mean, min and max of y over seeds on a common x grid (up to the shortest run).

    Returns (grid, mean, lo, hi); one seed gives lo = hi = mean.
    """
    curves = [(r[x], r[y]) for r in runs.values() if len(r[x])]
    x_max = min(c[0][-1] for c in curves)
    x_min = max(c[0][0] for c in curves)
    grid = np.linspace(x_min, x_max, n) if x_max > x_min else np.array([x_max])
    ys = np.stack([np.interp(grid, cx, cy) for cx, cy in curves])
    return grid, ys.mean(0), ys.min(0), ys.max(0)


def plot_methods(ax, results: str, env: str, methods, x: str = "episodes", y: str = "test_success",
                 labels: dict | None = None) -> dict[str, str]:
    """Plot mean (line) and min-max over seeds (band) of each method; returns method -> status.

    The status says how many seeds were found and how far they got, or that no run exists yet.
    """
    status = {}
    for method in methods:
        runs = find_runs(results, env, method)
        if not runs:
            status[method] = f"no progress.csv under {os.path.join(results, env, method)} yet"
            continue
        grid, mean, lo, hi = mean_curve(runs, x, y)
        label = (labels or {}).get(method, method) + f" ({len(runs)} seed{'s' if len(runs) > 1 else ''})"
        (line,) = ax.plot(grid, mean, label=label, marker="o" if len(grid) == 1 else None)
        if len(runs) > 1:
            ax.fill_between(grid, lo, hi, color=line.get_color(), alpha=0.2)
        last = max(float(r[x][-1]) for r in runs.values())
        status[method] = f"{len(runs)} seed(s), up to {last:.0f} {x}, final mean {y} {mean[-1]:.2f}"
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.set_title(env)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend()
    return status


def plot_learning_curves(ax, runs: list[dict], env: str, methods, labels: dict | None = None,
                         colors: dict | None = None, threshold: float | None = None) -> dict[str, str]:
    """Fig. 4 style: mean (line) and one std over seeds (band) of test success against episodes.

    `runs` is `acder_lite.table.load_runs(...)`; the curves are `table.learning_curves(runs)`.
    A run that stopped early holds its last value up to its budget (drawn dotted beyond the
    last real evaluation). Returns method -> status, like `plot_methods`.
    """
    from .table import learning_curves
    curves = learning_curves([r for r in runs if r["env"] == env and r["method"] in methods])
    status = {}
    for method in methods:
        seeds = [r for r in runs if r["env"] == env and r["method"] == method and r["rows"]]
        if (env, method) not in curves:
            status[method] = "not run"
            continue
        x, mean, std, n = curves[(env, method)]
        real = max(max(row["episodes"] for row in r["rows"]) for r in seeds)
        label = (labels or {}).get(method, method) + f" ({len(seeds)} seed{'s' if len(seeds) > 1 else ''})"
        kw = {"color": colors[method]} if colors and method in colors else {}
        inside = x <= real
        (line,) = ax.plot(x[inside], mean[inside], label=label, **kw)
        if (~inside).any():
            j = max(0, int(inside.sum()) - 1)
            ax.plot(x[j:], mean[j:], ls=":", color=line.get_color())
        if n.max() > 1:
            ax.fill_between(x, mean - std, mean + std, color=line.get_color(), alpha=0.2, lw=0)
        done = sum(bool(r.get("done")) for r in seeds)
        status[method] = (f"{len(seeds)} seed(s), {done} finished, evaluated up to {real:,.0f} episodes, "
                          f"last mean test success {mean[inside][-1]:.2f}")
    if threshold is not None:
        ax.axhline(threshold, color="gray", ls="--", lw=0.8)
    ax.set_xlabel("training episodes (all workers)")
    ax.set_ylabel("test success")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8)
    return status
