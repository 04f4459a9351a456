"""What a compensation used, written beside its command and carried into the runs made from it.

`tx200-twin compensate --out CMD.csv` writes `CMD.compensation.json` beside the command: the method, the FE
history's symmetry as declared and as its column names state it, and the forces the compensation assumed at
every command sample. `tx200-twin lab --commanded CMD.csv` copies it into the run's `meta.json` under
`compensation`; `check` compares those forces with the ones the run measured to name the cause of a gain
(`twin.analysis.gain_cause`). A command without it is still checked; the cause is then reported unknown.

Format `tx200-twin-compensation/2` (`FORMAT`): the per-sample arrays are packed (`pack_column`): times in whole
microseconds and forces in tenths of a newton (the precision format 1 rounded them to) as little-endian int64
first differences, zlib-compressed, base64 text: about a tenth of the size of format 1's JSON lists and read
back to the same numbers. Format 1 records (no `format` key, `t_s` and `f_used_n` as JSON lists) are still read.
"""

from __future__ import annotations

import base64
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.jsonio import read_json, write_json
from twin.errors import DataFileError

SYMMETRIES = ("half", "full")
#: The record's format (`to_json`); a record without the key is format 1 (JSON lists).
FORMAT = "tx200-twin-compensation/2"
#: Steps per unit of the packed columns: 1 µs for the times, 0.1 N for the forces (format 1's rounding, `np.round`).
T_STEPS_PER_S, F_STEPS_PER_N = 1_000_000, 10
#: Largest packed value in steps (integers a float64 holds exactly); a record beyond it is written as format 1.
PACK_LIMIT = 2.0**53


