"""Validated CSV reading and atomic writing, shared by every file format of the project (JSON: `jsonio`).

Readers name the file and the 1-based data row of the first bad value; writers write to a temporary
file beside the target and rename it, so a crash never leaves half a file, and they refuse to write
over a file the caller marked as an input.
"""

from __future__ import annotations

import csv
import io
import math
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from twin.base.outputs import check_outputs, plain_mode, write_failure
from twin.errors import DataFileError, InputError


def _content_lines(path: Path, required: Sequence[str], *, first_only: bool = False) -> list[str]:
    """The lines of a CSV that are neither blank nor `#` comments (only the header with `first_only`)."""
    lines: list[str] = []
    for line in read_text(path, "a CSV file").splitlines(keepends=True):
        if line.strip() and not line.lstrip().startswith("#"):
            lines.append(line)
            if first_only:
                break
    if not lines:
        raise DataFileError(path, f"file is empty; expected a header with columns {list(required)}")
    return lines


def read_bytes(path: str | Path, expected: str) -> bytes:
    """A file's bytes.

    Raises:
        DataFileError: Missing, a folder or unreadable (naming the file and `expected`).
    """
    path = Path(path)
    if path.is_dir():
        raise DataFileError(path, f"is a folder; expected {expected}")
    if not path.is_file():
        raise DataFileError(path, f"file not found; expected {expected}")
    try:
        return path.read_bytes()
    except OSError as exc:
        raise DataFileError(path, f"cannot read it ({exc.strerror or type(exc).__name__})") from None


def read_text(path: str | Path, expected: str = "a text file", encoding: str = "utf-8-sig") -> str:
    """A text file's contents (UTF-8 by default, a leading BOM dropped), every failure as a `DataFileError`.

    Args:
        path: The file.
        expected: What the file should be, for the messages (e.g. "a CSV file").
        encoding: A declared encoding (e.g. "latin-1").

    Raises:
        DataFileError: Missing, a folder, unreadable, or not in `encoding` (naming the line and the byte).
    """
    path = Path(path)
    data = read_bytes(path, expected)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        name = "UTF-8" if encoding.lower().replace("_", "-") in ("utf-8", "utf-8-sig", "utf8") else encoding
        raise DataFileError(
            path, f"line {line}: byte {data[exc.start:exc.start + 1]!r} is not {name}; expected {expected} in {name} "
            "(an import mapping declares another encoding with e.g. `encoding = \"latin-1\"`)"
        ) from None
    except LookupError:
        raise InputError(f"unknown encoding {encoding!r}; expected one Python knows, e.g. 'utf-8', 'latin-1'") from None


def read_header(path: str | Path, required: Sequence[str] = ()) -> list[str]:
    """The column names of a CSV's header row (stripped), reading no further than the header.

    Args:
        path: CSV file.
        required: Columns the caller expects, for the message of an empty file.

    Raises:
        DataFileError: Missing or empty file.
    """
    path = Path(path)
    return [name.strip() for name in next(csv.reader(_content_lines(path, required, first_only=True)))]


def read_table(
    path: str | Path,
    required: Sequence[str],
    *,
    optional: Sequence[str] = (),
    min_rows: int = 1,
) -> dict[str, np.ndarray]:
    """Read a numeric CSV with a header row and return the named columns as float arrays.

    Extra columns are ignored. Blank lines and lines starting with `#` are skipped. Columns are taken as
    named: a length column that may be declared in mm or m is read with `twin.base.units.read_si_table`.

    Args:
        path: CSV file.
        required: Columns that must be present.
        optional: Columns returned when present.
        min_rows: Minimum number of data rows.

    Returns:
        Column name -> 1-D float64 array (one entry per data row).

    Raises:
        DataFileError: Missing file, missing columns, a short (truncated) or non-numeric row, NaN/inf,
            or fewer than `min_rows` rows. The message names file, row and the expected columns.
    """
    path = Path(path)
    lines = _content_lines(path, required)
    reader = csv.reader(io.StringIO("".join(lines)))
    header = [name.strip() for name in next(reader)]
    missing = [name for name in required if name not in header]
    if missing:
        raise DataFileError(path, f"missing column(s) {missing}; header has {header}, required {list(required)}")
    wanted = [name for name in (*required, *optional) if name in header]
    index = {name: header.index(name) for name in wanted}
    fast = _plain_columns(lines[1:], len(header), [index[name] for name in wanted])
    if fast is not None:  # the plain numeric CSV every writer of ours and most lab software writes
        if fast.shape[0] < min_rows:
            raise DataFileError(path, f"has {fast.shape[0]} data row(s), expected at least {min_rows}")
        return {name: fast[:, k].copy() for k, name in enumerate(wanted)}
    values: dict[str, list[float]] = {name: [] for name in wanted}
    for row_number, fields in enumerate(reader, start=1):
        if len(fields) < len(header):
            raise DataFileError(
                path, f"row has {len(fields)} field(s), header has {len(header)} (truncated file?)", row_number
            )
        for name, column in index.items():
            text = fields[column].strip()
            try:
                value = float(text)
            except ValueError:
                raise DataFileError(path, f"column '{name}' holds {text!r}, expected a number", row_number) from None
            if not math.isfinite(value):
                raise DataFileError(path, f"column '{name}' holds {text!r}, expected a finite number", row_number)
            values[name].append(value)
    n_rows = len(values[wanted[0]]) if wanted else 0
    if n_rows < min_rows:
        raise DataFileError(path, f"has {n_rows} data row(s), expected at least {min_rows}")
    return {name: np.asarray(column, dtype=float) for name, column in values.items()}


