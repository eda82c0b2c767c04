"""The chapters as committed: outputs stripped (`make book` executes them) and code
cells of at most 20 lines (package logic lives in the package; issue 13 asks it of
chapter 8, the house style of every chapter)."""

import glob
import json
import os

import pytest

from conftest import ROOT

CHAPTERS = sorted(glob.glob(os.path.join(ROOT, "notebooks", "*.ipynb")))
MAX_CELL_LINES = 20


def code_cells(path):
    cells = json.load(open(path, encoding="utf-8"))["cells"]
    return [(i, c) for i, c in enumerate(cells) if c["cell_type"] == "code"]


@pytest.mark.parametrize("path", CHAPTERS, ids=os.path.basename)
def test_committed_without_outputs(path):
    kept = [i for i, c in code_cells(path) if c["outputs"] or c["execution_count"]]
    assert not kept, f"cells {kept} keep outputs: strip them before committing"


@pytest.mark.parametrize("path", CHAPTERS, ids=os.path.basename)
def test_code_cells_are_short(path):
    long = {
        i: n
        for i, c in code_cells(path)
        if (n := len("".join(c["source"]).splitlines())) > MAX_CELL_LINES
    }
    assert not long, f"cells (index: lines) over {MAX_CELL_LINES} lines: {long}"
