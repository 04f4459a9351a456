"""docs/online.md's words on where the pyramid's and the groove's online miss comes from are its table's
(`experiments/online_floor.py`, generated between the online-floor markers)."""

from __future__ import annotations

from doc_numbers import quoted
from online_doc_tables import ROBOTS, table_rows

PARTS = ("pyramid", "groove")


def _rows() -> dict[tuple[str, str], dict[str, float]]:
    rows = {}
    for cells in table_rows("online-floor"):
        mm = [float(c.split(" mm")[0]) for c in cells[2:8]]
        rise, peak = cells[8].split(" / ")
        rows[(cells[0], cells[1])] = {"online": mm[0], "perfect": mm[1], "air_nominal": mm[2], "air_online": mm[3],
                                      "air_no_friction": mm[4], "oracle": mm[5], "rise_ms": float(rise.split(" ms")[0]),
                                      "peak": float(peak)}
    assert list(rows) == [(r, p) for r in ROBOTS for p in PARTS], list(rows)
    return rows


def test_the_words_on_the_online_floor_are_its_table() -> None:
    rows = _rows()
    # the page's numbers first (a guard before the claims)
    sensor = quoted("online.md", "A perfect sensor changes the pyramids' miss by little (from", 6)
    for k, robot in enumerate(ROBOTS):
        sensor[2 * k].check(rows[(robot, "pyramid")]["online"])
        sensor[2 * k + 1].check(rows[(robot, "pyramid")]["perfect"])
    sensor_grooves = quoted("online.md", "On the grooves it moves the first robot's from", 6)
    for k, robot in enumerate(("tx200", "irb6640")):
        sensor_grooves[2 * k].check(rows[(robot, "groove")]["online"])
        sensor_grooves[2 * k + 1].check(rows[(robot, "groove")]["perfect"])
    sensor_grooves[4].check(rows[("kr210", "groove")]["online"])
    sensor_grooves[5].check(rows[("kr210", "groove")]["perfect"])
    irb = rows[("irb6640", "groove")]  # "takes a fifth off the third's"
    assert 0.15 <= 1.0 - irb["perfect"] / irb["online"] <= 0.25, irb
    air = quoted("online.md", "misses the pyramid online by", 3)
    groove = quoted("online.md", "where the controller stops at the corners, and the groove\nby", 5)
    step = quoted("online.md", "90 % of a step after", 6)
    kr_pyramid = quoted("online.md", "on every row but the KR 210's pyramid (", 2)
    oracle = quoted("online.md", "the arm's own miss would leave the pyramids at", 6)
    for k, robot in enumerate(ROBOTS):
        air[k].check(rows[(robot, "pyramid")]["air_online"])
        groove[k].check(rows[(robot, "groove")]["air_online"])
        step[k].check(rows[(robot, "pyramid")]["rise_ms"])
        step[3 + k].check(rows[(robot, "pyramid")]["peak"])
        oracle[k].check(rows[(robot, "pyramid")]["oracle"])
        oracle[3 + k].check(rows[(robot, "groove")]["oracle"])
    groove[3].check(rows[("tx200", "groove")]["online"])
    groove[4].check(rows[("irb6640", "groove")]["online"])
    kr_pyramid[0].check(rows[("kr210", "pyramid")]["air_no_friction"])
    kr_pyramid[1].check(rows[("kr210", "pyramid")]["air_nominal"])
    for (robot, part), r in rows.items():
        if part == "pyramid":
            # "changes the pyramids' miss by little": a perfect sensor moves it by under a tenth
            assert abs(r["online"] - r["perfect"]) < 0.1 * r["online"], (robot, r)
            # the arm's own miss in air is a large share of what is left online (the floor the force cannot lower)
            assert r["air_online"] > 0.4 * r["online"], (robot, r)
        elif robot != "kr210":  # "the sensor is not what stops them": under a quarter off a groove that does not ring
            assert r["online"] - r["perfect"] < 0.25 * r["online"], (robot, r)
        # "the joints' friction more than their servo": under a third with it off, but the KR 210's pyramid
        share = r["air_no_friction"] / r["air_nominal"]
        assert share < (1.0 if (robot, part) == ("kr210", "pyramid") else 1.0 / 3.0), (robot, part, r)
        # the friction's lag turned with the planned travel: two fifths to two thirds off on the TX200 and the IRB
        # 6640, none on the KR 210
        off = 1.0 - r["air_online"] / r["air_nominal"]
        assert (off <= 0.0) if robot == "kr210" else (0.4 <= off <= 2.0 / 3.0), (robot, part, off)
        # "reaches the tip late and overshoots"
        assert r["rise_ms"] >= 30.0 and r["peak"] > 1.2, (robot, r)
    # "a feed-forward of the arm's own miss would take the first and the third robot's pyramids under 0.15 mm, not the
    # KR 210's, nor a second robot's groove to its 0.10 mm" (#50's targets; the first robot's groove meets it already)
    for robot in ROBOTS:
        assert (rows[(robot, "pyramid")]["oracle"] <= 0.15) == (robot != "kr210"), robot
    assert sum(rows[(robot, "groove")]["oracle"] <= 0.10 for robot in ROBOTS) <= 1
    for robot in ("kr210", "irb6640"):  # "on their pyramids most of what is left online is the arm's own miss"
        assert rows[(robot, "pyramid")]["air_online"] > 0.5 * rows[(robot, "pyramid")]["online"], robot
    for robot in ("tx200", "irb6640"):  # "about four fifths of what the first and the third robot's grooves miss
        for part, (low, high) in (("groove", (0.75, 0.85)), ("pyramid", (0.8, 0.95))):  # online, and five sixths of
            r = rows[(robot, part)]  # what their pyramids do"
            assert low <= r["air_online"] / r["online"] <= high, (robot, part, r)
