"""The guard of generated pages: numbers compared within what a machine's floating point moves them, words exact."""

from __future__ import annotations

from doc_numbers import page_differences

PAGE = "| case | Fz [N] | rms [mm] |\n| BM3 | 1814 | 0.73 |\n| x = +40 mm | -23.52 | 4 iterations |\n"


def test_a_number_moved_by_floating_point_passes() -> None:
    moved = PAGE.replace("0.73", "0.74").replace("-23.52", "-23.34").replace("1814", "1816")
    assert page_differences(PAGE, moved) == []


def test_a_number_moved_beyond_it_fails() -> None:
    assert page_differences(PAGE, PAGE.replace("0.73", "0.77"))  # 4 units of its last digit, 5 %
    assert page_differences(PAGE, PAGE.replace("1814", "1900"))  # 4.7 %
    assert page_differences(PAGE, PAGE.replace("-23.52", "-24.52"))


def test_changed_words_or_a_missing_number_fail() -> None:
    assert page_differences(PAGE, PAGE.replace("BM3", "BM4"))
    assert page_differences(PAGE, PAGE.replace("| 0.73 |", "|  |"))
