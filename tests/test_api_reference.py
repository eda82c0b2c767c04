"""The book's API reference (book/api.md; sphinx-autodoc2 writes a page a module under
book/apidocs/ when the book is built, _config.yml): a new module of acder_lite gets a
page in the toc and a place on book/api.md's map of the data flow, so none is
forgotten. Cheap: no book is built (tests/test_browser.py builds one with these pages).
"""

from __future__ import annotations

import re
from pathlib import Path

import yaml
from autodoc2.utils import yield_modules
from sphinx.util.matching import patmatch

ROOT = Path(__file__).resolve().parent.parent
CONFIG = yaml.safe_load((ROOT / "_config.yml").read_text())
AUTODOC2 = {
    k: v for k, v in CONFIG["sphinx"]["config"].items() if k.startswith("autodoc2_")
}
API_PAGE = "book/api"


def public_modules() -> list[str]:
    """The modules autodoc2 writes a page for, as it finds them (no import), but for
    private ones (`_name`, `__main__`)."""
    (package,) = AUTODOC2["autodoc2_packages"]
    skip = [re.compile(p) for p in AUTODOC2.get("autodoc2_skip_module_regexes", [])]
    # a folder's __init__ is its subpackage's page (acder_lite.algo.__init__ -> algo)
    names = [
        name.removesuffix(".__init__") for _, name in yield_modules(ROOT / package)
    ]
    return sorted(
        n
        for n in names
        if not any(part.startswith("_") for part in n.split("."))
        and not any(p.fullmatch(n) for p in skip)
        and n != package
    )


def _api_entries() -> list[str]:
    """The `file:`s and `glob:`s below the API page in _toc.yml."""
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text())
    found = []

    def walk(node):
        for child in node.get("parts", []) + node.get("chapters", []):
            if child.get("file") == API_PAGE:
                found.append(child)
            walk(child)

    walk(toc)
    assert len(found) == 1, f"{API_PAGE} is {len(found)} times in _toc.yml"
    return [e.get("file") or e.get("glob") for e in found[0].get("sections", [])]


def test_public_modules_are_found():
    mods = public_modules()
    assert "acder_lite.algo.rewards" in mods and "acder_lite.train.trainer" in mods, (
        mods
    )
    assert len(mods) >= 40, mods


def test_every_module_has_a_page_in_the_toc():
    out = AUTODOC2["autodoc2_output_dir"]
    entries = _api_entries()
    missing = [
        m
        for m in public_modules()
        if not any(patmatch(f"{out}/acder_lite/{m}", e) for e in entries)
    ]
    assert not missing, (
        f"no entry under {API_PAGE} in _toc.yml takes autodoc2's page of {missing} "
        f"({out}/acder_lite/<module>.md); entries: {entries}"
    )


def test_every_module_is_on_the_api_pages_map():
    text = (ROOT / f"{API_PAGE}.md").read_text()
    named = set(re.findall(r"\{py:mod\}`[^`<]*<(acder_lite\.[\w.]+)>`", text))
    named |= set(re.findall(r"\{py:mod\}`(acder_lite\.[\w.]+)`", text))
    mods = set(public_modules())
    assert not mods - named, (
        f"{API_PAGE}.md does not place {sorted(mods - named)} on its map of the "
        "data flow ({py:mod}`name <acder_lite.name>`)"
    )
    assert not named - mods, f"{API_PAGE}.md names no module {sorted(named - mods)}"


MODULE = '''"""A module."""
from dataclasses import dataclass

UNSET = None  # a constant that is None
TABLE: dict = {"a": 1}
MADE = dict(a=1)


@dataclass
class Row:
    """A row."""

    name: str
    """No default."""
    epochs: int | None = None
    """None in the source."""
'''


def _rendered(tmp_path) -> dict[str, str | None]:
    """Each data item of MODULE as ApiRenderer shows it: its value line, or None."""
    import sys

    from autodoc2.analysis import analyse_module
    from autodoc2.config import Config
    from autodoc2.db import InMemoryDb

    sys.path.insert(0, str(ROOT / "jupyter-config"))
    try:
        from api_render import ApiRenderer
    finally:
        sys.path.remove(str(ROOT / "jupyter-config"))
    (tmp_path / "mod.py").write_text(MODULE)
    db = InMemoryDb()
    for item in analyse_module(tmp_path / "mod.py", "mod"):
        db.add(item)
    renderer = ApiRenderer(db, Config())
    shown = {}
    for name in (
        "mod.UNSET",
        "mod.TABLE",
        "mod.MADE",
        "mod.Row.name",
        "mod.Row.epochs",
    ):
        lines = list(renderer.render_data(db.get_item(name)))
        at = [i for i, line in enumerate(lines) if line == ":value: >"]
        shown[name] = lines[at[0] + 1].strip() if at else None
    return shown


def test_renderer_shows_what_the_source_assigns(tmp_path):
    # autodoc2 gives None for a dict literal, a field without a default and a real None
    # alike: the renderer shows None only where the source says it, a call unquoted
    assert _rendered(tmp_path) == {
        "mod.UNSET": "None",
        "mod.TABLE": None,
        "mod.MADE": "dict(...)",
        "mod.Row.name": None,
        "mod.Row.epochs": "None",
    }
