"""book/check_built.py, the checks `make book` runs over the built HTML: each check
finds the fault it names on a small built page, and passes a page without it. And the
table of contents puts the appendices after the chapters."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location(
    "check_built", ROOT / "book/check_built.py"
)
check_built = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check_built)

SOLUTION = (
    '<details class="sd-sphinx-override sd-dropdown sd-card sd-mb-3">'
    "<summary>Solution</summary><p>The answer.</p></details>"
)


def page(prose: str, code: str = "", exercises: int = 1, solutions: int = 1, img=""):
    items = "".join(
        f"<li><p>Do exercise {i}.</p>{SOLUTION if i < solutions else ''}</li>"
        for i in range(exercises)
    )
    return (
        '<html><body><article class="bd-article"><section><h1>A chapter</h1>'
        f"<p>{prose}</p>{img}"
        '<div class="cell docutils container">'
        '<div class="cell_input docutils container">'
        f"<pre>{code}</pre></div></div>"
        '<section><h2><span class="section-number">1.2. </span>Exercises'
        '<a class="headerlink" href="#x">#</a></h2>'
        f"<ol>{items}</ol></section></section></article></body></html>"
    )


def book(tmp_path, pages: dict[str, str]) -> Path:
    html = tmp_path / "html"
    (html / "notebooks").mkdir(parents=True)
    for name, text in pages.items():
        (html / name).write_text(text)
    return html


def test_a_clean_page_passes_and_its_words_are_counted(tmp_path):
    html = book(tmp_path, {"notebooks/02_x.html": page("one two three four", "a b")})
    assert check_built.problems(html) == []
    prose, code = check_built.words(html / "notebooks/02_x.html")
    # the heading, the paragraph, "Exercises", the item and its solution are prose
    assert code == 2 and prose > 4


def test_more_code_than_prose_is_found(tmp_path):
    html = book(tmp_path, {"notebooks/02_x.html": page("few words", "x = 1 " * 40)})
    (line,) = check_built.problems(html)
    assert "02_x.html" in line and "allowed: more prose than code" in line


def test_an_exercise_without_a_solution_is_found(tmp_path):
    html = book(tmp_path, {"notebooks/03_x.html": page("w " * 50, exercises=3)})
    found = check_built.problems(html)
    assert found == [
        "03_x.html: exercise 2 has no Solution dropdown",
        "03_x.html: exercise 3 has no Solution dropdown",
    ]


def test_chapter_8_is_held_to_its_length(tmp_path):
    long = "word " * (check_built.RESULTS_MAX + 10)
    html = book(tmp_path, {"notebooks/08_results.html": page(long)})
    (line,) = check_built.problems(html)
    assert "08_results.html" in line and "at most 3,600" in line


def test_an_image_without_words_is_found(tmp_path):
    imgs = {
        "no alt": '<img src="../_images/a.png">',
        "a file name": '<img alt="../_images/ab12.png" src="../_images/ab12.png">',
        "words": '<img alt="Test success against epochs, ACDER above HER" src="b.png">',
    }
    html = book(
        tmp_path,
        {
            f"notebooks/0{i}_x.html": page("w " * 50, img=v)
            for i, v in enumerate(imgs.values())
        },
    )
    found = check_built.problems(html)
    assert len(found) == 2 and all("allowed: words that say" in f for f in found)
    assert {f.split(":")[0] for f in found} == {
        "notebooks/00_x.html",
        "notebooks/01_x.html",
    }


def test_an_executed_notebook_is_counted_as_its_page_shows_it(tmp_path):
    import json

    nb = {
        "cells": [
            {"cell_type": "markdown", "metadata": {}, "source": ["one two three"]},
            {
                "cell_type": "code",
                "metadata": {"tags": ["remove-cell"]},
                "source": ["a b c d"],
                "outputs": [],
            },
            {
                "cell_type": "code",
                "metadata": {"tags": ["remove-input"]},
                "source": ["hidden code"],
                "outputs": [
                    {"output_type": "stream", "name": "stdout", "text": ["shown out"]}
                ],
            },
            {"cell_type": "code", "metadata": {}, "source": ["x = 1"], "outputs": []},
        ]
    }
    path = tmp_path / "a.ipynb"
    path.write_text(json.dumps(nb))
    assert check_built.notebook_words(path) == (
        3,
        2 + 2,
    )  # "shown out", "x", "1"? see below


def test_the_appendices_come_after_the_chapters():
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text())
    captions = [p["caption"] for p in toc["parts"]]
    assert captions.index("Chapters") < captions.index("Appendices")
    appendix = [
        c["file"] for c in toc["parts"][captions.index("Appendices")]["chapters"]
    ]
    assert "book/departures" in appendix
    chapters = [c["file"] for c in toc["parts"][captions.index("Chapters")]["chapters"]]
    assert "book/departures" not in chapters and len(chapters) == 10
