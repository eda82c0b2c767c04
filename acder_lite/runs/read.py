"""Finding and reading run folders: `<root>/<env>/<name>/seed<k>/` as
`sweep` writes them, or run folders of any other name (`train --out DIR`), each a cell
of its own (`load_runs`).

A run folder holds `config.json` (the config, the command, versions), `progress.csv`
(one row per evaluation) and, once it has ended, `done.json`. `load_runs(root)` reads
every run folder under `root` (or `root` itself); a folder it cannot read is named on
stderr in one line, with why, and skipped, so one bad folder never hides the others.

Traps:
- Runs are grouped by their folder name (`name`), not by config.json's method: the
  protocol-v1 folder `acder-baselines-clip` holds runs whose config now reads as method
  `acder` with `target_clip="baselines"` (`legacy.upgrade_legacy`), and
  experiments/readings/ names its folders after the setting under test (`sicm-raw`,
  ...).
- A run's budget is the epochs its *first* command planned (`planned_epochs`): a
  protocol-v1 run ended by `train --resume DIR --epochs N` has N in its config.
- A live run has config.json but no progress.csv until its first evaluation; it is
  skipped (and named) like a broken one, since it has nothing to read yet.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
import shlex
import sys
from pathlib import Path

from acder_lite.config import TASK_PRESETS, Config, ConfigError
from acder_lite.legacy import upgrade_legacy
from acder_lite.stats.report import episodes_to_threshold, threshold

REQUIRED_COLUMNS = ("episodes", "test_success")
"""progress.csv columns every run has (`epoch` too since protocol v1,
but not required)."""

COLUMN_RANGES = {
    "test_success": (0.0, 1.0, "a number in [0, 1]"),
    "episodes": (0.0, math.inf, "a finite number >= 0"),
    "epoch": (0.0, math.inf, "a finite number >= 0"),
}
"""(low, high, what is allowed) of the numeric progress.csv columns `read_progress`
checks. Trap: float() reads "nan" and "inf", and a test_success of 7 in every row
would turn "not within budget" into a crossing."""


SEED_FOLDER = re.compile(r"seed([0-9]+)")
"""The name of a run folder of the grid's layout, `<env>/<name>/seed<k>/`."""


class RunError(ValueError):
    """A run folder that cannot be read; the message says why, in a few words."""


def find_run_dirs(root: str | Path) -> list[Path]:
    """Folders under `root` (and `root` itself) that hold a config.json or a
    progress.csv, sorted.

    Hidden folders are left out."""
    root = Path(root)
    found = set()
    for name in ("config.json", "progress.csv"):
        for p in root.rglob(name):
            if not any(part.startswith(".") for part in p.relative_to(root).parts[:-1]):
                found.add(p.parent)
    return sorted(found)


def finished_run(root, *folders: str) -> str | None:
    """The first of `folders` (relative to `root`) that holds a finished run (done.json
    and policy.pt), or None. Trap: policy.pt alone does not do, since train rewrites it
    at every epoch end of a run still in progress."""
    for f in folders:
        if all((Path(root) / f / n).is_file() for n in ("done.json", "policy.pt")):
            return f
    return None


def run_folder_above(path: str | Path) -> tuple[Path, str] | None:
    """The nearest folder above `path` that holds a run, and the file that says so
    (train's config.json, or a packed checkpoint's state); None if none does. The
    folder is named as `path` is, relative if it is. Trap: `train --out RUN/sub`
    trained a run inside a run, which table, pack and sweep then found as a run of its
    own under the first. Trap the other way: progress.csv, checkpoint.pt and a
    config.json without train's "command" and "config" are other tools' names too (a
    stray ~/checkpoint.pt would refuse every run under $HOME), so they make no run."""
    from acder_lite.runs.packed import FOLDER, STATE

    path = Path(path)
    for p in Path(os.path.abspath(path)).parents:
        for name in ("config.json", f"{FOLDER}/{STATE}"):
            if not os.path.isfile(p / name):
                continue
            if name == "config.json":
                try:
                    d = read_json(p / name, name)
                except RunError:
                    continue
                if not ("command" in d and "config" in d):
                    continue
            return (p if path.is_absolute() else Path(os.path.relpath(p))), name
    return None


def number(s):
    """A progress.csv field as a float; '' stays ''
    (a column a method does not write)."""
    try:
        return float(s)
    except (TypeError, ValueError):
        return s


