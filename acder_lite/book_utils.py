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
