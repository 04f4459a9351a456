"""Errors of the import mapping, and typed access to a parsed TOML file whose errors name the key's line.

`tomllib` gives no line numbers for keys; `key_line` finds the line of `a.b.key = ...` inside `[a.b]` by
scanning the text, so every message can say where to look.
"""

from __future__ import annotations

import difflib
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from twin.errors import DataFileError


class MappingError(DataFileError):
    """An import mapping or a raw file it describes is wrong: names the file, the line and the key.

    Attributes:
        path: The offending file (the mapping, or a raw export).
        row: 1-based line in that file, or None.
        key: The mapping key (`tracker.frame.points_sheet`) or column concerned, or None.
    """

    def __init__(
        self, path: str | Path, message: str, line: int | None = None, key: str | None = None
    ) -> None:
        self.path = Path(path)
        self.row = line
        self.key = key
        where = (
            f"{self.path}" + ("" if line is None else f", line {line}") + ("" if key is None else f", {key}")
        )
        Exception.__init__(self, f"{where}: {message}")


class RegistrationError(MappingError):
    """The tracker frame cannot be registered: too few, collinear or inconsistent reference points."""


class ClockError(MappingError):
    """A stream's clock cannot be aligned with the commanded path (no overlap, no onset, offset too large)."""


def key_line(text: str, dotted: str) -> int | None:
    """1-based line of `a.b.key = ...` in TOML text (inside table `[a.b]`), else of the table header."""
    *table_parts, key = dotted.split(".")
    table = ".".join(table_parts)
    current = ""
    header_line = None
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        header = re.fullmatch(r"\[\[?\s*([^\]]+?)\s*\]\]?\s*(#.*)?", line)
        if header:
            current = header.group(1).replace(" ", "")
            if current == dotted:
                return number
            if current == table:
                header_line = number
            continue
        if current == table and re.match(rf"{re.escape(key)}\s*=", line):
            return number
    return header_line


class TomlReader:
    """Typed access to parsed TOML with errors that name the mapping file, the key and its line.

    Args:
        path: The TOML file (for messages).
        text: Its text (to find key lines).
        data: The parsed document.
    """

    def __init__(self, path: Path, text: str, data: dict[str, Any]) -> None:
        self.path, self.text, self.data = path, text, data

    def error(self, dotted: str, message: str, cls: type[MappingError] = MappingError) -> MappingError:
        return cls(self.path, message, key_line(self.text, dotted), dotted)

    def check_keys(self, known: list[str]) -> None:
        """Refuse a key the schema does not have, naming the closest known one (a misspelling is not ignored)."""
        tables = {k.rsplit(".", 1)[0] for k in known} | {k.split(".", 1)[0] for k in known}
        for dotted in _leaves(self.data):
            if dotted in known:
                continue
            close = difflib.get_close_matches(dotted, known + sorted(tables), n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else "see docs/import-export.md for the schema"
            raise self.error(dotted, f"unknown key '{dotted}'; {hint}")

    def get(self, dotted: str, default: Any = ..., *, kind: type | tuple[type, ...] | None = None) -> Any:
        node: Any = self.data
        for part in dotted.split("."):
            if not isinstance(node, dict) or part not in node:
                if default is ...:
                    raise self.error(
                        dotted, f"missing key '{dotted}'; see docs/import-export.md for the schema"
                    )
                return default
            node = node[part]
        if kind is not None and (
            not isinstance(node, kind) or (isinstance(node, bool) and bool not in as_tuple(kind))
        ):
            names = " or ".join(k.__name__ for k in as_tuple(kind))
            raise self.error(dotted, f"is {node!r}, expected {names}")
        return node

    def number(self, dotted: str, default: Any = ..., *, positive: bool = False) -> float:
        value = self.get(dotted, default, kind=(int, float))
        if value is None:
            return math.nan
        if not math.isfinite(value) or (positive and value <= 0):
            raise self.error(
                dotted, f"is {value!r}, expected a finite{' positive' if positive else ''} number"
            )
        return float(value)

    def unit(self, dotted: str, table: dict[str, float], default: Any = ...) -> float:
        name = self.get(dotted, default, kind=str)
        if name not in table:
            raise self.error(dotted, f"unknown unit {name!r}; expected one of {sorted(table)}")
        return table[name]

    def matrix(self, dotted: str, shape: tuple[int, int] | None, default: Any = ...) -> np.ndarray | None:
        value = self.get(dotted, default)
        if value is None:
            return None
        try:
            array = np.array(value, dtype=float)
        except (TypeError, ValueError):
            array = np.array([])
        ok = array.ndim == 2 and (array.shape == shape if shape else array.shape[1] == 3)
        if not ok or not np.all(np.isfinite(array)):
            want = f"{shape[0]}x{shape[1]}" if shape else "k x 3"
            raise self.error(dotted, f"is {value!r}, expected a {want} array of finite numbers")
        return array

    def vector(self, dotted: str, default: Any = ...) -> np.ndarray:
        """A 3-vector of finite numbers."""
        value = self.get(dotted, default)
        try:
            array = np.array(value, dtype=float)
        except (TypeError, ValueError):
            array = np.array([])
        if array.shape != (3,) or not np.all(np.isfinite(array)):
            raise self.error(dotted, f"is {value!r}, expected 3 finite numbers [x, y, z]")
        return array


def _leaves(data: dict[str, Any], prefix: str = "") -> list[str]:
    """The dotted names of a TOML document's values (tables descended into)."""
    names: list[str] = []
    for key, value in data.items():
        dotted = f"{prefix}{key}"
        names += _leaves(value, f"{dotted}.") if isinstance(value, dict) else [dotted]
    return names


def as_tuple(kind: type | tuple[type, ...]) -> tuple[type, ...]:
    return kind if isinstance(kind, tuple) else (kind,)