def read_progress(path: str | Path) -> list[dict]:
    """The rows of a progress.csv, numeric fields as floats.

    Raises RunError when it is missing, has no `episodes` or `test_success` column, or a
    row with more fields than the header or whose `episodes`/`test_success`/`epoch` is
    not a number in its `COLUMN_RANGES` (nan and inf are refused), or whose `episodes`
    is not above the row before's (each evaluation follows more training; the
    crossings interpolate between rows)."""
    path = Path(path)
    if not path.exists():
        raise RunError("no progress.csv yet (no evaluation written)")
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            header = reader.fieldnames or []
            missing = [c for c in REQUIRED_COLUMNS if c not in header]
            if missing:
                raise RunError(f"progress.csv has no {missing[0]!r} column")
            rows = []
            for i, row in enumerate(reader, 2):
                if None in row:
                    raise RunError(
                        f"progress.csv line {i} has more fields than its header"
                    )
                raw, row = row, {k: number(v) for k, v in row.items()}
                for c in REQUIRED_COLUMNS + (("epoch",) if "epoch" in header else ()):
                    if not isinstance(row[c], float):
                        raise RunError(
                            f"progress.csv line {i}: {c} {row[c]!r} is not a number"
                        )
                    low, high, allowed = COLUMN_RANGES[c]
                    if not low <= row[c] <= high or math.isinf(row[c]):
                        raise RunError(
                            f"progress.csv line {i}: {c} {raw[c]!r} is out of range; "
                            f"allowed: {allowed}"
                        )
                if rows and not row["episodes"] > rows[-1]["episodes"]:
                    raise RunError(
                        f"progress.csv line {i}: episodes {raw['episodes']!r} is not "
                        f"above line {i - 1}'s; allowed: a count that grows by row"
                    )
                rows.append(row)
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise RunError(f"progress.csv cannot be read ({type(e).__name__})") from None
    return rows


def read_json(path: Path, what: str) -> dict:
    """A JSON object from `path`; RunError if it is missing,
    not JSON or not an object."""
    if not path.exists():
        raise RunError(f"no {what}")
    try:
        d = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise RunError(f"{what} is not valid JSON ({type(e).__name__})") from None
    if not isinstance(d, dict):
        raise RunError(f"{what} is not a JSON object")
    return d


def shown(v) -> str:
    """A JSON value for a one-line reason: short ones as they are, lists and objects by
    kind (they can be long)."""
    if isinstance(v, dict):
        return "an object"
    if isinstance(v, list):
        return "a list"
    text = json.dumps(v)
    return text if len(text) <= 40 else text[:37] + "..."


def check_outer_fields(whole: dict) -> None:
    """RunError naming the first field of config.json outside "config" that is there
    but not of the type `read_run`, `planned_epochs` and `grid_time` read it as
    (train and sweep write them so; absent is fine). Trap: shlex.split(None) reads
    stdin, so a null "command" would hang `table` instead of failing."""

    def need(name, value, kind, allowed):
        if not isinstance(value, kind):
            raise RunError(f"config.json: {name} is {shown(value)}; allowed: {allowed}")

    if "command" in whole:
        need("command", whole["command"], str, "a string (the train command)")
    if "versions" in whole:
        need("versions", whole["versions"], dict, "an object")
    if "resumes" in whole:
        need("resumes", whole["resumes"], list, "a list of objects, one per resume")
        for i, r in enumerate(whole["resumes"]):
            name = f"resumes[{i}]"
            need(name, r, dict, "an object, as train appends one per resume")
            if "command" in r:
                need(f"{name}.command", r["command"], str, "a string")
            if "versions" in r:
                need(f"{name}.versions", r["versions"], dict, "an object")
    if "same_as" in whole:
        allowed = 'an object with "run", the folder the sweep copied it from'
        need("same_as", whole["same_as"], dict, allowed)
        run = whole["same_as"].get("run")
        if not isinstance(run, str) or not run:
            raise RunError(
                f"config.json: same_as.run is {shown(run)}; allowed: a non-empty "
                "string (the folder the sweep copied this run from)"
            )


def read_config(d: Path) -> dict:
    """config.json of run folder `d` (the whole file), its "config" upgraded to today's
    fields (`legacy.upgrade_legacy`) and checked by `Config.validate`, the fields
    around it by `check_outer_fields`. RunError if it cannot be used."""
    whole = read_json(d / "config.json", "config.json")
    cfg = whole.get("config")
    if not isinstance(cfg, dict):
        raise RunError('config.json has no "config" object')
    check_outer_fields(whole)
    if "switches" in cfg and not isinstance(cfg["switches"], dict):
        # upgrade_legacy reads a protocol-v1 target_clip out of it before validate
        raise RunError(
            f"config.json: config.switches is {shown(cfg['switches'])}; "
            "allowed: an object"
        )
    try:
        up = upgrade_legacy(cfg)
        Config.from_dict(up).validate()
    except (ConfigError, TypeError) as e:
        raise RunError(f"config.json: {e}") from None
    for key in ("epochs", "cycles", "episodes_per_cycle", "workers"):
        if not isinstance(up.get(key), int):
            raise RunError(f"config.json: {key} is {up.get(key)!r}, not an integer")
    return dict(whole, config=up)


