"""docs/online.md's words on the plant's step are its table's (`experiments/online_timestep.py`, generated between
the online-timestep markers), and the table's 1 ms column is the other-part table's "online, learned" true tip:
the same runs, formed again."""

from __future__ import annotations

from doc_numbers import quoted
from online_doc_tables import BOTH_L, ON_L, assert_other_part_true_tip, rows_by_part


def _read(cells: list[str]) -> dict[str, float]:
    share = cells[4].split(" / ")
    mm = [float(cells[k].split(" mm")[0]) for k in (2, 3, 5, 6)]
    return {"ms1": mm[0], "ms05": mm[1], "share1": float(share[0]), "share05": float(share[1]), "both1": mm[2],
            "both05": mm[3]}


def _rows() -> dict[tuple[str, str], dict[str, float]]:
    return rows_by_part("online-timestep", _read)


def test_the_default_step_columns_are_the_other_part_tables_true_tip() -> None:
    """Same code, seeds and step: the same runs (a table regenerated apart from the other would show here)."""
    assert_other_part_true_tip(_rows(), ((ON_L, "ms1"), (BOTH_L, "both1")))


def test_the_words_on_the_plants_step_are_its_table() -> None:
    rows = _rows()
    kr_key, irb_key = ("kr210", "groove"), ("irb6640", "groove")
    # the page's numbers first (a guard before the claims)
    most = quoted("online.md", "Online, every row but the KR 210's groove moves by at most", 1)[0]
    kr = quoted("online.md", "converged there; that groove\ngoes from", 2)
    both = quoted("online.md", "every row but two moves by at most", 1)[0]
    grooves = quoted("online.md", "the IRB 6640's groove goes from", 5)  # [2]: the next robot's name
    kr[0].check(rows[kr_key]["ms1"])
    kr[1].check(rows[kr_key]["ms05"])
    for k, key in enumerate((irb_key, kr_key)):
        grooves[3 * k].check(rows[key]["both1"])
        grooves[3 * k + 1].check(rows[key]["both05"])
    online = max(abs(r["ms05"] - r["ms1"]) for key, r in rows.items() if key != kr_key)
    most.check(online)
    others = [abs(r["both05"] - r["both1"]) for key, r in rows.items() if key not in (kr_key, irb_key)]
    both.check(max(others))
    # the step is converged online and for "both" but on the grooves that ring, well inside the targets' scale (0.1 mm)
    assert online <= 0.01 and max(others) <= 0.01, (online, others)
