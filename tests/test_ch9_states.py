"""Chapter 9's paragraph on the 400-epoch run, in each state that run can be in.

The chapter reads the 400-epoch DDPG+ACDER run of FetchPushMultiStep-v0 from
results/ as it is when the book is built, and hidden cells (`STATE_CELLS`) pick one of
five paragraphs for it: queued (no folder, or no evaluation yet), in flight with the
rule not met, in flight with the rule met, finished without it, finished with it. Today
the run is only planned; the other states come over weeks of compute, and a slip in
their cells (a format key F lacks, a KeyError) would break the book build only then.
These tests run those cells alone, in order, in one namespace holding what the
chapter's earlier cells define (the chance level as fixed numbers: the cells that
count it simulate env resets), on synthetic run folders made from the real 40-epoch
run (its config.json and progress.csv, extended and edited), and check that each state
gets its paragraph with every field filled in."""

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest

from acder_lite.book import multistep_report as MR
from acder_lite.book import utils as BU
from acder_lite.config import TASK_PRESETS
from conftest import ROOT

CHAPTER = Path(ROOT) / "notebooks" / "09_multistep_push.ipynb"
ENV = "FetchPushMultiStep-v0"
SHORT = Path(ROOT) / MR.SHORT_ROOT / ENV / "acder" / "seed0"
STATE_CELLS = ("c9a10016b", "c9a10017", "c9a10018", "c9a10019", "c9a10020")
STATE_CELLS += ("c9a10021", "c9a10022", "c9a10023", "c9a10024")
"""The hidden cells that read the 400-epoch run and glue its paragraphs, in order."""
BOX = "c9a10025"
"""The markdown cell that pastes them."""
GLUE_REF = re.compile(r"\{glue(?::\w+)?\}`([^`:]+)`")
BLOCKS = dict(
    block0_on_target=0.0875,
    block1_on_target=0.075,
    block0_moved=0.5,
    block1_moved=0.45,
    pool_block_on_target=0.3,
)
"""Per-block columns as today's trainer writes them (the 40-epoch run has none)."""


def chapter_cells() -> dict:
    cells = json.loads(CHAPTER.read_text(encoding="utf-8"))["cells"]
    return {c.get("id"): (i, c) for i, c in enumerate(cells)}


@pytest.fixture(scope="module")
def acder40():
    """The real 40-epoch ACDER run, read as the chapter reads it."""
    runs = MR.read_runs(Path(ROOT) / MR.SHORT_ROOT / ENV, Path(ROOT))
    return next(r for r in runs if r["name"] == "acder")


def run_cells(root: Path, acder40: dict) -> tuple[dict, dict]:
    """Execute `STATE_CELLS` in order on the run folders under `root`; returns (what
    they glued, name -> text; the namespace)."""
    by_id = chapter_cells()
    missing = [c for c in STATE_CELLS if c not in by_id]
    assert not missing, f"chapter 9 has no cell {missing}: renamed? fix STATE_CELLS"
    where = [by_id[c][0] for c in STATE_CELLS]
    assert where == sorted(where), "the state cells are no longer in this order"
    glued = {}
    n0, both0 = 10_000, 66  # the chance level of cell 60a5cb20, about the real one
    ns = dict(  # the first cell's imports, then what the cells before these define
        __name__="__chapter9__",
        Path=Path,
        np=np,
        MR=MR,
        BU=BU,
        percent=BU.percent,
        glue=lambda name, value, **kw: glued.__setitem__(name, value),  # no display
        ENV=ENV,
        P=TASK_PRESETS[ENV],
        ROOT=root,
        n0=n0,
        both0=both0,
        chance=both0 / n0,
        each=np.array([0.08, 0.075]),  # each block's share alone (cell c9a10007)
        acder40=acder40,
    )
    for cid in STATE_CELLS:
        source = "".join(by_id[cid][1]["source"])
        exec(compile(source, f"09_multistep_push.ipynb, cell {cid}", "exec"), ns)
    return glued, ns


