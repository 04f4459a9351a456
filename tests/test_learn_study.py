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


@pytest.mark.slow
def test_the_pages_groove_row_is_the_one_a_fresh_run_writes(tmp_path: Path) -> None:
    row = study.variant_study(tmp_path / "groove-neutral", "groove-neutral")
    fresh = _row_numbers(study.table([row]), "groove-neutral")
    documented = _row_numbers(DOC.read_text(), "groove-neutral")
    assert len(fresh) == len(documented)
    for new, old in zip(fresh, documented, strict=True):
        assert new == pytest.approx(old, rel=0.05, abs=0.02), (fresh, documented)
    learned = row["learned"]["residual_rms_mm"]
    untaught = row["untaught"]["residual_rms_mm"]
    assert learned < 0.25 * untaught  # the learned twin's compensation removes most of what the untaught leaves
    quoted("learning.md", "the groove's learned compensation leaves", 1)[0].check(
        row["learned"]["away_from_stops_mm"], slack=3)
