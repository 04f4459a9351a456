"""docs/learning.md's words on the pyramid's corners and stops are its generated table's
(`experiments/pyramid_corners.py`, between the pyramid-corners markers): each claim is read off the table, and the
numbers the words quote are the table's."""

from __future__ import annotations

from pathlib import Path

from doc_numbers import quoted

PAGE = Path(__file__).resolve().parents[1] / "docs" / "learning.md"
#: Issue #48's offline pyramid target [mm].
PYRAMID_TARGET_MM = 0.15


def _rows() -> dict[tuple[str, int], dict[str, float]]:
    page = PAGE.read_text(encoding="utf-8")
    block = page[page.index("<!-- pyramid-corners:begin"):page.index("<!-- pyramid-corners:end")]
    rows: dict[tuple[str, int], dict[str, float]] = {}
    for line in block.splitlines():
        if not line.startswith("| ") or line.startswith("| cell"):
            continue
        cell, sharp, rounded, nominal, near, arm, following = (c.strip() for c in line.split("|")[1:-1])
        n_sharp, n_rounded = (float(v.split("(")[0]) for v in nominal.split("/"))
        near_share, near_samples = (float(v) for v in near.split(" of "))
        learned, pyramid_fit, cone_fit = (float(v) for v in arm.split("/"))
        next_static, next_dynamic = (float(v) for v in following.split("/"))
        rows[(cell.split(",")[0], 1 if "sheet law 1" in cell else 2)] = {
            "sharp": float(sharp.split("(")[0]), "rounded": float(rounded.split("(")[0]),
            "rounded_stops": float(rounded.split("(")[1].split(";")[0]),
            "nominal_sharp": n_sharp, "nominal_rounded": n_rounded,
            "nominal_rounded_stops": float(nominal.split("/")[1].split("(")[1].rstrip(")")),
            "near": near_share, "near_samples": near_samples,
            "learned": learned, "pyramid_fit": pyramid_fit, "cone_fit": cone_fit,
            "next_static": next_static, "next_dynamic": next_dynamic}
    return rows


def test_the_words_on_the_pyramid_s_corners_are_the_table_s() -> None:
    rows = _rows()
    assert set(rows) == {(robot, law) for robot in ("tx200", "kr210", "irb6640") for law in (1, 2)}
    tx1, kr2 = rows[("tx200", 1)], rows[("kr210", 2)]
    law1 = [r for (_, law), r in rows.items() if law == 1]
    law2 = [r for (_, law), r in rows.items() if law == 2]
    others = [r for key, r in rows.items() if key != ("tx200", 1)]
    # the page's numbers first (a guard before the claims)
    stays = quoted("learning.md", "the nominal runs' robot part stays where it was (", 2)
    stays[0].check(tx1["nominal_sharp"])
    stays[1].check(tx1["nominal_rounded"])
    within = quoted("learning.md", "first law, and within", 1)[0]
    within.check(max(abs(r["nominal_rounded"] - r["nominal_sharp"]) for r in rows.values()))
    rounded = quoted("learning.md", "misses as the sharp one does on the first law (", 2)
    rounded[0].check(tx1["sharp"])
    rounded[1].check(tx1["rounded"])
    law1_within = quoted("learning.md", "on the TX200, within", 1)[0]
    law1_within.check(max(abs(r["rounded"] - r["sharp"]) for r in law1))
    second = quoted("learning.md", "On the second law it misses less (the KR 210:", 2)
    second[0].check(kr2["sharp"])
    second[1].check(kr2["rounded"])
    near = quoted("learning.md", "about the tool's radius:", 4)
    near[0].check(100.0 * min(r["near"] for r in rows.values()))
    near[1].check(100.0 * max(r["near"] for r in rows.values()))
    near[2].check(100.0 * min(r["near_samples"] for r in rows.values()))
    near[3].check(100.0 * max(r["near_samples"] for r in rows.values()))
    dyn = quoted("learning.md", "takes the compensated run's robot part down on every cell: from", 2)
    dyn[0].check(tx1["learned"])
    dyn[1].check(tx1["pyramid_fit"])
    by = quoted("learning.md", "on the TX200's first law, and by", 2)
    by[0].check(min(r["learned"] - r["pyramid_fit"] for r in others))
    by[1].check(max(r["learned"] - r["pyramid_fit"] for r in others))
    cone_kr = quoted("learning.md", "it takes as much off the KR 210's second law (", 2)
    cone_kr[0].check(kr2["learned"])
    cone_kr[1].check(kr2["cone_fit"])
    worse = quoted("learning.md", "TX200's and the IRB 6640's first law worse (", 2)
    worse[0].check(tx1["cone_fit"])
    worse[1].check(rows[("irb6640", 1)]["cone_fit"])
    tx2, irb1, kr1 = rows[("tx200", 2)], rows[("irb6640", 1)], rows[("kr210", 1)]
    under = quoted("learning.md", "pyramid under the 0.15 mm target on the TX200 (", 7)  # [4]: the IRB 6640's name
    for k, r in ((0, tx2), (2, tx1), (5, irb1)):
        under[k].check(min(r["next_static"], r["next_dynamic"]))
        under[k + 1].check(max(r["next_static"], r["next_dynamic"]))
    leaves = quoted("learning.md", "on the KR 210's first law it leaves", 2)
    leaves[0].check(min(kr1["next_static"], kr1["next_dynamic"]))
    leaves[1].check(max(kr1["next_static"], kr1["next_dynamic"]))
    held2 = [r for (robot, law), r in rows.items() if robot != "tx200" and law == 2]
    second_law = quoted("learning.md", "held-out robots' second law", 2)
    second_law[0].check(min(min(r["next_static"], r["next_dynamic"]) for r in held2))
    second_law[1].check(max(max(r["next_static"], r["next_dynamic"]) for r in held2))
    # the claims
    assert all(r["nominal_rounded_stops"] < 0.2 for r in rows.values())  # rounded nominal runs: no corner stop
    assert all(r["rounded"] < r["sharp"] for r in law2)
    assert all(r["rounded"] > PYRAMID_TARGET_MM for r in law2)  # "not near the target"
    assert all(r["near"] > r["near_samples"] for r in rows.values())  # the miss gathers at the corners
    assert all(r["pyramid_fit"] < r["learned"] for r in rows.values())
    assert abs(kr2["cone_fit"] - kr2["pyramid_fit"]) <= 0.005  # "as much"
    # the next pyramid under the target on the TX200 (both laws) and the IRB 6640's first law, not elsewhere
    for key, r in rows.items():
        assert (max(r["next_static"], r["next_dynamic"]) < PYRAMID_TARGET_MM) == (
            key in {("tx200", 1), ("tx200", 2), ("irb6640", 1)}), (key, r)
    assert kr1["next_static"] > PYRAMID_TARGET_MM > kr1["next_dynamic"]  # "under the target with the term only"
    assert tx1["cone_fit"] > tx1["learned"] and rows[("irb6640", 1)]["cone_fit"] > rows[("irb6640", 1)]["learned"]