def epochs_option(command: str) -> int | None:
    """N of `--epochs N` (or `--epochs=N`) in a command line;
    None if absent or unreadable."""
    try:
        toks = shlex.split(command)
    except ValueError:
        return None
    for i, t in enumerate(toks):
        v = (
            toks[i + 1]
            if t == "--epochs" and i + 1 < len(toks)
            else t[9:]
            if t.startswith("--epochs=")
            else None
        )
        if v is not None:
            return int(v) if v.isdecimal() else None  # "²".isdigit(), int("²") fails
    return None


def planned_epochs(config_json: dict) -> int | None:
    """The epochs a run was started with, from its config.json (the whole file,
    not only "config").

    A run ended at an epoch by `train --resume DIR --epochs N` (protocol v1) has N in
    its config, so the plan is read from the first command: its `--epochs`, else the
    config's value if no resume changed it, else the task preset the first command
    fell back on (`Config.epochs` None).
    """
    first = epochs_option(config_json.get("command", ""))
    if first is not None:
        return first
    cfg = config_json.get("config", {})
    if all(
        epochs_option(r.get("command", "")) is None
        for r in config_json.get("resumes", [])
    ):
        return cfg.get("epochs")
    # a resume's --epochs wrote its N into the config: that is not the plan
    return TASK_PRESETS.get(cfg.get("env"), {}).get("epochs")


def how_it_ended(done: dict | None, planned: int | None) -> str | None:
    """None (no done.json), 'stop rule' (the success held: stop_reason "success held",
    or protocol v1's stopped_early before stop_reason was recorded), 'budget' (ran its
    planned epochs) or 'cut' (ended before them otherwise: v1's "gap after first
    success", or a resume with fewer epochs)."""
    if done is None:
        return None
    reason = done.get("stop_reason")
    if reason == "success held" or (reason is None and done.get("stopped_early")):
        return "stop rule"
    if reason == "gap after first success":
        return "cut"
    epochs = done.get("epochs")
    if (
        planned is None
        or not isinstance(epochs, (int, float))
        or epochs >= planned - 1e-9
    ):
        return "budget"
    return "cut"


def read_run(d: str | Path) -> dict:
    """One run folder as a dict; RunError (why) if its config.json or progress.csv
    cannot be read.

    Keys: env, name (the folder under `<env>/`, or a run folder's own name where it is
    not `seed<k>`: `load_runs`), method (config's, upgraded), seed, dir,
    rows (`read_progress`), config (upgraded "config"), planned_epochs, budget_epochs
    (the same, else the config's epochs), budget (training episodes of budget_epochs),
    episodes_per_epoch (cycles x episodes_per_cycle x workers), done (done.json
    present), done_info (its content, or None), ended (`how_it_ended`), update_dtype,
    same_as (the run folder the sweep copied it from, `acder_lite.runs.same_as`; None if
    it was trained here).
    """
    d = Path(d)
    whole = read_config(d)
    rows = read_progress(d / "progress.csv")
    done = (
        read_json(d / "done.json", "done.json") if (d / "done.json").exists() else None
    )
    cfg = whole["config"]
    planned = planned_epochs(whole)
    grid = SEED_FOLDER.fullmatch(d.name)  # <env>/<name>/seed<k>, else a cell of its own
    seed = cfg.get("seed")
    if seed is None:
        seed = int(grid[1]) if grid else d.name
    per_epoch = cfg["cycles"] * cfg["episodes_per_cycle"] * cfg["workers"]
    budget_epochs = planned or cfg["epochs"]
    return dict(
        env=cfg.get("env", d.parent.parent.name if grid else d.parent.name),
        name=d.parent.name if grid else d.name,
        method=cfg.get("method"),
        seed=seed,
        dir=str(d),
        rows=rows,
        config=cfg,
        planned_epochs=planned,
        budget_epochs=float(budget_epochs),
        budget=float(budget_epochs * per_epoch),
        episodes_per_epoch=float(per_epoch),
        done=done is not None,
        done_info=done,
        ended=how_it_ended(done, planned),
        update_dtype=cfg.get("update_dtype", "float32"),
        same_as=None
        if not (whole.get("same_as") or {}).get("run")
        else os.path.normpath(os.path.join(d, whole["same_as"]["run"])),
    )


def stderr_line(message: str) -> None:
    """The default `warn` of `load_runs`: the message as one line on stderr."""
    print(message, file=sys.stderr)


