"""Small helpers for the book's notebooks: show a package function's source, the budgets."""
from __future__ import annotations

import inspect


def show_source(obj, lines: tuple[int, int] | None = None):
    """Display the source of a package object (function, class, method) as highlighted code.

    The notebooks show the package's code this way instead of copying it, so the book and the
    package cannot drift apart.
    """
    from IPython.display import Markdown
    src = inspect.getsource(obj)
    if lines is not None:
        src = "\n".join(src.splitlines()[lines[0]:lines[1]])
    mod = inspect.getmodule(obj)
    where = f"{mod.__name__}.{getattr(obj, '__qualname__', '')}" if mod else ""
    return Markdown(f"`{where}`\n\n```python\n{src.rstrip()}\n```")


def budgets(fast: bool, **pairs) -> dict:
    """Pick each budget: `name=(full, fast)` -> value for this mode. Prints the table."""
    chosen = {k: (v[1] if fast else v[0]) for k, v in pairs.items()}
    print(f"ACDER_FAST={int(fast)}: " + ", ".join(f"{k}={v}" for k, v in chosen.items()))
    return chosen


def glue(name: str, value, display: bool = False):
    """`myst_nb.glue` for values quoted in prose, with display off.

    Numpy scalars become Python numbers first (numpy 2's repr, `np.float64(0.5)`, cannot be
    formatted by `{glue:text}` with a format spec). Strings become Markdown, to be pasted with
    `{glue:md}` (`{glue:text}` would show their quotes)."""
    import numpy as np
    from IPython.display import Markdown
    from myst_nb import glue as _glue
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, str):
        value = Markdown(value)
    return _glue(name, value, display=display)
