"""Counts and lists in English, for the CLI's lines and the book's sentences: one rule
for "1 trial" against "2 trials", so no output says "1 trials" or "trial(s)"; and
clauses joined into one sentence (`sentence`)."""

from __future__ import annotations


def plural(n: float, noun: str) -> str:
    """The noun as `n` of it reads: 'epoch' for 1, 'epochs' for 0, 2 or 2.5 (a regular
    plural: the noun + 's')."""
    return noun if n == 1 else noun + "s"


def count(n: int, noun: str) -> str:
    """'1 seed', '3 seeds', '2,560 rows'."""
    return f"{n:,} {plural(n, noun)}"


def and_join(items: list[str]) -> str:
    """'a', 'a and b', 'a, b and c'; 'none' for no items."""
    if not items:
        return "none"
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def sentence(parts: list[str]) -> str:
    """Clauses joined by '; ' as one sentence: first letter upper case,
    a full stop at the end."""
    text = "; ".join(p for p in parts if p)
    return (
        text[:1].upper() + text[1:] + ("." if text and not text.endswith(".") else "")
    )
