"""Loading FE force histories: where the thesis's bug lived.

The thesis's FE model is half-symmetric (§2.2): the exported Fx and Fz must be doubled, Fy (the reaction
against the symmetry plane) discarded. The compensation script forgot the doubling, so only half the
deflection was compensated (§5.1). Here the symmetry must be declared by every caller, and column names that
contradict the declaration are refused.

Accepted files (CSV, header row, `#` comment lines allowed; see docs/forces.md):

* position: `x_mm`, `z_mm`, and `s_mm` (arc length, strictly increasing) or `t_s` (time, strictly increasing;
  then s is the arc length of the (x, z) polyline);
* half-symmetric model: `fx_half_n`, `fz_half_n` (and optionally `fy_sym_n`, ignored);
* full model: `fx_n`, `fz_n` (and optionally `fy_n`).

Lengths may be declared in metres instead (`x_m`, `z_m`, `s_m`; units by declaration, `twin.base.units`).
Metres under `_mm` names are caught by the point spacing, not by the size of the part (`check_point_spacing`:
every point within 0.5 mm of the origin, a median step below 0.01 mm); an FE export's `t_s` is often a
normalised step time, so its speed says nothing of the unit.

Forces are those EXERTED BY THE SHEET ON THE TOOL, in the sheet frame (Fz > 0 while forming).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from twin.base.csvio import check_monotonic
from twin.base.resources import data_file
from twin.base.units import SITable, check_point_spacing, read_si_table
from twin.errors import DataFileError, SymmetryError
from twin.process.toolpath.groove import ToolPath, label_passes

HALF_COLUMNS = ("fx_half_n", "fz_half_n")
FULL_COLUMNS = ("fx_n", "fz_n")
#: Arc length beyond the chord (relative, and [m]) that marks a turn between two samples (`ForceHistory.turns`).
TURN_SLACK, TURN_SLACK_M = 1e-3, 1e-6
_OPTIONAL = ("s_mm", "t_s", "fx_half_n", "fy_sym_n", "fz_half_n", "fx_n", "fy_n", "fz_n")

_BUG = (
    "the FE model is half-symmetric (thesis §2.2): its exported Fx and Fz are half the physical forces; "
    "the thesis's compensation forgot to double them and compensated only half the deflection (§5.1). "
    "Declare symmetry='half' for a half-model export (forces are doubled) or symmetry='full' for a full model"
)


@dataclass(frozen=True)
class ForceHistory:
    """A force history along the ideal path, physical forces.

    Attributes:
        s_m: Arc length along the path [m], shape (n,).
        p_sheet_m: Tool-tip position (x, 0, z) in the sheet frame [m], shape (n, 3).
        f_sheet_n: PHYSICAL force exerted by the sheet on the tool, sheet frame [N], shape (n, 3).
        symmetry: The declaration the file was loaded with, `half` or `full`.
        column_symmetry: The symmetry the file's column names state (`half` for `*_half_n` columns); it differs
            from `symmetry` only when the column check was skipped (`trust_columns=False`).
        source: The file read.
    """

    s_m: np.ndarray
    p_sheet_m: np.ndarray
    f_sheet_n: np.ndarray
    symmetry: str
    source: Path
    column_symmetry: str

    def turns(self) -> np.ndarray:
        """Where the path turned between two samples: the arc length between samples i and i+1 exceeds their
        chord (by 0.1 % and 1 µm), shape (n-1,) bool. An export sampled at equal arc length puts a zig-zag's
        reversals between samples; the sample just past one can still lie on the old side of the previous one.
        """
        chord = np.linalg.norm(np.diff(self.p_sheet_m, axis=0), axis=1)
        return np.diff(self.s_m) > chord * (1.0 + TURN_SLACK) + TURN_SLACK_M

    def pass_labels(self, deadband_m: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
        """(pass_index, direction) of the samples: `label_passes` of x, with a sample reached through a turn
        (`turns`) given to the pass that follows the turn.

        Args:
            deadband_m: Back-travel that declares a reversal (`label_passes`) [m].
        """
        pass_index, direction = label_passes(self.p_sheet_m[:, 0], deadband_m=deadband_m)
        turned = self.turns()
        for b in np.flatnonzero(np.diff(pass_index) != 0):  # b ends its pass
            if b >= 1 and turned[b - 1] and pass_index[b - 1] == pass_index[b]:
                pass_index[b], direction[b] = pass_index[b + 1], direction[b + 1]
        return pass_index, direction

    def to_path(self, feed_m_per_s: float = 2.0 / 60.0) -> ToolPath:
        """The history's sample points as a ToolPath (constant feed; passes from `pass_labels`).

        Args:
            feed_m_per_s: Feed used to turn arc length into time [m/s] (2 m/min, §1.2.3).
        """
        pass_index, direction = self.pass_labels()
        return ToolPath(
            t_s=(self.s_m - self.s_m[0]) / feed_m_per_s,
            p_sheet_m=self.p_sheet_m.copy(),
            pass_index=pass_index,
            direction=direction,
        )


def load_force_history(path: str | Path, *, symmetry: str, trust_columns: bool = True) -> ForceHistory:
    """Load an FE force history CSV and return PHYSICAL forces.

    Args:
        path: CSV file (column sets in the module docstring).
        symmetry: REQUIRED, no default: `half` (half-symmetric model; Fx, Fz doubled, Fy set to 0) or `full`.
        trust_columns: Keep True. False skips the check that the column names agree with `symmetry`; it exists
            only to reproduce the thesis's mistake (a half-model file declared `full`) in regression tests.

    Returns:
        The history, physical forces.

    Raises:
        SymmetryError: `symmetry` is None or not `half`/`full`, or the column names contradict it (half-named
            columns declared `full`, full-named declared `half`) while `trust_columns` is True.
        DataFileError: Missing file or columns, truncated or non-numeric rows, NaN, s or t not increasing.
        UnitsError: A length spelled both `_mm` and `_m`, or metres under `_mm` names (module docstring).
    """
    if symmetry not in ("half", "full"):
        raise SymmetryError(f"load_force_history({str(path)!r}): symmetry={symmetry!r} is not valid; {_BUG}")
    path = Path(path)
    table = read_si_table(path, ("x_mm", "z_mm"), optional=_OPTIONAL, min_rows=2)
    names = _force_columns(table, symmetry, trust_columns)
    has_half = names == HALF_COLUMNS
    x_m, z_m = _metres(table, "x_mm"), _metres(table, "z_mm")
    check_point_spacing(table, ("x_mm", "z_mm"))
    if "s_mm" in table:
        s_m = _metres(table, "s_mm")
        check_monotonic(path, table.typed["s_mm"], s_m)
        check_point_spacing(table, ("s_mm",))
    elif "t_s" in table:
        check_monotonic(path, "t_s", table.si("t_s"))
        if table.declared_mm(("x_mm", "z_mm")):  # the arc length summed in the file's millimetres
            x_mm, z_mm = table.as_read["x_mm"], table.as_read["z_mm"]
            s_m = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x_mm), np.diff(z_mm))))) / 1000.0
        else:
            s_m = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x_m), np.diff(z_m)))))
    else:
        found = sorted(table.typed.values())
        raise DataFileError(
            path, f"missing column 's_mm' or 's_m' (arc length) or 't_s' (time); found {found}"
        )
    scale = 2.0 if symmetry == "half" else 1.0
    f = np.zeros((len(x_m), 3))
    f[:, 0] = scale * table.si(names[0])
    f[:, 2] = scale * table.si(names[1])
    if symmetry == "full" and "fy_n" in table:
        f[:, 1] = table.si("fy_n")
    p = np.column_stack([x_m, np.zeros_like(x_m), z_m])
    return ForceHistory(
        s_m=s_m,
        p_sheet_m=p,
        f_sheet_n=f,
        symmetry=symmetry,
        source=path,
        column_symmetry="half" if has_half else "full",
    )


def _force_columns(table: SITable, symmetry: str, trust_columns: bool) -> tuple[str, str]:
    """The force columns of the file (`HALF_COLUMNS` or `FULL_COLUMNS`), checked against the declaration.

    Raises:
        DataFileError: Both sets or neither. SymmetryError: The names contradict `symmetry` (`trust_columns`).
    """
    path = table.path
    has_half = all(name in table for name in HALF_COLUMNS)
    has_full = all(name in table for name in FULL_COLUMNS)
    if has_half and has_full:
        raise DataFileError(
            path, f"holds both half-model {list(HALF_COLUMNS)} and full-model {list(FULL_COLUMNS)} columns"
        )
    if not (has_half or has_full):
        raise DataFileError(
            path,
            f"missing force columns: expected {list(HALF_COLUMNS)} (half-symmetric model) or "
            f"{list(FULL_COLUMNS)} (full model); found {sorted(table.typed.values())}",
        )
    names = HALF_COLUMNS if has_half else FULL_COLUMNS
    if trust_columns and (has_half != (symmetry == "half")):
        kind = "half-symmetric" if has_half else "full-model"
        raise SymmetryError(
            f"{path}: columns {list(names)} name a {kind} export but symmetry={symmetry!r} was declared; "
            f"{_BUG}. (trust_columns=False exists only to reproduce the thesis's mistake.)"
        )
    return names


def _metres(table: SITable, name: str) -> np.ndarray:
    """A length column in metres: millimetres as typed divided by 1000 (the arithmetic of every history this loader
    has read), metres as typed."""
    return table.as_read[name] / 1000.0 if table.declared_mm((name,)) else table.si(name)


#: The shipped history as last read, by (path, mtime, size): `default_force_history` parses the file once.
_SHIPPED: dict[tuple[str, int, int], ForceHistory] = {}


def default_force_history() -> ForceHistory:
    """The shipped stand-in history `twin/data/fe_force_history.csv`, loaded as half-symmetric (the file is read once
    per process while it is unchanged; every call gets arrays of its own, as a fresh load)."""
    path = data_file("fe_force_history.csv")
    stat = path.stat()
    key = (str(path), stat.st_mtime_ns, stat.st_size)
    if key not in _SHIPPED:
        _SHIPPED.clear()
        _SHIPPED[key] = load_force_history(path, symmetry="half")
    read = _SHIPPED[key]
    return replace(read, s_m=read.s_m.copy(), p_sheet_m=read.p_sheet_m.copy(), f_sheet_n=read.f_sheet_n.copy())
