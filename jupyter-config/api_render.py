"""The API reference's renderer (_config.yml's `autodoc2_render_plugin`; also a Sphinx
extension, which only puts this folder on the path): sphinx-autodoc2's MyST renderer,
except for the values of variables it could not read.

autodoc2 0.5.0 reads the package statically (astroid) and keeps the value of a module's
or a class's variable only when it is a constant or a tuple or list of constants. A call
becomes the string "dict(...)", which its renderer quotes as if it were a string
('dict(...)'); anything else (a dict, an expression, a dataclass field without a
default) becomes None, which it prints as the value: `METHODS: dict[str, dict] = None`,
`CellStat.env: str = None` (sphinx-autodoc2 issue #30, open). Here a call is shown
unquoted, `dict(...)`, and an unread value not at all: the item shows its name, type and
docstring. A value that is None in the source (`Config.epochs: int | None = None`) is
told from an unread one by the item's source line, and shown.
"""

from __future__ import annotations

import linecache
import re

from autodoc2.render.myst_ import MystRenderer

CALL = re.compile(r"[\w.]+\(\.\.\.\)")  # autodoc2's stand-in for a call's value
# a one-line assignment of None (`name = None`, `name: T = None`, a comment after)
NONE_ASSIGNED = re.compile(r"^\s*[\w.]+\s*(:[^=]+)?=\s*None\s*(#.*)?$")


class ApiRenderer(MystRenderer):
    def render_package(self, item):
        """A subpackage's page (acder_lite.algo) lists its modules as links, not as a
        `{toctree}`: the book's table of contents (_toc.yml's glob) already places
        every module's page, and a second toctree would be a warning per folder."""
        lines = iter(super().render_package(item))
        for line in lines:
            if line != "```{toctree}":
                yield line
                continue
            for entry in lines:
                if entry == "```":
                    break
                if entry and not entry.startswith(":"):
                    yield f"- {{py:mod}}`{entry}`"

    def render_data(self, item):
        value = item.get("value")
        lines = super().render_data(item)
        for line in lines:
            if line != ":value: >":
                yield line
                continue
            shown = next(lines)  # the value, on the line after
            if value is None and not self.assigned_none(item):
                continue
            if isinstance(value, str) and CALL.fullmatch(value):
                shown = f"   {value}"
            yield line
            yield shown

    def assigned_none(self, item) -> bool:
        """Whether the item's source is one line that assigns None (autodoc2 gives None
        for that and for a value it could not read alike)."""
        first, last = item.get("range", (0, -1))
        if first != last:
            return False
        module = item["full_name"]
        while (found := self.get_item(module)) is None or found["type"] != "module":
            if "." not in module:
                return False
            module = module.rsplit(".", 1)[0]
        # linecache reads each module once for all its items
        return bool(NONE_ASSIGNED.match(linecache.getline(found["file_path"], first)))


def setup(app):
    return {"parallel_read_safe": True, "parallel_write_safe": True}
