"""The generated tables of docs/online.md, read for the tests that guard the page's words on them."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

DOC = Path(__file__).resolve().parents[1] / "docs" / "online.md"
#: The robots of the studies' tables, in their order, and each robot's parts (`experiments/online_other_part.py`).
ROBOTS = ("tx200", "kr210", "irb6640")
PARTS = ("cone 80 x 8", "pyramid", "groove")
#: The other-part tables' columns after robot and part (`experiments/online_other_part.py` COLUMNS: nominal, offline
#: default, offline learned, online default, online learned, both learned), read by name.
NOMINAL, OFF_D, OFF_L, ON_D, ON_L, BOTH_L = range(6)


def table_rows(marker: str) -> list[list[str]]:
    """The body rows of the table between a page's `<!-- MARKER:begin` and `<!-- MARKER:end` lines, as stripped
    cells (the header and its rule left out)."""
    text = DOC.read_text(encoding="utf-8")
    block = text[text.index(f"<!-- {marker}:begin"):text.index(f"<!-- {marker}:end")]
    return [[c.strip() for c in line.strip("|").split("|")] for line in block.splitlines()[3:]]


def other_part(marker: str) -> dict[str, dict[tuple[str, str], list[float | None]]]:
    """An other-part table by (robot, part): each column's rms, rms less the tracker offset and true-tip rms [mm]
    ("rms", "less", "true"); None where the table says "refused"."""
    out: dict[str, dict[tuple[str, str], list[float | None]]] = {"rms": {}, "less": {}, "true": {}}
    reads = {"rms": lambda c: c.split(" / ")[0], "less": lambda c: c.split("(")[1].split(";")[0],
             "true": lambda c: c.split("; true ")[1].rstrip(")")}
    for cells in table_rows(marker):
        for name, read in reads.items():
            out[name][(cells[0], cells[1])] = [None if c == "refused" else float(read(c)) for c in cells[2:]]
    return out


def rows_by_part(marker: str, read: Callable[[list[str]], dict[str, float]]) -> dict[tuple[str, str], dict[str, float]]:
    """A table of every robot's parts (`ROBOTS` x `PARTS`, in that order, asserted) by (robot, part), each row's
    cells read by `read`."""
    rows = {(cells[0], cells[1]): read(cells) for cells in table_rows(marker)}
    assert list(rows) == [(r, p) for r in ROBOTS for p in PARTS], list(rows)
    return rows


def assert_other_part_true_tip(rows: dict[tuple[str, str], dict[str, float]], columns: tuple[tuple[int, str], ...]) -> None:
    """The rows' named numbers are the law-1 other-part table's true tip in those columns (`ON_L`, `BOTH_L`, ...),
    to the printed digit: a study that forms that table's runs again (same code, seed and step) gives the same runs,
    and a table regenerated apart from the other shows here."""
    true = other_part("online-other-part")["true"]
    for key, row in rows.items():
        for column, name in columns:
            assert abs(row[name] - true[key][column]) <= 0.0015, (key, name, true[key][column])
