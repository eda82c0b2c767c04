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
