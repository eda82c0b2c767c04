"""The book's helpers for every chapter (acder_lite.book_utils): the budgets, how
shares and vectors are written."""

from acder_lite.book_utils import budgets, vector_text


def test_budgets_of_a_chapter_that_trains_nothing_print_no_precision(capsys):
    assert budgets(False, trains=False, resets=(10, 2)) == {"resets": 10}
    assert capsys.readouterr().out.splitlines() == ["ACDER_FAST=0: resets=10"]


def test_percent_drops_trailing_zeros():
    from acder_lite.book_utils import percent

    assert [percent(x) for x in (0.1, 0.025, 0.003, 1.0, 0.12345)] == [
        "10%",
        "2.5%",
        "0.3%",
        "100%",
        "12.3%",
    ]


def test_percent_range_gives_both_ends_the_same_decimals():
    from acder_lite.book_utils import percent_range

    assert percent_range(0.0043, 0.01) == "0.43% to 1.00%"
    assert percent_range(0.12, 0.3449) == "12% to 34%"
    assert percent_range(0.0, 0.0093) == "0.00% to 0.93%"
    assert percent_range(0.00038, 0.0093) == "0.038% to 0.930%"


def test_vector_text_prints_no_negative_zero():
    assert vector_text([1.3634, -0.0001, -0.1384]) == "[ 1.363  0.000 -0.138]"
    assert vector_text([[-0.0, 0.26]], digits=1) == "[ 0.0  0.3]"
