"""The book's first page (book/intro.md), a MyST-NB text notebook: its hidden cells read
the committed runs, glue every number of "What we found" into the prose and assert each
claim. `make test` does not build the book, so these tests run the page's code cells in
order, in one namespace, with `myst_nb.glue` recording what they glue: its assertions
run here, on the runs as committed, on copies of them in the states the grid passes
through (Pick&Place seeds in training, then finished), and on a copy doctored so that a
claim no longer holds, which must fail."""

import csv
import json
import re
import shutil
from pathlib import Path

import pytest
import yaml

from conftest import ROOT

INTRO = Path(ROOT) / "book" / "intro.md"
CELL = re.compile(r"^```\{code-cell\}[^\n]*\n(.*?)^```[ \t]*$", re.S | re.M)
GLUE_REF = re.compile(r"\{glue(?::\w+)?\}`([\w-]+)`")
GLUE_FIGURE = re.compile(r"^```\{glue:figure\}\s+([\w-]+)", re.M)
PP = "FetchPickAndPlace-v4"


def front_matter(text: str) -> dict:
    head = re.match(r"^---\n(.*?)\n---\n", text, re.S)
    assert head, "intro.md starts with its front matter"
    return yaml.safe_load(head.group(1))


def code_cells(text: str) -> list[tuple[dict, str]]:
    """(options, source) of each ```{code-cell} block: the `:key: value` lines that
    open it, then its code."""
    out = []
    for m in CELL.finditer(text):
        lines = m.group(1).splitlines()
        options = {}
        while lines and re.match(r"^:\w+:", lines[0]):
            key, value = re.match(r"^:(\w+):\s*(.*)$", lines.pop(0)).groups()
            options[key] = yaml.safe_load(value)
        out.append((options, "\n".join(lines)))
    return out


def prose(text: str) -> str:
    """The page without its front matter and code cells."""
    return CELL.sub("", re.sub(r"^---\n.*?\n---\n", "", text, count=1, flags=re.S))


def run_intro(monkeypatch, root: Path | None = None) -> dict:
    """Execute the page's code cells in order (ACDER_FAST=1, results from `root`, the
    checkout by default); returns what they glued, name -> text (or the figure)."""
    import matplotlib

    matplotlib.use("Agg")
    import myst_nb

    glued = {}

    def glue(name, value, display=True):
        glued[name] = getattr(value, "data", value)  # IPython's Markdown: its text

    monkeypatch.setattr(myst_nb, "glue", glue)
    monkeypatch.setenv("ACDER_FAST", "1")
    if root is None:
        monkeypatch.delenv("ACDER_INTRO_ROOT", raising=False)
    else:
        monkeypatch.setenv("ACDER_INTRO_ROOT", str(root))
    namespace = {"__name__": "__intro__"}
    for i, (_, source) in enumerate(code_cells(INTRO.read_text())):
        exec(compile(source, f"book/intro.md, code cell {i}", "exec"), namespace)
    return glued


def data_copy(tmp: Path) -> Path:
    """What the page reads, copied without policies and checkpoints: results/, the
    readings, the replay buffers read back."""
    skip = shutil.ignore_patterns("*.pt", "checkpoint*", "*.log", ".*")
    for part in ("results", "experiments/readings", "experiments/angle-wraps/buffer"):
        shutil.copytree(Path(ROOT) / part, tmp / part, ignore=skip)
    return tmp


def read_rows(path: Path) -> tuple[list[str], list[dict]]:
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


def write_rows(path: Path, fields: list[str], rows: list[dict]) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)


def seed_like(cell: Path, seed: int, source: int, rows: int | None, done: bool):
    """Seed `seed` of a cell folder, made from seed `source`: its first `rows` rows of
    progress.csv (all with None), config.json with the seed changed, and done.json
    only if `done` (else it reads as still training)."""
    src, dst = cell / f"seed{source}", cell / f"seed{seed}"
    shutil.rmtree(dst, ignore_errors=True)
    dst.mkdir()
    fields, table = read_rows(src / "progress.csv")
    write_rows(dst / "progress.csv", fields, table if rows is None else table[:rows])
    config = json.loads((src / "config.json").read_text())
    config["seed"] = config["config"]["seed"] = seed
    (dst / "config.json").write_text(json.dumps(config))
    if done:
        shutil.copy(src / "done.json", dst / "done.json")


def test_intro_is_a_text_notebook_the_book_executes():
    """Front matter of a MyST-NB text notebook (python3), executed by the book's
    settings (not excluded), every code cell hidden from the reader; "What we found"
    comes first, after one paragraph on what ACDER is."""
    text = INTRO.read_text()
    meta = front_matter(text)
    assert meta["file_format"] == "mystnb" and meta["kernelspec"]["name"] == "python3"
    config = yaml.safe_load((Path(ROOT) / "_config.yml").read_text())
    assert config["execute"]["execute_notebooks"] in ("force", "auto", "cache")
    excluded = config.get("exclude_patterns", []) + config["execute"].get(
        "exclude_patterns", []
    )
    assert not any(Path("book/intro.md").match(p) for p in excluded)
    cells = code_cells(text)
    assert len(cells) > 5
    for options, source in cells:
        assert {"remove-cell", "remove-input"} & set(options.get("tags", []))
        long = [line for line in source.splitlines() if len(line) > 88]
        assert not long, f"code lines over the book's 88 columns: {long}"
        lines = source.strip("\n").splitlines()
        assert len(lines) <= 20, f"a cell of {len(lines)} lines (20 at most): split it"
    body = prose(text)
    title, rest = body.split("\n## ", 1)
    assert rest.startswith("What we found\n")
    paragraphs = [p for p in title.split("\n\n")[1:] if p.strip()]
    assert len(paragraphs) == 1, "before 'What we found': one paragraph on ACDER"
    found = GLUE_REF.sub("", rest.split("```{glue:figure}")[0])
    typed = re.findall(r"\S*\d\S*", re.sub(r"\b(Fig\.|Eq\.|chapter) \d+", "", found))
    assert not typed, f"numbers typed in 'What we found' (glue them): {typed}"


