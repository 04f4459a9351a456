"""docs/dynamic-plant.md's plant-corners tables are what `experiments/plant_corners.py` measures: the sheet laws on
rigid paths and the plant's own joint stiffness (fast), the KR210 pyramid on the plant at two timesteps (slow)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "experiments"))

import plant_corners  # noqa: E402


def _block() -> str:
    page = (REPO / "docs" / "dynamic-plant.md").read_text(encoding="utf-8")
    return page.split("<!-- plant-corners:begin")[1].split("<!-- plant-corners:end")[0]


def _rows(prefix: str) -> list[list[str]]:
    """The table rows of the block whose first cell starts with `prefix`, as cells."""
    rows = []
    for line in _block().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0].startswith(prefix):
            rows.append(cells)
    return rows


def test_the_rigid_table_is_what_the_laws_give() -> None:
    documented = {(r[0], int(r[1])): r for r in _rows("KR210") + _rows("TX200") if len(r) == 6}
    measured = plant_corners.rigid_rows()
    assert len(documented) == len(measured) == 6
    for row in measured:
        doc = documented[(row["path"], row["law"])]
        assert row["max_jump_n"] == pytest.approx(float(doc[2]), abs=0.5), doc
        assert row["steady_n"] == pytest.approx(float(doc[3]), abs=1.0), doc
        assert row["jump_over_steady"] == pytest.approx(float(doc[4]), abs=0.002), doc
        assert row["mean_fz_n"] == pytest.approx(float(doc[5]), abs=1.0), doc


def test_the_stiffness_table_is_the_plants() -> None:
    measured = plant_corners.stiffness_rows()
    for name in plant_corners.ROBOTS:
        (doc,) = _rows(name)
        rows = [r for r in measured if r["robot"] == name]
        for cell, row in zip(doc[1:], rows, strict=True):
            prior, plant, ratio = (float(v) for v in re.findall(r"[\d.]+", cell))
            assert 1e-6 * row["prior_nm_per_rad"] == pytest.approx(prior, rel=5e-3)
            assert 1e-6 * row["plant_nm_per_rad"] == pytest.approx(plant, rel=5e-3)
            assert row["plant_nm_per_rad"] / row["prior_nm_per_rad"] == pytest.approx(ratio, abs=0.006)


@pytest.mark.slow
def test_the_plant_table_is_what_the_plant_gives() -> None:
    documented = {(int(r[0]), float(r[1])): r for r in _rows("1") + _rows("2") if len(r) == 8}
    measured = plant_corners.plant_rows()
    assert len(documented) == len(measured) == 4
    for row in measured:
        doc = documented[(row["law"], row["timestep_s"])]
        assert row["fast_rms_mm"] == pytest.approx(float(doc[2]), abs=0.003), doc
        assert 100 * row["contact_lost_frac"] == pytest.approx(float(doc[3].rstrip(" %")), abs=0.05), doc
        assert row["max_error_mm"] == pytest.approx(float(doc[5]), abs=0.05), doc
        median, peak = (float(v) for v in doc[6].split("/"))
        assert row["corner_peak_median_n"] == pytest.approx(median, rel=0.05, abs=3.0), doc
        assert row["corner_peak_max_n"] == pytest.approx(peak, rel=0.05, abs=3.0), doc


def test_the_pages_ratio_ranges_are_its_stiffness_table() -> None:
    """The page's prose ("the TX200's 0.74-1.38x its prior ... the KR 210's 0.35-1.38x and the IRB 6640's 0.45-0.75x")
    is the table's smallest and largest plant / prior ratio of each robot."""
    page = (REPO / "docs" / "dynamic-plant.md").read_text(encoding="utf-8")
    said = re.search(r"the TX200's ([\d.]+)-([\d.]+)x its prior.*?the KR 210's ([\d.]+)-([\d.]+)x and the IRB 6640's\s+"
                     r"([\d.]+)-([\d.]+)x", page, flags=re.DOTALL)
    assert said is not None
    for k, name in enumerate(("tx200", "kr210", "irb6640")):
        (row,) = _rows(name)
        ratios = [float(re.findall(r"\(([\d.]+)x\)", cell)[0]) for cell in row[1:]]
        assert (float(said.group(2 * k + 1)), float(said.group(2 * k + 2))) == pytest.approx(
            (min(ratios), max(ratios)), abs=0.006), name