@dataclass(frozen=True)
class CompensationRecord:
    """The evidence a compensation leaves for `check`.

    Attributes:
        method: How the command was made (`formula`, `twin`).
        t_s: Times of the command samples [s], shape (n,).
        f_used_n: Force by the sheet on the tool the compensation assumed at each sample, sheet frame [N], (n, 3).
        history_symmetry: Symmetry the FE history was loaded with (`half` doubles its forces), or None.
        history_column_symmetry: Symmetry its column names state (`*_half_n` columns: `half`), or None.
        history_file: The history's file, or None.
        design_file: The design mesh the command was compensated to (`compensate --target-stl`: its part, not
            its path, is what was asked), or None.
    """

    method: str
    t_s: np.ndarray
    f_used_n: np.ndarray
    history_symmetry: str | None = None
    history_column_symmetry: str | None = None
    history_file: str | None = None
    design_file: str | None = None

    def __post_init__(self) -> None:
        t, f = np.asarray(self.t_s, dtype=float), np.asarray(self.f_used_n, dtype=float)
        if t.ndim != 1 or f.shape != (len(t), 3) or not (np.all(np.isfinite(t)) and np.all(np.isfinite(f))):
            raise DataFileError("compensation record", f"t_s {t.shape} and f_used_n {f.shape}: expected (n,) and "
                                "(n, 3), finite")
        for name in ("history_symmetry", "history_column_symmetry"):
            value = getattr(self, name)
            if value is not None and value not in SYMMETRIES:
                raise DataFileError("compensation record", f"{name} = {value!r}: expected one of {SYMMETRIES}")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "f_used_n", f)

    @property
    def symmetry_mismatch(self) -> bool:
        """The history's column names name a half-symmetric model and it was loaded as full (or the reverse)."""
        return (self.history_symmetry is not None and self.history_column_symmetry is not None
                and self.history_symmetry != self.history_column_symmetry)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready (format `FORMAT`, the arrays packed), forces rounded to 0.1 N, times to 1 µs."""
        head = {
            "method": self.method,
            "history": {"file": self.history_file, "symmetry": self.history_symmetry,
                        "column_symmetry": self.history_column_symmetry},
            **({} if self.design_file is None else {"design": self.design_file}),
        }
        t, f = np.rint(self.t_s * T_STEPS_PER_S), np.rint(self.f_used_n * F_STEPS_PER_N)
        if max(float(np.max(np.abs(t), initial=0.0)), float(np.max(np.abs(f), initial=0.0))) >= PACK_LIMIT:
            return {**head, "t_s": np.round(self.t_s, 6).tolist(), "f_used_n": np.round(self.f_used_n, 1).tolist()}
        return {"format": FORMAT, **head, "samples": len(t), "t_s": pack_column(t, T_STEPS_PER_S),
                "f_used_n": pack_column(f, F_STEPS_PER_N)}

    @classmethod
    def from_json(cls, data: Mapping[str, Any], source: str | Path) -> CompensationRecord:
        """Read one back (format 1 or `FORMAT`); DataFileError naming `source` when a key is missing or
        malformed."""
        try:
            history = data.get("history") or {}
            form = data.get("format")
            if form is None:
                t, f = np.asarray(data["t_s"], dtype=float), np.asarray(data["f_used_n"], dtype=float)
            elif form == FORMAT:
                n = int(data["samples"])
                t, f = unpack_column(data["t_s"], (n,)), unpack_column(data["f_used_n"], (n, 3))
            else:
                raise ValueError(f"format {form!r}, expected {FORMAT!r} (or none: format 1)")
            return cls(str(data["method"]), t, f, history.get("symmetry"), history.get("column_symmetry"),
                       history.get("file"), data.get("design"))
        except (KeyError, TypeError, ValueError, AttributeError, zlib.error) as exc:
            raise DataFileError(source, f"compensation record: {exc!r}; expected method, t_s, f_used_n and "
                                "history {file, symmetry, column_symmetry}") from None


def pack_column(steps: np.ndarray, per_unit: int) -> dict[str, Any]:
    """A column of whole steps, shape (n,) or (n, k), as `{"per_unit", "int64_diff_zlib_base64"}`: its first
    differences along the samples, little-endian int64, zlib, base64 (`unpack_column`).

    Args:
        steps: The values times `per_unit`, whole numbers of magnitude below `PACK_LIMIT`.
        per_unit: Steps per unit (per second, per newton).
    """
    ints = steps.astype("<i8")
    first_differences = np.diff(ints, axis=0, prepend=np.zeros((1, *ints.shape[1:]), dtype="<i8"))
    packed = base64.b64encode(zlib.compress(first_differences.tobytes())).decode("ascii")
    return {"per_unit": per_unit, "int64_diff_zlib_base64": packed}


def unpack_column(column: Mapping[str, Any], shape: tuple[int, ...]) -> np.ndarray:
    """The values [s or N] of a `pack_column` column of `shape` (steps / per_unit, as `np.round` divides);
    ValueError when its data has another size."""
    raw = zlib.decompress(base64.b64decode(column["int64_diff_zlib_base64"], validate=True))
    if len(raw) != 8 * int(np.prod(shape)):
        raise ValueError(f"a packed column of {len(raw)} bytes, expected int64 values of shape {shape}")
    steps = np.cumsum(np.frombuffer(raw, dtype="<i8").reshape(shape), axis=0)
    return steps / float(int(column["per_unit"]))


def record_path(command_csv: str | Path) -> Path:
    """Where the record of a command file lives: `CMD.csv` -> `CMD.compensation.json`."""
    path = Path(command_csv)
    return path.with_name(path.stem + ".compensation.json")


def write_record(command_csv: str | Path, record: CompensationRecord) -> Path:
    """Write the record beside its command; returns its path."""
    path = record_path(command_csv)
    write_json(path, record.to_json())
    return path


def read_record(command_csv: str | Path) -> CompensationRecord | None:
    """The record beside a command file, or None when there is none."""
    path = record_path(command_csv)
    return CompensationRecord.from_json(read_json(path), path) if path.is_file() else None


def run_record(meta: Mapping[str, Any], source: str | Path = "meta.json") -> CompensationRecord | None:
    """The record a run carries in its meta (`compensation`), or None."""
    data = meta.get("compensation")
    return None if data is None else CompensationRecord.from_json(data, source)
