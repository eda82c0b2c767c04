"""Chapter 8's claims fail loudly when the runs stop supporting them.

Every number in chapter 8's prose is glued from the committed runs, and each claim has
a hidden assertion cell beside it. These tests run the chapter's code cells in order,
in one namespace, with `myst_nb.glue` recording what they glue (as tests/test_intro.py
does for the introduction), on copies of the run folders it reads, made by
`ACDER_RESULTS_ROOT`: the copy as committed glues every reference of the text; a seed
still training (no done.json) changes nothing the page says, since it reads finished
runs only; and a copy doctored so that one claim no longer holds stops the chapter at
that claim's assertion. One execution takes about ten seconds (`ACDER_FAST=1`: fewer
bootstrap resamples)."""

import csv
import json
import re
import shutil
from pathlib import Path

import pytest

from conftest import ROOT

CHAPTER = Path(ROOT) / "notebooks" / "08_results.ipynb"
READS = (
    "results",
    "experiments/readings",
    "experiments/constant-bonus",
    "experiments/sicm-sincos",
    "experiments/angle-wraps/buffer",
)
GLUE_REF = re.compile(r"\{glue(?::\w+)?\}`([^`:]+)`")
PP = "FetchPickAndPlace-v4"


def run_chapter(monkeypatch, root: Path) -> dict:
    """Execute chapter 8's code cells in order on the run folders under `root`;
    returns what they glued, name -> text."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import myst_nb

    glued = {}

    def glue(name, value, display=True):
        glued[name] = getattr(value, "data", value)  # IPython's Markdown: its text

    monkeypatch.setattr(myst_nb, "glue", glue)
    monkeypatch.setattr(plt, "show", lambda *a, **k: plt.close("all"))
    monkeypatch.setenv("ACDER_FAST", "1")
    monkeypatch.setenv("ACDER_RESULTS_ROOT", str(root))
    cells = json.loads(CHAPTER.read_text())["cells"]
    namespace = {"__name__": "__chapter8__"}
    for i, cell in enumerate(cells):
        if cell["cell_type"] == "code":
            source = "".join(cell["source"])
            exec(compile(source, f"08_results.ipynb, cell {i}", "exec"), namespace)
    return glued


def data_copy(tmp: Path) -> Path:
    """What the chapter reads, without policies, checkpoints and logs."""
    skip = shutil.ignore_patterns("*.pt", "checkpoint*", "*.log", ".*")
    for part in READS:
        shutil.copytree(Path(ROOT) / part, tmp / part, ignore=skip)
    return tmp


def rewrite(progress: Path, change) -> None:
    """progress.csv with `change(rows)` applied to its rows (dicts of strings)."""
    with open(progress, newline="") as f:
        reader = csv.DictReader(f)
        fields, rows = reader.fieldnames, list(reader)
    with open(progress, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(change(rows))


@pytest.fixture(scope="module")
def committed(tmp_path_factory):
    return data_copy(tmp_path_factory.mktemp("committed"))


def test_chapter_glues_every_reference_from_the_committed_runs(monkeypatch, committed):
    glued = run_chapter(monkeypatch, committed)
    cells = json.loads(CHAPTER.read_text())["cells"]
    text = "\n".join(
        "".join(c["source"]) for c in cells if c["cell_type"] == "markdown"
    )
    wanted = set(GLUE_REF.findall(text))
    assert wanted <= set(glued), f"never glued: {sorted(wanted - set(glued))}"
    bad = {k: v for k, v in glued.items() if re.search(r"\b(None|nan|inf)\b", str(v))}
    assert not bad, bad
    # the brief's numbers, as the committed runs give them: Push and the readings have
    # all their seeds; Pick&Place's grow as its seeds finish, so only their order
    assert (glued["icm_push"], glued["acder_push"]) == ("4,780", "5,876")
    assert (glued["norm_push"], glued["raw_push"]) == ("5,074", "5,918")
    icm_pp, acder_pp = (int(glued[k].replace(",", "")) for k in ("icm_pp", "acder_pp"))
    assert 9_000 < icm_pp < acder_pp


def test_a_seed_still_training_changes_nothing_the_chapter_says(monkeypatch, tmp_path):
    """Pick&Place's DDPG+HER and ACDER get a seed 4 in training (the first rows of
    seed 0, no done.json): the page reads finished runs only, so every glued value
    stays as it was but the count of runs in training."""
    root = data_copy(tmp_path)
    for name in ("her", "acder"):  # a seed 4 training here already: not in the copy
        shutil.rmtree(root / "results" / PP / name / "seed4", ignore_errors=True)
    before = run_chapter(monkeypatch, root)
    for name in ("her", "acder"):
        cell = root / "results" / PP / name
        shutil.copytree(cell / "seed0", cell / "seed4")
        (cell / "seed4" / "done.json").unlink()
        config = json.loads((cell / "seed4" / "config.json").read_text())
        config["seed"] = config["config"]["seed"] = 4
        (cell / "seed4" / "config.json").write_text(json.dumps(config))
        rewrite(cell / "seed4" / "progress.csv", lambda rows: rows[:3])
    during = run_chapter(monkeypatch, root)
    changed = {k for k in before if before[k] != during.get(k)}
    assert changed == {"n_training"}, changed
    assert int(during["n_training"]) == int(before["n_training"]) + 2


def test_the_chapter_stops_where_a_claim_no_longer_holds(monkeypatch, tmp_path):
    """DDPG+HER+ICM's Push seeds made slower (each test success moved 8 evaluations
    later): it no longer crosses before ACDER, and the assertion beside the verdict's
    second finding stops the chapter."""
    root = data_copy(tmp_path)
    for seed in sorted((root / "results" / "FetchPush-v4" / "her-icm").glob("seed*")):

        def later(rows):
            success = [r["test_success"] for r in rows]
            for i, r in enumerate(rows):
                r["test_success"] = success[i - 8] if i >= 8 else "0.0"
            return rows

        rewrite(seed / "progress.csv", later)
    with pytest.raises(AssertionError, match="only ICM before ACDER on Push"):
        run_chapter(monkeypatch, root)


def test_the_chapter_asks_for_a_rewrite_once_pick_and_place_has_every_seed(
    monkeypatch, tmp_path
):
    """The verdict's Pick&Place sentence is written for seeds still to come. With all
    five of DDPG+HER's and ACDER's seeds finished (seeds 3 and 4 here copies of seeds
    0 and 1), its assertion fails and names why: the sentence must be rewritten."""
    root = data_copy(tmp_path)
    for name in ("her", "acder"):
        cell = root / "results" / PP / name
        for seed, source in ((3, 0), (4, 1)):
            shutil.rmtree(cell / f"seed{seed}", ignore_errors=True)
            shutil.copytree(cell / f"seed{source}", cell / f"seed{seed}")
            config = json.loads((cell / f"seed{seed}" / "config.json").read_text())
            config["seed"] = config["config"]["seed"] = seed
            (cell / f"seed{seed}" / "config.json").write_text(json.dumps(config))
    with pytest.raises(AssertionError, match="all seeds in"):
        run_chapter(monkeypatch, root)
