"""The grid's plan: which (env, method, seed) cells a sweep has, where each one's run
folder is, and what to do with it (run, resume, copy or skip), from the command line's
`--envs/--methods/--seeds` (`plan`) or from a plan file (`read_plan`, e.g.
results/plan.toml). `acder_lite.cli.sweep` runs what this plans.
"""

from __future__ import annotations

import itertools
import os
import re
from dataclasses import dataclass, field, fields
from pathlib import Path

from acder_lite.runs import packed, same_as
from acder_lite.config import ENV_IDS, METHODS, TASK_PRESETS, Config, ConfigError
from acder_lite.io import file_in_the_way


@dataclass
class Cell:
    """One (env, method, seed) of the grid and what the sweep will do with it."""

    env: str
    method: str
    seed: int
    out: Path
    action: str
    """'run' (fresh), 'resume' (checkpoint.pt or checkpoint.packed/, no done.json),
    'copy' (a finished `same_as` run) or 'skip' (done, on hold, waiting for its
    `same_as` run, or a progress.csv it cannot resume: see `plan_cell`)."""
    note: str = ""
    """Why a cell is skipped, or what was found in its directory."""
    options: dict = field(default_factory=dict)
    """Config fields this cell sets (a plan group's `config`),
    passed to train as --field value."""
    hold: str = ""
    """A plan group on hold: why (the cell is skipped with this note)."""
    source: Path | None = None
    """A finished run this cell is (a plan group's `same_as`): copied, not trained."""

    @property
    def name(self) -> str:
        return "/".join(self.out.parts[-3:])

    @property
    def epochs(self) -> int:
        """The epochs this cell trains for: its group's `epochs`, else its task's
        preset (`TASK_PRESETS`), as `train` resolves them."""
        return self.options.get("epochs", TASK_PRESETS[self.env]["epochs"])


def run_dir(results: str | Path, env: str, method: str, seed: int) -> Path:
    """`results/<env>/<method>/seed<k>`, the layout results/README.md describes."""
    return Path(results) / env / method / f"seed{seed}"


def cell_state(out: Path) -> str:
    """What a run folder holds: 'done' (done.json), 'interrupted' (checkpoint.pt, or
    a packed checkpoint carried over from another machine: `packed`), 'orphan'
    (progress.csv, no checkpoint: committed results, or a run stopped before its first
    epoch) or 'new'."""
    if (out / "done.json").exists():
        return "done"
    if (out / "checkpoint.pt").exists() or packed.has_packed(out):
        return "interrupted"
    if (out / "progress.csv").exists():
        return "orphan"
    return "new"


def plan_cell(cell: Cell) -> Cell:
    """`cell` with its action (and note) set from what its folder holds: 'run',
    'resume', 'skip', or 'copy' (a `same_as` run that has finished and has this cell's
    config). PlanError (one line) if Config refuses the cell or its `same_as` run's
    config differs.

    Trap: a cell Config refuses (EBP on Reach, a seed >= 2**64) was a 'skip' with
    exit 0, meant for an `--envs` x `--methods` grid with gaps, and it hid mistakes
    too. A grid with gaps is a plan file of gapless groups; `check_names` and
    `check_pairs` refuse a bad cell before any is planned, and this is the backstop."""
    try:
        config = Config(
            **dict(cell.options, env=cell.env, method=cell.method, seed=cell.seed)
        ).resolve()
    except (ConfigError, TypeError) as e:
        raise PlanError(
            f"the cell ({cell.env}, {cell.method}, seed {cell.seed}): {e}"
        ) from None
    state = cell_state(cell.out)
    if state == "done":
        cell.action, cell.note = "skip", "already complete"
    elif cell.hold:
        cell.action, cell.note = "skip", f"on hold: {cell.hold}"
    elif cell.source is not None:
        verdict, why = same_as.check(config.to_dict(), cell.source)
        if verdict == "differs":
            raise PlanError(why)
        cell.action, cell.note = (
            ("copy", f"same as {cell.source}")
            if verdict == "copy"
            else ("skip", f"waits: {why}")
        )
    elif state == "interrupted":
        cell.action, cell.note = (
            "resume",
            (
                "checkpoint.pt found"
                if (cell.out / "checkpoint.pt").exists()
                else f"{packed.FOLDER} found: its buffer is re-simulated"
            ),
        )
    elif state == "orphan":
        cell.action, cell.note = (
            "skip",
            (
                "progress.csv without checkpoint.pt or done.json: nothing to "
                "resume; remove the folder to start over"
            ),
        )
    else:
        cell.action, cell.note = "run", ""
    return cell


