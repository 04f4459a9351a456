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
@pytest.mark.xfail(strict=True, raises=AssertionError, reason="with the plant's own joint stiffness (issue #45) the "
                   "learned twin's groove compensation leaves 0.213 of the untaught twin's 0.680 mm (0.31x, 0.25x "
                   "asked), most of it at the reversals")
def test_the_learned_compensation_removes_most_of_what_the_untaught_leaves(groove_row: dict) -> None:
    assert groove_row["learned"]["residual_rms_mm"] < 0.25 * groove_row["untaught"]["residual_rms_mm"]