def _plain_columns(rows: Sequence[str], width: int, columns: Sequence[int]) -> np.ndarray | None:
    """The columns of plain numeric rows parsed at once (numpy's C reader), (rows, columns); None where any row is
    not plain (a quote, fewer fields than the header, a field that is not a finite number): `read_table`'s row by
    row reading then names the row and the field."""
    if not columns or any('"' in row for row in rows) or any(row.count(",") < width - 1 for row in rows):
        return None
    try:
        table = np.loadtxt(rows, delimiter=",", usecols=columns, dtype=float, ndmin=2, comments=None)
    except ValueError:
        return None
    if table.shape != (len(rows), len(columns)) or not np.all(np.isfinite(table)):
        return None
    return table


def check_monotonic(path: str | Path, column: str, values: np.ndarray, *, strict: bool = True) -> None:
    """Raise if `values` is not increasing (strictly by default), naming the first bad row."""
    steps = np.diff(values)
    bad = np.flatnonzero(steps <= 0) if strict else np.flatnonzero(steps < 0)
    if bad.size:
        row = int(bad[0]) + 2
        kind = "strictly increasing" if strict else "non-decreasing"
        raise DataFileError(
            path, f"column '{column}' is not {kind}: {values[row - 2]!r} then {values[row - 1]!r}", row
        )


def write_text(path: str | Path, text: str, *, protect: Sequence[str | Path] = ()) -> Path:
    """Write a text file atomically (temporary sibling, then rename); never over a `protect`ed input."""
    _atomic_write_text(Path(path), text, protect)
    return Path(path)


def write_bytes(path: str | Path, data: bytes, *, protect: Sequence[str | Path] = ()) -> Path:
    """Write a binary file (e.g. an STL) atomically; never over a `protect`ed input."""
    _atomic_write_text(Path(path), data, protect)
    return Path(path)


def check_not_an_input(path: str | Path, protect: Sequence[str | Path]) -> None:
    """InputError when the output `path` is one of the `protect`ed input files (an input is never overwritten)."""
    try:
        check_outputs([("", other) for other in protect], [("", path)])
    except InputError as exc:
        raise InputError(f"refusing to overwrite input file {path} ({exc}); choose another output path") from None


def _atomic_write_text(path: Path, text: str | bytes, protect: Sequence[str | Path]) -> None:
    path = Path(path)
    check_not_an_input(path, protect)
    if path.is_dir():
        raise DataFileError(path, "is a folder; expected a file name to write")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise write_failure(path, exc) from None
    try:
        plain_mode(tmp_name)
        if isinstance(text, bytes):
            with os.fdopen(fd, "wb") as binary:
                binary.write(text)
        else:
            with os.fdopen(fd, "w", newline="") as handle:
                handle.write(text)
        os.replace(tmp_name, path)
    except BaseException as exc:
        if os.path.exists(tmp_name):
            os.unlink(tmp_name)
        if isinstance(exc, OSError):
            raise write_failure(path, exc) from None
        raise


def make_folder(path: str | Path) -> Path:
    """`mkdir -p` of an output folder, a failure as a `DataFileError` naming it."""
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_failure(path, exc) from None
    return Path(path)


def temporary_folder(target: str | Path) -> Path:
    """A new hidden sibling folder of `target` to write it in (then `swap_in_directory`); failures name `target`."""
    target = Path(target)
    make_folder(target.parent)
    try:
        return Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    except OSError as exc:
        raise write_failure(target, exc) from None


def swap_in_directory(tmp: Path, target: Path) -> None:
    """Put a fully written sibling folder `tmp` at `target` by renames: a reader never sees it half written.

    An existing `target` is first renamed aside into a temporary sibling and removed only once `tmp` stands in
    its place.
    """
    try:
        plain_mode(tmp, directory=True)
        if target.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".old", dir=target.parent))
            os.replace(target, old / "previous")
            os.replace(tmp, target)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, target)
    except OSError as exc:
        raise write_failure(target, exc) from None


def write_table(
    path: str | Path,
    columns: Mapping[str, np.ndarray | Sequence[float]],
    *,
    formats: Mapping[str, str] | None = None,
    protect: Sequence[str | Path] = (),
    comment: str | None = None,
) -> Path:
    """Write columns to a CSV atomically.

    Args:
        path: Output file.
        columns: Column name -> values; all the same length.
        formats: Optional per-column format spec (default `.6f`; integer columns use `d`).
        protect: Input files that must never be overwritten.
        comment: Optional first line, written after `# `.

    Returns:
        The path written.
    """
    names = list(columns)
    arrays = [np.asarray(columns[name]) for name in names]
    lengths = {len(a) for a in arrays}
    if len(lengths) > 1:
        raise InputError(f"columns have different lengths {dict(zip(names, map(len, arrays), strict=True))}")
    formats = dict(formats or {})
    specs = [
        formats.get(name, "d" if np.issubdtype(arr.dtype, np.integer) else ".6f")
        for name, arr in zip(names, arrays, strict=True)
    ]
    out = io.StringIO()
    if comment:
        out.write(f"# {comment}\n")
    out.write(",".join(names) + "\n")
    for row in zip(*arrays, strict=True):
        out.write(",".join(format(value, spec) for value, spec in zip(row, specs, strict=True)) + "\n")
    _atomic_write_text(Path(path), out.getvalue(), protect)
    return Path(path)
