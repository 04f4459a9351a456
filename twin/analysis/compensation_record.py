"""What a compensation used, written beside its command and carried into the runs made from it.

`tx200-twin compensate --out CMD.csv` writes `CMD.compensation.json` beside the command: the method, the FE
history's symmetry as declared and as its column names state it, and the forces the compensation assumed at
every command sample. `tx200-twin lab --commanded CMD.csv` copies it into the run's `meta.json` under
`compensation`; `check` compares those forces with the ones the run measured to name the cause of a gain
(`twin.analysis.gain_cause`). A command without it is still checked; the cause is then reported unknown.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twin.base.jsonio import read_json, write_json
from twin.errors import DataFileError

SYMMETRIES = ("half", "full")


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
        """JSON-ready, forces rounded to 0.1 N, times to 1 µs."""
        return {
            "method": self.method,
            "history": {"file": self.history_file, "symmetry": self.history_symmetry,
                        "column_symmetry": self.history_column_symmetry},
            **({} if self.design_file is None else {"design": self.design_file}),
            "t_s": np.round(self.t_s, 6).tolist(),
            "f_used_n": np.round(self.f_used_n, 1).tolist(),
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any], source: str | Path) -> CompensationRecord:
        """Read one back; DataFileError naming `source` when a key is missing or malformed."""
        try:
            history = data.get("history") or {}
            return cls(str(data["method"]), np.asarray(data["t_s"], dtype=float),
                       np.asarray(data["f_used_n"], dtype=float), history.get("symmetry"),
                       history.get("column_symmetry"), history.get("file"), data.get("design"))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise DataFileError(source, f"compensation record: {exc!r}; expected method, t_s, f_used_n and "
                                "history {file, symmetry, column_symmetry}") from None


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
