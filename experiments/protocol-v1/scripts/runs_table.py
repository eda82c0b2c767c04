"""Markdown rows for results/README.md: one per run folder given, from its config.json and done.json.

    python results/scripts/runs_table.py results/FetchPush-v4/her-ebp/seed0 ...

Columns: run, git commits (start; resumes, short), wall time, epochs, how it ended
(`acder_lite.table.how_ended`: early stop, full budget, hovering or cut short, or still training).
"""
import json
import sys
from pathlib import Path

from acder_lite.table import how_ended, load_runs


def row(d: Path) -> str:
    cfg = json.loads((d / "config.json").read_text())
    c = cfg["config"]
    commits = [cfg["versions"].get("git", "?")[:7]] + [r["versions"].get("git", "?")[:7] for r in cfg.get("resumes", [])]
    # consecutive duplicates (a resume from the same commit) said once
    commits = [x for i, x in enumerate(commits) if i == 0 or x != commits[i - 1]]
    run = load_runs(d)[0]
    name = f"{c['env']} `{c['method']}` seed {c['seed']}"
    if run["update_dtype"] != "float32":
        name += f" ({run['update_dtype']} update)"
    done_p = d / "done.json"
    if not done_p.exists():
        return f"| {name} | {'; '.join(commits)} | – | – | still training |"
    done = json.loads(done_p.read_text())
    how = how_ended(run)
    if how == "hovering":
        rule = "`--stop-gap-episodes`" if done.get("stop_reason") == "gap after first success" else "`end_when_hovering.sh`"
        how = f"ended at {done['epochs']:.0f} epochs (hovering; {rule})"
    elif how == "cut short":
        how = f"cut short at {done['epochs']:.0f} epochs, before reaching the threshold (`end_at_epoch.sh`)"
    return (f"| {name} | {'; '.join(commits)} | {done['wall_s']:,.0f} s | {done['epochs']:.1f} | {how} |")


if __name__ == "__main__":
    print("| run | git commit (start; resumes) | wall time | epochs | how it ended |")
    print("|---|---|---|---|---|")
    for a in sys.argv[1:]:
        print(row(Path(a)))