def plan(envs, methods, seeds, results, options: dict | None = None) -> list[Cell]:
    """The grid in env-major order, each cell with its action (`plan_cell`)."""
    return [
        plan_cell(
            Cell(
                env,
                method,
                seed,
                run_dir(results, env, method, seed),
                "",
                options=dict(options or {}),
            )
        )
        for env in envs
        for method in methods
        for seed in seeds
    ]


class PlanError(ValueError):
    """A bad plan file or option; the message is one line naming what is wrong and
    what is allowed."""


_GROUP_KEYS = {
    "envs",
    "methods",
    "seeds",
    "root",
    "name",
    "config",
    "queue",
    "hold",
    "note",
    "same_as",
}


_TOP_KEYS = ("defaults", "group")
"""A plan file's top-level keys: `[defaults]` and `[[group]]`."""


def read_plan(path: str | Path) -> list[Cell]:
    """The cells of a plan file (TOML), in the order they are to start,
    each with its action.

    A plan is a list of `[[group]]` tables, each a grid: `envs`, `methods`, `seeds`
    (lists); `root` (folder of `<env>/<name>/seed<k>`, relative to the plan's own
    folder; default: that folder); `name` (the folder under `<env>/`, default the
    method; needs one method); `config` (Config fields the runs set, e.g.
    {sicm_input = "raw"}; not `threads`, sweep's --threads); `queue` (default
    "grid"); `hold` (a reason: the group is planned but not started); `same_as` (a
    folder of `seed<k>` runs, relative to the plan's folder, that these cells are:
    each is copied once it has finished, if its config equals the cell's, see
    `same_as.check`; needs one env and one method). A
    `[defaults]` table gives every group its keys (a group's own win; `config` tables
    merge). Cells of different queues alternate, so two queues share the cores; within a
    queue they keep the file's order. Any other top-level key, and any (env, method)
    pair of a group that Config refuses with its `config`, is a PlanError: a group is
    a grid without gaps (a grid with EBP on Push, not Reach: two groups).
    """
    import tomllib

    path = Path(path)
    try:
        with open(path, "rb") as f:
            text = f.read().decode("utf-8")
        doc = tomllib.loads(text)
    except OSError as e:
        raise PlanError(f"plan {str(path)!r} cannot be read: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise PlanError(f"plan {str(path)!r} is not valid TOML: {e}") from None
    except UnicodeDecodeError:
        raise PlanError(
            f"plan {str(path)!r} is not valid TOML: not UTF-8 text"
        ) from None
    unknown = sorted(set(doc) - set(_TOP_KEYS))
    if unknown:  # a typo ([default], [[groups]]) would drop its tables silently
        raise PlanError(
            f"plan {str(path)!r}: unknown top-level key {unknown[0]!r}; "
            "allowed: [defaults] and [[group]] tables"
        )
    groups = doc.get("group")
    if not isinstance(groups, list) or not groups:
        raise PlanError(
            f"plan {str(path)!r} has no [[group]] tables; allowed: one or more"
        )
    defaults = doc.get("defaults", {})
    if not isinstance(defaults, dict) or set(defaults) - _GROUP_KEYS:
        raise PlanError(
            f"plan {str(path)!r}: [defaults] may hold only: "
            f"{', '.join(sorted(_GROUP_KEYS))}"
        )
    problem = _check_group(defaults)
    if problem:
        line = _line_of(text, "defaults", 1, _key_of(problem))
        raise PlanError(f"plan {str(path)!r}{line}, [defaults]: {problem}")
    queues: dict[str, list[Cell]] = {}
    for i, g in enumerate(groups, 1):
        if not isinstance(g, dict):
            raise _group_error(
                path, text, i, f" is {g!r}, not a table; allowed: [[group]] tables"
            )
        problem = _check_group(g)
        if problem:
            raise _group_error(path, text, i, f": {problem}")
        g = {
            **defaults,
            **g,
            "config": {**defaults.get("config", {}), **g.get("config", {})},
        }
        unknown = sorted(set(g) - _GROUP_KEYS)
        if unknown:
            raise _group_error(
                path,
                text,
                i,
                f": unknown key {unknown[0]!r}; allowed: "
                f"{', '.join(sorted(_GROUP_KEYS))}",
            )
        for key in ("envs", "methods", "seeds"):
            if not isinstance(g.get(key), list) or not g[key]:
                raise _group_error(path, text, i, f": {key} must be a non-empty list")
        problem = check_names(g["envs"], g["methods"], g["seeds"])
        if problem:
            raise _group_error(path, text, i, f": {problem}")
        if "name" in g and len(g["methods"]) != 1:
            raise _group_error(
                path,
                text,
                i,
                f": name needs exactly one method, not {len(g['methods'])}",
            )
        if "same_as" in g and (len(g["envs"]), len(g["methods"])) != (1, 1):
            raise _group_error(
                path,
                text,
                i,
                f": same_as needs exactly one env and one method, not "
                f"{len(g['envs'])} and {len(g['methods'])}",
            )
        options = g["config"]
        problem = check_pairs(g["envs"], g["methods"], options)
        if problem:
            raise _group_error(path, text, i, f": {problem}")
        root = Path(os.path.normpath(path.parent / g.get("root", ".")))
        problem = _same_as_problem(g, path.parent, root)
        if problem:
            raise _group_error(path, text, i, f": {problem}")
        for env, method, seed in itertools.product(g["envs"], g["methods"], g["seeds"]):
            out = run_dir(root, env, g.get("name", method), seed)
            cell = Cell(
                env,
                method,
                seed,
                out,
                "",
                options=dict(options),
                hold=str(g.get("hold", "")),
                source=None
                if "same_as" not in g
                else Path(os.path.normpath(path.parent / g["same_as"])) / f"seed{seed}",
            )
            try:
                cell = plan_cell(cell)
            except PlanError as e:
                raise _group_error(path, text, i, f": {e}") from None
            queues.setdefault(str(g.get("queue", "grid")), []).append(cell)
    # The same env/method/seed may be planned under two roots (chapter 9's 40-epoch
    # run in experiments/, the 400-epoch one in results/): a folder is the identity.
    outs = [c.out for q in queues.values() for c in q]
    dup = next((o for o in outs if outs.count(o) > 1), None)
    if dup:
        shown = os.path.relpath(dup, path.parent)
        raise PlanError(
            f"plan {str(path)!r}: the run folder {shown!r} "
            "is planned twice; allowed: once"
        )
    return [
        c
        for batch in itertools.zip_longest(*queues.values())
        for c in batch
        if c is not None
    ]


def _group_error(path: Path, text: str, i: int, what: str) -> PlanError:
    """`plan 'FILE' line N, group I: WHAT` (or `... group I is ...`): N is the line of
    the key WHAT is about (`_key_of`), else of the group's `[[group]]` header, so a
    plan edited while a sweep runs says which line to fix."""
    key = _key_of(what[2:]) if what.startswith(": ") else None
    return PlanError(
        f"plan {str(path)!r}{_line_of(text, 'group', i, key)}, group {i}{what}"
    )


def _key_of(problem: str) -> str | None:
    """The group key a problem line is about: its first word when that is one
    (`envs must be ...`, `config may not set ...`), the key it names as unknown, or the
    list that `check_names` and `check_pairs` found a bad entry in."""
    m = re.match(r"unknown key '([^']+)'", problem)
    if m:
        return m.group(1)
    for start, key in (
        ("unknown env", "envs"),
        ("unknown method", "methods"),
        ("the pair", "methods"),
        ("the cell", None),
    ):
        if problem.startswith(start):
            return key
    word = problem.split(" ", 1)[0].strip("-:")
    return word if word in _GROUP_KEYS else None


def _line_of(text: str, table: str, nth: int, key: str | None) -> str:
    """' line N': the line of `key = ...` in the `nth` `[[table]]` (or `[table]`) of
    the TOML `text`, else of that table's header; '' where there is none (a group
    written inline, `group = [...]`)."""
    header = re.compile(rf"^\s*\[\[?\s*{table}\s*\]\]?\s*(#.*)?$")
    lines, seen, at = text.splitlines(), 0, None
    for n, line in enumerate(lines, 1):
        if at is None:
            if header.match(line):
                seen += 1
                if seen == nth:
                    at = n
            continue
        if line.lstrip().startswith("["):  # the next table: the key is not here
            break
        if key and re.match(rf"^\s*[\"']?{re.escape(key)}[\"']?\s*[=.]", line):
            return f" line {n}"
    return f" line {at}" if at else ""


_TEXT_KEYS = ("root", "name", "queue", "hold", "note", "same_as")
# Config fields a group's `config` may not set: the cell's own (its envs, methods and
# seeds say them) and what `resolve` fills
_NOT_IN_CONFIG = ("env", "method", "seed", "switches", "update_dtype_why", "device_why")
_SWEEP_SETS = {"threads": "--threads"}
"""Config fields a group's `config` may not set because `sweep` sets them in every
cell, and its option: --threads is also the CPUs Ray reserves for a cell, so the plan's
value could not be honoured. Trap: a plan's `threads = 2` was replaced by sweep's
--threads (default 1) without a word (`sweep._overrides_plan` compares only the options
given); threads changes how fast a run goes, not its numbers (`same_as.NEUTRAL_FIELDS`),
so it is the machine's to say, not the grid's record."""


def option_values(path: str | Path, key: str) -> list:
    """The distinct values a plan file's cells set for the Config field `key` (a group's
    `config`), sorted; [] where no cell sets it."""
    return sorted({c.options[key] for c in read_plan(path) if key in c.options})


def _check_group(g: dict) -> str | None:
    """A group's (or [defaults]') keys of the wrong type, a `name` that is not one
    folder, a `config` field it may not set: one line, or None."""
    for key in _TEXT_KEYS:
        if key in g and not isinstance(g[key], str):
            return f"{key} is {g[key]!r}, not a string; allowed: a string"
    for key in ("root", "name", "same_as"):  # a NUL: a path no OS can make
        if "\0" in g.get(key, ""):
            return (
                f"{key} {g[key]!r} holds a NUL character; allowed: a path without one"
            )
    name = g.get("name")
    if name is not None and (name in ("", ".", "..") or "/" in name or "\\" in name):
        return f"name {name!r} is not one folder name; allowed: e.g. 'acder-raw'"
    options = g.get("config", {})
    if not isinstance(options, dict):
        return f"config is {options!r}, not a table; allowed: a table of Config fields"
    known = {f.name for f in fields(Config)}
    for key in options:
        if key in _NOT_IN_CONFIG:
            return (
                f"config may not set {key!r} (the cell's envs, methods and seeds "
                "do, or resolve fills it)"
            )
        if key in _SWEEP_SETS:
            return (
                f"config may not set {key!r}: sweep's {_SWEEP_SETS[key]} sets it for "
                f"every cell (the CPUs Ray reserves for it); allowed: sweep "
                f"{_SWEEP_SETS[key]} N, and no {key!r} in the plan"
            )
        if key not in known:
            allowed = ", ".join(sorted(known - set(_NOT_IN_CONFIG) - set(_SWEEP_SETS)))
            return f"config: unknown field {key!r}; allowed: {allowed}"
    return None


def _same_as_problem(g: dict, here: Path, root: Path) -> str | None:
    """A group's `same_as` that names no folder of runs a cell could ever be copied
    from, as one line (None if it can): a file (or a path under one), or the group's
    own run folders. Trap: the cells waited for ever ('its same_as run ... has not
    finished'), the sweep saying nothing more."""
    if "same_as" not in g:
        return None
    source = Path(os.path.normpath(here / g["same_as"]))
    p = file_in_the_way(source)
    if p:
        return (
            f"same_as {g['same_as']!r} is "
            + ("a file" if p == str(source) else f"under {p!r}, a file")
            + "; allowed: a folder of seed<k> runs"
        )
    for seed in g["seeds"]:
        run = source / f"seed{seed}"
        if run.exists() and not run.is_dir():
            return (
                f"same_as {g['same_as']!r}: its seed{seed} is a file; allowed: a "
                "folder of seed<k> runs"
            )
    own = run_dir(root, g["envs"][0], g.get("name", g["methods"][0]), 0).parent
    if source.resolve() == own.resolve():
        return (
            f"same_as {g['same_as']!r} is where the group's own runs go; allowed: "
            "the folder of another group's runs"
        )
    return None


def check_names(envs, methods, seeds, dashes: str = "") -> str | None:
    """Unknown names, and an env, method or seed given twice: what Config cannot see,
    since it checks one cell; the keys named as a plan has them, or (`dashes` "--") as
    sweep's options. Trap: `--envs X X` planned the cell twice, two tasks training
    into one folder."""
    for env in envs:
        if not isinstance(env, str) or env not in ENV_IDS:
            return f"unknown env {env!r}; allowed: {', '.join(ENV_IDS)}"
    for method in methods:
        if not isinstance(method, str) or method not in METHODS:
            return f"unknown method {method!r}; allowed: {', '.join(METHODS)}"
    if any(isinstance(s, bool) or not isinstance(s, int) or s < 0 for s in seeds):
        return "seeds must be integers >= 0"
    if any(s >= 2**64 for s in seeds):
        return "seeds must be integers < 2**64 (torch.manual_seed's range)"
    for key, values in (("envs", envs), ("methods", methods), ("seeds", seeds)):
        twice = next((v for i, v in enumerate(values) if v in values[:i]), None)
        if twice is not None:
            return f"{dashes}{key} gives {twice!r} twice; allowed: each {key[:-1]} once"
    return None


def check_pairs(envs, methods, options: dict | None = None) -> str | None:
    """The first (env, method) pair of a grid that Config refuses, alone or with
    `options` (a group's `config`), as one line naming the pair, or None.

    Trap: checking only the first pair let the others (EBP on Reach, sicm_angles on
    Reach) become skipped cells with exit 0."""
    for env, method in itertools.product(envs, methods):
        for what, fields_ in (("the pair", {}), ("config on the pair", options or {})):
            try:
                Config(**dict(fields_, env=env, method=method)).resolve()
            except (ConfigError, TypeError) as e:
                return f"{what} ({env}, {method}): {e}"
    return None