def load_runs(root: str | Path, warn=stderr_line) -> list[dict]:
    """Every readable run under `root` (`read_run`), sorted by (env, name, seed).

    Cells: a run folder named `seed<k>` is a seed of the cell (env, the folder above
    it), the grid's layout `<env>/<name>/seed<k>/`; a run folder of any other name
    (`train --out runs/push-her`) is a cell of its own, named after its folder, its
    seed read from its config.json. Runs of one cell must agree on config.json's method
    and hold one run per seed: where they do not (`conflicts`), every run involved is
    left out, since none of them is the cell's more than the others.

    A folder that cannot be read, or is so left out, is passed to `warn` as one line,
    "skipped DIR: why", and left out; `warn=None` drops the lines."""
    runs = []
    for d in find_run_dirs(root):
        try:
            runs.append(read_run(d))
        except RunError as e:
            if warn is not None:
                warn(f"skipped {d}: {e}")
    runs.sort(key=lambda r: (r["env"], r["name"], str(r["seed"])))
    why = conflicts(runs)
    if warn is not None:
        for r in runs:
            if r["dir"] in why:
                warn(f"skipped {r['dir']}: {why[r['dir']]}")
    return [r for r in runs if r["dir"] not in why]


def conflicts(runs: list[dict]) -> dict[str, str]:
    """{run folder: why} for the runs of `read_run` that cannot share their cell (env,
    name): every run of a cell whose runs disagree on the method, and every run of a
    seed that a cell holds more than once."""
    cells: dict[tuple, list[dict]] = {}
    for r in runs:
        cells.setdefault((r["env"], r["name"]), []).append(r)
    out = {}
    for (env, name), rs in cells.items():
        where = f"{env}/{name}"
        methods = sorted({str(r["method"]) for r in rs})
        if len(methods) > 1:
            for r in rs:
                out[r["dir"]] = (
                    f"the runs of cell {where} mix methods ({', '.join(methods)}); "
                    "allowed: one method per cell (a folder of its own per method)"
                )
            continue
        seeds: dict[str, list[dict]] = {}
        for r in rs:
            seeds.setdefault(str(r["seed"]), []).append(r)
        for seed, same in seeds.items():
            if len(same) > 1:
                for r in same:
                    out[r["dir"]] = (
                        f"seed {seed} of cell {where} is in {len(same)} run folders; "
                        "allowed: one run per seed of a cell"
                    )
    return out


def how_ended(run: dict) -> str | None:
    """Why a run of `load_runs` ended, in protocol v1's words: "early stop" (the stop
    rule), "full budget", "hovering" (ended before its budget after it had reached its
    task's threshold: the gap rule, or `train --resume DIR --epochs N`) or "cut short"
    (ended so before reaching it). None while there is no done.json."""
    ended = run["ended"]
    if ended is None:
        return None
    if ended == "stop rule":
        return "early stop"
    if ended == "budget":
        return "full budget"
    if (run.get("done_info") or {}).get("stop_reason") == "gap after first success":
        return "hovering"  # the gap rule counts from the first crossing: it was reached
    thr = run["config"].get("success_threshold") or threshold(
        run["env"]
    )  # the run's own rule
    return (
        "hovering"
        if episodes_to_threshold(run["rows"], thr) is not None
        else "cut short"
    )


def planned_cells(
    plan_path: str | Path, root: str | Path
) -> dict[tuple[str, str], dict]:
    """Seeds a plan file (`plan.read_plan`) plans per (env, name) for run folders under
    `root`: {(env, name): {"seeds": n, "hold": reason or ''}}. Raises plan.PlanError on
    a bad plan."""
    from acder_lite.runs.plan import read_plan

    root = Path(root).resolve()
    out: dict[tuple[str, str], dict] = {}
    for cell in read_plan(plan_path):
        out_dir = Path(cell.out).resolve()
        if root not in out_dir.parents:
            continue
        entry = out.setdefault((cell.env, out_dir.parent.name), dict(seeds=0, hold=""))
        entry["seeds"] += 1
        if cell.hold and not entry["hold"]:
            entry["hold"] = cell.hold
    return out


def load_folder(path: str | Path, warn=stderr_line) -> list[dict]:
    """`load_runs` of `path`, or [] where there is no such folder (an experiment not
    run in this checkout): the book reads what is there."""
    path = Path(path)
    return load_runs(path, warn=warn) if path.is_dir() else []


def planned_folder(plan_path: str | Path, root: str | Path) -> dict:
    """`planned_cells` of the run folders under `root`, or {} where there is no plan
    file at `plan_path` (then nothing counts as planned)."""
    return planned_cells(plan_path, root) if Path(plan_path).exists() else {}