def test_intro_runs_on_the_committed_runs_and_glues_every_number(monkeypatch):
    glued = run_intro(monkeypatch)
    text = prose(INTRO.read_text())
    wanted = set(GLUE_REF.findall(text)) | set(GLUE_FIGURE.findall(text))
    assert wanted <= set(glued), f"never glued: {sorted(wanted - set(glued))}"
    texts = {k: v for k, v in glued.items() if isinstance(v, str)}
    bad = {k: v for k, v in texts.items() if re.search(r"\bNone\b|\bnan\b|\binf\b", v)}
    assert not bad
    assert glued["table_bars"].__class__.__name__ == "Figure"
    # the paper's ratios beside ours, Reach and Push read in full
    assert (glued["paper_ratio_reach"], glued["paper_ratio_push"]) == ("5.6", "5.3")


def test_intro_holds_while_pick_and_place_seeds_train(monkeypatch, tmp_path):
    """Pick&Place's seeds 3 and 4 of HER and ACDER commit mid-run (no done.json): the
    page reads the finished seeds and says how many of the planned are in; its
    assertions hold. So it does with none of them committed yet (seeds 0-2 only)."""
    root = data_copy(tmp_path)
    for name in ("her", "acder"):
        for seed in (3, 4):
            shutil.rmtree(root / "results" / PP / name / f"seed{seed}", True)
    before = run_intro(monkeypatch, root)
    assert "finished so far" in before["pp_seeds"], before["pp_seeds"]
    for name in ("her", "acder"):
        cell = root / "results" / PP / name
        seed_like(cell, 3, source=0, rows=6, done=False)
        seed_like(cell, 4, source=1, rows=2, done=False)
    during = run_intro(monkeypatch, root)
    assert during["pp_seeds"] == before["pp_seeds"]
    for key in ("pp_ratio", "pp_icm", "pp_ablation"):
        assert during[key] == before[key]
    # ACDER's seed 3 finishes before HER's (a copy of its seed 0 stands in for it)
    seed_like(root / "results" / PP / "acder", 3, source=0, rows=None, done=True)
    later = run_intro(monkeypatch, root)
    assert later["pp_seeds"] == (
        "3 of DDPG+HER's 5 seeds and 4 of DDPG+ACDER's 5 finished so far, the others "
        "to come"
    )
    assert "ACDER's 4 finished seeds" in later["pp_ablation"]


def test_intro_holds_once_pick_and_place_has_all_its_seeds(monkeypatch, tmp_path):
    """All five seeds of Pick&Place's HER and ACDER finished (here seeds 3 and 4 are
    copies of seeds 0 and 1, a stand-in for runs not done yet): the page says so, and
    the rule reads the ablations itself."""
    root = data_copy(tmp_path)
    for name in ("her", "acder"):
        cell = root / "results" / PP / name
        seed_like(cell, 3, source=0, rows=None, done=True)
        seed_like(cell, 4, source=1, rows=None, done=True)
    glued = run_intro(monkeypatch, root)
    assert glued["pp_seeds"] == "all 5 seeds of each"
    assert "finished seeds" not in glued["pp_ablation"]


@pytest.mark.parametrize(
    "env, name, later, match",
    [
        # slower: DDPG+HER+ICM no longer crosses before ACDER on Push
        ("FetchPush-v4", "her-icm", 8, "finding 2"),
        # faster: it crosses first outside ACDER's interval, which the verdict denies
        ("FetchPush-v4", "her-icm", -4, r"finding 2: HER\+ICM's crossing outside"),
        # without start states no longer faster than full ACDER on Reach
        ("FetchReach-v4", "acder-no-start-states", 2, "finding 3: faster on Reach"),
    ],
)
def test_intro_fails_when_a_claim_no_longer_holds(
    monkeypatch, tmp_path, env, name, later, match
):
    """A cell's seeds made slower or faster (each test success moved `later`
    evaluations later, or earlier where negative; a failure before the first, the last
    value after the last): the claim it supports no longer holds, and its assertion
    stops the page."""
    root = data_copy(tmp_path)
    for seed in sorted((root / "results" / env / name).glob("seed*")):
        fields, rows = read_rows(seed / "progress.csv")
        success = [r["test_success"] for r in rows]
        for i, r in enumerate(rows):
            j = min(max(i - later, 0), len(rows) - 1)
            r["test_success"] = success[j] if 0 <= i - later else "0.0"
        write_rows(seed / "progress.csv", fields, rows)
    with pytest.raises(AssertionError, match=match):
        run_intro(monkeypatch, root)
