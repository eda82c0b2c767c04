"""Learning curves from committed runs (results/<env>/<method>/seed<k>/progress.csv).

Used by the book (chapters 7 and 8) on `acder_lite.table.load_runs(...)`. Missing runs are
reported in the returned status, never an error.
"""
from __future__ import annotations


def plot_learning_curves(ax, runs: list[dict], env: str, methods, labels: dict | None = None,
                         colors: dict | None = None, threshold: float | None = None) -> dict[str, str]:
    """Fig. 4 style: mean (line) and one std over seeds (band) of test success against episodes.

    `runs` is `acder_lite.table.load_runs(...)`; the curves are `table.learning_curves(runs)`.
    A run that stopped early holds its last value up to its budget (drawn dotted beyond the
    last real evaluation). Returns method -> status.
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
