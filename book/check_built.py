"""Checks over the built book (`make book` runs it after Jupyter Book): what a reader
sees.

For every chapter page (`notebooks/*.html`):
- its prose outweighs its code and output: words outside code cells and `<pre>` blocks
  against words inside them (a cell's source, its printed output, its tables). Hidden
  cells are not in the HTML, so they count for nothing; a collapsed solution is prose a
  reader opens.
- every exercise has a solution: the "Exercises" section has one `Solution` dropdown per
  item.
- chapter 8, the results page, holds at most `RESULTS_MAX` words of prose (its detail is
  an appendix page).
On every page of the book: every `<img>` has alt text, and the alt text is not a file
name (Sphinx writes the image's path there when a figure has none).

`words(path)` and `problems(html_dir)` are what tests/test_book_checks.py calls; run as
`python book/check_built.py [_build/html]`: one line per problem, exit 1 if any, else
one line per chapter with its counts. `python book/check_built.py X.ipynb ...` counts
executed notebooks instead (`notebook_words`), for a writer checking one chapter.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from bs4 import BeautifulSoup

WORD = re.compile(r"[A-Za-z0-9][\w.,'%/+-]*")
RESULTS_MAX = 3600
"""Chapter 8's prose, at most: the issue's 'about 3,500 words'."""
FILENAME = re.compile(r"(^|/)[\w.-]+\.(png|svg|gif|jpe?g|webp)$", re.IGNORECASE)


def _article(html: str):
    soup = BeautifulSoup(html, "html.parser")
    art = soup.find("article") or soup.find("main") or soup
    for tag in art.find_all(["script", "style"]):
        tag.decompose()
    for tag in art.find_all(class_="headerlink"):
        tag.decompose()
    return art


def words(path: str | Path) -> tuple[int, int]:
    """(prose words, code-and-output words) of one built page."""
    art = _article(Path(path).read_text(encoding="utf-8"))
    code = 0
    for cls in ("cell_input", "cell_output"):
        for c in art.find_all(class_=cls):
            code += len(WORD.findall(c.get_text(" ")))
            c.decompose()
    for c in art.find_all("pre"):
        code += len(WORD.findall(c.get_text(" ")))
        c.decompose()
    return len(WORD.findall(art.get_text(" "))), code


def notebook_words(path: str | Path) -> tuple[int, int]:
    """(prose words, code-and-output words) of an *executed* notebook, as its built page
    would show them: a `remove-cell` counts for nothing, `remove-input` and
    `remove-output` drop their part. A quick measure while writing a chapter; the built
    page (`words`) is the one the checks use."""
    import json

    nb = json.loads(Path(path).read_text(encoding="utf-8"))
    prose = code = 0
    for cell in nb["cells"]:
        tags = set(cell.get("metadata", {}).get("tags", []))
        if "remove-cell" in tags:
            continue
        text = "".join(cell["source"])
        if cell["cell_type"] == "markdown":
            prose += len(WORD.findall(text))
            continue
        if cell["cell_type"] != "code":
            continue
        if "remove-input" not in tags:
            code += len(WORD.findall(text))
        if "remove-output" in tags:
            continue
        for out in cell.get("outputs", []):
            if "text" in out:
                code += len(WORD.findall("".join(out["text"])))
            data = out.get("data", {})
            for mime in ("text/html", "text/markdown", "text/plain"):
                if mime in data:
                    body = "".join(data[mime])
                    if mime == "text/html":
                        body = BeautifulSoup(body, "html.parser").get_text(" ")
                    code += len(WORD.findall(body))
                    break
    return prose, code


def _exercise_problems(art, name: str) -> list[str]:
    head = next(
        (
            h
            for h in art.find_all(["h2", "h3"])
            if re.fullmatch(r"[\d.\s]*Exercises#?", h.get_text().strip())
        ),
        None,
    )
    if head is None:
        return [f"{name}: no 'Exercises' section"]
    section = head.find_parent("section")
    items = section.find_all("li", recursive=True) if section else []
    top = [li for li in items if not li.find_parent("li")]
    missing = [
        i + 1
        for i, li in enumerate(top)
        if not any(
            "Solution" in d.get_text()
            for d in li.find_all(
                ["details", "summary", "div"], class_=re.compile("drop")
            )
        )
    ]
    if not top:
        return [f"{name}: the 'Exercises' section lists no exercise"]
    return [f"{name}: exercise {i} has no Solution dropdown" for i in missing]


def problems(html_dir: str | Path) -> list[str]:
    """Every problem the checks find in a built book, one line each."""
    html_dir = Path(html_dir)
    out = []
    for page in sorted((html_dir / "notebooks").glob("*.html")):
        prose, code = words(page)
        if prose <= code:
            out.append(
                f"{page.name}: {prose:,} words of prose against {code:,} of code "
                "and output; allowed: more prose than code"
            )
        if page.name.startswith("08_") and prose > RESULTS_MAX:
            out.append(
                f"{page.name}: {prose:,} words of prose; allowed: at most "
                f"{RESULTS_MAX:,} (the detail goes to the appendix)"
            )
        if page.name[:2].isdigit():
            art = _article(page.read_text(encoding="utf-8"))
            out += _exercise_problems(art, page.name)
    for page in sorted(html_dir.rglob("*.html")):
        rel = page.relative_to(html_dir)
        if rel.parts[0] in ("_static", "_sources", "genindex.html", "search.html"):
            continue
        soup = BeautifulSoup(page.read_text(encoding="utf-8"), "html.parser")
        for img in soup.find_all("img"):
            alt = (img.get("alt") or "").strip()
            src = img.get("src", "")
            if "logo" in " ".join(img.get("class", [])):
                continue
            if not alt or FILENAME.search(alt) or alt == src:
                out.append(
                    f"{rel}: <img src={src!r}> has alt text {alt!r}; allowed: "
                    "words that say what the figure shows"
                )
    return out


def main(argv: list[str]) -> int:
    if argv and argv[0].endswith(".ipynb"):
        for path in argv:
            prose, code = notebook_words(path)
            print(
                f"{Path(path).stem:28s} prose {prose:6,d}  code and output {code:6,d}"
            )
        return 0
    html_dir = Path(argv[0] if argv else "_build/html")
    if not (html_dir / "notebooks").is_dir():
        print(f"check_built: {html_dir} holds no built chapters; run `make book` first")
        return 2
    found = problems(html_dir)
    for line in found:
        print(line)
    if not found:
        for page in sorted((html_dir / "notebooks").glob("*.html")):
            prose, code = words(page)
            print(f"{page.stem:28s} prose {prose:6,d}  code and output {code:6,d}")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
