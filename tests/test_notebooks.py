"""The chapters as committed: outputs stripped (`make book` executes them) and code
cells of at most 20 lines (package logic lives in the package; issue 13 asks it of
chapter 8, the house style of every chapter)."""

import glob
import json
import os
import re

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
def test_every_cell_has_a_unique_id(path):
    """nbformat 4.5 cells carry an id; without one every read warns
    (MissingIDFieldWarning), and a future nbformat refuses the file."""
    ids = [c.get("id") for c in json.load(open(path, encoding="utf-8"))["cells"]]
    missing = [i for i, x in enumerate(ids) if not x]
    assert not missing, f"cells {missing} have no id (nbformat.validator.normalize)"
    assert len(set(ids)) == len(ids), "two cells share an id"


@pytest.mark.parametrize("path", CHAPTERS, ids=os.path.basename)
def test_code_cells_are_short(path):
    long = {
        i: n
        for i, c in code_cells(path)
        if (n := len("".join(c["source"]).splitlines())) > MAX_CELL_LINES
    }
    assert not long, f"cells (index: lines) over {MAX_CELL_LINES} lines: {long}"


GLUE_REF = re.compile(r"\{glue(?::\w+)?\}`([^`:]+)")
GLUE_NAME = re.compile(r"glue\(\s*\"([^\"]+)\"")
GLUE_PREFIX = re.compile(r"glue\(\s*f\"([^\"{]*)\{")


@pytest.mark.parametrize("path", CHAPTERS, ids=os.path.basename)
def test_every_glued_reference_is_glued(path):
    """Each {glue:...}`name` of the text is glued by a code cell of the same chapter
    (a name built with an f-string counts by its fixed prefix). `make book` fails on a
    missing one (warnings are errors), and `make test` does not build the book."""
    cells = json.load(open(path, encoding="utf-8"))["cells"]
    code = "\n".join("".join(c["source"]) for c in cells if c["cell_type"] == "code")
    names = set(GLUE_NAME.findall(code))
    prefixes = [p for p in GLUE_PREFIX.findall(code) if p]
    text = "\n".join(
        "".join(c["source"]) for c in cells if c["cell_type"] == "markdown"
    )
    missing = sorted(
        {
            r
            for r in GLUE_REF.findall(text)
            if r not in names and not any(r.startswith(p) for p in prefixes)
        }
    )
    assert not missing, f"referenced but never glued: {missing}"


PAGE_GLUE_REF = re.compile(r"\{glue(?::(\w+))?\}`([\w/.-]+)::([\w-]+)(:\w*)?`")


def test_every_glued_reference_across_pages_is_glued_as_plain_text():
    """A book page quoting a chapter's glued value
    (`{glue:text}`../notebooks/NB.ipynb::key:s``; none does today: the introduction
    computes its own, tests/test_intro.py) names,
    relative to itself and with its suffix (Sphinx resolves it so), a chapter that
    glues that key with `other_pages=True`, and ends in a format spec: myst-nb pastes
    only text/plain across pages, and splits the role's text at its last ":", so
    without the spec it takes "...::" for the key. Either way `make book` fails."""
    pages = glob.glob(os.path.join(ROOT, "book", "*.md"))
    refs = [(p, *m) for p in pages for m in PAGE_GLUE_REF.findall(open(p).read())]
    for page, role, doc, key, spec in refs:
        where = f"{os.path.basename(page)}: {doc}::{key}"
        assert role == "text", f"{where}: only {{glue:text}} pastes across pages"
        assert spec, f"{where}: add a format spec (':s')"
        path = os.path.normpath(os.path.join(os.path.dirname(page), doc))
        assert path.endswith(".ipynb") and os.path.isfile(path), (
            f"{where}: no such file"
        )
        cells = json.load(open(path))["cells"]
        code = "\n".join(
            "".join(c["source"]) for c in cells if c["cell_type"] == "code"
        )
        assert re.search(rf'glue\("{key}", .*other_pages=True\)', code), (
            f"{where}: the chapter does not glue it with other_pages=True"
        )


@pytest.mark.parametrize("path", CHAPTERS, ids=os.path.basename)
def test_every_saved_scene_is_shown(path):
    """`viz.show_scene(name)` returns the scene's iframe; only a cell's last top-level
    expression is displayed, so inside an `if` (or mid-cell) it must be wrapped in
    `display(...)`, or the reader gets no 3D scene (chapter 10's did, once). And every
    scene a chapter saves is one it shows."""
    import ast

    saved, shown = set(), set()
    for i, c in code_cells(path):
        tree = ast.parse("".join(c["source"]))
        last = tree.body[-1] if tree.body else None
        for node in ast.walk(tree):
            attr = getattr(getattr(node, "func", None), "attr", "")
            if attr == "save_scene":  # save_scene(scene, name)
                saved.add(ast.unparse(node.args[1]))
            if attr != "show_scene":
                continue
            name = ast.unparse(node.args[0])
            bare = isinstance(last, ast.Expr) and last.value is node
            wrapped = any(
                isinstance(p, ast.Call) and getattr(p.func, "id", "") == "display"
                and node in p.args
                for p in ast.walk(tree)
            )  # fmt: skip
            assert bare or wrapped, f"cell {i}: show_scene({name}) is never displayed"
            shown.add(name)
    assert saved <= shown, f"scenes saved but not shown: {sorted(saved - shown)}"
