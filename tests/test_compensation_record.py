"""The compensation record's format: packed arrays that read back to format 1's rounded numbers, format 1 still
read, a damaged or unknown record refused naming its file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from twin.analysis.compensation_record import (
    FORMAT,
    CompensationRecord,
    read_record,
    record_path,
    run_record,
    write_record,
)
from twin.errors import DataFileError


@pytest.fixture
def record() -> CompensationRecord:
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.02, 4000))
    f = np.column_stack([rng.normal(0, 300, 4000), rng.normal(0, 50, 4000), rng.uniform(0, 2500, 4000)])
    return CompensationRecord("twin", t, f, "full", "half", "fe.csv")


def test_the_record_reads_back_as_format_1_rounded_it(record: CompensationRecord, tmp_path: Path) -> None:
    path = write_record(tmp_path / "cmd.csv", record)
    assert path == record_path(tmp_path / "cmd.csv")
    assert json.loads(path.read_text())["format"] == FORMAT
    back = read_record(tmp_path / "cmd.csv")
    assert back is not None
    np.testing.assert_array_equal(back.t_s, np.round(record.t_s, 6))  # exactly: 1 µs and 0.1 N, as format 1
    np.testing.assert_array_equal(back.f_used_n, np.round(record.f_used_n, 1))
    assert (back.method, back.history_symmetry, back.history_column_symmetry, back.history_file) == (
        "twin", "full", "half", "fe.csv")
    assert back.symmetry_mismatch
    format_1 = {"method": "twin", "t_s": np.round(record.t_s, 6).tolist(),
                "f_used_n": np.round(record.f_used_n, 1).tolist()}
    assert path.stat().st_size < len(json.dumps(format_1, indent=2)) / 4  # compact


def test_a_format_1_record_and_a_run_carrying_it_are_still_read(record: CompensationRecord, tmp_path: Path) -> None:
    old = {"method": "formula", "history": {"file": None, "symmetry": "half", "column_symmetry": None},
           "t_s": [0.0, 0.5, 1.0], "f_used_n": [[1.0, 0.0, 100.0], [2.0, 0.0, 200.5], [3.0, 0.0, 300.0]]}
    record_path(tmp_path / "old.csv").write_text(json.dumps(old))
    back = read_record(tmp_path / "old.csv")
    assert back is not None and back.method == "formula" and back.history_symmetry == "half"
    np.testing.assert_array_equal(back.f_used_n[:, 2], [100.0, 200.5, 300.0])
    carried = run_record({"compensation": json.loads(json.dumps(record.to_json()))})
    assert carried is not None
    np.testing.assert_array_equal(carried.f_used_n, np.round(record.f_used_n, 1))


def test_forces_beyond_the_packed_range_are_written_as_format_1() -> None:
    huge = CompensationRecord("twin", np.array([0.0, 1.0]), np.array([[0.0, 0.0, 1e18], [0.0, 0.0, 1.0]]))
    data = huge.to_json()
    assert "format" not in data and data["f_used_n"][0][2] == 1e18
    back = CompensationRecord.from_json(data, "x")
    assert back.f_used_n[0, 2] == 1e18


@pytest.mark.parametrize("damage", ["format", "samples", "data"])
def test_a_damaged_record_is_refused_naming_its_file(record: CompensationRecord, tmp_path: Path, damage: str) -> None:
    data = record.to_json()
    if damage == "format":
        data["format"] = "tx200-twin-compensation/9"
    elif damage == "samples":
        data["samples"] = 17
    else:
        data["f_used_n"]["int64_diff_zlib_base64"] = "bm90IHpsaWI="  # base64 of text, not zlib
    record_path(tmp_path / "cmd.csv").write_text(json.dumps(data))
    with pytest.raises(DataFileError, match=r"cmd\.compensation\.json"):
        read_record(tmp_path / "cmd.csv")
