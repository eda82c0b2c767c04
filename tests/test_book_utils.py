"""The book's helpers for every chapter (acder_lite.book.utils): the budgets, how
shares and vectors are written."""

from acder_lite.book.utils import budgets, vector_text


def test_budgets_of_a_chapter_that_trains_nothing_print_no_precision(capsys):
    assert budgets(False, trains=False, resets=(10, 2)) == {"resets": 10}
    assert capsys.readouterr().out.splitlines() == ["ACDER_FAST=0: resets=10"]


def test_percent_drops_trailing_zeros():
    from acder_lite.book.utils import percent

    assert [percent(x) for x in (0.1, 0.025, 0.003, 1.0, 0.12345)] == [
        "10%",
        "2.5%",
        "0.3%",
        "100%",
        "12.3%",
    ]


def test_percent_range_gives_both_ends_the_same_decimals():
    from acder_lite.book.utils import percent_range

    assert percent_range(0.0043, 0.01) == "0.43% to 1.00%"
    assert percent_range(0.12, 0.3449) == "12% to 34%"
    assert percent_range(0.0, 0.0093) == "0.00% to 0.93%"
    assert percent_range(0.00038, 0.0093) == "0.038% to 0.930%"


def test_vector_text_prints_no_negative_zero():
    assert vector_text([1.3634, -0.0001, -0.1384]) == "[ 1.363  0.000 -0.138]"
    assert vector_text([[-0.0, 0.26]], digits=1) == "[ 0.0  0.3]"


def test_percent_range_up_to_a_whole_share_has_no_decimals():
    """0 to 1: the nonzero end, 100%, needs no decimal for 2 significant digits (its
    places, 2 - 1 - 2 = -1, are held at 0), so both ends are whole percents."""
    from acder_lite.book.utils import percent_range

    assert percent_range(0.0, 1.0) == "0% to 100%"
    assert percent_range(1.0, 1.0) == "100% to 100%"


def test_glue_hands_myst_nb_python_numbers_and_markdown(monkeypatch):
    """A numpy scalar reaches `myst_nb.glue` as a Python number (numpy 2's repr,
    `np.float64(0.5)`, breaks `{glue:text}`'s format spec), a string as Markdown, with
    display off unless asked."""
    import myst_nb
    import numpy as np
    from IPython.display import Markdown

    from acder_lite.book.utils import glue

    got = []
    monkeypatch.setattr(myst_nb, "glue", lambda *a, **k: got.append((a, k)))
    glue("x", np.float64(0.5))
    glue("n", np.int64(3), display=True)
    glue("s", "**b**")
    glue("t", "on Push 1.9", other_pages=True)
    (x, kx), (n, kn), (s, _), (t, _) = got
    assert t == ("t", "on Push 1.9")  # text/plain: another page's {glue:text} pastes it
    assert x == ("x", 0.5) and type(x[1]) is float and kx == {"display": False}
    assert n == ("n", 3) and type(n[1]) is int and kn == {"display": True}
    assert isinstance(s[1], Markdown) and s[1].data == "**b**"
