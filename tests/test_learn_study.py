"""docs/learning.md's study table (`experiments/learn_cell.py`): the groove variant with neutral knobs rerun and
its row held to the page's numbers, within what a machine's floating point and the plant's stepping move them.
Slow: `make test-slow`."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest
from doc_numbers import quoted

EXPERIMENTS = Path(__file__).resolve().parent.parent / "experiments"
sys.path.insert(0, str(EXPERIMENTS))  # the study imports its sibling `experiments_cli`, as when run as a script
_SPEC = importlib.util.spec_from_file_location("learn_cell", EXPERIMENTS / "learn_cell.py")
assert _SPEC is not None and _SPEC.loader is not None
study = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(study)

DOC = Path(__file__).resolve().parent.parent / "docs" / "learning.md"


def _row_numbers(text: str, variant: str) -> list[float]:
    row = next(line for line in text.splitlines() if line.startswith(f"| {variant} |"))
    return [float(v) for v in re.findall(r"(?<![\w.])\d+(?:\.\d+)?", row.split("|", 2)[2])]


@pytest.fixture(scope="module")
def groove_row(tmp_path_factory: pytest.TempPathFactory) -> dict:
    return study.variant_study(tmp_path_factory.mktemp("learn") / "groove-neutral", "groove-neutral")


@pytest.mark.slow
def test_the_pages_groove_row_is_the_one_a_fresh_run_writes(groove_row: dict) -> None:
    row = groove_row
    fresh = _row_numbers(study.table([row]), "groove-neutral")
    documented = _row_numbers(DOC.read_text(), "groove-neutral")
    assert len(fresh) == len(documented)
    for new, old in zip(fresh, documented, strict=True):
        assert new == pytest.approx(old, rel=0.05, abs=0.02), (fresh, documented)
    quoted("learning.md", "the groove's learned compensation leaves", 1)[0].check(
        row["learned"]["away_from_stops_mm"], slack=3)


@pytest.mark.slow
def test_the_learned_compensation_removes_most_of_what_the_untaught_leaves(groove_row: dict) -> None:
    """Was a strict xfail (0.213 of the untaught's 0.680 mm, 0.31x) until the sheet learner chose its terms from the
    data (#48): 0.130 mm, 0.19x."""
    assert groove_row["learned"]["residual_rms_mm"] < 0.25 * groove_row["untaught"]["residual_rms_mm"]


def _block(marker: str) -> str:
    text = DOC.read_text()
    return text[text.index(f"<!-- {marker}:begin"):text.index(f"<!-- {marker}:end")]


def test_the_pages_words_on_the_four_cells_are_its_tables() -> None:
    """The prose under the law-2 table: (replay gap, compensated residual) learned over untaught (a tenth to two
    fifths; a fifth to a little over half), the compensated residual 1.5-3.5 times the replay gap, better than the
    untaught on every part, the targets met on the TX200's wider cone only (its pyramid under 0.15 mm only)."""
    law2, law1 = _block("learn-table-law2"), _block("learn-table")
    pyramid = _row_numbers(law1, "cone-tx200 -> pyramid (never formed)")
    quoted("learning.md", "its pyramid comes\nunder 0.15 mm (", 1)[0].check(pyramid[8])  # a guard before the claims
    for variant in ("cone-kr210", "cone-irb6640"):
        for part in ("", " -> pyramid (never formed)", " -> cone 80 x 8 (never formed)"):
            n = _row_numbers(law2, variant + part)  # nominal rms, max; untaught gap mm, N, rms, max; learned ...
            assert 0.1 <= n[6] / n[2] <= 0.4 and 0.2 <= n[8] / n[4] <= 0.55, (variant + part, n)
            assert 1.5 < n[8] / n[6] < 3.5, (variant + part, n)  # the compensated residual 1.5-3.5 times the replay gap
    worse, learned = [], {}
    for law, block in ((1, law1), (2, law2)):
        for line in block.splitlines()[3:]:
            name = line.split("|")[1].strip()
            n = _row_numbers(block, name)
            if n[8] >= n[4]:
                worse.append((law, name))
            if name.startswith(("cone-kr210", "cone-irb6640")):
                learned[(law, name)] = n[8]
                cone = "pyramid" not in name
                assert n[8] > (0.10 if cone else 0.15) or n[8] > 0.25 * n[4], name  # not met on these two robots
    assert worse == [], worse
    assert min(learned, key=learned.get) == (1, "cone-kr210 -> cone 80 x 8 (never formed)"), learned
    n = _row_numbers(law1, "cone-tx200 -> cone 80 x 8 (never formed)")
    assert n[8] <= 0.10 and n[8] <= 0.25 * n[4], n
    assert 0.25 * pyramid[4] < pyramid[8] <= 0.15, pyramid  # under 0.15 mm, not under a quarter of the untaught's


def _robot_rows(marker: str) -> dict[tuple[str, str], tuple[float, float, float]]:
    """(cell, joint) -> (learned / plant, miss / spread, spread [%]) of a robot-learning table."""
    out = {}
    for line in _block(marker).splitlines()[3:]:
        r = [c.strip() for c in line.split("|")[1:-1]]
        out[(r[0], r[1])] = (float(r[5]), float(r[6]), float(r[3].split("(")[1].split(" %")[0]))
    return out


def test_the_pages_words_on_the_learned_robot_are_its_table() -> None:
    rows = _robot_rows("robot-learning")
    assert len(rows) == 16
    for (cell, joint), (ratio, miss, _spread) in rows.items():
        assert miss <= 2.0, (cell, joint, miss)  # within two stated spreads
        if joint != "j1":
            assert abs(ratio - 1.0) <= 0.0601, (cell, joint, ratio)  # 6 %, as the table rounds it
        elif cell in ("tx200:cone", "kr210:cone"):
            assert 1.16 <= ratio <= 1.2, (cell, joint, ratio)
    met = [k for k, (_, miss, spread) in rows.items() if miss <= 2.0 and spread <= 15]
    assert len(met) == 13 and {k for k in rows if k not in met} == {("tx200:groove", "j1"), ("kr210:cone", "j1"),
                                                                    ("irb6640:cone", "j1")}


def test_the_pages_words_on_the_robot_learned_from_two_runs_are_its_table() -> None:
    one, two = _robot_rows("robot-learning"), _robot_rows("robot-learning-two-runs")
    assert len(two) == 16
    pairs = [key for key in two if key[0].endswith("cone+pyramid")]
    assert len(pairs) == 12
    alone = [one[(robot + ":cone", "j1")][2] for robot in ("tx200", "kr210", "irb6640")]
    both = [two[(robot + ":cone+pyramid", "j1")][2] for robot in ("tx200", "kr210", "irb6640")]
    # the page's numbers first (a guard before the claims)
    said = quoted("learning.md", "but the spreads do not\nnarrow: joint 1's is", 4)
    for q, v in zip(said, (min(both), max(both), min(alone), max(alone)), strict=True):
        q.check(v)
    quoted("learning.md", "and the IRB 6640's joint 5's", 1)[0].check(two[("irb6640:cone+pyramid", "j5")][2])
    groove = quoted("learning.md", "The groove and the cone leave joint 1's at", 2)
    groove[0].check(two[("tx200:groove+cone", "j1")][2])
    groove[1].check(one[("tx200:groove", "j1")][2])
    for key in pairs:  # within 1.2 stated spreads
        assert two[key][1] <= 1.2, (key, two[key])
    met = [key for key in pairs if two[key][1] <= 2.0 and two[key][2] <= 15]
    assert len(met) == 9, met  # "met on 9 of the 12"


def test_the_pages_words_on_the_learned_robot_without_friction_are_its_table() -> None:
    on, off = _robot_rows("robot-learning"), _robot_rows("robot-learning-no-friction")
    assert on.keys() == off.keys()
    assert all(abs(on[k][0] - off[k][0]) <= 0.05 for k in on), (on, off)  # the same within 5 %


def test_the_pages_words_on_the_robot_learned_with_a_fast_ft_stream_are_its_table() -> None:
    slow, fast = _robot_rows("robot-learning"), _robot_rows("robot-learning-fast-ft")
    assert fast.keys() == slow.keys()
    cones = [key for key in fast if key[0].endswith(":cone")]
    assert len(cones) == 12
    misses = [fast[key][1] for key in cones]
    quoted("learning.md", "12 of 12, within", 1)[0].check(max(misses))
    alone = [slow[(robot + ":cone", "j1")][2] for robot in ("tx200", "kr210", "irb6640")]
    quick = [fast[(robot + ":cone", "j1")][2] for robot in ("tx200", "kr210", "irb6640")]
    said = quoted("learning.md", "joint 1's spread narrows from", 4)
    for q, v in zip(said, (min(alone), max(alone), min(quick), max(quick)), strict=True):
        q.check(v)
    groove = [*quoted("learning.md", "On the groove joint 1's narrows from", 2),
              *quoted("learning.md", "joint 5's widens from", 2)]
    for q, v in zip(groove, (slow[("tx200:groove", "j1")][2], fast[("tx200:groove", "j1")][2],
                             slow[("tx200:groove", "j5")][2], fast[("tx200:groove", "j5")][2]), strict=True):
        q.check(v)
    assert all(fast[key][2] <= 15 for key in cones) and max(misses) <= 2.0  # "12 of 12"
    met = [k for k, (_, miss, spread) in fast.items() if miss <= 2.0 and spread <= 15]
    assert {k for k in fast if k not in met} == {("tx200:groove", "j1"), ("tx200:groove", "j5")}  # "two joints out"
