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
    """The prose under the law-2 table: (replay gap, compensated residual) learned over untaught, the targets not
    met, the IRB 6640's law-1 rows."""
    law2 = _block("learn-table-law2")
    for variant in ("cone-kr210", "cone-irb6640"):
        for part in ("", " -> pyramid (never formed)", " -> cone 80 x 8 (never formed)"):
            n = _row_numbers(law2, variant + part)  # nominal rms, max; untaught gap mm, N, rms, max; learned ...
            assert 0.25 <= n[6] / n[2] <= 0.5 and 0.35 <= n[8] / n[4] <= 0.75, (variant + part, n)
    n = _row_numbers(law2, "groove-neutral")
    assert n[6] < n[2] and n[8] >= 0.98 * n[4]
    law1 = _block("learn-table")
    learned = {}
    for block in (law1, law2):
        for line in block.splitlines():
            if line.startswith("| cone-kr210") or line.startswith("| cone-irb6640"):
                name = line.split("|")[1].strip()
                n = _row_numbers(block, name)
                cone = "pyramid" not in name
                assert n[8] > (0.10 if cone else 0.15) or n[8] > 0.25 * n[4], name  # no cell meets #48's targets
                learned[(block is law2, name)] = n[8]
    nearest = min(learned, key=learned.get)
    assert nearest == (False, "cone-kr210 -> cone 80 x 8 (never formed)"), learned
    for part in ("cone-irb6640", "cone-irb6640 -> pyramid (never formed)", "cone-irb6640 -> cone 80 x 8 (never formed)"):
        n = _row_numbers(law1, part)  # compensates worse; replays the cones better, an eighth of their force gap
        assert n[8] > n[4] and ("pyramid" in part or (n[6] < n[2] and 0.1 <= n[7] / n[3] <= 0.15)), (part, n)


def test_the_pages_words_on_the_learned_robot_are_its_table() -> None:
    rows = [line.split("|")[1:-1] for line in _block("robot-learning").splitlines()[3:]]
    joints = [(r[0].strip(), r[1].strip(), float(r[5]), float(r[6])) for r in rows]  # cell, joint, ratio, miss
    assert len(joints) == 16
    for cell, joint, ratio, miss in joints:
        if joint in ("j2", "j3"):
            assert miss <= 2.0, (cell, joint, miss)
        elif cell.endswith("cone") and (joint == "j5" or not cell.startswith("irb6640")):
            assert ratio > 1.1 and miss > 2.0, (cell, joint, ratio, miss)
    met = [j for j, r in zip(joints, rows, strict=True) if j[3] <= 2.0 and float(r[3].split("(")[1].split(" %")[0]) <= 15]
    assert len(met) == 9, met


def test_the_pages_words_on_the_learned_robot_without_friction_are_its_table() -> None:
    rows = [line.split("|")[1:-1] for line in _block("robot-learning-no-friction").splitlines()[3:]]
    joints = [(r[0].strip(), r[1].strip(), float(r[5]), float(r[6]), float(r[3].split("(")[1].split(" %")[0]))
              for r in rows]  # cell, joint, learned / plant, miss / spread, spread [%]
    assert len(joints) == 16
    for cell, joint, ratio, _miss, spread in joints:
        if joint in ("j2", "j3", "j5"):
            assert abs(ratio - 1.0) <= 0.0501, (cell, joint, ratio)  # 5 %, as the table rounds it
        if joint == "j1" and cell in ("tx200:cone", "kr210:cone"):
            assert ratio > 1.1, (cell, joint, ratio)
        assert spread <= 3 or cell == "tx200:groove", (cell, joint, spread)
    assert max(miss for *_, miss, _ in joints) > 5.0  # the misses are larger than the spread says
