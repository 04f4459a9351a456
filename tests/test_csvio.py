"""Validated CSV reading and atomic writing: every error names the file, the row and what was expected."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from twin.base.csvio import check_monotonic, read_header, read_table, write_table
from twin.base.jsonio import emit_json, read_json, write_json
from twin.errors import DataFileError, InputError


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_read_table_returns_columns_and_ignores_extras_comments_blank_lines(tmp_path: Path) -> None:
    path = _write(tmp_path / "a.csv", "# made by hand\nt_s,x_mm,extra\n0,1.5,9\n\n1,2.5,9\n")
    table = read_table(path, ("t_s", "x_mm"))
    assert set(table) == {"t_s", "x_mm"}
    np.testing.assert_array_equal(table["x_mm"], [1.5, 2.5])


@pytest.mark.parametrize(
    ("text", "match", "row"),
    [
        ("t_s,y_mm\n0,1\n", r"missing column\(s\) \['x_mm'\]", None),
        ("t_s,x_mm\n0,1\n1\n", "truncated", 2),
        ("t_s,x_mm\n0,abc\n", "holds 'abc', expected a number", 1),
        ("t_s,x_mm\n0,1\n1,nan\n", "expected a finite number", 2),
        ("", "file is empty", None),
    ],
)
def test_read_table_raises_naming_file_and_row(tmp_path: Path, text: str, match: str, row: int | None) -> None:
    path = _write(tmp_path / "bad.csv", text)
    with pytest.raises(DataFileError, match=match) as info:
        read_table(path, ("t_s", "x_mm"))
    assert info.value.path == path and info.value.row == row
    assert str(path) in str(info.value)


def test_the_plain_and_the_row_by_row_reading_give_the_same_numbers(tmp_path: Path) -> None:
    """A plain numeric CSV is parsed at once; one with a quoted field, spaces or a short comment row by row: the
    same values either way, bit for bit."""
    rng = np.random.default_rng(3)
    rows = [f"{t:.6f},{x:.4f}, {y:.9e} ,7" for t, x, y in rng.normal(size=(200, 3))]
    plain = read_table(_write(tmp_path / "plain.csv", "t_s,x_mm,y_mm,k\n" + "\n".join(rows) + "\n"),
                       ("t_s", "x_mm", "y_mm"))
    quoted = read_table(_write(tmp_path / "quoted.csv", 't_s,x_mm,y_mm,k\n' + "\n".join(rows[:-1])
                               + "\n" + rows[-1].replace(",7", ',"7"') + "\n"), ("t_s", "x_mm", "y_mm"))
    for name in ("t_s", "x_mm", "y_mm"):
        np.testing.assert_array_equal(plain[name], quoted[name])
        np.testing.assert_array_equal(plain[name], [float(r.split(",")[("t_s", "x_mm", "y_mm").index(name)])
                                                    for r in rows])


def test_read_table_raises_on_missing_file_and_too_few_rows(tmp_path: Path) -> None:
    with pytest.raises(DataFileError, match="file not found"):
        read_table(tmp_path / "none.csv", ("t_s",))
    with pytest.raises(DataFileError, match="at least 3"):
        read_table(_write(tmp_path / "short.csv", "t_s\n0\n1\n"), ("t_s",), min_rows=3)


def test_check_monotonic_names_the_first_bad_row(tmp_path: Path) -> None:
    check_monotonic(tmp_path / "f.csv", "t_s", np.array([0.0, 1.0, 2.0]))
    with pytest.raises(DataFileError, match="not strictly increasing") as info:
        check_monotonic(tmp_path / "f.csv", "t_s", np.array([0.0, 1.0, 1.0, 3.0]))
    assert info.value.row == 3  # the data row holding the repeated value
    check_monotonic(tmp_path / "f.csv", "t_s", np.array([0.0, 1.0, 1.0]), strict=False)


def test_read_header_skips_comments_and_blank_lines(tmp_path: Path) -> None:
    path = _write(tmp_path / "h.csv", "# made by hand\n\n t_s , x_m\n0,1\n")
    assert read_header(path) == ["t_s", "x_m"]
    with pytest.raises(DataFileError, match=r"file is empty; expected a header with columns \['t_s'\]"):
        read_header(_write(tmp_path / "e.csv", "# nothing\n"), ("t_s",))
    with pytest.raises(DataFileError, match="file not found"):
        read_header(tmp_path / "none.csv")


def test_write_table_is_atomic_formats_and_protects_inputs(tmp_path: Path) -> None:
    out = write_table(tmp_path / "sub" / "o.csv", {"k": np.array([1, 2]), "x_mm": [0.5, 1.25]}, comment="hello")
    assert out.read_text() == "# hello\nk,x_mm\n1,0.500000\n2,1.250000\n"
    assert not [p for p in out.parent.iterdir() if p.name.endswith(".tmp")]
    with pytest.raises(InputError, match="refusing to overwrite input"):
        write_table(out, {"k": [1]}, protect=[out])
    with pytest.raises(InputError, match="different lengths"):
        write_table(tmp_path / "p.csv", {"a": [1.0], "b": [1.0, 2.0]})


def test_json_is_strict_nan_becomes_null_and_stdout_target(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_json(tmp_path / "a.json", {"k": np.array([1.0, math.nan]), "p": tmp_path, "n": np.float64(2.0)})
    assert json.loads(path.read_text()) == {"k": [1.0, None], "p": str(tmp_path), "n": 2.0}
    assert read_json(path)["n"] == 2.0
    emit_json("-", {"v": np.int64(3)})
    assert json.loads(capsys.readouterr().out) == {"v": 3}
    emit_json(None, {"v": 1})  # no --json: nothing written
    with pytest.raises(DataFileError, match="not valid JSON"):
        read_json(_write(tmp_path / "bad.json", "{oops"))
    with pytest.raises(DataFileError, match="expected a JSON object"):
        read_json(_write(tmp_path / "list.json", "[1, 2]"))
