"""The measured numbers the docs quote, read from the docs themselves, for the tests that measure them.

`quoted(doc, anchor, count)` returns the first `count` numbers written after `anchor` in `docs/<doc>` (or
README.md), each with the tolerance its printed digits claim (one unit of the last digit): a test that
measures the number asserts `measured == pytest.approx(q.value, abs=q.tol)`, so a doc left stale, or an anchor
that no longer exists, fails the test that measures it.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple

import pytest

REPO = Path(__file__).resolve().parents[1]
_NUMBER = re.compile(r"(?<![\d.])[-+]?\d+(?:\.\d+)?")  # a range's dash (0.976-1.009) is no minus


class Quoted(NamedTuple):
    """A number as the doc prints it: its value and one unit of its last printed digit."""

    value: float
    tol: float

    def check(self, measured: float, *, slack: float = 1.0) -> None:
        """Assert the measurement rounds to the printed number (within `slack` units of its last digit)."""
        assert measured == pytest.approx(self.value, abs=slack * self.tol), (
            f"the doc says {self.value}, measured {measured:.6g}: regenerate the doc's number"
        )


def quoted(doc: str, anchor: str, count: int) -> list[Quoted]:
    """The first `count` numbers after `anchor` in `docs/<doc>` (`README.md` at the repository's root).

    Raises:
        AssertionError: The anchor is not in the doc, or fewer numbers follow it.
    """
    path = REPO / doc if doc == "README.md" else REPO / "docs" / doc
    text = " ".join(path.read_text(encoding="utf-8").split())  # lines joined: an anchor may span a line break
    anchor = " ".join(anchor.split())
    assert anchor in text, f"{path.name} no longer says {anchor!r}: update the test with the doc"
    found = _NUMBER.findall(text[text.index(anchor) + len(anchor):])[:count]
    assert len(found) == count, f"{path.name}: fewer than {count} numbers after {anchor!r}"
    out = []
    for s in found:
        decimals = len(s.split(".")[1]) if "." in s else 0
        out.append(Quoted(float(s), 10.0 ** -decimals))
    return out


#: How far a machine's floating point (BLAS kernel, thread count) may move a generated page's number: 2 % of it or
#: two units of its last printed digit, whichever is larger. One rule for every generated page; its words must
#: agree exactly.
PAGE_REL_TOL = 0.02
PAGE_DIGITS_TOL = 2.0


def page_differences(expected: str, actual: str) -> list[str]:
    """Where two renderings of a generated page differ beyond what floating point explains: words that differ,
    or numbers further apart than `PAGE_REL_TOL` / `PAGE_DIGITS_TOL` (empty: the same page)."""
    split = re.compile(r"((?<![\w.])[-+]?\d+(?:\.\d+)?)")
    a, b = split.split(expected), split.split(actual)
    if len(a) != len(b):
        return [f"the pages have {len(a) // 2} and {len(b) // 2} numbers"]
    out = []
    for i, (x, y) in enumerate(zip(a, b, strict=True)):
        if i % 2 == 0:
            if x != y:
                out.append(f"text {x[-40:]!r} -> {y[-40:]!r}")
            continue
        decimals = len(x.split(".")[1]) if "." in x else 0
        tol = max(PAGE_REL_TOL * abs(float(x)), PAGE_DIGITS_TOL * 10.0**-decimals)
        if abs(float(x) - float(y)) > tol:
            out.append(f"{x} -> {y} (beyond {tol:g}) after {a[i - 1][-40:]!r}")
    return out
