"""Small helpers for the book's notebooks: show a package function's source, the
budgets, glue, and how numbers are written (shares, intervals of shares, vectors).
Chapter 1's random policy is in `random_play`, the per-seed readings of "Results in
detail" in `per_seed`."""

from __future__ import annotations

import inspect


def show_source(obj, lines: tuple[int, int] | None = None):
    """Display the source of a package object (function, class,
    method) as highlighted code.

    The notebooks show the package's code this way instead of copying it, so the book
    and the package cannot drift apart.
    """
    from IPython.display import Markdown

    src = inspect.getsource(obj)
    if lines is not None:
        src = "\n".join(src.splitlines()[lines[0] : lines[1]])
    mod = inspect.getmodule(obj)
    where = f"{mod.__name__}.{getattr(obj, '__qualname__', '')}" if mod else ""
    return Markdown(f"`{where}`\n\n```python\n{src.rstrip()}\n```")


def budgets(fast: bool, trains: bool = True, **pairs) -> dict:
    """Pick each budget: `name=(full, fast)` -> value for this mode.

    Prints the table, and the precision `Config.update_dtype="auto"` picks on this CPU
    for a default run's update (timed in both precisions, with the two timings:
    `precision.choose_update_dtype`; a chapter's run times its own shapes): the
    chapters train with the default, so a reader on another CPU sees why their numbers
    differ from the rendered book's in the later digits. `trains=False` prints the
    table only: for a chapter that trains no network, and for the teaching chapters,
    which say the precision once, in a line pointing at the engineering appendix, not
    in their first cell."""
    from acder_lite.precision import choose_update_dtype

    chosen = {k: (v[1] if fast else v[0]) for k, v in pairs.items()}
    print(
        f"ACDER_FAST={int(fast)}: " + ", ".join(f"{k}={v}" for k, v in chosen.items())
    )
    if trains:
        dtype, why = choose_update_dtype("auto")
        print(f"network updates in {dtype} on this CPU ({why})")
    return chosen


def glue(name: str, value, display: bool = False, other_pages: bool = False):
    """`myst_nb.glue` for values quoted in prose, with display off.

    Numpy scalars become Python numbers first (numpy 2's repr, `np.float64(0.5)`, cannot
    be formatted by `{glue:text}` with a format spec). Strings become Markdown, to be
    pasted with `{glue:md}` (`{glue:text}` would show their quotes), unless
    `other_pages`: then a string stays plain text, for another page to paste with
    `{glue:text}`../notebooks/NAME.ipynb::key:s`` (the chapter's path from that page,
    with its suffix; the format spec, since the role splits at its last ":"). myst-nb
    pastes only text/plain across pages, stripping the quotes: no Markdown in it."""
    import numpy as np
    from IPython.display import Markdown
    from myst_nb import glue as _glue

    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, str) and not other_pages:
        value = Markdown(value)
    return _glue(name, value, display=display)


def percent(share: float, digits: int = 3) -> str:
    """A share as the book writes it: '10%', '2.5%', '0.3%' (`digits` significant
    digits at most, no trailing zeros)."""
    return f"{100 * share:.{digits}g}%"


def percent_range(low: float, high: float, digits: int = 2) -> str:
    """An interval of shares with one number of decimals for both ends, enough for
    `digits` significant digits of the smaller nonzero one: '0.43% to 1.00%', not
    '0.43% to 1%'."""
    import math

    ends = [100 * abs(x) for x in (low, high) if x]  # a 0 end takes the other's
    places = digits - 1 - math.floor(math.log10(min(ends))) if ends else 0
    places = max(0, places)
    return f"{100 * low:.{places}f}% to {100 * high:.{places}f}%"


def vector_text(x, digits: int = 3) -> str:
    """A vector as the chapters print it: `digits` decimals, a space where the sign
    of a positive number goes (the columns line up) and no negative zero, which numpy
    prints for a tiny negative rounded away: '[ 1.363  0.000 -0.138]'."""
    import numpy as np

    values = np.round(np.asarray(x, dtype=float).ravel(), digits) + 0.0  # -0. -> 0.
    return "[" + " ".join(f"{v: .{digits}f}" for v in values) + "]"
