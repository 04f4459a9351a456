"""Reading a cell's raw exports: any delimiter, decimal commas, a UTF-8 BOM, a header row or column indices.

The file is only read, never modified. Every bad value raises a `MappingError` naming the raw file, its
1-based line and the column, with what was expected.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from twin.base.csvio import read_text
from twin.process.description import PLAUSIBLE
from twin.runs.mapping import MappingError, TableSpec


@dataclass(frozen=True)
class RawTable:
    """One raw export in SI units, still on its own clock and in its own frame.

    Attributes:
        t_s: Sample times on the stream's clock, strictly increasing [s] (None for a profile).
        values: Samples converted to SI, shape (n, k) [m or N].
        lines: 1-based file line of each sample, shape (n,).
    """

    t_s: np.ndarray | None
    values: np.ndarray
    lines: np.ndarray


def _column_index(spec: TableSpec, header: list[str] | None, column: str | int, key: str, line: int) -> int:
    if isinstance(column, int):
        return column
    assert header is not None
    names = [name.strip() for name in header]
    if column not in names:
        raise MappingError(spec.file, f"column {column!r} ({key}) not in the header {names}", line, key)
    return names.index(column)


def _number(spec: TableSpec, text: str, line: int, key: str) -> float:
    cleaned = text.strip()
    if spec.decimal == ",":
        if "." in cleaned:
            raise MappingError(spec.file, f"holds {text!r}, expected a number with decimal ','", line, key)
        cleaned = cleaned.replace(",", ".")
    try:
        value = float(cleaned)
    except ValueError:
        raise MappingError(
            spec.file, f"holds {text!r}, expected a number with decimal {spec.decimal!r}", line, key
        ) from None
    if not math.isfinite(value):
        raise MappingError(spec.file, f"holds {text!r}, expected a finite number", line, key)
    return value


class _Columns(NamedTuple):
    """Where a table's values are: the mapping keys of the value columns, their indices and the time's."""

    keys: tuple[str, ...]  # ("x", "y", "z"), ("x", "z") or ("fx", "fy", "fz")
    values: list[int]
    time: int | None


class _Samples(NamedTuple):
    """The data rows read, in file units: values, times (empty without a time column) and 1-based lines."""

    values: list[list[float]]
    times: list[float]
    lines: list[int]


def _header(spec: TableSpec, rows: list[list[str]]) -> tuple[list[str] | None, int]:
    """The header row (None without one) and the index of the first row after it.

    Raises:
        MappingError: `header_line` is past the end of the file.
    """
    header: list[str] | None = None
    first = 0
    if spec.header_line > 0:
        if spec.header_line > len(rows):
            raise MappingError(spec.file, f"has {len(rows)} lines, header_line is {spec.header_line}")
        header = rows[spec.header_line - 1]
        first = spec.header_line
    return header, first


def _column_indices(spec: TableSpec, header: list[str] | None) -> _Columns:
    """Resolve the mapping's value and time columns (header names or indices) to indices."""
    keys = {"commanded": ("x", "y", "z"), "tracker": ("x", "y", "z"), "profile": ("x", "z")}
    names = keys.get(spec.name, ("fx", "fy", "fz"))
    header_line = max(spec.header_line, 1)
    index = [_column_index(spec, header, c, k, header_line) for c, k in zip(spec.columns, names, strict=True)]
    t_index = (
        None
        if spec.time_column is None
        else _column_index(spec, header, spec.time_column, "time", header_line)
    )
    return _Columns(names, index, t_index)


def _read_samples(spec: TableSpec, rows: list[list[str]], first: int, columns: _Columns) -> _Samples:
    """Parse the data rows from `rows[first]` on, skipping blank and `#` lines.

    Raises:
        MappingError: A short row or a value that is not a number (file, line and column named).
    """
    index, names, t_index = columns.values, columns.keys, columns.time
    wanted = [*index, *([] if t_index is None else [t_index])]
    values: list[list[float]] = []
    times: list[float] = []
    lines: list[int] = []
    for number, fields in enumerate(rows[first:], start=first + 1):
        if not fields or not "".join(fields).strip() or fields[0].lstrip().startswith("#"):
            continue
        if len(fields) <= max(wanted):
            raise MappingError(
                spec.file, f"row has {len(fields)} field(s), expected at least {max(wanted) + 1}", number
            )
        values.append([_number(spec, fields[i], number, k) for i, k in zip(index, names, strict=True)])
        if t_index is not None:
            times.append(_number(spec, fields[t_index], number, "time"))
        lines.append(number)
    return _Samples(values, times, lines)


def _checked_times(spec: TableSpec, times: list[float], lines: np.ndarray) -> np.ndarray:
    """The sample times in seconds [s]; MappingError at the first that does not increase strictly."""
    t_s = np.asarray(times) * spec.time_scale
    bad = np.flatnonzero(np.diff(t_s) <= 0)
    if bad.size:
        k = int(bad[0])
        raise MappingError(
            spec.file,
            f"time goes from {times[k]!r} to {times[k + 1]!r}; expected strictly increasing",
            int(lines[k + 1]),
            "time",
        )
    return t_s


LARGEST_FORCE_N = PLAUSIBLE["force_n"].high  # 50 kN: ten times the largest ISF force a robot cell carries
LARGEST_POSITION_M = 10.0  # 10 m: beyond any cell's tracker volume or robot reach


def _check_plausible(spec: TableSpec, values: np.ndarray, lines: np.ndarray) -> None:
    """MappingError when the declared unit makes the values implausible (N declared as kN, mm as m)."""
    peak = np.abs(values).max(axis=1) if values.size else np.zeros(0)
    if not peak.size:
        return
    worst = int(np.argmax(peak))
    limit, unit, what = (LARGEST_FORCE_N, "N", "forces") if spec.name == "forces" else (LARGEST_POSITION_M, "m", "positions")
    if peak[worst] > limit:
        raise MappingError(
            spec.file, f"{what} reach {peak[worst]:.4g} {unit} with the declared `{spec.name}.unit` (scale "
            f"{spec.scale:g} {unit} per file unit); expected at most {limit:g} {unit}: is the unit right?",
            int(lines[worst]), f"{spec.name}.unit",
        )


def read_raw_table(spec: TableSpec) -> RawTable:
    """Read one raw export as described by its mapping table.

    Blank lines, lines starting with `#` and the lines before the header are skipped; every other line
    after the header is a sample.

    Args:
        spec: The mapping's description of the file.

    Returns:
        Times [s] and values [m or N] with the file line of each sample.

    Raises:
        MappingError: Missing column, short row, non-numeric value, fewer than 2 samples, or time not strictly
            increasing; names the file, the line and the column.
    """
    text = read_text(spec.file, f"the {spec.name} export", spec.encoding)
    rows = list(csv.reader(text.splitlines(), delimiter=spec.delimiter))
    header, first = _header(spec, rows)
    columns = _column_indices(spec, header)
    samples = _read_samples(spec, rows, first, columns)
    if len(samples.values) < 2:
        raise MappingError(spec.file, f"has {len(samples.values)} data row(s), expected at least 2")
    array = np.asarray(samples.values, dtype=float) * spec.scale
    line_array = np.asarray(samples.lines)
    _check_plausible(spec, array, line_array)
    if spec.name == "profile":
        return RawTable(None, array, line_array)
    if columns.time is None:
        assert spec.rate_hz is not None
        t_s = np.arange(len(samples.values)) / spec.rate_hz
    else:
        t_s = _checked_times(spec, samples.times, line_array)
    return RawTable(t_s, array, line_array)
