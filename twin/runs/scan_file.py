"""Scans of a formed part from a laser or fringe scanner: point clouds in the scanner's frame, read to metres.

`read_scan(path, units)` reads by the file's suffix:

* `.ply`: a PLY point cloud or mesh, ASCII or binary (`trimesh.load`); its vertices are the points.
* `.xyz`, `.txt`, `.asc`, `.pts`: whitespace-separated columns x y z (extra columns, e.g. normals or colours,
  ignored; blank lines and `#` comments skipped); an error names the line.
* `.csv`: a header with `x_mm, y_mm, z_mm` (or `x_m, ...`: the file declares its unit, `twin.base.units`) or
  plain `x, y, z` in `units`; an error names the data row.

Units: a PLY, an XYZ and a plain CSV carry none: `units` (`mm`, the default, or `m`) says which. A scan whose
extent, read so, lies outside `MIN_SPAN_MM` .. `MAX_SPAN_MM` (a formed part spans millimetres to metres) is
refused as the wrong unit (`UnitsError`), as is a `units` that contradicts a CSV's declared columns. The points
are returned as read, in the scanner's frame (`twin.analysis.scan_registration` lays them on the design).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from twin.base.csvio import read_header, read_table
from twin.base.units import read_si_table
from twin.errors import DataFileError, UnitsError

UNITS = {"mm": 1e-3, "m": 1.0}
SUFFIXES = {".ply": "ply", ".xyz": "xyz", ".txt": "xyz", ".asc": "xyz", ".pts": "xyz", ".csv": "csv"}
MIN_SPAN_MM = 2.0  # a scanned part spans at least this [mm] ...
MAX_SPAN_MM = 5000.0  # ... and at most this [mm]
MIN_SCAN_POINTS = 3


def read_scan(path: str | Path, units: str | None = None) -> np.ndarray:
    """The points of a scan file, in the scanner's frame [m] (n, 3) (module docstring).

    Args:
        path: A `.ply`, `.xyz` (`.txt`, `.asc`, `.pts`) or `.csv` file.
        units: `mm` or `m`; None: millimetres, or the unit a CSV's columns declare.

    Raises:
        DataFileError: Missing file, unknown suffix, unreadable or non-numeric content, NaN/inf, missing columns,
            too few points (the file and the line, row or vertex named).
        UnitsError: `units` contradicts a CSV's columns, or the extent does not look like the unit.
    """
    path = Path(path)
    if units is not None and units not in UNITS:
        raise DataFileError(path, f"scan units {units!r}: expected one of {', '.join(UNITS)}")
    kind = SUFFIXES.get(path.suffix.lower())
    if kind is None:
        raise DataFileError(path, f"unknown scan format {path.suffix!r}: expected one of {', '.join(SUFFIXES)}")
    if not path.is_file():
        raise DataFileError(path, "no such scan file")
    if kind == "csv":
        points, unit = _read_csv(path, units)
    else:
        unit = units or "mm"
        points = (_read_ply(path) if kind == "ply" else _read_xyz(path)) * UNITS[unit]
    if len(points) < MIN_SCAN_POINTS:
        raise DataFileError(path, f"holds {len(points)} point(s), expected at least {MIN_SCAN_POINTS}")
    span_mm = 1e3 * float(np.max(np.ptp(points, axis=0)))
    if not MIN_SPAN_MM <= span_mm <= MAX_SPAN_MM:
        other = "m" if unit == "mm" else "mm"
        raise UnitsError(
            path,
            f"read in {unit} the scan spans {span_mm:.4g} mm, expected {MIN_SPAN_MM:g} to {MAX_SPAN_MM:g} mm for a "
            f"formed part: the wrong unit? (--scan-units {other})",
        )
    return points


def _read_csv(path: Path, units: str | None) -> tuple[np.ndarray, str]:
    header = read_header(path, ("x_mm", "y_mm", "z_mm"))
    if any(name in header for name in ("x_mm", "x_m", "y_mm", "y_m", "z_mm", "z_m")):
        table = read_si_table(path, ("x_mm", "y_mm", "z_mm"), min_rows=MIN_SCAN_POINTS)
        declared = "mm" if table.declared_mm(("x_mm", "y_mm", "z_mm")) else "m"
        if units is not None and units != declared:
            raise UnitsError(
                path, f"its {table.quoted(('x_mm', 'y_mm', 'z_mm'))} declare {declared}, but the scan units say "
                f"{units}: drop --scan-units or rename the columns"
            )
        return np.column_stack([table.si(name) for name in ("x_mm", "y_mm", "z_mm")]), declared
    if not all(name in header for name in ("x", "y", "z")):
        raise DataFileError(
            path, f"missing columns: expected x_mm, y_mm, z_mm (or x_m, y_m, z_m, or x, y, z in --scan-units); "
            f"header has {header}"
        )
    unit = units or "mm"
    plain = read_table(path, ("x", "y", "z"), min_rows=MIN_SCAN_POINTS)
    return np.column_stack([plain[name] for name in ("x", "y", "z")]) * UNITS[unit], unit


def _read_xyz(path: Path) -> np.ndarray:
    rows: list[list[float]] = []
    with path.open(encoding="utf-8-sig", errors="replace") as handle:
        for line_number, line in enumerate(handle, start=1):
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            fields = text.replace(",", " ").split()
            try:
                values = [float(field) for field in fields[:3]]
            except ValueError:
                raise DataFileError(
                    path, f"line {line_number} reads {text[:60]!r}: expected numbers x y z [+ extra columns]"
                ) from None
            if len(values) < 3:
                raise DataFileError(path, f"line {line_number} has {len(values)} number(s), expected x y z")
            if not all(math.isfinite(v) for v in values):
                raise DataFileError(path, f"line {line_number} holds {text[:60]!r}: expected finite numbers")
            rows.append(values)
    return np.asarray(rows, dtype=float).reshape(-1, 3)


def _read_ply(path: Path) -> np.ndarray:
    import trimesh  # scipy with it: only for a PLY file

    try:
        with np.errstate(all="ignore"):  # a non-finite vertex is refused below
            loaded = trimesh.load(path, file_type="ply", process=False)
    except Exception as exc:
        raise DataFileError(path, f"not a PLY file trimesh can read: {exc}") from None
    vertices = getattr(loaded, "vertices", None)
    if vertices is None:
        raise DataFileError(path, f"holds a {type(loaded).__name__}, expected a point cloud or a mesh")
    points = np.asarray(vertices, dtype=float).reshape(-1, 3)
    bad = np.flatnonzero(~np.all(np.isfinite(points), axis=1))
    if len(bad):
        raise DataFileError(path, f"vertex {bad[0]} (0-based) is {points[bad[0]].tolist()}: expected finite x y z")
    return points