def write_long_run(
    folder: Path,
    epochs: int = 0,
    later: float = 0.0,
    edits: dict | None = None,
    blocks: bool = True,
    done: dict | None = None,
    cpu: str | None = None,
    progress: bool = True,
) -> list[dict]:
    """A 400-epoch run folder made from the real 40-epoch one: its config.json with
    `--epochs 400` (and `cpu` in its versions), and with `progress`, `epochs` rows of
    progress.csv: the 40 real rows, then rows whose test success is `later`, then
    `edits` ({epoch: test success}) applied, with the per-block columns (`BLOCKS`)
    where `blocks`. With `done` (what to change in the real done.json), done.json.
    Returns the rows written (strings)."""
    folder.mkdir(parents=True)
    whole = json.loads((SHORT / "config.json").read_text())
    # the plan is read from the command's --epochs (read.planned_epochs), not config
    whole["command"] = whole["command"].replace("--epochs 40 ", "--epochs 400 ")
    assert "--epochs 400 " in whole["command"]
    whole["config"]["epochs"] = 400
    if cpu:
        whole["versions"] = dict(whole["versions"], cpu=cpu)
    (folder / "config.json").write_text(json.dumps(whole, indent=2))
    if not progress:
        return []
    with open(SHORT / "progress.csv", newline="") as f:
        reader = csv.DictReader(f)
        fields, real = list(reader.fieldnames), list(reader)
    rows = []
    for i in range(epochs):
        e = i + 1
        row = dict(real[i % len(real)])
        if i >= len(real):  # trap: episodes must grow row by row, or read_run refuses
            row.update(epoch=e, cycle=50 * e, episodes=400 * e, env_steps=40_000 * e)
            row.update(wall_s=200.0 * e, test_success=later)
        if e in (edits or {}):
            row["test_success"] = edits[e]
        if blocks:  # the pool is empty at the first evaluation: its share is NaN
            row.update(BLOCKS, pool_block_on_target="nan" if e == 1 else 0.3)
        rows.append(row)
    with open(folder / "progress.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields + (list(BLOCKS) if blocks else []))
        w.writeheader()
        w.writerows(rows)
    if done is not None:
        info = json.loads((SHORT / "done.json").read_text())
        info.update(epochs=float(epochs), episodes=400 * epochs)
        info.update(final_test_success=float(rows[-1]["test_success"]))
        info["stop_rule"]["budget_epochs"] = 400
        info.update(done)
        (folder / "done.json").write_text(json.dumps(info, indent=2))
    return rows


RUN5 = {e: 0.1 for e in range(46, 51)}  # 8 of 80 each: exactly at the level counts
EARLY5 = {e: 0.125 for e in range(31, 36)}  # within the 40 rows: they now differ
CASES = {  # name: (the state the cells read, write_long_run's arguments; None: none)
    "planned": ("planned", None),
    "started": ("started", dict(progress=False)),
    "started, progress.csv without a row": ("started", dict(epochs=0)),
    "in flight at chance, the 40 rows": ("in flight", dict(epochs=40, blocks=False)),
    "in flight above chance, four at the level": (
        "in flight",
        dict(epochs=60, later=0.05, edits={e: 0.125 for e in range(51, 55)}),
    ),
    "in flight, the rule met": ("in flight", dict(epochs=60, edits=RUN5)),
    "finished below chance, the rule not met": (
        "finished",
        dict(epochs=400, edits={3: 0.0125}, done={}),
    ),
    "finished, the rule met, cut": (
        "finished",
        dict(epochs=80, edits=EARLY5, done={}, cpu="AMD EPYC 7B13"),
    ),
}
STARTS = {  # (state, rule met): how its paragraph starts
    ("in flight", False): "**In flight, at epoch {last} of 400 (",
    ("in flight", True): "**In flight at epoch {last} of 400, and the rule is met.**",
    ("finished", False): "**Finished, the rule not met.** It ended at epoch {last} (",
    ("finished", True): "**Finished, the rule met.** It ended at epoch {last} (",
    ("planned", False): "**Queued.** Its folder does not exist yet",
    ("started", False): "**Queued.** Its folder holds its config.json",
}


def met_at(rows: list[dict], level=MR.RULE_LEVEL, times=MR.RULE_EVALUATIONS):
    """The epoch of the row that first completes `times` rows in a row at `level` or
    more, counted here apart from MR.rule_reading; None if none does."""
    streak = 0
    for r in rows:
        streak = streak + 1 if float(r["test_success"]) >= level else 0
        if streak == times:
            return int(r["epoch"])
    return None


@pytest.mark.parametrize("name", CASES)
def test_each_state_of_the_long_run_gets_its_paragraph(name, tmp_path, acder40):
    state, case = CASES[name]
    folder = tmp_path / MR.LONG_ROOT / ENV / "acder" / "seed0"
    rows = [] if case is None else write_long_run(folder, **case)
    case = case or {}
    glued, ns = run_cells(tmp_path, acder40)
    assert ns["STATE"] == state

    box = "".join(chapter_cells()[BOX][1]["source"])
    wanted = set(GLUE_REF.findall(box)) | {"long_summary"}
    assert wanted <= set(glued), f"never glued: {sorted(wanted - set(glued))}"
    for key, text in glued.items():
        assert isinstance(text, str), (key, text)
        assert not re.search(r"[{}]", text), f"{key}: a field left unfilled: {text}"
        assert not re.search(r"\b(None|nan|inf)\b", text), f"{key}: {text}"

    text, summary = glued["long_text"], glued["long_summary"]
    last, when = (int(rows[-1]["epoch"]) if rows else 0), met_at(rows)
    assert ns["LONG"]["epoch"] == last
    assert text.startswith(STARTS[state, when is not None].format(last=last)), text
    assert ns["RULE"]["met"] == (when is not None) == ("the rule met" in name)
    assert ns["RULE"]["met_at"] == when
    if when is not None:
        assert f"at epoch {when}" in text and f"at epoch {when}" in summary
    elif rows:
        assert re.search("not met|without meeting", summary), summary
    if state == "in flight" and when is None:  # the paragraph that gives the share
        assert f"({last / 400:.0%} of the budget)" in text, text
    if state == "finished":
        ended = "its full budget" if last == 400 else "cut short before its budget"
        assert f"It ended at epoch {last} ({ended})" in text, text
    verdict = re.search(r"(at|above|below) chance", name)
    if verdict:
        assert f"{verdict[1]} the chance level of" in text, text

    blocks, first = glued["blocks_text"], glued["first_rows_text"]
    assert bool(blocks) == bool(first) == bool(rows)
    if not rows:
        return
    if case.get("blocks", True):
        assert blocks.startswith("Over its last 5 evaluations, block 0 ended"), blocks
    else:
        assert blocks == "This run's progress.csv has no per-block columns."
    m = min(len(rows), 40)
    edited = [e for e in case.get("edits", {}) if e <= 40]
    if not edited:
        assert first.startswith(f"Its first {m} evaluations repeat"), first
    else:
        start = f"Its first {m} evaluations do not repeat the 40-epoch run's: the "
        start += f"first difference is at epoch {min(edited)} in `test_success`"
        assert first.startswith(start), first
        cpu = case.get("cpu")
        said = f"this run's config.json records {cpu}" if cpu else "nor does this one"
        assert said in first, first


def test_the_cases_cover_every_state_and_paragraph():
    """Every paragraph has a case, and a state added to `MR.RUN_STATES` needs one."""
    assert {state for state, _ in CASES.values()} == set(MR.RUN_STATES)
    assert {(s, "the rule met" in n) for n, (s, _) in CASES.items()} == set(STARTS)
