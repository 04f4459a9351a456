"""docs/online.md's words on the lab's seed are its table's (`experiments/online_seeds.py`, generated between the
online-seeds markers), and the table's seed-3 columns are the other-part table's true tip: the same runs, formed
again; at the plant's step halved the KR 210's groove spans as much (the timestep table's words rest on it)."""

from __future__ import annotations

from doc_numbers import quoted
from online_doc_tables import BOTH_L, ON_L, ROBOTS, assert_other_part_true_tip, other_part, rows_by_part


def _spans(cell: str) -> tuple[float, float, float]:
    least, median, largest = (float(v) for v in cell.split(" / "))
    return least, median, largest


def _read(cells: list[str]) -> dict[str, float]:
    on, both, fine = _spans(cells[3]), _spans(cells[5]), _spans(cells[6])
    return {"on3": float(cells[2]), "on_least": on[0], "on_median": on[1], "on_largest": on[2],
            "both3": float(cells[4]), "both_least": both[0], "both_median": both[1], "both_largest": both[2],
            "fine_least": fine[0], "fine_median": fine[1], "fine_largest": fine[2]}


def _rows() -> dict[tuple[str, str], dict[str, float]]:
    return rows_by_part("online-seeds", _read)


def test_the_seed_3_columns_are_the_other_part_tables_true_tip() -> None:
    """Same code, seed and step: the same runs (a table regenerated apart from the other would show here)."""
    rows = _rows()
    assert_other_part_true_tip(rows, ((ON_L, "on3"), (BOTH_L, "both3")))
    for key, row in rows.items():
        for mode in ("on", "both"):
            assert row[f"{mode}_least"] <= row[f"{mode}3"] <= row[f"{mode}_largest"], (key, row)
            assert row[f"{mode}_least"] <= row[f"{mode}_median"] <= row[f"{mode}_largest"], (key, row)


def test_the_words_on_the_seed_are_its_table() -> None:
    rows = _rows()
    # the page's numbers first (a guard before the claims)
    most = quoted("online.md", "Every row but the KR 210's groove spans at most", 1)[0]
    groove = quoted("online.md", "The KR 210's groove online spans", 3)
    both = quoted("online.md", "command under it the same groove spans", 3)
    fine = quoted("online.md", "at the plant's step halved it spans", 3)
    kr = rows[("kr210", "groove")]
    for q, value in zip(groove, (kr["on_least"], kr["on_largest"], kr["on_median"]), strict=True):
        q.check(value)
    for q, value in zip(fine, (kr["fine_least"], kr["fine_largest"], kr["fine_median"]), strict=True):
        q.check(value)
    for q, value in zip(both, (kr["both_least"], kr["both_largest"], kr["both_median"]), strict=True):
        q.check(value)
    ringing = {(("kr210", "groove"), "on"), (("kr210", "groove"), "both")}
    spans = [r[f"{m}_largest"] - r[f"{m}_least"] for key, r in rows.items() for m in ("on", "both")
             if (key, m) not in ringing]
    most.check(max(spans), slack=2.0)  # a difference of two printed numbers: up to two units of the last digit
    # "every row but" that groove: a draw moves it by hundredths at most, against that groove by tenths
    assert max(spans) <= 0.05, spans
    assert kr["on_largest"] - kr["on_least"] > 0.2 and kr["both_largest"] - kr["both_least"] > 0.2, kr
    # at the plant's step halved it spans as much: the draw's, more than the integrator's (the timestep table's words)
    assert kr["fine_largest"] - kr["fine_least"] > 0.2 and kr["fine_least"] < kr["on_median"] < kr["fine_largest"], kr
    assert max(r["fine_largest"] - r["fine_least"] for key, r in rows.items() if key != ("kr210", "groove")) <= 0.03
    # every cone within the 0.10 mm target on each seed, and the TX200's groove
    assert max(rows[(r, "cone 80 x 8")]["on_largest"] for r in ROBOTS) <= 0.10
    assert rows[("tx200", "groove")]["on_largest"] <= 0.10
    assert rows[("tx200", "pyramid")]["on_largest"] <= 0.15  # "and its pyramid within the pyramid's 0.15 mm"


def test_the_words_on_the_seed_with_the_side_read_past_the_imprint_are_its_table() -> None:
    """The seeds table formed again with law 1 reading each side 1.1 tool radii out: its seed-3 columns are that
    plant's other-part table's, and no row spans more than the page says, the KR 210's groove included."""
    rows = rows_by_part("online-seeds-read", _read)
    default = _rows()[("kr210", "groove")]
    # the page's numbers first (a guard before the claims)
    most = quoted("online.md", "Over the six seeds every row there spans at most", 1)[0]
    kr = quoted("online.md", "at either step: the KR 210's groove online", 4)
    was = quoted("online.md", "where on the default read it spans", 4)
    edge = quoted("online.md", "the IRB 6640's at its edge: online", 4)[1:]  # its seeds' least, largest, median
    for q, key in zip(edge, ("on_least", "on_largest", "on_median"), strict=True):
        q.check(rows[("irb6640", "pyramid")][key])
    groove = rows[("kr210", "groove")]
    for q, value in zip(kr, (groove["on_least"], groove["on_largest"], groove["both_least"], groove["both_largest"]),
                        strict=True):
        q.check(value)
    for q, value in zip(was, (default["on_least"], default["on_largest"], default["both_least"],
                              default["both_largest"]), strict=True):
        q.check(value)
    spans = [r[f"{m}_largest"] - r[f"{m}_least"] for r in rows.values() for m in ("on", "both", "fine")]
    most.check(max(spans), slack=2.0)  # a difference of two printed numbers: up to two units of the last digit
    true = other_part("online-other-part-read")["true"]
    for key, row in rows.items():
        assert (row["on3"], row["both3"]) == (true[key][ON_L], true[key][BOTH_L]), key  # the same runs
    assert max(spans) <= 0.02 and groove["on_largest"] <= 0.12 and groove["both_largest"] <= 0.10, groove
