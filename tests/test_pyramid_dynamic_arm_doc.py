"""docs/dynamic-twin.md's "The arm under the measured forces": the table `experiments/pyramid_dynamic_arm.py`
wrote, and every number and claim its words make of it (a stale or edited page fails here)."""

from __future__ import annotations

from pathlib import Path

from doc_numbers import quoted

PAGE = Path(__file__).resolve().parents[1] / "docs" / "dynamic-twin.md"


def _table_lines(marker: str) -> list[list[str]]:
    """The stripped cells of each row of the page's generated table between its `marker` lines (one row a cell)."""
    text = PAGE.read_text(encoding="utf-8")
    block = text[text.index(f"<!-- {marker}:begin"):text.index(f"<!-- {marker}:end")]
    return [[c.strip() for c in line.split("|")[1:-1]] for line in block.splitlines()
            if line.startswith("| ") and "sheet law" in line]


def _cell(cell: str) -> str:
    """A table's cell ("kr210, sheet law 1 (held out)") as "robot law N"."""
    robot = "kr210" if "kr210" in cell else "irb6640" if "irb6640" in cell else "tx200"
    return f"{robot} {'law 2' if 'law 2' in cell else 'law 1'}"


def _rows() -> dict[tuple[str, str], list[float]]:
    """(robot and law, sensor) -> [β, ζ, cone rms, quasi-static, dynamic, rigid, the stream above 20 Hz (NaN: -)]
    of the generated table."""
    out = {}
    for cell, sensor, above, servo, parts in _table_lines("pyramid-dynamic-arm"):
        (beta, zeta), cone = servo.split(";")[0].split("/"), servo.split(";")[1]
        out[(_cell(cell), "fast" if sensor.startswith("1000") else "30")] = [
            float(beta), float(zeta), float(cone), *(float(v) for v in parts.split("/")),
            float("nan") if above == "-" else float(above)]
    return out


def test_the_table_has_every_cell_and_both_sensors() -> None:
    rows = _rows()
    assert len(rows) == 12 and {k[1] for k in rows} == {"fast", "30"}


def test_with_the_fast_sensor_the_cones_servo_takes_the_held_out_pyramids_robot_part_down() -> None:
    rows = _rows()
    kr, irb = rows[("kr210 law 1", "fast")], rows[("irb6640 law 1", "fast")]
    for q, v in zip([*quoted("dynamic-twin.md", "law the KR 210's from", 2),
                     *quoted("dynamic-twin.md", "and the IRB 6640's from", 2)], (kr[3], kr[4], irb[3], irb[4]), strict=True):
        q.check(v)
    for q, v in zip(quoted("dynamic-twin.md", "where a rigid servo leaves", 2), (kr[5], irb[5]), strict=True):
        q.check(v)
    for robot in ("kr210", "irb6640"):
        for law in ("law 1", "law 2"):
            *_, static, dynamic, rigid, _ = rows[(f"{robot} {law}", "fast")]
            assert dynamic < 6 / 7 * static and dynamic < rigid, (robot, law)  # "by a seventh or more"


def test_with_the_thesiss_stream_it_gains_less() -> None:
    rows = _rows()
    irb = rows[("irb6640 law 1", "30")]
    for q, v in zip(quoted("dynamic-twin.md", "the IRB 6640's first law from", 2), (irb[3], irb[4]), strict=True):
        q.check(v)
    for robot in ("kr210", "irb6640"):
        for law in ("law 1", "law 2"):
            slow, fast = rows[(f"{robot} {law}", "30")], rows[(f"{robot} {law}", "fast")]
            assert fast[4] < slow[4], (robot, law)
    for cell in ("tx200 law 2", "kr210 law 2"):  # "on the second law's TX200 and KR 210 nothing (within 0.001 mm)"
        _, _, _, static, dynamic, _, _ = rows[(cell, "30")]
        assert round(abs(dynamic - static), 3) <= 0.001, cell  # printed to the micrometre


def test_the_fast_stream_shows_what_a_30_hz_one_folds_back() -> None:
    rows = _rows()
    above = [v[6] for k, v in rows.items() if k[1] == "fast"]
    low, high = quoted("dynamic-twin.md", "on these runs the plant's force moves by", 2)
    low.check(min(above))
    high.check(max(above))
    assert len(above) == 6 and all(a > 0 for a in above)


def _command_rows() -> dict[str, list[float]]:
    """robot and law -> [β, ζ, delay ms, quasi-static, moving] of the `--commands` table; every row's arm driven by
    its measured forces (asserted: the 1 kHz stream is fast enough)."""
    out = {}
    for cell, servo, parts in _table_lines("pyramid-dynamic-commands"):
        numbers, drive = servo.split(";")
        assert drive.strip() == "its measured forces", cell
        out[_cell(cell)] = [*(float(v) for v in numbers.split("/")), *(float(v) for v in parts.split("/"))]
    return out


def test_through_the_commands_the_held_out_pyramids_robot_part_comes_down() -> None:
    rows = _command_rows()
    kr, irb = rows["kr210 law 1"], rows["irb6640 law 1"]
    for q, v in zip([*quoted("dynamic-twin.md", "on the first law the KR 210's pyramid from", 2),
                     *quoted("dynamic-twin.md", "the IRB 6640's pyramid from", 2)], (kr[3], kr[4], irb[3], irb[4]),
                    strict=True):
        q.check(v)
    kr2, irb2 = rows["kr210 law 2"], rows["irb6640 law 2"]
    for q, v in zip([*quoted("dynamic-twin.md", "on the second law the KR 210's pyramid from", 2),
                     *quoted("dynamic-twin.md", "the IRB 6640's second-law pyramid from", 2)],
                    (kr2[3], kr2[4], irb2[3], irb2[4]), strict=True):
        q.check(v)
    grid = _rows()
    quoted("dynamic-twin.md", "the grid's servo took that one to", 1)[0].check(grid[("irb6640 law 2", "fast")][4])
    assert len(rows) == 6
    for robot in ("kr210", "irb6640"):
        for law in ("law 1", "law 2"):
            *_, static, moving = rows[f"{robot} {law}"]
            assert moving < static, (robot, law)
    # "further than with the study's grid above" (first law); "the grid's servo took that one to"
    for robot, row in (("kr210", kr), ("irb6640", irb)):
        assert row[4] < grid[(f"{robot} law 1", "fast")][4], robot
    assert grid[("irb6640 law 2", "fast")][4] < irb2[4]
