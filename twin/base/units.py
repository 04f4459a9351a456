"""Length columns by declaration: a CSV states the unit of each length in the column's name, `_mm` or `_m`.

The file formats' canonical length columns are in millimetres (`x_mm`, `z_mm`, ...) and the writers write
them; a reader also accepts the same quantity declared in metres (`x_m`, `z_m`, ...). `read_si_table` finds
either spelling, remembers which one the file typed and returns SI values [m]; a file that spells one column
both ways is refused.

A declared unit is trusted. Two checks catch the classic slip, metres written under `_mm` names, and neither
depends on how big the part is (a 10 mm cone and a 1 m panel are read alike):

* a timed path (commanded, tracker), `check_path_speed`: the median tool speed over the moving samples must
  reach 0.05 mm/s (3 mm/min). Forming feeds run from ~100 mm/min (1.7 mm/s) to over 10 m/min, so a correct
  file clears the bar 30x over; metres read as mm move 1000x slower (the thesis's 2 m/min reads 0.033 mm/s)
  and are caught for feeds up to 3 m/min. A stream that does not move says nothing of its unit: not checked.
* untimed points (part profile, part scan, FE force history), `check_point_spacing`: refused when every
  coordinate lies within 0.5 mm of the origin AND the median nearest-neighbour step is below 0.01 mm. No cell
  measures or meshes a formed part a millimetre across every few micrometres (scanners, CMMs and FE meshes
  step 0.02-2 mm), while any part under ~1 m written in metres at a step under 10 mm looks exactly like that.

Both checks run only when every length column checked is declared `_mm` (a file declaring metres anywhere
has thought about its units). They raise `UnitsError` naming the file, the columns as typed, what was found
and what was expected, and suggest renaming the columns to `_m`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twin.base.csvio import read_header, read_table
from twin.errors import DataFileError, UnitsError

MM_SUFFIX, M_SUFFIX = "_mm", "_m"
MIN_PATH_SPEED_MM_S = (
    0.05  # slowest plausible median tool speed [mm/s]: 3 mm/min, 30x under the slowest ISF feed
)
LARGEST_LENGTH_M = 100.0  # no cell's path or part lies 100 m from its sheet origin: a larger value is a typo
MOVING_FRACTION = 0.1  # a sample moves when its speed exceeds this fraction of the 95th-percentile speed [-]
MAX_METRES_LIKE_COORDINATE_MM = 0.5  # every |coordinate| under this [mm] ...
MAX_METRES_LIKE_STEP_MM = 0.01  # ... with a median neighbour step under this [mm]: metres under `_mm` names


def is_length(name: str) -> bool:
    """Whether a canonical column name is a length (it ends in `_mm`)."""
    return name.endswith(MM_SUFFIX)


def metre_name(name: str) -> str:
    """The metre spelling of a canonical `_mm` column name (`x_mm` -> `x_m`)."""
    return name[: -len(MM_SUFFIX)] + M_SUFFIX


@dataclass(frozen=True)
class SITable:
    """A CSV's columns in SI units, with the name each column was typed under.

    Attributes:
        path: The file read.
        values: Canonical column name (`x_mm`, `t_s`, ...) -> values in SI: lengths [m], others as read.
        typed: Canonical column name -> the name as the file typed it (`x_mm` or `x_m` for a length).
        as_read: Canonical column name -> the values in the unit the file typed them in.
    """

    path: Path
    values: dict[str, np.ndarray]
    typed: dict[str, str]
    as_read: dict[str, np.ndarray]

    def __contains__(self, name: object) -> bool:
        return name in self.values

    def si(self, name: str) -> np.ndarray:
        """The values of canonical column `name` in SI units ([m] for a length)."""
        return self.values[name]

    def declared_mm(self, names: Sequence[str]) -> bool:
        """Whether every one of the (present) length columns `names` was typed in millimetres."""
        return all(self.typed[name].endswith(MM_SUFFIX) for name in names if name in self.typed)

    def quoted(self, names: Sequence[str]) -> str:
        """`column 'x_mm'` or `columns 'x_mm', 'z_mm'`: the names as typed, for a message."""
        typed = [f"'{self.typed[name]}'" for name in names if name in self.typed]
        return ("column " if len(typed) == 1 else "columns ") + ", ".join(typed)


def read_si_table(
    path: str | Path, required: Sequence[str], *, optional: Sequence[str] = (), min_rows: int = 1
) -> SITable:
    """Read a numeric CSV by canonical column names; a length (`x_mm`) may be declared in metres (`x_m`).

    Args:
        path: CSV file (header row; `#` comments and blank lines skipped; extra columns ignored).
        required: Canonical columns that must be present (lengths in either unit).
        optional: Canonical columns returned when present.
        min_rows: Minimum number of data rows.

    Returns:
        The columns in SI units and the names the file typed.

    Raises:
        UnitsError: A length column spelled both ways (`x_mm` and `x_m`).
        DataFileError: Missing file or columns, truncated or non-numeric rows, NaN/inf, too few rows.
    """
    path = Path(path)
    header = read_header(path, required)
    typed: dict[str, str] = {}
    missing: list[str] = []
    for name in (*required, *optional):
        spellings = [name, metre_name(name)] if is_length(name) else [name]
        found = [spelling for spelling in spellings if spelling in header]
        if len(found) > 1:
            raise UnitsError(
                path,
                f"declares one length twice, as '{found[0]}' [mm] and '{found[1]}' [m]: "
                "keep one of the two columns",
            )
        if found:
            typed[name] = found[0]
        elif name in required:
            missing.append(name)
    if missing:
        alternatives = [metre_name(name) for name in missing if is_length(name)]
        hint = f" (a length may be declared in metres instead: {alternatives})" if alternatives else ""
        raise DataFileError(
            path, f"missing column(s) {missing}{hint}; header has {header}, required {list(required)}"
        )
    raw = read_table(
        path,
        [typed[name] for name in required],
        optional=[typed[n] for n in optional if n in typed],
        min_rows=min_rows,
    )
    values = {
        name: raw[spelling] * (1e-3 if is_length(name) and spelling.endswith(MM_SUFFIX) else 1.0)
        for name, spelling in typed.items()
    }
    for name, spelling in typed.items():
        far = np.flatnonzero(np.abs(values[name]) > LARGEST_LENGTH_M)
        if is_length(name) and len(far):
            raise UnitsError(path, f"column '{spelling}' holds {raw[spelling][far[0]]:g}: expected a length within "
                                   f"{LARGEST_LENGTH_M:g} m of the sheet origin", int(far[0]) + 1)
    return SITable(path, values, typed, {name: raw[spelling] for name, spelling in typed.items()})


def moving_median_speed(t_s: np.ndarray, p: np.ndarray) -> float | None:
    """Median speed of a sampled path over its moving samples, in p's unit per second; None if it never moves.

    A sample interval moves when its speed exceeds `MOVING_FRACTION` of the 95th-percentile speed (of the
    largest speed if most of the path stands still): dwells and a tracker's noise while standing are left out,
    and the rule is a ratio, the same in any unit and for any size of path.

    Args:
        t_s: Strictly increasing times, shape (n,) [s].
        p: Positions, shape (n, k), any length unit.
    """
    dt = np.diff(t_s)
    keep = dt > 0
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1)[keep] / dt[keep]
    if speed.size == 0:
        return None
    reference = float(np.percentile(speed, 95)) or float(speed.max())
    if reference <= 0.0:
        return None
    return float(np.median(speed[speed > MOVING_FRACTION * reference]))


def check_path_speed(table: SITable, lengths: Sequence[str], *, time: str = "t_s") -> None:
    """UnitsError when a timed path declared in mm moves too slowly for a forming tool: metres were written.

    Args:
        table: The file's columns (`read_si_table`).
        lengths: Canonical position columns (`x_mm`, `y_mm`, `z_mm`).
        time: Canonical time column [s], strictly increasing.

    Raises:
        UnitsError: Every position column is declared `_mm` and the median speed over the moving samples is
            below `MIN_PATH_SPEED_MM_S` (module docstring).
    """
    if not table.declared_mm(lengths):
        return
    p_mm = np.column_stack([table.si(name) for name in lengths]) * 1e3
    speed_mm_s = moving_median_speed(table.si(time), p_mm)
    if speed_mm_s is None or speed_mm_s >= MIN_PATH_SPEED_MM_S:
        return
    raise UnitsError(
        table.path,
        f"{table.quoted(lengths)} move at a median {speed_mm_s:.3g} mm/s over the moving samples, "
        f"expected at least {MIN_PATH_SPEED_MM_S:g} mm/s (forming feeds are 1.7 mm/s and up; metres read "
        f"as mm move 1000x slower): are the values in metres? declare them so: rename the columns to "
        f"{', '.join(repr(metre_name(n)) for n in lengths)}",
    )


def check_point_spacing(table: SITable, lengths: Sequence[str]) -> None:
    """UnitsError when untimed points declared in mm are packed as no formed part is: metres were written.

    Args:
        table: The file's columns (`read_si_table`).
        lengths: Canonical coordinate columns of the points (e.g. `x_mm`, `z_mm`).

    Raises:
        UnitsError: Every coordinate column is declared `_mm`, every |coordinate| is below
            `MAX_METRES_LIKE_COORDINATE_MM` and the median nearest-neighbour step is below
            `MAX_METRES_LIKE_STEP_MM` (module docstring).
    """
    if not table.declared_mm(lengths):
        return
    points_mm = np.column_stack([table.si(name) for name in lengths]) * 1e3
    largest_mm = float(np.max(np.abs(points_mm))) if points_mm.size else 0.0
    if points_mm.shape[0] < 2 or largest_mm >= MAX_METRES_LIKE_COORDINATE_MM:
        return
    from scipy.spatial import cKDTree  # only for files that already look like metres

    distances, _ = cKDTree(points_mm).query(points_mm, k=2)
    step_mm = float(np.median(distances[:, 1]))
    if step_mm >= MAX_METRES_LIKE_STEP_MM:
        return
    raise UnitsError(
        table.path,
        f"{table.quoted(lengths)} hold points all within {largest_mm:.3g} mm of the origin, a median "
        f"{step_mm:.3g} mm apart; expected a formed part in mm (no part is measured within "
        f"{MAX_METRES_LIKE_COORDINATE_MM:g} mm every < {MAX_METRES_LIKE_STEP_MM:g} mm): "
        f"are the values in metres? declare them so: rename the columns to "
        f"{', '.join(repr(metre_name(n)) for n in lengths)}",
    )
